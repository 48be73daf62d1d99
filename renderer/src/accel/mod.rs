//! Acceleration structure: a binary BVH built on the host with obvhs (PLOC with reinsertion and
//! leaf collapsing: Meister & Bittner 2018; Meister et al. 2021), flattened into the two-boxes-
//! per-node layout that `shaders/common/traverse.glsl` walks (`GpuBvhNode`).
//!
//! Why BVH2 first: it is the simplest layout that traverses well on both lavapipe and NVIDIA,
//! and obvhs builds it quickly. The planned next step for large scenes is obvhs's compressed
//! 8-wide BVH (Ylitie et al. 2017), whose ~2x faster incoherent traversal the issue tracker asks
//! us to measure against this one.
//!
//! `flatten` turns obvhs's tree into GPU nodes and keeps it within the traversal's short stack
//! ([`STACK_DEPTH`] levels) where it can, rebuilding too-deep subtrees balanced; a tree that is
//! still deeper renders through the shader's stackless fallback, which walks the tree with
//! parent pointers ([`parents`]). No scene is refused for the shape of its tree.
//!
//! `cwbvh` holds the compressed 8-wide BVH (`accel: "cwbvh"`, Ylitie et al. 2017) built by
//! obvhs, `grid` the alternative uniform grid (`accel: "grid"`), `select` the options that pick
//! one and the build entry point used by `compile`, `estimate` the surface-area estimates with
//! which `"auto"` chooses between the two BVHs on small scenes, and `cache` the on-disk cache of
//! built structures.

pub mod cache;
pub mod cwbvh;
mod cwbvh_convert;
mod distinct;
pub mod estimate;
mod flatten;
pub mod grid;
mod ploc;
mod select;

pub use flatten::{parents, MAX_LEAF, STACK_DEPTH};
pub use select::{
    auto_choice, build_accel, parse_request, Accel, AccelInfo, AccelKind, AccelOptions,
    AccelRequest, AutoChoice, CacheStatus, SceneSize, AUTO_CWBVH_TRIANGLES, REQUEST_NAMES,
};

use std::time::{Duration, Instant};

use obvhs::aabb::Aabb;
use obvhs::bvh2::leaf_collapser::collapse;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::{Boundable, BvhBuildParams};

use crate::layout::GpuBvhNode;

/// PLOC's search distances (obvhs's `PlocSearchDistance`).
const SEARCH_DISTANCES: [usize; 6] = [1, 2, 6, 14, 24, 32];

/// The builds' parameters: obvhs's medium preset with `reinsertion` as the reinsertion batch
/// ratio. Knobs for measuring build time against tree quality (bench/RESULTS.md):
/// `CANDELA_PLOC_SEARCH` (1, 2, 6, 14, 24 or 32) sets PLOC's search distance,
/// `CANDELA_REINSERTION` the reinsertion batch ratio (0: no reinsertion),
/// `CANDELA_COLLAPSE_COST` the binary tree's leaf-collapse traversal cost (see also
/// `CANDELA_BVH_LEAF` and the CWBVH's `CANDELA_CWBVH_PRIM_COST`). The cache key includes them as
/// set ([`knobs`]), so a measuring run never serves its trees to others.
pub(crate) fn build_params(reinsertion: f32) -> BvhBuildParams {
    let mut params = BvhBuildParams::medium_build();
    params.reinsertion_batch_ratio = reinsertion;
    let var = |name: &str| std::env::var(name).ok();
    if let Some(v) = var("CANDELA_PLOC_SEARCH").and_then(|v| v.parse::<u32>().ok()) {
        if SEARCH_DISTANCES.contains(&(v as usize)) {
            params.ploc_search_distance = v.into();
        }
    }
    if let Some(r) = var("CANDELA_REINSERTION").and_then(|v| v.parse::<f32>().ok()) {
        params.reinsertion_batch_ratio = r.clamp(0.0, 1.0);
    }
    if let Some(c) = var("CANDELA_COLLAPSE_COST").and_then(|v| v.parse::<f32>().ok()) {
        params.collapse_traversal_cost = c.clamp(0.01, 100.0);
    }
    params
}

/// The binary BVH's largest leaf: [`MAX_LEAF`], or the measuring knob `CANDELA_BVH_LEAF`
/// (1 to [`MAX_LEAF`]).
fn bvh_max_leaf() -> u32 {
    let knob = std::env::var("CANDELA_BVH_LEAF")
        .ok()
        .and_then(|v| v.parse::<u32>().ok());
    knob.unwrap_or(MAX_LEAF as u32).clamp(1, MAX_LEAF as u32)
}

/// The build knobs as set in the environment (see [`build_params`]), for the cache key.
pub(crate) fn knobs() -> String {
    [
        "CANDELA_PLOC_SEARCH",
        "CANDELA_REINSERTION",
        "CANDELA_COLLAPSE_COST",
        "CANDELA_BVH_LEAF",
        "CANDELA_CWBVH_PRIM_COST",
    ]
    .map(|name| format!("{name}={:?};", std::env::var(name).ok()))
    .concat()
}

/// The PLOC build of a binary tree over `prims` (leaf i is primitive i) with `params`' search
/// distance and narrow first passes (ploc.rs: obvhs's tree, built on every core).
pub(crate) fn ploc(prims: &[PrimBounds], params: &BvhBuildParams) -> obvhs::bvh2::Bvh2 {
    use obvhs::ploc::PlocSearchDistance as D;
    assert!(
        matches!(params.sort_precision, obvhs::ploc::SortPrecision::U64),
        "PLOC sorts 64-bit Morton codes"
    );
    let search = match params.ploc_search_distance {
        D::Minimum => 1,
        D::VeryLow => 2,
        D::Low => 6,
        D::Medium => 14,
        D::High => 24,
        D::VeryHigh => 32,
    };
    ploc::build(prims, search, params.search_depth_threshold)
}

/// A primitive's bounds for the builder.
#[derive(Clone, Copy, Debug)]
pub struct PrimBounds {
    pub min: [f32; 3],
    pub max: [f32; 3],
}

impl Boundable for PrimBounds {
    fn aabb(&self) -> Aabb {
        Aabb::new(self.min.into(), self.max.into())
    }
}

/// A built BVH: GPU nodes, and `order[i]` = the original index of the primitive stored at slot i.
#[derive(Debug, Clone)]
pub struct Bvh {
    pub nodes: Vec<GpuBvhNode>,
    pub order: Vec<u32>,
    pub depth: usize,
    pub build_time: Duration,
    /// Seconds of each step of the build, in order (see [`Phases`]).
    pub phases: Phases,
}

/// Seconds of each step of a build, in the order run (`accel_phases` in the render statistics),
/// for finding where a cold build spends its time.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Phases(pub Vec<(&'static str, f64)>);

impl Phases {
    /// Runs `f`, recording its time under `name`.
    pub fn time<T>(&mut self, name: &'static str, f: impl FnOnce() -> T) -> T {
        let start = Instant::now();
        let out = f();
        self.0.push((name, start.elapsed().as_secs_f64()));
        out
    }
}

/// Builds the BVH over `prims`. An empty scene yields one node with two empty leaves.
/// `keep_deep`: copy obvhs's tree as built even where it is deeper than [`STACK_DEPTH`] (a
/// testing aid for the traversal's stackless fallback); otherwise too-deep subtrees are rebuilt
/// balanced (see `flatten`).
pub fn build(prims: &[PrimBounds], keep_deep: bool) -> Bvh {
    let start = Instant::now();
    if prims.is_empty() {
        return Bvh {
            nodes: vec![GpuBvhNode::zeroed_node()],
            order: vec![],
            depth: 1,
            build_time: start.elapsed(),
            phases: Phases::default(),
        };
    }
    // obvhs's `build_bvh2` (medium preset, our leaf size), its steps timed apart: PLOC,
    // reinsertion, leaf collapsing, reinsertion again.
    let mut params = build_params(BvhBuildParams::medium_build().reinsertion_batch_ratio);
    params.max_prims_per_leaf = bvh_max_leaf();
    let mut ph = Phases::default();
    let mut bvh = ph.time("ploc", || ploc(prims, &params));
    let mut reinsertion = ReinsertionOptimizer::default();
    ph.time("reinsert", || {
        reinsertion.run(&mut bvh, params.reinsertion_batch_ratio, None)
    });
    ph.time("collapse", || {
        collapse(
            &mut bvh,
            params.max_prims_per_leaf.clamp(1, 255),
            params.collapse_traversal_cost,
        )
    });
    ph.time("reinsert2", || {
        reinsertion.run(
            &mut bvh,
            params.reinsertion_batch_ratio
                * params.post_collapse_reinsertion_batch_ratio_multiplier,
            None,
        )
    });
    let limit = (!keep_deep).then_some(STACK_DEPTH);
    let flat = ph.time("flatten", || flatten::flatten(&bvh, prims, limit));
    ph.time("drop_bvh2", || drop(bvh));
    Bvh {
        nodes: flat.nodes,
        order: flat.order,
        depth: flat.depth,
        build_time: start.elapsed(),
        phases: ph,
    }
}

impl GpuBvhNode {
    fn zeroed_node() -> Self {
        bytemuck::Zeroable::zeroed()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_boxes(n: usize) -> Vec<PrimBounds> {
        (0..n)
            .map(|i| PrimBounds {
                min: [i as f32, 0.0, 0.0],
                max: [i as f32 + 0.5, 1.0, 1.0],
            })
            .collect()
    }

    /// Boxes nested in each other, each 0.8 times the last about a common corner: an
    /// agglomerative SAH build chains them one level per box.
    fn nested_boxes(n: usize) -> Vec<PrimBounds> {
        (0..n)
            .map(|i| {
                let s = 0.8f32.powi(i as i32 % 300) * (1.0 + i as f32 * 1e-4);
                PrimBounds {
                    min: [0.0, 0.0, 0.0],
                    max: [s, s, s * 1e-3],
                }
            })
            .collect()
    }

    /// Every primitive is reachable exactly once, every child box contains its primitives, the
    /// reported depth is the tree's, and the parent pointers lead back to the root.
    fn check_tree(prims: &[PrimBounds], bvh: &Bvh) {
        let n = prims.len();
        let mut seen = vec![0u32; n];
        let mut stack = vec![0usize];
        let mut visited_single_leaf = false;
        while let Some(i) = stack.pop() {
            let node = bvh.nodes[i];
            let children = [
                (node.left, node.l_count, node.l_min, node.l_max),
                (node.right, node.r_count, node.r_min, node.r_max),
            ];
            for (k, (c, count, mn, mx)) in children.into_iter().enumerate() {
                if n == 1 && k == 1 {
                    visited_single_leaf = true;
                    continue; // the duplicated single leaf
                }
                if count == 0 {
                    stack.push(c as usize);
                } else {
                    assert!(count as usize <= MAX_LEAF);
                    for slot in c..c + count {
                        let p = prims[bvh.order[slot as usize] as usize];
                        for a in 0..3 {
                            assert!(mn[a] <= p.min[a] && mx[a] >= p.max[a]);
                        }
                        seen[bvh.order[slot as usize] as usize] += 1;
                    }
                }
            }
        }
        assert!(seen.iter().all(|&s| s == 1), "n = {n}: {seen:?}");
        assert_eq!(visited_single_leaf, n == 1);
        assert_eq!(flatten::depth_of(&bvh.nodes), Some(bvh.depth));
        let parents = parents(&bvh.nodes);
        assert_eq!(parents[0], crate::layout::NONE);
        for (i, &p) in parents.iter().enumerate().skip(1) {
            let node = bvh.nodes[p as usize];
            assert!(
                (node.l_count == 0 && node.left as usize == i)
                    || (node.r_count == 0 && node.right as usize == i)
            );
        }
    }

    #[test]
    fn flattened_tree_covers_every_primitive_once() {
        for n in [1usize, 2, 3, 17, 1000] {
            let prims = unit_boxes(n);
            check_tree(&prims, &build(&prims, false));
        }
    }

    /// A chain deeper than the stack is kept as built only on request; by default the part
    /// below the limit is rebuilt balanced, and the tree fits the stack.
    #[test]
    fn deep_trees_are_bounded_unless_kept() {
        for prims in [nested_boxes(2000), vec![unit_boxes(1)[0]; 5000]] {
            let deep = build(&prims, true);
            check_tree(&prims, &deep);
            let bounded = build(&prims, false);
            check_tree(&prims, &bounded);
            println!(
                "{} prims: depth {} as built, {} bounded",
                prims.len(),
                deep.depth,
                bounded.depth
            );
            assert!(bounded.depth <= STACK_DEPTH, "{}", bounded.depth);
        }
        let deep = build(&nested_boxes(2000), true);
        assert!(deep.depth > STACK_DEPTH, "{}", deep.depth);
    }

    /// Pseudo-random small boxes (a fixed LCG), a mix of sizes so PLOC's tree is irregular.
    pub(crate) fn random_boxes(n: usize, seed: u64) -> Vec<PrimBounds> {
        let mut x = seed;
        let mut next = move || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 40) as f32 / (1u64 << 24) as f32
        };
        (0..n)
            .map(|_| {
                let c = [next() * 10.0, next() * 10.0, next() * 10.0];
                let s = 0.01 + next() * next() * 2.0;
                PrimBounds {
                    min: c.map(|v| v - s),
                    max: c.map(|v| v + s),
                }
            })
            .collect()
    }

    /// Emitting subtrees in parallel gives exactly the serial pass's nodes and order, with and
    /// without the depth limit, and on trees whose top is rebuilt balanced.
    #[test]
    fn parallel_flatten_matches_serial() {
        let mut params = BvhBuildParams::medium_build();
        params.max_prims_per_leaf = MAX_LEAF as u32;
        let cases = [
            random_boxes(20_000, 1),
            random_boxes(3_000, 7),
            nested_boxes(3000),
        ];
        for prims in cases {
            let mut t = Duration::ZERO;
            let bvh = obvhs::bvh2::builder::build_bvh2(&prims, params, &mut t);
            for limit in [None, Some(STACK_DEPTH), Some(12)] {
                let serial = flatten::flatten_with(&bvh, &prims, limit, 0);
                for max_job in [4, 64, 1000, usize::MAX] {
                    let par = flatten::flatten_with(&bvh, &prims, limit, max_job);
                    let bytes = |n: &[GpuBvhNode]| bytemuck::cast_slice::<_, u8>(n).to_vec();
                    assert_eq!(
                        bytes(&par.nodes),
                        bytes(&serial.nodes),
                        "{limit:?} {max_job}"
                    );
                    assert_eq!(par.order, serial.order, "{limit:?} {max_job}");
                    assert_eq!(par.depth, serial.depth, "{limit:?} {max_job}");
                }
            }
        }
    }

    /// The subtree sizes (computed in parallel near the root) equal a plain recursion's, on a
    /// reinserted tree (children not stored after their parents) and a chain deeper than the
    /// parallel levels.
    #[test]
    fn subtree_sizes_match_a_recursion() {
        fn reference(b: &obvhs::bvh2::Bvh2, i: usize, s: &mut flatten::Sizes) {
            let n = &b.nodes[i];
            if n.prim_count > 0 {
                s.count[i] = n.prim_count as u64;
                return;
            }
            let (l, r) = (n.first_index as usize, n.first_index as usize + 1);
            reference(b, l, s);
            reference(b, r, s);
            s.height[i] = 1 + s.height[l].max(s.height[r]);
            s.count[i] = s.count[l] + s.count[r];
            s.inner[i] = 1 + s.inner[l] + s.inner[r];
        }
        let params = BvhBuildParams::medium_build();
        for prims in [random_boxes(30_000, 9), nested_boxes(400)] {
            let mut b = ploc(&prims, &params);
            ReinsertionOptimizer::default().run(&mut b, 0.05, None);
            let got = flatten::sizes(&b);
            let n = b.nodes.len();
            let mut want = flatten::Sizes {
                height: vec![0; n],
                count: vec![0; n],
                inner: vec![0; n],
            };
            reference(&b, 0, &mut want);
            assert!(got.height == want.height && got.count == want.count);
            assert!(got.inner == want.inner);
            assert!(want.height[0] > 12, "{}", want.height[0]);
        }
    }

    #[test]
    fn depth_of_rejects_what_is_not_a_tree() {
        let mut bvh = build(&unit_boxes(100), false);
        assert!(flatten::depth_of(&bvh.nodes).is_some());
        bvh.nodes[1].left = 0; // a cycle back to the root
        bvh.nodes[1].l_count = 0;
        assert_eq!(flatten::depth_of(&bvh.nodes), None);
        bvh.nodes[1].left = 1 << 30; // out of range
        assert_eq!(flatten::depth_of(&bvh.nodes), None);
    }

    #[test]
    fn empty_scene_has_a_root() {
        let bvh = build(&[], false);
        assert_eq!(bvh.nodes.len(), 1);
        assert!(bvh.order.is_empty());
        assert_eq!(flatten::depth_of(&bvh.nodes), Some(1));
    }
}
