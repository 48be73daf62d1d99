// vct debug kernel: samples the filtered volume at given points, levels and directions
// (probe[3i] = (grid position, level), probe[3i+1] = direction, probe[3i+2] ← value), so the
// tests can check that the octree and the dense storage hold the same values.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "vct/common.glsl"
#include "vct/volume.glsl"

layout(set = 0, binding = B_VCT_PROBE, scalar) buffer VctProbe { vec4 probe[]; };
layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

void main() {
    uint i = LINEAR_GID;
    if (i >= VP_COUNT) return;
    vec4 a = probe[3u * i];
    vec3 d = probe[3u * i + 1u].xyz;
    probe[3u * i + 2u] = a.w < 0.0 ? vol_sample(a.xyz, uint(-a.w - 1.0), d) : vol_sample_lod(a.xyz, a.w, d);
}
