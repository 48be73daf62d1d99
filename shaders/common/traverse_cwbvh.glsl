// Compressed 8-wide BVH traversal (accel "cwbvh", `#define ACCEL_CWBVH`; built by
// renderer/src/accel/cwbvh.rs): Ylitie, Karras & Laine, "Efficient Incoherent Ray Traversal on
// GPUs Through Compressed Wide BVHs" (HPG 2017), following obvhs's `traverse!` macro.
//
// A node group (uvec2) is a base child index and a hit mask: bits 24..31 the node's inner
// children that the ray hit, each at bit 24 + (slot XOR the ray's octant), so the highest set
// bit is the child nearest along the ray (the builder orders slots by octant); the low byte
// holds the node's imask, to count inner children stored before a slot. A primitive group is a
// base leaf slot (the primitive's index; with CWBVH_INDIRECT an index into cwbvh_prims) and a
// 24-bit mask of leaf slots hit. The walk takes the highest
// node of the current group, pushes the rest of the group, and intersects the node's eight
// quantised child boxes at once; leaves' primitives are tested right away (no postponing).
//
// Child boxes are decoded as p + e·q (e a power of two, so e·q is exact and the sum rounds
// once) and tested with the same slab test as the binary BVH (intersect_box, far distance
// widened). The host quantises them so that this f32 decoding still contains every child
// (renderer/src/compile/frame.rs, `place_cwbvh`), and keeps every tree within CWBVH_STACK
// levels: a walk pushes at most one group per level, so the stack never overflows (the guard
// on the push only keeps a corrupt tree from writing out of bounds).
// Included from common/traverse.glsl after intersect_prim.
#ifndef COMMON_TRAVERSE_CWBVH_GLSL
#define COMMON_TRAVERSE_CWBVH_GLSL

layout(set = 0, binding = B_CWBVH_NODES, scalar) readonly buffer CwbvhNodes { GpuCwbvhNode cw_nodes[]; };
#ifdef CWBVH_INDIRECT
// Leaf slot -> primitive, when the primitives are not stored in leaf order (a testing aid).
layout(set = 0, binding = B_CWBVH_PRIMS, scalar) readonly buffer CwbvhPrims { uint cwbvh_prims[]; };
#endif

// Byte c (0..7) of eight packed in a uvec2.
uint cw_byte(uvec2 v, uint c) {
    return ((c < 4u ? v.x : v.y) >> ((c & 3u) * 8u)) & 0xffu;
}

// The hit mask of node n's children (see the top), for a ray with octant bits oct_inv.
uint cw_intersect_node(GpuCwbvhNode n, Ray r, RayPre pre, uint oct_inv) {
    vec3 e = vec3(uintBitsToFloat((n.e_imask & 0xffu) << 23),
                  uintBitsToFloat(((n.e_imask >> 8) & 0xffu) << 23),
                  uintBitsToFloat(((n.e_imask >> 16) & 0xffu) << 23));
    uint hitmask = 0u;
    for (uint c = 0u; c < 8u; ++c) {
        uint meta = cw_byte(n.meta, c);
        if (meta == 0u) continue; // an empty slot
        vec3 qlo = vec3(cw_byte(n.q[0], c), cw_byte(n.q[2], c), cw_byte(n.q[4], c));
        vec3 qhi = vec3(cw_byte(n.q[1], c), cw_byte(n.q[3], c), cw_byte(n.q[5], c));
        float t = intersect_box(r.o, pre, n.p + e * qlo, n.p + e * qhi, r.tmin, r.tmax);
        if (isinf(t)) continue;
        // Inner children's meta is 24..31 (bits 3 and 4 set), leaves' offsets are below 24.
        bool inner = ((meta & (meta << 1u)) & 0x10u) != 0u;
        uint bits = (meta >> 5u) & 7u;
        uint index = inner ? ((meta ^ oct_inv) & 0x1fu) : (meta & 0x1fu);
        hitmask |= bits << index;
    }
    return hitmask;
}

// Traverses the CWBVH. With any_hit it returns at the first intersection.
bool traverse_cwbvh(Ray r, bool any_hit, out Hit hit) {
    hit.t = r.tmax; hit.prim = NONE; hit.b12 = vec2(0.0);
    if (g.counts.x == 0u) return false; // empty scene
    RayPre pre = ray_precompute(r.d);
    // Octant bits, inverted (obvhs's ray_get_octant_inv4, one byte).
    uint oct_inv = (r.d.x < 0.0 ? 0u : 4u) | (r.d.y < 0.0 ? 0u : 2u) | (r.d.z < 0.0 ? 0u : 1u);
    uvec2 stack[CWBVH_STACK];
    int sp = 0;
    uvec2 node_group = uvec2(0u, 0x80000000u); // the root alone
    uvec2 prim_group = uvec2(0u);
    while (true) {
        // Step 1: the nearest remaining node of the group, the rest of the group pushed.
        if ((node_group.y & 0xff000000u) != 0u) {
            uint hits = node_group.y;
            uint bit = uint(findMSB(hits));
            node_group.y &= ~(1u << bit);
            if ((node_group.y & 0xff000000u) != 0u && sp < CWBVH_STACK) stack[sp++] = node_group;
            uint slot = (bit - 24u) ^ oct_inv;
            uint rel = bitCount(hits & ~(0xffffffffu << slot));
            GpuCwbvhNode n = cw_nodes[node_group.x + rel];
            // Step 2: its children's boxes.
            uint hitmask = cw_intersect_node(n, r, pre, oct_inv);
            node_group = uvec2(n.child_base, (hitmask & 0xff000000u) | (n.e_imask >> 24));
            prim_group = uvec2(n.prim_base, hitmask & 0x00ffffffu);
        } else {
            node_group = uvec2(0u);
        }
        // Step 3: the primitives of the leaves hit.
        while (prim_group.y != 0u) {
            uint b = uint(findMSB(prim_group.y));
            prim_group.y &= ~(1u << b);
#ifdef CWBVH_INDIRECT
            uint i = cwbvh_prims[prim_group.x + b];
#else
            uint i = prim_group.x + b;
#endif
            if (intersect_prim(r, pre, i, NONE, hit) && any_hit) return true;
        }
        // Step 4: the next group, or done.
        if ((node_group.y & 0xff000000u) == 0u) {
            if (sp == 0) break;
            node_group = stack[--sp];
        }
    }
    return hit.prim != NONE;
}

#endif
