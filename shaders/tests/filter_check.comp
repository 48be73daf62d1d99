#version 460
//! Pixel filter check, for a GPU unit test (renderer/tests/filter_gpu.rs): draws offsets with
//! common/filter.glsl's filter_sample and evaluates filter_eval, for one pixel of the film that
//! the globals describe, one invocation per item; the host bins the samples against the density.
//!
//! Buffers (set 0): binding B_GLOBALS, the scene's globals (the film and the filter's tables);
//! binding 60, Inputs: vec4 inputs[count]; binding 61, Outputs: vec4 outputs[count].
//! Push constants: the kernels' (common/types.glsl), read here as flags = mode, spp = count and
//! (seed_lo, seed_hi) = the pixel.
//! Modes (input → output):
//!   MODE_SAMPLE  u.xy → (filter_sample(u, pixel), 0, 0)
//!   MODE_EVAL    o.xy → (filter_eval(o, pixel), 0, 0, 0)
#extension GL_GOOGLE_include_directive : require

#include "common/filter.glsl"

#define MODE_SAMPLE 0u
#define MODE_EVAL 1u

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 60) readonly buffer Inputs { vec4 inputs[]; };
layout(std430, set = 0, binding = 61) writeonly buffer Outputs { vec4 outputs[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.spp) return;
    uvec2 pixel = uvec2(pc.seed_lo, pc.seed_hi);
    vec2 v = inputs[i].xy;
    if (pc.flags == MODE_SAMPLE) {
        outputs[i] = vec4(filter_sample(v, pixel), 0.0, 0.0);
    } else {
        outputs[i] = vec4(filter_eval(v, pixel), 0.0, 0.0, 0.0);
    }
}
