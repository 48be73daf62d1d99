//! Compile step 2 and 4: the scene's triangles and spheres as camera-relative GPU primitives with
//! their bounds, shading records and exact f64 shapes (for light areas), and the bounding sphere
//! that directional and environment lights are placed around.

use glam::{DVec3, Vec3};

use super::frame::outward;
use super::CompileError;
use crate::accel::PrimBounds;
use crate::layout::*;
use crate::scene::{Light, Scene, TriangleMesh};

/// A primitive's exact (f64, camera-relative) geometry.
#[derive(Clone, Copy, Debug)]
pub(super) enum Shape {
    Triangle([DVec3; 3]),
    Sphere { center: DVec3, radius: f64 },
}

/// The primitives of a scene in input order (meshes' triangles, then spheres).
#[derive(Default)]
pub(super) struct Prims {
    pub gpu: Vec<GpuPrim>,
    pub bounds: Vec<PrimBounds>,
    /// The same boxes in the scene frame (`world − centre`, rounded outwards): the BVH's input.
    pub bvh_bounds: Vec<PrimBounds>,
    pub tri_shading: Vec<GpuTriShading>,
    pub shapes: Vec<Shape>,
    pub triangle_count: usize,
}

pub(super) fn f3(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// Every primitive of `scene`, positioned relative to `origin` (computed in f64, then rounded),
/// with its bounds relative to `origin` and to `centre` (the BVH's frame).
pub(super) fn gather(scene: &Scene, origin: DVec3, centre: DVec3) -> Result<Prims, CompileError> {
    let frames = Frames { origin, centre };
    let mut out = Prims::default();
    let alpha_material = alpha_materials(scene);
    if scene.materials.len() > PRIM_MATERIAL_MASK as usize {
        return Err(CompileError::TooManyMaterials(scene.materials.len()));
    }
    let prims = scene.meshes.iter().map(|m| m.indices.len()).sum::<usize>()
        + scene.spheres.len()
        + scene
            .prototypes
            .iter()
            .map(|m| m.indices.len())
            .sum::<usize>();
    if prims >= NONE as usize {
        return Err(CompileError::TooManyPrims(prims));
    }
    for mesh in &scene.meshes {
        triangles(mesh, frames, &alpha_material, false, &mut out);
    }
    spheres(scene, frames, &alpha_material, &mut out);
    Ok(out)
}

/// Whether each material is alpha-masked.
pub(super) fn alpha_materials(scene: &Scene) -> Vec<bool> {
    scene
        .materials
        .iter()
        .map(|m| m.alpha_mask.is_some())
        .collect()
}

/// The camera's position and the BVH frame's origin (world space).
#[derive(Clone, Copy)]
pub(super) struct Frames {
    pub origin: DVec3,
    pub centre: DVec3,
}

/// One mesh's triangles, with a shading record where the mesh has normals or uvs, or an
/// alpha-masked material, or `masked_elsewhere` (an instance of this prototype replaces its
/// material by a masked one). A mask reads the record's uvs (without uvs, the triangles'
/// barycentrics); such records hold what common/surface.glsl takes without one, so the feature
/// `tri_shading`, which compiles the reading of records into surface.glsl, stays off for them.
/// Every triangle's records are computed in parallel into the slots it takes.
pub(super) fn triangles(
    mesh: &TriangleMesh,
    frames: Frames,
    alpha_material: &[bool],
    masked_elsewhere: bool,
    out: &mut Prims,
) {
    use rayon::prelude::*;
    let origin = frames.origin;
    let masked = |m: &u32| alpha_material.get(*m as usize).copied().unwrap_or(false);
    let shaded = mesh.normals.is_some()
        || mesh.uvs.is_some()
        || masked_elsewhere
        || (alpha_material.contains(&true) && mesh.materials.par_iter().any(masked));
    // Step 1: room for the mesh's records (triangle t's shading record, if any, is at
    // `shade_base + t`).
    let (n, base, shade_base) = (mesh.indices.len(), out.gpu.len(), out.tri_shading.len());
    let empty = PrimBounds {
        min: [0.0; 3],
        max: [0.0; 3],
    };
    grow(&mut out.gpu, n, bytemuck::Zeroable::zeroed());
    grow(&mut out.bounds, n, empty);
    grow(&mut out.bvh_bounds, n, empty);
    grow(&mut out.shapes, n, Shape::Triangle([DVec3::ZERO; 3]));
    if shaded {
        grow(&mut out.tri_shading, n, bytemuck::Zeroable::zeroed());
        (out.tri_shading[shade_base..].par_iter_mut())
            .zip(mesh.indices.par_iter())
            .for_each(|(r, idx)| *r = shading_record(mesh, idx));
    }
    // Step 2: each triangle's primitive, boxes (camera-relative and in the BVH's frame) and
    // exact shape.
    (
        out.gpu[base..].par_iter_mut(),
        out.bounds[base..].par_iter_mut(),
        out.bvh_bounds[base..].par_iter_mut(),
        out.shapes[base..].par_iter_mut(),
    )
        .into_par_iter()
        .enumerate()
        .for_each(|(t, (gpu, bounds, bvh_bounds, shape))| {
            let idx = &mesh.indices[t];
            let p = idx.map(|i| mesh.positions[i as usize] - origin);
            let m = mesh.materials.get(t).copied().unwrap_or(0);
            let mut flags = m & PRIM_MATERIAL_MASK;
            if masked(&m) {
                flags |= PRIM_ALPHA;
            }
            let shading = if shaded {
                (shade_base + t) as u32
            } else {
                NONE
            };
            let [a, b, c] = p.map(f3);
            *gpu = GpuPrim {
                a: [a[0], a[1], a[2], f32::from_bits(flags)],
                b: [b[0], b[1], b[2], f32::from_bits(NONE)],
                c: [c[0], c[1], c[2], f32::from_bits(shading)],
            };
            *bounds = PrimBounds {
                min: f3(p[0].min(p[1]).min(p[2])),
                max: f3(p[0].max(p[1]).max(p[2])),
            };
            let w = idx.map(|i| mesh.positions[i as usize] - frames.centre);
            *bvh_bounds = outward(w[0].min(w[1]).min(w[2]), w[0].max(w[1]).max(w[2]));
            *shape = Shape::Triangle(p);
        });
    out.triangle_count += n;
}

/// `v` with `n` more copies of `fill`, written on every core: a serial fill of a 30M-triangle
/// mesh's records (gigabytes, page faults included) took seconds.
fn grow<T: Clone + Send + Sync>(v: &mut Vec<T>, n: usize, fill: T) {
    use rayon::prelude::*;
    v.par_extend(rayon::iter::repeat_n(fill, n));
}

/// A triangle's vertex normals and uvs (w of `uv_v`: 1 when the normals are the mesh's own). A
/// mesh without uvs gets each triangle's own barycentric corners (0, 1), (1, 1), (0, 0), so that
/// uv = (b1, 1 − b2) as for triangles without a record (common/intersect.glsl's
/// `barycentric_uv`): Mitsuba's (b1, b2) in candela's v direction.
fn shading_record(mesh: &TriangleMesh, idx: &[u32; 3]) -> GpuTriShading {
    const CORNERS: [glam::Vec2; 3] = [glam::Vec2::Y, glam::Vec2::ONE, glam::Vec2::ZERO];
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
            .unwrap_or(CORNERS[k])
    };
    GpuTriShading {
        n0: [n(0).x, n(0).y, n(0).z, uv(0).x],
        n1: [n(1).x, n(1).y, n(1).z, uv(1).x],
        n2: [n(2).x, n(2).y, n(2).z, uv(2).x],
        uv_v: [
            uv(0).y,
            uv(1).y,
            uv(2).y,
            if mesh.normals.is_some() { 1.0 } else { 0.0 },
        ],
    }
}

/// The analytic spheres, with bounds padded so rounding cannot clip them. An alpha-masked
/// material's mask cuts them at their own uvs (the traversal's `intersect_sphere_masked`).
fn spheres(scene: &Scene, frames: Frames, alpha_material: &[bool], out: &mut Prims) {
    for s in &scene.spheres {
        let c = s.center - frames.origin;
        let mut flags = PRIM_SPHERE | (s.material & PRIM_MATERIAL_MASK);
        if s.flip_normals {
            flags |= PRIM_FLIP_NORMALS;
        }
        if alpha_material
            .get(s.material as usize)
            .copied()
            .unwrap_or(false)
        {
            flags |= PRIM_ALPHA;
        }
        let cf = f3(c);
        out.gpu.push(GpuPrim {
            a: [cf[0], cf[1], cf[2], f32::from_bits(flags)],
            b: [s.radius as f32, 0.0, 0.0, f32::from_bits(NONE)],
            c: [0.0, 0.0, 0.0, f32::from_bits(NONE)],
        });
        // Bounds padded by a few ulps so rounding of centre and radius cannot clip the sphere.
        let r = DVec3::splat(s.radius * (1.0 + 1e-6));
        let pad = c.abs() * 1e-6;
        out.bounds.push(PrimBounds {
            min: f3(c - r - pad),
            max: f3(c + r + pad),
        });
        let cs = s.center - frames.centre;
        let pad_s = cs.abs() * 1e-6;
        out.bvh_bounds.push(outward(cs - r - pad_s, cs + r + pad_s));
        out.shapes.push(Shape::Sphere {
            center: c,
            radius: s.radius,
        });
    }
}

/// The camera-relative bounding sphere (centre, radius) of the primitives (and instances: every
/// list of boxes in `bounds`) and the point and spot lights; a unit sphere at the camera for an
/// empty scene.
pub(super) fn scene_sphere(scene: &Scene, bounds: &[&[PrimBounds]], origin: DVec3) -> (DVec3, f64) {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for b in bounds.iter().flat_map(|list| list.iter()) {
        lo = lo.min(DVec3::from(b.min.map(f64::from)));
        hi = hi.max(DVec3::from(b.max.map(f64::from)));
    }
    for l in &scene.lights {
        if let Light::Point { position, .. } | Light::Spot { position, .. } = l {
            lo = lo.min(*position - origin);
            hi = hi.max(*position - origin);
        }
    }
    if lo.x <= hi.x {
        (0.5 * (lo + hi), 0.5 * (hi - lo).length().max(1e-6))
    } else {
        (DVec3::ZERO, 1.0)
    }
}
