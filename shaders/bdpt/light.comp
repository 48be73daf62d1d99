// `bdpt`, split design, light pass (renderer/src/integrators/bdpt.rs): one thread per light
// subpath of the band — one per pixel, or one per block of K pixels with `light_share` K
// (store.glsl) — traces it for sample pc.sample_base with the random numbers of its (block's
// first) pixel (the same subpath the per-pixel design traces there: dimensions 256 on),
// evaluates its light-tracing strategies (t = 1, splatted, counting for the block's pixels) and
// stores the vertices for the camera pass (bdpt.comp with BDPT_SPLIT) to join.
#version 460
#extension GL_GOOGLE_include_directive : require
#ifdef BDPT_FLOAT_SPLATS
#extension GL_EXT_shader_atomic_float : require
#endif
#define BDPT_LIGHT_PASS 1

#include "common/bindings.glsl"
#include "common/film.glsl"
#include "common/dispatch.glsl"
#include "bdpt/subpath.glsl"
#include "bdpt/strategies.glsl"
#include "bdpt/store.glsl"

PASS_LOCAL_SIZE;

void main() {
    COUNT_CLOCK_START;
    // Threads cover the band's light subpaths: lv_cols() per row, block t.px.x of row t.px.y,
    // traced with the random numbers of the block's first pixel.
    FilmTask t = film_task();
    uint block = t.px.x;
    if (t.px.y >= g.film.y || !lv_block_used(block)) return;
    t.px.x = lv_block_pixel(block);
    bdpt_light_weight = float(lv_block_pixels(block));
    t.pixel = t.px.y * g.film.x + t.px.x;
    int max_depth = PASS_MAX_DEPTH < 0 ? BDPT_DEPTH_CAP : min(PASS_MAX_DEPTH, BDPT_DEPTH_CAP);
    bdpt_mis = (pc.flags & PUSH_FLAG_BDPT_NO_MIS) == 0u;
    bdpt_path = (t.px.y - (pc.dispatch >> 8)) * lv_cols() + block;
    uint rays = 0u, dropped = 0u;
    // Step 1: the light subpath.
    Rng rng = rng_init(t.pixel, pc.sample_base, pc.seed_lo, pc.seed_hi);
    int nc, nl;
    trace_subpaths(t.px, max_depth, rng, rays, nc, nl);
    // Step 2: light tracing (t = 1), splatted.
    bdpt_strategies(1, nl, 1, max_depth, rng, rays, dropped);
    // Step 3: the vertices, for the camera pass.
    for (int v = 0; v < nl; ++v) light_vertex_store(v, vtx[LGT(v)]);
    light_counts[bdpt_path] = uint(nl);
    film_count(rays, dropped);
}
