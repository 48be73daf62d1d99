// The strategies of one bdpt sample (connect.glsl), shared by the per-pixel kernel (bdpt.comp:
// every t), the split design's camera pass (bdpt.comp with BDPT_SPLIT: t ≥ 2) and its light pass
// (light.comp: t = 1). Each strategy draws from its own dimensions (1024 + 64t + s), so which
// kernel evaluates it does not change its value.
#ifndef BDPT_STRATEGIES_GLSL
#define BDPT_STRATEGIES_GLSL
#include "bdpt/connect.glsl"
#include "bdpt/splat.glsl"

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

// The strategies (s, t) with t ≥ t_first of a sample whose subpaths have nc camera and nl light
// vertices: the camera-side estimate (returned) and the light-tracing splats (t = 1, added to
// the splat buffers by the parity of the sample index rng.key.y; non-finite ones are dropped
// and counted). A path of s + t vertices has s + t − 1 ≤ max_depth segments. s = 1 samples its
// own light point, so it runs even when the light subpath is empty.
vec3 bdpt_strategies(int nc, int nl, int t_first, int max_depth, inout Rng rng, inout uint rays, inout uint dropped) {
    vec3 L = vec3(0.0);
    MisInputs mi = mis_inputs_of_sample(nl);
    mis_running_sums(nc, nl, mi.nee_ratio);
    for (int t = t_first; t <= nc; ++t) {
        for (int s = BDPT_HAS_S01 ? 0 : 2; s <= max(nl, 1); ++s) {
            int k = s + t - 1;
            if ((s == 1 && t == 1) || k < 1 || k > max_depth) continue;
            if (s >= 2 && s > nl) continue;
            if (!strategy_enabled(s, t)) continue;
            // Each strategy draws from its own dimensions, whichever others run.
            rng.dim = 1024u + uint(t) * 64u + uint(s);
            float w;
            vec2 film;
            vec3 c = connect(s, t, rng_next4(rng), mi, rays, film, w);
            c *= strategy_weight(w);
            if (BDPT_HAS_T1 && t == 1) {
                // A light subpath shared by several pixels counts for each (paths.glsl).
                c *= bdpt_light_weight;
                if (!is_finite(c)) {
                    dropped += 1u;
                } else if (any(greaterThan(c, vec3(0.0)))) {
                    // t = 0 is no strategy: its dimensions hold the splats' roulette.
                    rng.dim = 1024u + uint(s);
                    splat_film(film, c, (rng.key.y & 1u) == 1u, rng_next1(rng));
                }
                continue;
            }
            L += c;
        }
    }
    return L;
}

#endif
