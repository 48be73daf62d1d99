// bdpt's split design: the light subpaths of a band of pixels (one sample each), kept between the
// light pass (light.comp writes them) and the camera pass (bdpt.comp with BDPT_SPLIT reads them).
// Seven vec4 per vertex, stored plane by plane so that neighbouring pixels' threads read
// neighbouring memory: vertex v, word k of path p at (v·7 + k)·paths + p, where paths (the
// band's capacity) = the buffer's length / (7 · BDPT_MAX_LIGHT). A path's vertex count is in
// B_BDPT_LIGHT_COUNTS. The position error p_err is not kept (only the light pass, which has the
// vertex itself, spawns rays from light vertices).
#ifndef BDPT_STORE_GLSL
#define BDPT_STORE_GLSL
#include "bdpt/vertex.glsl"

// The camera pass only reads the light subpaths: `readonly` there (as vct's gather reads its
// volume; +0.4..+1.5% on five of six scenes: bench/RESULTS.md, "Read-only buffers, the
// tangent only where a BSDF reads it").
#ifdef BDPT_CAMERA_PASS
#define LV_ACCESS readonly
#else
#define LV_ACCESS
#endif
layout(set = 0, binding = B_BDPT_LIGHT_VERTICES, scalar) LV_ACCESS buffer LightVertices { vec4 light_vertices[]; };
layout(set = 0, binding = B_BDPT_LIGHT_COUNTS, scalar) LV_ACCESS buffer LightCounts { uint light_counts[]; };

#define LV_WORDS 7u

// The path (within the band) this thread reads or writes; set by main.
uint bdpt_path = 0u;

// Light subpaths per row of the band (renderer/src/integrators/bdpt.rs, `light_cols`): one per
// pixel, or with K pixels sharing one (paths.glsl) one per block: block b of a row holds pixels
// [bK − o, bK − o + K), shifted by o = the sample index mod K so that the blocks' edges move
// from sample to sample; ⌊(width + K − 2) / K⌋ + 1 blocks cover the row whatever o is.
uint lv_cols() {
    uint k = 1u << bdpt_share_log2();
    return k == 1u ? g.film.x : (max(g.film.x, 1u) + k - 2u) / k + 1u;
}
uint lv_shift() { return pc.sample_base & ((1u << bdpt_share_log2()) - 1u); }
// The block of pixel column x.
uint lv_block(uint x) { return (x + lv_shift()) >> bdpt_share_log2(); }
// The pixel column whose random numbers block b's light subpath uses (its first pixel).
uint lv_block_pixel(uint b) { return max(b << bdpt_share_log2(), lv_shift()) - lv_shift(); }
// The pixels of block b within the row (K but at the row's ends).
uint lv_block_pixels(uint b) {
    uint k = 1u << bdpt_share_log2();
    uint lo = lv_block_pixel(b), hi = min((b << bdpt_share_log2()) + k - lv_shift(), g.film.x);
    return hi - lo;
}
// Whether block b holds a pixel of the row.
bool lv_block_used(uint b) { return b <= (g.film.x - 1u + lv_shift()) >> bdpt_share_log2(); }

uint lv_paths() { return uint(light_vertices.length()) / (LV_WORDS * uint(BDPT_MAX_LIGHT)); }
uint lv_at(int v, uint k) { return (uint(v) * LV_WORDS + k) * lv_paths() + bdpt_path; }

#ifndef BDPT_CAMERA_PASS
void light_vertex_store(int v, Vertex x) {
    light_vertices[lv_at(v, 0u)] = vec4(x.p, uintBitsToFloat(x.kind));
    light_vertices[lv_at(v, 1u)] = vec4(x.ng, uintBitsToFloat(x.flags));
    light_vertices[lv_at(v, 2u)] = vec4(x.ns, uintBitsToFloat(x.material));
    light_vertices[lv_at(v, 3u)] = vec4(x.tangent, uintBitsToFloat(x.light));
    light_vertices[lv_at(v, 4u)] = vec4(x.wo, x.pdf_rev);
    light_vertices[lv_at(v, 5u)] = vec4(x.beta, x.pdf_fwd);
    light_vertices[lv_at(v, 6u)] = vec4(x.uv, x.mis_acc, 0.0);
}
#endif

Vertex light_vertex_load(int v) {
    Vertex x;
    vec4 w = light_vertices[lv_at(v, 0u)];
    x.p = w.xyz; x.kind = floatBitsToUint(w.w);
    w = light_vertices[lv_at(v, 1u)];
    x.ng = w.xyz; x.flags = floatBitsToUint(w.w);
    w = light_vertices[lv_at(v, 2u)];
    x.ns = w.xyz; x.material = floatBitsToUint(w.w);
    w = light_vertices[lv_at(v, 3u)];
    x.tangent = w.xyz; x.light = floatBitsToUint(w.w);
    w = light_vertices[lv_at(v, 4u)];
    x.wo = w.xyz; x.pdf_rev = w.w;
    w = light_vertices[lv_at(v, 5u)];
    x.beta = w.xyz; x.pdf_fwd = w.w;
    w = light_vertices[lv_at(v, 6u)];
    x.uv = w.xy; x.mis_acc = w.z;
    x.p_err = vec3(0.0);
    return x;
}

#endif
