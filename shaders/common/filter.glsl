// The pixel filter, sampled (camera.glsl) and evaluated (camera_we.glsl), with Mitsuba 3's
// meaning. The Gaussian is Mitsuba's `gaussian` as its film applies it: separable, per axis
// w(x) = max(0, e^{−x²/2σ²} − e^{−r²/2σ²}) with r = 4σ (rfilters/gaussian.cpp), read from a
// table of 31 steps over [0, r] (`eval_discretized`, which ImageBlock::put uses: the value at
// the start of the step holding |x|), so its support is the square [−r, r]². Mitsuba's film
// draws samples only on the film and divides each pixel by the weights it received, so a pixel
// within r of the film's edge has its filter cut there and renormalised; here each pixel samples
// its own filter so cut (weight 1 per sample), which has the same expectation. The box filter is
// the pixel's own square.
//
// Per axis, in steps h = r/31 (q = |x|/h): the step values v_k = e^{−8k²/961} − e^{−8} do not
// depend on σ, nor do their running sums C_k = Σ_{i<k} v_i, so the mass of [0, q] is
// P(q) = C_k + (q − k)·v_k with k = ⌊q⌋. A pixel away from the film's edges draws a step from an
// alias table (one lookup) and a point in it; a pixel within r of an edge inverts P on the
// interval it keeps, [max(−31, −c/h), min(31, e/h)] for a centre c pixels from the film's low edge
// and e from its high edge (a binary search over C_k). The tables (C_k and the alias table) come from the host
// (renderer/src/compile/camera.rs) in the globals buffer: constant arrays in the shader, indexed
// per lane, cost bdpt half its speed on an H100 (bench/RESULTS.md).
// g.filter_params: (σ, r, h, 0).
#ifndef COMMON_FILTER_GLSL
#define COMMON_FILTER_GLSL
#include "common/bindings.glsl"

// v_k: the filter on step k (0 from step 31 on).
float filter_v(int k) { return k < 31 ? max(exp(float(k * k) * (-8.0 / 961.0)) - 3.3546263e-4, 0.0) : 0.0; }

// P(q): the mass of [0, q], q ≥ 0 in steps.
float filter_p(float q) {
    q = min(q, 31.0);
    int k = min(int(q), 30);
    return g.filter_c[k] + (q - float(k)) * filter_v(k);
}

// The signed mass of [0, z], z in steps (negative for z < 0).
float filter_mass(float z) { return sign(z) * filter_p(abs(z)); }

// P⁻¹(s), s ∈ [0, C_31]: the step k with C_k ≤ s < C_{k+1} (binary search), then linear in it.
float filter_p_inv(float s) {
    int lo = 0, hi = 30;
    while (lo < hi) {
        int mid = (lo + hi + 1) >> 1;
        if (g.filter_c[mid] <= s) lo = mid; else hi = mid - 1;
    }
    return float(lo) + (s - g.filter_c[lo]) / filter_v(lo);
}

// Whether the filter of a pixel centred at c lies wholly on an axis of n pixels (its radius r
// from both edges): the test that picks the alias table, without a division.
bool filter_whole(float c, float n) {
    float r = g.filter_params.y;
    return c >= r && n - c >= r;
}

// The interval (in steps) that the filter of a pixel centred at c keeps on an axis of n pixels.
vec2 filter_interval(float c, float n) {
    if (filter_whole(c, n)) return vec2(-31.0, 31.0);
    float h = g.filter_params.z;
    return vec2(max(-31.0, -c / h), min(31.0, (n - c) / h));
}

// An offset (in steps) drawn from the whole filter: a side from u's first half or second, a step
// from the alias table (bits 0..26: the probability of keeping it, times 2^24; 27..31: the other
// step), and a point uniform in it, from what is left of u (Vose's method reuses the fraction).
float filter_sample_whole(float u) {
    float side = u < 0.5 ? -1.0 : 1.0;
    float x = fract(2.0 * u) * 31.0;
    int j = min(int(x), 30);
    float f = x - float(j);
    uint e = g.filter_alias[j];
    float keep = float(e & 0x7ffffffu) * (1.0 / 16777216.0);
    float q = f < keep ? float(j) + f / keep : float(e >> 27) + (f - keep) / (1.0 - keep);
    return side * min(q, 31.0);
}

// An offset (pixels) drawn from the cut filter of the pixel centred at c on an axis of n pixels:
// the alias table away from the edges, P inverted on the kept interval near them.
float filter_sample_axis(float u, float c, float n) {
    if (filter_whole(c, n)) return filter_sample_whole(u) * g.filter_params.z;
    vec2 iv = filter_interval(c, n);
    float t = mix(filter_mass(iv.x), filter_mass(iv.y), u);
    float z = t >= 0.0 ? filter_p_inv(t) : -filter_p_inv(-t);
    return clamp(z, iv.x, iv.y) * g.filter_params.z;
}

// The cut filter's density (per pixel) at offset o from a centre c on an axis of n pixels: 0 off
// the kept interval (off the film, or past the radius).
float filter_eval_axis(float o, float c, float n) {
    float h = g.filter_params.z, z = o / h;
    vec2 iv = filter_interval(c, n);
    if (!(z >= iv.x && z < iv.y)) return 0.0;
    float mass = filter_whole(c, n) ? 2.0 * g.filter_c[31] : filter_mass(iv.y) - filter_mass(iv.x);
    return filter_v(int(abs(z))) / (h * mass);
}

// An offset from the centre of pixel `px`, drawn from its filter.
vec2 filter_sample(vec2 u, uvec2 px) {
    if (FILTER_GAUSSIAN) {
        vec2 c = vec2(px) + 0.5, n = vec2(g.film.xy);
        return vec2(filter_sample_axis(u.x, c.x, n.x), filter_sample_axis(u.y, c.y, n.y));
    }
    return u - 0.5;
}

// The normalised filter of pixel `px` at offset o (pixels) from its centre: the density that
// filter_sample draws from (bdpt's splat_film takes its two axes apart, row by row;
// renderer/tests/filter_gpu.rs checks it against filter_sample).
float filter_eval(vec2 o, uvec2 px) {
    if (FILTER_GAUSSIAN) {
        vec2 c = vec2(px) + 0.5, n = vec2(g.film.xy);
        return filter_eval_axis(o.x, c.x, n.x) * filter_eval_axis(o.y, c.y, n.y);
    }
    return (o.x >= -0.5 && o.x < 0.5 && o.y >= -0.5 && o.y < 0.5) ? 1.0 : 0.0;
}

#endif
