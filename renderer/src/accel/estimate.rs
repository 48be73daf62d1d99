//! Surface-area estimates of a tree's traversal cost per ray, with which `"auto"` chooses
//! between the binary BVH and the CWBVH on scenes below [`super::AUTO_CWBVH_TRIANGLES`].
//!
//! A ray that reaches a node's box is taken to reach each child box with the probability of
//! their surface-area ratio (MacDonald & Booth 1990, the SAH's estimate), so a tree's expected
//! node fetches per ray are 1 (the root) plus the area ratios of its inner children to the
//! root's box, and its expected primitive tests the leaves' ratios times their primitives.
//! The CWBVH fetches fewer nodes and tests fewer primitives than the binary BVH on every scene
//! measured (lavapipe counts), yet is slower on some, because one wide node (eight quantised
//! boxes, ordered by octant) costs several binary ones (two boxes). The costs per fetch and per
//! test below are measured on an NVIDIA H100 (bench/RESULTS.md, "`auto` by the trees'
//! estimates"): in the middle of the band that puts the nine project scenes and meshes of 100k
//! to 1M triangles on the side their measured speed favours, and validated on fourteen random
//! scenes they were not fitted on (the estimate picked the faster tree on twelve; the picks
//! ran 1.051× the binary BVH's speed in the geometric mean, no scene below 0.986).
//!
//! The surface-area ratio is exact for rays from far away in uniformly random directions; rays
//! that start inside the scene (a room's walls around the camera) meet boxes differently, so
//! the estimate is a heuristic, not a prediction of Msamples/s.

use crate::layout::{GpuBvhNode, GpuCwbvhNode};
use obvhs::aabb::Aabb;

/// Cost of one binary node fetch (two child boxes): the unit.
pub const BVH_NODE_COST: f64 = 1.0;
/// Cost of one CWBVH node fetch (eight quantised child boxes, octant order), in binary fetches.
pub const CWBVH_NODE_COST: f64 = 3.3;
/// Cost of one primitive test (triangle or sphere), in binary fetches.
pub const PRIM_COST: f64 = 0.6;

/// Expected node fetches and primitive tests per ray of one tree.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    pub nodes: f64,
    pub prims: f64,
}

impl Estimate {
    /// The expected cost per ray with `node_cost` per fetch and [`PRIM_COST`] per test.
    pub fn cost(&self, node_cost: f64) -> f64 {
        self.nodes * node_cost + self.prims * PRIM_COST
    }
}

/// Both trees' estimated costs per ray, in binary node fetches (the render report's
/// `accel_estimate`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Costs {
    pub bvh: f64,
    pub cwbvh: f64,
}

impl Costs {
    pub fn of(bvh: &Estimate, cwbvh: &Estimate) -> Costs {
        Costs {
            bvh: bvh.cost(BVH_NODE_COST),
            cwbvh: cwbvh.cost(CWBVH_NODE_COST),
        }
    }

    /// Whether the CWBVH is the cheaper tree (ties keep the binary BVH).
    pub fn prefer_cwbvh(&self) -> bool {
        self.cwbvh < self.bvh
    }
}

/// A box's half surface area (the ratios need no more), in f64 with each side clamped at 0, so
/// that an inverted (empty) box has none: obvhs' `half_area` multiplies the signed sides, which
/// makes a box inverted on all three axes positive.
fn area(b: &Aabb) -> f64 {
    let d = b.diagonal();
    let [x, y, z] = [d.x, d.y, d.z].map(|s| s.max(0.0) as f64);
    (x + y) * z + x * y
}

/// Sums the estimate over a tree given as its root's child boxes and a function from a node to
/// its children (box, inner child's index or None, primitives of a leaf). Each node is visited
/// once (a malformed index list cannot loop); a root box of no area (a flat or empty scene)
/// counts every child as reached.
fn sum<F>(count: usize, children: F) -> Estimate
where
    F: Fn(usize) -> Vec<(Aabb, Option<usize>, u32)>,
{
    let mut e = Estimate {
        nodes: 1.0,
        prims: 0.0,
    };
    if count == 0 {
        return e;
    }
    let root = children(0)
        .into_iter()
        .map(|c| c.0)
        .reduce(|a, b| a.union(&b));
    let root_area = root.as_ref().map(area).unwrap_or(0.0);
    let ratio = |b: &Aabb| match root_area > 0.0 {
        true => (area(b) / root_area).min(1.0),
        false => 1.0,
    };
    let mut seen = vec![false; count];
    seen[0] = true;
    let mut stack = vec![0usize];
    // Step 1: walk every node once from the root; step 2: add each child's share.
    while let Some(i) = stack.pop() {
        for (b, inner, prims) in children(i) {
            match inner {
                Some(c) if c < count && !std::mem::replace(&mut seen[c], true) => {
                    e.nodes += ratio(&b);
                    stack.push(c);
                }
                Some(_) => {}
                None => e.prims += ratio(&b) * prims as f64,
            }
        }
    }
    e
}

/// The binary BVH's estimate (`GpuBvhNode`: a child is a leaf of `count` primitives when its
/// count is not 0, else the inner node at its index). A root that is a leaf is stored in both
/// slots and tested twice, as the traversal does.
pub fn of_bvh(nodes: &[GpuBvhNode]) -> Estimate {
    sum(nodes.len(), |i| {
        let n = &nodes[i];
        [
            (n.l_min, n.l_max, n.left, n.l_count),
            (n.r_min, n.r_max, n.right, n.r_count),
        ]
        .into_iter()
        .map(|(lo, hi, index, count)| {
            let b = Aabb::new(lo.into(), hi.into());
            (b, (count == 0).then_some(index as usize), count)
        })
        .collect()
    })
}

/// The CWBVH's estimate (`GpuCwbvhNode`: child c's box is `p + 2^(e − 127) · q` per axis; inner
/// children stored from `child_base` in slot order; a leaf's primitives in the unary count of
/// its `meta`'s high bits).
pub fn of_cwbvh(nodes: &[GpuCwbvhNode]) -> Estimate {
    sum(nodes.len(), |i| {
        let n = &nodes[i];
        let scale: [f32; 3] = std::array::from_fn(|a| 2f32.powi(n.e_imask[a] as i32 - 127));
        let mut inner = 0usize;
        (0..8)
            .filter(|&c| n.meta[c] != 0)
            .map(|c| {
                let lo = std::array::from_fn(|a| n.p[a] + scale[a] * n.q[2 * a][c] as f32);
                let hi = std::array::from_fn(|a| n.p[a] + scale[a] * n.q[2 * a + 1][c] as f32);
                let b = Aabb::new(lo.into(), hi.into());
                if n.e_imask[3] & (1 << c) != 0 {
                    inner += 1;
                    (b, Some(n.child_base as usize + inner - 1), 0)
                } else {
                    (b, None, (n.meta[c] >> 5).count_ones())
                }
            })
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{build, cwbvh, PrimBounds};

    fn flat_box(lo: [f32; 3], hi: [f32; 3]) -> PrimBounds {
        PrimBounds { min: lo, max: hi }
    }

    /// Half areas: a box's, and none for a box inverted on one axis or on all three.
    #[test]
    fn inverted_boxes_have_no_area() {
        let b = |lo: [f32; 3], hi: [f32; 3]| Aabb::new(lo.into(), hi.into());
        assert_eq!(area(&b([0.0; 3], [1.0, 2.0, 3.0])), 11.0);
        assert_eq!(area(&b([0.0, 0.0, 1.0], [1.0, 2.0, 0.0])), 2.0);
        assert_eq!(area(&b([1.0; 3], [0.0; 3])), 0.0);
        assert_eq!(area(&Aabb::empty()), 0.0);
    }

    /// Six walls of a unit room, two triangles each (their boxes overlap at the edges).
    fn room() -> Vec<PrimBounds> {
        let mut v = Vec::new();
        for axis in 0..3 {
            for side in [0.0f32, 1.0] {
                let mut lo = [0.0; 3];
                let mut hi = [1.0; 3];
                lo[axis] = side;
                hi[axis] = side;
                v.push(flat_box(lo, hi));
                v.push(flat_box(lo, hi));
            }
        }
        v
    }

    #[test]
    fn one_leaf_is_one_fetch_and_its_primitives() {
        // A single primitive: the binary root is a leaf held in both slots (tested twice); the
        // wide root holds it once.
        let p = [flat_box([0.0; 3], [1.0; 3])];
        let b = of_bvh(&build(&p, false).nodes);
        assert_eq!(
            b,
            Estimate {
                nodes: 1.0,
                prims: 2.0
            }
        );
        let w = of_cwbvh(&cwbvh::build(&p).nodes);
        assert_eq!(
            w,
            Estimate {
                nodes: 1.0,
                prims: 1.0
            }
        );
        assert!(
            !Costs::of(&b, &w).prefer_cwbvh(),
            "one primitive: the binary BVH"
        );
    }

    #[test]
    fn children_count_by_their_share_of_the_root_area() {
        // Two disjoint unit cubes 3 apart: root box 4 × 1 × 1 (area 18), each leaf cube 6.
        let p = [
            flat_box([0.0; 3], [1.0; 3]),
            flat_box([3.0, 0.0, 0.0], [4.0, 1.0, 1.0]),
        ];
        let b = of_bvh(&build(&p, false).nodes);
        assert!(
            (b.nodes - 1.0).abs() < 1e-9 && (b.prims - 12.0 / 18.0).abs() < 1e-6,
            "{b:?}"
        );
        let w = of_cwbvh(&cwbvh::build(&p).nodes);
        // Quantised boxes are conservative: at least the exact share, within 2% here.
        assert!(
            w.nodes == 1.0 && w.prims >= 12.0 / 18.0 - 1e-6 && w.prims < 0.68,
            "{w:?}"
        );
    }

    #[test]
    fn overlapping_walls_prefer_the_wide_tree_and_a_few_apart_do_not() {
        // A room's walls overlap: many tests per ray in a binary tree, fewer in a wide node.
        let walls = room();
        let c = Costs::of(
            &of_bvh(&build(&walls, false).nodes),
            &of_cwbvh(&cwbvh::build(&walls).nodes),
        );
        assert!(c.prefer_cwbvh(), "{c:?}");
        // Three small boxes far apart: one wide fetch costs more than the binary tree's.
        let apart: Vec<_> = (0..3)
            .map(|i| {
                flat_box(
                    [i as f32 * 10.0, 0.0, 0.0],
                    [i as f32 * 10.0 + 1.0, 1.0, 1.0],
                )
            })
            .collect();
        let c = Costs::of(
            &of_bvh(&build(&apart, false).nodes),
            &of_cwbvh(&cwbvh::build(&apart).nodes),
        );
        assert!(!c.prefer_cwbvh(), "{c:?}");
    }

    #[test]
    fn malformed_indices_neither_loop_nor_panic() {
        // The empty scene's node (both slots inner, index 0) and an index past the end.
        let mut n: GpuBvhNode = bytemuck::Zeroable::zeroed();
        assert_eq!(
            of_bvh(&[n]),
            Estimate {
                nodes: 1.0,
                prims: 0.0
            }
        );
        n.left = 7;
        assert_eq!(of_bvh(&[n]).prims, 0.0);
        assert_eq!(
            of_bvh(&[]),
            Estimate {
                nodes: 1.0,
                prims: 0.0
            }
        );
        assert_eq!(
            of_cwbvh(&[]),
            Estimate {
                nodes: 1.0,
                prims: 0.0
            }
        );
    }
}
