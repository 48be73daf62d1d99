//! GGX (Trowbridge-Reitz) microfacet distribution with anisotropic roughness: the normal
//! distribution D, Smith's separable shadowing-masking G1 / G, visible-normal sampling and its
//! density. Formulas are Mitsuba 3's `include/mitsuba/render/microfacet.h`
//! (MicrofacetType::GGX, sample_visible = true); the sampling routine is Heitz 2018,
//! "Sampling the GGX Distribution of Visible Normals" (JCGT 7(4)), which draws exactly the
//! distribution Mitsuba's `sample_visible_11` draws.
//!
//! Conventions: local frame, z = macro-surface normal, alpha = (alpha_x along the tangent x,
//! alpha_y along the bitangent y). Smith G1 is rewritten as 2|z| / (|z| + sqrt(z² + (αx x)² +
//! (αy y)²)), which equals Mitsuba's 2 / (1 + sqrt(1 + α² tan²θ)) but never forms tan²θ, so it is
//! finite (0) at grazing angles instead of inf/inf.
//! The half vector, D and G1 use `precise` locals: without it the compiler may fuse multiply-adds
//! differently where bsdf_sample and bsdf_pdf inline them, so a sampled direction's pdf and
//! bsdf_pdf of the same direction could disagree (measured on lavapipe: for grazing wo and very
//! sharp lobes some sampled directions got bsdf_pdf = 0 or pdfs tens of percent apart; with
//! `precise` they agree to rounding).
#ifndef COMMON_BSDF_MICROFACET_GLSL
#define COMMON_BSDF_MICROFACET_GLSL

#include "common/math.glsl"

/// Below this alpha (in both directions) a GGX lobe is treated as perfectly specular.
#define GGX_ALPHA_DELTA 1e-3
/// Mitsuba clamps alphas to this in MicrofacetDistribution::configure().
#define GGX_ALPHA_MIN 1e-4

/// GGX normal distribution D(m) (Walter et al. 2007, anisotropic form). 0 for m.z <= 0.
float ggx_D(vec3 m, vec2 alpha) {
    precise float ex = m.x / alpha.x;
    precise float ey = m.y / alpha.y;
    precise float k = ex * ex + ey * ey + m.z * m.z;
    precise float denom = PI * alpha.x * alpha.y * k * k;
    if (!(denom > 0.0)) return 0.0;
    precise float result = 1.0 / denom;
    // Mitsuba: "prevent potential numerical issues in other stages of the model"
    return (result * m.z > 1e-20) ? result : 0.0;
}

/// Smith G1(v, m) / |cos θ_v|. Finite for every unit v (including v.z = 0, where it is 0 by the
/// orientation test). 0 when v sees the back of the microfacet.
float ggx_G1_over_cos(vec3 v, vec3 m, vec2 alpha) {
    // Ensure consistent orientation (can't see the back of the microfacet from the front)
    if (dot(v, m) * v.z <= 0.0) return 0.0;
    precise float xy_alpha_2 = sqr(alpha.x * v.x) + sqr(alpha.y * v.y);
    precise float denom = abs(v.z) + sqrt(v.z * v.z + xy_alpha_2);
    return denom > 0.0 ? 2.0 / denom : 0.0;
}

/// Smith's single-direction shadowing-masking function G1(v, m) for GGX, in [0, 1].
float ggx_G1(vec3 v, vec3 m, vec2 alpha) {
    return min(ggx_G1_over_cos(v, m, alpha) * abs(v.z), 1.0);
}

/// Smith's separable shadowing-masking G(wo, wi, m) = G1(wo, m) · G1(wi, m) (as Mitsuba).
float ggx_G(vec3 wo, vec3 wi, vec3 m, vec2 alpha) {
    return ggx_G1(wo, m, alpha) * ggx_G1(wi, m, alpha);
}

/// Sample a microfacet normal from the distribution of normals visible from `wi`
/// (Heitz 2018, Listing 1). `wi` must be a unit vector with wi.z >= 0. `u` in [0,1)².
vec3 ggx_sample_vndf(vec3 wi, vec2 alpha, vec2 u) {
    // Section 3.2: transform the view direction to the hemisphere configuration
    vec3 vh = normalize(vec3(alpha.x * wi.x, alpha.y * wi.y, max(wi.z, 0.0)));
    // Section 4.1: orthonormal basis (with special case if the cross product is zero)
    float lensq = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = lensq > 1e-20 ? vec3(-vh.y, vh.x, 0.0) * inversesqrt(lensq) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(vh, t1);
    // Section 4.2: parameterization of the projected area
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    float p1 = r * cos(phi);
    float p2 = r * sin(phi);
    float s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * safe_sqrt(1.0 - p1 * p1) + s * p2;
    // Section 4.3: reprojection onto the hemisphere
    vec3 nh = p1 * t1 + p2 * t2 + safe_sqrt(1.0 - p1 * p1 - p2 * p2) * vh;
    // Section 3.4: transform the normal back to the ellipsoid configuration
    vec3 ne = vec3(alpha.x * nh.x, alpha.y * nh.y, max(nh.z, 0.0));
    float len2 = dot(ne, ne);
    return len2 > 0.0 ? ne * inversesqrt(len2) : vec3(0.0, 0.0, 1.0);
}

/// Density of `ggx_sample_vndf` (w.r.t. the solid angle of m):
/// D(m) · G1(wi, m) · |wi·m| / cos θ_i (Mitsuba `MicrofacetDistribution::pdf`). wi.z >= 0.
float ggx_pdf_vndf(vec3 wi, vec3 m, vec2 alpha) {
    return ggx_D(m, alpha) * ggx_G1_over_cos(wi, m, alpha) * abs(dot(wi, m));
}

/// Mirror `v` about the (unit) microfacet normal m: 2(v·m)m − v.
vec3 mf_reflect(vec3 v, vec3 m) { return 2.0 * dot(v, m) * m - v; }

/// Refract `v` through the (unit) microfacet normal m (Mitsuba `refract(wi, m, cos_theta_t,
/// eta_ti)`); cos_theta_t and eta_ti come from `fresnel_dielectric`.
vec3 mf_refract(vec3 v, vec3 m, float cos_theta_t, float eta_ti) {
    return m * (dot(v, m) * eta_ti + cos_theta_t) - v * eta_ti;
}

/// Generalised half vector for the pair (wo, wi): normalize(wo + wi·eta_wi), flipped to the
/// upper hemisphere (Mitsuba `mulsign(m, cos_theta(m))`). false when it is undefined.
bool mf_half_vector(vec3 wo, vec3 wi, float eta_wi, out vec3 m) {
    precise vec3 h = wo + wi * eta_wi;
    precise float len2 = dot(h, h);
    if (!(len2 > 1e-12)) {
        m = vec3(0.0, 0.0, 1.0);
        return false;
    }
    m = h * inversesqrt(len2);
    if (m.z < 0.0) m = -m;
    return true;
}

#endif // COMMON_BSDF_MICROFACET_GLSL
