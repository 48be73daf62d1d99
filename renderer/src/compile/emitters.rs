//! Compile step 5: the light table. Emissive primitives (in BVH order, so a primitive's slot
//! names its light), then point, spot and directional lights, then the environment; and which
//! textures are environment maps (their rows clamp instead of wrapping).

use glam::{DVec3, Vec2, Vec3};

use super::light_bvh::LightBvh;
use super::lights::{self, LightBuilder};
use super::mask_coverage;
use super::prims::Shape;
use crate::layout::*;
use crate::scene::{Environment, Light, Scene};

/// The scene's lights in GPU form.
pub(super) struct Emitters {
    pub lights: Vec<GpuLight>,
    pub alias: Vec<GpuAlias>,
    /// The light BVH's nodes (`render.light_sampler: "bvh"`; empty with the power sampler), its
    /// node and infinite-light counts.
    pub light_bvh: Vec<GpuLightNode>,
    pub light_counts: [u32; 2],
    /// `GpuGlobals::env`: light index, texture, width, height.
    pub env: [u32; 4],
    /// `GpuGlobals::env_params`: scale, cos and sin of the y rotation; the light BVH's
    /// probability of picking an infinite light.
    pub env_params: [f32; 4],
    pub env_dist: Vec<f32>,
    /// Per texture: true where it is the environment map.
    pub clamp_rows: Vec<bool>,
}

/// Builds the light table; marks each emissive primitive of `sorted` (BVH order, `order[slot]` its
/// input index into `shapes`; `tri_shading` their normals and uvs) with its light index.
/// `radius`: the scene's bounding sphere.
pub(super) fn gather(
    scene: &Scene,
    order: &[u32],
    sorted: &mut [GpuPrim],
    shapes: &[Shape],
    tri_shading: &[GpuTriShading],
    radius: f64,
) -> Emitters {
    let origin = scene.camera.position;
    let mut lb = LightBuilder::new();
    emissive_prims(scene, order, sorted, shapes, tri_shading, &mut lb);
    for l in &scene.lights {
        delta_light(l, origin, radius, &mut lb);
    }
    let mut out = Emitters {
        lights: Vec::new(),
        alias: Vec::new(),
        light_bvh: Vec::new(),
        light_counts: [0, 0],
        env: [NONE, NONE, 0, 0],
        env_params: [1.0, 1.0, 0.0, 0.0],
        env_dist: Vec::new(),
        clamp_rows: vec![false; scene.textures.len()],
    };
    environment(scene, radius, &mut lb, &mut out);
    // The light BVH, when asked for, over the lights before their pick probabilities are set.
    let tree = (scene.render.light_sampler.as_deref() == Some("bvh") && !lb.lights.is_empty())
        .then(|| LightBvh::build(&lb.lights, &lb.power));
    (out.lights, out.alias) = lb.finish();
    if let Some(t) = tree {
        for (l, trail) in out.lights.iter_mut().zip(&t.trails) {
            l.bvh_trail = trail.map_or(0, |(_, bits)| bits);
        }
        out.light_counts = [t.nodes.len() as u32, t.infinite.len() as u32];
        out.env_params[3] = t.p_infinite() as f32;
        out.light_bvh = t.gpu_nodes();
    }
    out
}

/// The least share of its power a masked emitter is picked by (`emissive_prims`).
const MIN_PICK_SHARE: f32 = 1.0 / 256.0;

/// Every primitive whose material emits becomes an area light; an alpha-masked one records the
/// share of it that its mask cuts away (`GpuLight::p2.w`, for `deferred`) and is picked by the
/// power of what its mask keeps.
fn emissive_prims(
    scene: &Scene,
    order: &[u32],
    sorted: &mut [GpuPrim],
    shapes: &[Shape],
    tri_shading: &[GpuTriShading],
    lb: &mut LightBuilder,
) {
    let emission: Vec<Vec3> = scene.materials.iter().map(|m| m.emission).collect();
    let emits = |bits: u32| -> Option<Vec3> {
        let e = emission
            .get((bits & PRIM_MATERIAL_MASK) as usize)
            .copied()
            .unwrap_or(Vec3::ZERO);
        (e.max_element() > 0.0).then_some(e)
    };
    // Step 1: the kept share of every masked emitter, in parallel (SIDE² mask lookups each).
    let kept: Vec<f32> = {
        use rayon::prelude::*;
        let sorted = &*sorted;
        order
            .par_iter()
            .enumerate()
            .map(|(slot, &orig)| {
                let bits = sorted[slot].a[3].to_bits();
                if bits & PRIM_ALPHA == 0 || emits(bits).is_none() {
                    return 1.0;
                }
                mask_kept(
                    scene,
                    bits,
                    &shapes[orig as usize],
                    tri_shading.get(sorted[slot].c[3].to_bits() as usize),
                )
            })
            .collect()
    };
    // Step 2: the lights, in slot order.
    for (slot, &orig) in order.iter().enumerate() {
        let bits = sorted[slot].a[3].to_bits();
        let Some(e) = emits(bits) else { continue };
        let li = match shapes[orig as usize] {
            Shape::Sphere { center, radius } => lb.sphere(
                slot as u32,
                center,
                radius,
                bits & PRIM_FLIP_NORMALS != 0,
                e,
            ),
            Shape::Triangle(p) => lb.triangle(slot as u32, p, e),
        };
        if bits & PRIM_ALPHA != 0 {
            let kept = kept[slot];
            lb.lights[li as usize].p2[3] = 1.0 - kept;
            // Light sampling picks by the power that exists (the pick pdf and the light BVH
            // follow): a sample in a hole is wasted. Never zero, so a sliver the estimate's
            // points miss can still be picked.
            lb.power[li as usize] *= f64::from(kept.max(MIN_PICK_SHARE));
        }
        sorted[slot].b[3] = f32::from_bits(li);
    }
}

/// The share of an alpha-masked primitive (material and flags `bits`, its shading record if a
/// triangle has one) that its mask keeps: 1 where the mask cannot apply (no texture, no uvs).
fn mask_kept(scene: &Scene, bits: u32, shape: &Shape, shading: Option<&GpuTriShading>) -> f32 {
    let mask = scene.materials[(bits & PRIM_MATERIAL_MASK) as usize]
        .alpha_mask
        .and_then(|t| scene.textures.get(t as usize));
    match (shape, mask, shading) {
        (Shape::Sphere { .. }, Some(mask), _) => mask_coverage::sphere_kept(mask),
        (Shape::Triangle(_), Some(mask), Some(s)) => {
            let uv = [
                Vec2::new(s.n0[3], s.uv_v[0]),
                Vec2::new(s.n1[3], s.uv_v[1]),
                Vec2::new(s.n2[3], s.uv_v[2]),
            ];
            mask_coverage::triangle_kept(mask, uv)
        }
        _ => 1.0,
    }
}

/// A point, spot or directional light, positioned relative to `origin`.
fn delta_light(l: &Light, origin: DVec3, radius: f64, lb: &mut LightBuilder) {
    match l {
        Light::Point {
            position,
            intensity,
        } => lb.point(*position - origin, *intensity),
        Light::Spot {
            position,
            direction,
            intensity,
            cutoff_angle,
            beam_width,
        } => lb.spot(
            *position - origin,
            *direction,
            *intensity,
            *cutoff_angle,
            *beam_width,
        ),
        Light::Directional {
            direction,
            irradiance,
        } => lb.directional(*direction, *irradiance, radius),
    };
}

/// A constant or image-based environment, with its sampling distribution.
fn environment(scene: &Scene, radius: f64, lb: &mut LightBuilder, out: &mut Emitters) {
    match &scene.environment {
        Some(Environment::Constant { radiance }) if radiance.max_element() > 0.0 => {
            out.env[0] = lb.env_constant(*radiance, radius);
        }
        Some(Environment::Map {
            texture,
            scale,
            rotate_y,
        }) => {
            if let Some(tex) = scene.textures.get(*texture as usize) {
                let (dist, mean) = lights::env_distribution(tex);
                out.env_dist = dist;
                out.env = [
                    lb.env_map(*scale, mean, radius),
                    *texture,
                    tex.width,
                    tex.height,
                ];
                let a = rotate_y.to_radians();
                out.env_params = [*scale, a.cos(), a.sin(), 0.0];
                out.clamp_rows[*texture as usize] = true;
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    /// A masked lamp is picked by the share of its power that its mask keeps: two equal quad
    /// lamps, one masked to about 61% (tests/import/mitsuba/mask.png), the other whole.
    #[test]
    fn masked_emitters_are_picked_by_the_power_they_keep() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/import/mitsuba");
        let lamp = |x: f32, m: &str| {
            format!(
                r#"{{"type": "quad", "origin": [{x}, 1.5, -1], "edge_u": [2, 0, 0], "edge_v": [0, 0, 2], "material": "{m}"}}"#
            )
        };
        let json = format!(
            r#"{{"version": 1, "camera": {{"position": [0, 0.8, 3], "look_at": [0, 0, 0]}},
            "film": {{"width": 8, "height": 8}},
            "materials": {{
              "whole": {{"type": "diffuse", "reflectance": 0, "emission": [4, 4, 4]}},
              "masked": {{"type": "diffuse", "reflectance": 0, "emission": [4, 4, 4],
                         "alpha_mask": {{"texture": "mask.png", "scale": [2, 2]}}}}}},
            "objects": [{}, {}]}}"#,
            lamp(-3.0, "whole"),
            lamp(1.0, "masked")
        );
        let scene = crate::scene::load_str(&json, Some(&root)).unwrap();
        let c = super::super::compile(&scene, 8, 8).unwrap();
        // Each quad is two triangles; sum the picks of each lamp's pair.
        let (mut masked, mut whole, mut kept) = (0.0f64, 0.0f64, 0.0f64);
        for l in &c.lights {
            if l.p2[3] > 0.0 {
                masked += f64::from(l.pick_pdf);
                kept += f64::from(1.0 - l.p2[3]) / 2.0;
            } else {
                whole += f64::from(l.pick_pdf);
            }
        }
        assert_eq!(c.lights.len(), 4);
        assert!((masked + whole - 1.0).abs() < 1e-6);
        assert!((0.4..0.8).contains(&kept), "kept share {kept}");
        let ratio = masked / whole;
        assert!(
            (ratio / kept - 1.0).abs() < 1e-3,
            "masked / whole pick {ratio:.4}, kept share {kept:.4}"
        );
    }
}
