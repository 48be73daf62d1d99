// vct stage 1: conservative voxelization of every triangle and sphere into a fragment list
// (one (voxel, prim) pair per voxel a primitive touches). Triangles: the triangle/box overlap
// test of Akenine-Möller 2001 ("Fast 3D Triangle-Box Overlap Testing": separating axes = the box
// normals, the triangle normal, and the nine edge cross products) against every voxel of the
// triangle's bounding box; spheres: the voxel box straddles the sphere surface (nearest box point
// inside, farthest outside). Thin geometry is never lost: a voxel is kept when any part of the
// primitive touches it. Work is cut into tiles of a primitive's voxel box (one per thread): one
// slice along its longest axis, `rows` rows of the second longest and `deep` voxels of the
// shortest (4 and 8, more when a scene has too many tiles for one launch: VP_MODE), numbered
// primitive after primitive (renderer/src/integrators/vct/build.rs, `voxel_tiles`), so a warp's
// threads share a primitive and a wall spanning the grid is spread over many threads. Push
// constants: VP_LEVEL the primitives, VP_COUNT the tiles, VP_MODE the tile size (rows | deep
// << 16). Counting pass (capacity 0) and emitting pass share the kernel: each thread counts
// its voxels, the workgroup sums its threads' counts in shared memory and reserves one block
// with one global atomic (millions of threads on one counter serialise), and each thread
// writes its share of the block.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "vct/common.glsl"

layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

// Per primitive: its first tile, and its tile grid (row blocks | depth blocks << 16).
layout(set = 0, binding = B_VCT_TILES, scalar) readonly buffer VctTiles { uvec2 tiles[]; };

shared uint s_count;
shared uint s_base;

// Akenine-Möller's axis test: projections of the triangle (v0, v1, v2, relative to the box
// centre) and of the box (half size h) on `axis` are disjoint.
bool separated(vec3 axis, vec3 v0, vec3 v1, vec3 v2, vec3 h) {
    float p0 = dot(v0, axis), p1 = dot(v1, axis), p2 = dot(v2, axis);
    float r = dot(h, abs(axis));
    return min(p0, min(p1, p2)) > r || max(p0, max(p1, p2)) < -r;
}

bool tri_box_overlap(vec3 c, vec3 h, vec3 a, vec3 b, vec3 d) {
    vec3 v0 = a - c, v1 = b - c, v2 = d - c;
    // Box normals (the triangle's bounding box against the voxel).
    if (any(greaterThan(min(v0, min(v1, v2)), h)) || any(lessThan(max(v0, max(v1, v2)), -h))) return false;
    vec3 e0 = v1 - v0, e1 = v2 - v1, e2 = v0 - v2;
    // Triangle normal (plane/box test).
    vec3 n = cross(e0, e1);
    if (abs(dot(n, v0)) > dot(h, abs(n))) return false;
    // The nine edge × box-axis cross products.
    vec3 ax[3] = vec3[3](vec3(1, 0, 0), vec3(0, 1, 0), vec3(0, 0, 1));
    vec3 es[3] = vec3[3](e0, e1, e2);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            vec3 axis = cross(ax[i], es[j]);
            if (dot(axis, axis) > 0.0 && separated(axis, v0, v1, v2, h)) return false;
        }
    return true;
}

// Whether voxel v (grid units) holds part of primitive pr.
bool touches(GpuPrim pr, bool sphere, vec3 v) {
    vec3 c = v + 0.5;
    // A hair more than half a voxel, so rounding never drops a voxel the primitive grazes.
    vec3 h = vec3(0.5 + 1e-4);
    if (sphere) {
        vec3 sc = to_grid(pr.a.xyz);
        float r = pr.b.x / P.grid.w;
        vec3 dmin = max(abs(sc - c) - h, vec3(0.0));
        vec3 dmax = abs(sc - c) + h;
        return dot(dmin, dmin) <= r * r * (1.0 + 1e-4) && dot(dmax, dmax) >= r * r * (1.0 - 1e-4);
    }
    return tri_box_overlap(c, h, to_grid(pr.a.xyz), to_grid(pr.b.xyz), to_grid(pr.c.xyz));
}

void main() {
    uint tile = LINEAR_GID;
    // Threads without work stay to the end: the workgroup meets at barriers.
    bool work = tile < VP_COUNT;
    uint prim = 0u;
    GpuPrim pr;
    bool sphere = false;
    ivec3 slo = ivec3(0), shi = ivec3(-1);
    if (work) {
        // Step 1: the tile's primitive, the last whose first tile is at or before it.
        uint lo_i = 0u, hi_i = VP_LEVEL - 1u;
        while (lo_i < hi_i) {
            uint mid = (lo_i + hi_i + 1u) >> 1;
            if (tiles[mid].x <= tile) lo_i = mid; else hi_i = mid - 1u;
        }
        prim = lo_i;
        pr = prims[prim];
        sphere = (floatBitsToUint(pr.a.w) & PRIM_SPHERE) != 0u;
        // Step 2: the primitive's voxel range.
        vec3 lo, hi;
        if (sphere) {
            vec3 sc = to_grid(pr.a.xyz);
            float r = pr.b.x / P.grid.w;
            lo = sc - r; hi = sc + r;
        } else {
            vec3 a = to_grid(pr.a.xyz), b = to_grid(pr.b.xyz), d = to_grid(pr.c.xyz);
            lo = min(a, min(b, d)); hi = max(a, max(b, d));
        }
        float rmax = float(vct_res() - 1u);
        ivec3 vlo = ivec3(clamp(floor(lo - 1e-3), vec3(0.0), vec3(rmax)));
        ivec3 vhi = ivec3(clamp(floor(hi + 1e-3), vec3(0.0), vec3(rmax)));
        // Step 3: this tile's slice along the longest axis, rows along the second longest and
        // depth along the shortest (the tile grid is the CPU's, at least as large as this box).
        ivec3 ext = vhi - vlo;
        int axis = ext.x >= ext.y ? (ext.x >= ext.z ? 0 : 2) : (ext.y >= ext.z ? 1 : 2);
        int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
        int row_axis = ext[a1] >= ext[a2] ? a1 : a2;
        int depth_axis = 3 - axis - row_axis;
        int rows_per = int(VP_MODE & 0xffffu), deep_per = int(VP_MODE >> 16);
        uint rows = tiles[prim].y & 0xffffu, depth = tiles[prim].y >> 16;
        uint local = tile - tiles[prim].x;
        int slice = int(local / (rows * depth));
        int row = int((local / depth) % rows) * rows_per;
        int deep = int(local % depth) * deep_per;
        work = slice <= ext[axis] && row <= ext[row_axis] && deep <= ext[depth_axis];
        slo = vlo; shi = vhi;
        slo[axis] = vlo[axis] + slice;
        shi[axis] = slo[axis];
        slo[row_axis] = vlo[row_axis] + row;
        shi[row_axis] = min(slo[row_axis] + rows_per - 1, vhi[row_axis]);
        slo[depth_axis] = vlo[depth_axis] + deep;
        shi[depth_axis] = min(slo[depth_axis] + deep_per - 1, vhi[depth_axis]);
    }
    // Step 4: count the voxels touched.
    uint n = 0u;
    if (work)
        for (int z = slo.z; z <= shi.z; ++z)
            for (int y = slo.y; y <= shi.y; ++y)
                for (int x = slo.x; x <= shi.x; ++x)
                    if (touches(pr, sphere, vec3(x, y, z))) n += 1u;
    // Step 5: one block for the workgroup, this thread's share of it.
    if (gl_LocalInvocationIndex == 0u) s_count = 0u;
    barrier();
    uint mine = n > 0u ? atomicAdd(s_count, n) : 0u;
    barrier();
    if (gl_LocalInvocationIndex == 0u && s_count > 0u) s_base = atomicAdd(info.frag_count, s_count);
    barrier();
    if (n == 0u) return;
    uint base = s_base + mine;
    if (base + n > P.caps.x) return; // counting pass (capacity 0) or overflow
    // Step 6: write them.
    for (int z = slo.z; z <= shi.z; ++z)
        for (int y = slo.y; y <= shi.y; ++y)
            for (int x = slo.x; x <= shi.x; ++x)
                if (touches(pr, sphere, vec3(x, y, z))) frags[base++] = uvec2(pack_cell(uvec3(x, y, z)), prim);
}
