//! Scene compilation: a loaded `Scene` (f64, world space) becomes the flat, camera-relative f32
//! buffers of `crate::layout`, a BVH, a light table and the feature set its kernels are specialised for.
//!
//! Precision: every position is `world − camera` computed in f64 and only then rounded to f32,
//! so a scene translated by 1e5 units renders exactly like one at the origin.

mod features;
pub mod light_bvh;
mod lights;
mod materials;

use std::path::Path;
use std::time::Duration;

use glam::{DVec3, Vec3};

use crate::accel::grid::Grid;
use crate::accel::{self, AccelError, AccelInfo, AccelOptions, PrimBounds};
use crate::layout::*;
use crate::scene::{Environment, Filter, Light, Scene};
pub use features::{FeatureSet, KernelMode};
pub use lights::{alias_table, luminance};

/// The scene in GPU form, ready to upload.
#[derive(Debug, Clone)]
pub struct CompiledScene {
    pub globals: GpuGlobals,
    pub nodes: Vec<GpuBvhNode>,
    pub prims: Vec<GpuPrim>,
    pub tri_shading: Vec<GpuTriShading>,
    pub materials: Vec<GpuMaterial>,
    pub textures: Vec<GpuTexture>,
    pub texels: Vec<[f32; 4]>,
    pub lights: Vec<GpuLight>,
    pub alias: Vec<GpuAlias>,
    /// The light BVH's nodes (`render.light_sampler: "bvh"`; empty with the power sampler).
    pub light_bvh: Vec<GpuLightNode>,
    pub env_dist: Vec<f32>,
    pub features: FeatureSet,
    pub width: u32,
    pub height: u32,
    pub triangle_count: usize,
    pub bvh_depth: usize,
    pub bvh_build_time: Duration,
    /// The uniform grid when `accel` is "grid" (then `nodes` is empty and the kernels are built
    /// with `ACCEL_GRID`).
    pub grid: Option<Grid>,
    /// Which structure was built, how long it took, its size, cache hit or miss.
    pub accel: AccelInfo,
    /// The camera's position in world space (f64): every position above is relative to it.
    pub camera_position: [f64; 3],
    /// A hash of the world-space geometry (positions, indices, per-triangle materials, spheres),
    /// the same wherever the camera is: caches of structures built from the geometry key on it
    /// and place them with `camera_position`.
    pub geometry_hash: u64,
}

/// [`CompiledScene::geometry_hash`] of a scene.
fn world_geometry_hash(scene: &Scene) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for m in &scene.meshes {
        let bits: Vec<[u64; 3]> = m
            .positions
            .iter()
            .map(|p| p.to_array().map(f64::to_bits))
            .collect();
        (bits, &m.indices, &m.materials).hash(&mut h);
    }
    for s in &scene.spheres {
        (
            s.center.to_array().map(f64::to_bits),
            s.radius.to_bits(),
            s.flip_normals,
            s.material,
        )
            .hash(&mut h);
    }
    h.finish()
}

/// Options of [`compile_with`].
#[derive(Debug, Clone, Copy, Default)]
pub struct CompileOptions<'a> {
    /// BVH (default) or uniform grid, and the grid's resolution.
    pub accel: AccelOptions,
    /// Directory of the acceleration-structure cache (None: always build).
    pub cache: Option<&'a Path>,
}

#[derive(Debug, thiserror::Error)]
pub enum CompileError {
    #[error(transparent)]
    Accel(#[from] AccelError),
    #[error("scene has {0} primitives; at most {max} are supported", max = PRIM_MATERIAL_MASK)]
    TooManyPrims(usize),
}

/// A primitive's exact (f64, camera-relative) geometry.
#[derive(Clone, Copy)]
enum Shape {
    Triangle([DVec3; 3]),
    Sphere { center: DVec3, radius: f64 },
}

fn f3(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// Compiles `scene` for a film of `width` × `height` (the job may override the scene's film),
/// with a BVH and no cache.
pub fn compile(scene: &Scene, width: u32, height: u32) -> Result<CompiledScene, CompileError> {
    compile_with(scene, width, height, &CompileOptions::default())
}

/// [`compile`] with a choice of acceleration structure and a cache of built structures.
pub fn compile_with(
    scene: &Scene,
    width: u32,
    height: u32,
    options: &CompileOptions<'_>,
) -> Result<CompiledScene, CompileError> {
    let origin = scene.camera.position;
    let rel = |p: DVec3| p - origin;
    let features = FeatureSet::detect(scene);

    // Step 1: materials and textures.
    let materials: Vec<GpuMaterial> = scene
        .materials
        .iter()
        .map(materials::gpu_material)
        .collect();
    let alpha_material: Vec<bool> = scene
        .materials
        .iter()
        .map(|m| m.alpha_mask.is_some())
        .collect();
    let emission: Vec<Vec3> = scene.materials.iter().map(|m| m.emission).collect();

    // Step 2: primitives in input order, with bounds, camera-relative.
    let mut prims: Vec<GpuPrim> = Vec::new();
    let mut bounds: Vec<PrimBounds> = Vec::new();
    let mut tri_shading: Vec<GpuTriShading> = Vec::new();
    // Camera-relative f64 geometry of each primitive, for exact light areas and centres.
    let mut shapes: Vec<Shape> = Vec::new();
    let mut triangle_count = 0usize;
    for mesh in &scene.meshes {
        let shaded = mesh.normals.is_some() || mesh.uvs.is_some();
        for (t, idx) in mesh.indices.iter().enumerate() {
            let p = idx.map(|i| rel(mesh.positions[i as usize]));
            let m = mesh.materials.get(t).copied().unwrap_or(0);
            let mut flags = m & PRIM_MATERIAL_MASK;
            if alpha_material.get(m as usize).copied().unwrap_or(false) {
                flags |= PRIM_ALPHA;
            }
            let shading = if shaded {
                let n = |k: usize| {
                    mesh.normals
                        .as_ref()
                        .map(|ns| ns[idx[k] as usize])
                        .unwrap_or(Vec3::ZERO)
                };
                let uv = |k: usize| {
                    mesh.uvs
                        .as_ref()
                        .map(|u| u[idx[k] as usize])
                        .unwrap_or(glam::Vec2::ZERO)
                };
                tri_shading.push(GpuTriShading {
                    n0: [n(0).x, n(0).y, n(0).z, uv(0).x],
                    n1: [n(1).x, n(1).y, n(1).z, uv(1).x],
                    n2: [n(2).x, n(2).y, n(2).z, uv(2).x],
                    uv_v: [
                        uv(0).y,
                        uv(1).y,
                        uv(2).y,
                        if mesh.normals.is_some() { 1.0 } else { 0.0 },
                    ],
                });
                (tri_shading.len() - 1) as u32
            } else {
                NONE
            };
            let [a, b, c] = p.map(f3);
            prims.push(GpuPrim {
                a: [a[0], a[1], a[2], f32::from_bits(flags)],
                b: [b[0], b[1], b[2], f32::from_bits(NONE)],
                c: [c[0], c[1], c[2], f32::from_bits(shading)],
            });
            let mn = p[0].min(p[1]).min(p[2]);
            let mx = p[0].max(p[1]).max(p[2]);
            bounds.push(PrimBounds {
                min: f3(mn),
                max: f3(mx),
            });
            shapes.push(Shape::Triangle(p));
            triangle_count += 1;
        }
    }
    for s in &scene.spheres {
        let c = rel(s.center);
        let mut flags = PRIM_SPHERE | (s.material & PRIM_MATERIAL_MASK);
        if s.flip_normals {
            flags |= PRIM_FLIP_NORMALS;
        }
        let cf = f3(c);
        prims.push(GpuPrim {
            a: [cf[0], cf[1], cf[2], f32::from_bits(flags)],
            b: [s.radius as f32, 0.0, 0.0, f32::from_bits(NONE)],
            c: [0.0, 0.0, 0.0, f32::from_bits(NONE)],
        });
        // Bounds padded by a few ulps so rounding of centre and radius cannot clip the sphere.
        let r = DVec3::splat(s.radius * (1.0 + 1e-6));
        let pad = c.abs() * 1e-6;
        bounds.push(PrimBounds {
            min: f3(c - r - pad),
            max: f3(c + r + pad),
        });
        shapes.push(Shape::Sphere {
            center: c,
            radius: s.radius,
        });
    }
    if prims.len() > PRIM_MATERIAL_MASK as usize {
        return Err(CompileError::TooManyPrims(prims.len()));
    }

    // Step 3: the BVH (or grid), and primitives reordered into its order.
    let bvh = accel::build_accel(&options.accel, &prims, &bounds, options.cache)?;
    let mut sorted: Vec<GpuPrim> = bvh.order.iter().map(|&i| prims[i as usize]).collect();

    // Step 4: scene bounds (camera-relative) for directional and environment lights.
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for b in &bounds {
        lo = lo.min(DVec3::from(b.min.map(f64::from)));
        hi = hi.max(DVec3::from(b.max.map(f64::from)));
    }
    for l in &scene.lights {
        if let Light::Point { position, .. } | Light::Spot { position, .. } = l {
            lo = lo.min(rel(*position));
            hi = hi.max(rel(*position));
        }
    }
    let (center, radius) = if lo.x <= hi.x {
        (0.5 * (lo + hi), 0.5 * (hi - lo).length().max(1e-6))
    } else {
        (DVec3::ZERO, 1.0)
    };

    // Step 5: lights: emissive primitives, then delta lights, then the environment.
    let mut lb = lights::LightBuilder::new();
    for (slot, &orig) in bvh.order.iter().enumerate() {
        let orig = orig as usize;
        let bits = sorted[slot].a[3].to_bits();
        let e = emission
            .get((bits & PRIM_MATERIAL_MASK) as usize)
            .copied()
            .unwrap_or(Vec3::ZERO);
        if e.max_element() <= 0.0 {
            continue;
        }
        let li = match shapes[orig] {
            Shape::Sphere { center, radius } => lb.sphere(
                slot as u32,
                center,
                radius,
                bits & PRIM_FLIP_NORMALS != 0,
                e,
            ),
            Shape::Triangle(p) => lb.triangle(slot as u32, p, e),
        };
        sorted[slot].b[3] = f32::from_bits(li);
    }
    for l in &scene.lights {
        match l {
            Light::Point {
                position,
                intensity,
            } => lb.point(rel(*position), *intensity),
            Light::Spot {
                position,
                direction,
                intensity,
                cutoff_angle,
                beam_width,
            } => lb.spot(
                rel(*position),
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
    let mut env = [NONE, NONE, 0, 0];
    let mut env_params = [1.0f32, 1.0, 0.0, 0.0];
    let mut env_dist = Vec::new();
    let mut clamp_rows = vec![false; scene.textures.len()];
    match &scene.environment {
        Some(Environment::Constant { radiance }) if radiance.max_element() > 0.0 => {
            env[0] = lb.env_constant(*radiance, radius);
        }
        Some(Environment::Map {
            texture,
            scale,
            rotate_y,
        }) => {
            if let Some(tex) = scene.textures.get(*texture as usize) {
                let (dist, mean) = lights::env_distribution(tex);
                env_dist = dist;
                env[0] = lb.env_map(*scale, mean, radius);
                env[1] = *texture;
                env[2] = tex.width;
                env[3] = tex.height;
                let a = rotate_y.to_radians();
                env_params = [*scale, a.cos(), a.sin(), 0.0];
                clamp_rows[*texture as usize] = true;
            }
        }
        _ => {}
    }
    // The light BVH, when asked for, over the lights before their pick probabilities are set.
    let light_bvh = (scene.render.light_sampler.as_deref() == Some("bvh") && !lb.lights.is_empty())
        .then(|| light_bvh::LightBvh::build(&lb.lights, &lb.power));
    let (mut gpu_lights, alias) = lb.finish();
    if let Some(t) = &light_bvh {
        for (l, trail) in gpu_lights.iter_mut().zip(&t.trails) {
            l.bvh_trail = trail.map_or(0, |(_, bits)| bits);
        }
    }
    let light_counts = light_bvh
        .as_ref()
        .map_or([0, 0], |t| [t.nodes.len() as u32, t.infinite.len() as u32]);
    let p_infinite = light_bvh.as_ref().map_or(0.0, |t| t.p_infinite() as f32);
    let light_bvh = light_bvh.map_or(Vec::new(), |t| t.gpu_nodes());
    let (textures, texels) = if features.textures || features.alpha {
        materials::pack_textures(&scene.textures, &clamp_rows)
    } else {
        (Vec::new(), Vec::new())
    };

    // Step 6: camera and film.
    let cam = &scene.camera;
    let forward = (cam.look_at - cam.position).normalize();
    let right = forward.cross(cam.up).normalize();
    let up = right.cross(forward);
    let tan_half = (cam.fov_y.to_radians() * 0.5).tan();
    let (filter_kind, stddev) = match scene.film.filter {
        Filter::Box => (0, 0.5),
        Filter::Gaussian { stddev } => (1, stddev),
    };
    let globals = GpuGlobals {
        cam_forward: [forward.x as f32, forward.y as f32, forward.z as f32, 0.0],
        cam_right: [right.x as f32, right.y as f32, right.z as f32, 0.0],
        cam_up: [up.x as f32, up.y as f32, up.z as f32, 0.0],
        lens: [
            tan_half as f32,
            width as f32 / height as f32,
            cam.aperture_radius as f32,
            cam.focus_distance as f32,
        ],
        film: [width, height, filter_kind, gpu_lights.len() as u32],
        filter: [stddev, 4.0 * stddev, 0.0, 0.0],
        scene_sphere: [
            center.x as f32,
            center.y as f32,
            center.z as f32,
            radius as f32,
        ],
        env,
        env_params: [env_params[0], env_params[1], env_params[2], p_infinite],
        counts: [
            sorted.len() as u32,
            bvh.nodes.len() as u32,
            light_counts[0],
            light_counts[1],
        ],
    };
    Ok(CompiledScene {
        globals,
        nodes: bvh.nodes,
        prims: sorted,
        tri_shading,
        materials,
        textures,
        texels,
        lights: gpu_lights,
        alias,
        light_bvh,
        env_dist,
        features,
        width,
        height,
        triangle_count,
        bvh_depth: bvh.depth,
        bvh_build_time: if bvh.grid.is_none() {
            bvh.info.build_time
        } else {
            Duration::ZERO
        },
        grid: bvh.grid,
        accel: bvh.info,
        camera_position: origin.to_array(),
        geometry_hash: world_geometry_hash(scene),
    })
}
