//! Host tests of the uniform grid: resolution choice, insertion (every primitive lands in every
//! cell it overlaps, checked by sampling points on the shapes, independently of the overlap
//! tests), and a host mirror of the 3D-DDA in shaders/common/grid.glsl (every cell the ray
//! passes through is visited, in order, one face step at a time).

use super::*;
use crate::layout::NONE;

/// A tiny deterministic generator (xorshift64*), so the tests need no crate.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn v(&mut self, lo: f64, hi: f64) -> DVec3 {
        DVec3::new(
            lo + (hi - lo) * self.next(),
            lo + (hi - lo) * self.next(),
            lo + (hi - lo) * self.next(),
        )
    }
}

fn tri(p: [DVec3; 3]) -> (GpuPrim, PrimBounds) {
    let f = |v: DVec3, w: u32| [v.x as f32, v.y as f32, v.z as f32, f32::from_bits(w)];
    let prim = GpuPrim {
        a: f(p[0], 0),
        b: f(p[1], NONE),
        c: f(p[2], NONE),
    };
    let g = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32];
    let mn = p[0].min(p[1]).min(p[2]);
    let mx = p[0].max(p[1]).max(p[2]);
    (
        prim,
        PrimBounds {
            min: g(mn),
            max: g(mx),
        },
    )
}

fn sphere(c: DVec3, r: f64) -> (GpuPrim, PrimBounds) {
    let prim = GpuPrim {
        a: [
            c.x as f32,
            c.y as f32,
            c.z as f32,
            f32::from_bits(PRIM_SPHERE),
        ],
        b: [r as f32, 0.0, 0.0, f32::from_bits(NONE)],
        c: [0.0, 0.0, 0.0, f32::from_bits(NONE)],
    };
    let g = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32];
    (
        prim,
        PrimBounds {
            min: g(c - r),
            max: g(c + r),
        },
    )
}

/// The cell containing `p` (f64 arithmetic on the grid's f32 frame), or None outside.
fn cell_of(g: &Grid, p: DVec3) -> Option<[u32; 3]> {
    let res = g.resolution();
    let mut c = [0u32; 3];
    for a in 0..3 {
        let x = (p[a] - g.info.lo[a] as f64) / g.info.cell[a] as f64;
        if x < 0.0 || x >= res[a] as f64 {
            return None;
        }
        c[a] = x as u32;
    }
    Some(c)
}

fn random_scene(rng: &mut Rng, n: usize) -> (Vec<GpuPrim>, Vec<PrimBounds>) {
    (0..n)
        .map(|i| {
            if i % 5 == 4 {
                sphere(rng.v(-3.0, 3.0), 0.05 + 0.6 * rng.next())
            } else {
                // Mostly small triangles, some long thin ones spanning many cells.
                let a = rng.v(-4.0, 4.0);
                let s = if i % 7 == 0 { 6.0 } else { 0.8 };
                tri([a, a + rng.v(-s, s), a + rng.v(-s, s)])
            }
        })
        .unzip()
}

#[test]
fn resolution_follows_the_options() {
    // An explicit resolution is the cell count along the longest axis.
    assert_eq!(choose_resolution([4.0, 2.0, 1.0], 100, Some(8)), [8, 4, 2]);
    assert_eq!(choose_resolution([4.0, 2.0, 1.0], 100, Some(1)), [1, 1, 1]);
    assert_eq!(choose_resolution([1.0, 0.0, 1.0], 10, Some(4)), [4, 1, 4]);
    // Automatic: about λ cells per primitive.
    for n in [10usize, 1000, 100_000] {
        let r = choose_resolution([2.0, 1.0, 3.0], n, None);
        let cells = r.iter().map(|&x| x as f64).product::<f64>();
        let ratio = cells / (DEFAULT_DENSITY * n as f64);
        assert!((0.4..2.5).contains(&ratio), "n = {n}: {r:?}");
    }
    // Caps per axis and in total.
    assert_eq!(
        choose_resolution([1.0, 1.0, 1.0], 10, Some(100_000)),
        [256; 3] // 512³ cells exceed MAX_CELLS = 256³
    );
    let r = choose_resolution([1.0, 1.0, 1.0], usize::MAX / 4, None);
    assert!(r.iter().map(|&x| x as u64).product::<u64>() <= MAX_CELLS);
    assert_eq!(choose_resolution([0.0; 3], 5, None), [1, 1, 1]);
    assert_eq!(choose_resolution([1.0; 3], 0, None), [1, 1, 1]);
}

#[test]
fn triangle_box_overlap_cases() {
    let (lo, hi) = (DVec3::ZERO, DVec3::ONE);
    let t = |a: [f64; 3], b: [f64; 3], c: [f64; 3]| {
        triangle_box_overlap(&[a.into(), b.into(), c.into()], lo, hi)
    };
    assert!(t([0.5, 0.5, 0.5], [2.0, 0.5, 0.5], [0.5, 2.0, 0.5])); // a vertex inside
    assert!(t([-1.0, -1.0, 0.5], [3.0, -1.0, 0.5], [-1.0, 3.0, 0.5])); // cuts through
    assert!(!t([2.0, 2.0, 0.5], [3.0, 2.0, 0.5], [2.0, 3.0, 0.5])); // beside
                                                                    // Bounds overlap, triangle misses the corner (separated by an edge axis or the plane).
    assert!(!t([1.5, -0.5, 0.5], [1.5, 1.5, 0.5], [3.0, 0.5, 0.5]));
    assert!(t([1.2, 0.0, 0.0], [0.0, 1.2, 0.0], [0.0, 0.0, 1.2])); // plane cuts the box
    assert!(t([2.9, 0.0, 0.0], [0.0, 2.9, 0.0], [0.0, 0.0, 2.9])); // clips the (1,1,1) corner
    assert!(!t([3.1, 0.0, 0.0], [0.0, 3.1, 0.0], [0.0, 0.0, 3.1])); // plane beyond (1,1,1)
                                                                    // Degenerate (a segment) still found where it crosses the box.
    assert!(t([-1.0, 0.5, 0.5], [2.0, 0.5, 0.5], [0.5, 0.5, 0.5]));
}

/// Every primitive is listed in every cell containing a point of it (sampled densely), lists are
/// sorted without duplicates, and nothing is listed far from its shape.
#[test]
fn every_primitive_lands_in_every_cell_it_overlaps() {
    let mut rng = Rng(0x1234_5678_9abc_def1);
    let (prims, bounds) = random_scene(&mut rng, 60);
    for res in [Some(1), Some(2), Some(7), None, Some(40)] {
        let g = build(&prims, &bounds, res);
        let [nx, ny, nz] = g.resolution();
        assert_eq!(g.cells.len() as u32, nx * ny * nz + 1);
        assert_eq!(g.info.prim_refs as usize, g.prims.len());
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    let c = g.cell(x, y, z);
                    assert!(c.windows(2).all(|w| w[0] < w[1]), "sorted, unique");
                }
            }
        }
        for (i, p) in prims.iter().enumerate() {
            let mut points = Vec::new();
            if p.a[3].to_bits() & PRIM_SPHERE != 0 {
                let c = DVec3::new(p.a[0] as f64, p.a[1] as f64, p.a[2] as f64);
                for _ in 0..400 {
                    let d = (rng.v(-1.0, 1.0)).normalize_or(DVec3::X);
                    points.push(c + d * p.b[0] as f64);
                }
            } else {
                let v = |w: [f32; 4]| DVec3::new(w[0] as f64, w[1] as f64, w[2] as f64);
                let (a, b, c) = (v(p.a), v(p.b), v(p.c));
                let k = 40;
                for u in 0..=k {
                    for w in 0..=(k - u) {
                        let (fu, fw) = (u as f64 / k as f64, w as f64 / k as f64);
                        points.push(a + (b - a) * fu + (c - a) * fw);
                    }
                }
            }
            for q in points {
                let cell = cell_of(&g, q).expect("the grid box holds every primitive");
                assert!(
                    g.cell(cell[0], cell[1], cell[2]).contains(&(i as u32)),
                    "res {res:?}: primitive {i} missing from cell {cell:?}"
                );
            }
        }
        // No reference outside the primitive's dilated bounds.
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    for &i in g.cell(x, y, z) {
                        let b = bounds[i as usize];
                        for (a, c) in [x, y, z].into_iter().enumerate() {
                            let lo = g.info.lo[a] + c as f32 * g.info.cell[a];
                            let hi = lo + g.info.cell[a];
                            let slack = 0.01 * g.info.cell[a];
                            assert!(b.min[a] <= hi + slack && b.max[a] >= lo - slack);
                        }
                    }
                }
            }
        }
        // Exact overlap is tighter than bounds: long thin triangles skip most of their box.
        let box_refs: u64 = bounds
            .iter()
            .map(|b| {
                (0..3)
                    .map(|a| {
                        let c = |x: f32| {
                            (((x - g.info.lo[a]) / g.info.cell[a]).floor() as i64)
                                .clamp(0, g.resolution()[a] as i64 - 1)
                        };
                        (c(b.max[a]) - c(b.min[a]) + 1) as u64
                    })
                    .product::<u64>()
            })
            .sum();
        assert!(g.prims.len() as u64 <= box_refs + 60 * 8);
        if res == Some(40) {
            assert!(
                (g.prims.len() as u64) < box_refs / 2,
                "{} vs {box_refs}",
                g.prims.len()
            );
        }
    }
}

#[test]
fn empty_and_flat_scenes() {
    let g = build(&[], &[], None);
    assert_eq!(g.resolution(), [1, 1, 1]);
    assert_eq!(g.cells, vec![0, 0]);
    // A single quad in the plane z = 0: the flat axis gets one cell of nonzero size.
    let (p0, b0) = tri([DVec3::ZERO, DVec3::X, DVec3::Y]);
    let (p1, b1) = tri([DVec3::X, DVec3::ONE.with_z(0.0), DVec3::Y]);
    let g = build(&[p0, p1], &[b0, b1], Some(8));
    assert_eq!(g.resolution()[2], 1);
    assert!(g.info.cell[2] > 0.0 && g.info.inv_cell[2].is_finite());
    assert_eq!(g.cell(0, 0, 0), &[0]);
    assert_eq!(g.cell(7, 7, 0), &[1]);
}

/// The host mirror of `traverse_grid`'s walk (f32, as in shaders/common/grid.glsl): the cells
/// visited for a ray over (tmin, tmax), with no hits to stop it.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(a <= b)` is true on NaN, as in the shader
fn dda_cells(info: &GpuGridInfo, o: [f32; 3], d: [f32; 3], tmin: f32, tmax: f32) -> Vec<[i32; 3]> {
    let inv: [f32; 3] = std::array::from_fn(|a| {
        let tiny = 1e-30f32;
        let dc = if d[a].abs() < tiny {
            if d[a] < 0.0 {
                -tiny
            } else {
                tiny
            }
        } else {
            d[a]
        };
        1.0 / dc
    });
    let gamma = 1.0 + 2.0 * (3.0 * 5.960_464_5e-8) / (1.0 - 3.0 * 5.960_464_5e-8);
    let (mut t_enter, mut t_leave) = (tmin, tmax);
    for a in 0..3 {
        let t0 = (info.lo[a] - o[a]) * inv[a];
        let t1 = (info.hi[a] - o[a]) * inv[a];
        t_enter = t_enter.max(t0.min(t1));
        t_leave = t_leave.min(t0.max(t1) * gamma);
    }
    if !(t_enter <= t_leave) {
        return Vec::new();
    }
    let res = [info.nx as i32, info.ny as i32, info.nz as i32];
    let mut cell = [0i32; 3];
    let (mut stp, mut stop, mut face, mut t_next) = ([0i32; 3], [0i32; 3], [0i32; 3], [0f32; 3]);
    for a in 0..3 {
        let p = o[a] + t_enter * d[a];
        cell[a] = (((p - info.lo[a]) * info.inv_cell[a]).floor() as i32).clamp(0, res[a] - 1);
        let pos = inv[a] >= 0.0;
        stp[a] = if pos { 1 } else { -1 };
        stop[a] = if pos { res[a] } else { -1 };
        face[a] = pos as i32;
        t_next[a] = (info.lo[a] + (cell[a] + face[a]) as f32 * info.cell[a] - o[a]) * inv[a];
    }
    let mut out = Vec::new();
    loop {
        out.push(cell);
        let t_exit = t_next[0].min(t_next[1]).min(t_next[2]);
        if tmax <= t_exit || t_exit > t_leave {
            break;
        }
        let a = if t_next[0] <= t_next[1] && t_next[0] <= t_next[2] {
            0
        } else if t_next[1] <= t_next[2] {
            1
        } else {
            2
        };
        cell[a] += stp[a];
        if cell[a] == stop[a] {
            break;
        }
        t_next[a] = (info.lo[a] + (cell[a] + face[a]) as f32 * info.cell[a] - o[a]) * inv[a];
    }
    out
}

/// The walk visits, in order and by face steps, every cell that points of the ray segment lie
/// in: rays from inside and outside the grid, axis-aligned rays, rays ending inside.
#[test]
fn dda_visits_every_cell_the_ray_crosses() {
    let mut rng = Rng(42);
    let (prims, bounds) = random_scene(&mut rng, 30);
    for res in [Some(1), Some(5), Some(33), None] {
        let g = build(&prims, &bounds, res);
        let lo = DVec3::from(g.info.lo.map(f64::from));
        let hi = DVec3::from(g.info.hi.map(f64::from));
        for k in 0..300 {
            // Origins inside and far outside the grid.
            let o = if k % 2 == 0 {
                lo + (hi - lo) * rng.v(0.0, 1.0)
            } else {
                rng.v(-30.0, 30.0)
            };
            let mut d = rng.v(-1.0, 1.0).normalize_or(DVec3::Z);
            if k % 10 == 1 {
                // Axis-aligned: two components exactly zero, aimed at the grid.
                let a = k / 10 % 3;
                let mut e = DVec3::ZERO;
                e[a] = if (0.5 * (lo + hi) - o)[a] >= 0.0 {
                    1.0
                } else {
                    -1.0
                };
                d = e;
            }
            let tmax: f64 = if k % 3 == 0 { 5.0 } else { 1e30 };
            let f = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32];
            let cells = dda_cells(&g.info, f(o), f(d), 0.0, tmax as f32);
            // Consecutive cells are face neighbours.
            for w in cells.windows(2) {
                let steps: i32 = (0..3).map(|a| (w[1][a] - w[0][a]).abs()).sum();
                assert_eq!(steps, 1, "{cells:?}");
            }
            // Every sampled point of the segment inside the grid, away from cell faces, lies in
            // a visited cell.
            for s in 0..2000 {
                let t = (s as f64 + 0.5) / 2000.0 * tmax.min(120.0);
                let p = o + d * t;
                let Some(c) = cell_of(&g, p) else { continue };
                let near_face = (0..3).any(|a| {
                    let x = (p[a] - g.info.lo[a] as f64) / g.info.cell[a] as f64;
                    (x - x.round()).abs() < 1e-4
                });
                if !near_face {
                    let c = c.map(|x| x as i32);
                    assert!(
                        cells.contains(&c),
                        "res {res:?} ray {k}: {c:?} not in {cells:?}"
                    );
                }
            }
        }
    }
}

/// Ray/triangle distance in f64 (Möller–Trumbore), for the host mirror of the closest-hit walk.
fn hit_triangle(p: &GpuPrim, o: DVec3, d: DVec3) -> Option<f64> {
    let v = |w: [f32; 4]| DVec3::new(w[0] as f64, w[1] as f64, w[2] as f64);
    let (a, b, c) = (v(p.a), v(p.b), v(p.c));
    let (e1, e2) = (b - a, c - a);
    let q = d.cross(e2);
    let det = e1.dot(q);
    if det.abs() < 1e-14 {
        return None;
    }
    let s = o - a;
    let u = s.dot(q) / det;
    let r = s.cross(e1);
    let w = d.dot(r) / det;
    let t = e2.dot(r) / det;
    (u >= 0.0 && w >= 0.0 && u + w <= 1.0 && t > 0.0).then_some(t)
}

/// The closest-hit rule of grid.glsl on the host: walk the cells in order, keep the nearest hit
/// so far, stop once it lies before the current cell's exit. Returns (t, primitive).
fn grid_closest(g: &Grid, prims: &[GpuPrim], o: DVec3, d: DVec3) -> Option<(f64, u32)> {
    let f = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32];
    let cells = dda_cells(&g.info, f(o), f(d), 0.0, f32::MAX);
    let mut best: Option<(f64, u32)> = None;
    for c in cells {
        for &i in g.cell(c[0] as u32, c[1] as u32, c[2] as u32) {
            if let Some(t) = hit_triangle(&prims[i as usize], o, d) {
                if best.is_none_or(|(bt, _)| t < bt) {
                    best = Some((t, i));
                }
            }
        }
        // The cell's exit distance (the nearest far face), as in the shader.
        let exit = (0..3)
            .map(|a| {
                let face = if d[a] >= 0.0 { c[a] + 1 } else { c[a] };
                let x = g.info.lo[a] as f64 + face as f64 * g.info.cell[a] as f64;
                if d[a] == 0.0 {
                    f64::INFINITY
                } else {
                    (x - o[a]) / d[a]
                }
            })
            .fold(f64::INFINITY, f64::min);
        if best.is_some_and(|(t, _)| t <= exit) {
            break;
        }
    }
    best
}

/// Long triangles span many cells, so a hit found in an early cell may lie beyond it while a
/// nearer triangle waits in a later cell: the walk must still return the true nearest hit.
#[test]
fn closest_hit_walk_equals_brute_force() {
    let mut rng = Rng(7);
    let (prims, bounds): (Vec<GpuPrim>, Vec<PrimBounds>) = (0..80)
        .map(|i| {
            let a = rng.v(-4.0, 4.0);
            let s = if i % 3 == 0 { 7.0 } else { 0.7 };
            tri([a, a + rng.v(-s, s), a + rng.v(-s, s)])
        })
        .unzip();
    let mut checked = 0;
    for res in [Some(1), Some(4), None, Some(24)] {
        let g = build(&prims, &bounds, res);
        for k in 0..400 {
            let o = if k % 2 == 0 {
                rng.v(-4.0, 4.0)
            } else {
                rng.v(-20.0, 20.0)
            };
            let target = rng.v(-3.0, 3.0);
            let d = (target - o).normalize();
            let brute = prims
                .iter()
                .enumerate()
                .filter_map(|(i, p)| hit_triangle(p, o, d).map(|t| (t, i as u32)))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let walk = grid_closest(&g, &prims, o, d);
            match (brute, walk) {
                (None, None) => {}
                (Some(b), Some(w)) => {
                    assert!(
                        (b.0 - w.0).abs() <= 1e-9 * b.0.max(1.0),
                        "res {res:?} ray {k}"
                    );
                    checked += 1;
                }
                _ => panic!("res {res:?} ray {k}: brute {brute:?}, walk {walk:?}"),
            }
        }
    }
    assert!(checked > 300, "only {checked} rays hit anything");
}

#[test]
fn grid_info_matches_its_glsl_mirror_size() {
    // vec3 lo; uint nx; vec3 hi; uint ny; vec3 cell; uint nz; vec3 inv_cell; uint prim_refs
    assert_eq!(std::mem::size_of::<GpuGridInfo>(), 64);
    assert_eq!(std::mem::offset_of!(GpuGridInfo, ny), 28);
    assert_eq!(std::mem::offset_of!(GpuGridInfo, inv_cell), 48);
}
