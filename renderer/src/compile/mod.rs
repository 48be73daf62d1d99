//! Scene compilation: a loaded `Scene` (f64, world space) becomes the flat, camera-relative f32
//! buffers of `crate::layout`, a BVH, a light table and the feature set its kernels are specialised for.
//!
//! Precision: every position is `world − camera` computed in f64 and only then rounded to f32,
//! so a scene translated by 1e5 units renders exactly like one at the origin.
//!
//! The BVH is built in the scene frame (`world − centre of the scene's bounds`, boxes rounded
//! outwards) so that it, and its cache key, do not depend on the camera; its node boxes are then
//! moved to the camera frame in f64 and rounded outwards again (`frame::place_nodes`), so each
//! still contains its primitives exactly as uploaded. A compressed wide BVH is requantised into
//! the camera frame the same way (`frame::place_cwbvh`).

mod camera;
mod emitters;
mod features;
mod frame;
mod instances;
pub mod light_bvh;
mod light_split;
mod lights;
mod mask_coverage;
mod materials;
mod prims;

use std::path::Path;
use std::time::Duration;

use crate::accel::cwbvh::Cwbvh;
use crate::accel::grid::Grid;
use crate::accel::{self, AccelInfo, AccelOptions};
use crate::layout::*;
use crate::scene::expand::{expand_instances, Expand};
use crate::scene::Scene;
pub use camera::SceneConstants;
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
    /// Each BVH node's parent, for the traversal's stackless fallback: only for trees deeper
    /// than `accel::STACK_DEPTH` (empty otherwise; a one-word placeholder is uploaded).
    pub bvh_parents: Vec<u32>,
    /// Seconds spent loading the scene before it was compiled (set by `prepare` from its
    /// caller's measure; zero when unknown), and compiling it (this function, including the
    /// acceleration structure's build or cache load).
    pub load_time: Duration,
    pub compile_time: Duration,
    /// Entries of the traversal's short stack the kernels are built with: `accel::STACK_DEPTH`,
    /// or fewer through [`CompiledScene::with_traversal_stack`] (a testing aid).
    pub traversal_stack: usize,
    /// The uniform grid when `accel` is "grid" (then `nodes` is empty and the kernels are built
    /// with `ACCEL_GRID`).
    pub grid: Option<Grid>,
    /// The compressed 8-wide BVH when `accel` is "cwbvh" (then `nodes` is empty and the kernels
    /// are built with `ACCEL_CWBVH`).
    pub cwbvh: Option<Cwbvh>,
    /// Which structure was built, how long it took, its size, cache hit or miss.
    pub accel: AccelInfo,
    /// Instances (`instance` objects) in the top-level BVH's leaf order, and that BVH (empty
    /// without instances: then the kernels are built without `HAS_INSTANCES`). The prototypes'
    /// own BVHs are in `nodes` after the scene's, their primitives in `prims` after the scene's.
    pub instances: Vec<GpuInstance>,
    pub tlas_nodes: Vec<GpuBvhNode>,
    /// The camera's position in world space (f64): every position above is relative to it.
    pub camera_position: [f64; 3],
    /// A hash of the world-space geometry (positions, indices, per-triangle materials, spheres),
    /// the same wherever the camera is: caches of structures built from the geometry key on it
    /// and place them with `camera_position`.
    pub geometry_hash: u64,
}

impl CompiledScene {
    /// What the scene holds constant for specialised kernels: its filter, camera model and
    /// whether surfaces need their tangent's direction.
    pub fn constants(&self) -> SceneConstants {
        SceneConstants::of(&self.globals)
    }

    /// A testing aid: kernels whose traversal stack holds only `entries` (1..=STACK_DEPTH), so
    /// the stackless fallback for deep trees runs on any scene (the parent pointers are made).
    pub fn with_traversal_stack(mut self, entries: usize) -> Self {
        self.traversal_stack = entries.clamp(1, accel::STACK_DEPTH);
        if self.bvh_parents.is_empty() && self.grid.is_none() && self.cwbvh.is_none() {
            self.bvh_parents = accel::parents(&self.nodes);
        }
        self
    }
}

/// Hashes a mesh's positions (bits), indices and per-triangle materials.
fn hash_mesh(m: &crate::scene::TriangleMesh, h: &mut impl std::hash::Hasher) {
    use std::hash::Hash;
    let bits: Vec<[u64; 3]> = m
        .positions
        .iter()
        .map(|p| p.to_array().map(f64::to_bits))
        .collect();
    (bits, &m.indices, &m.materials).hash(h);
}

/// [`CompiledScene::geometry_hash`] of a scene. Each list is preceded by its length, so that
/// moving an item from one list to the next changes the hash.
fn world_geometry_hash(scene: &Scene) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    scene.meshes.len().hash(&mut h);
    for m in &scene.meshes {
        hash_mesh(m, &mut h);
    }
    scene.spheres.len().hash(&mut h);
    for s in &scene.spheres {
        (
            s.center.to_array().map(f64::to_bits),
            s.radius.to_bits(),
            s.flip_normals,
            s.material,
        )
            .hash(&mut h);
    }
    scene.prototypes.len().hash(&mut h);
    for m in &scene.prototypes {
        hash_mesh(m, &mut h);
    }
    scene.instances.len().hash(&mut h);
    for i in &scene.instances {
        (
            i.prototype,
            i.to_world.to_cols_array().map(f64::to_bits),
            i.material,
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
    /// Write every instance out as a mesh (scene/expand.rs), for integrators that read
    /// primitives by index (vct, deferred). Without it only emitting instances are, and all of
    /// them with an `accel` other than the binary BVH.
    pub expand_instances: bool,
    /// The most triangles the scene may have with instances written out (the caller's scene
    /// limits; None: the loader's default, `scene::Limits::default().max_triangles`).
    pub max_triangles: Option<u64>,
}

#[derive(Debug, thiserror::Error)]
pub enum CompileError {
    /// Primitive indices are u32, and u32::MAX marks "none".
    #[error("scene has {0} primitives; at most {max} are supported", max = NONE - 1)]
    TooManyPrims(usize),
    /// A primitive's material index has the low 24 bits of a u32 (`PRIM_MATERIAL_MASK`).
    #[error("scene has {0} materials; at most {max} are supported", max = PRIM_MATERIAL_MASK)]
    TooManyMaterials(usize),
    /// Instances to write out as meshes would make too large a scene (scene/expand.rs).
    #[error("instances: {0}")]
    Expand(String),
    /// Instance indices have 28 bits in the traversal's stack (`MAX_INSTANCES`).
    #[error("scene has {0} instances; at most {max} are supported", max = MAX_INSTANCES - 1)]
    TooManyInstances(usize),
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
    let start = std::time::Instant::now();
    // Step 0: instances only the binary BVH's second level can trace, and none that emit,
    // stay instances; the others are written out as meshes (scene/expand.rs).
    let (expand, why) = if options.expand_instances {
        (
            Expand::All,
            "the integrator traces no instances".to_string(),
        )
    } else if options.accel.kind != accel::AccelKind::Bvh {
        let name = options.accel.kind.name();
        (Expand::All, format!("accel \"{name}\" has no second level"))
    } else {
        (
            Expand::Emitting,
            "emitting instances are lights".to_string(),
        )
    };
    let max =
        (options.max_triangles).unwrap_or(crate::scene::Limits::default().max_triangles as u64);
    let expanded = expand_instances(scene, expand, &why, max).map_err(CompileError::Expand)?;
    let scene = expanded.as_ref().unwrap_or(scene);
    let origin = scene.camera.position;
    let features = FeatureSet::detect(scene);
    if !scene.instances.is_empty() {
        if scene.instances.len() >= MAX_INSTANCES as usize {
            return Err(CompileError::TooManyInstances(scene.instances.len()));
        }
    }

    // Step 1: materials (textures are packed with the lights, which mark the environment's).
    let materials: Vec<GpuMaterial> = scene
        .materials
        .iter()
        .map(materials::gpu_material)
        .collect();

    // Step 2: primitives in input order, with bounds, camera-relative (and in the scene frame,
    // for the BVH).
    let centre = frame::scene_centre(scene);
    let gather_start = std::time::Instant::now();
    let prims = prims::gather(scene, origin, centre)?;
    let gather_s = gather_start.elapsed().as_secs_f64();

    // Step 3: the BVH (or grid) built in the scene frame and placed in the camera's, and
    // primitives reordered into its order.
    let mut bvh = accel::build_accel(
        &options.accel,
        &prims.gpu,
        &prims.bounds,
        &prims.bvh_bounds,
        options.cache,
    );
    let place_start = std::time::Instant::now();
    frame::place_nodes(&mut bvh.nodes, origin - centre);
    if let Some(c) = &mut bvh.cwbvh {
        frame::place_cwbvh(&mut c.nodes, origin - centre);
    }
    let place_s = place_start.elapsed().as_secs_f64();
    let reorder_start = std::time::Instant::now();
    let mut sorted: Vec<GpuPrim> = {
        use rayon::prelude::*;
        (bvh.order.par_iter())
            .map(|&i| prims.gpu[i as usize])
            .collect()
    };
    // Gathering, placing the nodes in the camera frame and reordering the primitives are
    // compile steps outside `accel_build_s`, listed with the build's phases for the cold-start
    // breakdown.
    bvh.info.phases.0.insert(0, ("gather_prims", gather_s));
    (bvh.info.phases.0).push(("place", place_s));
    (bvh.info.phases.0).push(("reorder_prims", reorder_start.elapsed().as_secs_f64()));
    let scene_prims = sorted.len();

    // Step 3b: instances: the prototypes' BVHs after the scene's, and the top-level BVH.
    let inst = instances::build(
        scene,
        origin,
        instances::Bases {
            nodes: bvh.nodes.len(),
            prims: sorted.len(),
            tri_shading: prims.tri_shading.len(),
        },
        &options.accel,
        options.cache,
    );

    // Step 4: scene bounds (camera-relative) for directional and environment lights.
    let (center, radius) = prims::scene_sphere(scene, &[&prims.bounds, &inst.bounds], origin);

    // Step 5: lights: emissive primitives, then delta lights, then the environment (emitting
    // instances were written out as meshes in step 0).
    let emitters = emitters::gather(
        scene,
        &bvh.order,
        &mut sorted,
        &prims.shapes,
        &prims.tri_shading,
        radius,
    );
    sorted.extend_from_slice(&inst.prims);
    let mut tri_shading = prims.tri_shading;
    tri_shading.extend_from_slice(&inst.tri_shading);
    let mut nodes = bvh.nodes;
    nodes.extend_from_slice(&inst.nodes);
    let depth = bvh.depth.max(inst.depth);
    let bvh_parents = if depth > accel::STACK_DEPTH {
        accel::parents(&nodes)
    } else {
        Vec::new()
    };
    let mut accel_info = bvh.info;
    if !inst.instances.is_empty() {
        accel_info.bytes += (inst.nodes.len() * std::mem::size_of::<GpuBvhNode>()) as u64;
        accel_info.instances = inst.instances.len() as u64;
        accel_info.instance_bytes = (inst.instances.len() * std::mem::size_of::<GpuInstance>()
            + inst.tlas.len() * std::mem::size_of::<GpuBvhNode>())
            as u64;
        accel_info.instanced_triangles = inst.instanced_triangles;
        accel_info.build_time += inst.build_time;
        if inst.cache == accel::CacheStatus::Miss {
            accel_info.cache = accel::CacheStatus::Miss;
        }
    }
    let (textures, texels) = if features.textures || features.alpha {
        materials::pack_textures(&scene.textures, &emitters.clamp_rows)
    } else {
        (Vec::new(), Vec::new())
    };

    // Step 6: camera and film.
    let globals = camera::globals(
        scene,
        width,
        height,
        camera::SceneFacts {
            center,
            radius,
            light_count: emitters.lights.len() as u32,
            env: emitters.env,
            env_params: emitters.env_params,
            prim_count: scene_prims as u32,
            node_count: nodes.len() as u32,
            light_nodes: emitters.light_counts,
            instances: [inst.instances.len() as u32, inst.tlas.len() as u32],
            tangents: features.mat_conductor || features.mat_principled,
        },
    );
    Ok(CompiledScene {
        globals,
        nodes,
        prims: sorted,
        tri_shading,
        materials,
        textures,
        texels,
        lights: emitters.lights,
        alias: emitters.alias,
        light_bvh: emitters.light_bvh,
        env_dist: emitters.env_dist,
        features,
        width,
        height,
        triangle_count: prims.triangle_count + inst.prototype_triangles as usize,
        bvh_depth: depth,
        bvh_parents,
        traversal_stack: accel::STACK_DEPTH,
        load_time: Duration::ZERO,
        compile_time: start.elapsed(),
        bvh_build_time: if bvh.grid.is_none() {
            accel_info.build_time
        } else {
            Duration::ZERO
        },
        grid: bvh.grid,
        cwbvh: bvh.cwbvh,
        accel: accel_info,
        instances: inst.instances,
        tlas_nodes: inst.tlas,
        camera_position: origin.to_array(),
        geometry_hash: world_geometry_hash(scene),
    })
}

#[cfg(test)]
mod tests {
    /// The same quad as a scene mesh or as an (unused) definition's prototype hashes
    /// differently: each list is preceded by its length.
    #[test]
    fn geometry_hash_separates_meshes_from_prototypes() {
        let quad = r#"{"type": "quad", "origin": [0, 0, 0], "edge_u": [1, 0, 0], "edge_v": [0, 1, 0], "material": "a"}"#;
        let scene = |objects: &str, definitions: &str| {
            let json = format!(
                r#"{{"version": 1, "camera": {{"position": [0, 0, 5], "look_at": [0, 0, 0]}},
                "film": {{"width": 8, "height": 8}}, "materials": {{"a": {{"type": "diffuse"}}}},
                "definitions": {{{definitions}}}, "objects": [{objects}]}}"#
            );
            crate::scene::load_str(&json, None).unwrap()
        };
        let as_mesh = scene(quad, "");
        let as_prototype = scene("", &format!(r#""q": {quad}"#));
        assert_eq!(as_mesh.meshes.len(), 1);
        assert_eq!(as_prototype.prototypes.len(), 1);
        assert_eq!(
            as_mesh.meshes[0].positions,
            as_prototype.prototypes[0].positions
        );
        assert_ne!(
            super::world_geometry_hash(&as_mesh),
            super::world_geometry_hash(&as_prototype)
        );
    }
}
