//! Primitives grouped by identical boxes, on every core, for the CWBVH build (cwbvh.rs): PLOC
//! merges one pair per pass among identical boxes, quadratic in their number, so the build runs
//! over the distinct boxes and expands each into its copies afterwards. Meshes have many copies
//! (a quad's two triangles share their box).
//!
//! 1. Hash every box's bits; scatter the indices into buckets by the hash's high bits (a
//!    counting sort over chunks, so each bucket lists its primitives in input order).
//! 2. Each bucket on its own core: an open-addressing table of its distinct boxes, their first
//!    primitive and their members in input order.
//! 3. The distinct boxes numbered by first appearance (a parallel filter of the first
//!    primitives), their members written to their ranges of one array.
//!
//! It replaced a parallel sort of (box bits, index) pairs and serial walks of its runs (2.2–3.4 s
//! of a 30M-triangle build on an H100 host, 0.7–1.0 s now; bench/RESULTS.md, "Cold builds on
//! every core"). Copies of one box all land in one bucket, grouped on one core: linear, and
//! measured only as a part of whole meshes.

use std::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};

use rayon::prelude::*;

use super::PrimBounds;

/// Primitives grouped by identical boxes: distinct box `r` (numbered by first appearance) has
/// `reps[r]`, its first primitive in input order, and `members(r)`, every primitive with that
/// box, in input order. Without copies `reps[i] == i` and nothing else is kept.
pub(super) struct Copies {
    pub reps: Vec<u32>,
    pub start: Vec<u32>,
    pub members: Vec<u32>,
}

impl Copies {
    pub fn members(&self, r: u32) -> &[u32] {
        &self.members[self.start[r as usize] as usize..self.start[r as usize + 1] as usize]
    }

    fn identity(n: usize) -> Copies {
        Copies {
            reps: (0..n as u32).into_par_iter().collect(),
            start: Vec::new(),
            members: Vec::new(),
        }
    }
}

/// Primitives per bucket aimed at (a bucket's table stays in a core's cache).
const BUCKET_SIZE: usize = 8192;
/// At most this many buckets (the chunk × bucket counts stay small).
const MAX_BUCKETS: usize = 4096;

fn bits(b: &PrimBounds) -> [u32; 6] {
    let (lo, hi) = (b.min.map(f32::to_bits), b.max.map(f32::to_bits));
    [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]]
}

/// A 64-bit hash of a box's bits (multiply-xor per word, splitmix64's finaliser).
fn hash(b: &PrimBounds) -> u64 {
    let mut h = 0x243F_6A88_85A3_08D3u64;
    for w in bits(b) {
        h = (h ^ w as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        h ^= h >> 32;
    }
    crate::cache_file::mix64(h)
}

/// One bucket's distinct boxes: first primitive of each (increasing) and members grouped by box,
/// group g being `members[end[g - 1]..end[g]]` (from 0 for g = 0).
struct Groups {
    firsts: Vec<u32>,
    end: Vec<u32>,
    members: Vec<u32>,
}

/// Groups `prims` by identical boxes (bit-identical min and max).
pub(super) fn distinct_boxes(prims: &[PrimBounds]) -> Copies {
    let n = prims.len();
    if n < 2 {
        return Copies::identity(n);
    }
    // Step 1: hashes, then indices scattered into buckets by the hash's top bits: each chunk
    // counts its primitives per bucket, offsets are laid out bucket-major (chunks in order inside
    // a bucket), and each chunk writes its own positions.
    let hashes: Vec<u64> = prims.par_iter().map(hash).collect();
    let buckets = n.div_ceil(BUCKET_SIZE).next_power_of_two().min(MAX_BUCKETS);
    let shift = 64 - buckets.trailing_zeros();
    let bucket = |h: u64| {
        if buckets == 1 {
            0
        } else {
            (h >> shift) as usize
        }
    };
    let chunk = n
        .div_ceil(rayon::current_num_threads() * 4)
        .max(BUCKET_SIZE);
    let counts: Vec<Vec<u32>> = hashes
        .par_chunks(chunk)
        .map(|c| {
            let mut k = vec![0u32; buckets];
            for &h in c {
                k[bucket(h)] += 1;
            }
            k
        })
        .collect();
    let mut offsets = vec![vec![0u32; buckets]; counts.len()];
    let mut bucket_start = vec![0u32; buckets + 1];
    let mut at = 0u32;
    for b in 0..buckets {
        bucket_start[b] = at;
        for (c, k) in counts.iter().enumerate() {
            offsets[c][b] = at;
            at += k[b];
        }
    }
    bucket_start[buckets] = at;
    let scattered: Vec<AtomicU32> = (0..n).into_par_iter().map(|_| AtomicU32::new(0)).collect();
    hashes
        .par_chunks(chunk)
        .zip(offsets.into_par_iter())
        .enumerate()
        .for_each(|(c, (hs, mut next))| {
            for (k, &h) in hs.iter().enumerate() {
                let b = bucket(h);
                scattered[next[b] as usize].store((c * chunk + k) as u32, Relaxed);
                next[b] += 1;
            }
        });
    let scattered: Vec<u32> = scattered.into_iter().map(AtomicU32::into_inner).collect();
    // Step 2: each bucket's distinct boxes.
    let groups: Vec<Groups> = (0..buckets)
        .into_par_iter()
        .map(|b| {
            let ids = &scattered[bucket_start[b] as usize..bucket_start[b + 1] as usize];
            group_bucket(ids, prims, &hashes)
        })
        .collect();
    drop(scattered);
    drop(hashes);
    let distinct: usize = groups.iter().map(|g| g.firsts.len()).sum();
    if distinct == n {
        return Copies::identity(n);
    }
    // Step 3: distinct boxes numbered by their first primitive; each one's members written into
    // its range (sizes first, then one prefix sum).
    let is_rep: Vec<AtomicBool> = (0..n)
        .into_par_iter()
        .map(|_| AtomicBool::new(false))
        .collect();
    groups.par_iter().for_each(|g| {
        for &f in &g.firsts {
            is_rep[f as usize].store(true, Relaxed);
        }
    });
    let reps: Vec<u32> = (0..n as u32)
        .into_par_iter()
        .filter(|&i| is_rep[i as usize].load(Relaxed))
        .collect();
    drop(is_rep);
    let rank: Vec<AtomicU32> = (0..n).into_par_iter().map(|_| AtomicU32::new(0)).collect();
    reps.par_iter()
        .enumerate()
        .for_each(|(r, &f)| rank[f as usize].store(r as u32, Relaxed));
    let sizes: Vec<AtomicU32> = (0..=distinct)
        .into_par_iter()
        .map(|_| AtomicU32::new(0))
        .collect();
    groups.par_iter().for_each(|g| {
        let mut from = 0;
        for (&f, &end) in g.firsts.iter().zip(&g.end) {
            sizes[rank[f as usize].load(Relaxed) as usize + 1].store(end - from, Relaxed);
            from = end;
        }
    });
    let mut start: Vec<u32> = sizes.into_iter().map(AtomicU32::into_inner).collect();
    for r in 1..start.len() {
        start[r] += start[r - 1];
    }
    let members: Vec<AtomicU32> = (0..n).into_par_iter().map(|_| AtomicU32::new(0)).collect();
    groups.par_iter().for_each(|g| {
        let mut from = 0;
        for (&f, &end) in g.firsts.iter().zip(&g.end) {
            let at = start[rank[f as usize].load(Relaxed) as usize] as usize;
            for (k, &m) in g.members[from as usize..end as usize].iter().enumerate() {
                members[at + k].store(m, Relaxed);
            }
            from = end;
        }
    });
    Copies {
        reps,
        start,
        members: members.into_iter().map(AtomicU32::into_inner).collect(),
    }
}

/// Step 2 for one bucket (`ids` increasing): its distinct boxes in an open-addressing table
/// (linear probing on the hash's low bits; equal hashes compared by box bits).
fn group_bucket(ids: &[u32], prims: &[PrimBounds], hashes: &[u64]) -> Groups {
    let mask = (ids.len() * 2).next_power_of_two() - 1;
    let mut table = vec![u32::MAX; mask + 1];
    let mut firsts: Vec<u32> = Vec::new();
    let mut group_of = Vec::with_capacity(ids.len());
    for &i in ids {
        let h = hashes[i as usize];
        let mut slot = h as usize & mask;
        let g = loop {
            let g = table[slot];
            if g == u32::MAX {
                table[slot] = firsts.len() as u32;
                firsts.push(i);
                break firsts.len() as u32 - 1;
            }
            let f = firsts[g as usize] as usize;
            if hashes[f] == h && bits(&prims[f]) == bits(&prims[i as usize]) {
                break g;
            }
            slot = (slot + 1) & mask;
        };
        group_of.push(g);
    }
    // Members grouped by box (a counting sort: each group's members stay in input order).
    let mut end = vec![0u32; firsts.len()];
    for &g in &group_of {
        end[g as usize] += 1;
    }
    let mut at = 0;
    for e in end.iter_mut() {
        at += *e;
        *e = at - *e; // the group's start, for now
    }
    let mut members = vec![0u32; ids.len()];
    for (&i, &g) in ids.iter().zip(&group_of) {
        members[end[g as usize] as usize] = i;
        end[g as usize] += 1;
    }
    Groups {
        firsts,
        end,
        members,
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::*;
    use crate::accel::tests::random_boxes;

    /// The serial reference: one pass in input order with a map from box bits to group.
    fn reference(prims: &[PrimBounds]) -> Vec<Vec<u32>> {
        let mut group: HashMap<[u32; 6], usize> = HashMap::new();
        let mut members: Vec<Vec<u32>> = Vec::new();
        for (i, b) in prims.iter().enumerate() {
            let g = *group.entry(bits(b)).or_insert_with(|| {
                members.push(Vec::new());
                members.len() - 1
            });
            members[g].push(i as u32);
        }
        members
    }

    fn check(prims: &[PrimBounds]) {
        let want = reference(prims);
        let got = distinct_boxes(prims);
        let reps: Vec<u32> = want.iter().map(|m| m[0]).collect();
        assert_eq!(got.reps, reps);
        if want.len() == prims.len() {
            assert!(got.start.is_empty() && got.members.is_empty());
            return;
        }
        assert_eq!(got.start.len(), want.len() + 1);
        for (r, m) in want.iter().enumerate() {
            assert_eq!(got.members(r as u32), m.as_slice(), "group {r}");
        }
    }

    /// Against the serial reference over many buckets and chunks: copies drawn from a pool
    /// (groups of one to dozens, scattered over the input), boxes differing in one bit or in
    /// the sign of a zero only, no copies at all, and tiny inputs.
    #[test]
    fn groups_match_a_serial_map() {
        let pool = random_boxes(20_000, 11);
        let mut x = 7u64;
        let mut copies: Vec<PrimBounds> = (0..90_000)
            .map(|_| {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
                let k = (x >> 33) as usize;
                // Squared: a few boxes copied many times, most a few times.
                pool[(k % 141) * (k % 141) % pool.len()]
            })
            .collect();
        copies.extend(random_boxes(5_000, 12));
        let mut near = random_boxes(3_000, 13);
        let twin = near[10];
        near[20] = twin;
        near[30] = PrimBounds {
            min: [
                twin.min[0],
                twin.min[1],
                f32::from_bits(twin.min[2].to_bits() + 1),
            ],
            ..twin
        };
        near[40] = PrimBounds {
            min: [0.0, 0.0, 0.0],
            max: [1.0; 3],
        };
        near[50] = PrimBounds {
            min: [-0.0, 0.0, 0.0],
            max: [1.0; 3],
        };
        near[60] = near[40];
        for prims in [
            copies,
            near,
            random_boxes(50_000, 14),
            vec![pool[0]; 3],
            pool[..2].to_vec(),
            pool[..1].to_vec(),
            Vec::new(),
        ] {
            check(&prims);
        }
    }
}
