//! Warping of uniform samples to disks, hemispheres, spheres, cones and triangles, plus the
//! power heuristic for MIS. Mappings follow Mitsuba 3 `include/mitsuba/core/warp.h`
//! (concentric disk: Shirley & Chiu 1997; triangle: the area-preserving sqrt mapping) and
//! Veach 1997 §9.2 (power heuristic, β = 2).
#ifndef COMMON_SAMPLING_GLSL
#define COMMON_SAMPLING_GLSL

#include "common/math.glsl"

/// Uniform point on the unit disk, low-distortion concentric mapping (Shirley & Chiu 1997).
vec2 sample_uniform_disk_concentric(vec2 u) {
    float x = 2.0 * u.x - 1.0;
    float y = 2.0 * u.y - 1.0;
    if (x == 0.0 && y == 0.0) return vec2(0.0);
    // Pick the larger coordinate as the radius so the division below is safe (|rp| <= |r|).
    bool quadrant_1_or_3 = abs(x) < abs(y);
    float r = quadrant_1_or_3 ? y : x;
    float rp = quadrant_1_or_3 ? x : y;
    float phi = 0.25 * PI * rp / r;
    if (quadrant_1_or_3) phi = 0.5 * PI - phi;
    return r * vec2(cos(phi), sin(phi));
}

/// Cosine-weighted direction on the +z hemisphere (Malley's method). z may be 0 on the rim.
vec3 sample_cosine_hemisphere(vec2 u) {
    vec2 p = sample_uniform_disk_concentric(u);
    float z = safe_sqrt(1.0 - dot(p, p));
    return vec3(p, z);
}

/// Density of `sample_cosine_hemisphere` w.r.t. solid angle: cos θ / π (0 below the horizon).
float pdf_cosine_hemisphere(vec3 w) { return w.z > 0.0 ? w.z * INV_PI : 0.0; }

/// Uniform direction on the unit sphere (density 1 / 4π).
vec3 sample_uniform_sphere(vec2 u) {
    float z = 1.0 - 2.0 * u.x;
    float r = safe_sqrt(1.0 - z * z);
    float phi = 2.0 * PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}

/// Uniform direction in the cone {w : w.z >= cos_max} around +z: 1 − cos θ = u.x (1 − cos_max).
/// sin θ is formed from 1 − cos θ, not from cos θ: for a narrow cone (cos_max near 1) cos θ has
/// only a few representable values and sqrt(1 − cos²θ) would put every sample on a few rings.
vec3 sample_uniform_cone(vec2 u, float cos_max) {
    float one_minus_cos = u.x * (1.0 - cos_max);
    float cos_theta = 1.0 - one_minus_cos;
    float sin_theta = safe_sqrt(one_minus_cos * (2.0 - one_minus_cos));
    float phi = 2.0 * PI * u.y;
    return vec3(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta);
}

/// Density of `sample_uniform_cone`: 1 / (2π (1 − cos_max)); FLT_MAX_C for a degenerate cone.
float pdf_uniform_cone(float cos_max) {
    float solid_angle_over_2pi = 1.0 - cos_max;
    return solid_angle_over_2pi > 0.0 ? INV_2PI / solid_angle_over_2pi : FLT_MAX_C;
}

/// Uniform point on a triangle as barycentrics (b1, b2) (b0 = 1 − b1 − b2); area-preserving
/// (Mitsuba `square_to_uniform_triangle`).
vec2 sample_uniform_triangle(vec2 u) {
    float t = safe_sqrt(1.0 - u.x);
    return vec2(1.0 - t, t * u.y);
}

/// Power heuristic (β = 2) for one sample from each of two strategies: f² / (f² + g²).
/// Written with the ratio of the smaller pdf to the larger so it cannot overflow; returns
/// 1 when f is +inf (a delta strategy) and g is finite, 0.5 when both are +inf, 0 when f <= 0
/// or is NaN (including both zero).
float power_heuristic(float f_pdf, float g_pdf) {
    if (!(f_pdf > 0.0)) return 0.0;
    if (!(g_pdf > 0.0)) return 1.0;
    if (isinf(f_pdf)) return isinf(g_pdf) ? 0.5 : 1.0;
    if (isinf(g_pdf)) return 0.0;
    if (f_pdf >= g_pdf) {
        float r = g_pdf / f_pdf;
        return 1.0 / (1.0 + r * r);
    }
    float r = f_pdf / g_pdf;
    float r2 = r * r;
    return r2 / (1.0 + r2);
}

#endif // COMMON_SAMPLING_GLSL
