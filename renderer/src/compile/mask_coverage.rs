//! The share of an alpha-masked emitter that exists: the fraction of its area where the mask is
//! ≥ 0.5, as the shaders' `mask_cuts` decides (shaders/common/alpha.glsl). Light sampling picks
//! such an emitter by its power times this share (a sampled point in a hole emits nothing, so the
//! estimate stays unbiased whatever the share; it only steers samples away from the holes), and
//! `deferred`'s point-like area lights shine with intensity radiance · area · this share
//! (renderer/src/integrators/deferred/lights.rs). Estimated on a fixed stratified set of
//! `SIDE`² points spread uniformly over the surface's area.

use std::f32::consts::PI;

use glam::{Vec2, Vec4};

use crate::scene::Texture;

/// Points per side of the stratified set (`SIDE`² points per emitter).
const SIDE: usize = 16;

/// Bilinear lookup at uv with repeat wrapping: common/texture.glsl's `texture_eval` (masks
/// never clamp rows: only environment maps do).
pub fn texture_eval(t: &Texture, uv: Vec2) -> Vec4 {
    let uv = uv * t.scale;
    let uv = uv - uv.floor();
    let fx = uv.x * t.width as f32 - 0.5;
    let fy = (1.0 - uv.y) * t.height as f32 - 0.5;
    let (x0, y0) = (fx.floor(), fy.floor());
    let (ax, ay) = (fx - x0, fy - y0);
    let (w, h) = (t.width as i64, t.height as i64);
    let fetch = |x: i64, y: i64| {
        let (x, y) = (x.rem_euclid(w), y.rem_euclid(h));
        Vec4::from(t.texels[(y * w + x) as usize])
    };
    let (ix, iy) = (x0 as i64, y0 as i64);
    let top = fetch(ix, iy).lerp(fetch(ix + 1, iy), ax);
    let bottom = fetch(ix, iy + 1).lerp(fetch(ix + 1, iy + 1), ax);
    top.lerp(bottom, ay)
}

/// The stratified unit-square points.
fn points() -> impl Iterator<Item = Vec2> {
    (0..SIDE * SIDE).map(|k| {
        let (i, j) = (k % SIDE, k / SIDE);
        Vec2::new(
            (i as f32 + 0.5) / SIDE as f32,
            (j as f32 + 0.5) / SIDE as f32,
        )
    })
}

/// The fraction of `uv(point)` over the points that the mask keeps.
fn kept(mask: &Texture, uv: impl Fn(Vec2) -> Vec2) -> f32 {
    let n = points()
        .filter(|&u| texture_eval(mask, uv(u)).x >= 0.5)
        .count();
    n as f32 / (SIDE * SIDE) as f32
}

/// The share of a triangle with vertex uvs `uv` that `mask` keeps (points uniform by area:
/// barycentrics (1 − √u, v√u)).
pub fn triangle_kept(mask: &Texture, uv: [Vec2; 3]) -> f32 {
    kept(mask, |u| {
        let s = u.x.sqrt();
        let (b1, b2) = (1.0 - s, u.y * s);
        (1.0 - b1 - b2) * uv[0] + b1 * uv[1] + b2 * uv[2]
    })
}

/// The share of a sphere that `mask` keeps at the sphere's own uvs (common/intersect.glsl's
/// `sphere_uv`: u = longitude / 2π, v = 1 − colatitude / π; points uniform by area: z uniform).
pub fn sphere_kept(mask: &Texture) -> f32 {
    kept(mask, |u| {
        let z = 1.0 - 2.0 * u.y;
        Vec2::new(u.x, 1.0 - z.clamp(-1.0, 1.0).acos() / PI)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A w×h texture whose texel (x, y) (row 0 at the top) is `f(x, y)`.
    fn texture(w: u32, h: u32, f: impl Fn(u32, u32) -> f32) -> Texture {
        let texels: Vec<[f32; 4]> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| [f(x, y), 0.0, 0.0, 1.0])
            .collect();
        Texture {
            source: "test".into(),
            width: w,
            height: h,
            texels: texels.into(),
            scale: Vec2::ONE,
        }
    }

    #[test]
    fn lookups_match_the_shader_conventions() {
        // Row 0 is the top: v = 1 there; bilinear between texel centres; repeat wrapping.
        let t = texture(2, 2, |x, y| (x + 2 * y) as f32);
        assert_eq!(texture_eval(&t, Vec2::new(0.25, 0.75)).x, 0.0);
        assert_eq!(texture_eval(&t, Vec2::new(0.75, 0.25)).x, 3.0);
        assert_eq!(texture_eval(&t, Vec2::new(0.5, 0.75)).x, 0.5);
        assert_eq!(texture_eval(&t, Vec2::new(1.25, -0.75)).x, 2.0);
    }

    #[test]
    fn shares_follow_the_mask() {
        let all = texture(4, 4, |_, _| 1.0);
        let none = texture(4, 4, |_, _| 0.0);
        // Left half kept (u < 0.5), as a wide texture so the bilinear ramp is thin.
        let left = texture(64, 1, |x, _| if x < 32 { 1.0 } else { 0.0 });
        let quad = [Vec2::ZERO, Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)];
        assert_eq!(triangle_kept(&all, quad), 1.0);
        assert_eq!(triangle_kept(&none, quad), 0.0);
        // The triangle (0,0), (1,0), (0,1) has 3/4 of its area at u < 1/2.
        let t = triangle_kept(&left, quad);
        assert!((t - 0.75).abs() < 0.03, "{t}");
        // Half the longitudes of a sphere.
        let s = sphere_kept(&left);
        assert!((s - 0.5).abs() < 0.03, "{s}");
        // The texture's top quarter is the cap of colatitude < π/4 (v = 1 at the +z pole), by
        // area (1 − cos π/4) / 2 of the sphere.
        let cap = texture(1, 64, |_, y| if y < 16 { 1.0 } else { 0.0 });
        let s = sphere_kept(&cap);
        let exact = (1.0 - std::f32::consts::FRAC_PI_4.cos()) / 2.0;
        assert!((s - exact).abs() < 0.03, "{s} against {exact}");
    }
}
