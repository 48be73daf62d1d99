// `bdpt`: bidirectional path tracing (Veach 1997 ch. 10; pbrt-v3's BDPTIntegrator as the
// model), one thread per pixel. Per sample the thread traces one camera subpath and one light
// subpath into fixed-size private arrays (vertex.glsl; capacity BDPT_DEPTH_CAP segments, set by
// the host from max_depth) and evaluates every strategy (s, t) with s + t − 1 ≤ max_depth
// (connect.glsl), weighted by the power heuristic. Strategies with t ≥ 2 belong to this pixel
// and go to ACCUM as pt/nee's samples do (deterministic whatever the pass split); t = 1 (light
// tracing) lands anywhere and is splatted atomically (splat.glsl).
// Why per-pixel light subpaths and not a light-vertex cache (Davidovič et al. 2014): it is the
// simplest design with bounded state (no shared buffer of light vertices, no second dispatch,
// no resampling bias to reason about) and makes every strategy exactly pbrt's, which the tests
// check one by one; the cache is the faster follow-up once this is the reference.
// Defines (renderer/src/integrators/bdpt.rs): BDPT_DEPTH_CAP, BDPT_FLOAT_SPLATS. The options
// mis / strategy / weighted travel in GpuPush::flags, so they share one compiled kernel.
#version 460
#extension GL_GOOGLE_include_directive : require
#ifdef BDPT_FLOAT_SPLATS
#extension GL_EXT_shader_atomic_float : require
#endif

#include "common/bindings.glsl"
#include "common/film.glsl"
#include "common/dispatch.glsl"
#include "bdpt/vertex.glsl"
#include "bdpt/subpath.glsl"
#include "bdpt/connect.glsl"
#include "bdpt/splat.glsl"

layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

// GpuPush::flags bits: PUSH_FLAG_BDPT_* (renderer/src/layout.rs).

// True when strategy (s, t) is rendered (all of them, or the debug one).
bool strategy_enabled(int s, int t) {
    if ((pc.flags & PUSH_FLAG_BDPT_STRATEGY) == 0u) return true;
    return uint(s) == ((pc.flags >> PUSH_FLAG_BDPT_S_SHIFT) & 0xffu)
        && uint(t) == ((pc.flags >> PUSH_FLAG_BDPT_T_SHIFT) & 0xffu);
}

// The weight a contribution gets: its MIS weight, or 1 when a debug strategy is rendered
// unweighted.
float strategy_weight(float w) {
    const uint unweighted = PUSH_FLAG_BDPT_STRATEGY | PUSH_FLAG_BDPT_UNWEIGHTED;
    return (pc.flags & unweighted) == unweighted ? 1.0 : w;
}

// One bdpt sample of pixel px: the camera-side estimate (returned) and the light-tracing
// splats (added to the splat buffer; non-finite ones are dropped and counted).
vec3 bdpt_sample(uvec2 px, inout Rng rng, int max_depth, inout uint rays, inout uint dropped) {
    // Step 1: the subpaths; a path of s + t vertices has s + t − 1 ≤ max_depth segments.
    int nc, nl;
    trace_subpaths(px, max_depth, rng, rays, nc, nl);
    vec3 L = vec3(0.0);
    // Step 2: every strategy. s = 1 samples its own light point, so it runs even when the light
    // subpath is empty.
    for (int t = 1; t <= nc; ++t) {
        for (int s = 0; s <= max(nl, 1); ++s) {
            int k = s + t - 1;
            if ((s == 1 && t == 1) || k < 1 || k > max_depth) continue;
            if (s >= 2 && s > nl) continue;
            if (!strategy_enabled(s, t)) continue;
            // Each strategy draws from its own dimensions, whichever others run.
            rng.dim = 1024u + uint(t) * 64u + uint(s);
            float w;
            vec2 film;
            vec3 c = connect(s, t, rng_next4(rng), rays, film, w);
            c *= strategy_weight(w);
            if (t == 1) {
                if (!is_finite(c)) {
                    dropped += 1u;
                } else if (any(greaterThan(c, vec3(0.0)))) {
                    splat_film(film, c);
                }
                continue;
            }
            L += c;
        }
    }
    return L;
}

void main() {
    FilmTask t = film_task();
    // Mitsuba's max_depth, capped by the arrays' capacity (−1: the capacity).
    int max_depth = pc.max_depth < 0 ? BDPT_DEPTH_CAP : min(pc.max_depth, BDPT_DEPTH_CAP);
    bdpt_mis = (pc.flags & PUSH_FLAG_BDPT_NO_MIS) == 0u;
    vec4 acc = film_load(t);
    uint rays = 0u, dropped = 0u;
    for (uint r = 0u; r < film_rounds(t); ++r) {
        uint i = film_sample(t, r);
        vec3 L = vec3(0.0);
        if (film_has(t, i)) {
            Rng rng = rng_init(t.pixel, pc.sample_base + i, pc.seed_lo, pc.seed_hi);
            L = bdpt_sample(t.px, rng, max_depth, rays, dropped);
        }
        film_lanes_add(t, acc, L, r, dropped);
    }
    film_store(t, acc);
    film_count(rays, dropped);
}
