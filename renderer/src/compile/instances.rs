//! Instancing, the two-level structure: one BVH per prototype mesh (a BLAS, built once in the
//! prototype's own frame and cached like the scene's BVH), and a top-level BVH (TLAS) over the
//! instances' world boxes. Nothing here grows with instances × triangles: an instance costs one
//! `GpuInstance` (two 3×4 matrices) and one TLAS leaf, a prototype triangle what a scene
//! triangle costs.
//!
//! Frames: a prototype's primitives and BLAS are stored in its object frame as loaded (the
//! definition's own transform applied). An instance's matrices map the camera-relative world
//! frame the rest of the scene uses to that frame and back; they are composed in f64 (object →
//! world, then − camera) and rounded once. The shader moves each ray into the object frame
//! without renormalising its direction, so hit distances need no conversion
//! (shaders/common/traverse.glsl), and moves hit vertices and normals back
//! (shaders/common/surface.glsl). The TLAS is rebuilt on every compile (it follows the camera;
//! building it is cheap next to the BLASes).

use std::path::Path;
use std::time::{Duration, Instant};

use glam::{DMat4, DVec3};

use super::frame::outward;
use super::prims::{self, Frames, Prims};
use crate::accel::{self, AccelOptions, CacheStatus, PrimBounds};
use crate::layout::*;
use crate::scene::transform::{affine_rows_f32 as rows, box_corners};
use crate::scene::Scene;

// The two-level walk's leaf entries (shaders/common/traverse.glsl, `tl_leaf`): a top-level
// leaf's count in three bits from TL_COUNT_SHIFT, below the tag bit 31.
const _: () = assert!(accel::MAX_LEAF < 8 && TL_COUNT_SHIFT <= 28);

/// The instanced part of a compiled scene, to append to the scene's own arrays.
#[derive(Default)]
pub(super) struct Instanced {
    /// The prototypes' primitives in their BLAS order (object frame), to append after the
    /// scene's own; their shading indices already count the scene's records.
    pub prims: Vec<GpuPrim>,
    pub tri_shading: Vec<GpuTriShading>,
    /// The BLAS nodes, with absolute node and primitive indices (after the scene's own).
    pub nodes: Vec<GpuBvhNode>,
    /// The deepest BLAS.
    pub depth: usize,
    /// Instances in TLAS leaf order, and the TLAS over them.
    pub instances: Vec<GpuInstance>,
    pub tlas: Vec<GpuBvhNode>,
    /// The instances' camera-relative world boxes (for the scene's bounding sphere).
    pub bounds: Vec<PrimBounds>,
    /// Prototype triangles (unique, instanced) and the triangles as rendered.
    pub prototype_triangles: u64,
    pub instanced_triangles: u64,
    /// BLAS builds (or cache loads) and the TLAS build.
    pub build_time: Duration,
    /// The BLASes' cache status: a hit only when every one was loaded.
    pub cache: CacheStatus,
}

/// Where the instanced arrays start in the scene's: node, primitive and shading record counts.
#[derive(Clone, Copy)]
pub(super) struct Bases {
    pub nodes: usize,
    pub prims: usize,
    pub tri_shading: usize,
}

/// The box of BLAS `nodes` (its root's two children).
fn root_box(root: &GpuBvhNode) -> (DVec3, DVec3) {
    let f = |a: [f32; 3]| DVec3::from(a.map(f64::from));
    (
        f(root.l_min).min(f(root.r_min)),
        f(root.l_max).max(f(root.r_max)),
    )
}

/// The world box (camera-relative) of an object box under `m`, in f64 and rounded outwards,
/// with slack for the f32 rounding of the ray's move into the object frame.
fn world_box(m: DMat4, lo: DVec3, hi: DVec3) -> PrimBounds {
    let (mut wlo, mut whi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for c in box_corners(lo, hi) {
        let w = m.transform_point3(c);
        wlo = wlo.min(w);
        whi = whi.max(w);
    }
    let slack = wlo.abs().max(whi.abs()) * 1e-6 + (whi - wlo) * 1e-6;
    outward(wlo - slack, whi + slack)
}

/// Builds the BLASes of the prototypes that instances use (each once) and the TLAS over the
/// instances, relative to the camera at `origin`.
pub(super) fn build(
    scene: &Scene,
    origin: DVec3,
    bases: Bases,
    opts: &AccelOptions,
    cache: Option<&Path>,
) -> Instanced {
    let start = Instant::now();
    let mut out = Instanced::default();
    if scene.instances.is_empty() {
        return out;
    }
    out.cache = if cache.is_some() {
        CacheStatus::Hit
    } else {
        CacheStatus::Off
    };
    let alpha_material = prims::alpha_materials(scene);
    // Step 1: each used prototype's primitives (object frame) and BLAS.
    // A prototype some instance of which replaces its material by a masked one needs the
    // records the mask reads, whatever its own materials (prims::triangles).
    let is_masked = |m: u32| alpha_material.get(m as usize).copied().unwrap_or(false);
    let mut used = vec![false; scene.prototypes.len()];
    let mut masked_elsewhere = vec![false; scene.prototypes.len()];
    for i in &scene.instances {
        used[i.prototype as usize] = true;
        masked_elsewhere[i.prototype as usize] |= i.material.is_some_and(is_masked);
    }
    let object = Frames {
        origin: DVec3::ZERO,
        centre: DVec3::ZERO,
    };
    let blas_opts = AccelOptions {
        kind: accel::AccelKind::Bvh,
        by_estimate: false,
        ..*opts
    };
    // Per prototype: its BLAS root node index and object box.
    let mut roots: Vec<Option<(u32, DVec3, DVec3)>> = vec![None; scene.prototypes.len()];
    for (p, mesh) in scene.prototypes.iter().enumerate() {
        if !used[p] {
            continue;
        }
        let mut local = Prims::default();
        prims::triangles(
            mesh,
            object,
            &alpha_material,
            masked_elsewhere[p],
            &mut local,
        );
        let built = accel::build_accel(
            &blas_opts,
            &local.gpu,
            &local.bounds,
            &local.bvh_bounds,
            cache,
        );
        let node_base = (bases.nodes + out.nodes.len()) as u32;
        let prim_base = (bases.prims + out.prims.len()) as u32;
        let shading_base = (bases.tri_shading + out.tri_shading.len()) as u32;
        out.prims.extend(built.order.iter().map(|&i| {
            let mut g = local.gpu[i as usize];
            let si = g.c[3].to_bits();
            if si != NONE {
                g.c[3] = f32::from_bits(si + shading_base);
            }
            g
        }));
        out.tri_shading.extend_from_slice(&local.tri_shading);
        let (lo, hi) = root_box(&built.nodes[0]);
        out.nodes.extend(built.nodes.iter().map(|n| {
            let mut n = *n;
            for (c, count) in [(&mut n.left, n.l_count), (&mut n.right, n.r_count)] {
                *c += if count == 0 { node_base } else { prim_base };
            }
            n
        }));
        out.depth = out.depth.max(built.depth);
        out.cache = match (out.cache, built.info.cache) {
            (_, CacheStatus::Off) => CacheStatus::Off,
            (CacheStatus::Miss, _) | (_, CacheStatus::Miss) => CacheStatus::Miss,
            _ => CacheStatus::Hit,
        };
        out.prototype_triangles += mesh.indices.len() as u64;
        roots[p] = Some((node_base, lo, hi));
    }
    // Step 2: the instances' matrices (camera-relative) and world boxes.
    let to_camera = DMat4::from_translation(-origin);
    let mut instances = Vec::with_capacity(scene.instances.len());
    for inst in &scene.instances {
        let Some((root, lo, hi)) = roots[inst.prototype as usize] else {
            continue;
        };
        let o2w = to_camera * inst.to_world;
        let w2o = o2w.inverse();
        let (world_to_object, object_to_world) = (rows(w2o), rows(o2w));
        // Loading refuses transforms whose inverse leaves f32; this guards the camera-relative
        // translation (a far camera) so that no ray becomes NaN.
        if ![world_to_object, object_to_world]
            .iter()
            .flatten()
            .flatten()
            .all(|x| x.is_finite())
        {
            tracing::warn!(
                "an instance's matrices overflow 32-bit floats from this camera; skipped"
            );
            continue;
        }
        let mut flags = 0;
        if glam::DMat3::from_mat4(inst.to_world).determinant() < 0.0 {
            flags |= INST_MIRROR;
        }
        if inst.material.is_some_and(is_masked) {
            flags |= INST_ALPHA;
        }
        instances.push(GpuInstance {
            world_to_object,
            object_to_world,
            root,
            material: inst.material.unwrap_or(NONE),
            flags,
            pad: 0,
        });
        out.bounds.push(world_box(o2w, lo, hi));
        out.instanced_triangles += scene.prototypes[inst.prototype as usize].indices.len() as u64;
    }
    // Step 3: the TLAS, its leaves indexing the instances in its own order.
    // Its depth is bounded whatever the boxes (thousands of coincident instances included):
    // the shader's walk of it has no fallback for a deeper tree.
    let tlas = accel::build(&out.bounds, false);
    assert!(
        tlas.depth <= accel::STACK_DEPTH,
        "TLAS depth {}",
        tlas.depth
    );
    out.instances = tlas.order.iter().map(|&i| instances[i as usize]).collect();
    out.tlas = tlas.nodes;
    out.build_time = start.elapsed();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two definitions, three instances (one unused definition): every BLAS leaf indexes its
    /// own prototype's primitives, the matrices are each other's inverse, every instance is in
    /// one TLAS leaf, and each world box holds its instance's vertices.
    #[test]
    fn two_levels_index_and_bound_correctly() {
        let json = r#"{
            "version": 1,
            "camera": {"position": [3, 2, 9], "look_at": [0, 0, 0]},
            "film": {"width": 8, "height": 8},
            "materials": {"a": {"type": "diffuse"}, "b": {"type": "diffuse"}},
            "definitions": {
                "cube": {"type": "box", "min": [-1, -1, -1], "max": [1, 1, 1], "material": "a"},
                "unused": {"type": "quad", "origin": [0, 0, 0], "edge_u": [1, 0, 0], "edge_v": [0, 1, 0], "material": "a"},
                "tri": {"type": "triangles", "positions": [0,0,0, 1,0,0, 0,1,0], "indices": [0,1,2], "material": "b"}
            },
            "objects": [
                {"type": "quad", "origin": [-5, -1, 5], "edge_u": [10, 0, 0], "edge_v": [0, 0, -10], "material": "a"},
                {"type": "instance", "definition": "cube", "transform": {"scale": [1, 2, 0.5], "translate": [2, 0, 0]}},
                {"type": "instance", "definition": "tri", "material": "a", "transform": {"scale": [-1, 1, 1]}},
                {"type": "instance", "definition": "cube", "transform": {"rotate": {"axis": [1, 1, 1], "angle": 33}, "translate": [-2, 1, 0]}}
            ]
        }"#;
        let scene = crate::scene::load_str(json, None).unwrap();
        assert_eq!(scene.prototypes.len(), 3);
        let origin = scene.camera.position;
        let bases = Bases {
            nodes: 5,
            prims: 2,
            tri_shading: 2,
        };
        let out = build(&scene, origin, bases, &AccelOptions::default(), None);
        assert_eq!(
            out.prototype_triangles,
            12 + 1,
            "the unused quad is not built"
        );
        assert_eq!(out.instanced_triangles, 12 + 1 + 12);
        assert_eq!(out.prims.len(), 13);
        assert_eq!(out.instances.len(), 3);
        // Leaves of each BLAS stay within its prototype's primitives.
        for inst in &out.instances {
            let mut stack = vec![inst.root as usize];
            let mut count = 0;
            while let Some(i) = stack.pop() {
                let n = out.nodes[i - bases.nodes];
                for (c, k) in [(n.left, n.l_count), (n.right, n.r_count)] {
                    if k == 0 {
                        stack.push(c as usize);
                    } else {
                        assert!(c as usize >= bases.prims && (c + k) as usize <= bases.prims + 13);
                        count += k;
                    }
                }
            }
            assert!(count >= 1);
        }
        // Every instance once in the TLAS leaves.
        let mut seen = [0; 3];
        for n in &out.tlas {
            for (c, k) in [(n.left, n.l_count), (n.right, n.r_count)] {
                for i in c..c + k {
                    seen[i as usize] += 1;
                }
            }
        }
        assert!(seen.iter().all(|&s| s >= 1), "{seen:?}");
        // Matrices: inverse of each other; the mirrored instance is flagged.
        for inst in &out.instances {
            let m = |r: [[f32; 4]; 3]| {
                DMat4::from_cols_array(&[
                    r[0][0] as f64,
                    r[1][0] as f64,
                    r[2][0] as f64,
                    0.0,
                    r[0][1] as f64,
                    r[1][1] as f64,
                    r[2][1] as f64,
                    0.0,
                    r[0][2] as f64,
                    r[1][2] as f64,
                    r[2][2] as f64,
                    0.0,
                    r[0][3] as f64,
                    r[1][3] as f64,
                    r[2][3] as f64,
                    1.0,
                ])
            };
            let id = m(inst.world_to_object) * m(inst.object_to_world);
            assert!(id.abs_diff_eq(DMat4::IDENTITY, 1e-5), "{id:?}");
        }
        let mirrored: Vec<bool> = out
            .instances
            .iter()
            .map(|i| i.flags & INST_MIRROR != 0)
            .collect();
        assert_eq!(mirrored.iter().filter(|&&m| m).count(), 1);
        assert_eq!(out.instances.iter().filter(|i| i.material == 0).count(), 1);
        // World boxes hold the instances' vertices (camera-relative).
        for (k, inst) in scene.instances.iter().enumerate() {
            let mesh = &scene.prototypes[inst.prototype as usize];
            let b = out.bounds[k];
            for p in &mesh.positions {
                let w = inst.to_world.transform_point3(*p) - origin;
                for a in 0..3 {
                    assert!(b.min[a] as f64 <= w[a] && w[a] <= b.max[a] as f64);
                }
            }
        }
    }

    /// Five thousand instances with the same world box: the TLAS stays within the shader's
    /// stack (it has no fallback for a deeper one) and holds every instance once.
    #[test]
    fn coincident_instances_keep_the_tlas_within_the_stack() {
        let n = 5000;
        let objects: Vec<String> = (0..n)
            .map(|_| r#"{"type": "instance", "definition": "tri"}"#.to_string())
            .collect();
        let json = format!(
            r#"{{"version": 1, "camera": {{"position": [0, 0, 5], "look_at": [0, 0, 0]}},
            "film": {{"width": 8, "height": 8}}, "materials": {{"a": {{"type": "diffuse"}}}},
            "definitions": {{"tri": {{"type": "triangles", "positions": [0,0,0, 1,0,0, 0,1,0],
                "indices": [0,1,2], "material": "a"}}}},
            "objects": [{}]}}"#,
            objects.join(",")
        );
        let scene = crate::scene::load_str(&json, None).unwrap();
        let bases = Bases {
            nodes: 1,
            prims: 0,
            tri_shading: 0,
        };
        let out = build(
            &scene,
            scene.camera.position,
            bases,
            &AccelOptions::default(),
            None,
        );
        // Depth (inner levels) and leaf coverage, walking from the root.
        let (mut depth, mut seen) = (0, vec![0u32; n]);
        let mut stack = vec![(0usize, 1usize)];
        while let Some((i, d)) = stack.pop() {
            depth = depth.max(d);
            let n = out.tlas[i];
            for (c, k) in [(n.left, n.l_count), (n.right, n.r_count)] {
                if k == 0 {
                    assert!(
                        c as usize > i && (c as usize) < out.tlas.len(),
                        "node {i} child {c}"
                    );
                    stack.push((c as usize, d + 1));
                } else {
                    (c..c + k).for_each(|j| seen[j as usize] += 1);
                }
            }
        }
        assert!(depth <= accel::STACK_DEPTH, "{depth}");
        assert!(seen.iter().all(|&s| s == 1));
        for n in &out.tlas {
            for (lo, hi) in [(n.l_min, n.l_max), (n.r_min, n.r_max)] {
                for a in 0..3 {
                    assert!(
                        lo[a] <= out.bounds[0].min[a] && hi[a] >= out.bounds[0].max[a],
                        "{n:?}"
                    );
                }
            }
        }
    }
}
