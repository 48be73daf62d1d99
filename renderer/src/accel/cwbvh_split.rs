//! The binary-to-wide conversion of the CWBVH in parallel, around obvhs's serial converter
//! (`bvh2_to_cwbvh`, one recursion over the whole tree): the binary tree is cut into subtrees
//! of at most `max_sub` primitives, each converted on its own thread, and the part above the cut
//! is converted with each subtree standing in as a one-primitive leaf; the results are then
//! stitched into one tree.
//!
//! The converter's choices (which binary nodes become wide nodes, how leaves group) are made
//! bottom-up from each subtree's own costs, so inside a subtree they are exactly what the whole
//! conversion makes. What differs is the seam: every subtree root becomes a wide node of its own
//! (the whole conversion could have spread its children into the wide node above), and the
//! part above sees the subtrees as cheap leaves. With a few hundred subtrees out of millions of
//! nodes the seam is a tiny part of the tree (`split_conversion_keeps_quality` measures it).
//!
//! 1. Primitive counts of every binary subtree; the cut: the children with at most `max_sub`
//!    primitives of nodes with more.
//! 2. Each subtree copied out as its own `Bvh2` and converted (in parallel); the top copied out
//!    with each subtree as a leaf holding one "primitive", the subtree's number, and converted.
//! 3. Stitching, top-down over the top's wide nodes: every node's children are laid out
//!    together in slot order (the node format finds internal children at consecutive indices);
//!    a leaf child (a subtree) becomes an internal child, the subtree's root node, and the
//!    subtree's other nodes follow as a block, their child and primitive indices moved by the
//!    block's and the subtree's primitive offsets.
//! 4. A wide node's children are binary descendants at least one level further down on both
//!    sides of the seam, so the wide tree is still at most as deep as the binary one.

use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::cwbvh::CwBvh;
use rayon::prelude::*;

use super::flatten::heights;

/// Converts `bvh2` (one primitive per leaf) to the wide node array and leaf-slot order, as
/// `bvh2_to_cwbvh(bvh2, max_leaf, true, false)` would but converting subtrees of at most
/// `max_sub` (≥ 1) primitives in parallel. None when the whole tree is that small, or its top
/// is not shaped for the split (convert it whole).
pub fn convert_split(
    bvh2: &Bvh2,
    max_leaf: u32,
    max_sub: u64,
) -> Option<(Vec<CwBvhNode>, Vec<u32>)> {
    // Step 1: counts and the cut.
    let (_, count) = heights(bvh2);
    let src = &bvh2.nodes;
    if src[0].is_leaf() || count[0] <= max_sub {
        return None;
    }
    // A top that is not a tree of a few levels (a chain peeling off small subtrees) would make
    // many small subtrees, each a wide node of its own, where the whole conversion packs them:
    // such trees are converted whole.
    let parts = count[0] / max_sub + 1;
    let max_depth = 2 * (u64::BITS - parts.leading_zeros()) as usize + 8;
    let mut cuts: Vec<usize> = Vec::new();
    let mut stack = vec![(0usize, 0usize)];
    while let Some((i, d)) = stack.pop() {
        if d > max_depth || cuts.len() as u64 > 4 * parts {
            return None;
        }
        for c in [src[i].first_index as usize, src[i].first_index as usize + 1] {
            if count[c] <= max_sub {
                cuts.push(c);
            } else {
                stack.push((c, d + 1));
            }
        }
    }
    // Step 2: the subtrees, then the top, converted.
    let subs: Vec<CwBvh> = cuts
        .par_iter()
        .map(|&c| {
            let sub = copy_out(bvh2, c, |_| false);
            bvh2_to_cwbvh(&sub, max_leaf, true, false)
        })
        .collect();
    let mut cut_of = vec![u32::MAX; src.len()];
    for (k, &c) in cuts.iter().enumerate() {
        cut_of[c] = k as u32;
    }
    let top = copy_out(bvh2, 0, |i| cut_of[i] != u32::MAX);
    // The top's leaves hold the subtree numbers, in place of primitive indices.
    let mut top = top;
    for p in top.primitive_indices.iter_mut() {
        *p = cut_of[*p as usize];
    }
    let top = bvh2_to_cwbvh(&top, 1, true, false);
    // Step 3: stitching. Each subtree's primitives go where its root is reached, in the top's
    // order of leaves.
    let mut prim_at = vec![0u32; subs.len()];
    let mut order = Vec::with_capacity(bvh2.primitive_indices.len());
    for &k in &top.primitive_indices {
        prim_at[k as usize] = order.len() as u32;
        order.extend_from_slice(&subs[k as usize].primitive_indices);
    }
    let total_nodes = top.nodes.len() + subs.iter().map(|s| s.nodes.len()).sum::<usize>();
    let mut nodes: Vec<CwBvhNode> = Vec::with_capacity(total_nodes);
    nodes.push(top.nodes[0]);
    // (top node, its place in `nodes`), laid out breadth-first.
    let mut queue = std::collections::VecDeque::from([(0usize, 0usize)]);
    let mut bodies: Vec<(usize, usize)> = Vec::new(); // (subtree, block start)
    while let Some((t, at)) = queue.pop_front() {
        let mut node = top.nodes[t];
        let base = nodes.len();
        let mut next_internal = 0;
        let mut placed = 0usize;
        for i in 0..8 {
            let meta = node.child_meta[i];
            if meta == 0 {
                continue;
            }
            if node.imask & (1 << i) != 0 {
                let child = node.child_base_idx as usize + next_internal;
                next_internal += 1;
                nodes.push(CwBvhNode::default());
                queue.push_back((child, base + placed));
            } else {
                let k = top.primitive_indices
                    [(node.primitive_base_idx + (meta & 0x1f) as u32) as usize]
                    as usize;
                // The subtree's root here; its other nodes as a block after everything else.
                let mut root = subs[k].nodes[0];
                bodies.push((k, 0));
                let body = bodies.len() - 1;
                root.primitive_base_idx += prim_at[k];
                nodes.push(root);
                // The root's child index is fixed once the block's start is known.
                bodies[body].1 = base + placed;
                node.imask |= 1 << i;
                node.child_meta[i] = (24 + i as u8) | 0b0010_0000;
            }
            placed += 1;
        }
        node.child_base_idx = base as u32;
        node.primitive_base_idx = 0;
        nodes[at] = node;
    }
    // Step 3b: the subtrees' other nodes, block by block, indices moved.
    for (k, root_at) in bodies {
        let sub = &subs[k];
        let start = nodes.len();
        // Node j ≥ 1 of the subtree goes to start + j − 1.
        let shift = |n: &mut CwBvhNode| {
            n.child_base_idx = (n.child_base_idx as usize + start - 1) as u32;
        };
        shift(&mut nodes[root_at]);
        nodes.extend(sub.nodes[1..].iter().map(|&n| {
            let mut n = n;
            shift(&mut n);
            n.primitive_base_idx += prim_at[k];
            n
        }));
    }
    debug_assert_eq!(nodes.len(), total_nodes);
    Some((nodes, order))
}

/// The subtree of binary node `root` as a `Bvh2` of its own, children in adjacent pairs as
/// obvhs lays them out; a node for which `stop` holds becomes a leaf of one primitive, its
/// node index (the caller renumbers those).
fn copy_out(bvh2: &Bvh2, root: usize, stop: impl Fn(usize) -> bool) -> Bvh2 {
    let src = &bvh2.nodes;
    let mut nodes = vec![Bvh2Node::default()];
    let mut indices = Vec::new();
    let mut stack = vec![(root, 0usize)];
    while let Some((i, out)) = stack.pop() {
        let n = src[i];
        if i != root && stop(i) {
            nodes[out] = Bvh2Node::new(*n.aabb(), 1, indices.len() as u32);
            indices.push(i as u32);
        } else if n.is_leaf() {
            let f = n.first_index as usize;
            nodes[out] = Bvh2Node::new(*n.aabb(), n.prim_count, indices.len() as u32);
            indices.extend_from_slice(&bvh2.primitive_indices[f..f + n.prim_count as usize]);
        } else {
            let c = nodes.len();
            nodes.extend([Bvh2Node::default(); 2]);
            nodes[out] = Bvh2Node::new(*n.aabb(), 0, c as u32);
            stack.push((n.first_index as usize, c));
            stack.push((n.first_index as usize + 1, c + 1));
        }
    }
    Bvh2 {
        nodes,
        primitive_indices: indices,
        ..Default::default()
    }
}
