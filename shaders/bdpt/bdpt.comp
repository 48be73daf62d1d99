// `bdpt`: bidirectional path tracing (Veach 1997 ch. 10; pbrt-v3's BDPTIntegrator as the
// model). Per sample one camera subpath and one light subpath, in fixed-size arrays
// (paths.glsl; capacity BDPT_DEPTH_CAP segments, set by the host from max_depth), and every
// strategy (s, t) with s + t − 1 ≤ max_depth (strategies.glsl, connect.glsl), weighted by the
// power heuristic. Strategies with t ≥ 2 belong to this pixel and go to ACCUM as pt/nee's
// samples do (deterministic whatever the pass split); t = 1 (light tracing) lands anywhere and
// is splatted atomically (splat.glsl).
// Two designs (renderer/src/integrators/bdpt.rs), the same estimator:
//   - per-pixel (default build of this file): one thread per pixel traces both subpaths into one
//     private array and evaluates every strategy;
//   - split (BDPT_SPLIT: this file is the camera pass): light.comp first traces every pixel's
//     light subpath of the band into a buffer (store.glsl) and splats its light tracing; then
//     one thread per pixel traces the camera subpath alone and joins it to its pixel's light
//     vertices read from that buffer (t ≥ 2). With `light_share` K the light pass traces one
//     light subpath per block of K pixels, which they all join (paths.glsl). Each pass holds one subpath, about half the
//     per-thread state, and the light walks run apart from the camera walks.
// Defines: BDPT_DEPTH_CAP, BDPT_FLOAT_SPLATS, BDPT_SPLIT. The options mis / strategy / weighted
// travel in GpuPush::flags, so they share one compiled kernel.
#version 460
#extension GL_GOOGLE_include_directive : require
#ifdef BDPT_FLOAT_SPLATS
#extension GL_EXT_shader_atomic_float : require
#endif

#ifdef BDPT_SPLIT
#define BDPT_CAMERA_PASS 1
#endif

#include "common/bindings.glsl"
#include "common/film.glsl"
#include "common/dispatch.glsl"
#include "bdpt/subpath.glsl"
#include "bdpt/strategies.glsl"

PASS_LOCAL_SIZE;

// Mitsuba's max_depth, capped by the arrays' capacity (−1: the capacity).
int bdpt_max_depth() { return PASS_MAX_DEPTH < 0 ? BDPT_DEPTH_CAP : min(PASS_MAX_DEPTH, BDPT_DEPTH_CAP); }

void main() {
    COUNT_CLOCK_START;
    FilmTask t = film_task();
    int max_depth = bdpt_max_depth();
    bdpt_mis = (pc.flags & PUSH_FLAG_BDPT_NO_MIS) == 0u;
#ifdef BDPT_CAMERA_PASS
    // The light subpath of this band and sample that this pixel joins (its own, or its
    // block's with `light_share`: store.glsl).
    bdpt_path = (t.px.y - (pc.dispatch >> 8)) * lv_cols() + lv_block(t.px.x);
#endif
    vec4 acc = film_load(t);
    uint rays = 0u, dropped = 0u;
    for (uint r = 0u; r < film_rounds(t); ++r) {
        uint i = film_sample(t, r);
        vec3 L = vec3(0.0);
        if (film_has(t, i)) {
            Rng rng = rng_init(t.pixel, pc.sample_base + i, pc.seed_lo, pc.seed_hi);
            int nc, nl;
            trace_subpaths(t.px, max_depth, rng, rays, nc, nl);
#ifdef BDPT_CAMERA_PASS
            nl = int(light_counts[bdpt_path]);
            L = bdpt_strategies(nc, nl, 2, max_depth, rng, rays, dropped);
#else
            L = bdpt_strategies(nc, nl, 1, max_depth, rng, rays, dropped);
#endif
        }
        film_lanes_add(t, acc, L, r, dropped);
    }
    film_store(t, acc);
    film_count(rays, dropped);
}
