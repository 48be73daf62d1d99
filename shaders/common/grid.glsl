// Uniform grid traversal (accel "grid", `#define ACCEL_GRID`; built by renderer/src/accel/grid.rs):
// the 3D-DDA of Amanatides & Woo 1987 over the cells the ray crosses, in order. Each cell lists
// the primitives overlapping it (`grid_cells[i] .. grid_cells[i + 1]` of `grid_prims`).
//
// Closest hit: a primitive that spans several cells may be hit beyond the current cell, and a
// nearer primitive may still wait in a later cell. The nearest hit so far is kept (r.tmax shrinks
// with it) and the walk stops only once that hit lies before the current cell's exit distance,
// so no hit is ever taken too early and none is tested twice in vain. Any hit (shadow rays) stops
// at the first intersection in (tmin, tmax).
//
// Robustness: the direction's tiny components are clamped before the reciprocal (ray_precompute),
// the ray is first clipped to the grid box (rays may start outside it), the entry cell is clamped
// into the grid, and each crossing distance is computed from the cell boundary itself rather than
// accumulated, so rounding never builds up over a long walk. The host dilates cells slightly when
// inserting primitives, which covers the remaining f32 rounding of cell boundaries.
// Included from common/traverse.glsl after intersect_prim.
#ifndef COMMON_GRID_GLSL
#define COMMON_GRID_GLSL

layout(set = 0, binding = B_GRID, scalar) readonly buffer GridInfo { GpuGridInfo grid; };
layout(set = 0, binding = B_GRID_CELLS, scalar) readonly buffer GridCells { uint grid_cells[]; };
layout(set = 0, binding = B_GRID_PRIMS, scalar) readonly buffer GridPrims { uint grid_prims[]; };

// Walks the grid. With any_hit it returns at the first intersection.
bool traverse_grid(Ray r, bool any_hit, out Hit hit) {
    hit.t = r.tmax; hit.prim = NONE; hit.b12 = vec2(0.0);
    if (g.counts.x == 0u) return false; // empty scene
    RayPre pre = ray_precompute(r.d);
    // Step 1: clip the ray to the grid box (slab test, far distance widened as for BVH boxes).
    vec3 t0 = (grid.lo - r.o) * pre.inv_d;
    vec3 t1 = (grid.hi - r.o) * pre.inv_d;
    vec3 tn = min(t0, t1);
    vec3 tf = max(t0, t1) * GAMMA3_BOX;
    float t_enter = max(max(tn.x, tn.y), max(tn.z, r.tmin));
    float t_leave = min(min(tf.x, tf.y), min(tf.z, r.tmax));
    if (!(t_enter <= t_leave)) return false;
    // Step 2: the entry cell, clamped into the grid (the entry point may round just outside).
    ivec3 res = ivec3(grid.nx, grid.ny, grid.nz);
    vec3 p = r.o + t_enter * r.d;
    ivec3 cell = clamp(ivec3(floor((p - grid.lo) * grid.inv_cell)), ivec3(0), res - 1);
    // Step 3: DDA set-up: step direction per axis, the cell index that ends the walk, and which
    // face (lower or upper) of the current cell the ray leaves through.
    bvec3 pos = greaterThanEqual(pre.inv_d, vec3(0.0));
    ivec3 stp = mix(ivec3(-1), ivec3(1), pos);
    ivec3 stop = mix(ivec3(-1), res, pos);
    ivec3 face = mix(ivec3(0), ivec3(1), pos);
    vec3 t_next = (grid.lo + vec3(cell + face) * grid.cell - r.o) * pre.inv_d;
    while (true) {
        // Step 4: the current cell's primitives.
        uint ci = (uint(cell.z) * uint(res.y) + uint(cell.y)) * uint(res.x) + uint(cell.x);
        uint end = grid_cells[ci + 1u];
        for (uint k = grid_cells[ci]; k < end; ++k)
            if (intersect_prim(r, pre, grid_prims[k], NONE, hit) && any_hit) return true;
        // Step 5: stop once the nearest hit (or the ray's end) lies before this cell's exit.
        float t_exit = min(min(t_next.x, t_next.y), t_next.z);
        if (r.tmax <= t_exit || t_exit > t_leave) break;
        // Step 6: step into the neighbour across the nearest face.
        int a = (t_next.x <= t_next.y && t_next.x <= t_next.z) ? 0 : (t_next.y <= t_next.z ? 1 : 2);
        cell[a] += stp[a];
        if (cell[a] == stop[a]) break;
        t_next[a] = (grid.lo[a] + float(cell[a] + face[a]) * grid.cell[a] - r.o[a]) * pre.inv_d[a];
    }
    return hit.prim != NONE;
}

#endif
