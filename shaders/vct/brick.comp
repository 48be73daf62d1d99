// vct stage 3 (octree storage): the brick pool. The brick of a node at depth k holds level
// m = D−1−k: the 2×2×2 cells of that level inside the node (brick index 0..1 per axis) and, at
// index 2, the first cells of the +x/+y/+z neighbours (border transfer), so that trilinear
// interpolation needs one brick: a lookup at a point finds the node holding the lower corner of
// its 2×2×2 neighbourhood and reads all eight samples from its brick. Sample positions are cell
// centres, exactly those of the dense storage, so both give the same filtered values.
// Modes (flags): 0 leaf bricks (depth D−1: the slots of the node's voxels and border, so level 0
// is read from the voxels' own two-sided radiance as in dense storage),
// 1 inner samples of depth k from the children's bricks (anisotropic filtering), 2 border
// samples of depth k from the neighbours' inner samples. One thread per (node, brick sample).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "vct/common.glsl"
#include "vct/aniso.glsl"

layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

uint brick_index(uvec3 i) { return i.x + 3u * i.y + 9u * i.z; }

void main() {
    uint gid = LINEAR_GID;
    if (gid >= VP_COUNT) return;
    uint D = vct_levels();
    uint k = VP_LEVEL;
    uint leaf_k = D - 1u;
    if (VP_MODE == 0u) {
        // Leaf bricks: radiance of the voxels 2c + i, i in {0,1,2}³.
        uint node = info.level_start[leaf_k] + gid / 27u;
        uint s = gid % 27u;
        uvec3 i = uvec3(s % 3u, (s / 3u) % 3u, s / 9u);
        uvec3 v = 2u * unpack_cell(vnodes[node].y) + i;
        uint slot = NONE;
        if (all(lessThan(v, uvec3(vct_res())))) slot = voxel_slot(v);
        leaf[(node - info.level_start[leaf_k]) * 27u + s] = slot;
        return;
    }
    uint m = D - 1u - k;
    if (VP_MODE == 1u) {
        // Inner sample o of a depth-k node: the anisotropic filter of child o's eight inner
        // samples (level m − 1).
        uint node = info.level_start[k] + gid / 8u;
        uint o = gid % 8u;
        uint child = vnodes[node].x & ~NODE_FLAG;
        vec4 outv[6];
        if (child == 0u) {
            for (uint d = 0u; d < 6u; ++d) outv[d] = vec4(0.0);
        } else {
            uint cn = child + o;
            vec4 ch[8][6];
            for (uint co = 0u; co < 8u; ++co) {
                uint s = brick_index(octant_bits(co));
                if (m == 1u) {
                    uint slot = leaf[(cn - info.level_start[leaf_k]) * 27u + s];
                    for (uint d = 0u; d < 6u; ++d) ch[co][d] = slot == NONE ? vec4(0.0) : level0_value(slot, d);
                } else {
                    for (uint d = 0u; d < 6u; ++d) ch[co][d] = unpack_h4(mip[(cn * 27u + s) * 6u + d]);
                }
            }
            aniso_filter(ch, outv);
        }
        uint s = brick_index(octant_bits(o));
        for (uint d = 0u; d < 6u; ++d) mip[(node * 27u + s) * 6u + d] = pack_h4(outv[d]);
        return;
    }
    // Border: samples with an index 2 copy the neighbour's inner sample of the same cell.
    uint node = info.level_start[k] + gid / 27u;
    uint s = gid % 27u;
    uvec3 i = uvec3(s % 3u, (s / 3u) % 3u, s / 9u);
    if (all(lessThan(i, uvec3(2u)))) return;
    uvec3 cell = 2u * unpack_cell(vnodes[node].y) + i;
    uint n = vct_res() >> m;
    uint src = NONE;
    if (all(lessThan(cell, uvec3(n)))) src = octree_find(cell >> 1u, k);
    uint ss = brick_index(cell & 1u);
    for (uint d = 0u; d < 6u; ++d)
        mip[(node * 27u + s) * 6u + d] = src == NONE ? uvec2(0u) : mip[(src * 27u + ss) * 6u + d];
}
