//! Lights to their GPU form: emissive triangles and spheres become area lights, point, spot and
//! directional lights and the environment follow, and an alias table (Vose 1991) picks among
//! them with probability proportional to power (pbrt's power light sampler). The environment
//! map gets a piecewise-constant 2D distribution of luminance · sinθ for importance sampling.

use std::f64::consts::PI;

use glam::{DVec3, Vec3};

use crate::layout::{light, GpuAlias, GpuLight};
use crate::scene::Texture;

/// Luminance of linear Rec.709 RGB.
pub fn luminance(c: Vec3) -> f64 {
    (0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z) as f64
}

/// A light before its pick probability is known.
pub struct LightBuilder {
    pub lights: Vec<GpuLight>,
    pub power: Vec<f64>,
}

fn v4(v: DVec3, w: f32) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w]
}

fn c4(c: Vec3) -> [f32; 4] {
    [c.x, c.y, c.z, 0.0]
}

impl LightBuilder {
    pub fn new() -> Self {
        LightBuilder {
            lights: Vec::new(),
            power: Vec::new(),
        }
    }

    fn push(&mut self, l: GpuLight, power: f64) -> u32 {
        self.lights.push(l);
        self.power.push(power.max(0.0));
        (self.lights.len() - 1) as u32
    }

    fn blank(kind: u32) -> GpuLight {
        GpuLight {
            kind,
            prim: u32::MAX,
            pick_pdf: 0.0,
            bvh_trail: 0,
            p0: [0.0; 4],
            p1: [0.0; 4],
            p2: [0.0; 4],
            radiance: [0.0; 4],
        }
    }

    /// An emissive triangle (camera-relative vertices) stored at prim slot `prim`.
    pub fn triangle(&mut self, prim: u32, p: [DVec3; 3], radiance: Vec3) -> u32 {
        let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
        let mut l = Self::blank(light::TRIANGLE);
        l.prim = prim;
        l.p0 = v4(p[0], area as f32);
        l.p1 = v4(p[1], 0.0);
        l.p2 = v4(p[2], 0.0);
        l.radiance = c4(radiance);
        self.push(l, luminance(radiance) * area * PI)
    }

    /// An emissive sphere (camera-relative centre).
    pub fn sphere(
        &mut self,
        prim: u32,
        center: DVec3,
        radius: f64,
        flip: bool,
        radiance: Vec3,
    ) -> u32 {
        let mut l = Self::blank(light::SPHERE);
        l.prim = prim;
        l.p0 = v4(center, radius as f32);
        l.p1 = [if flip { 1.0 } else { 0.0 }, 0.0, 0.0, 0.0];
        l.radiance = c4(radiance);
        self.push(l, luminance(radiance) * 4.0 * PI * radius * radius * PI)
    }

    pub fn point(&mut self, position: DVec3, intensity: Vec3) -> u32 {
        let mut l = Self::blank(light::POINT);
        l.p0 = v4(position, 0.0);
        l.radiance = c4(intensity);
        self.push(l, 4.0 * PI * luminance(intensity))
    }

    /// Spot light; angles in degrees.
    pub fn spot(
        &mut self,
        position: DVec3,
        direction: DVec3,
        intensity: Vec3,
        cutoff_deg: f32,
        beam_deg: f32,
    ) -> u32 {
        let cutoff = (cutoff_deg as f64).to_radians();
        let beam = (beam_deg as f64).to_radians().min(cutoff);
        let mut l = Self::blank(light::SPOT);
        l.p0 = v4(position, 0.0);
        l.p1 = v4(direction.normalize(), 0.0);
        l.p2 = [
            cutoff.cos() as f32,
            beam.cos() as f32,
            cutoff as f32,
            beam as f32,
        ];
        l.radiance = c4(intensity);
        // pbrt's estimate: the cone out to the middle of the falloff region.
        let power = 2.0 * PI * (1.0 - (0.5 * (cutoff + beam)).cos()) * luminance(intensity);
        self.push(l, power)
    }

    pub fn directional(&mut self, direction: DVec3, irradiance: Vec3, scene_radius: f64) -> u32 {
        let mut l = Self::blank(light::DIRECTIONAL);
        l.p0 = v4(direction.normalize(), 0.0);
        l.radiance = c4(irradiance);
        self.push(l, PI * scene_radius * scene_radius * luminance(irradiance))
    }

    pub fn env_constant(&mut self, radiance: Vec3, scene_radius: f64) -> u32 {
        let mut l = Self::blank(light::ENV_CONSTANT);
        l.radiance = c4(radiance);
        self.push(
            l,
            4.0 * PI * PI * scene_radius * scene_radius * luminance(radiance),
        )
    }

    pub fn env_map(&mut self, scale: f32, mean_luminance: f64, scene_radius: f64) -> u32 {
        let mut l = Self::blank(light::ENV_MAP);
        l.radiance = [scale, scale, scale, 0.0];
        self.push(
            l,
            4.0 * PI * PI * scene_radius * scene_radius * mean_luminance * scale as f64,
        )
    }

    /// Sets pick probabilities ∝ power and builds the alias table. Lights of zero power are
    /// never picked (a scene where all are zero picks uniformly).
    pub fn finish(mut self) -> (Vec<GpuLight>, Vec<GpuAlias>) {
        let n = self.lights.len();
        if n == 0 {
            return (self.lights, Vec::new());
        }
        let total: f64 = self.power.iter().sum();
        let pmf: Vec<f64> = if total > 0.0 && total.is_finite() {
            self.power.iter().map(|p| p / total).collect()
        } else {
            vec![1.0 / n as f64; n]
        };
        for (l, p) in self.lights.iter_mut().zip(&pmf) {
            l.pick_pdf = *p as f32;
        }
        (self.lights, alias_table(&pmf))
    }
}

impl Default for LightBuilder {
    fn default() -> Self {
        Self::new()
    }
}

/// Vose's alias method: entry i keeps i with probability `prob`, else returns `alias`.
pub fn alias_table(pmf: &[f64]) -> Vec<GpuAlias> {
    let n = pmf.len();
    let mut scaled: Vec<f64> = pmf.iter().map(|p| p * n as f64).collect();
    let mut table = vec![
        GpuAlias {
            prob: 1.0,
            alias: 0
        };
        n
    ];
    let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
    while let Some(&l) = large.last() {
        let Some(s) = small.pop() else { break };
        table[s] = GpuAlias {
            prob: scaled[s] as f32,
            alias: l as u32,
        };
        scaled[l] -= 1.0 - scaled[s];
        if scaled[l] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    for i in large.into_iter().chain(small) {
        table[i] = GpuAlias {
            prob: 1.0,
            alias: i as u32,
        };
    }
    table
}

/// The environment map's sampling distribution (see shaders/common/env.glsl for the layout):
/// marginal CDF over rows, conditional CDFs per row, and the pdf per texel in uv space.
/// Returns (buffer, mean luminance).
pub fn env_distribution(tex: &Texture) -> (Vec<f32>, f64) {
    let (w, h) = (tex.width as usize, tex.height as usize);
    let mut f = vec![0f64; w * h];
    let mut mean = 0.0;
    for y in 0..h {
        let sin_theta = (PI * (y as f64 + 0.5) / h as f64).sin();
        for x in 0..w {
            let t = tex.texels[y * w + x];
            let lum = luminance(Vec3::new(t[0], t[1], t[2])).max(0.0);
            let lum = if lum.is_finite() { lum } else { 0.0 };
            mean += lum * sin_theta;
            f[y * w + x] = lum * sin_theta;
        }
    }
    // Mean radiance over the sphere: Σ L sinθ ΔθΔφ / 4π with Δθ = π/h, Δφ = 2π/w.
    let mean_lum = mean * (PI / h as f64) * (2.0 * PI / w as f64) / (4.0 * PI);
    let mut out = vec![0f32; (h + 1) + h * (w + 1) + w * h];
    let mut row_sums = vec![0f64; h];
    for y in 0..h {
        let base = h + 1 + y * (w + 1);
        let mut acc = 0.0;
        for x in 0..w {
            acc += f[y * w + x];
        }
        row_sums[y] = acc;
        let mut run = 0.0;
        for x in 0..w {
            out[base + x] = if acc > 0.0 {
                (run / acc) as f32
            } else {
                x as f32 / w as f32
            };
            run += f[y * w + x];
        }
        out[base + w] = 1.0;
    }
    let total: f64 = row_sums.iter().sum();
    let mut run = 0.0;
    for y in 0..h {
        out[y] = if total > 0.0 {
            (run / total) as f32
        } else {
            y as f32 / h as f32
        };
        run += row_sums[y];
    }
    out[h] = 1.0;
    // pdf over uv ∈ [0,1]²: f / (∫f du dv) with ∫ = total / (w h).
    let pdf_base = h + 1 + h * (w + 1);
    for i in 0..w * h {
        out[pdf_base + i] = if total > 0.0 {
            (f[i] * (w * h) as f64 / total) as f32
        } else {
            1.0
        };
    }
    (out, mean_lum)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alias_table_reproduces_the_pmf() {
        let pmf = [0.1, 0.5, 0.0, 0.25, 0.15];
        let t = alias_table(&pmf);
        let n = pmf.len() as f64;
        let mut got = vec![0f64; pmf.len()];
        for (i, e) in t.iter().enumerate() {
            got[i] += e.prob as f64 / n;
            got[e.alias as usize] += (1.0 - e.prob as f64) / n;
        }
        for (g, p) in got.iter().zip(pmf) {
            assert!((g - p).abs() < 1e-6, "{got:?}");
        }
    }

    #[test]
    fn env_distribution_pdf_integrates_to_one() {
        let (w, h) = (8u32, 4u32);
        let texels = (0..w * h)
            .map(|i| [1.0 + (i % 5) as f32, 1.0, 0.5, 1.0])
            .collect();
        let tex = Texture {
            source: "t".into(),
            width: w,
            height: h,
            texels,
            scale: glam::Vec2::ONE,
        };
        let (d, _) = env_distribution(&tex);
        let base = (h + 1 + h * (w + 1)) as usize;
        let integral: f64 = d[base..].iter().map(|&p| p as f64).sum::<f64>() / (w * h) as f64;
        assert!((integral - 1.0).abs() < 1e-5, "{integral}");
        assert_eq!(d[h as usize], 1.0);
    }
}
