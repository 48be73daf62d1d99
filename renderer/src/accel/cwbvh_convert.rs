//! The binary BVH collapsed into the compressed 8-wide tree on every core: the same tree, node
//! for node and bit for bit, as obvhs's serial `bvh2_to_cwbvh(bvh2, max_leaf, true, false)`
//! (Ylitie et al. 2017's SAH-cost dynamic programme after jan-van-bergen's GPU-Raytracer, children
//! ordered by octant), which took 11.6 of a 30M-triangle build's 22.5 s on one core of an H100
//! host (bench/RESULTS.md, "Cold builds on every core").
//!
//! 1. Costs: bottom-up, each binary node's seven decisions (make a leaf, an internal wide node,
//!    or distribute i+1 slots between its two children) from its children's. Subtrees near the
//!    root run in parallel (`rayon::join`); a node's slots are written only by its own task.
//! 2. Nodes: top-down, each wide node's children gathered by the decisions and ordered by
//!    octant, its internal children's nodes allocated as one block right after it is visited and
//!    its leaves' primitives appended, depth first. The top [`PARALLEL_LEVELS`] wide levels
//!    convert their children's subtrees in parallel into buffers of their own (indices relative
//!    to them); the serial order's offsets are then laid out from their sizes and every buffer
//!    is copied into its place in the final arrays at once, its indices shifted (no appends
//!    level by level: with them this step took 1.65 s at 30M triangles, 0.98 s without).
//!
//! Nothing here is used by anything but `cwbvh::build`; `cwbvh_tests` checks it against obvhs.

use glam::{UVec3, Vec3A};
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::node::CwBvhNode;
use rayon::prelude::*;

use super::Phases;

/// Binary levels whose two subtrees' costs are computed in parallel.
const PARALLEL_COST_LEVELS: u32 = 14;
/// Wide levels whose children's subtrees are converted in parallel (8⁴ = 4096 tasks at most).
const PARALLEL_LEVELS: u32 = 4;
/// obvhs's leaf cost factor (a primitive test's cost against a wide node's) and quantisation
/// denominator (1 / 255).
const PRIM_COST: f32 = 0.3;
const DENOM: f32 = 1.0 / 255.0;
const INVALID: u8 = u8::MAX;
const NO_CHILD: u32 = u32::MAX;

/// [`PRIM_COST`], or the measuring knob `CANDELA_CWBVH_PRIM_COST` (0.01 to 10; part of the accel
/// cache's key, `accel::knobs`).
fn prim_cost() -> f32 {
    static COST: std::sync::OnceLock<f32> = std::sync::OnceLock::new();
    *COST.get_or_init(|| {
        let knob = std::env::var("CANDELA_CWBVH_PRIM_COST").ok();
        knob.and_then(|v| v.parse::<f32>().ok())
            .map_or(PRIM_COST, |c| c.clamp(0.01, 10.0))
    })
}

#[derive(Copy, Clone, PartialEq, Default)]
enum Kind {
    Leaf,
    Internal,
    #[default]
    Distribute,
}

/// Slot i of a binary node: the best way to cover its subtree with at most i + 1 wide slots.
#[derive(Copy, Clone, Default)]
struct Decision {
    cost: f32,
    kind: Kind,
    left: u8,
    right: u8,
}

/// The decisions, written by disjoint tasks (each node's seven slots by the task that visits
/// the node, after its children's tasks are joined). Disjoint because the binary BVH is a tree:
/// every node is reached once from the root (checked after the fact: the primitives counted
/// equal the tree's; a node reached twice would count its primitives twice).
struct Decisions {
    ptr: *mut Decision,
    len: usize,
}
// SAFETY: tasks write disjoint slots (the tree's nodes are reached once each, see above) and read
// only slots written by tasks they joined.
unsafe impl Sync for Decisions {}

impl Decisions {
    fn get(&self, i: usize) -> Decision {
        assert!(i < self.len);
        // SAFETY: in bounds; written before (see the type's doc).
        unsafe { *self.ptr.add(i) }
    }
    fn set(&self, i: usize, d: Decision) {
        assert!(i < self.len);
        // SAFETY: in bounds; this slot belongs to the calling task alone.
        unsafe { *self.ptr.add(i) = d }
    }
}

/// The wide tree: nodes (root first) and the primitive index of each leaf slot.
pub struct Converted {
    pub nodes: Vec<CwBvhNode>,
    pub primitive_indices: Vec<u32>,
}

/// Converts `bvh2` (one primitive per leaf, as PLOC builds it) with wide leaves of at most
/// `max_prims_per_leaf` primitives (≤ 3).
/// The steps' times go into `ph` ("convert costs", "convert nodes").
pub fn bvh2_to_cwbvh(bvh2: &Bvh2, max_prims_per_leaf: u32, ph: &mut Phases) -> Converted {
    if bvh2.nodes.is_empty() {
        return Converted {
            nodes: Vec::new(),
            primitive_indices: Vec::new(),
        };
    }
    // Step 1: the cost table.
    let decisions = ph.time("convert costs", || {
        // (Filled in parallel: 56 bytes per node, gigabytes at tens of millions.)
        let mut decisions: Vec<Decision> = (0..bvh2.nodes.len() * 7)
            .into_par_iter()
            .map(|_| Decision::default())
            .collect();
        let shared = Decisions {
            ptr: decisions.as_mut_ptr(),
            len: decisions.len(),
        };
        let counted = cost(bvh2, &shared, 0, max_prims_per_leaf, 0);
        assert_eq!(
            counted as usize,
            bvh2.primitive_indices.len(),
            "the binary BVH is not a tree over its primitives"
        );
        decisions
    });
    // Step 2: the root (index 0) and everything below it (from index 1).
    ph.time("convert nodes", || {
        let c = Converter {
            bvh2,
            decisions: &decisions,
        };
        let (mut root, part) = c.plan(0, 0);
        let mut segs = Segments::default();
        let (nodes, prims) = lay(&part, 1, 0, &mut segs);
        shift(&mut root, 1, 0);
        let mut out = Converted {
            nodes: (0..1 + nodes as usize)
                .into_par_iter()
                .map(|_| CwBvhNode::default())
                .collect(),
            primitive_indices: vec![0; prims as usize],
        };
        out.nodes[0] = root;
        segs.write(&mut out.nodes[1..], &mut out.primitive_indices);
        out
    })
}

/// Step 1 for the subtree of binary node `n`: its decisions, after its children's; returns its
/// primitive count.
fn cost(bvh2: &Bvh2, d: &Decisions, n: usize, max_leaf: u32, level: u32) -> u32 {
    let node = &bvh2.nodes[n];
    let half_area = node.aabb().half_area();
    let (first, at) = (node.first_index as usize, n * 7);
    if node.prim_count != 0 {
        assert_eq!(
            node.prim_count, 1,
            "the wide tree is built from leaves of one primitive"
        );
        let leaf = Decision {
            cost: half_area * (node.prim_count as f32) * prim_cost(),
            kind: Kind::Leaf,
            left: 0,
            right: 0,
        };
        for i in 0..7 {
            d.set(at + i, leaf);
        }
        return node.prim_count;
    }
    let (a, b) = if level < PARALLEL_COST_LEVELS {
        rayon::join(
            || cost(bvh2, d, first, max_leaf, level + 1),
            || cost(bvh2, d, first + 1, max_leaf, level + 1),
        )
    } else {
        (
            cost(bvh2, d, first, max_leaf, level + 1),
            cost(bvh2, d, first + 1, max_leaf, level + 1),
        )
    };
    let prims = a + b;
    let (l, r) = (first * 7, (first + 1) * 7);
    // Slot 0 (i = 1 in the paper): a leaf, or an internal node over the best split of 8 slots.
    let cost_leaf = if prims <= max_leaf {
        (prims as f32) * half_area * prim_cost()
    } else {
        f32::INFINITY
    };
    let (mut best, mut left, mut right) = (f32::INFINITY, INVALID, INVALID);
    for k in 0..7 {
        let c = d.get(l + k).cost + d.get(r + 6 - k).cost;
        if c < best {
            (best, left, right) = (c, k as u8, 6 - k as u8);
        }
    }
    let internal = best + half_area;
    let (kind, c0) = if cost_leaf < internal {
        (Kind::Leaf, cost_leaf)
    } else {
        (Kind::Internal, internal)
    };
    d.set(
        at,
        Decision {
            cost: c0,
            kind,
            left,
            right,
        },
    );
    // Slots 1..6 (i = 2..7): the previous slot's, or i + 1 slots distributed to the children.
    for i in 1..7 {
        let prev = d.get(at + i - 1);
        let (mut best, mut split) = (prev.cost, None);
        for k in 0..i {
            let c = d.get(l + k).cost + d.get(r + i - k - 1).cost;
            if c < best {
                (best, split) = (c, Some((k as u8, (i - k - 1) as u8)));
            }
        }
        d.set(
            at + i,
            match split {
                Some((left, right)) => Decision {
                    cost: best,
                    kind: Kind::Distribute,
                    left,
                    right,
                },
                None => prev,
            },
        );
    }
    prims
}

/// `node`'s child and primitive indices shifted by `dn` and `dp`.
fn shift(node: &mut CwBvhNode, dn: u32, dp: u32) {
    node.child_base_idx += dn;
    node.primitive_base_idx += dp;
}

/// The top levels' plan of the wide tree: a subtree converted by one task, or a wide node over
/// binary node `n` whose children's parts were planned in parallel.
enum Part {
    Below(Below),
    Upper {
        /// Its leaf children's primitives.
        prims: Vec<u32>,
        /// Its internal children: each one's wide node (indices relative to its part) and part.
        children: Vec<(CwBvhNode, Part)>,
    },
}

/// The final arrays as runs in address order: nodes copied with their indices shifted, or made
/// while laying out (an upper node's children), and primitive indices copied as they are.
#[derive(Default)]
struct Segments<'a> {
    nodes: Vec<NodeRun<'a>>,
    prims: Vec<&'a [u32]>,
}

enum NodeRun<'a> {
    Shifted(&'a [CwBvhNode], u32, u32),
    Made(Vec<CwBvhNode>),
}

impl NodeRun<'_> {
    fn len(&self) -> usize {
        match self {
            NodeRun::Shifted(from, ..) => from.len(),
            NodeRun::Made(v) => v.len(),
        }
    }
}

impl Segments<'_> {
    /// Every run written into its place (`nodes` and `prims` exactly their total length), on
    /// every core.
    fn write(&self, nodes: &mut [CwBvhNode], prims: &mut [u32]) {
        let mut jobs = Vec::with_capacity(self.nodes.len());
        let mut rest = nodes;
        for run in &self.nodes {
            let (to, tail) = rest.split_at_mut(run.len());
            jobs.push((to, run));
            rest = tail;
        }
        assert!(rest.is_empty(), "node runs cover the array");
        jobs.into_par_iter().for_each(|(to, run)| match run {
            NodeRun::Shifted(from, dn, dp) => {
                to.par_iter_mut().zip(from.par_iter()).for_each(|(t, f)| {
                    *t = *f;
                    shift(t, *dn, *dp);
                })
            }
            NodeRun::Made(from) => to.copy_from_slice(from),
        });
        let mut jobs = Vec::with_capacity(self.prims.len());
        let mut rest = prims;
        for run in &self.prims {
            let (to, tail) = rest.split_at_mut(run.len());
            jobs.push((to, *run));
            rest = tail;
        }
        assert!(rest.is_empty(), "primitive runs cover the array");
        jobs.into_par_iter()
            .for_each(|(to, from)| to.par_iter_mut().zip(from).for_each(|(t, f)| *t = *f));
    }
}

/// Lays `part` out from node `node_at` and primitive `prim_at` in the serial order (an upper
/// node's leaf primitives, its children's block, then each child's part in turn), adding its
/// runs to `segs`; returns the nodes and primitives it holds.
fn lay<'a>(part: &'a Part, node_at: u32, prim_at: u32, segs: &mut Segments<'a>) -> (u32, u32) {
    match part {
        Part::Below(b) => {
            segs.nodes
                .push(NodeRun::Shifted(&b.nodes, node_at, prim_at));
            segs.prims.push(&b.prims);
            (b.nodes.len() as u32, b.prims.len() as u32)
        }
        Part::Upper { prims, children } => {
            segs.prims.push(prims);
            let block = segs.nodes.len();
            segs.nodes.push(NodeRun::Made(Vec::new()));
            let (mut n, mut p) = (
                node_at + children.len() as u32,
                prim_at + prims.len() as u32,
            );
            let mut heads = Vec::with_capacity(children.len());
            for (head, child) in children {
                let mut head = *head;
                shift(&mut head, n, p);
                heads.push(head);
                let (dn, dp) = lay(child, n, p, segs);
                (n, p) = (n + dn, p + dp);
            }
            segs.nodes[block] = NodeRun::Made(heads);
            (n - node_at, p - prim_at)
        }
    }
}

/// A wide node's internal children, in slot order (no allocation per node).
#[derive(Default)]
struct Children {
    slot: [u32; 8],
    len: usize,
}

impl Children {
    fn as_slice(&self) -> &[u32] {
        &self.slot[..self.len]
    }
}

/// What a subtree adds below its wide root: nodes and leaf primitives, indices relative to them.
#[derive(Default)]
struct Below {
    nodes: Vec<CwBvhNode>,
    prims: Vec<u32>,
}

struct Converter<'a> {
    bvh2: &'a Bvh2,
    decisions: &'a [Decision],
}

impl Converter<'_> {
    /// Step 2 for the wide node over binary node `n` (`level` wide levels below the root): the
    /// node and its subtree's part, indices relative to that part (children's block first).
    fn plan(&self, n: usize, level: u32) -> (CwBvhNode, Part) {
        let mut out = Below::default();
        if level >= PARALLEL_LEVELS {
            let head = self.visit(n, &mut out);
            return (head, Part::Below(out));
        }
        let (mut head, internal) = self.head(n, &mut out);
        head.child_base_idx = 0;
        let children = internal
            .as_slice()
            .par_iter()
            .map(|&c| self.plan(c as usize, level + 1))
            .collect();
        (
            head,
            Part::Upper {
                prims: out.prims,
                children,
            },
        )
    }

    /// Serial step 2 (obvhs's recursion): the wide node over `n`, its subtree appended to `out`.
    fn visit(&self, n: usize, out: &mut Below) -> CwBvhNode {
        let (mut head, internal) = self.head(n, out);
        let base = out.nodes.len();
        head.child_base_idx = base as u32;
        out.nodes.resize(base + internal.len, CwBvhNode::default());
        for (k, &c) in internal.as_slice().iter().enumerate() {
            out.nodes[base + k] = self.visit(c as usize, out);
        }
        head
    }

    /// The wide node over binary node `n` (child_base_idx left for the caller) with its leaf
    /// children's primitives appended to `out`, and its internal children in slot order.
    fn head(&self, n: usize, out: &mut Below) -> (CwBvhNode, Children) {
        let aabb = *self.bvh2.nodes[n].aabb();
        let mut node = CwBvhNode {
            p: aabb.min.into(),
            ..Default::default()
        };
        // The quantisation grid: a power of two per axis, 255 steps over the box.
        let e = ((aabb.max - aabb.min).max(Vec3A::splat(1e-20)) * DENOM)
            .log2()
            .ceil()
            .exp2();
        let rcp_e = 1.0 / e;
        let bits = UVec3::new(e.x.to_bits(), e.y.to_bits(), e.z.to_bits()) >> 23u32;
        node.e = [bits.x as u8, bits.y as u8, bits.z as u8];
        let mut children = [NO_CHILD; 8];
        let mut count = 0;
        self.children(n, &mut children, &mut count, 0);
        self.order_children(n, &mut children, count);
        node.imask = 0;
        node.primitive_base_idx = out.prims.len() as u32;
        let mut prims = 0u32;
        let mut internal = Children::default();
        for (i, &c) in children.iter().enumerate() {
            if c == NO_CHILD {
                continue;
            }
            let b = self.bvh2.nodes[c as usize].aabb();
            let lo = ((b.min - aabb.min) * rcp_e)
                .floor()
                .clamp(Vec3A::ZERO, Vec3A::splat(255.0));
            let hi = ((b.max - aabb.min) * rcp_e)
                .ceil()
                .clamp(Vec3A::ZERO, Vec3A::splat(255.0));
            node.child_min_x[i] = lo.x as u8;
            node.child_min_y[i] = lo.y as u8;
            node.child_min_z[i] = lo.z as u8;
            node.child_max_x[i] = hi.x as u8;
            node.child_max_y[i] = hi.y as u8;
            node.child_max_z[i] = hi.z as u8;
            match self.decisions[c as usize * 7].kind {
                Kind::Leaf => {
                    let before = out.prims.len();
                    self.leaf_prims(c as usize, &mut out.prims);
                    let k = (out.prims.len() - before) as u32;
                    // The three high bits: the primitive count in unary.
                    node.child_meta[i] = prims as u8
                        | match k {
                            1 => 0b0010_0000,
                            2 => 0b0110_0000,
                            3 => 0b1110_0000,
                            _ => unreachable!("a wide leaf of {k} primitives"),
                        };
                    prims += k;
                }
                Kind::Internal => {
                    node.imask |= 1 << i;
                    node.child_meta[i] = (24 + i as u8) | 0b0010_0000;
                    internal.slot[internal.len] = c;
                    internal.len += 1;
                }
                Kind::Distribute => unreachable!("a distributed slot is not a child"),
            }
        }
        (node, internal)
    }

    /// The primitives under binary node `n`, left to right.
    fn leaf_prims(&self, n: usize, out: &mut Vec<u32>) {
        let node = &self.bvh2.nodes[n];
        if node.prim_count != 0 {
            out.push(self.bvh2.primitive_indices[node.first_index as usize]);
        } else {
            self.leaf_prims(node.first_index as usize, out);
            self.leaf_prims(node.first_index as usize + 1, out);
        }
    }

    /// The binary nodes that become the wide node's children, by slot `i`'s decisions.
    fn children(&self, n: usize, children: &mut [u32; 8], count: &mut usize, i: usize) {
        let node = &self.bvh2.nodes[n];
        if node.prim_count != 0 {
            children[*count] = n as u32;
            *count += 1;
            return;
        }
        let d = self.decisions[n * 7 + i];
        for (c, slot) in [
            (node.first_index as usize, d.left),
            (node.first_index as usize + 1, d.right),
        ] {
            if self.decisions[c * 7 + slot as usize].kind == Kind::Distribute {
                self.children(c, children, count, slot as usize);
            } else {
                children[*count] = c as u32;
                *count += 1;
            }
        }
    }

    /// Children placed in the slots of the octant directions they lie towards (greedy
    /// assignment, cheapest first), so that a ray's octant gives the traversal's order.
    fn order_children(&self, n: usize, children: &mut [u32; 8], count: usize) {
        let p = self.bvh2.nodes[n].aabb().center();
        let mut cost = [[f32::MAX; 8]; 8];
        for s in 0..8 {
            let d = Vec3A::new(
                if s & 0b100 != 0 { -1.0 } else { 1.0 },
                if s & 0b010 != 0 { -1.0 } else { 1.0 },
                if s & 0b001 != 0 { -1.0 } else { 1.0 },
            );
            for c in 0..count {
                let v = self.bvh2.nodes[children[c] as usize].aabb().center() - p;
                cost[c][s] = d.dot(v);
            }
        }
        let mut assignment = [usize::MAX; 8];
        let mut filled = [false; 8];
        loop {
            let (mut min, mut slot, mut child) = (f32::MAX, usize::MAX, usize::MAX);
            for c in 0..count {
                if assignment[c] != usize::MAX {
                    continue;
                }
                for s in 0..8 {
                    if !filled[s] && cost[c][s] < min {
                        (min, slot, child) = (cost[c][s], s, c);
                    }
                }
            }
            if slot == usize::MAX {
                break;
            }
            filled[slot] = true;
            assignment[child] = slot;
        }
        let original = std::mem::replace(children, [NO_CHILD; 8]);
        for c in 0..count {
            children[assignment[c]] = original[c];
        }
    }
}
