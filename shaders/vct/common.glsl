// vct: the voxel volume's bindings, parameters and packing, shared by every vct kernel
// (renderer/src/integrators/vct/ mirrors them: `VctParams`, `VctInfo`, the `B_VCT_*` indices).
// Positions are camera-relative like the scene's; grid units put voxel corners at integers.
//
// Storage. Every surface voxel has a *slot*: dense storage numbers voxels linearly
// (x + R(y + Rz)); the octree gives the 8 voxels under each leaf-parent node (depth D−1) slots
// (node − level_start[D−1])·8 + octant. Per slot: packed attributes (albedo+opacity, normal,
// mean surface point), emission and the injected radiance. Mip levels m ≥ 1 hold six
// directional values per cell (Crassin et al. 2011's anisotropic voxels): dense storage in one
// flat array per level, the octree in 3×3×3 bricks (see volume.glsl).
#ifndef VCT_COMMON_GLSL
#define VCT_COMMON_GLSL
#include "common/bindings.glsl"
#include "common/math.glsl"

#define B_VCT_PARAMS 16
#define B_VCT_INFO 17
#define B_VCT_FRAGS 18
#define B_VCT_NODES 19
#define B_VCT_ACC 20
#define B_VCT_ATTR 21
#define B_VCT_EMIT 22
#define B_VCT_RAD 23
#define B_VCT_MIP 24
#define B_VCT_LEAF 25
#define B_VCT_BOUNCE 26
#define B_VCT_PROBE 27
#define B_VCT_TILES 28

#define VCT_LEVELS_MAX 16
#define NODE_FLAG 0x80000000u
#define ACC_WORDS 14u

struct VctParams {
    vec4 grid;        // grid minimum corner (camera-relative), voxel size
    uvec4 dims;       // resolution R, levels D = log2 R, storage (0 dense, 1 octree), coarsest level cones read
    vec4 cone;        // tan of the diffuse cones' half-angle, diffuse cone count, step factor, AO distance (grid units)
    uvec4 mode;       // ao output, shadow cones, injection samples per voxel, diffuse cones per sample
    uvec4 caps;       // fragment capacity, node capacity, slot capacity, occupancy mask's first node word (0: none)
    uint mip_offset[VCT_LEVELS_MAX]; // dense: first cell of level m in MIP (cells of 6 values)
};

struct VctInfo {
    uint frag_count;
    uint node_count;
    uint overflow;
    uint voxel_count;
    uint level_start[VCT_LEVELS_MAX];
    uint level_end[VCT_LEVELS_MAX];
};

layout(set = 0, binding = B_VCT_PARAMS, scalar) readonly buffer VctParamsBuf { VctParams P; };

// The options that pick code paths, read from the parameters (the generic kernel) or compiled in
// where the host specialises the kernel (renderer/src/integrators/vct/mod.rs, `constants`): the
// storage, the AO output, shadow cones and the diffuse cones. The cones traced per sample stay a
// run-time read (measured: `constants`), the macro only lets a measurement compile them in.
#ifndef VCT_OCTREE
#define VCT_OCTREE (P.dims.z == 1u)
#endif
#ifndef VCT_AO
#define VCT_AO (P.mode.x == 1u)
#endif
#ifndef VCT_SHADOW_CONE
#define VCT_SHADOW_CONE (P.mode.y == 1u)
#endif
#ifndef VCT_CONES
#define VCT_CONES max(uint(P.cone.y), 1u)
#endif
#ifndef VCT_CONES_PER_SAMPLE
#define VCT_CONES_PER_SAMPLE P.mode.w
#endif
// The volume's depth D = log2 R: compiled in by specialised kernels (the octree walks' trip
// counts: +5.9% on the Cornell box; the resolution and the march's other parameters were
// measured too and left out: bench/RESULTS.md, "Read-only buffers, the tangent only where a
// BSDF reads it").
#ifndef VCT_LEVELS
#define VCT_LEVELS P.dims.y
#endif
// The qualifier of the volume's buffers: empty for the build kernels, which write them;
// `readonly` in the gather (vct.comp).
#ifndef VCT_READS
#define VCT_READS
#endif
layout(set = 0, binding = B_VCT_INFO, scalar) VCT_READS buffer VctInfoBuf { VctInfo info; };
layout(set = 0, binding = B_VCT_FRAGS, scalar) buffer VctFrags { uvec2 frags[]; };      // (packed voxel, prim)
layout(set = 0, binding = B_VCT_NODES, scalar) VCT_READS buffer VctNodes { uvec2 vnodes[]; };     // (first child | flag, packed coords)
layout(set = 0, binding = B_VCT_ACC, scalar) buffer VctAcc { uint acc[]; };            // ACC_WORDS per slot while building
layout(set = 0, binding = B_VCT_ATTR, scalar) VCT_READS buffer VctAttr { uvec4 attr[]; };        // albedo rgba8, normal snorm8+two-sided, point offset snorm16×3
layout(set = 0, binding = B_VCT_EMIT, scalar) buffer VctEmit { uvec2 emit[]; };        // half4 emitted radiance
layout(set = 0, binding = B_VCT_RAD, scalar) VCT_READS buffer VctRad { uvec4 rad[]; };           // half4 (radiance·opacity, opacity) of the front and back sides
layout(set = 0, binding = B_VCT_MIP, scalar) VCT_READS buffer VctMip { uvec2 mip[]; };           // half4 × 6 directions per cell / brick sample
layout(set = 0, binding = B_VCT_LEAF, scalar) VCT_READS buffer VctLeaf { uint leaf[]; };         // octree: 27 voxel slots (or NONE) per leaf-parent brick
layout(set = 0, binding = B_VCT_BOUNCE, scalar) buffer VctBounce { uvec4 bounce[]; };  // second bounce per slot, front and back

// Build kernels reuse the session's push-constant block (common/types.glsl): the level or depth
// in sample_base, a thread count in spp, a mode in flags.
#define VP_LEVEL pc.sample_base
#define VP_COUNT pc.spp
#define VP_MODE pc.flags

// The thread's index in a 1D launch spread over x and y (x at most 65535 groups of 64).
#define LINEAR_GID (gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u)

uvec2 pack_h4(vec4 v) { return uvec2(packHalf2x16(v.xy), packHalf2x16(v.zw)); }
vec4 unpack_h4(uvec2 u) { return vec4(unpackHalf2x16(u.x), unpackHalf2x16(u.y)); }

uint pack_cell(uvec3 c) { return c.x | (c.y << 10) | (c.z << 20); }
uvec3 unpack_cell(uint p) { return uvec3(p & 1023u, (p >> 10) & 1023u, (p >> 20) & 1023u); }
uint octant(uvec3 b) { return b.x | (b.y << 1) | (b.z << 2); }
uvec3 octant_bits(uint o) { return uvec3(o & 1u, (o >> 1) & 1u, (o >> 2) & 1u); }

uint vct_res() { return P.dims.x; }
uint vct_levels() { return VCT_LEVELS; }
bool vct_octree() { return VCT_OCTREE; }

// World (camera-relative) ↔ grid units.
vec3 to_grid(vec3 p) { return (p - P.grid.xyz) / P.grid.w; }
vec3 from_grid(vec3 q) { return P.grid.xyz + q * P.grid.w; }

// The octree node at depth k holding cell c of that depth (c < 2^k), or NONE.
uint octree_find(uvec3 c, uint k) {
    uint node = 0u;
    for (uint d = 0u; d < k; ++d) {
        uint child = vnodes[node].x & ~NODE_FLAG;
        if (child == 0u) return NONE;
        uvec3 b = (c >> (k - 1u - d)) & 1u;
        node = child + octant(b);
    }
    return node;
}

// The slot of level-0 voxel v, or NONE where the octree has no node for it.
uint voxel_slot(uvec3 v) {
    uint r = vct_res();
    if (!vct_octree()) return v.x + r * (v.y + r * v.z);
    uint k = vct_levels() - 1u;
    uint node = octree_find(v >> 1u, k);
    if (node == NONE) return NONE;
    return (node - info.level_start[k]) * 8u + octant(v & 1u);
}

// The octree's occupancy mask (P.caps.w > 0): one bit per level-0 voxel, set where the voxel is
// occupied (normalize.comp, exactly where its opacity is 1), in 4×4×4 bricks of one uvec2 each,
// stored after the node pool from vnodes[P.caps.w] (renderer/src/integrators/vct/build.rs).
// Returns the word's index and the bit's place (0..63) in it.
uvec2 occupancy_place(uvec3 c) {
    uint n4 = vct_res() >> 2u;
    uvec3 b = c >> 2u, o = c & 3u;
    return uvec2(P.caps.w + b.x + n4 * (b.y + n4 * b.z), o.x | (o.y << 2u) | (o.z << 4u));
}

// The level-0 voxel a slot belongs to.
uvec3 slot_cell(uint slot) {
    uint r = vct_res();
    if (!vct_octree()) return uvec3(slot % r, (slot / r) % r, slot / (r * r));
    uint k = vct_levels() - 1u;
    uvec3 c = unpack_cell(vnodes[info.level_start[k] + slot / 8u].y);
    return 2u * c + octant_bits(slot % 8u);
}

/// A voxel's averaged surface: albedo, opacity, normal (zero where the normals cancel), whether
/// any of its surfaces reflects on both sides, and its mean surface point (camera-relative).
struct Voxel { vec3 albedo; float opacity; vec3 n; bool two_sided; vec3 p; };

Voxel load_voxel(uint slot) {
    uvec4 a = attr[slot];
    Voxel vx;
    vec4 al = unpackUnorm4x8(a.x);
    vec4 nn = unpackSnorm4x8(a.y);
    vx.albedo = al.rgb;
    vx.opacity = al.a;
    vx.n = dot(nn.xyz, nn.xyz) > 0.25 ? normalize(nn.xyz) : vec3(0.0);
    vx.two_sided = nn.w > 0.5;
    vec3 off = vec3(unpackSnorm2x16(a.z), unpackSnorm2x16(a.w).x);
    vx.p = from_grid(vec3(slot_cell(slot)) + 0.5 + off);
    return vx;
}

// Travel direction of directional value `dir` (0 +x, 1 −x, 2 +y, 3 −y, 4 +z, 5 −z).
vec3 dir_axis(uint dir) {
    vec3 e = vec3(0.0);
    e[dir >> 1u] = (dir & 1u) == 0u ? 1.0 : -1.0;
    return e;
}

// level0_value from the slot's loaded radiance r and normal n, for the axis direction e.
vec4 level0_face(uvec4 r, vec3 n, vec3 e) {
    float c = dot(n, e);
    float nl = dot(n, n);
    if (nl < 0.25) return unpack_h4(r.xy);
    return (c <= 0.0 ? unpack_h4(r.xy) : unpack_h4(r.zw)) * (abs(c) * inversesqrt(nl));
}

// Level 0 is directional too: a voxel keeps the radiance of the two sides of its surface
// (front: the side its normal points to), and a cone travelling along e sees the side facing
// −e, with the surface's projected coverage |n·e| as opacity: a thin wall lit on one side does
// not shine on the other, and a wall seen edge-on neither shows its lit side nor occludes
// (voxels whose normals cancel show the same opaque value every way).
vec4 level0_value(uint slot, uint dir) {
    return level0_face(rad[slot], unpackSnorm4x8(attr[slot].y).xyz, dir_axis(dir));
}

// The radiance of the side of slot's surface a ray travelling along d sees (its opacity is 1).
vec3 level0_seen(uint slot, vec3 d) {
    uvec4 r = rad[slot];
    vec3 n = unpackSnorm4x8(attr[slot].y).xyz;
    vec4 v = dot(n, d) <= 0.0 ? unpack_h4(r.xy) : unpack_h4(r.zw);
    return v.a > 0.0 ? v.rgb / v.a : vec3(0.0);
}

// Level-0 value of a slot seen along d: the d²-weighted mix of its three visible directional
// values (both storages read level 0 this way).
vec4 level0_dir(uint slot, vec3 d) {
    vec3 w = d * d;
    uvec4 r = rad[slot];
    vec3 n = unpackSnorm4x8(attr[slot].y).xyz;
    return w.x * level0_face(r, n, dir_axis(d.x >= 0.0 ? 0u : 1u)) +
           w.y * level0_face(r, n, dir_axis(d.y >= 0.0 ? 2u : 3u)) +
           w.z * level0_face(r, n, dir_axis(d.z >= 0.0 ? 4u : 5u));
}

// Anisotropic value seen by a cone travelling along d from six directional values
// (+x, −x, +y, −y, +z, −z): weights d², the face each axis shows (Crassin 2011).
vec4 combine_dirs(vec4 v0, vec4 v1, vec4 v2, vec4 v3, vec4 v4, vec4 v5, vec3 d) {
    vec3 w = d * d;
    return w.x * (d.x >= 0.0 ? v0 : v1) + w.y * (d.y >= 0.0 ? v2 : v3) + w.z * (d.z >= 0.0 ? v4 : v5);
}

#endif
