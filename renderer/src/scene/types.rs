//! The loaded scene: what `scene::load` produces from a validated scene document (docs/scene-format.md).
//!
//! Everything here is resolved: material names are indices, files are read, transforms are applied
//! in f64 (world space), textures are decoded to linear RGBA f32. The GPU compile step
//! (`crate::compile`) turns this into camera-relative f32 buffers; nothing here knows about Vulkan.

use glam::{DMat4, DVec3, Vec2, Vec3};

/// A fully loaded scene, in world space, f64 where precision matters.
#[derive(Debug, Clone)]
pub struct Scene {
    pub camera: Camera,
    pub film: Film,
    /// Materials by index; `material_names[i]` is the name of `materials[i]`.
    pub materials: Vec<Material>,
    pub material_names: Vec<String>,
    pub textures: Vec<Texture>,
    pub meshes: Vec<TriangleMesh>,
    pub spheres: Vec<Sphere>,
    /// The meshes of the top-level `definitions`, in their own frame (the definition's
    /// `transform` applied): rendered only through `instances`, each stored once however many
    /// instances place it.
    pub prototypes: Vec<TriangleMesh>,
    /// Objects of type `instance`: a prototype placed with a transform.
    pub instances: Vec<Instance>,
    pub lights: Vec<Light>,
    pub environment: Option<Environment>,
    /// The optional `render` section (defaults a job may override).
    pub render: RenderDefaults,
}

/// A prototype placed in the world (an `instance` object): small, whatever the mesh's size.
#[derive(Debug, Clone, PartialEq)]
pub struct Instance {
    /// Index into `Scene::prototypes`.
    pub prototype: u32,
    /// Object (the prototype's frame) to world, affine and invertible (validated), f64.
    pub to_world: DMat4,
    /// A material replacing every one of the prototype's (None: the prototype's own).
    pub material: Option<u32>,
}

impl Scene {
    /// What accel "auto" looks at ([`crate::accel::auto_choice`]).
    pub fn accel_size(&self) -> crate::accel::SceneSize {
        crate::accel::SceneSize {
            triangles: self.meshes.iter().map(|m| m.indices.len() as u64).sum(),
            instances: self.instances.len(),
        }
    }

    /// Triangles as rendered: the meshes' plus every instance's copy of its prototype's.
    pub fn instanced_triangles(&self) -> u64 {
        self.instances
            .iter()
            .map(|i| self.prototypes[i.prototype as usize].indices.len() as u64)
            .sum()
    }
}

#[derive(Debug, Clone)]
pub struct Camera {
    pub position: DVec3,
    pub look_at: DVec3,
    pub up: DVec3,
    /// Vertical field of view in degrees.
    pub fov_y: f64,
    pub aperture_radius: f64,
    pub focus_distance: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Filter {
    Box,
    Gaussian { stddev: f32 },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tonemap {
    Clamp,
    Reinhard,
    Aces,
}

#[derive(Debug, Clone)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub filter: Filter,
    pub exposure: f32,
    pub tonemap: Tonemap,
}

/// A colour parameter: constant linear RGB or a texture (index into `Scene::textures`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ColorParam {
    Const(Vec3),
    Texture(u32),
}

/// A scalar parameter: constant or a texture whose red channel is used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ScalarParam {
    Const(f32),
    Texture(u32),
}

#[derive(Debug, Clone, PartialEq)]
pub enum MaterialKind {
    Diffuse {
        reflectance: ColorParam,
    },
    /// `eta_k: None` means Fresnel = 1 (Mitsuba `material: "none"`).
    Conductor {
        reflectance: ColorParam,
        roughness: ScalarParam,
        anisotropy: ScalarParam,
        eta_k: Option<(Vec3, Vec3)>,
    },
    Dielectric {
        ior: f32,
        roughness: ScalarParam,
        transmittance: ColorParam,
        reflectance: ColorParam,
    },
    Principled {
        base_color: ColorParam,
        metallic: ScalarParam,
        roughness: ScalarParam,
        specular: ScalarParam,
        spec_tint: ScalarParam,
        anisotropic: ScalarParam,
        sheen: ScalarParam,
        sheen_tint: ScalarParam,
        spec_trans: ScalarParam,
        /// Index of refraction; None: derived from `specular` as Mitsuba's principled does
        /// (specular 0.5 ⇔ ior 1.5).
        ior: Option<f32>,
        subsurface: ScalarParam,
        clearcoat: ScalarParam,
        clearcoat_gloss: ScalarParam,
    },
    Phong {
        diffuse: ColorParam,
        specular: ColorParam,
        exponent: f32,
    },
}

#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    pub kind: MaterialKind,
    /// Front-face emitted radiance (zero: not an emitter).
    pub emission: Vec3,
    /// Cut-out mask texture (cut where the mask's red channel < 0.5).
    pub alpha_mask: Option<u32>,
    pub two_sided: bool,
}

/// A decoded texture: linear RGBA f32, row 0 at the top (v = 1 at the top, OBJ convention:
/// texel row = (1 - v) * height).
#[derive(Debug, Clone)]
pub struct Texture {
    /// Where it came from, for error messages and the cache key.
    pub source: String,
    pub width: u32,
    pub height: u32,
    /// Shared, not copied, by the textures of one image (another scale or channel of the same
    /// file reads it anew) and by scenes derived from this one (instances written out).
    pub texels: std::sync::Arc<[[f32; 4]]>,
    /// UV scale from the scene's `scale` field.
    pub scale: Vec2,
}

/// Triangles in world space. Quads, boxes, inline triangles and mesh files all end up here.
#[derive(Debug, Clone)]
pub struct TriangleMesh {
    /// Where it came from (`objects[3]` or `objects[3] (bunny.ply)`), for messages.
    pub name: String,
    pub positions: Vec<DVec3>,
    /// Per-vertex shading normals (world space, normalised), if smooth shading applies.
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    pub indices: Vec<[u32; 3]>,
    /// Material per triangle (same length as `indices`); OBJ `usemtl` can vary it.
    pub materials: Vec<u32>,
}

#[derive(Debug, Clone)]
pub struct Sphere {
    pub center: DVec3,
    pub radius: f64,
    pub flip_normals: bool,
    pub material: u32,
}

#[derive(Debug, Clone, PartialEq)]
pub enum Light {
    /// Intensity in W/sr.
    Point { position: DVec3, intensity: Vec3 },
    /// `direction` is normalised (position → look_at); angles in degrees.
    Spot {
        position: DVec3,
        direction: DVec3,
        intensity: Vec3,
        cutoff_angle: f32,
        beam_width: f32,
    },
    /// `direction` is normalised: the way light travels.
    Directional { direction: DVec3, irradiance: Vec3 },
}

#[derive(Debug, Clone)]
pub enum Environment {
    Constant {
        radiance: Vec3,
    },
    /// Equirectangular radiance map (index into `Scene::textures`), +Y up, centre column looking
    /// down −Z; `rotate_y` in degrees.
    Map {
        texture: u32,
        scale: f32,
        rotate_y: f32,
    },
}

/// The values of `render.light_sampler`: lights picked ∝ power, or by a light BVH from the
/// shading point.
pub const LIGHT_SAMPLERS: [&str; 2] = ["power", "bvh"];

#[derive(Debug, Clone, Default, PartialEq)]
pub struct RenderDefaults {
    pub integrator: Option<String>,
    pub max_depth: Option<i32>,
    pub spp: Option<u32>,
    /// Acceleration structure: "auto", "bvh", "cwbvh" or "grid" (None: auto); see docs/accel.md.
    pub accel: Option<String>,
    /// Grid cells along the longest axis of the scene box (None: automatic).
    pub grid_resolution: Option<u32>,
    /// How next-event estimation picks lights: "power" (None: the default) or "bvh"
    /// (renderer/src/compile/light_bvh.rs).
    pub light_sampler: Option<String>,
}

impl RenderDefaults {
    /// The scene's acceleration-structure request, for [`crate::accel::AccelOptions::resolve`].
    pub fn accel_request(&self) -> crate::accel::AccelRequest<'_> {
        crate::accel::AccelRequest {
            kind: self.accel.as_deref(),
            grid_resolution: self.grid_resolution,
        }
    }
}
