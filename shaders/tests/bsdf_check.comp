#version 460
//! BSDF consistency check, for a GPU unit test: for every (material case, wo) pair, draws
//! N = 64 · samples_per_thread low-discrepancy samples through bsdf_sample and reports a Monte Carlo
//! albedo, sample/eval/pdf consistency, NaN/Inf counts and the integral of bsdf_pdf over the sphere.
//! Method after pbrt-v4's BSDF tests and Mitsuba 3's chi² BSDF tests (reduced to moments).
//!
//! Dispatch: one workgroup of 64 threads per (case, wo) pair, pair = case · num_wos + wo_index,
//! workgroup index = gl_WorkGroupID.x + gl_WorkGroupID.y · gl_NumWorkGroups.x (so more than 65535
//! pairs can be split over y); workgroups past num_cases · num_wos do nothing.
//!
//! Buffers (set 0, std430, plain vec4 arrays; integers are stored as exact small floats):
//!   binding 0, Cases:   7 vec4 per case c, at cases[7c + k]:
//!     k = 0: (type, flags, mode, unused)    type: MAT_*, flags: MATF_* bits, mode: TRANSPORT_*
//!     k = 1: (c0.r, c0.g, c0.b, unused)
//!     k = 2: (c1.r, c1.g, c1.b, unused)
//!     k = 3: (c2.r, c2.g, c2.b, unused)
//!     k = 4: (s[0], s[1], s[2], s[3])
//!     k = 5: (s[4], s[5], s[6], s[7])
//!     k = 6: (s[8], s[9], s[10], s[11])
//!   binding 1, Wos:     1 vec4 per wo: (wo.x, wo.y, wo.z, unused), a unit vector in the local frame.
//!   binding 2, Results: 4 vec4 per pair p, at results[4p + k]:
//!     k = 0: (Σ weight over non-delta samples / N  [rgb: MC albedo of the non-delta lobes],
//!             max relative mismatch between s.weight and bsdf_eval / bsdf_pdf at s.wi)
//!     k = 1: (Σ weight over delta samples / N      [rgb: albedo of the delta lobes],
//!             max relative mismatch between s.pdf and bsdf_pdf(wo, s.wi), non-delta samples)
//!     k = 2: (number of NaN/Inf values seen in any output,
//!             4π · mean of bsdf_pdf(wo, d) over uniform sphere directions d  [≈ ∫ pdf dω],
//!             fraction of samples that were delta, fraction of samples where bsdf_sample failed)
//!     k = 3: (fraction of samples whose weight mismatch exceeds 1e-3,
//!             fraction of samples whose pdf mismatch exceeds 1e-3, 0, 0)
//!   The total albedo is results[4p].rgb + results[4p+1].rgb; for a consistent BSDF
//!   results[4p+2].y ≈ 1 − delta fraction − failed fraction. Max mismatches can be large for
//!   isolated samples at grazing wo or for extremely sharp lobes, where a threshold test in the BSDF
//!   may round differently at separately compiled call sites; the k = 3 fractions show how rare.
//! Push constants: num_cases, num_wos, samples_per_thread, seed.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require

#include "common/bsdf/bsdf.glsl"

layout(local_size_x = 64) in;

layout(push_constant) uniform Push {
    uint num_cases;
    uint num_wos;
    uint samples_per_thread;
    uint seed;
} pc;

layout(std430, set = 0, binding = 0) readonly buffer Cases { vec4 cases[]; };
layout(std430, set = 0, binding = 1) readonly buffer Wos { vec4 wos[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Results { vec4 results[]; };

shared vec4 sh_a[64];
shared vec4 sh_b[64];
shared vec4 sh_c[64];
shared vec2 sh_d[64];

/// PCG hash (Jarzynski & Olano 2020).
uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

float u01(uint x) { return float(x >> 8) * (1.0 / 16777216.0); }

float radical_inverse_2(uint i) { return float(bitfieldReverse(i) >> 8) * (1.0 / 16777216.0); }

float radical_inverse_3(uint i) {
    float inv_base = 1.0 / 3.0, f = inv_base, r = 0.0;
    while (i > 0u) {
        r += f * float(i % 3u);
        i /= 3u;
        f *= inv_base;
    }
    return r;
}

/// Cranley-Patterson rotation into [0, 1).
vec3 shift01(vec3 u, vec3 shift) { return min(fract(u + shift), vec3(0.99999994)); }

uint count_bad(vec3 v) { return (any(isnan(v)) || any(isinf(v))) ? 1u : 0u; }
uint count_bad(float x) { return (isnan(x) || isinf(x)) ? 1u : 0u; }

/// max over channels of |a − b| / max(|a|, |b|) (differences below 1e-6 absolute count as 0).
float rel_mismatch(vec3 a, vec3 b) {
    vec3 d = abs(a - b);
    vec3 s = max(max(abs(a), abs(b)), vec3(1e-6));
    return max_comp(d / s);
}

SurfaceParams load_case(uint c) {
    SurfaceParams m;
    vec4 h = cases[7u * c + 0u];
    m.type = uint(h.x + 0.5);
    m.flags = uint(h.y + 0.5);
    m.c0 = cases[7u * c + 1u].xyz;
    m.c1 = cases[7u * c + 2u].xyz;
    m.c2 = cases[7u * c + 3u].xyz;
    vec4 s0 = cases[7u * c + 4u], s1 = cases[7u * c + 5u], s2 = cases[7u * c + 6u];
    m.s[0] = s0.x; m.s[1] = s0.y; m.s[2] = s0.z; m.s[3] = s0.w;
    m.s[4] = s1.x; m.s[5] = s1.y; m.s[6] = s1.z; m.s[7] = s1.w;
    m.s[8] = s2.x; m.s[9] = s2.y; m.s[10] = s2.z; m.s[11] = s2.w;
    return m;
}

void main() {
    uint pair = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    uint num_pairs = pc.num_cases * pc.num_wos;
    if (pair >= num_pairs) return;   // uniform over the workgroup
    uint case_index = pair / pc.num_wos;
    uint wo_index = pair % pc.num_wos;
    uint lid = gl_LocalInvocationID.x;

    SurfaceParams m = load_case(case_index);
    uint mode = uint(cases[7u * case_index].z + 0.5);
    vec3 wo = wos[wo_index].xyz;

    // Per-pair random shifts of the 3D Hammersley point set
    uint h0 = pcg_hash(pair ^ pcg_hash(pc.seed));
    uint h1 = pcg_hash(h0), h2 = pcg_hash(h1), h3 = pcg_hash(h2), h4 = pcg_hash(h3), h5 = pcg_hash(h4);
    vec3 shift_sample = vec3(u01(h0), u01(h1), u01(h2));
    vec3 shift_sphere = vec3(u01(h3), u01(h4), u01(h5));

    uint spt = max(pc.samples_per_thread, 1u);
    uint n_total = 64u * spt;
    float inv_n = 1.0 / float(n_total);

    vec3 weight_sum = vec3(0.0), delta_sum = vec3(0.0);
    float mismatch_weight = 0.0, mismatch_pdf = 0.0;
    uint bad = 0u, delta_count = 0u, fail_count = 0u;
    uint mismatch_weight_count = 0u, mismatch_pdf_count = 0u;
    float pdf_integral = 0.0;

    if (lid == 0u) bad += count_bad(bsdf_albedo_hint(m));

    for (uint j = 0u; j < spt; ++j) {
        uint i = lid * spt + j;
        // Stratified (3D Hammersley) uniforms: u.x picks the lobe, u.yz the direction
        vec3 u = shift01(vec3((float(i) + 0.5) * inv_n, radical_inverse_2(i), radical_inverse_3(i)), shift_sample);

        BsdfSample s;
        bool ok = bsdf_sample(m, wo, u, mode, s);
        bad += count_bad(s.weight) + count_bad(s.pdf) + count_bad(s.wi) + count_bad(s.eta);
        if (!ok) {
            fail_count += 1u;
        } else if ((s.flags & BSDF_DELTA) != 0u) {
            delta_count += 1u;
            delta_sum += s.weight;
        } else {
            weight_sum += s.weight;
            vec3 f = bsdf_eval(m, wo, s.wi, mode);
            float p = bsdf_pdf(m, wo, s.wi);
            bad += count_bad(f) + count_bad(p);
            float mw = 1.0, mp = 1.0;
            if (p > 0.0) {
                mw = rel_mismatch(s.weight, f / p);
                mp = abs(s.pdf - p) / max(max(s.pdf, p), 1e-20);
            }
            mismatch_weight = max(mismatch_weight, mw);
            mismatch_pdf = max(mismatch_pdf, mp);
            mismatch_weight_count += mw > 1e-3 ? 1u : 0u;
            mismatch_pdf_count += mp > 1e-3 ? 1u : 0u;
        }

        // ∫ pdf dω by uniform sphere sampling (density 1/4π)
        vec3 us = shift01(vec3((float(i) + 0.5) * inv_n, radical_inverse_2(i), 0.0), shift_sphere);
        vec3 d = sample_uniform_sphere(us.xy);
        float pd = bsdf_pdf(m, wo, d);
        vec3 fd = bsdf_eval(m, wo, d, mode);
        bad += count_bad(pd) + count_bad(fd);
        pdf_integral += pd * (4.0 * PI);
    }

    sh_a[lid] = vec4(weight_sum, mismatch_weight);
    sh_b[lid] = vec4(delta_sum, mismatch_pdf);
    sh_c[lid] = vec4(float(bad), pdf_integral, float(delta_count), float(fail_count));
    sh_d[lid] = vec2(float(mismatch_weight_count), float(mismatch_pdf_count));
    barrier();

    // Tree reduction: sums for the accumulators, max for the mismatches
    [[unroll]] for (uint stride = 32u; stride > 0u; stride >>= 1u) {
        if (lid < stride) {
            vec4 a0 = sh_a[lid], a1 = sh_a[lid + stride];
            vec4 b0 = sh_b[lid], b1 = sh_b[lid + stride];
            sh_a[lid] = vec4(a0.xyz + a1.xyz, max(a0.w, a1.w));
            sh_b[lid] = vec4(b0.xyz + b1.xyz, max(b0.w, b1.w));
            sh_c[lid] = sh_c[lid] + sh_c[lid + stride];
            sh_d[lid] = sh_d[lid] + sh_d[lid + stride];
        }
        barrier();
    }

    if (lid == 0u) {
        vec4 a = sh_a[0], b = sh_b[0], c = sh_c[0];
        vec2 d = sh_d[0];
        results[4u * pair + 0u] = vec4(a.xyz * inv_n, a.w);
        results[4u * pair + 1u] = vec4(b.xyz * inv_n, b.w);
        results[4u * pair + 2u] = vec4(c.x, c.y * inv_n, c.z * inv_n, c.w * inv_n);
        results[4u * pair + 3u] = vec4(d * inv_n, 0.0, 0.0);
    }
}
