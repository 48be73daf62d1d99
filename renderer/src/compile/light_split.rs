//! Where the light BVH (light_bvh.rs) splits a group of lights: pbrt-v4's surface area
//! orientation heuristic (SAOH; Conty Estevez & Kulla 2018). The centroids are binned into 12
//! buckets along each axis; a split between buckets costs Σ over its two sides of
//! power · M_Ω (the solid angle the side's emission cone and spread can reach) · surface area ·
//! Kr (the centroids' box: its longest extent over its extent along the axis, which discourages
//! thin boxes).
//! The cheapest split of the three axes wins; where none exists (every centroid in one bucket),
//! where the best costs nothing (flat or powerless sides) or the tree could run out of depth (the bit trails hold MAX_DEPTH levels), the median along
//! the longest axis is taken, which keeps what is left within log2 n levels.

use glam::DVec3;

use super::light_bvh::{LightBounds, MAX_DEPTH};

const BUCKETS: usize = 12;

/// The SAOH cost of a side (pbrt-v4 `BVHLightSampler::EvaluateCost`); `extent` is the parent's
/// centroid box, `axis` the split's.
fn cost(b: &LightBounds, extent: DVec3, axis: usize) -> f64 {
    // Step 1: M_Ω, the cone of normals widened by the emission's spread.
    let theta_o = b.cos_theta_o.clamp(-1.0, 1.0).acos();
    let theta_e = b.cos_theta_e.clamp(-1.0, 1.0).acos();
    let theta_w = (theta_o + theta_e).min(std::f64::consts::PI);
    let sin_o = (1.0 - b.cos_theta_o * b.cos_theta_o).max(0.0).sqrt();
    let m_omega = 2.0 * std::f64::consts::PI * (1.0 - b.cos_theta_o)
        + std::f64::consts::FRAC_PI_2
            * (2.0 * theta_w * sin_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_o
                + b.cos_theta_o);
    // Step 2: the box's surface area, and Kr.
    let d = b.max - b.min;
    let area = 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
    let kr = extent.max_element() / extent[axis];
    b.phi * m_omega * kr * area
}

/// Partitions `items` (at least two) for a node at `depth` and returns the size of the first
/// part (1 ..= len − 1).
pub fn split(items: &mut [(u32, LightBounds)], depth: usize) -> usize {
    let n = items.len();
    let centroid = LightBounds::centroid;
    let (cmin, cmax) = items.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), (_, b)| (lo.min(centroid(b)), hi.max(centroid(b))),
    );
    let ext = cmax - cmin;
    let longest = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    // Step 1: the SAOH split, while the depth left allows any split: after it, the larger side
    // (at most n − 1 lights, at depth + 1) must still fit by medians. The test is
    // bits(n − 1) = ⌊log2(n − 1)⌋ + 1 ≤ MAX_DEPTH − depth − 1, one level stricter than
    // ⌈log2(n − 1)⌉ where n − 1 is a power of two.
    let levels_left = MAX_DEPTH.saturating_sub(depth + 1);
    let fits = (usize::BITS - (n - 1).leading_zeros()) as usize <= levels_left;
    let bucket_of = |b: &LightBounds, axis: usize| {
        let t = (centroid(b)[axis] - cmin[axis]) / ext[axis];
        ((t * BUCKETS as f64) as usize).min(BUCKETS - 1)
    };
    let mut best: Option<(f64, usize, usize)> = None; // (cost, axis, first bucket above)
    for axis in 0..3 {
        if !fits || !(ext[axis] > 0.0) {
            continue;
        }
        let mut buckets: [Option<LightBounds>; BUCKETS] = [None; BUCKETS];
        for (_, b) in items.iter() {
            let k = bucket_of(b, axis);
            buckets[k] = Some(buckets[k].map_or(*b, |u| u.union(b)));
        }
        // Costs of every split, from the unions below and above it.
        let mut below = [None; BUCKETS];
        let mut acc: Option<LightBounds> = None;
        for k in 0..BUCKETS {
            if let Some(b) = buckets[k] {
                acc = Some(acc.map_or(b, |u| u.union(&b)));
            }
            below[k] = acc;
        }
        let mut above: Option<LightBounds> = None;
        for k in (1..BUCKETS).rev() {
            if let Some(b) = buckets[k] {
                above = Some(above.map_or(b, |u| u.union(&b)));
            }
            if let (Some(lo), Some(hi)) = (below[k - 1], above) {
                let c = cost(&lo, ext, axis) + cost(&hi, ext, axis);
                if c.is_finite() && best.is_none_or(|(bc, _, _)| c < bc) {
                    best = Some((c, axis, k));
                }
            }
        }
    }
    // A best cost of 0 (every side flat or powerless: e.g. point lights on a line) says nothing;
    // the median keeps the tree balanced there.
    if let Some((_, axis, k)) = best.filter(|b| b.0 > 0.0) {
        // Step 2: partition at that bucket boundary.
        let mut first = 0;
        for i in 0..n {
            if bucket_of(&items[i].1, axis) < k {
                items.swap(i, first);
                first += 1;
            }
        }
        if first > 0 && first < n {
            return first;
        }
    }
    // Step 3: the median along the longest axis.
    let mid = n / 2;
    items.select_nth_unstable_by(mid, |a, b| {
        centroid(&a.1)[longest].total_cmp(&centroid(&b.1)[longest])
    });
    mid
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compile::light_bvh::LightBvh;
    use crate::compile::lights::LightBuilder;
    use glam::Vec3;

    /// The depth of every leaf (root 0).
    fn leaf_depths(bvh: &LightBvh) -> Vec<usize> {
        fn walk(bvh: &LightBvh, i: usize, d: usize, out: &mut Vec<usize>) {
            let node = &bvh.nodes[i];
            if node.leaf {
                out.push(d);
            } else {
                walk(bvh, i + 1, d + 1, out);
                walk(bvh, node.index as usize, d + 1, out);
            }
        }
        let mut out = Vec::new();
        walk(bvh, 0, 0, &mut out);
        out
    }

    #[test]
    fn two_clusters_are_split_apart() {
        // Eight lights near x = 0 and eight near x = 10, in an order that mixes them.
        let mut items: Vec<(u32, LightBounds)> = (0..16u32)
            .map(|i| {
                let x = if i % 2 == 0 { 0.0 } else { 10.0 } + 0.01 * i as f64;
                let p = DVec3::new(x, 0.1 * (i % 3) as f64, 0.0);
                (
                    i,
                    LightBounds::all_directions(p, p + DVec3::splat(0.05), 1.0 + (i % 4) as f64),
                )
            })
            .collect();
        let first = split(&mut items, 0);
        assert_eq!(first, 8);
        let near: Vec<bool> = items.iter().map(|(_, b)| b.min.x < 5.0).collect();
        assert!(
            near[..8].iter().all(|&n| n) || near[..8].iter().all(|&n| !n),
            "{near:?}"
        );
    }

    #[test]
    fn points_on_a_line_are_split_at_the_median() {
        // Every side is flat (no surface area): every split costs 0, so the median is taken.
        let mut items: Vec<(u32, LightBounds)> = (0..10u32)
            .map(|i| {
                let p = DVec3::new(1.5f64.powi(i as i32), 0.0, 0.0);
                (i, LightBounds::all_directions(p, p, 1.0))
            })
            .collect();
        assert_eq!(split(&mut items, 0), 5);
        assert!(
            items[..5].iter().all(|(i, _)| *i < 5),
            "{:?}",
            items.iter().map(|x| x.0).collect::<Vec<_>>()
        );
    }

    #[test]
    fn skewed_lights_stay_within_the_trail_depth() {
        // Lights at geometrically growing distances (off a line, so that the sides' costs are
        // not 0): the SAOH peels a few off at each level, which would exceed 32 levels; the
        // median takes over in time. Plus identical points.
        let mut b = LightBuilder::new();
        for i in 0..900 {
            let off = DVec3::new(0.0, 0.01 * (i % 7) as f64, 0.01 * (i % 5) as f64);
            b.point(DVec3::new(1.1f64.powi(i), 0.0, 0.0) + off, Vec3::ONE);
        }
        for _ in 0..300 {
            b.point(DVec3::new(-1.0, 2.0, 3.0), Vec3::ONE);
        }
        let bvh = LightBvh::build(&b.lights, &b.power);
        let depths = leaf_depths(&bvh);
        assert_eq!(depths.len(), 1200);
        let deepest = *depths.iter().max().unwrap();
        println!("deepest leaf {deepest} of {}", depths.len());
        assert!(deepest <= MAX_DEPTH, "a leaf at depth {deepest}");
        // The tree reaches the limit, so the guard is exercised (measured: 31).
        assert!(
            deepest >= MAX_DEPTH - 2,
            "the guard was not exercised: {deepest}"
        );
        assert!(bvh.trails.iter().all(|t| t.is_some()));
        let p = DVec3::new(5.0, 1.0, 0.0);
        let total: f64 = (0..1200).map(|l| bvh.pmf(p, DVec3::Y, l)).sum();
        assert!((total - 1.0).abs() < 1e-9, "Σ pmf {total}");
    }
}
