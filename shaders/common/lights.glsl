// Light sampling for next-event estimation: pick a light with probability proportional to its
// power (alias table, Walker 1977 / Vose 1991), or with the light BVH from the shading point
// (LIGHT_BVH: render.light_sampler "bvh", common/light_bvh.glsl; the session defines it only
// for integrators whose registry entry takes it, renderer/src/integrators/registry.rs; bdpt's
// light subpaths still start ∝ power, shaders/common/light_emit.glsl), then sample it:
// triangles uniformly by area, spheres by the solid angle they subtend (pbrt-v4's cone
// sampling, with its small-angle series so tiny distant spheres stay accurate),
// point/spot/directional lights as delta lights, and the environment by its map distribution
// (or uniformly for a constant one). All pdfs are solid angle at the reference point and
// include the pick probability, so the MIS weights of NEE and BSDF sampling use the same pdf
// for the same path.
#ifndef COMMON_LIGHTS_GLSL
#define COMMON_LIGHTS_GLSL
#include "common/bindings.glsl"
#include "common/sampling.glsl"
#include "common/env.glsl"
#include "common/alpha.glsl"

#ifdef LIGHT_BVH
#define LIGHT_SAMPLER_BVH 1
#include "common/light_bvh.glsl"
#endif

struct LightSample {
    vec3 wi;      // direction from the reference point towards the light
    float dist;   // distance to the sampled point (+inf for directional/environment)
    vec3 p;       // sampled point (for the shadow ray), when dist is finite
    vec3 L;       // radiance (area/env) or intensity / dist² (point/spot) or irradiance (directional)
    float pdf;    // solid-angle pdf × pick probability; the pick probability alone for delta lights
    bool delta;
    uint li;      // the light picked
};

uint pick_light(float u) {
    uint n = g.film.w;
    float x = u * float(n);
    uint i = min(uint(x), n - 1u);
    GpuAlias a = light_alias[i];
    return (x - float(i)) < a.prob ? i : a.alias;
}

// The probability that NEE at p_ref (shading normal n_ref, or 0) picks light li.
float light_pick_pmf(uint li, vec3 p_ref, vec3 n_ref) {
#ifdef LIGHT_SAMPLER_BVH
    return light_bvh_pmf(li, p_ref, n_ref);
#else
    return lights[li].pick_pdf;
#endif
}

// Spot falloff, Mitsuba 3's: 1 inside the beam, linear in angle to 0 at the cutoff.
float spot_falloff(GpuLight l, float cos_theta) {
    if (cos_theta <= l.p2.x) return 0.0;
    if (cos_theta >= l.p2.y) return 1.0;
    return clamp((l.p2.z - safe_acos(cos_theta)) / (l.p2.z - l.p2.w), 0.0, 1.0);
}

// Whether sphere light l is sampled by area from p_ref (else by the cone it subtends): from
// inside, and always when it emits inward (flipped normals): then only points inside see its
// front, and a point on the sphere itself (a shading point on the emitter, which rounding may
// put just outside) must reach the far side, not the near intersection the cone gives.
bool sphere_sampled_by_area(GpuLight l, vec3 p_ref) {
    vec3 dc = l.p0.xyz - p_ref;
    return l.p1.x > 0.5 || dot(dc, dc) <= l.p0.w * l.p0.w;
}

// The normal at a point of the sphere (centre c, radius r) sampled as seen from p_ref: uniformly
// over the sphere's area when `by_area`, else uniformly in the cone of directions the sphere
// subtends (pbrt-v4 SampleSphere; p_ref must be outside), with a series expansion for small
// cones that avoids 1 − cos cancellation. The point is c + r · normal.
vec3 sample_sphere_seen_from(vec3 c, float r, vec3 p_ref, vec2 u, bool by_area) {
    vec3 dc = c - p_ref;
    float d2 = dot(dc, dc);
    if (by_area || d2 <= r * r) return sample_uniform_sphere(u);
    float dcl = sqrt(d2);
    float sin_max = r / dcl, sin2_max = sin_max * sin_max;
    float cos_max = safe_sqrt(1.0 - sin2_max);
    float cos_t = (cos_max - 1.0) * u.x + 1.0;
    float sin2_t = 1.0 - cos_t * cos_t;
    if (sin2_max < 0.00068523) {
        sin2_t = sin2_max * u.x;
        cos_t = sqrt(1.0 - sin2_t);
    }
    float cos_a = sin2_t / sin_max + cos_t * safe_sqrt(1.0 - sin2_t / sin2_max);
    float sin_a = safe_sqrt(1.0 - cos_a * cos_a);
    float phi = 2.0 * PI * u.y;
    vec3 wc = dc / dcl;
    vec3 t, bt;
    make_frame(-wc, t, bt);
    return from_local(vec3(sin_a * cos(phi), sin_a * sin(phi), cos_a), t, bt, -wc);
}

// Solid-angle pdf of sampling point `pl` (normal nl) on sphere light l from p_ref.
float sphere_light_pdf(GpuLight l, vec3 p_ref, vec3 pl, vec3 nl) {
    vec3 c = l.p0.xyz;
    float r = l.p0.w;
    vec3 dc = c - p_ref;
    float d2 = dot(dc, dc);
    if (sphere_sampled_by_area(l, p_ref)) {
        // Uniform area sampling converted to solid angle.
        vec3 w = pl - p_ref;
        float dist2 = dot(w, w);
        float cosl = abs(dot(nl, normalize(w)));
        return cosl > 0.0 ? dist2 / (cosl * 4.0 * PI * r * r) : 0.0;
    }
    float sin2_max = r * r / d2;
    float cos_max = safe_sqrt(1.0 - sin2_max);
    float one_minus_cos = sin2_max < 0.00068523 ? 0.5 * sin2_max : 1.0 - cos_max;
    return 1.0 / (2.0 * PI * one_minus_cos);
}

// Solid-angle pdf (× pick probability) that NEE at p_ref (shading normal n_ref) would have
// chosen the point hit on light `li` at position pl with front normal nl.
float light_pdf_hit(uint li, vec3 p_ref, vec3 n_ref, vec3 pl, vec3 nl) {
    GpuLight l = lights[li];
    if (l.kind == LIGHT_TRIANGLE) {
        vec3 w = pl - p_ref;
        float dist2 = dot(w, w);
        float cosl = abs(dot(nl, w)) * inversesqrt(max(dist2, 1e-38));
        return cosl > 0.0 ? light_pick_pmf(li, p_ref, n_ref) * dist2 / (cosl * l.p0.w) : 0.0;
    }
    if (light_is_sphere(l.kind)) return light_pick_pmf(li, p_ref, n_ref) * sphere_light_pdf(l, p_ref, pl, nl);
    return 0.0;
}

// pdf (× pick probability) of the environment sampling direction d.
float env_pdf(vec3 d) {
    uint li = ENV_LIGHT;
    if (li == NONE) return 0.0;
    GpuLight l = lights[li];
    float pick = light_pick_pmf(li, vec3(0.0), vec3(0.0)); // (infinite lights: the same from everywhere)
#ifdef HAS_ENV_MAP
    if (l.kind == LIGHT_ENV_MAP) return pick * env_map_pdf(d);
#endif
    return pick * INV_4PI;
}

// The unit normal of triangle light l, on its emitting (front) side.
vec3 triangle_light_normal(GpuLight l) { return normalize(cross(l.p1.xyz - l.p0.xyz, l.p2.xyz - l.p0.xyz)); }

// NEE's light sample from p_ref (shading normal n_ref, or 0 where there is none; only the light
// BVH's pick uses it).
bool sample_light(vec3 p_ref, vec3 n_ref, vec3 u, out LightSample ls) {
    ls.wi = vec3(0.0, 0.0, 1.0); ls.dist = 0.0; ls.p = vec3(0.0); ls.L = vec3(0.0); ls.pdf = 0.0; ls.delta = false; ls.li = NONE;
    if (g.film.w == 0u) return false;
#ifdef LIGHT_SAMPLER_BVH
    uint li;
    float pick;
    if (!light_bvh_pick(p_ref, n_ref, u.x, li, pick)) return false;
#else
    uint li = pick_light(u.x);
    float pick = lights[li].pick_pdf;
#endif
    ls.li = li;
    GpuLight l = lights[li];
    vec2 u2 = u.yz;
    if (l.kind == LIGHT_TRIANGLE) {
        // Uniform point on the triangle; emission on its front side only.
        vec2 b = sample_uniform_triangle(u2);
        vec3 p0 = l.p0.xyz, p1 = l.p1.xyz, p2 = l.p2.xyz;
        vec3 pl = (1.0 - b.x - b.y) * p0 + b.x * p1 + b.y * p2;
        vec3 nl = triangle_light_normal(l);
        vec3 w = pl - p_ref;
        float dist2 = dot(w, w);
        if (!(dist2 > 0.0)) return false;
        ls.dist = sqrt(dist2);
        ls.wi = w / ls.dist;
        float cosl = -dot(nl, ls.wi);
        if (cosl <= 0.0 || emitter_cut(l, pl, b)) return false;
        ls.p = pl;
        ls.L = l.radiance.rgb;
        ls.pdf = pick * dist2 / (cosl * l.p0.w);
        return ls.pdf > 0.0 && !isinf(ls.pdf);
    }
    if (light_is_sphere(l.kind)) {
        vec3 c = l.p0.xyz;
        float r = l.p0.w;
        vec3 nl = sample_sphere_seen_from(c, r, p_ref, u2, sphere_sampled_by_area(l, p_ref));
        vec3 pl = c + r * nl;
        vec3 w = pl - p_ref;
        float dist2 = dot(w, w);
        if (!(dist2 > 0.0)) return false;
        ls.dist = sqrt(dist2);
        ls.wi = w / ls.dist;
        // Front side: outward normal unless the sphere's normals are flipped (p1.x = 1).
        vec3 front = l.p1.x > 0.5 ? -nl : nl;
        if (dot(front, ls.wi) >= 0.0 || emitter_cut(l, pl, vec2(0.0))) return false;
        ls.p = pl;
        ls.L = l.radiance.rgb;
        ls.pdf = pick * sphere_light_pdf(l, p_ref, pl, nl);
        return ls.pdf > 0.0 && !isinf(ls.pdf);
    }
#ifdef HAS_DELTA_LIGHTS
    if (l.kind == LIGHT_POINT || l.kind == LIGHT_SPOT) {
        vec3 w = l.p0.xyz - p_ref;
        float dist2 = dot(w, w);
        if (!(dist2 > 0.0)) return false;
        ls.dist = sqrt(dist2);
        ls.wi = w / ls.dist;
        ls.p = l.p0.xyz;
        float falloff = l.kind == LIGHT_SPOT ? spot_falloff(l, -dot(ls.wi, l.p1.xyz)) : 1.0;
        ls.L = l.radiance.rgb * falloff / dist2;
        ls.pdf = pick;
        ls.delta = true;
        return falloff > 0.0;
    }
    if (l.kind == LIGHT_DIRECTIONAL) {
        ls.wi = -l.p0.xyz;
        ls.dist = uintBitsToFloat(0x7f800000u);
        ls.L = l.radiance.rgb;
        ls.pdf = pick;
        ls.delta = true;
        return true;
    }
#endif
    if (light_is_env(l.kind)) {
        float pdf_dir;
#ifdef HAS_ENV_MAP
        if (l.kind == LIGHT_ENV_MAP) {
            ls.wi = env_map_sample(u2, pdf_dir);
        } else
#endif
        {
            ls.wi = sample_uniform_sphere(u2);
            pdf_dir = INV_4PI;
        }
        ls.dist = uintBitsToFloat(0x7f800000u);
        ls.L = env_eval(ls.wi);
        ls.pdf = pick * pdf_dir;
        return ls.pdf > 0.0;
    }
    return false;
}

#endif
