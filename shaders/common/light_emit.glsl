// Lights as the start of light subpaths (bidirectional methods, light tracing): sampling an
// emitted ray and the densities of doing so, after pbrt-v3's Light::Sample_Le / Pdf_Le.
//  - triangles and spheres: a point uniform by area, a cosine-weighted direction about the front
//    normal (emission is front-side only, as Mitsuba's `area`);
//  - point: uniform direction; spot: uniform in the cutoff cone, radiance scaled by the falloff;
//  - directional and environment ("infinite"): the direction (delta, or the environment's own
//    distribution) and a point on the disk of the scene's bounding sphere facing it, moved back
//    by the radius, so every ray that can reach the scene is covered (pbrt's approach).
// The pick probability (∝ power, `pick_light`) is returned separately: subpath densities keep
// position and direction apart (pbrt: pdfPos · lightPdf for the first vertex, pdfDir for the
// second). NEE's sample_light (lights.glsl) stays the one for connections to a fresh light point.
#ifndef COMMON_LIGHT_EMIT_GLSL
#define COMMON_LIGHT_EMIT_GLSL
#include "common/lights.glsl"
#include "common/surface.glsl"

struct LightEmit {
    vec3 p;        // ray origin: on the light, or on the scene's bounding disk (infinite lights)
    vec3 p_err;    // rounding-error bound of p (area lights; 0 otherwise)
    vec3 n;        // front normal at p (area lights); 0 for points and infinite lights
    vec3 d;        // direction the light travels
    vec3 Le;       // radiance (area, environment), intensity (point, spot) or irradiance (directional)
    float pdf_pos; // area density of p, pick excluded (1 for point/spot, 1/(πR²) for infinite lights)
    float pdf_dir; // solid-angle density of d (1 for the delta direction of a directional light)
    float pick;    // probability of having chosen this light
    uint li;
    bool infinite; // directional or environment
    bool delta;    // point, spot or directional
};

// True for the lights that sit at infinity (their "position" is a direction).
bool light_is_infinite(uint kind) {
    return kind == LIGHT_DIRECTIONAL || light_is_env(kind);
}
bool light_is_delta(uint kind) {
    return kind == LIGHT_POINT || kind == LIGHT_SPOT || kind == LIGHT_DIRECTIONAL;
}

// Surface area of an area light (triangle: stored; sphere: 4πr²); 0 for the others.
float light_area(GpuLight l) {
    if (l.kind == LIGHT_TRIANGLE) return l.p0.w;
    if (light_is_sphere(l.kind)) return 4.0 * PI * l.p0.w * l.p0.w;
    return 0.0;
}

// Front (emitting) normal of area light l at its point pl.
vec3 light_front_normal(GpuLight l, vec3 pl) {
    if (l.kind == LIGHT_TRIANGLE) return triangle_light_normal(l);
    vec3 n = normalize(pl - l.p0.xyz);
    return l.p1.x > 0.5 ? -n : n;
}

// Solid-angle density with which light li emits direction w from its point pl (front normal nl),
// pick excluded (pbrt's Pdf_Le pdfDir). 0 for the delta direction of directional lights.
float light_pdf_dir(uint li, vec3 nl, vec3 w) {
    GpuLight l = lights[li];
    if (l.kind == LIGHT_TRIANGLE || light_is_sphere(l.kind)) return max(dot(nl, w), 0.0) * INV_PI;
    if (l.kind == LIGHT_POINT) return INV_4PI;
    if (l.kind == LIGHT_SPOT) return dot(w, l.p1.xyz) >= l.p2.x ? pdf_uniform_cone(l.p2.x) : 0.0;
    return 0.0;
}

// Area density (pick excluded) of the light's point: 1/area; 1 for delta positions; 1/(πR²) on
// the bounding disk for infinite lights.
float light_pdf_pos(uint li) {
    GpuLight l = lights[li];
    if (l.kind == LIGHT_TRIANGLE || light_is_sphere(l.kind)) {
        float a = light_area(l);
        return a > 0.0 ? 1.0 / a : 0.0;
    }
    if (light_is_infinite(l.kind)) return 1.0 / (PI * sqr(g.scene_sphere.w));
    return 1.0;
}

// A point on the disk of the bounding sphere perpendicular to d, moved back by the radius.
vec3 infinite_light_origin(vec3 d, vec2 u) {
    vec3 t, b;
    make_frame(d, t, b);
    vec2 cd = sample_uniform_disk_concentric(u);
    float r = g.scene_sphere.w;
    return g.scene_sphere.xyz + r * (cd.x * t + cd.y * b) - r * d;
}

// Samples an emitted ray. u0: (pick, position 2D, direction x); u1: (direction y, …).
bool sample_light_emission(vec4 u0, vec4 u1, out LightEmit e) {
    e.p = vec3(0.0); e.p_err = vec3(0.0); e.n = vec3(0.0); e.d = vec3(0.0, 0.0, 1.0); e.Le = vec3(0.0);
    e.pdf_pos = 0.0; e.pdf_dir = 0.0; e.pick = 0.0; e.li = NONE; e.infinite = false; e.delta = false;
    if (g.film.w == 0u) return false;
    // Step 1: pick a light ∝ power.
    uint li = pick_light(u0.x);
    GpuLight l = lights[li];
    e.li = li;
    e.pick = l.pick_pdf;
    e.infinite = light_is_infinite(l.kind);
    e.delta = light_is_delta(l.kind);
    vec2 u_pos = u0.yz, u_dir = vec2(u0.w, u1.x);
    // Step 2: the origin and direction, by light kind.
    if (l.kind == LIGHT_TRIANGLE || light_is_sphere(l.kind)) {
        vec2 bary = vec2(0.0);
        if (l.kind == LIGHT_TRIANGLE) {
            bary = sample_uniform_triangle(u_pos);
            float b0 = 1.0 - bary.x - bary.y;
            e.p = b0 * l.p0.xyz + bary.x * l.p1.xyz + bary.y * l.p2.xyz;
            e.p_err = gamma_n(7.0) * (abs(b0 * l.p0.xyz) + abs(bary.x * l.p1.xyz) + abs(bary.y * l.p2.xyz));
        } else {
            vec3 local = l.p0.w * sample_uniform_sphere(u_pos);
            e.p = l.p0.xyz + local;
            e.p_err = gamma_n(5.0) * (abs(l.p0.xyz) + abs(local));
        }
        // A point in a hole of the surface's alpha mask emits nothing (common/alpha.glsl).
        if (emitter_cut(l, e.p, bary)) return false;
        e.n = light_front_normal(l, e.p);
        vec3 t, b;
        make_frame(e.n, t, b);
        vec3 w = sample_cosine_hemisphere(u_dir);
        if (!(w.z > 0.0)) return false;
        e.d = from_local(w, t, b, e.n);
        e.pdf_pos = light_pdf_pos(li);
        e.pdf_dir = w.z * INV_PI;
        e.Le = l.radiance.rgb;
    }
#ifdef HAS_DELTA_LIGHTS
    else if (l.kind == LIGHT_POINT) {
        e.p = l.p0.xyz;
        e.d = sample_uniform_sphere(u_dir);
        e.pdf_pos = 1.0;
        e.pdf_dir = INV_4PI;
        e.Le = l.radiance.rgb;
    } else if (l.kind == LIGHT_SPOT) {
        vec3 axis = l.p1.xyz, t, b;
        make_frame(axis, t, b);
        e.p = l.p0.xyz;
        e.d = from_local(sample_uniform_cone(u_dir, l.p2.x), t, b, axis);
        e.pdf_pos = 1.0;
        e.pdf_dir = pdf_uniform_cone(l.p2.x);
        e.Le = l.radiance.rgb * spot_falloff(l, dot(e.d, axis));
    } else if (l.kind == LIGHT_DIRECTIONAL) {
        e.d = l.p0.xyz;
        e.p = infinite_light_origin(e.d, u_pos);
        e.pdf_pos = light_pdf_pos(li);
        e.pdf_dir = 1.0;
        e.Le = l.radiance.rgb;
    }
#endif
    else if (light_is_env(l.kind)) {
        // The direction towards the environment, then the ray travelling away from it.
        vec3 wi;
        float pdf_dir;
#ifdef HAS_ENV_MAP
        if (l.kind == LIGHT_ENV_MAP) {
            wi = env_map_sample(u_dir, pdf_dir);
        } else
#endif
        {
            wi = sample_uniform_sphere(u_dir);
            pdf_dir = INV_4PI;
        }
        e.d = -wi;
        e.p = infinite_light_origin(e.d, u_pos);
        e.pdf_pos = light_pdf_pos(li);
        e.pdf_dir = pdf_dir;
        e.Le = env_eval(wi);
    }
    return e.pick > 0.0 && e.pdf_pos > 0.0 && e.pdf_dir > 0.0 && any(greaterThan(e.Le, vec3(0.0)));
}

#endif
