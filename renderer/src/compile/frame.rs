//! The frame the BVH is built in: the centre of the scene's bounds, so the structure (and its
//! cache key) does not follow the camera; boxes move between frames in f64 and round outwards.

use glam::DVec3;
use rayon::prelude::*;

use crate::accel::PrimBounds;
use crate::layout::{GpuBvhNode, GpuCwbvhNode};
use crate::scene::Scene;

/// The largest f32 ≤ x.
fn f32_down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x {
        f.next_down()
    } else {
        f
    }
}

/// The smallest f32 ≥ x.
fn f32_up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x {
        f.next_up()
    } else {
        f
    }
}

/// An f64 box rounded outwards to f32.
pub(super) fn outward(min: DVec3, max: DVec3) -> PrimBounds {
    PrimBounds {
        min: min.to_array().map(f32_down),
        max: max.to_array().map(f32_up),
    }
}

/// The centre of the scene's geometry (world space, f64): the origin of the frame the BVH is
/// built in.
pub(super) fn scene_centre(scene: &Scene) -> DVec3 {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for m in &scene.meshes {
        for p in &m.positions {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
    }
    for s in &scene.spheres {
        lo = lo.min(s.center - DVec3::splat(s.radius));
        hi = hi.max(s.center + DVec3::splat(s.radius));
    }
    if lo.x <= hi.x {
        0.5 * (lo + hi)
    } else {
        DVec3::ZERO
    }
}

/// Moves BVH node boxes from the scene frame to the camera frame (`box − offset`, offset = camera
/// − scene centre), in f64 and rounded outwards with a few ulps of slack for the f32 rounding of
/// the camera-relative primitives (a sphere's centre), so every box still contains its
/// primitives as the GPU sees them.
pub(super) fn place_nodes(nodes: &mut [GpuBvhNode], offset: DVec3) {
    let place = |mn: &mut [f32; 3], mx: &mut [f32; 3]| {
        let lo = DVec3::from(mn.map(f64::from)) - offset;
        let hi = DVec3::from(mx.map(f64::from)) - offset;
        let slack = lo.abs().max(hi.abs()) * 1e-6;
        let b = outward(lo - slack, hi + slack);
        (*mn, *mx) = (b.min, b.max);
    };
    nodes.par_iter_mut().for_each(|n| {
        place(&mut n.l_min, &mut n.l_max);
        place(&mut n.r_min, &mut n.r_max);
    });
}

/// Moves CWBVH nodes from the scene frame to the camera frame. Quantised boxes cannot simply be
/// shifted (the node origin would round), so each node is requantised: its children's boxes,
/// decoded exactly in f64 and moved as in `place_nodes` (same slack), get a new origin `p` (the
/// f32 at or below their union) and per axis the smallest power-of-two scale `e` with
/// `p + 255·e` at or above it; each plane is rounded outwards and then stepped further out until
/// the shader's f32 decoding `p + e·q` (one rounding: e·q is exact) contains the box. Slots,
/// metadata and indices are unchanged.
pub(super) fn place_cwbvh(nodes: &mut [GpuCwbvhNode], offset: DVec3) {
    nodes.par_iter_mut().for_each(|n| {
        let scale = |byte: u8| f32::from_bits((byte as u32) << 23) as f64;
        let e_old = [
            scale(n.e_imask[0]),
            scale(n.e_imask[1]),
            scale(n.e_imask[2]),
        ];
        // Step 1: the children's boxes in the camera frame, and their union.
        let mut boxes = [None; 8];
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for (c, b) in boxes.iter_mut().enumerate() {
            if n.meta[c] == 0 {
                continue;
            }
            let plane = |a: usize, k: usize| n.p[a] as f64 + e_old[a] * n.q[2 * a + k][c] as f64;
            let bmin = DVec3::new(plane(0, 0), plane(1, 0), plane(2, 0)) - offset;
            let bmax = DVec3::new(plane(0, 1), plane(1, 1), plane(2, 1)) - offset;
            let slack = bmin.abs().max(bmax.abs()) * 1e-6;
            let (bmin, bmax) = (bmin - slack, bmax + slack);
            lo = lo.min(bmin);
            hi = hi.max(bmax);
            *b = Some((bmin, bmax));
        }
        if lo.x > hi.x {
            return; // no children: the empty scene's root
        }
        // Step 2: per axis, the new origin and scale, then each child's planes.
        for a in 0..3 {
            let p = f32_down(lo[a]);
            let decode = |e: f32, q: u8| (p + e * q as f32) as f64;
            let want = ((hi[a] - p as f64) / 255.0).max(f64::MIN_POSITIVE);
            let mut k = (want.log2().ceil() as i32).clamp(-126, 127);
            while k < 127 && decode(2f32.powi(k), 255) < hi[a] {
                k += 1;
            }
            let e = 2f32.powi(k);
            for (c, b) in boxes.iter().enumerate() {
                let Some((bmin, bmax)) = b else { continue };
                let mut ql = ((bmin[a] - p as f64) / e as f64).floor().clamp(0.0, 255.0) as u8;
                while ql > 0 && decode(e, ql) > bmin[a] {
                    ql -= 1;
                }
                let mut qh = ((bmax[a] - p as f64) / e as f64).ceil().clamp(0.0, 255.0) as u8;
                while qh < 255 && decode(e, qh) < bmax[a] {
                    qh += 1;
                }
                n.q[2 * a][c] = ql;
                n.q[2 * a + 1][c] = qh;
            }
            n.p[a] = p;
            n.e_imask[a] = (k + 127) as u8;
        }
    });
}
