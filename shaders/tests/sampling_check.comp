#version 460
//! Sampling and RNG checks, for a GPU unit test (renderer/tests/sampling_gpu.rs): runs the warps,
//! densities and the power heuristic of common/sampling.glsl and the counter-based generator of
//! common/rng.glsl on the GPU, one invocation per item; the host bins the results and runs
//! chi-square tests (after Mitsuba 3's `ChiSquareTest`, reduced to fixed binnings).
//!
//! Buffers (set 0, std430):
//!   binding 0, Inputs:  vec4 inputs[count]  (unused by MODE_RNG)
//!   binding 1, Outputs: vec4 outputs[...]   (count entries; count · dims for MODE_RNG)
//! Push constants: mode, count, a, b, param, seed_lo, seed_hi, unused.
//! Modes (input → output):
//!   MODE_COSINE_HEMISPHERE  u.xy → (sample_cosine_hemisphere(u), pdf_cosine_hemisphere(w))
//!   MODE_UNIFORM_SPHERE     u.xy → (sample_uniform_sphere(u), 0)
//!   MODE_UNIFORM_CONE       u.xy → (sample_uniform_cone(u, param), pdf_uniform_cone(param))
//!   MODE_DISK_CONCENTRIC    u.xy → (sample_uniform_disk_concentric(u), 0, 0)
//!   MODE_TRIANGLE           u.xy → (sample_uniform_triangle(u), 0, 0)
//!   MODE_PDF_COSINE         w.xyz → (pdf_cosine_hemisphere(w), 0, 0, 0)
//!   MODE_POWER_HEURISTIC    (f, g) → (power_heuristic(f, g), power_heuristic(g, f), 0, 0)
//!   MODE_RNG                invocation i: pixel = i % a, sample = i / a; for d < b:
//!                           outputs[i · b + d] = rng_next4 of rng_init(pixel, sample, seed_lo,
//!                           seed_hi) after d calls (so count = pixels · samples, dims = b)
#extension GL_GOOGLE_include_directive : require

#include "common/sampling.glsl"
#include "common/rng.glsl"

#define MODE_COSINE_HEMISPHERE 0u
#define MODE_UNIFORM_SPHERE 1u
#define MODE_UNIFORM_CONE 2u
#define MODE_DISK_CONCENTRIC 3u
#define MODE_TRIANGLE 4u
#define MODE_PDF_COSINE 5u
#define MODE_POWER_HEURISTIC 6u
#define MODE_RNG 7u

layout(local_size_x = 64) in;

layout(push_constant) uniform Push {
    uint mode;
    uint count;
    uint a;
    uint b;
    float param;
    uint seed_lo;
    uint seed_hi;
    uint unused;
} pc;

layout(std430, set = 0, binding = 0) readonly buffer Inputs { vec4 inputs[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Outputs { vec4 outputs[]; };

void main() {
    uint i = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    if (i >= pc.count) return;

    if (pc.mode == MODE_RNG) {
        uint pixel = i % max(pc.a, 1u);
        uint sample_index = i / max(pc.a, 1u);
        Rng rng = rng_init(pixel, sample_index, pc.seed_lo, pc.seed_hi);
        for (uint d = 0u; d < pc.b; ++d) outputs[i * pc.b + d] = rng_next4(rng);
        return;
    }

    vec4 in_v = inputs[i];
    vec4 out_v = vec4(0.0);
    switch (pc.mode) {
        case MODE_COSINE_HEMISPHERE: {
            vec3 w = sample_cosine_hemisphere(in_v.xy);
            out_v = vec4(w, pdf_cosine_hemisphere(w));
            break;
        }
        case MODE_UNIFORM_SPHERE: out_v = vec4(sample_uniform_sphere(in_v.xy), 0.0); break;
        case MODE_UNIFORM_CONE:
            out_v = vec4(sample_uniform_cone(in_v.xy, pc.param), pdf_uniform_cone(pc.param));
            break;
        case MODE_DISK_CONCENTRIC: out_v = vec4(sample_uniform_disk_concentric(in_v.xy), 0.0, 0.0); break;
        case MODE_TRIANGLE: out_v = vec4(sample_uniform_triangle(in_v.xy), 0.0, 0.0); break;
        case MODE_PDF_COSINE: out_v = vec4(pdf_cosine_hemisphere(in_v.xyz), 0.0, 0.0, 0.0); break;
        case MODE_POWER_HEURISTIC:
            out_v = vec4(power_heuristic(in_v.x, in_v.y), power_heuristic(in_v.y, in_v.x), 0.0, 0.0);
            break;
        default: break;
    }
    outputs[i] = out_v;
}
