// Which pixel and which samples an invocation of a pass kernel renders (renderer/src/render/
// dispatch.rs sizes passes to the GPU, not to the image). pc.dispatch: bits 0–3 log2 of the
// lanes L (threads sharing one pixel's samples: 1, 2, 4 or 8), bits 8–31 the first film row
// of this dispatch's band. Tiles of 64 threads cover 8 × (8/L) pixels; lane k of a pixel
// takes the pass's samples k, k + L, k + 2L, ... in rounds, and after each round lane 0 adds
// the round's L results to the pixel's sum in sample order with film_add, so the sum is, bit for
// bit, the one a single thread makes whatever L is. Usage (every pass kernel):
//   FilmTask t = film_task();
//   vec4 acc = film_load(t);
//   for (uint r = 0u; r < film_rounds(t); ++r) {
//       uint i = film_sample(t, r);           // index within the pass
//       vec3 L = vec3(0.0);
//       if (film_has(t, i)) L = ...sample pc.sample_base + i of pixel t.px...;
//       film_lanes_add(t, acc, L, r, dropped); // every thread calls it (it may hold a barrier)
//   }
//   film_store(t, acc);
// Needs common/bindings.glsl (ACCUM) and common/film.glsl; pass kernels declare their workgroup
// with PASS_LOCAL_SIZE: WG_TILES tiles of 8 × 8 threads (default 1), side by side along the
// film's rows (renderer/src/render/dispatch.rs divides the workgroups in x by the same number;
// why: renderer/src/integrators/registry.rs, `workgroup_tiles`).
#ifndef COMMON_DISPATCH_GLSL
#define COMMON_DISPATCH_GLSL

#ifndef WG_TILES
#define WG_TILES 1
#endif
#define PASS_LOCAL_SIZE layout(local_size_x = 8, local_size_y = 8, local_size_z = WG_TILES) in

struct FilmTask {
    uvec2 px;
    uint pixel;
    uint lane;
    uint lanes_log2;
    bool valid; // inside the film (threads outside still take part in the rounds)
};

FilmTask film_task() {
    FilmTask t;
    t.lanes_log2 = pc.dispatch & 0xfu;
    uint li = gl_LocalInvocationIndex & 63u; // within the tile
    t.lane = li & ((1u << t.lanes_log2) - 1u);
    uint slot = li >> t.lanes_log2; // pixel within the tile: 8 columns, 8/L rows
    // Tiles side by side in x, so a workgroup never reaches into the next band's rows.
    uint tile_col = gl_WorkGroupID.x * uint(WG_TILES) + gl_LocalInvocationID.z;
    t.px = uvec2(tile_col * 8u + (slot & 7u),
                 (pc.dispatch >> 8) + gl_WorkGroupID.y * (8u >> t.lanes_log2) + (slot >> 3));
    t.valid = t.px.x < g.film.x && t.px.y < g.film.y;
    t.pixel = t.px.y * g.film.x + t.px.x;
    return t;
}

// Rounds of the sample loop: the pass's samples over the lanes, the same for every thread.
uint film_rounds(FilmTask t) { return (pc.spp + (1u << t.lanes_log2) - 1u) >> t.lanes_log2; }

// The pass-relative index of this thread's sample in round r.
uint film_sample(FilmTask t, uint r) { return (r << t.lanes_log2) + t.lane; }

// Whether this thread renders sample i of the pass.
bool film_has(FilmTask t, uint i) { return t.valid && i < pc.spp; }

vec4 film_load(FilmTask t) { return t.valid && t.lane == 0u ? accum[t.pixel] : vec4(0.0); }

void film_store(FilmTask t, vec4 acc) {
    if (t.valid && t.lane == 0u) {
        accum[t.pixel] = acc;
        film_odd_store(t.pixel);
    }
}

shared vec3 film_lane_L[64 * WG_TILES];

// Adds round r's results to acc (lane 0's) in sample order.
void film_lanes_add(FilmTask t, inout vec4 acc, vec3 L, uint r, inout uint dropped) {
    if (t.lanes_log2 == 0u) {
        if (film_has(t, r)) film_add(acc, L, pc.sample_base + r, dropped);
        return;
    }
    // (A uniform branch: lanes come from a push constant, so the barriers are reached by all.)
    film_lane_L[gl_LocalInvocationIndex] = L;
    barrier();
    if (t.valid && t.lane == 0u) {
        uint lanes = 1u << t.lanes_log2;
        for (uint k = 0u; k < lanes; ++k) {
            uint i = (r << t.lanes_log2) + k;
            if (i < pc.spp) film_add(acc, film_lane_L[gl_LocalInvocationIndex + k], pc.sample_base + i, dropped);
        }
    }
    barrier();
}

#endif
