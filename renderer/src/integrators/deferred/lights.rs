//! The light manager of `deferred`: turns the compiled scene's lights into the records the cull
//! and shade stages read (`DeferredLight`, mirrored as `DLight` in shaders/deferred/common.glsl),
//! on the host, once per session.
//!
//! - **Influence radius.** Point and spot lights fall off as I/d² (physical inverse square, no
//!   windowing), so a light's irradiance at a surface facing it drops below `cutoff` beyond
//!   r = sqrt(I_max / cutoff), I_max being its largest RGB intensity component (a spot's peak,
//!   an area emitter's on-axis intensity). Shading ignores a light beyond r, so every light it
//!   skips contributes at most `cutoff` irradiance, i.e. at most f_max·cutoff radiance (≤
//!   cutoff/π·albedo on a diffuse surface). `cutoff = 0` makes every radius unbounded.
//! - **Area emitters** become point-like lights, exact in the far field: an emissive triangle
//!   of radiance L and area A is a *cosine* light at its centroid with I(θ) = L·A·cos θ on its
//!   front side (θ from its normal; Lambertian emitters radiate I ∝ cos θ); an emissive sphere
//!   of radius R is an isotropic point at its centre with I = L·πR² (exact outside the sphere
//!   for a receiver that sees the whole sphere); shadow rays towards it stop at its surface.
//!   Spheres with inward normals emit only inside and are left out. Near an emitter (distance
//!   comparable to its size) the approximation over- or underestimates; see docs/deferred.md.
//! - **Directional lights** are always shaded (no radius); the **environment** is shaded as an
//!   ambient term by the shade stage (one BSDF sample per pixel sample).
//! - **Merging** (`merge_radius` > 0, off by default): isotropic point lights (including those
//!   made from spheres) whose own influence radius is below `merge_radius` are grouped by a
//!   uniform grid of cells `merge_radius` wide; every cell holding two or more becomes one point
//!   light with the summed RGB intensity at the lights' power-weighted centroid (weights:
//!   luminance of I), with the influence radius of the sum. Individually each of these lights is
//!   negligible beyond `merge_radius`; together they may not be, and the merged light keeps their
//!   far-field sum (exact to first order in cell size / distance). Near the cell (closer than a
//!   few cell widths) the merged light misplaces them; spots and area emitters never merge.

use std::collections::HashMap;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::compile::luminance;
use crate::layout::{light, GpuLight};

/// Light kinds of [`DeferredLight`] (DL_* in shaders/deferred/common.glsl).
pub mod kind {
    pub const POINT: u32 = 0;
    pub const SPOT: u32 = 1;
    /// A small planar emitter: I(θ) = I0·cos θ on its front side.
    pub const COSINE: u32 = 2;
    pub const DIRECTIONAL: u32 = 3;
}

/// Influence radius standing for "unbounded" (finite so the GPU tests never see inf·0).
pub const UNBOUNDED: f32 = f32::MAX;

/// One light record (64 bytes). See `DLight` in shaders/deferred/common.glsl for the fields.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct DeferredLight {
    /// Camera-relative position, influence radius.
    pub pos_radius: [f32; 4],
    /// RGB intensity (W/sr) or irradiance (directional); w: kind as f32 bits.
    pub intensity: [f32; 4],
    /// Axis (spot, cosine) or travel direction (directional); w: cos cutoff (spot), 0 (cosine),
    /// −1 (point, directional).
    pub axis: [f32; 4],
    /// (cos beam, cutoff rad, beam rad, shadow-ray stop distance).
    pub spot: [f32; 4],
}

impl DeferredLight {
    pub fn kind(&self) -> u32 {
        self.intensity[3].to_bits()
    }
    fn rgb(&self) -> Vec3 {
        Vec3::new(self.intensity[0], self.intensity[1], self.intensity[2])
    }
    fn pos(&self) -> Vec3 {
        Vec3::new(self.pos_radius[0], self.pos_radius[1], self.pos_radius[2])
    }
}

/// The light manager's settings (from `DeferredOptions`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ManagerOptions {
    /// Irradiance below which a light is ignored (≥ 0; 0: unbounded radii).
    pub cutoff: f32,
    /// Cell width for merging small point lights; 0: no merging.
    pub merge_radius: f32,
}

/// What the light manager did (reported in `details()`).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct ManagerStats {
    /// Lights of the compiled scene, by kind.
    pub scene_point: usize,
    pub scene_spot: usize,
    pub scene_triangle: usize,
    pub scene_sphere: usize,
    pub scene_directional: usize,
    pub scene_environment: usize,
    /// Lights left out: zero intensity, or spheres emitting inwards.
    pub skipped: usize,
    /// Point lights merged away, and the merged lights that replaced them.
    pub merged_from: usize,
    pub merged_into: usize,
    /// Lights the cull stage tests per tile, and the directional lights shaded everywhere.
    pub culled: usize,
    pub directional: usize,
    /// Largest and mean finite influence radius of the culled lights (0 when none is finite).
    pub max_radius: f32,
    pub mean_radius: f32,
}

/// The manager's output: `lights[..n_cull]` are culled per tile, `lights[n_cull..]` are the
/// directional lights.
#[derive(Debug, Clone, Default)]
pub struct LightSet {
    pub lights: Vec<DeferredLight>,
    pub n_cull: u32,
    pub n_dir: u32,
    pub stats: ManagerStats,
}

/// Influence radius of a light of largest intensity component `i_max`: sqrt(i_max / cutoff).
pub fn influence_radius(i_max: f32, cutoff: f32) -> f32 {
    if cutoff > 0.0 {
        let r = (i_max.max(0.0) as f64 / cutoff as f64).sqrt();
        if r.is_finite() && r < UNBOUNDED as f64 {
            return r as f32;
        }
    }
    UNBOUNDED
}

fn record(kind: u32, pos: Vec3, intensity: Vec3, cutoff: f32) -> DeferredLight {
    DeferredLight {
        pos_radius: [
            pos.x,
            pos.y,
            pos.z,
            influence_radius(intensity.max_element(), cutoff),
        ],
        intensity: [intensity.x, intensity.y, intensity.z, f32::from_bits(kind)],
        axis: [0.0, 0.0, 0.0, -1.0],
        spot: [0.0; 4],
    }
}

fn v3(a: [f32; 4]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

/// Builds the light set of a compiled scene.
pub fn manage(scene_lights: &[GpuLight], o: &ManagerOptions) -> LightSet {
    let mut st = ManagerStats::default();
    let mut cull: Vec<DeferredLight> = Vec::new();
    let mut dirs: Vec<DeferredLight> = Vec::new();
    // Step 1: one record per light, area emitters made point-like.
    for l in scene_lights {
        let rgb = v3(l.radiance);
        match l.kind {
            light::POINT => {
                st.scene_point += 1;
                if rgb.max_element() <= 0.0 {
                    st.skipped += 1;
                    continue;
                }
                cull.push(record(kind::POINT, v3(l.p0), rgb, o.cutoff));
            }
            light::SPOT => {
                st.scene_spot += 1;
                if rgb.max_element() <= 0.0 {
                    st.skipped += 1;
                    continue;
                }
                let mut r = record(kind::SPOT, v3(l.p0), rgb, o.cutoff);
                let axis = v3(l.p1).normalize_or_zero();
                r.axis = [axis.x, axis.y, axis.z, l.p2[0]];
                r.spot = [l.p2[1], l.p2[2], l.p2[3], 0.0];
                cull.push(r);
            }
            light::TRIANGLE => {
                st.scene_triangle += 1;
                let (p0, p1, p2) = (v3(l.p0), v3(l.p1), v3(l.p2));
                // The area that exists: an alpha mask's holes do not shine.
                let area = l.p0[3] * (1.0 - l.p2[3]);
                let n = (p1 - p0).cross(p2 - p0).normalize_or_zero();
                let i0 = rgb * area;
                if i0.max_element() <= 0.0 || n == Vec3::ZERO {
                    st.skipped += 1;
                    continue;
                }
                let mut r = record(kind::COSINE, (p0 + p1 + p2) / 3.0, i0, o.cutoff);
                r.axis = [n.x, n.y, n.z, 0.0];
                cull.push(r);
            }
            light::SPHERE => {
                st.scene_sphere += 1;
                let radius = l.p0[3];
                let flipped = l.p1[0] > 0.5;
                let i = rgb * (std::f32::consts::PI * radius * radius * (1.0 - l.p2[3]));
                if flipped || i.max_element() <= 0.0 {
                    st.skipped += 1;
                    continue;
                }
                let mut r = record(kind::POINT, v3(l.p0), i, o.cutoff);
                r.spot[3] = radius;
                cull.push(r);
            }
            light::DIRECTIONAL => {
                st.scene_directional += 1;
                if rgb.max_element() <= 0.0 {
                    st.skipped += 1;
                    continue;
                }
                let d = v3(l.p0).normalize_or_zero();
                let mut r = record(kind::DIRECTIONAL, Vec3::ZERO, rgb, 0.0);
                r.axis = [d.x, d.y, d.z, -1.0];
                dirs.push(r);
            }
            _ => st.scene_environment += 1,
        }
    }
    // Step 2: merge small point lights cell by cell.
    if o.merge_radius > 0.0 {
        cull = merge_small(cull, o, &mut st);
    }
    // Step 3: statistics and the final order (culled lights, then directional ones).
    let finite: Vec<f32> = cull
        .iter()
        .map(|l| l.pos_radius[3])
        .filter(|&r| r < UNBOUNDED)
        .collect();
    st.max_radius = finite.iter().cloned().fold(0.0, f32::max);
    st.mean_radius = if finite.is_empty() {
        0.0
    } else {
        finite.iter().sum::<f32>() / finite.len() as f32
    };
    st.culled = cull.len();
    st.directional = dirs.len();
    let n_cull = cull.len() as u32;
    let n_dir = dirs.len() as u32;
    cull.extend(dirs);
    LightSet {
        lights: cull,
        n_cull,
        n_dir,
        stats: st,
    }
}

/// Merges isotropic point lights of influence radius below `merge_radius` that share a grid
/// cell into one light per cell (see the module documentation). Order: the lights that stay,
/// in their order, then the merged ones by first member.
fn merge_small(
    lights: Vec<DeferredLight>,
    o: &ManagerOptions,
    st: &mut ManagerStats,
) -> Vec<DeferredLight> {
    let cell = o.merge_radius;
    let small = |l: &DeferredLight| {
        l.kind() == kind::POINT && l.spot[3] == 0.0 && l.pos_radius[3] < o.merge_radius
    };
    let key = |p: Vec3| {
        let c = (p / cell).floor();
        (c.x as i64, c.y as i64, c.z as i64)
    };
    let mut groups: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
    let mut order: Vec<(i64, i64, i64)> = Vec::new();
    for (i, l) in lights.iter().enumerate() {
        if small(l) {
            let k = key(l.pos());
            let g = groups.entry(k).or_default();
            if g.is_empty() {
                order.push(k);
            }
            g.push(i);
        }
    }
    let mut merged_away = vec![false; lights.len()];
    let mut merged = Vec::new();
    for k in order {
        let members = &groups[&k];
        if members.len() < 2 {
            continue;
        }
        // Summed intensity at the power-weighted centroid.
        let (mut sum, mut wsum, mut centroid) = (Vec3::ZERO, 0.0f64, glam::DVec3::ZERO);
        for &i in members {
            let l = &lights[i];
            let w = luminance(l.rgb()).max(1e-30);
            sum += l.rgb();
            wsum += w;
            centroid += l.pos().as_dvec3() * w;
            merged_away[i] = true;
        }
        let c = (centroid / wsum).as_vec3();
        merged.push(record(kind::POINT, c, sum, o.cutoff));
        st.merged_from += members.len();
        st.merged_into += 1;
    }
    let mut out: Vec<DeferredLight> = lights
        .into_iter()
        .zip(merged_away)
        .filter(|(_, gone)| !gone)
        .map(|(l, _)| l)
        .collect();
    out.extend(merged);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blank(kind: u32) -> GpuLight {
        GpuLight {
            kind,
            prim: u32::MAX,
            pick_pdf: 1.0,
            bvh_trail: 0,
            p0: [0.0; 4],
            p1: [0.0; 4],
            p2: [0.0; 4],
            radiance: [0.0; 4],
        }
    }

    fn point(p: [f32; 3], i: f32) -> GpuLight {
        let mut l = blank(light::POINT);
        l.p0 = [p[0], p[1], p[2], 0.0];
        l.radiance = [i, i, i, 0.0];
        l
    }

    #[test]
    fn radius_is_where_irradiance_reaches_the_cutoff() {
        let r = influence_radius(100.0, 0.01);
        assert!((r - 100.0).abs() < 1e-3, "{r}");
        // At the radius, I/r² equals the cutoff.
        assert!((100.0 / (r * r) - 0.01).abs() < 1e-6);
        assert_eq!(influence_radius(1.0, 0.0), UNBOUNDED);
        let set = manage(
            &[point([1.0, 2.0, 3.0], 4.0)],
            &ManagerOptions {
                cutoff: 1.0,
                merge_radius: 0.0,
            },
        );
        assert_eq!(set.n_cull, 1);
        assert_eq!(set.lights[0].pos_radius, [1.0, 2.0, 3.0, 2.0]);
    }

    #[test]
    fn area_emitters_become_point_like_lights() {
        // A 1×1 quad half (triangle of area 0.5) facing +y with radiance 2: I0 = L·A = 1.
        let mut t = blank(light::TRIANGLE);
        t.p0 = [0.0, 0.0, 0.0, 0.5];
        t.p1 = [0.0, 0.0, 1.0, 0.0];
        t.p2 = [1.0, 0.0, 0.0, 0.0];
        t.radiance = [2.0, 2.0, 2.0, 0.0];
        let mut s = blank(light::SPHERE);
        s.p0 = [0.0, 5.0, 0.0, 0.5];
        s.radiance = [1.0, 1.0, 1.0, 0.0];
        let mut flipped = s;
        flipped.p1[0] = 1.0;
        let set = manage(
            &[t, s, flipped],
            &ManagerOptions {
                cutoff: 0.0,
                merge_radius: 0.0,
            },
        );
        assert_eq!(set.n_cull, 2);
        assert_eq!(set.stats.skipped, 1);
        let tri = &set.lights[0];
        assert_eq!(tri.kind(), kind::COSINE);
        assert_eq!(&tri.intensity[..3], &[1.0, 1.0, 1.0]);
        assert_eq!(tri.axis, [0.0, 1.0, 0.0, 0.0]);
        let sph = &set.lights[1];
        assert_eq!(sph.kind(), kind::POINT);
        assert!((sph.intensity[0] - std::f32::consts::PI * 0.25).abs() < 1e-6);
        assert_eq!(sph.spot[3], 0.5);
    }

    #[test]
    fn merging_conserves_intensity_at_the_power_weighted_centroid() {
        let lights = [
            point([0.1, 0.1, 0.1], 1.0),
            point([0.3, 0.1, 0.1], 3.0),
            point([5.5, 0.1, 0.1], 1.0), // alone in its cell: kept
            point([0.2, 0.2, 0.2], 1e6), // too strong to merge: kept
        ];
        let o = ManagerOptions {
            cutoff: 100.0,
            merge_radius: 1.0,
        };
        let set = manage(&lights, &o);
        assert_eq!(set.stats.merged_from, 2);
        assert_eq!(set.stats.merged_into, 1);
        assert_eq!(set.n_cull, 3);
        let m = set.lights[2];
        assert_eq!(m.intensity[0], 4.0);
        assert!((m.pos_radius[0] - 0.25).abs() < 1e-6, "{m:?}");
        assert!((m.pos_radius[3] - 0.2).abs() < 1e-6);
    }
}
