// Light-tracing splats (t = 1): a light path lands on any pixel, so its contributions are added
// atomically to a separate buffer at binding B_SPLAT; the host forms the image as
// accum.rgb / accum.w + splat / (pixels · spp) (renderer/src/integrators/bdpt.rs).
//  - BDPT_FLOAT_SPLATS: float atomicAdd (GL_EXT_shader_atomic_float; 4 floats per pixel). The
//    order of the additions varies from run to run, so the splat sum is not bit-reproducible.
//  - otherwise: 64-bit unsigned fixed point with SPLAT_FRAC_BITS fractional bits, from 32-bit
//    integer atomics (8 words per pixel: low words r, g, b, −, then high words r, g, b, −; a
//    wrapped low word carries one into the high word). Integer sums do not depend on order, so
//    this path is bit-reproducible. Each addition is truncated to 2^−20 and the total must stay
//    below 2^44 (about 1.8e13) per channel.
// The pixel filter (camera_we.glsl) spreads a splat over every pixel whose filter covers it.
// Splats of odd sample index are also added to a second buffer of the same format (B_SPLAT_ODD),
// so that the two halves of the error estimate (renderer/src/render/halves.rs) each carry their
// own light tracing (with float splats through B_BDPT_SPLAT_NEW and splat_merge.comp).
#ifndef BDPT_SPLAT_GLSL
#define BDPT_SPLAT_GLSL
#include "common/camera_we.glsl"

#define SPLAT_FRAC_BITS 20

#ifdef BDPT_FLOAT_SPLATS
layout(set = 0, binding = B_SPLAT, scalar) buffer Splat { float splat[]; };
layout(set = 0, binding = B_BDPT_SPLAT_NEW, scalar) buffer SplatNew { float splat_new[]; };

// Odd samples' splats go to B_BDPT_SPLAT_NEW alone, which splat_merge.comp adds to both B_SPLAT
// and B_SPLAT_ODD at the end of the pass: three atomics per pixel whatever the parity (adding
// them to both buffers here took six, and the atomics are most of the splats' cost).
void splat_add(uint pixel, vec3 v, bool odd) {
    if (odd) {
        atomicAdd(splat_new[4u * pixel + 0u], v.r);
        atomicAdd(splat_new[4u * pixel + 1u], v.g);
        atomicAdd(splat_new[4u * pixel + 2u], v.b);
    } else {
        atomicAdd(splat[4u * pixel + 0u], v.r);
        atomicAdd(splat[4u * pixel + 1u], v.g);
        atomicAdd(splat[4u * pixel + 2u], v.b);
    }
}
#else
layout(set = 0, binding = B_SPLAT, scalar) buffer Splat { uint splat[]; };
layout(set = 0, binding = B_SPLAT_ODD, scalar) buffer SplatOdd { uint splat_odd[]; };

void splat_add_channel(uint lo_index, float v, bool odd) {
    // v · 2^20 as hi · 2^32 + lo, both exact in float arithmetic (power-of-two scalings, and
    // v − 4096·hi is exact by Sterbenz); the low part is truncated to an integer.
    v = clamp(v, 0.0, 1.7e13);
    float hi = floor(v * exp2(float(SPLAT_FRAC_BITS - 32)));
    uint lo = uint((v - hi * exp2(float(32 - SPLAT_FRAC_BITS))) * exp2(float(SPLAT_FRAC_BITS)));
    uint carry = 0u, carry_odd = 0u;
    if (lo != 0u) {
        uint before = atomicAdd(splat[lo_index], lo);
        if (before + lo < before) carry = 1u;
        if (odd) {
            before = atomicAdd(splat_odd[lo_index], lo);
            if (before + lo < before) carry_odd = 1u;
        }
    }
    uint h = uint(hi) + carry;
    if (h != 0u) atomicAdd(splat[lo_index + 4u], h);
    h = uint(hi) + carry_odd;
    if (odd && h != 0u) atomicAdd(splat_odd[lo_index + 4u], h);
}

void splat_add(uint pixel, vec3 v, bool odd) {
    splat_add_channel(8u * pixel + 0u, v.r, odd);
    splat_add_channel(8u * pixel + 1u, v.g, odd);
    splat_add_channel(8u * pixel + 2u, v.b, odd);
}
#endif

// Filter weights below this are Russian-rouletted in splats: a pixel of weight w < SPLAT_RR_WEIGHT
// receives L · SPLAT_RR_WEIGHT with probability w / SPLAT_RR_WEIGHT, else nothing, so its
// expectation is unchanged. A Gaussian's footprint (radius 4σ) holds 16–25 pixels, most of them
// in its faint rim; the splats were a fifth of bdpt's time on the Cornell box (bench/
// RESULTS.md, "bdpt's splats"), and the roulette adds the rim's variance only (at most
// SPLAT_RR_WEIGHT × the rim's share of the filter, per unit L²). 0 splats every pixel.
#ifndef SPLAT_RR_WEIGHT
#define SPLAT_RR_WEIGHT 0.05
#endif

// Adds contribution L, landed at film position `film` (pixels), to every pixel whose filter
// covers it, weighted by the normalised filter; `odd`: the sample index is odd; u: a uniform
// for the roulette of faint pixels (each rouletted pixel k of the footprint draws
// fract(u + k·φ⁻¹), uniform for each and spread evenly over them).
void splat_film(vec2 film, vec3 L, bool odd, float u) {
    ivec2 res = ivec2(g.film.xy);
    if (FILTER_GAUSSIAN) {
        float r = g.filter_params.y;
        ivec2 lo = max(ivec2(ceil(film - 0.5 - r)), ivec2(0));
        ivec2 hi = min(ivec2(floor(film - 0.5 + r)), res - 1);
        // The filter is separable: each row's weight once, then each pixel's along the row.
        for (int y = lo.y; y <= hi.y; ++y) {
            float wy = filter_eval_axis(film.y - (float(y) + 0.5), float(y) + 0.5, float(res.y));
            if (wy <= 0.0) continue;
            for (int x = lo.x; x <= hi.x; ++x) {
                float wf = wy * filter_eval_axis(film.x - (float(x) + 0.5), float(x) + 0.5, float(res.x));
                if (!(wf > 0.0)) continue;
                if (wf < SPLAT_RR_WEIGHT) {
                    u = fract(u + 0.618034);
                    if (u * SPLAT_RR_WEIGHT >= wf) continue;
                    wf = SPLAT_RR_WEIGHT;
                }
                splat_add(uint(y * res.x + x), L * wf, odd);
            }
        }
    } else {
        ivec2 j = ivec2(floor(film));
        if (all(greaterThanEqual(j, ivec2(0))) && all(lessThan(j, res))) splat_add(uint(j.y * res.x + j.x), L, odd);
    }
}

#endif
