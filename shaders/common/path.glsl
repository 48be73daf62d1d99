// The path-tracing megakernel shared by `pt` (INTEGRATOR_NEE 0: BSDF sampling only) and `nee`
// (INTEGRATOR_NEE 1: next-event estimation with multiple importance sampling, power heuristic).
// Each pixel's `pc.spp` samples are traced by one thread, or by up to 8 threads on small films
// (common/dispatch.glsl), and added to the running sum in the accumulation buffer in sample
// order, so the floating-point sum is the same whatever the pass split or dispatch shape.
// max_depth has Mitsuba 3's meaning (1: directly visible emitters only; 2: + direct light; −1:
// unbounded), and Russian roulette starts at rr_depth as in Mitsuba's `path` integrator.
//
// Why a megakernel: for the scenes candela targets, shading is light next to traversal (a few
// hundred instructions per BSDF), so keeping path state in registers beats writing it to memory
// between wavefront stages (Laine et al. 2013 find wavefront wins only with heavy, divergent
// shading). It also keeps the pass to one dispatch, which matters on lavapipe. Revisit with
// measurements once the principled BSDF and textures dominate.
#ifndef COMMON_PATH_GLSL
#define COMMON_PATH_GLSL
#include "common/bindings.glsl"
#include "common/film.glsl"
#include "common/dispatch.glsl"
#include "common/math.glsl"
#include "common/rng.glsl"
#include "common/camera.glsl"
#include "common/traverse.glsl"
#include "common/surface.glsl"
#include "common/material.glsl"
#include "common/lights.glsl"

PASS_LOCAL_SIZE;

vec3 trace_path(uvec2 px, inout Rng rng, inout uint rays) {
    // Step 1: the camera ray.
    Ray ray = camera_ray(px, rng);
    vec3 L = vec3(0.0), beta = vec3(1.0);
    float eta_scale = 1.0;
    float prev_pdf = 1.0;     // BSDF pdf of the direction that led here
    bool prev_delta = true;   // ... and whether it was a delta lobe
    vec3 prev_p = ray.o;      // where that direction started (for light pdfs)
    vec3 prev_n = vec3(0.0);  // ... and its shading normal (the light BVH's receiver term)
    for (int depth = 0;; ++depth) {
        // Step 2: find the next vertex; escaping rays see the environment.
        Hit hit;
        rays += 1u;
        if (!trace_closest(ray, hit)) {
            vec3 le = env_eval(ray.d);
            if (any(greaterThan(le, vec3(0.0)))) {
                float w = 1.0;
#if INTEGRATOR_NEE
                if (!prev_delta) w = power_heuristic(prev_pdf, env_pdf(ray.d));
#endif
                L += beta * w * le;
            }
            break;
        }
        Surface s = surface_at(hit, ray);
        vec3 wo_world = -ray.d;

        // Step 3: emission of the surface hit, front side only: the side of the geometric normal,
        // the same side light sampling (lights.glsl) and bdpt emit from.
        GpuMaterial gm = materials[s.material];
        if (s.light != NONE && dot(wo_world, s.ng) > 0.0) {
            float w = 1.0;
#if INTEGRATOR_NEE
            if (!prev_delta) w = power_heuristic(prev_pdf, light_pdf_hit(s.light, prev_p, prev_n, s.p, s.ng));
#endif
            L += beta * w * gm.emission.rgb;
        }
        // Step 4: stop where max_depth says no further vertex may contribute.
        if (PASS_MAX_DEPTH >= 0 && depth + 1 >= PASS_MAX_DEPTH) break;

        // Step 5: the BSDF in the local shading frame (z = ns, x = tangent).
        SurfaceParams m = resolve_material(s.material, s.uv);
        vec3 bt = cross(s.ns, s.tangent);
        vec3 wo = to_local(wo_world, s.tangent, bt, s.ns);

#if INTEGRATOR_NEE
        // Step 6: next-event estimation, MIS-weighted against BSDF sampling.
        vec3 ul = rng_next3(rng);
        if (!bsdf_is_delta(m)) {
            LightSample ls;
            if (sample_light(s.p, s.ns, ul, ls) && any(greaterThan(ls.L, vec3(0.0)))) {
                vec3 wi = to_local(ls.wi, s.tangent, bt, s.ns);
                vec3 f = bsdf_eval(m, wo, wi, TRANSPORT_RADIANCE);
                if (any(greaterThan(f, vec3(0.0)))) {
                    Ray shadow = isinf(ls.dist) ? spawn_ray(s, ls.wi) : spawn_ray_to(s, ls.p);
                    rays += 1u;
                    if (!trace_any(shadow)) {
                        float w = ls.delta ? 1.0 : power_heuristic(ls.pdf, bsdf_pdf(m, wo, wi));
                        L += beta * f * ls.L * (w / ls.pdf);
                    }
                }
            }
        }
#endif
        // Step 7: continue the path by sampling the BSDF.
        // One draw serves the BSDF (xyz) and step 8's roulette (w), as in bdpt's walks: a
        // separate draw for the roulette cost nee 1.4% on the Cornell box (bench/RESULTS.md,
        // "The random numbers' cost").
        BsdfSample bs;
        vec4 ub = rng_next4(rng);
        if (!bsdf_sample(m, wo, ub.xyz, TRANSPORT_RADIANCE, bs)) break;
        beta *= bs.weight;
        if (!any(greaterThan(beta, vec3(0.0)))) break;
        prev_pdf = bs.pdf;
        prev_delta = (bs.flags & BSDF_DELTA) != 0u;
        prev_p = s.p;
        prev_n = s.ns;
        if ((bs.flags & BSDF_TRANSMISSION) != 0u) eta_scale *= sqr(bs.eta);
        ray = spawn_ray(s, from_local(bs.wi, s.tangent, bt, s.ns));

        // Step 8: Russian roulette from rr_depth on (Mitsuba: q = min(max(β)·η², 0.95)).
        if (depth + 1 >= PASS_RR_DEPTH) {
            float q = min(max_comp(beta) * eta_scale, 0.95);
            if (ub.w >= q) break;
            beta /= q;
        }
    }
    return L;
}

void main() {
    COUNT_CLOCK_START;
    FilmTask t = film_task();
    vec4 acc = film_load(t);
    uint rays = 0u, dropped = 0u;
    for (uint r = 0u; r < film_rounds(t); ++r) {
        uint i = film_sample(t, r);
        vec3 L = vec3(0.0);
        if (film_has(t, i)) {
            Rng rng = rng_init(t.pixel, pc.sample_base + i, pc.seed_lo, pc.seed_hi);
            L = trace_path(t.px, rng, rays);
        }
        film_lanes_add(t, acc, L, r, dropped);
    }
    film_store(t, acc);
    film_count(rays, dropped);
}

#endif
