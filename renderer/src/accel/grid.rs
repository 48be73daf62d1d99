//! Uniform grid acceleration structure (Fujimoto et al. 1986; Cleary & Wyvill 1988), the
//! alternative to the BVH selected with `accel: "grid"`. Built on the host: the scene box is cut
//! into nx × ny × nz equal cells, each primitive is referenced from every cell it really
//! overlaps (triangles: the separating-axis triangle/box test of Akenine-Möller 2001; spheres:
//! Arvo's sphere/box distance test), and the references are stored cell after cell so a cell is
//! the range `cells[i] .. cells[i + 1]` of `prims` (a prefix sum: offset and count in one u32 per
//! cell). `shaders/common/grid.glsl` walks the cells with the 3D-DDA of Amanatides & Woo 1987.
//!
//! Resolution: by default the grid has about λ·N cells for N primitives (λ = 3 cells per
//! primitive, the density Cleary & Wyvill and the GPU stream ray tracers of Purcell et al. 2002
//! and Wald et al. 2006 found best), split over the axes in proportion to the scene box
//! (n_a ≈ extent_a · (λN / volume)^(1/3)). An explicit `grid_resolution` R is the number of cells
//! along the longest axis; the other axes get cells of about the same size. Each axis is capped
//! at [`MAX_AXIS`] cells and the whole grid at [`MAX_CELLS`].
//!
//! Robustness: cells are dilated by [`DILATION`] cell widths (plus the f32 rounding of the
//! coordinates) when primitives are inserted, so the GPU's f32 cell walk cannot step past a
//! cell a primitive touches within rounding; the traversal keeps the nearest hit found so far
//! and stops only once it lies before the current cell's exit, so a primitive spanning several
//! cells can never be taken too early.

use std::time::{Duration, Instant};

use glam::DVec3;

use super::PrimBounds;
use crate::layout::{GpuGridInfo, GpuPrim, PRIM_SPHERE};

/// Cells per primitive of the automatic resolution (λ).
pub const DEFAULT_DENSITY: f64 = 3.0;
/// Most cells along one axis.
pub const MAX_AXIS: u32 = 512;

/// An explicit grid resolution (cells along the longest axis), checked: the one rule that the
/// scene file, the CLI, the HTTP API and the acceleration choice apply. The error is the part of
/// a message after its location.
pub fn check_resolution(r: u64) -> Result<u32, String> {
    if (1..=MAX_AXIS as u64).contains(&r) {
        Ok(r as u32)
    } else {
        Err(format!(
            "must be in [1, {MAX_AXIS}] (cells along the longest axis), got {r}"
        ))
    }
}
/// Most cells in the whole grid (64 MiB of offsets).
pub const MAX_CELLS: u64 = 1 << 24;
/// Cells are grown by this fraction of their width when primitives are inserted.
pub const DILATION: f64 = 1e-3;

/// A built grid in its GPU form.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    pub info: GpuGridInfo,
    /// `cells[i] .. cells[i + 1]` is cell i's range of `prims`; cells + 1 entries.
    pub cells: Vec<u32>,
    /// Primitive indices (into the scene's primitive array), cell after cell.
    pub prims: Vec<u32>,
    pub build_time: Duration,
}

impl Grid {
    /// Cells along x, y, z.
    pub fn resolution(&self) -> [u32; 3] {
        [self.info.nx, self.info.ny, self.info.nz]
    }

    /// Bytes of the three GPU buffers.
    pub fn bytes(&self) -> u64 {
        (std::mem::size_of::<GpuGridInfo>() + 4 * self.cells.len() + 4 * self.prims.len()) as u64
    }

    /// The primitive indices referenced from cell (x, y, z).
    pub fn cell(&self, x: u32, y: u32, z: u32) -> &[u32] {
        let i = ((z * self.info.ny + y) * self.info.nx + x) as usize;
        &self.prims[self.cells[i] as usize..self.cells[i + 1] as usize]
    }
}

/// Chooses the cells per axis for `n` primitives in a box of `extent` (see the module docs):
/// `resolution` = cells along the longest axis, or None for about λ·n cells in all.
pub fn choose_resolution(extent: [f64; 3], n: usize, resolution: Option<u32>) -> [u32; 3] {
    let longest = extent.iter().cloned().fold(0.0, f64::max);
    if n == 0 || longest <= 0.0 {
        return [1, 1, 1];
    }
    // Step 1: the edge length of a (roughly cubic) cell.
    let side = match resolution {
        Some(r) => longest / r.clamp(1, MAX_AXIS) as f64,
        None => {
            // Axes thinner than a thousandth of the longest count as that thin for the volume.
            let e = extent.map(|x| x.max(longest * 1e-3));
            let volume = e[0] * e[1] * e[2];
            (volume / (DEFAULT_DENSITY * n as f64)).cbrt()
        }
    };
    // Step 2: cells per axis, capped per axis and then in total.
    let mut res = extent.map(|x| ((x / side).round() as u64).clamp(1, MAX_AXIS as u64) as u32);
    let total = |r: &[u32; 3]| r.iter().map(|&x| x as u64).product::<u64>();
    if total(&res) > MAX_CELLS {
        let f = (MAX_CELLS as f64 / total(&res) as f64).cbrt();
        res = res.map(|r| ((r as f64 * f).floor() as u32).max(1));
        while total(&res) > MAX_CELLS {
            let a = (0..3).max_by_key(|&a| res[a]).unwrap_or(0);
            res[a] -= 1;
        }
    }
    res
}

/// Builds the grid over `prims` (their exact shapes) with `bounds[i]` the box of `prims[i]`.
pub fn build(prims: &[GpuPrim], bounds: &[PrimBounds], resolution: Option<u32>) -> Grid {
    let start = Instant::now();
    // Step 1: the grid box: the scene bounds, padded so no primitive touches its faces and no
    // axis is flat.
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for b in bounds {
        lo = lo.min(DVec3::from(b.min.map(f64::from)));
        hi = hi.max(DVec3::from(b.max.map(f64::from)));
    }
    if bounds.is_empty() {
        (lo, hi) = (DVec3::ZERO, DVec3::ONE);
    }
    let ext = hi - lo;
    let pad = DVec3::splat(ext.max_element().max(1e-6) * 1e-4) + lo.abs().max(hi.abs()) * 1e-6;
    let (lo, hi) = (lo - pad, hi + pad);
    let res = choose_resolution((hi - lo).to_array(), prims.len(), resolution);
    // The frame exactly as the GPU sees it (f32), used for the insertion below as well.
    let lo32 = lo.to_array().map(|x| x as f32);
    let hi32 = hi.to_array().map(|x| x as f32);
    let cell32: [f32; 3] = std::array::from_fn(|a| (hi32[a] - lo32[a]) / res[a] as f32);
    let lo_f = DVec3::from(lo32.map(f64::from));
    let cell_f = DVec3::from(cell32.map(f64::from));
    // Dilation in world units: a fraction of a cell plus the rounding of f32 coordinates.
    let mag = lo_f
        .abs()
        .max(DVec3::from(hi32.map(f64::from)).abs())
        .max_element();
    let dil = cell_f * DILATION + DVec3::splat(mag * 1e-5);

    // Step 2: for each primitive, the cells of its dilated bounds that it really overlaps.
    let n_cells = res.iter().map(|&r| r as usize).product::<usize>();
    let mut counts = vec![0u32; n_cells + 1];
    let mut refs: Vec<(u32, u32)> = Vec::new(); // (cell, prim)
    let cell_range = |x: f64, a: usize, d: f64| -> u32 {
        (((x - lo_f[a] + d) / cell_f[a]).floor().max(0.0) as u64).min(res[a] as u64 - 1) as u32
    };
    for (i, (p, b)) in prims.iter().zip(bounds).enumerate() {
        let r0: [u32; 3] = std::array::from_fn(|a| cell_range(b.min[a] as f64, a, -dil[a]));
        let r1: [u32; 3] = std::array::from_fn(|a| cell_range(b.max[a] as f64, a, dil[a]));
        let shape = Shape::of(p);
        // A primitive whose dilated bounds fall in one cell overlaps it: no test needed.
        let single = r0 == r1;
        for z in r0[2]..=r1[2] {
            for y in r0[1]..=r1[1] {
                for x in r0[0]..=r1[0] {
                    let c = DVec3::new(x as f64, y as f64, z as f64);
                    let bmin = lo_f + c * cell_f - dil;
                    let bmax = lo_f + (c + 1.0) * cell_f + dil;
                    if single || shape.overlaps(bmin, bmax) {
                        let ci = (z * res[1] + y) * res[0] + x;
                        refs.push((ci, i as u32));
                        counts[ci as usize] += 1;
                    }
                }
            }
        }
    }
    // Step 3: prefix sum into offsets, then place the references (a counting sort by cell, so
    // each cell lists its primitives in ascending order).
    let mut offsets = vec![0u32; n_cells + 1];
    for i in 0..n_cells {
        offsets[i + 1] = offsets[i] + counts[i];
    }
    let mut fill = offsets.clone();
    let mut list = vec![0u32; refs.len()];
    for (c, p) in refs {
        list[fill[c as usize] as usize] = p;
        fill[c as usize] += 1;
    }
    let info = GpuGridInfo {
        lo: lo32,
        nx: res[0],
        hi: hi32,
        ny: res[1],
        cell: cell32,
        nz: res[2],
        inv_cell: cell32.map(|c| 1.0 / c),
        prim_refs: list.len() as u32,
    };
    Grid {
        info,
        cells: offsets,
        prims: list,
        build_time: start.elapsed(),
    }
}

/// A primitive's exact shape for the overlap tests (f32 values as uploaded, widened to f64).
enum Shape {
    Triangle([DVec3; 3]),
    Sphere(DVec3, f64),
}

impl Shape {
    fn of(p: &GpuPrim) -> Shape {
        let v = |x: [f32; 4]| DVec3::new(x[0] as f64, x[1] as f64, x[2] as f64);
        if p.a[3].to_bits() & PRIM_SPHERE != 0 {
            // Radius grown by its own rounding and the centre's, like the BVH bounds.
            let c = v(p.a);
            let r = p.b[0] as f64 * (1.0 + 1e-6) + c.abs().max_element() * 1e-6;
            Shape::Sphere(c, r)
        } else {
            Shape::Triangle([v(p.a), v(p.b), v(p.c)])
        }
    }

    fn overlaps(&self, bmin: DVec3, bmax: DVec3) -> bool {
        match self {
            Shape::Triangle(t) => triangle_box_overlap(t, bmin, bmax),
            Shape::Sphere(c, r) => {
                // Arvo 1990: squared distance from the centre to the box.
                let d = (bmin - *c).max(DVec3::ZERO) + (*c - bmax).max(DVec3::ZERO);
                d.length_squared() <= r * r
            }
        }
    }
}

/// Triangle/box overlap by the separating axis theorem (Akenine-Möller 2001): the box normals,
/// the triangle normal and the nine edge cross products. Degenerate triangles (zero normal or
/// edges) fall back on the remaining axes, which keeps the test conservative.
pub fn triangle_box_overlap(t: &[DVec3; 3], bmin: DVec3, bmax: DVec3) -> bool {
    let c = 0.5 * (bmin + bmax);
    let h = 0.5 * (bmax - bmin);
    let v = [t[0] - c, t[1] - c, t[2] - c];
    // Step 1: the box's own axes (the triangle's bounds against the box).
    for a in 0..3 {
        let mn = v[0][a].min(v[1][a]).min(v[2][a]);
        let mx = v[0][a].max(v[1][a]).max(v[2][a]);
        if mn > h[a] || mx < -h[a] {
            return false;
        }
    }
    // Step 2: the triangle's plane, and the nine cross products of edges with box axes.
    let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    let mut axes = [e[0].cross(e[1]); 10];
    for (k, edge) in e.iter().enumerate() {
        for (j, unit) in [DVec3::X, DVec3::Y, DVec3::Z].iter().enumerate() {
            axes[1 + 3 * k + j] = edge.cross(*unit);
        }
    }
    for axis in axes {
        if axis.length_squared() == 0.0 {
            continue;
        }
        let p = [axis.dot(v[0]), axis.dot(v[1]), axis.dot(v[2])];
        let r = h.x * axis.x.abs() + h.y * axis.y.abs() + h.z * axis.z.abs();
        // A little slack so rounding never separates touching shapes.
        let slack = 1e-9 * (r + p.iter().map(|x| x.abs()).fold(0.0, f64::max));
        if p[0].min(p[1]).min(p[2]) > r + slack || p[0].max(p[1]).max(p[2]) < -r - slack {
            return false;
        }
    }
    true
}

#[cfg(test)]
#[path = "grid_tests.rs"]
mod tests;
