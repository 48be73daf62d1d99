// vct stage 2c: averages the fragment sums of every slot into the packed voxel attributes
// (albedo and opacity, unit normal and two-sidedness, mean surface point) and the emission,
// counts the occupied voxels and marks them in the octree's occupancy mask (common.glsl). A
// voxel touched by any surface is opaque (opacity 1).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "vct/common.glsl"

layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

void main() {
    uint slot = LINEAR_GID;
    if (slot >= VP_COUNT) return;
    uint base = slot * ACC_WORDS;
    uint count = acc[base + 12u];
    if (count == 0u) {
        attr[slot] = uvec4(0u);
        emit[slot] = uvec2(0u);
        return;
    }
    float inv = 1.0 / float(count);
    vec3 albedo, le, n, off;
    for (int i = 0; i < 3; ++i) {
        albedo[i] = float(acc[base + uint(i)]) * inv / 65535.0;
        le[i] = float(acc[base + 3u + uint(i)]) * inv / 256.0;
        n[i] = float(int(acc[base + 6u + uint(i)]));
        off[i] = float(int(acc[base + 9u + uint(i)])) * inv / 32767.0;
    }
    float nl = length(n);
    n = nl > 1e-3 * float(count) * 32767.0 ? n / nl : vec3(0.0);
    float two_sided = (acc[base + 13u] & 1u) != 0u ? 1.0 : 0.0;
    attr[slot] = uvec4(packUnorm4x8(vec4(albedo, 1.0)), packSnorm4x8(vec4(n, two_sided)),
                       packSnorm2x16(off.xy), packSnorm2x16(vec2(off.z, 0.0)));
    emit[slot] = pack_h4(vec4(le, 1.0));
    atomicAdd(info.voxel_count, 1u);
    if (vct_octree() && P.caps.w != 0u) {
        uvec2 q = occupancy_place(slot_cell(slot));
        if (q.y < 32u) atomicOr(vnodes[q.x].x, 1u << q.y);
        else atomicOr(vnodes[q.x].y, 1u << (q.y - 32u));
    }
}
