#version 460
//! Texture lookup check, for a GPU unit test (renderer/tests/texture_gpu.rs): evaluates
//! common/texture.glsl's texture_eval at given uvs, one invocation per item.
//!
//! Buffers (set 0): bindings B_TEXTURES and B_TEXELS, the textures; binding 60, Inputs:
//! vec4 inputs[count] = (u, v, texture index, 0); binding 61, Outputs: vec4 outputs[count] ←
//! texture_eval. Push constants: the kernels' (common/types.glsl), spp = count.
#extension GL_GOOGLE_include_directive : require

#include "common/texture.glsl"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 60) readonly buffer Inputs { vec4 inputs[]; };
layout(std430, set = 0, binding = 61) writeonly buffer Outputs { vec4 outputs[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.spp) return;
    vec4 a = inputs[i];
    outputs[i] = texture_eval(uint(a.z), a.xy);
}
