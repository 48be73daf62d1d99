// vct stage 2 (octree storage): the sparse voxel octree built on the GPU level by level, with no
// CPU round trip between levels (Crassin & Green 2012, "Octree-Based Sparse Voxelization Using
// the GPU Hardware Rasterizer", OpenGL Insights ch. 22): for each depth k, (flag) every fragment
// walks down to its depth-k node and flags it; (alloc) every node of depth k that is flagged
// takes a tile of 8 children from the node pool with one atomic and initialises them; (mark) one
// thread records where depth k+1's nodes lie in the pool. Nodes of one depth are contiguous, so
// the next passes find them from `info.level_start/level_end` without a readback. Modes (flags):
// 0 init, 1 flag, 2 alloc, 3 mark; VP_LEVEL = k.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "vct/common.glsl"

layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

void main() {
    uint gid = LINEAR_GID;
    uint k = VP_LEVEL;
    if (VP_MODE == 0u) {
        // Init: the root alone.
        if (gid != 0u) return;
        info.node_count = 1u;
        info.overflow = 0u;
        info.level_start[0] = 0u;
        info.level_end[0] = 1u;
        vnodes[0] = uvec2(0u, 0u);
    } else if (VP_MODE == 1u) {
        // Flag: the depth-k node above each fragment.
        if (gid >= VP_COUNT) return;
        uvec3 v = unpack_cell(frags[gid].x);
        uint node = octree_find(v >> (vct_levels() - k), k);
        if (node != NONE && (vnodes[node].x & NODE_FLAG) == 0u) atomicOr(vnodes[node].x, NODE_FLAG);
    } else if (VP_MODE == 2u) {
        // Alloc: a tile of 8 children for each flagged node of depth k.
        uint node = info.level_start[k] + gid;
        if (node >= info.level_end[k]) return;
        if ((vnodes[node].x & NODE_FLAG) == 0u) return;
        uint first = atomicAdd(info.node_count, 8u);
        if (first + 8u > P.caps.y) {
            atomicOr(info.overflow, 1u);
            vnodes[node].x = 0u;
            return;
        }
        vnodes[node].x = first;
        uvec3 c = unpack_cell(vnodes[node].y);
        for (uint o = 0u; o < 8u; ++o) vnodes[first + o] = uvec2(0u, pack_cell(2u * c + octant_bits(o)));
    } else {
        // Mark: depth k+1 is what alloc added after depth k.
        if (gid != 0u) return;
        info.level_start[k + 1u] = info.level_end[k];
        info.level_end[k + 1u] = min(info.node_count, P.caps.y);
    }
}
