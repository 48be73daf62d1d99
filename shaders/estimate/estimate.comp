// The error estimate of an accumulation on the GPU (renderer/src/render/estimate_gpu.rs): the
// formula of renderer/src/metrics/estimate.rs (the CPU version, its single definition; a test
// checks the two agree), reduced to one sum and count so the host reads 16 bytes, not the film.
//
//   stage 0: one thread per pixel forms the full value F, the 3×3 box mean F̄ of F, and the
//            halves A (even samples) and B (odd samples) as the integrator resolves them
//            (ESTIMATE_SPLATS: bdpt's light-tracing splats / (pixels · spp), float or 64-bit
//            fixed point), then per channel (A − B)² n_a n_b / N² / (min(F², F̄²) + 0.01);
//            each workgroup sums its terms and writes (sum, count) to B_ESTIMATE_PARTIALS;
//   stage 1: one workgroup sums the partials (compensated) into B_ESTIMATE_RESULT.
// No atomics: the order of the additions is fixed, so the result is the same on every run.
#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_scalar_block_layout : require
#include "common/constants.glsl"

layout(local_size_x = 16, local_size_y = 16, local_size_z = 1) in;

// Mirrors GpuEstimatePush (renderer/src/layout.rs).
layout(push_constant, scalar) uniform Push {
    uint width;
    uint height;
    uint spp;
    uint stage;
    uint partials;
    uint pad0, pad1, pad2;
} pc;

layout(set = 0, binding = B_ACCUM, scalar) readonly buffer Accum { vec4 accum[]; };
layout(set = 0, binding = B_ACCUM_ODD, scalar) readonly buffer AccumOdd { vec4 accum_odd[]; };
#ifdef ESTIMATE_SPLATS
#ifdef ESTIMATE_FIXED_SPLATS
// Per pixel two entries: the low words (r, g, b, −), then the high words (bdpt/splat.glsl).
layout(set = 0, binding = B_SPLAT, scalar) readonly buffer Splat { uvec4 splat[]; };
layout(set = 0, binding = B_SPLAT_ODD, scalar) readonly buffer SplatOdd { uvec4 splat_odd[]; };
#else
layout(set = 0, binding = B_SPLAT, scalar) readonly buffer Splat { vec4 splat[]; };
layout(set = 0, binding = B_SPLAT_ODD, scalar) readonly buffer SplatOdd { vec4 splat_odd[]; };
#endif
#endif

struct Partial { float sum; uint count; };
layout(set = 0, binding = B_ESTIMATE_PARTIALS, scalar) buffer Partials { Partial partials[]; };
// Mirrors GpuEstimateResult.
layout(set = 0, binding = B_ESTIMATE_RESULT, scalar) buffer Result {
    float sum;
    uint count;
    uint pad3, pad4;
} result;

const float EPSILON = 0.01;

shared float s_sum[256];
shared uint s_count[256];

// Summed camera samples over their count (0 without samples), as mean_of_accumulation.
vec3 camera_mean(vec4 s) { return s.w > 0.0 ? s.rgb / s.w : vec3(0.0); }

#ifdef ESTIMATE_SPLATS
#ifdef ESTIMATE_FIXED_SPLATS
vec3 fixed_value(uvec4 lo, uvec4 hi) {
    return (vec3(hi.rgb) * exp2(float(32 - ESTIMATE_FRAC_BITS)) + vec3(lo.rgb) * exp2(-float(ESTIMATE_FRAC_BITS)));
}
vec3 splat_total(uint i) { return fixed_value(splat[2u * i], splat[2u * i + 1u]); }
vec3 splat_of_odd(uint i) { return fixed_value(splat_odd[2u * i], splat_odd[2u * i + 1u]); }
// The even samples' splats: the total minus the odd share, as 64-bit integers.
vec3 splat_of_even(uint i) {
    uvec4 borrow;
    uvec4 lo = usubBorrow(splat[2u * i], splat_odd[2u * i], borrow);
    uvec4 hi = splat[2u * i + 1u] - splat_odd[2u * i + 1u] - borrow;
    return fixed_value(lo, hi);
}
#else
vec3 splat_total(uint i) { return splat[i].rgb; }
vec3 splat_of_odd(uint i) { return splat_odd[i].rgb; }
vec3 splat_of_even(uint i) { return splat[i].rgb - splat_odd[i].rgb; }
#endif
// A splat sum over the paths of `spp` samples per pixel (0 without samples).
vec3 light(vec3 s, uint spp) {
    float paths = float(pc.width * pc.height) * float(spp);
    return paths > 0.0 ? s / paths : vec3(0.0);
}
#endif

// The image's value at pixel i (its resolver).
vec3 full_value(uint i) {
    vec3 v = camera_mean(accum[i]);
#ifdef ESTIMATE_SPLATS
    v += light(splat_total(i), pc.spp);
#endif
    return v;
}

bool finite(float x) { return !(isnan(x) || isinf(x)); }

// The sum of the pixel's three terms and how many (3, or 0 when the pixel is skipped).
void pixel_terms(uvec2 p, out float sum, out uint count) {
    sum = 0.0;
    count = 0u;
    uint i = p.y * pc.width + p.x;
    // Step 1: the sample counts of the halves.
    vec4 t = accum[i];
    vec4 o = accum_odd[i];
    float n = t.w, n_b = o.w, n_a = n - n_b;
    if (!(n_a >= 1.0 && n_b >= 1.0)) return;
    float weight = n_a * n_b / (n * n);
    // Step 2: the halves' values, resolved as the image.
    vec3 a = camera_mean(t - o);
    vec3 b = camera_mean(o);
#ifdef ESTIMATE_SPLATS
    a += light(splat_of_even(i), pc.spp - pc.spp / 2u);
    b += light(splat_of_odd(i), pc.spp / 2u);
#endif
    // Step 3: F and its 3×3 box mean over the neighbours inside the image (non-finite
    // values count as 0).
    vec3 f = full_value(i);
    vec3 box = vec3(0.0);
    float k = 0.0;
    int x0 = max(int(p.x) - 1, 0), x1 = min(int(p.x) + 1, int(pc.width) - 1);
    int y0 = max(int(p.y) - 1, 0), y1 = min(int(p.y) + 1, int(pc.height) - 1);
    for (int y = y0; y <= y1; ++y) {
        for (int x = x0; x <= x1; ++x) {
            vec3 v = full_value(uint(y) * pc.width + uint(x));
            for (int c = 0; c < 3; ++c) box[c] += finite(v[c]) ? v[c] : 0.0;
            k += 1.0;
        }
    }
    box /= k;
    // Step 4: per channel, the squared difference of the halves scaled to the variance of
    // the full mean, over the smaller of the pixel's and its neighbourhood's value squared.
    vec3 term;
    for (int c = 0; c < 3; ++c) {
        float mu2 = min(f[c] * f[c], box[c] * box[c]);
        float d = a[c] - b[c];
        term[c] = d * d * weight / (mu2 + EPSILON);
    }
    if (finite(term.x) && finite(term.y) && finite(term.z)) {
        sum = term.x + term.y + term.z;
        count = 3u;
    }
}

// Sums s_sum and s_count over the workgroup into entry 0.
void reduce_shared(uint lid) {
    for (uint stride = 128u; stride > 0u; stride >>= 1u) {
        barrier();
        if (lid < stride) {
            s_sum[lid] += s_sum[lid + stride];
            s_count[lid] += s_count[lid + stride];
        }
    }
    barrier();
}

void main() {
    uint lid = gl_LocalInvocationIndex;
    if (pc.stage == 0u) {
        float sum = 0.0;
        uint count = 0u;
        uvec2 p = gl_GlobalInvocationID.xy;
        if (p.x < pc.width && p.y < pc.height) pixel_terms(p, sum, count);
        s_sum[lid] = sum;
        s_count[lid] = count;
        reduce_shared(lid);
        if (lid == 0u) {
            uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
            partials[group] = Partial(s_sum[0], s_count[0]);
        }
    } else {
        // Kahan summation of this thread's share of the partials, then the tree.
        precise float sum = 0.0, lost = 0.0;
        uint count = 0u;
        for (uint j = lid; j < pc.partials; j += 256u) {
            precise float y = partials[j].sum - lost;
            precise float s = sum + y;
            lost = (s - sum) - y;
            sum = s;
            count += partials[j].count;
        }
        s_sum[lid] = sum;
        s_count[lid] = count;
        reduce_shared(lid);
        if (lid == 0u) {
            result.sum = s_sum[0];
            result.count = s_count[0];
        }
    }
}
