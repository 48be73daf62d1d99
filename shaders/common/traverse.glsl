// BVH traversal in compute: a binary BVH whose nodes hold both children's boxes (Aila & Laine
// 2009), nearest child first, a short stack of BVH_STACK entries. `trace_closest` finds the
// nearest hit; `trace_any` stops at the first occluder (shadow rays). Alpha-masked triangles
// and spheres are skipped where their mask is below 0.5 (common/alpha.glsl).
//
// Any depth: the host keeps trees within BVH_STACK levels where it can (renderer/src/accel/
// flatten.rs), and then the stack cannot overflow. A deeper tree (a pathological mesh) still
// renders: when a push would overflow, the walk restarts from the root with the nearest hit so
// far (r.tmax already shortened) as a stackless walk over parent pointers (Hapala et al. 2011,
// `traverse_stackless`), which needs no stack at all and visits every node the ray reaches.
//
// Instances (HAS_INSTANCES, renderer/src/compile/instances.rs): after the scene's own BVH, rays
// walk a top-level BVH whose leaves are instances; at each, the ray is moved into the
// instance's frame (its direction not renormalised, so distances t are the same in both
// frames) and walks the prototype's BVH, rooted inside the scene's node buffer (read by
// `bvh_node`), in the same loop as the top level (`traverse_instances`). Hits record the
// instance; common/surface.glsl moves them back to the world.
#ifndef COMMON_TRAVERSE_GLSL
#define COMMON_TRAVERSE_GLSL
#include "common/bindings.glsl"
#include "common/intersect.glsl"
#include "common/texture.glsl"
#include "common/alpha.glsl"

// Tests shorten the stack (TEST_BVH_STACK) to run the fallback on ordinary scenes.
#ifdef TEST_BVH_STACK
#define STACK_ENTRIES TEST_BVH_STACK
#else
#define STACK_ENTRIES BVH_STACK
#endif

layout(set = 0, binding = B_BVH_PARENTS, scalar) readonly buffer BvhParents { uint bvh_parents[]; };

struct Hit {
    float t;
    uint prim;   // index into prims (BVH order), NONE when missed
    vec2 b12;    // triangle barycentrics of v1, v2
#ifdef HAS_INSTANCES
    uint inst;   // the instance hit (index into instances), NONE for the scene's own primitives
#endif
};

#ifdef HAS_INSTANCES
#if defined(ACCEL_CWBVH) || defined(ACCEL_GRID)
#error "instances are traversed with the binary BVH only"
#endif
layout(set = 0, binding = B_INSTANCES, scalar) readonly buffer Instances { GpuInstance instances[]; };
layout(set = 0, binding = B_TLAS_NODES, std430) readonly buffer TlasNodes { vec4 tlas_words[]; };
#endif

#ifdef HAS_ALPHA
// The first root of sphere p within (tmin, tmax) that material m's alpha mask keeps, at the
// sphere's own uv (sphere_uv): a ray through a hole in the near side may meet the far side.
bool intersect_sphere_masked(Ray r, GpuPrim p, uint m, out float t) {
    float roots[2];
    t = 0.0;
    if (!sphere_roots(r, p.a.xyz, p.b.x, roots[0], roots[1])) return false;
    for (int k = 0; k < 2; ++k) {
        float tk = roots[k];
        if (!(tk > r.tmin && tk < r.tmax)) continue;
        if (mask_cuts(m, sphere_uv(r.o + tk * r.d - p.a.xyz, p.b.x))) continue;
        t = tk;
        return true;
    }
    return false;
}
#endif

// Tests primitive `i` against the ray (in the frame of instance `inst`, NONE for the scene's
// own primitives); shortens r.tmax on a hit.
bool intersect_prim(inout Ray r, RayPre pre, uint i, uint inst, inout Hit hit) {
    GpuPrim p = prims[i];
    COUNT_PRIM;
    uint bits = floatBitsToUint(p.a.w);
    float t;
#ifdef HAS_SPHERES
    if ((bits & PRIM_SPHERE) != 0u) {
#ifdef HAS_ALPHA
        if ((bits & PRIM_ALPHA) != 0u) {
            if (!intersect_sphere_masked(r, p, bits & PRIM_MATERIAL_MASK, t)) return false;
        } else
#endif
        if (!intersect_sphere(r, p.a.xyz, p.b.x, t)) return false;
        r.tmax = t; hit.t = t; hit.prim = i; hit.b12 = vec2(0.0);
        return true;
    }
#endif
    vec2 b12;
    if (!intersect_triangle(r, pre, p.a.xyz, p.b.xyz, p.c.xyz, t, b12)) return false;
#ifdef HAS_ALPHA
    uint m = bits & PRIM_MATERIAL_MASK;
    bool masked = (bits & PRIM_ALPHA) != 0u;
#ifdef HAS_INSTANCES
    // An instance's own material replaces the prototype's, mask included.
    if (inst != NONE && instances[inst].material != NONE) {
        m = instances[inst].material;
        masked = (instances[inst].flags & INST_ALPHA) != 0u;
    }
#endif
    if (masked && alpha_cut(m, p, b12)) return false;
#endif
    r.tmax = t; hit.t = t; hit.prim = i; hit.b12 = b12;
#ifdef HAS_INSTANCES
    hit.inst = inst;
#endif
    return true;
}

// A node from its four 16-byte words (the layout of GpuBvhNode, renderer/src/layout.rs).
GpuBvhNode bvh_node_of(vec4 w0, vec4 w1, vec4 w2, vec4 w3) {
    GpuBvhNode n;
    n.l_min = w0.xyz; n.left = floatBitsToUint(w0.w);
    n.l_max = w1.xyz; n.right = floatBitsToUint(w1.w);
    n.r_min = w2.xyz; n.l_count = floatBitsToUint(w2.w);
    n.r_max = w3.xyz; n.r_count = floatBitsToUint(w3.w);
    return n;
}

// Node i of the scene's BVH (prototypes' trees included).
GpuBvhNode bvh_node(uint i) {
    return bvh_node_of(node_words[4u * i], node_words[4u * i + 1u], node_words[4u * i + 2u],
                       node_words[4u * i + 3u]);
}

#ifdef HAS_INSTANCES
// Node i of the top-level BVH over the instances.
GpuBvhNode tlas_node(uint i) {
    return bvh_node_of(tlas_words[4u * i], tlas_words[4u * i + 1u], tlas_words[4u * i + 2u],
                       tlas_words[4u * i + 3u]);
}
#endif

// Whether the stackless walk visits node n's left child first: the child whose box centre comes
// first along the ray (a choice made from the node and the direction alone, so the walk can
// tell on the way up which child it came from and whether the other is still to visit).
bool stackless_left_first(GpuBvhNode n, vec3 d) {
    return dot((n.l_min + n.l_max) - (n.r_min + n.r_max), d) <= 0.0;
}

// Walks the whole tree rooted at `root` without a stack (Hapala et al. 2011): down into the near
// child, then the far one, then up to the parent. `phase` says what is next at `node`: 0 its
// near child, 1 its far child, 2 going up. r.tmax and hit carry the nearest hit found so far.
// Returns true when any_hit found an intersection.
bool traverse_stackless(inout Ray r, RayPre pre, uint root, uint inst, bool any_hit, inout Hit hit) {
    uint node = root;
    uint phase = 0u;
    while (true) {
        if (phase == 2u) {
            // Up: from the near child the far one is next; from the far child, up again.
            uint parent = bvh_parents[node];
            if (parent == NONE) return false;
            GpuBvhNode p = bvh_node(parent);
            bool from_left = p.l_count == 0u && p.left == node;
            phase = from_left == stackless_left_first(p, r.d) ? 1u : 2u;
            node = parent;
            continue;
        }
        GpuBvhNode n = bvh_node(node);
        bool left = (phase == 0u) == stackless_left_first(n, r.d);
        phase += 1u;
        float t = left ? intersect_box(r.o, pre, n.l_min, n.l_max, r.tmin, r.tmax)
                       : intersect_box(r.o, pre, n.r_min, n.r_max, r.tmin, r.tmax);
        if (isinf(t)) continue;
        uint child = left ? n.left : n.right;
        uint count = left ? n.l_count : n.r_count;
        if (count > 0u) {
            for (uint i = child; i < child + count; ++i)
                if (intersect_prim(r, pre, i, inst, hit) && any_hit) return true;
        } else {
            node = child;
            phase = 0u;
        }
    }
    return false;
}

// The nearest-first walk of a binary BVH (node i read by NODE(i), from node ROOT, a stack of
// STACK entries), for the scene's own tree (`traverse_tree`; instances have their own loop over
// both levels, `traverse_instances`, whose step 3a does what this does at a leaf). LEAF(i)
// tests leaf entry i, shortening r.tmax (true: any_hit may stop); OVERFLOW runs when a push
// would overflow the stack. Leaves are intersected at once; inner children are visited
// nearest first.
#define BVH_WALK(NODE, ROOT, STACK, LEAF, OVERFLOW)                                        \
    uint stack[STACK];                                                                  \
    int sp = 0;                                                                         \
    uint node = ROOT;                                                                   \
    while (true) {                                                                      \
        GpuBvhNode n = NODE(node);                                                      \
        COUNT_NODE;                                                                     \
        float tl = intersect_box(r.o, pre, n.l_min, n.l_max, r.tmin, r.tmax);           \
        float tr = intersect_box(r.o, pre, n.r_min, n.r_max, r.tmin, r.tmax);           \
        bool hl = !isinf(tl), hr = !isinf(tr);                                          \
        if (hl && n.l_count > 0u) {                                                     \
            for (uint i = n.left; i < n.left + n.l_count; ++i)                          \
                if (LEAF(i) && any_hit) return true;                                    \
            hl = false;                                                                 \
            tr = intersect_box(r.o, pre, n.r_min, n.r_max, r.tmin, r.tmax);             \
            hr = !isinf(tr);                                                            \
        }                                                                               \
        if (hr && n.r_count > 0u) {                                                     \
            for (uint i = n.right; i < n.right + n.r_count; ++i)                        \
                if (LEAF(i) && any_hit) return true;                                    \
            hr = false;                                                                 \
        }                                                                               \
        if (hl && hr) {                                                                 \
            if (sp == STACK) { OVERFLOW; }                                              \
            bool left_first = tl <= tr;                                                 \
            stack[sp++] = left_first ? n.right : n.left;                                \
            node = left_first ? n.left : n.right;                                       \
        } else if (hl) {                                                                \
            node = n.left;                                                              \
        } else if (hr) {                                                                \
            node = n.right;                                                             \
        } else {                                                                        \
            if (sp == 0) break;                                                         \
            node = stack[--sp];                                                         \
        }                                                                               \
    }

// Walks the BVH rooted at `root` (the scene's own tree at 0; `inst` NONE), shortening r.tmax
// and updating hit at each nearer hit. Returns true when any_hit found an intersection.
bool traverse_tree(inout Ray r, RayPre pre, uint root, uint inst, bool any_hit, inout Hit hit) {
#define TREE_LEAF(i) intersect_prim(r, pre, i, inst, hit)
    // The tree is deeper than the stack: finish without one (see the top).
#define TREE_OVERFLOW return traverse_stackless(r, pre, root, inst, any_hit, hit)
    BVH_WALK(bvh_node, root, STACK_ENTRIES, TREE_LEAF, TREE_OVERFLOW)
#undef TREE_LEAF
#undef TREE_OVERFLOW
    return false;
}

// Traverses the scene's own BVH. With any_hit it returns at the first intersection.
bool traverse(Ray r, bool any_hit, out Hit hit) {
    hit.t = r.tmax; hit.prim = NONE; hit.b12 = vec2(0.0);
#ifdef HAS_INSTANCES
    hit.inst = NONE;
#endif
    if (g.counts.x == 0u) return false; // empty scene
    RayPre pre = ray_precompute(r.d);
    return traverse_tree(r, pre, 0u, NONE, any_hit, hit) || hit.prim != NONE;
}

#ifdef HAS_INSTANCES
// Top-level stack entries besides inner nodes: a leaf's instances still to enter (TL_LEAF, the
// count from bit TL_COUNT_SHIFT up, the first instance below it; the host keeps instances below
// 2^TL_COUNT_SHIFT and leaves below 8: renderer/src/layout.rs, compile/instances.rs), and the
// mark below an instance's own entries (TL_EXIT).
#define TL_LEAF 0x80000000u
#define TL_EXIT 0xffffffffu
uint tl_leaf(uint first, uint count) { return TL_LEAF | (count << TL_COUNT_SHIFT) | first; }

// Walks the top-level BVH over the instances and, inside each instance it reaches, the
// prototype's BVH with the ray moved into the instance's frame (its direction not
// renormalised, so t is the same in both frames), continuing from the nearest hit so far
// (r.tmax, hit). Returns true when any_hit found an intersection.
//
// Both levels run in one loop over one stack (the top level's entries, then TL_EXIT, then the
// instance's), so that a warp's lanes take their node steps together whichever level each is
// in; a walk of the prototype's tree nested in the top level's (Aila & Laine's while-while
// inside a while) would idle every lane outside an instance while the others are inside one.
// The top level is built within BVH_STACK levels whatever the boxes (renderer/src/accel/
// flatten.rs, asserted by compile/instances.rs), so its part of the stack (one entry a level,
// plus a leaf's rest and the mark) cannot overflow; a prototype's tree deeper than its
// STACK_ENTRIES finishes that instance with the stackless walk.
bool traverse_instances(Ray r, bool any_hit, inout Hit hit) {
    if (g.instances.x == 0u) return false;
    RayPre pre_w = ray_precompute(r.d);
    Ray cur = r;
    RayPre pre = pre_w;
    uint stack[BVH_STACK + 2 + STACK_ENTRIES];
    int sp = 0;
    int base = 0;      // where the current instance's entries start
    uint inst = NONE;  // the instance the walk is in, NONE at the top level
    uint entry = 0u;   // the top level's root
    while (true) {
        // Step 1: a top-level leaf's next instance: keep the rest, move the ray into its frame.
        if ((entry & TL_LEAF) != 0u && inst == NONE) {
            uint k = entry & ((1u << TL_COUNT_SHIFT) - 1u), count = (entry >> TL_COUNT_SHIFT) & 7u;
            if (count > 1u) stack[sp++] = tl_leaf(k + 1u, count - 1u);
            stack[sp++] = TL_EXIT;
            base = sp;
            GpuInstance gi = instances[k];
            cur.o = vec3(dot(gi.world_to_object[0].xyz, r.o) + gi.world_to_object[0].w,
                         dot(gi.world_to_object[1].xyz, r.o) + gi.world_to_object[1].w,
                         dot(gi.world_to_object[2].xyz, r.o) + gi.world_to_object[2].w);
            cur.d = vec3(dot(gi.world_to_object[0].xyz, r.d),
                         dot(gi.world_to_object[1].xyz, r.d),
                         dot(gi.world_to_object[2].xyz, r.d));
            pre = ray_precompute(cur.d);
            inst = k;
            entry = gi.root;
        }
        // Step 2: the node's two children, at either level.
        GpuBvhNode n = inst == NONE ? tlas_node(entry) : bvh_node(entry);
        float tl = intersect_box(cur.o, pre, n.l_min, n.l_max, cur.tmin, cur.tmax);
        float tr = intersect_box(cur.o, pre, n.r_min, n.r_max, cur.tmin, cur.tmax);
        bool hl = !isinf(tl), hr = !isinf(tr);
        uint left = n.left, right = n.right;
        if (inst != NONE) {
            // Step 3a: in a prototype, leaves' primitives are tested at once.
            if (hl && n.l_count > 0u) {
                for (uint i = n.left; i < n.left + n.l_count; ++i)
                    if (intersect_prim(cur, pre, i, inst, hit) && any_hit) return true;
                hl = false;
                tr = intersect_box(cur.o, pre, n.r_min, n.r_max, cur.tmin, cur.tmax);
                hr = !isinf(tr);
            }
            if (hr && n.r_count > 0u) {
                for (uint i = n.right; i < n.right + n.r_count; ++i)
                    if (intersect_prim(cur, pre, i, inst, hit) && any_hit) return true;
                hr = false;
            }
        } else {
            // Step 3b: at the top level a leaf is visited like a node, its instances entered
            // in step 1.
            if (n.l_count > 0u) left = tl_leaf(n.left, n.l_count);
            if (n.r_count > 0u) right = tl_leaf(n.right, n.r_count);
            // A tree that is one leaf (≤ 4 instances) has it in both slots (flatten.rs): once.
            if (right == left) hr = false;
        }
        // Step 4: the nearer child next, the farther pushed; else the next entry.
        if (hl && hr) {
            if (inst != NONE && sp - base == STACK_ENTRIES) {
                // The prototype's tree is deeper than its stack: finish this instance without
                // one (see the top), then leave it.
                if (traverse_stackless(cur, pre, instances[inst].root, inst, any_hit, hit)) return true;
                sp = base;
            } else {
                bool left_first = tl <= tr;
                stack[sp++] = left_first ? right : left;
                entry = left_first ? left : right;
                continue;
            }
        } else if (hl || hr) {
            entry = hl ? left : right;
            continue;
        }
        // Step 5: pop; the mark takes the walk back to the top level, with the world ray
        // shortened to the nearest hit.
        while (true) {
            if (sp == 0) return false;
            entry = stack[--sp];
            if (entry != TL_EXIT) break;
            r.tmax = cur.tmax;
            cur = r;
            pre = pre_w;
            inst = NONE;
        }
    }
    return false;
}
#endif

// `walk` answers both queries: the nearest hit, or (any_hit) whether anything is hit at all.
#if defined(ACCEL_CWBVH)
// accel "cwbvh": the compressed 8-wide BVH (common/traverse_cwbvh.glsl).
#include "common/traverse_cwbvh.glsl"
bool walk(Ray r, bool any_hit, out Hit hit) { return traverse_cwbvh(r, any_hit, hit); }
#elif defined(ACCEL_GRID)
// accel "grid": the uniform grid (common/grid.glsl) instead of the BVH.
#include "common/grid.glsl"
bool walk(Ray r, bool any_hit, out Hit hit) { return traverse_grid(r, any_hit, hit); }
#elif defined(HAS_INSTANCES)
// The scene's own BVH, then the instances, beyond its nearest hit.
bool walk(Ray r, bool any_hit, out Hit hit) {
    if (traverse(r, any_hit, hit) && any_hit) return true;
    r.tmax = hit.t;
    traverse_instances(r, any_hit, hit);
    return hit.prim != NONE;
}
#else
bool walk(Ray r, bool any_hit, out Hit hit) { return traverse(r, any_hit, hit); }
#endif

// The queries the integrators call: `trace` with the kind chosen per thread (one inlined walk
// serves both, nee's loop), `trace_closest` and `trace_any`. COUNT_CLOCK (a measuring define,
// common/bindings.glsl) adds the cycles each thread spends in closest-hit (1) or any-hit (2)
// walks.
bool trace(Ray r, bool any_hit, out Hit hit) {
#ifdef COUNT_CLOCK
    uint c0 = clock2x32ARB().x;
    bool found = walk(r, any_hit, hit);
    if (COUNT_CLOCK == (any_hit ? 2 : 1)) count_clock += clock2x32ARB().x - c0;
    return found;
#else
    return walk(r, any_hit, hit);
#endif
}

bool trace_closest(Ray r, out Hit hit) { return trace(r, false, hit); }

bool trace_any(Ray r) {
    Hit h;
    return trace(r, true, h);
}

#endif
