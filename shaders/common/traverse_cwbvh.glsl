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
// quantised child boxes at once (all eight without a branch; kernels for trees of mostly empty
// nodes, built with CWBVH_SPARSE, skip empty slots); leaves' primitives are tested right away.
// Measured slower here and not used: Ylitie et al.'s triangle postponing, a stack partly in
// shared memory, and conversion-free byte decoding through 2^23's mantissa (bench/RESULTS.md,
// "The CWBVH node test and wide BVH loads", 2026-11-27).
//
// Child boxes are tested against the ray transformed into each node's quantised frame (one
// multiply-add per plane; intervals widened by a bound on its rounding). The host quantises them
// so that their f32 decoding p + e·q still contains every child
// (renderer/src/compile/frame.rs, `place_cwbvh`), and keeps every tree within CWBVH_STACK
// levels: a walk pushes at most one group per level, so the stack never overflows (the guard
// on the push only keeps a corrupt tree from writing out of bounds).
// Included from common/traverse.glsl after intersect_prim.
#ifndef COMMON_TRAVERSE_CWBVH_GLSL
#define COMMON_TRAVERSE_CWBVH_GLSL

// Nodes are read as five 16-byte words each, so every node is fetched with five wide loads (the
// struct declared over a scalar-layout buffer may be read a word at a time).
layout(set = 0, binding = B_CWBVH_NODES, std430) readonly buffer CwbvhNodes { uvec4 cw_words[]; };
#ifdef CWBVH_INDIRECT
// Leaf slot -> primitive, when the primitives are not stored in leaf order (a testing aid).
layout(set = 0, binding = B_CWBVH_PRIMS, scalar) readonly buffer CwbvhPrims { uint cwbvh_prims[]; };
#endif

// Node i (the word layout of GpuCwbvhNode, renderer/src/layout.rs).
GpuCwbvhNode cw_node(uint i) {
    uvec4 w0 = cw_words[5u * i], w1 = cw_words[5u * i + 1u], w2 = cw_words[5u * i + 2u],
          w3 = cw_words[5u * i + 3u], w4 = cw_words[5u * i + 4u];
    GpuCwbvhNode n;
    n.p = uintBitsToFloat(w0.xyz); n.e_imask = w0.w;
    n.child_base = w1.x; n.prim_base = w1.y; n.meta = w1.zw;
    n.q[0] = w2.xy; n.q[1] = w2.zw; n.q[2] = w3.xy; n.q[3] = w3.zw; n.q[4] = w4.xy; n.q[5] = w4.zw;
    return n;
}

// Relative slack of the transformed-ray test (cw_intersect_node): 8 ulps of 2^-24, twice the
// rounding bound.
const float CW_SLACK = 8.0 * 5.96046448e-8;

// Byte c (0..7) of eight packed in a uvec2.
uint cw_byte(uvec2 v, uint c) {
    return ((c < 4u ? v.x : v.y) >> ((c & 3u) * 8u)) & 0xffu;
}

// The hit mask of node n's children (see the top), for a ray with octant bits oct_inv.
uint cw_intersect_node(GpuCwbvhNode n, Ray r, RayPre pre, uint oct_inv) {
    // Step 1: the ray in the node's quantised frame (the paper's transformed ray): a child's
    // plane q on an axis lies at p + e·q, so the ray meets it at q·(e·inv_d) + (p - o)·inv_d,
    // one multiply-add per plane instead of decoding the box and then running the slab test.
    vec3 e = vec3(uintBitsToFloat((n.e_imask & 0xffu) << 23),
                  uintBitsToFloat(((n.e_imask >> 8) & 0xffu) << 23),
                  uintBitsToFloat(((n.e_imask >> 16) & 0xffu) << 23));
    vec3 scale = e * pre.inv_d;
    vec3 shift = (n.p - r.o) * pre.inv_d;
    // Rounding: shift carries two roundings, the multiply-add one more, so a plane's distance
    // is off by at most a few ulps of |shift| + 255·|scale| (which bounds |t| within the node)
    // in absolute terms, also where the two terms cancel (a ray starting near a child's plane).
    // Entering earlier and leaving later by that much keeps every box the ray touches; folded
    // into the shifts, it costs nothing per child.
    vec3 slack = CW_SLACK * (abs(shift) + 255.0 * abs(scale));
    vec3 shift_near = shift - slack, shift_far = shift + slack;
    // Step 2: per axis, the planes the ray enters by (the low ones when it runs towards +).
    bvec3 neg = lessThan(pre.inv_d, vec3(0.0));
    uvec2 near_x = neg.x ? n.q[1] : n.q[0], far_x = neg.x ? n.q[0] : n.q[1];
    uvec2 near_y = neg.y ? n.q[3] : n.q[2], far_y = neg.y ? n.q[2] : n.q[3];
    uvec2 near_z = neg.z ? n.q[5] : n.q[4], far_z = neg.z ? n.q[4] : n.q[5];
    // Step 3: where each child's hit bits go, for four children at once from each meta word
    // (one byte a child): inner children (bits 3 and 4 set) to bit 24 + (slot XOR octant),
    // leaves to their first primitive's slot (the low five bits). The bits themselves (5..7)
    // are 1 for an inner child, the leaf's primitives in unary, and 0 for an empty slot, which
    // therefore adds nothing whatever its box: no branch per child, so the compiler overlaps
    // the eight tests (7-16% faster than a branch per child for nee on the Cornell box and
    // large meshes; trees of mostly empty nodes keep the branch: CWBVH_SPARSE).
    uint inner_lo = (n.meta.x & (n.meta.x << 1u)) & 0x10101010u;
    uint inner_hi = (n.meta.y & (n.meta.y << 1u)) & 0x10101010u;
    uvec2 index = uvec2((n.meta.x ^ ((inner_lo >> 4u) * oct_inv)) & 0x1f1f1f1fu,
                        (n.meta.y ^ ((inner_hi >> 4u) * oct_inv)) & 0x1f1f1f1fu);
    uvec2 bits = (n.meta >> 5u) & 0x07070707u;
    // Step 4: each child's slab interval, widened by the slack.
    uint hitmask = 0u;
    for (uint c = 0u; c < 8u; ++c) {
#ifdef CWBVH_SPARSE
        // Trees of mostly empty nodes (renderer/src/accel/cwbvh.rs, `Cwbvh::sparse`).
        if (cw_byte(bits, c) == 0u) continue;
#endif
        vec3 tn = vec3(cw_byte(near_x, c), cw_byte(near_y, c), cw_byte(near_z, c)) * scale + shift_near;
        vec3 tf = vec3(cw_byte(far_x, c), cw_byte(far_y, c), cw_byte(far_z, c)) * scale + shift_far;
        float enter = max(max(tn.x, tn.y), max(tn.z, r.tmin));
        float leave = min(min(tf.x, tf.y), min(tf.z, r.tmax));
        // A NaN interval counts as a hit (the conservative side).
        hitmask |= (!(enter > leave) ? cw_byte(bits, c) : 0u) << cw_byte(index, c);
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
            GpuCwbvhNode n = cw_node(node_group.x + rel);
            COUNT_NODE;
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
