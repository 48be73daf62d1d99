// Sampling the filtered voxel volume, the same way for both storages: trilinear interpolation
// by hand (storage buffers only, no samplers) between the cell centres of one level, and linear
// between two levels. Every level, 0 included (the two sides of each voxel's surface), shows the
// cone's direction the d²-weighted mix of its three visible directional values. Outside the grid everything is empty.
// Dense: cells are read directly. Octree: the node holding the lower corner of the 2×2×2
// neighbourhood is found by a walk from the root and all eight samples come from its brick
// (brick.comp); where that node does not exist (empty space) each corner is looked up alone.
#ifndef VCT_VOLUME_GLSL
#define VCT_VOLUME_GLSL
#include "vct/common.glsl"

// The six directional values at `at` as seen along d: only the three faces d shows are read
// (combine_dirs' choice, made before the loads).
vec4 mip_dir(uint at, vec3 d) {
    vec3 w = d * d;
    uvec3 face = uvec3(d.x >= 0.0 ? 0u : 1u, d.y >= 0.0 ? 2u : 3u, d.z >= 0.0 ? 4u : 5u);
    return w.x * unpack_h4(mip[at + face.x]) + w.y * unpack_h4(mip[at + face.y]) +
           w.z * unpack_h4(mip[at + face.z]);
}

// Sample i (0..2 per axis) of the brick of `node` (depth D−1−m).
vec4 brick_value(uint node, uint m, uvec3 i, vec3 d) {
    uint s = i.x + 3u * i.y + 9u * i.z;
    if (m == 0u) {
        uint slot = leaf[(node - info.level_start[vct_levels() - 1u]) * 27u + s];
        return slot == NONE ? vec4(0.0) : level0_dir(slot, d);
    }
    return mip_dir((node * 27u + s) * 6u, d);
}

// Cell c of level m (inside the grid) as seen along d.
vec4 cell_value(uvec3 c, uint m, vec3 d) {
    if (vct_octree()) {
        uint node = octree_find(c >> 1u, vct_levels() - 1u - m);
        return node == NONE ? vec4(0.0) : brick_value(node, m, c & 1u, d);
    }
    uint n = vct_res() >> m;
    uint lin = c.x + n * (c.y + n * c.z);
    if (m == 0u) return level0_dir(lin, d);
    return mip_dir((P.mip_offset[m] + lin) * 6u, d);
}

// The slot of occupied level-0 voxel c (inside the grid), or NONE.
uint occupied_slot(uvec3 c) {
    uint slot = voxel_slot(c);
    if (slot == NONE) return NONE;
    return unpackUnorm4x8(attr[slot].x).a > 0.5 ? slot : NONE;
}

// occupied_slot for a walk along a line: `last` caches the last leaf-parent cell looked up
// and its node (octree), so consecutive half-voxel steps inside one 2×2×2 block walk the tree
// once. Start with last = uvec2(NONE).
uint occupied_slot_walk(uvec3 c, inout uvec2 last) {
    if (!vct_octree()) return occupied_slot(c);
    // Empty voxels from the occupancy mask, one load; only occupied ones walk the tree.
    if (P.caps.w != 0u) {
        uvec2 q = occupancy_place(c);
        if ((vnodes[q.x][q.y >> 5u] & (1u << (q.y & 31u))) == 0u) return NONE;
    }
    uint key = pack_cell(c >> 1u);
    if (key != last.x) {
        last = uvec2(key, octree_find(c >> 1u, vct_levels() - 1u));
    }
    if (last.y == NONE) return NONE;
    uint slot = (last.y - info.level_start[vct_levels() - 1u]) * 8u + octant(c & 1u);
    return unpackUnorm4x8(attr[slot].x).a > 0.5 ? slot : NONE;
}

// Trilinear sample of level m at grid position pg (level-0 voxel units).
vec4 vol_sample(vec3 pg, uint m, vec3 d) {
    int n = int(vct_res() >> m);
    vec3 q = pg / float(1u << m) - 0.5;
    vec3 bf = floor(q);
    vec3 f = q - bf;
    ivec3 base = ivec3(bf);
    if (any(lessThan(base, ivec3(-1))) || any(greaterThanEqual(base, ivec3(n)))) return vec4(0.0);
    uint node = NONE;
    ivec3 nb = max(base, ivec3(0)) >> 1;
    if (vct_octree()) node = octree_find(uvec3(nb), vct_levels() - 1u - m);
    vec4 v[8];
    for (uint o = 0u; o < 8u; ++o) {
        ivec3 c = base + ivec3(octant_bits(o));
        v[o] = vec4(0.0);
        if (any(lessThan(c, ivec3(0))) || any(greaterThanEqual(c, ivec3(n)))) continue;
        if (vct_octree() && node != NONE) v[o] = brick_value(node, m, uvec3(c - 2 * nb), d);
        else if (vct_octree() && (c >> 1) == nb) continue; // the missing node's own cells are empty
        else v[o] = cell_value(uvec3(c), m, d);
    }
    vec4 x00 = mix(v[0], v[1], f.x), x10 = mix(v[2], v[3], f.x);
    vec4 x01 = mix(v[4], v[5], f.x), x11 = mix(v[6], v[7], f.x);
    return mix(mix(x00, x10, f.y), mix(x01, x11, f.y), f.z);
}

// Sample at a fractional level (linear between the two nearest levels).
vec4 vol_sample_lod(vec3 pg, float lod, vec3 d) {
    float top = float(vct_levels() - 1u);
    lod = clamp(lod, 0.0, top);
    uint m0 = uint(lod);
    float t = lod - float(m0);
    vec4 a = vol_sample(pg, m0, d);
    if (t <= 0.0 || m0 + 1u > vct_levels() - 1u) return a;
    return mix(a, vol_sample(pg, m0 + 1u, d), t);
}

#endif
