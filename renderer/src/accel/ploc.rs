//! PLOC (Meister & Bittner 2018, "Parallel Locally-Ordered Clustering for Bounding Volume
//! Hierarchy Construction") on every core: the same binary tree, node for node and bit for bit,
//! as obvhs 0.4's `PlocBuilder::build` with 64-bit Morton codes, whose pass that merges the
//! agreeing pairs is serial (it walks every cluster of every pass on one core, and writes the
//! tree's nodes into freshly allocated pages there); its whole PLOC took 3.6–4.7 s of a
//! 30M-triangle build on an H100 host's 16 cores, 1.4–1.9 s with this one (bench/RESULTS.md,
//! "Cold builds on every core, session of 2026-11-27").
//!
//! 1. Leaves: one per primitive, the scene's box; Morton codes of their centres (21 bits per
//!    axis, in the scene's box), sorted (the same comparison sort as obvhs, so ties fall the same).
//! 2. Passes until one cluster is left: each cluster's nearest neighbour within `search`
//!    clusters either side (by the surface area of their union; ties to the later one), or, for
//!    the first `narrow_passes` passes, the cheaper of its two adjacent pairs; mutual neighbours
//!    merge. The merge is a stream compaction: chunks count their kept clusters and merges, a
//!    prefix sum places them, and each chunk writes its own ranges of the next pass's clusters
//!    and of the tree (children stored from the end of the node array down, in cluster order).
//!
//! `cwbvh_tests`/the tests below check it against obvhs's builder.

use obvhs::aabb::Aabb;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::{Bvh2, DEFAULT_MAX_STACK_DEPTH};
use obvhs::ploc::morton::morton_encode_u64_unorm;
use obvhs::Boundable;
use rayon::prelude::*;

use super::PrimBounds;

/// Smallest chunk of clusters one task handles (below it the pass runs on one core).
const MIN_CHUNK: usize = 1 << 13;

/// What a pass does with cluster i.
enum Fate {
    /// Carried to the next pass as it is.
    Keep,
    /// Merged with the earlier cluster `.0` (they chose each other); the parent goes on.
    Merge(usize),
    /// Merged by its partner (the later of the two).
    Taken,
}

/// The binary tree over `prims` (leaf i holds primitive i), searching `search` clusters either
/// side (1 to 32) after `narrow_passes` passes of adjacent pairs only.
pub fn build(prims: &[PrimBounds], search: usize, narrow_passes: usize) -> Bvh2 {
    assert!(
        super::SEARCH_DISTANCES.contains(&search),
        "PLOC search distance {search}"
    );
    let n = prims.len();
    assert!(
        n < 1 << 31,
        "PLOC over {n} primitives: node indices are 32-bit"
    );
    let mut bvh = Bvh2 {
        primitive_indices: (0..n as u32).into_par_iter().collect(),
        ..Default::default()
    };
    if n == 0 {
        return bvh;
    }
    // Step 1: the leaves, sorted along the Morton curve of their centres in the scene's box.
    let leaves: Vec<Bvh2Node> = (prims.par_iter().enumerate())
        .map(|(i, p)| Bvh2Node::new(p.aabb(), 1, i as u32))
        .collect();
    let total = leaves
        .par_iter()
        .map(|l| *l.aabb())
        .reduce(Aabb::empty, |a, b| a.union(&b));
    let scale = 1.0 / total.diagonal().as_dvec3();
    let offset = -total.min.as_dvec3() * scale;
    let mut mortons: Vec<(u64, u64)> = (leaves.par_iter().enumerate())
        .map(|(i, l)| {
            let centre = l.aabb().center().as_dvec3() * scale + offset;
            (morton_encode_u64_unorm(centre), i as u64)
        })
        .collect();
    mortons.par_sort_unstable_by_key(|m| m.0);
    let mut current: Vec<Bvh2Node> = mortons.par_iter().map(|m| leaves[m.1 as usize]).collect();
    drop((leaves, mortons));
    let mut next: Vec<Bvh2Node> = (0..n)
        .into_par_iter()
        .map(|_| Bvh2Node::default())
        .collect();
    // The tree, written from its end down (2n - 1 nodes, the root last at 0).
    bvh.nodes = (0..2 * n - 1)
        .into_par_iter()
        .map(|_| Bvh2Node::default())
        .collect();
    let mut insert = bvh.nodes.len();
    let mut merge = vec![0i8; n];
    // Step 2: the passes.
    let (mut count, mut depth) = (n, 0);
    while count > 1 {
        let clusters = &current[..count];
        neighbours(clusters, &mut merge[..count], search, depth < narrow_passes);
        let kept = compact(
            clusters,
            &merge[..count],
            &mut next,
            &mut bvh.nodes[..insert],
        );
        insert -= 2 * (count - kept);
        std::mem::swap(&mut current, &mut next);
        count = kept;
        depth += 1;
    }
    debug_assert_eq!(insert, 1);
    bvh.nodes[0] = current[0];
    bvh.max_depth = DEFAULT_MAX_STACK_DEPTH.max(depth + 1);
    bvh.children_are_ordered_after_parents = true;
    bvh
}

/// The surface area (half) of the union of two clusters' boxes. (NaN, which only boxes beyond
/// the scene's f32 range could give, counts as infinite, so every pass still merges.)
fn area(a: &Bvh2Node, b: &Bvh2Node) -> f32 {
    let area = a.aabb().union(b.aabb()).half_area();
    if area.is_nan() {
        f32::INFINITY
    } else {
        area
    }
}

/// Each cluster's choice as an offset to its partner: the nearest within `search` either side
/// (`<=`, so the later of equal costs), or with `narrow` the cheaper adjacent pair (the last
/// cluster looks back).
fn neighbours(clusters: &[Bvh2Node], merge: &mut [i8], search: usize, narrow: bool) {
    match search {
        _ if narrow => adjacent(clusters, merge),
        1 => adjacent(clusters, merge),
        2 => nearest::<2>(clusters, merge),
        6 => nearest::<6>(clusters, merge),
        14 => nearest::<14>(clusters, merge),
        24 => nearest::<24>(clusters, merge),
        32 => nearest::<32>(clusters, merge),
        _ => unreachable!("PLOC search distance {search}"),
    }
}

fn chunk_of(count: usize) -> usize {
    count
        .div_ceil(rayon::current_num_threads() * 4)
        .max(MIN_CHUNK)
}

/// `f(first, choices)` on every core over chunks of the choices (`first`: the chunk's first
/// cluster).
fn per_chunk(merge: &mut [i8], f: impl Fn(usize, &mut [i8]) + Sync) {
    let chunk = chunk_of(merge.len());
    (merge.par_chunks_mut(chunk).enumerate()).for_each(|(c, out)| f(c * chunk, out));
}

/// Search distance 1: the cheaper of a cluster's two adjacent pairs.
fn adjacent(clusters: &[Bvh2Node], merge: &mut [i8]) {
    let count = clusters.len();
    per_chunk(merge, |first, out| {
        for (k, m) in out.iter_mut().enumerate() {
            let i = first + k;
            *m = if i + 1 == count {
                -1
            } else {
                let before = if i == 0 {
                    f32::INFINITY
                } else {
                    area(&clusters[i - 1], &clusters[i])
                };
                if before < area(&clusters[i], &clusters[i + 1]) {
                    -1
                } else {
                    1
                }
            };
        }
    });
}

/// The nearest of the `S` clusters either side. Cluster j's costs to the clusters after it are
/// kept (in row j mod S) for when those look back: each pair's union is measured once per chunk.
fn nearest<const S: usize>(clusters: &[Bvh2Node], merge: &mut [i8]) {
    let count = clusters.len();
    per_chunk(merge, |first, out| {
        let mut ahead = [[0f32; S]; S];
        for (k, m) in out.iter_mut().enumerate() {
            let i = first + k;
            let (mut best, mut cost) = (i, f32::INFINITY);
            for other in i - S.min(i)..i {
                // Measured by `other` if this chunk visited it.
                let a = if k >= i - other {
                    ahead[other % S][i % S]
                } else {
                    area(&clusters[i], &clusters[other])
                };
                if a <= cost {
                    (best, cost) = (other, a);
                }
            }
            for other in i + 1..(i + S + 1).min(count) {
                let a = area(&clusters[i], &clusters[other]);
                ahead[i % S][other % S] = a;
                if a <= cost {
                    (best, cost) = (other, a);
                }
            }
            *m = (best as i64 - i as i64) as i8;
        }
    });
}

/// Cluster i's fate by its and its partner's choices.
fn fate(merge: &[i8], i: usize) -> Fate {
    let best = (i as i64 + merge[i] as i64) as usize;
    if best as i64 + merge[best] as i64 != i as i64 {
        Fate::Keep
    } else if best > i {
        Fate::Taken
    } else {
        Fate::Merge(best)
    }
}

/// One pass's merges: the next pass's clusters into `next` (in cluster order: kept ones and
/// parents, a parent where the later of its children was) and each merge's two children into
/// the end of `tree`, the first merge highest. Returns the number of clusters kept.
fn compact(
    clusters: &[Bvh2Node],
    merge: &[i8],
    next: &mut [Bvh2Node],
    tree: &mut [Bvh2Node],
) -> usize {
    let count = clusters.len();
    let chunk = chunk_of(count);
    // Each chunk's clusters carried on and merges.
    let tallies: Vec<(usize, usize)> = (0..count.div_ceil(chunk))
        .into_par_iter()
        .map(|c| {
            let (mut out, mut merges) = (0, 0);
            for i in c * chunk..((c + 1) * chunk).min(count) {
                match fate(merge, i) {
                    Fate::Keep => out += 1,
                    Fate::Merge(_) => (out, merges) = (out + 1, merges + 1),
                    Fate::Taken => {}
                }
            }
            (out, merges)
        })
        .collect();
    let kept: usize = tallies.iter().map(|t| t.0).sum();
    let merges: usize = tallies.iter().map(|t| t.1).sum();
    // Each chunk's ranges: its clusters in order, its children's pairs below the earlier chunks'.
    let tree_len = tree.len();
    let (mut next_rest, mut tree_rest) = (&mut next[..kept], &mut tree[tree_len - 2 * merges..]);
    let mut jobs = Vec::with_capacity(tallies.len());
    for (c, &(out, m)) in tallies.iter().enumerate() {
        let (to, rest) = next_rest.split_at_mut(out);
        next_rest = rest;
        let (rest, pairs) = tree_rest.split_at_mut(tree_rest.len() - 2 * m);
        let base = tree_len - 2 * merges + rest.len();
        tree_rest = rest;
        jobs.push((c, to, pairs, base));
    }
    jobs.into_par_iter().for_each(|(c, to, pairs, base)| {
        let (mut o, mut k) = (0, pairs.len() / 2);
        for i in c * chunk..((c + 1) * chunk).min(count) {
            match fate(merge, i) {
                Fate::Keep => {
                    to[o] = clusters[i];
                    o += 1;
                }
                Fate::Merge(best) => {
                    let (left, right) = (clusters[i], clusters[best]);
                    k -= 1;
                    pairs[2 * k] = left;
                    pairs[2 * k + 1] = right;
                    let union = left.aabb().union(right.aabb());
                    to[o] = Bvh2Node::new(union, 0, (base + 2 * k) as u32);
                    o += 1;
                }
                Fate::Taken => {}
            }
        }
    });
    kept
}

#[cfg(test)]
mod tests {
    use obvhs::ploc::{PlocBuilder, PlocSearchDistance, SortPrecision};

    use super::*;
    use crate::accel::tests::random_boxes;

    /// The same tree as obvhs's builder, bit for bit, for every search distance candela may use
    /// with and without narrow first passes, over scattered boxes (large enough for many chunks),
    /// a grid (ties in cost and equal Morton codes), flat boxes and tiny inputs.
    #[test]
    fn same_tree_as_obvhs() {
        let grid: Vec<PrimBounds> = (0..40_000)
            .map(|i| {
                let (x, y) = ((i % 200) as f32, (i / 200) as f32);
                PrimBounds {
                    min: [x, y, 0.0],
                    max: [x + 1.0, y + 1.0, 0.0],
                }
            })
            .collect();
        let cases = [
            random_boxes(60_000, 21),
            grid,
            random_boxes(3, 22),
            random_boxes(2, 23),
            random_boxes(1, 24),
            Vec::new(),
        ];
        for prims in &cases {
            for (search, narrow) in [(14, 3), (14, 0), (2, 0), (6, 2), (1, 0), (24, 3), (32, 0)] {
                let want = PlocBuilder::with_capacity(prims.len()).build(
                    PlocSearchDistance::from(search as u32),
                    prims,
                    (0..prims.len() as u32).collect(),
                    SortPrecision::U64,
                    narrow,
                );
                let got = build(prims, search, narrow);
                let what = format!("{} boxes, search {search}, narrow {narrow}", prims.len());
                let (a, b) = (
                    bytemuck::cast_slice::<_, u8>(&got.nodes),
                    bytemuck::cast_slice::<_, u8>(&want.nodes),
                );
                let first = a.iter().zip(b).position(|(x, y)| x != y);
                assert!(
                    a.len() == b.len() && first.is_none(),
                    "{what}: {} against {} node bytes, first difference at {first:?}",
                    a.len(),
                    b.len()
                );
                assert!(got.primitive_indices == want.primitive_indices, "{what}");
                assert_eq!(got.max_depth, want.max_depth, "{what}");
                assert_eq!(
                    got.children_are_ordered_after_parents, want.children_are_ordered_after_parents,
                    "{what}"
                );
            }
        }
    }
}
