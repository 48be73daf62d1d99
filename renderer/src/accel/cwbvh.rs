//! The compressed 8-wide BVH (`accel: "cwbvh"`; Ylitie, Karras & Laine 2017): 80-byte nodes
//! whose eight child boxes are quantised to 8 bits per plane against a per-node origin and
//! power-of-two scale, walked by shaders/common/traverse_cwbvh.glsl in ray-octant order with a
//! stack of node groups.
//!
//! obvhs builds it: PLOC (Meister & Bittner 2018) with reinsertion gives a binary BVH of one
//! primitive per leaf, and obvhs's converter, run on every core (cwbvh_convert.rs: the same tree
//! bit for bit), collapses it into the wide tree by the paper's SAH-cost dynamic programme
//! (leaves of at most 3 primitives), ordering each node's children by octant. Three guards are
//! ours:
//!
//! 0. PLOC merges one pair per pass among identical boxes (quadratic: a million copies of one
//!    triangle would take hours), so it runs over the distinct boxes and each leaf is then
//!    expanded into a balanced subtree over the copies of its box (`expand_copies`).
//! 1. The converter recurses once per binary level, and pathological meshes (a million identical
//!    triangles, triangles nested in each other) make PLOC chains as deep as the mesh is long.
//!    Before converting, binary subtrees deeper than [`BINARY_LIMIT`] are rebuilt balanced
//!    (`bound_height`).
//! 2. The traversal's stack holds [`STACK_DEPTH`] groups and a walk pushes at most one per
//!    level, so the wide tree must be at most that deep. Every wide node's children are binary
//!    descendants at least one level further down, so a wide tree is never deeper than the
//!    binary one it came from: when the first conversion is too deep, the binary tree is bounded
//!    to [`STACK_DEPTH`] levels and converted again, which cannot fail.
//!
//! The leaves' slots are the primitives' indices: by default the primitives are stored in the
//! CWBVH's own leaf order, and nothing more is uploaded. The testing aid `cwbvh_bvh_order`
//! stores them in the binary BVH's order instead, so images of both structures number
//! primitives (and lights) alike; the leaves then reach them through an index per slot
//! (`prims`, binding CWBVH_PRIMS, kernels built with `CWBVH_INDIRECT`).
//!
//! Trees of mostly empty nodes (fewer than [`SPARSE_CHILDREN`] children a node: scenes of one to
//! three spheres) are walked by kernels built with `CWBVH_SPARSE` ([`Cwbvh::sparse`]), which skip
//! empty slots; fuller trees test all eight without a branch.

use obvhs::aabb::Aabb;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::Bvh2;

use super::cwbvh_convert::bvh2_to_cwbvh;
use super::distinct::{distinct_boxes, Copies};
use super::flatten::heights;
use super::{Phases, PrimBounds};
use crate::layout::GpuCwbvhNode;

/// Levels the wide tree may have: the shaders' `CWBVH_STACK` (declared in layout.rs).
pub const STACK_DEPTH: usize = crate::layout::CWBVH_STACK_DEPTH as usize;
/// Binary levels above which a subtree is rebuilt balanced before the conversion (whose
/// recursion follows the binary tree).
pub const BINARY_LIMIT: usize = 256;
/// Most primitives in one wide leaf (the node format's limit).
pub const MAX_LEAF: u32 = 3;

/// Below this many non-empty children per node the kernels skip empty slots ([`Cwbvh::sparse`]).
/// Measured on an H100 (bench/RESULTS.md, "The CWBVH node test and wide BVH loads", call 5):
/// skipping made the one-sphere furnace (1 child a node) 1.24-1.47× and the three-sphere envmap
/// scene (3) 1.09-1.12× faster than the branchless test, but the Cornell box (8 children a
/// node), textured_mesh (7.7) and meshes of 2M and 8M triangles 0.90-0.93× as fast; lights (5)
/// measured −1 to +7% with the branchless test (call 4). A mesh of 100k triangles has 7.6.
pub const SPARSE_CHILDREN: f64 = 4.0;

/// A built CWBVH: nodes (in the frame of the bounds given), `order[slot]` = the input index of
/// the primitive at leaf slot `slot`, and the depth in wide levels.
#[derive(Debug, Clone)]
pub struct Built {
    pub nodes: Vec<GpuCwbvhNode>,
    pub order: Vec<u32>,
    pub depth: usize,
    /// Seconds of each step of the build.
    pub phases: Phases,
}

/// The CWBVH as uploaded: nodes (binding CWBVH_NODES) and, per leaf slot, the index of its
/// primitive in the scene's (reordered) primitives (binding CWBVH_PRIMS; kernels built with
/// `CWBVH_INDIRECT`). Empty `prims`: the identity (primitives stored in leaf order, the default),
/// so no index buffer is uploaded or read.
#[derive(Debug, Clone, PartialEq)]
pub struct Cwbvh {
    pub nodes: Vec<GpuCwbvhNode>,
    pub prims: Vec<u32>,
}

impl Cwbvh {
    /// Non-empty child slots per node (0 to 8).
    pub fn mean_children(&self) -> f64 {
        let slots: usize = self
            .nodes
            .iter()
            .map(|n| n.meta.iter().filter(|&&m| m != 0).count())
            .sum();
        slots as f64 / self.nodes.len().max(1) as f64
    }

    /// Whether the kernels should skip empty child slots one by one (`CWBVH_SPARSE`): trees of
    /// mostly empty nodes, fewer than [`SPARSE_CHILDREN`] children a node (a scene of a sphere or
    /// three). Fuller trees test all eight slots without a branch, which lets the compiler
    /// overlap the children's tests (shaders/common/traverse_cwbvh.glsl).
    pub fn sparse(&self) -> bool {
        self.mean_children() < SPARSE_CHILDREN
    }

    /// Bytes of both buffers.
    pub fn bytes(&self) -> u64 {
        (std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.prims.as_slice())) as u64
    }
}

/// Builds the CWBVH over `prims`. An empty scene yields one node without children.
pub fn build(prims: &[PrimBounds]) -> Built {
    if prims.is_empty() {
        return Built {
            nodes: vec![bytemuck::Zeroable::zeroed()],
            order: Vec::new(),
            depth: 1,
            phases: Phases::default(),
        };
    }
    let mut ph = Phases::default();
    // Step 1: PLOC and reinsertion (obvhs's cwbvh builder, steps kept apart for the guards),
    // over distinct boxes: PLOC merges one pair per pass among identical boxes, quadratic in
    // their number, so copies of a box share one leaf, expanded afterwards.
    let copies = ph.time("distinct", || distinct_boxes(prims));
    let reps = &copies.reps;
    // Without copies the distinct boxes are the input itself.
    let copied: Vec<PrimBounds> = if reps.len() < prims.len() {
        ph.time("rep_bounds", || {
            use rayon::prelude::*;
            reps.par_iter().map(|&i| prims[i as usize]).collect()
        })
    } else {
        Vec::new()
    };
    let rep_bounds = if reps.len() < prims.len() {
        &copied[..]
    } else {
        prims
    };
    let params = super::build_params(REINSERTION);
    let mut bvh2 = ph.time("ploc", || super::ploc(rep_bounds, &params));
    ph.time("reinsert", || {
        ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None)
    });
    if reps.len() < prims.len() {
        let built = std::mem::take(&mut bvh2);
        bvh2 = ph.time("expand", || expand_copies(built, prims, &copies));
    }
    // Step 2: binary chains bounded for the converter, then the conversion.
    if let Some(b) = ph.time("bound", || bound_height(&bvh2, prims, BINARY_LIMIT)) {
        bvh2 = b;
    }
    let mut built = convert(&bvh2, &mut ph);
    // Step 3: a wide tree deeper than the stack: convert a binary tree of at most that height.
    if built.depth > STACK_DEPTH {
        if let Some(b) = bound_height(&bvh2, prims, STACK_DEPTH) {
            built = convert(&b, &mut ph);
        }
    }
    debug_assert!(built.depth <= STACK_DEPTH, "{}", built.depth);
    built.phases = ph;
    built
}

/// The reinsertion batch ratio of the binary tree before the conversion: obvhs's fast preset's
/// (its medium preset, which the binary BVH keeps, has 0.05). Measured on an H100 host (bench/
/// RESULTS.md, "Cold builds on every core", 2026-11-27): 0.05 → 0.02 renders the same
/// Msamples/s at 2M and 30M triangles (the collapse to 8-wide nodes re-decides most of what
/// reinsertion refines), its reinsertion taking 0.75 s instead of 1.50 s at 30M; none at all
/// costs 2%.
const REINSERTION: f32 = 0.02;

fn convert(bvh2: &Bvh2, ph: &mut Phases) -> Built {
    let mut cw = bvh2_to_cwbvh(bvh2, MAX_LEAF, ph);
    let (nodes, depth) = ph.time("nodes", || {
        let nodes: Vec<GpuCwbvhNode> = bytemuck::cast_vec(std::mem::take(&mut cw.nodes));
        let depth = depth_of(&nodes).expect("obvhs builds a tree");
        (nodes, depth)
    });
    Built {
        nodes,
        order: cw.primitive_indices,
        depth,
        phases: Phases::default(),
    }
}

/// `bvh`, built over the distinct boxes, with each leaf (one distinct box) replaced by a
/// balanced subtree over the primitives of that box (`copies`), one primitive per leaf.
/// In place: a leaf whose box has one primitive takes that primitive's index (in parallel);
/// the few others become inner nodes whose subtrees are appended (the tree is the same as a
/// top-down copy would make; only where its nodes are stored differs).
fn expand_copies(bvh: Bvh2, prims: &[PrimBounds], copies: &Copies) -> Bvh2 {
    use rayon::prelude::*;
    let Bvh2 {
        mut nodes,
        primitive_indices: mut indices,
        ..
    } = bvh;
    // Step 1: the leaves that hold more than one primitive once expanded, with those primitives.
    let members_of = |n: &Bvh2Node, indices: &[u32]| -> Vec<u32> {
        let f = n.first_index as usize;
        indices[f..f + n.prim_count as usize]
            .iter()
            .flat_map(|&r| copies.members(r).iter().copied())
            .collect()
    };
    let multi: Vec<(usize, Vec<u32>)> = (nodes.par_iter().enumerate())
        .filter(|(_, n)| {
            n.prim_count > 1
                || (n.prim_count == 1 && copies.members(indices[n.first_index as usize]).len() > 1)
        })
        .map(|(i, n)| (i, members_of(n, &indices)))
        .collect();
    // Step 2: every slot from its distinct box to that box's (first) primitive.
    indices
        .par_iter_mut()
        .for_each(|p| *p = copies.members(*p)[0]);
    // Step 3: the other leaves split into balanced subtrees over their primitives, the first
    // leaves in the old slots, the others in new ones.
    for (leaf, set) in multi {
        let f = nodes[leaf].first_index;
        let mut reuse = f..f + nodes[leaf].prim_count;
        let mut tasks = vec![(set, leaf)];
        while let Some((mut set, out)) = tasks.pop() {
            let b = prims[set[0] as usize];
            let aabb = Aabb::new(b.min.into(), b.max.into());
            if set.len() == 1 {
                let slot = reuse.next().unwrap_or_else(|| {
                    indices.push(0);
                    indices.len() as u32 - 1
                });
                indices[slot as usize] = set[0];
                nodes[out] = Bvh2Node::new(aabb, 1, slot);
                continue;
            }
            let right = set.split_off(set.len() / 2);
            let c = nodes.len();
            nodes.extend([Bvh2Node::default(); 2]);
            nodes[out] = Bvh2Node::new(aabb, 0, c as u32);
            tasks.push((set, c));
            tasks.push((right, c + 1));
        }
    }
    Bvh2 {
        nodes,
        primitive_indices: indices,
        ..Default::default()
    }
}

/// Inner levels of `bvh` (its longest root-to-leaf path; 0 for a lone leaf), without per-node
/// arrays: subtrees near the root in parallel, each walked with an explicit stack (chains may be
/// deep).
fn height_of(bvh: &Bvh2) -> usize {
    fn walk(nodes: &[Bvh2Node], root: usize, level: usize) -> usize {
        let n = &nodes[root];
        let f = n.first_index as usize;
        if n.prim_count > 0 {
            return level;
        }
        if level < 12 {
            let (a, b) = rayon::join(
                || walk(nodes, f, level + 1),
                || walk(nodes, f + 1, level + 1),
            );
            return a.max(b);
        }
        let (mut most, mut stack) = (level, vec![(root, level)]);
        while let Some((i, d)) = stack.pop() {
            let n = &nodes[i];
            if n.prim_count > 0 {
                most = most.max(d);
            } else {
                let f = n.first_index as usize;
                stack.extend([(f, d + 1), (f + 1, d + 1)]);
            }
        }
        most
    }
    if bvh.nodes.is_empty() {
        return 0;
    }
    walk(&bvh.nodes, 0, 0)
}

/// Inner levels of a balanced tree over `n` single-primitive leaves: ⌈log2 n⌉.
fn balanced_height(n: u64) -> usize {
    (n.max(1).next_power_of_two().trailing_zeros()) as usize
}

/// `bvh` (one primitive per leaf, over `prims`) with at most `limit` inner levels, or None when
/// it has no more already. Top-down, as renderer/src/accel/flatten.rs does for the binary BVH:
/// a subtree that fits is copied; one that does not is kept when each child can be made to fit
/// one level further down, and otherwise rebuilt balanced (object median along the longest
/// centroid axis), whose height ⌈log2 n⌉ fits whenever n ≤ 2^limit.
fn bound_height(bvh: &Bvh2, prims: &[PrimBounds], limit: usize) -> Option<Bvh2> {
    // The usual tree fits: found without the per-node arrays (a second of a 30M build).
    if height_of(bvh) <= limit {
        return None;
    }
    let (height, count) = heights(bvh);
    let src = &bvh.nodes;
    enum Task {
        Copy {
            src: usize,
            out: usize,
            depth: usize,
        },
        Balanced {
            set: Vec<u32>,
            out: usize,
            depth: usize,
        },
    }
    let subtree_prims = |i: usize| -> Vec<u32> {
        let mut v = Vec::with_capacity(count[i] as usize);
        let mut st = vec![i];
        while let Some(j) = st.pop() {
            let n = &src[j];
            if n.prim_count > 0 {
                let f = n.first_index as usize;
                v.extend_from_slice(&bvh.primitive_indices[f..f + n.prim_count as usize]);
            } else {
                st.extend([n.first_index as usize, n.first_index as usize + 1]);
            }
        }
        v
    };
    let mut nodes = vec![Bvh2Node::default()];
    let mut indices: Vec<u32> = Vec::with_capacity(bvh.primitive_indices.len());
    let mut tasks = vec![Task::Copy {
        src: 0,
        out: 0,
        depth: 1,
    }];
    while let Some(task) = tasks.pop() {
        match task {
            Task::Copy { src: i, out, depth } => {
                let n = src[i];
                if n.prim_count > 0 {
                    let f = n.first_index as usize;
                    let first = indices.len() as u32;
                    indices.extend_from_slice(&bvh.primitive_indices[f..f + n.prim_count as usize]);
                    nodes[out] = Bvh2Node::new(*n.aabb(), n.prim_count, first);
                    continue;
                }
                let (l, r) = (n.first_index as usize, n.first_index as usize + 1);
                let fits = depth - 1 + height[i] as usize <= limit;
                let fixable = [l, r]
                    .iter()
                    .all(|&c| depth + balanced_height(count[c]) <= limit);
                if fits || fixable {
                    let c = nodes.len();
                    nodes.extend([Bvh2Node::default(); 2]);
                    nodes[out] = Bvh2Node::new(*n.aabb(), 0, c as u32);
                    tasks.push(Task::Copy {
                        src: l,
                        out: c,
                        depth: depth + 1,
                    });
                    tasks.push(Task::Copy {
                        src: r,
                        out: c + 1,
                        depth: depth + 1,
                    });
                } else {
                    tasks.push(Task::Balanced {
                        set: subtree_prims(i),
                        out,
                        depth,
                    });
                }
            }
            Task::Balanced {
                mut set,
                out,
                depth,
            } => {
                let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
                let (mut clo, mut chi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
                for &p in &set {
                    let b = prims[p as usize];
                    for a in 0..3 {
                        lo[a] = lo[a].min(b.min[a]);
                        hi[a] = hi[a].max(b.max[a]);
                        let c = 0.5 * (b.min[a] + b.max[a]);
                        clo[a] = clo[a].min(c);
                        chi[a] = chi[a].max(c);
                    }
                }
                let aabb = Aabb::new(lo.into(), hi.into());
                if set.len() == 1 {
                    nodes[out] = Bvh2Node::new(aabb, 1, indices.len() as u32);
                    indices.push(set[0]);
                    continue;
                }
                // The object median along the longest axis of the centroids' box.
                let axis = (0..3)
                    .max_by(|&a, &b| (chi[a] - clo[a]).total_cmp(&(chi[b] - clo[b])))
                    .unwrap_or(0);
                let key = |p: &u32| {
                    let b = prims[*p as usize];
                    b.min[axis] + b.max[axis]
                };
                let mid = set.len() / 2;
                set.select_nth_unstable_by(mid, |x, y| key(x).total_cmp(&key(y)));
                let right = set.split_off(mid);
                let c = nodes.len();
                nodes.extend([Bvh2Node::default(); 2]);
                nodes[out] = Bvh2Node::new(aabb, 0, c as u32);
                tasks.push(Task::Balanced {
                    set,
                    out: c,
                    depth: depth + 1,
                });
                tasks.push(Task::Balanced {
                    set: right,
                    out: c + 1,
                    depth: depth + 1,
                });
            }
        }
    }
    Some(Bvh2 {
        nodes,
        primitive_indices: indices,
        ..Default::default()
    })
}

/// The depth (wide levels) of `nodes` as a tree from node 0, or None when it is not one: a child
/// index out of range, or a node reached twice (a cycle or shared subtree).
pub fn depth_of(nodes: &[GpuCwbvhNode]) -> Option<usize> {
    let mut seen = vec![false; nodes.len()];
    let mut most = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, d)) = stack.pop() {
        if i >= nodes.len() || std::mem::replace(&mut seen[i], true) {
            return None;
        }
        most = most.max(d);
        let imask = nodes[i].e_imask[3];
        for k in 0..imask.count_ones() as usize {
            stack.push((nodes[i].child_base as usize + k, d + 1));
        }
    }
    Some(most)
}

/// Whether every leaf of `nodes` indexes within `slots` leaf slots.
pub fn leaves_in_range(nodes: &[GpuCwbvhNode], slots: usize) -> bool {
    nodes.iter().all(|n| {
        (0..8).all(|c| {
            let meta = n.meta[c];
            let inner = n.e_imask[3] & (1 << c) != 0;
            inner
                || meta == 0
                || n.prim_base as u64 + (meta & 0x1f) as u64 + (meta >> 5).count_ones() as u64
                    <= slots as u64
        })
    })
}

#[cfg(test)]
#[path = "cwbvh_tests.rs"]
mod tests;
