//! The frame the BVH is built in: the centre of the scene's bounds, so the structure (and its
//! cache key) does not follow the camera; boxes move between frames in f64 and round outwards.

use glam::DVec3;

use crate::accel::PrimBounds;
use crate::layout::GpuBvhNode;
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
    for n in nodes {
        place(&mut n.l_min, &mut n.l_max);
        place(&mut n.r_min, &mut n.r_max);
    }
}
