//! From obvhs's `Bvh2` to the GPU node array, keeping the tree within the traversal's short
//! stack where the geometry allows it.
//!
//! obvhs's PLOC builder (agglomerative, SAH-driven) can make very deep trees: a mesh of millions
//! of triangles goes past 64 levels, and pathological meshes (triangles nested in each other,
//! sizes halving) make chains as deep as the mesh is long. The traversal's stack holds
//! [`STACK_DEPTH`] entries; deeper trees still render (the shader falls back on a stackless
//! parent-pointer walk, `traverse_stackless` in shaders/common/traverse.glsl) but slowly. So the
//! flattening bounds the depth where it can:
//!
//! 1. Heights and primitive counts of every obvhs subtree (iteratively: chains may be deep).
//! 2. Top-down, a subtree that fits under the limit is copied as built (its SAH splits kept).
//!    A subtree that does not is kept too when each of its too-tall children can be rebuilt
//!    within the limit one level further down; otherwise it is rebuilt as a balanced tree
//!    (object median on the longest centroid axis, ≤ `MAX_LEAF` primitives per leaf), whose
//!    height is ⌈log2(n / MAX_LEAF)⌉. So only the deepest part that must change is rebuilt, and
//!    a scene already within the limit gets exactly obvhs's tree.
//!
//! The primitives are emitted leaf by leaf into a new order (`order[slot]` = input index).

use obvhs::bvh2::{node::Bvh2Node, Bvh2};

use super::PrimBounds;
use crate::layout::{GpuBvhNode, NONE};

/// Entries of the traversal's short stack (`BVH_STACK` in the shaders, declared in layout.rs):
/// trees up to this many levels are walked with the stack alone.
pub const STACK_DEPTH: usize = crate::layout::BVH_STACK_DEPTH as usize;
/// Most primitives in one leaf (obvhs's `max_prims_per_leaf`, and the balanced rebuild's).
pub const MAX_LEAF: usize = 4;

/// A child slot of a GPU node: an inner node index, or a leaf's range of the new order.
#[derive(Clone, Copy)]
struct Slot {
    index: u32,
    count: u32,
    min: [f32; 3],
    max: [f32; 3],
}

/// What is left to emit.
enum Task {
    /// obvhs inner node `src` into GPU node `gpu` at `depth`.
    Copy {
        src: usize,
        gpu: usize,
        depth: usize,
    },
    /// A balanced subtree over `prims` (input indices) into GPU node `gpu` at `depth`.
    Balanced {
        prims: Vec<u32>,
        gpu: usize,
        depth: usize,
    },
}

/// The flattened tree: GPU nodes, the primitive order and the depth (levels of inner nodes).
pub struct Flat {
    pub nodes: Vec<GpuBvhNode>,
    pub order: Vec<u32>,
    pub depth: usize,
}

/// Height of a balanced subtree over `n` (> MAX_LEAF) primitives, in inner-node levels.
fn balanced_height(n: usize) -> usize {
    let mut h = 1;
    let mut m = n.div_ceil(2);
    while m > MAX_LEAF {
        h += 1;
        m = m.div_ceil(2);
    }
    h
}

/// Heights (inner levels; 0 for a leaf) and primitive counts of every subtree of `bvh`,
/// iteratively in post-order (chains may be deep).
pub(super) fn heights(bvh: &Bvh2) -> (Vec<u32>, Vec<u64>) {
    let s = sizes(bvh);
    (s.height, s.count)
}

/// Per obvhs node: the height of its subtree (inner levels; 0 for a leaf), its primitives and
/// its inner nodes.
pub(super) struct Sizes {
    pub height: Vec<u32>,
    pub count: Vec<u64>,
    pub inner: Vec<u32>,
}

/// [`Sizes`] of every subtree of `bvh`: subtrees near the root in parallel, each walked
/// iteratively in post-order (chains may be deep). (Serial, it took about a second of a
/// 30M-triangle build.)
pub(super) fn sizes(bvh: &Bvh2) -> Sizes {
    /// Levels whose two subtrees are walked in parallel (4096 tasks).
    const PARALLEL_SIZE_LEVELS: u32 = 12;
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicU32, AtomicU64, Ordering::Relaxed};
    struct Out {
        height: Vec<AtomicU32>,
        count: Vec<AtomicU64>,
        inner: Vec<AtomicU32>,
    }
    // A node's sizes from its children's (already stored), stored.
    fn finish(src: &[Bvh2Node], o: &Out, i: usize) {
        let n = &src[i];
        if n.prim_count > 0 {
            o.count[i].store(n.prim_count as u64, Relaxed);
            return;
        }
        let (l, r) = (n.first_index as usize, n.first_index as usize + 1);
        let h = 1 + o.height[l].load(Relaxed).max(o.height[r].load(Relaxed));
        o.height[i].store(h, Relaxed);
        o.count[i].store(o.count[l].load(Relaxed) + o.count[r].load(Relaxed), Relaxed);
        o.inner[i].store(
            1 + o.inner[l].load(Relaxed) + o.inner[r].load(Relaxed),
            Relaxed,
        );
    }
    fn walk(src: &[Bvh2Node], o: &Out, root: usize, level: u32) {
        let n = &src[root];
        if n.prim_count == 0 && level < PARALLEL_SIZE_LEVELS {
            let f = n.first_index as usize;
            rayon::join(
                || walk(src, o, f, level + 1),
                || walk(src, o, f + 1, level + 1),
            );
            return finish(src, o, root);
        }
        let mut stack = vec![(root, false)];
        while let Some((i, expanded)) = stack.pop() {
            let n = &src[i];
            if n.prim_count > 0 || expanded {
                finish(src, o, i);
            } else {
                let f = n.first_index as usize;
                stack.extend([(i, true), (f, false), (f + 1, false)]);
            }
        }
    }
    let src = &bvh.nodes;
    let o = Out {
        height: (0..src.len())
            .into_par_iter()
            .map(|_| AtomicU32::new(0))
            .collect(),
        count: (0..src.len())
            .into_par_iter()
            .map(|_| AtomicU64::new(0))
            .collect(),
        inner: (0..src.len())
            .into_par_iter()
            .map(|_| AtomicU32::new(0))
            .collect(),
    };
    if !src.is_empty() {
        walk(src, &o, 0, 0);
    }
    Sizes {
        height: o.height.into_iter().map(AtomicU32::into_inner).collect(),
        count: o.count.into_iter().map(AtomicU64::into_inner).collect(),
        inner: o.inner.into_iter().map(AtomicU32::into_inner).collect(),
    }
}

/// Flattens `bvh` (built over `bounds`). `limit`: the depth to keep the tree within (None: copy
/// obvhs's tree as it is, a testing aid for deep trees).
pub fn flatten(bvh: &Bvh2, bounds: &[PrimBounds], limit: Option<usize>) -> Flat {
    // Subtrees copied whole with at most this many primitives are emitted in parallel (step 3).
    let max_job = (bvh.primitive_indices.len() / 256).max(4096);
    flatten_with(bvh, bounds, limit, max_job)
}

/// [`flatten`], emitting subtrees copied whole with at most `max_job` primitives in parallel
/// (0: all in the serial top-down pass); the result does not depend on `max_job`.
pub(super) fn flatten_with(
    bvh: &Bvh2,
    bounds: &[PrimBounds],
    limit: Option<usize>,
    max_job: usize,
) -> Flat {
    let src = &bvh.nodes;
    let n_src = src.len();
    // Step 1: heights (inner levels), primitive and inner-node counts of every subtree.
    let Sizes {
        height,
        count,
        inner,
    } = sizes(bvh);
    let max_job = max_job as u64;
    let mut jobs: Vec<Job> = Vec::new();
    let mut out = Flat {
        nodes: Vec::with_capacity(n_src / 2 + 1),
        order: Vec::with_capacity(bvh.primitive_indices.len()),
        depth: 1,
    };
    let leaf_prims = |i: usize| -> &[u32] {
        let n = &src[i];
        &bvh.primitive_indices[n.first_index as usize..(n.first_index + n.prim_count) as usize]
    };
    // A root that is a leaf: both slots hold it (the second test never wins a closer hit).
    if src[0].prim_count > 0 {
        let s = emit_leaf(
            &mut out.order,
            leaf_prims(0),
            src[0].aabb.min.into(),
            src[0].aabb.max.into(),
        );
        out.nodes.push(node_of(s, s));
        return out;
    }
    // Whether the subtree of obvhs node i, placed at depth d, fits the limit.
    let fits = |i: usize, d: usize| limit.is_none_or(|l| d - 1 + height[i] as usize <= l);
    let subtree_prims = |i: usize| -> Vec<u32> {
        let mut v = Vec::with_capacity(count[i] as usize);
        let mut st = vec![i];
        while let Some(j) = st.pop() {
            if src[j].prim_count > 0 {
                v.extend_from_slice(leaf_prims(j));
            } else {
                st.extend([src[j].first_index as usize, src[j].first_index as usize + 1]);
            }
        }
        v
    };
    // Step 2: top-down, copying or rebuilding each subtree.
    out.nodes.push(GpuBvhNode::zeroed_node());
    let mut tasks = vec![
        if fits(0, 1) || children_fixable(src, &count, 0, 1, limit, &fits) {
            Task::Copy {
                src: 0,
                gpu: 0,
                depth: 1,
            }
        } else {
            Task::Balanced {
                prims: subtree_prims(0),
                gpu: 0,
                depth: 1,
            }
        },
    ];
    while let Some(task) = tasks.pop() {
        match task {
            Task::Copy {
                src: si,
                gpu,
                depth,
            } => {
                if count[si] <= max_job && fits(si, depth) {
                    // Copied as built, so its place is known: the nodes and slots it would
                    // take here, filled in step 3.
                    out.depth = out.depth.max(depth - 1 + height[si] as usize);
                    jobs.push(Job {
                        src: si,
                        gpu,
                        node_at: out.nodes.len(),
                        slot_at: out.order.len(),
                    });
                    let (nodes, slots) = (inner[si] as usize - 1, count[si] as usize);
                    out.nodes
                        .resize(out.nodes.len() + nodes, GpuBvhNode::zeroed_node());
                    out.order.resize(out.order.len() + slots, 0);
                    continue;
                }
                out.depth = out.depth.max(depth);
                let first = src[si].first_index as usize;
                let mut slots = [None, None];
                for (k, slot) in slots.iter_mut().enumerate() {
                    let c = first + k;
                    let (mn, mx) = (src[c].aabb.min.into(), src[c].aabb.max.into());
                    if src[c].prim_count > 0 {
                        *slot = Some(emit_leaf(&mut out.order, leaf_prims(c), mn, mx));
                        continue;
                    }
                    let g = out.nodes.len();
                    out.nodes.push(GpuBvhNode::zeroed_node());
                    let d = depth + 1;
                    tasks.push(
                        if fits(c, d) || children_fixable(src, &count, c, d, limit, &fits) {
                            Task::Copy {
                                src: c,
                                gpu: g,
                                depth: d,
                            }
                        } else {
                            Task::Balanced {
                                prims: subtree_prims(c),
                                gpu: g,
                                depth: d,
                            }
                        },
                    );
                    *slot = Some(Slot {
                        index: g as u32,
                        count: 0,
                        min: mn,
                        max: mx,
                    });
                }
                if let [Some(l), Some(r)] = slots {
                    out.nodes[gpu] = node_of(l, r);
                }
            }
            Task::Balanced {
                mut prims,
                gpu,
                depth,
            } => {
                out.depth = out.depth.max(depth);
                // Object median on the longest axis of the centroids' box.
                let axis = longest_centroid_axis(&prims, bounds);
                let mid = prims.len() / 2;
                let key = |i: &u32| {
                    let b = &bounds[*i as usize];
                    b.min[axis] + b.max[axis]
                };
                prims.select_nth_unstable_by(mid, |a, b| key(a).total_cmp(&key(b)));
                let right = prims.split_off(mid);
                let mut slots = [None, None];
                for (slot, part) in slots.iter_mut().zip([prims, right]) {
                    let (mn, mx) = box_of(&part, bounds);
                    if part.len() <= MAX_LEAF {
                        *slot = Some(emit_leaf(&mut out.order, &part, mn, mx));
                        continue;
                    }
                    let g = out.nodes.len();
                    out.nodes.push(GpuBvhNode::zeroed_node());
                    tasks.push(Task::Balanced {
                        prims: part,
                        gpu: g,
                        depth: depth + 1,
                    });
                    *slot = Some(Slot {
                        index: g as u32,
                        count: 0,
                        min: mn,
                        max: mx,
                    });
                }
                if let [Some(l), Some(r)] = slots {
                    out.nodes[gpu] = node_of(l, r);
                }
            }
        }
    }
    // Step 3: the deferred subtrees, each into its own range of nodes and slots.
    run_jobs(&mut out, &jobs, |job, nodes, slots| {
        copy_subtree(bvh, job, nodes, slots)
    });
    out
}

/// A subtree copied as built, emitted after the top-down pass: obvhs node `src` into GPU node
/// `gpu`, its descendants into GPU nodes from `node_at` on, its primitives into slots from
/// `slot_at` on (the ranges the serial emission would have given them).
struct Job {
    src: usize,
    gpu: usize,
    node_at: usize,
    slot_at: usize,
}

/// Runs `emit` on every job in parallel, each with its own ranges of `out.nodes` and
/// `out.order` (jobs are in increasing order of both, and their ranges are disjoint), then
/// stores the root node each returns.
fn run_jobs(
    out: &mut Flat,
    jobs: &[Job],
    emit: impl Fn(&Job, &mut [GpuBvhNode], &mut [u32]) -> GpuBvhNode + Sync,
) {
    use rayon::prelude::*;
    // Carve the disjoint ranges: each job's nodes end where the next job's begin, or earlier
    // (the serial pass may have emitted nodes in between, which stay untouched).
    let mut parts = Vec::with_capacity(jobs.len());
    let (mut nodes, mut slots) = (&mut out.nodes[..], &mut out.order[..]);
    let (mut node_base, mut slot_base) = (0, 0);
    for (k, job) in jobs.iter().enumerate() {
        let node_end = jobs.get(k + 1).map_or(usize::MAX, |n| n.node_at);
        let slot_end = jobs.get(k + 1).map_or(usize::MAX, |n| n.slot_at);
        let (_, rest) = std::mem::take(&mut nodes).split_at_mut(job.node_at - node_base);
        let take = (node_end - job.node_at).min(rest.len());
        let (mine, rest) = rest.split_at_mut(take);
        (nodes, node_base) = (rest, job.node_at + take);
        let (_, rest) = std::mem::take(&mut slots).split_at_mut(job.slot_at - slot_base);
        let take = (slot_end - job.slot_at).min(rest.len());
        let (mine_s, rest) = rest.split_at_mut(take);
        (slots, slot_base) = (rest, job.slot_at + take);
        parts.push((job, mine, mine_s));
    }
    let roots: Vec<GpuBvhNode> = parts
        .into_par_iter()
        .map(|(job, n, s)| emit(job, n, s))
        .collect();
    for (job, root) in jobs.iter().zip(roots) {
        out.nodes[job.gpu] = root;
    }
}

/// Emits the subtree of `job` as the top-down pass would (children of a node numbered
/// together, the last child's subtree first): descendants into `nodes` (the job's range,
/// indices from `node_at`), primitives into `slots`. Returns the root's GPU node.
fn copy_subtree(bvh: &Bvh2, job: &Job, nodes: &mut [GpuBvhNode], slots: &mut [u32]) -> GpuBvhNode {
    let src = &bvh.nodes;
    let (mut next_node, mut next_slot) = (0usize, 0usize);
    let mut root = GpuBvhNode::zeroed_node();
    let mut stack = vec![(job.src, job.gpu)];
    while let Some((si, gpu)) = stack.pop() {
        let first = src[si].first_index as usize;
        let mut pair = [None, None];
        for (k, slot) in pair.iter_mut().enumerate() {
            let c = first + k;
            let (min, max) = (src[c].aabb.min.into(), src[c].aabb.max.into());
            let n = &src[c];
            if n.prim_count > 0 {
                let from = n.first_index as usize;
                let count = n.prim_count as usize;
                slots[next_slot..next_slot + count]
                    .copy_from_slice(&bvh.primitive_indices[from..from + count]);
                *slot = Some(Slot {
                    index: (job.slot_at + next_slot) as u32,
                    count: count as u32,
                    min,
                    max,
                });
                next_slot += count;
                continue;
            }
            let g = job.node_at + next_node;
            next_node += 1;
            stack.push((c, g));
            *slot = Some(Slot {
                index: g as u32,
                count: 0,
                min,
                max,
            });
        }
        if let [Some(l), Some(r)] = pair {
            let node = node_of(l, r);
            if gpu == job.gpu {
                root = node;
            } else {
                nodes[gpu - job.node_at] = node;
            }
        }
    }
    root
}

/// Whether obvhs inner node `i` at depth `d` can keep its split: each child that does not fit
/// at depth d + 1 could be rebuilt balanced within the limit there.
fn children_fixable(
    src: &[obvhs::bvh2::node::Bvh2Node],
    count: &[u64],
    i: usize,
    d: usize,
    limit: Option<usize>,
    fits: &impl Fn(usize, usize) -> bool,
) -> bool {
    let Some(limit) = limit else { return true };
    if d > limit {
        return false;
    }
    (0..2).all(|k| {
        let c = src[i].first_index as usize + k;
        src[c].prim_count > 0 || fits(c, d + 1) || d + balanced_height(count[c] as usize) <= limit
    })
}

fn emit_leaf(order: &mut Vec<u32>, prims: &[u32], min: [f32; 3], max: [f32; 3]) -> Slot {
    let first = order.len() as u32;
    order.extend_from_slice(prims);
    Slot {
        index: first,
        count: prims.len() as u32,
        min,
        max,
    }
}

fn node_of(l: Slot, r: Slot) -> GpuBvhNode {
    GpuBvhNode {
        l_min: l.min,
        left: l.index,
        l_max: l.max,
        right: r.index,
        r_min: r.min,
        l_count: l.count,
        r_max: r.max,
        r_count: r.count,
    }
}

fn box_of(prims: &[u32], bounds: &[PrimBounds]) -> ([f32; 3], [f32; 3]) {
    let (mut mn, mut mx) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for &i in prims {
        let b = &bounds[i as usize];
        for a in 0..3 {
            mn[a] = mn[a].min(b.min[a]);
            mx[a] = mx[a].max(b.max[a]);
        }
    }
    (mn, mx)
}

fn longest_centroid_axis(prims: &[u32], bounds: &[PrimBounds]) -> usize {
    let (mut mn, mut mx) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for &i in prims {
        let b = &bounds[i as usize];
        for a in 0..3 {
            let c = b.min[a] + b.max[a];
            mn[a] = mn[a].min(c);
            mx[a] = mx[a].max(c);
        }
    }
    (0..3)
        .max_by(|&a, &b| (mx[a] - mn[a]).total_cmp(&(mx[b] - mn[b])))
        .unwrap_or(0)
}

/// Each GPU node's parent (NONE for the root), for the stackless fallback walk.
pub fn parents(nodes: &[GpuBvhNode]) -> Vec<u32> {
    let mut p = vec![NONE; nodes.len()];
    for (i, n) in nodes.iter().enumerate() {
        for (c, count) in [(n.left, n.l_count), (n.right, n.r_count)] {
            if count == 0 && (c as usize) < nodes.len() && c as usize != i {
                p[c as usize] = i as u32;
            }
        }
    }
    p
}

/// The depth (inner levels) of a GPU tree, or None when it is not a tree over `nodes` (a child
/// index out of range, a node reached twice): a check for trees read from the cache.
pub fn depth_of(nodes: &[GpuBvhNode]) -> Option<usize> {
    let mut seen = vec![false; nodes.len()];
    let mut stack = vec![(0usize, 1usize)];
    let mut depth = 0;
    while let Some((i, d)) = stack.pop() {
        if std::mem::replace(seen.get_mut(i)?, true) {
            return None;
        }
        depth = depth.max(d);
        let n = &nodes[i];
        for (c, count) in [(n.left, n.l_count), (n.right, n.r_count)] {
            // The empty scene's root points at itself with empty slots.
            if count == 0 && !(i == 0 && c == 0) {
                stack.push((c as usize, d + 1));
            }
        }
    }
    Some(depth)
}
