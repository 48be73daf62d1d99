//! Acceleration structure: a binary BVH built on the host with obvhs (PLOC with reinsertion and
//! leaf collapsing: Meister & Bittner 2018; Meister et al. 2021), flattened into the two-boxes-
//! per-node layout that `shaders/common/traverse.glsl` walks (`GpuBvhNode`).
//!
//! Why BVH2 first: it is the simplest layout that traverses well on both lavapipe and NVIDIA,
//! and obvhs builds it quickly. The planned next step for large scenes is obvhs's compressed
//! 8-wide BVH (Ylitie et al. 2017), whose ~2x faster incoherent traversal the issue tracker asks
//! us to measure against this one.
//!
//! `grid` holds the alternative uniform grid (`accel: "grid"`), `select` the options that pick
//! one and the build entry point used by `compile`, and `cache` the on-disk cache of built
//! structures.

pub mod cache;
pub mod grid;
mod select;

pub use select::{
    build_accel, Accel, AccelInfo, AccelKind, AccelOptions, AccelRequest, CacheStatus,
};

use std::time::{Duration, Instant};

use obvhs::aabb::Aabb;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::{Boundable, BvhBuildParams};

use crate::layout::GpuBvhNode;

/// The deepest tree the traversal stack (BVH_STACK in traverse.glsl) can walk.
pub const MAX_DEPTH: usize = 64;

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
}

#[derive(Debug, thiserror::Error)]
pub enum AccelError {
    #[error("BVH is {0} levels deep; traversal supports at most {MAX_DEPTH}")]
    TooDeep(usize),
}

/// Builds the BVH over `prims`. An empty scene yields one node with two empty leaves.
pub fn build(prims: &[PrimBounds]) -> Result<Bvh, AccelError> {
    let start = Instant::now();
    if prims.is_empty() {
        let empty = GpuBvhNode {
            l_min: [0.0; 3],
            left: 0,
            l_max: [0.0; 3],
            right: 0,
            r_min: [0.0; 3],
            l_count: 0,
            r_max: [0.0; 3],
            r_count: 0,
        };
        return Ok(Bvh {
            nodes: vec![empty],
            order: vec![],
            depth: 1,
            build_time: start.elapsed(),
        });
    }
    let mut params = BvhBuildParams::medium_build();
    params.max_prims_per_leaf = 4;
    let mut core = Duration::ZERO;
    let bvh = build_bvh2(prims, params, &mut core);
    let src = &bvh.nodes;
    let child = |i: usize| -> (u32, u32, [f32; 3], [f32; 3]) {
        let n = &src[i];
        (
            n.first_index,
            n.prim_count,
            n.aabb.min.into(),
            n.aabb.max.into(),
        )
    };
    let mut nodes: Vec<GpuBvhNode> = Vec::with_capacity(src.len() / 2 + 1);
    let root = &src[0];
    if root.prim_count > 0 {
        // A single leaf: both children are that leaf (the second test never wins a closer hit).
        let (first, count, mn, mx) = child(0);
        nodes.push(GpuBvhNode {
            l_min: mn,
            left: first,
            l_max: mx,
            right: first,
            r_min: mn,
            l_count: count,
            r_max: mx,
            r_count: count,
        });
        return Ok(Bvh {
            nodes,
            order: bvh.primitive_indices.clone(),
            depth: 1,
            build_time: start.elapsed(),
        });
    }
    // Depth-first flattening; `stack` holds (source inner node, GPU slot, depth).
    nodes.push(GpuBvhNode::zeroed_node());
    let mut stack = vec![(0usize, 0usize, 1usize)];
    let mut depth = 1;
    while let Some((si, gi, d)) = stack.pop() {
        depth = depth.max(d);
        let first = src[si].first_index as usize;
        let mut slots = [(0u32, 0u32, [0f32; 3], [0f32; 3]); 2];
        for (k, slot) in slots.iter_mut().enumerate() {
            let (fi, count, mn, mx) = child(first + k);
            if count > 0 {
                *slot = (fi, count, mn, mx);
            } else {
                let g = nodes.len();
                nodes.push(GpuBvhNode::zeroed_node());
                stack.push((first + k, g, d + 1));
                *slot = (g as u32, 0, mn, mx);
            }
        }
        nodes[gi] = GpuBvhNode {
            l_min: slots[0].2,
            left: slots[0].0,
            l_max: slots[0].3,
            right: slots[1].0,
            r_min: slots[1].2,
            l_count: slots[0].1,
            r_max: slots[1].3,
            r_count: slots[1].1,
        };
    }
    if depth > MAX_DEPTH {
        return Err(AccelError::TooDeep(depth));
    }
    Ok(Bvh {
        nodes,
        order: bvh.primitive_indices.clone(),
        depth,
        build_time: start.elapsed(),
    })
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

    /// Every primitive is reachable exactly once and every child box contains its primitives.
    #[test]
    fn flattened_tree_covers_every_primitive_once() {
        for n in [1usize, 2, 3, 17, 1000] {
            let prims = unit_boxes(n);
            let bvh = build(&prims).unwrap();
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
        }
    }

    #[test]
    fn empty_scene_has_a_root() {
        let bvh = build(&[]).unwrap();
        assert_eq!(bvh.nodes.len(), 1);
        assert!(bvh.order.is_empty());
    }
}
