// BVH traversal in compute: a binary BVH whose nodes hold both children's boxes (Aila & Laine
// 2009), nearest child first, an explicit stack of BVH_STACK entries (the host checks the tree
// depth fits, so the stack cannot overflow). `trace_closest` finds the nearest hit;
// `trace_any` stops at the first occluder (shadow rays). Alpha-masked triangles are skipped
// where their mask is below 0.5.
#ifndef COMMON_TRAVERSE_GLSL
#define COMMON_TRAVERSE_GLSL
#include "common/bindings.glsl"
#include "common/intersect.glsl"
#include "common/texture.glsl"

#define BVH_STACK 64

struct Hit {
    float t;
    uint prim;   // index into prims (BVH order), NONE when missed
    vec2 b12;    // triangle barycentrics of v1, v2
};

#ifdef HAS_ALPHA
// True when the alpha mask of the triangle cuts the point with barycentrics b12 away.
bool alpha_cut(GpuPrim p, vec2 b12) {
    uint m = floatBitsToUint(p.a.w) & PRIM_MATERIAL_MASK;
    uint tex = materials[m].header.z;
    uint si = floatBitsToUint(p.c.w);
    if (tex == NONE || si == NONE) return false;
    GpuTriShading s = tri_shading[si];
    vec2 uv = (1.0 - b12.x - b12.y) * vec2(s.n0.w, s.uv_v.x) + b12.x * vec2(s.n1.w, s.uv_v.y) + b12.y * vec2(s.n2.w, s.uv_v.z);
    return texture_eval(tex, uv).r < 0.5;
}
#endif

// Tests primitive `i` against the ray; shortens r.tmax on a hit.
bool intersect_prim(inout Ray r, RayPre pre, uint i, inout Hit hit) {
    GpuPrim p = prims[i];
    uint bits = floatBitsToUint(p.a.w);
    float t;
#ifdef HAS_SPHERES
    if ((bits & PRIM_SPHERE) != 0u) {
        if (!intersect_sphere(r, p.a.xyz, p.b.x, t)) return false;
        r.tmax = t; hit.t = t; hit.prim = i; hit.b12 = vec2(0.0);
        return true;
    }
#endif
    vec2 b12;
    if (!intersect_triangle(r, pre, p.a.xyz, p.b.xyz, p.c.xyz, t, b12)) return false;
#ifdef HAS_ALPHA
    if ((bits & PRIM_ALPHA) != 0u && alpha_cut(p, b12)) return false;
#endif
    r.tmax = t; hit.t = t; hit.prim = i; hit.b12 = b12;
    return true;
}

// Traverses the BVH. With any_hit it returns at the first intersection.
bool traverse(Ray r, bool any_hit, out Hit hit) {
    hit.t = r.tmax; hit.prim = NONE; hit.b12 = vec2(0.0);
    if (g.counts.x == 0u) return false; // empty scene
    RayPre pre = ray_precompute(r.d);
    uint stack[BVH_STACK];
    int sp = 0;
    uint node = 0u;
    while (true) {
        GpuBvhNode n = nodes[node];
        float tl = intersect_box(r.o, pre, n.l_min, n.l_max, r.tmin, r.tmax);
        float tr = intersect_box(r.o, pre, n.r_min, n.r_max, r.tmin, r.tmax);
        bool hl = !isinf(tl), hr = !isinf(tr);
        // Leaves are intersected at once; inner children are visited nearest first.
        if (hl && n.l_count > 0u) {
            for (uint i = n.left; i < n.left + n.l_count; ++i)
                if (intersect_prim(r, pre, i, hit) && any_hit) return true;
            hl = false;
            tr = intersect_box(r.o, pre, n.r_min, n.r_max, r.tmin, r.tmax);
            hr = !isinf(tr);
        }
        if (hr && n.r_count > 0u) {
            for (uint i = n.right; i < n.right + n.r_count; ++i)
                if (intersect_prim(r, pre, i, hit) && any_hit) return true;
            hr = false;
        }
        if (hl && hr) {
            bool left_first = tl <= tr;
            stack[sp++] = left_first ? n.right : n.left;
            node = left_first ? n.left : n.right;
        } else if (hl) {
            node = n.left;
        } else if (hr) {
            node = n.right;
        } else {
            if (sp == 0) break;
            node = stack[--sp];
        }
    }
    return hit.prim != NONE;
}

#ifdef ACCEL_GRID
// accel "grid": the uniform grid (common/grid.glsl) answers both queries instead of the BVH.
#include "common/grid.glsl"
bool trace_closest(Ray r, out Hit hit) { return traverse_grid(r, false, hit); }

bool trace_any(Ray r) {
    Hit h;
    return traverse_grid(r, true, h);
}
#else
bool trace_closest(Ray r, out Hit hit) { return traverse(r, false, hit); }

bool trace_any(Ray r) {
    Hit h;
    return traverse(r, true, h);
}
#endif

#endif
