//! Instances written out as meshes of their own, where the two-level structure cannot serve
//! them: acceleration structures other than the binary BVH (cwbvh, grid), integrators that read
//! primitives by index (vct, deferred), and instances that emit light (every emitting triangle
//! is a light of its own, sampled by its world-space area). The copy of an instance is exactly
//! what the GPU's two-level path renders: the prototype's positions through the instance's f64
//! transform, its shading normals through the inverse transpose, its winding swapped by a
//! mirror, the instance's material override applied. Unlike the two-level path, memory then
//! grows with instances × triangles, so the expansion is bounded (the scene limits'
//! `max_triangles`, the caller's) and refused, naming the counts, beyond it.

use glam::Vec3;

use super::mesh::{to_world, Materials, RawMesh, Shading};
use super::transform::Transform;
use super::{Instance, Scene};

/// Which instances to write out as meshes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Expand {
    /// Every instance (the structure or the integrator has no second level).
    All,
    /// Only instances that emit light (their prototype's materials or their override).
    Emitting,
}

/// Whether material `m` of `scene` emits.
fn emits(scene: &Scene, m: u32) -> bool {
    scene
        .materials
        .get(m as usize)
        .is_some_and(|m| m.emission != Vec3::ZERO)
}

/// The instances of `scene` that `which` picks.
fn picked(scene: &Scene, which: Expand) -> Vec<bool> {
    let proto_emits: Vec<bool> = match which {
        Expand::All => Vec::new(),
        Expand::Emitting => scene
            .prototypes
            .iter()
            .map(|p| p.materials.iter().any(|&m| emits(scene, m)))
            .collect(),
    };
    let pick = |i: &Instance| match (which, i.material) {
        (Expand::All, _) => true,
        (Expand::Emitting, Some(m)) => emits(scene, m),
        (Expand::Emitting, None) => proto_emits[i.prototype as usize],
    };
    scene.instances.iter().map(pick).collect()
}

/// `scene` with the instances `which` picks written out as meshes (appended after its own, in
/// instance order), the others kept; None when it picks none. Err names the triangle counts
/// and `why` they are written out when the expanded scene would exceed `max_triangles`.
pub fn expand_instances(
    scene: &Scene,
    which: Expand,
    why: &str,
    max_triangles: u64,
) -> Result<Option<Scene>, String> {
    let picks = picked(scene, which);
    if !picks.contains(&true) {
        return Ok(None);
    }
    // Step 1: the bound, checked before anything is allocated.
    let own: u64 = scene.meshes.iter().map(|m| m.indices.len() as u64).sum();
    let added: u64 = (scene.instances.iter().zip(&picks))
        .filter(|(_, &p)| p)
        .map(|(i, _)| scene.prototypes[i.prototype as usize].indices.len() as u64)
        .sum();
    if own + added > max_triangles {
        let n = picks.iter().filter(|p| **p).count();
        return Err(format!(
            "writing out {n} instances as meshes ({why}) would make {} triangles; at most \
             {max_triangles}",
            own + added
        ));
    }
    // Step 2: each picked instance, as the two-level path places it.
    // (Every part but the meshes and instances as it was; the definitions only if some
    // instance still places them.)
    let keeps_any = picks.contains(&false);
    let mut out = Scene {
        camera: scene.camera.clone(),
        film: scene.film.clone(),
        materials: scene.materials.clone(),
        material_names: scene.material_names.clone(),
        textures: scene.textures.clone(),
        meshes: scene.meshes.clone(),
        spheres: scene.spheres.clone(),
        prototypes: if keeps_any {
            scene.prototypes.clone()
        } else {
            Vec::new()
        },
        instances: Vec::new(),
        lights: scene.lights.clone(),
        environment: scene.environment.clone(),
        render: scene.render.clone(),
    };
    for (k, (inst, &pick)) in scene.instances.iter().zip(&picks).enumerate() {
        if !pick {
            out.instances.push(inst.clone());
            continue;
        }
        let proto = &scene.prototypes[inst.prototype as usize];
        let path = format!("instance {k} of {}", proto.name);
        let transform = Transform::from_matrix(inst.to_world, &path).map_err(|e| e.to_string())?;
        let raw = RawMesh {
            positions: proto.positions.clone(),
            normals: (proto.normals.as_ref()).map(|n| n.iter().map(|v| v.as_dvec3()).collect()),
            uvs: proto.uvs.clone(),
            indices: proto.indices.clone(),
        };
        let materials = match inst.material {
            Some(m) => Materials::All(m),
            None => Materials::PerTriangle(proto.materials.clone()),
        };
        let mesh = to_world(
            raw,
            &transform,
            Shading::SourceOnly,
            path.clone(),
            materials,
            &path,
        )
        .map_err(|e| e.to_string())?;
        out.meshes.push(mesh);
    }
    Ok(Some(out))
}
