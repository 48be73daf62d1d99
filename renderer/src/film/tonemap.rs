//! Display encoding: exposure, tone curve, clamp, sRGB OETF, 8-bit quantisation.
//!
//! The pipeline and curves are documented on [`tonemap_srgb8`]; the GPU tonemap kernel must
//! match it channel for channel.

use crate::scene::Tonemap;

use super::Image;

/// Exposed values are clamped to `[0, MAX_EXPOSED]` before the curve (see [`tonemap_srgb8`]).
pub const MAX_EXPOSED: f32 = 1.0e4;

/// The tone curve for one channel of an exposed, non-negative value; the result may still need
/// clamping to `[0, 1]` (`Clamp` returns `x` itself, `Aces` slightly exceeds 1 above x ≈ 7.2).
pub fn tonemap_channel(x: f32, tonemap: Tonemap) -> f32 {
    match tonemap {
        Tonemap::Clamp => x,
        Tonemap::Reinhard => x / (1.0 + x),
        Tonemap::Aces => {
            // Narkowicz 2015 coefficients.
            const A: f32 = 2.51;
            const B: f32 = 0.03;
            const C: f32 = 2.43;
            const D: f32 = 0.59;
            const E: f32 = 0.14;
            (x * (A * x + B)) / (x * (C * x + D) + E)
        }
    }
}

/// The sRGB opto-electronic transfer function (linear `[0, 1]` → encoded `[0, 1]`).
pub fn srgb_oetf(linear: f32) -> f32 {
    if linear <= 0.003_130_8 {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// One pixel through exposure `scale = 2^EV`, curve, clamp, OETF and rounding.
pub fn tonemap_pixel(rgb: [f32; 3], scale: f32, tonemap: Tonemap) -> [u8; 3] {
    if !rgb.iter().all(|c| c.is_finite()) {
        return [0; 3];
    }
    rgb.map(|c| {
        let exposed = c * scale;
        // A NaN product (NaN exposure, or 0 · Inf scale) is black too.
        let x = if exposed.is_nan() {
            0.0
        } else {
            exposed.clamp(0.0, MAX_EXPOSED)
        };
        let y = tonemap_channel(x, tonemap).clamp(0.0, 1.0);
        (srgb_oetf(y) * 255.0).round() as u8
    })
}

/// The image as tightly packed RGB8, row 0 first (`3 · pixels.len()` bytes).
///
/// 1. A pixel with any NaN or ±Inf channel encodes as black (0, 0, 0). Then, per channel `x`:
/// 2. `x ← clamp(x · 2^exposure_ev, 0, 1e4)` (a NaN product is 0): negatives become 0, and the upper bound keeps the
///    rational curves below free of Inf/Inf (every curve is ≥ 0.9999 there, which still rounds
///    to 255);
/// 3. `y ← curve(x)`, see [`tonemap_channel`];
/// 4. `y ← clamp(y, 0, 1)`, sRGB OETF ([`srgb_oetf`], IEC 61966-2-1), then `round(255 · y)`.
///
/// Curves, all per channel (no luminance coupling, so hue shifts at saturation are expected):
/// - `Clamp`: `y = x` (the clamp of step 4 does the work).
/// - `Reinhard`: `y = x / (1 + x)` (Reinhard et al. 2002, eq. 3, without the white point).
/// - `Aces`: Narkowicz 2015, "ACES Filmic Tone Mapping Curve":
///   `y = x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)`, applied to the exposed value as it is,
///   **without** the 0.6 pre-scale of the blog post; to reproduce that look pass
///   `exposure_ev = log2(0.6) ≈ −0.737`.
pub fn tonemap_srgb8(img: &Image, exposure_ev: f32, tonemap: Tonemap) -> Vec<u8> {
    let scale = exposure_ev.exp2();
    let mut out = Vec::with_capacity(img.pixels.len() * 3);
    for &p in &img.pixels {
        out.extend_from_slice(&tonemap_pixel(p, scale, tonemap));
    }
    out
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The exposed input whose curve value is `y` (bisection in f64; the curves are monotonic).
    pub(crate) fn inverse_curve(y: f64, tonemap: Tonemap) -> f64 {
        let curve = |x: f64| tonemap_channel(x as f32, tonemap) as f64;
        let (mut lo, mut hi) = (0.0f64, 100.0f64);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if curve(mid) < y {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }

    #[test]
    fn srgb_oetf_known_values() {
        let q = |v: f32| (srgb_oetf(v) * 255.0).round() as u8;
        assert_eq!(q(0.0), 0);
        assert_eq!(q(1.0), 255);
        assert_eq!(q(0.5), 188);
        assert_eq!(q(0.18), 118);
        assert_eq!(q(0.002), 7); // linear segment: 12.92 · 0.002 · 255 = 6.59
    }

    #[test]
    fn curves_known_values() {
        let px = |x: f32, ev: f32, t| tonemap_pixel([x; 3], ev.exp2(), t)[0];
        // Reinhard: 1 → 0.5; 0.5 at +1 EV → 0.5; 0.18 → 0.1525 → 108.87.
        assert_eq!(px(1.0, 0.0, Tonemap::Reinhard), 188);
        assert_eq!(px(0.5, 1.0, Tonemap::Reinhard), 188);
        assert_eq!(px(0.18, 0.0, Tonemap::Reinhard), 109);
        assert_eq!(px(1e30, 0.0, Tonemap::Reinhard), 255);
        // ACES without pre-scale: 1 → 2.54/3.16 = 0.8038 → 231.6; 0.18 → 141.1; 0.5 → 205.9.
        assert_eq!(px(1.0, 0.0, Tonemap::Aces), 232);
        assert_eq!(px(0.18, 0.0, Tonemap::Aces), 141);
        assert_eq!(px(1.0, -1.0, Tonemap::Aces), 206);
        assert_eq!(px(10.0, 0.0, Tonemap::Aces), 255);
        assert_eq!(px(1e30, 0.0, Tonemap::Aces), 255);
        // Clamp.
        assert_eq!(px(0.36, -1.0, Tonemap::Clamp), 118);
        assert_eq!(px(1e30, 0.0, Tonemap::Clamp), 255);
    }

    #[test]
    fn nan_inf_negative_are_black() {
        for t in [Tonemap::Clamp, Tonemap::Reinhard, Tonemap::Aces] {
            assert_eq!(tonemap_pixel([f32::NAN, 1.0, 1.0], 1.0, t), [0; 3]);
            assert_eq!(tonemap_pixel([1.0, f32::INFINITY, 1.0], 1.0, t), [0; 3]);
            assert_eq!(tonemap_pixel([1.0, 1.0, f32::NEG_INFINITY], 1.0, t), [0; 3]);
            assert_eq!(tonemap_pixel([-0.5, -1.0, -1e30], 1.0, t), [0; 3]);
            assert_eq!(tonemap_pixel([0.5; 3], f32::NAN, t), [0; 3]);
        }
    }

    #[test]
    fn srgb8_layout_and_exposure() {
        let img = Image::from_fn(2, 1, |x, _| [x as f32 * 0.25, 0.0, 1.0]);
        let bytes = tonemap_srgb8(&img, 1.0, Tonemap::Clamp);
        assert_eq!(bytes, vec![0, 0, 255, 188, 0, 255]);
    }

    #[test]
    fn inverse_curve_hits_targets() {
        for t in [Tonemap::Clamp, Tonemap::Reinhard, Tonemap::Aces] {
            for y in [0.18, 0.5] {
                let x = inverse_curve(y, t);
                assert!((tonemap_channel(x as f32, t) as f64 - y).abs() < 1e-6);
            }
        }
    }
}
