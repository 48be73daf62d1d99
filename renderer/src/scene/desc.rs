//! The scene document as written (docs/scene-format.md, version 1): serde structs, every one with
//! `deny_unknown_fields`. Nothing here is validated beyond JSON types; `validate`, `materials` and
//! `assemble` turn it into the loaded `Scene`. Optional fields stay `Option` so that defaults that
//! depend on other fields (beam width, focus distance, sRGB by file type) are applied in one place.
//!
//! Objects with a `"type"` tag (materials, objects, lights, environment, filter) are deserialised
//! in `desc_tagged`, which keeps JSON paths intact inside them.

use serde::Deserialize;

pub use super::desc_values::{
    Channel, ColorDesc, NumList, OrderedMap, ScalarDesc, TextureRefDesc, Triple, Version,
};

/// `[x, y, z]`.
pub type V3 = [f64; 3];

/// The whole document.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDesc {
    pub version: Version,
    pub camera: CameraDesc,
    #[serde(default)]
    pub film: FilmDesc,
    pub materials: OrderedMap<MaterialDesc>,
    pub objects: Vec<ObjectDesc>,
    /// Named geometry that is not rendered by itself, only through `instance` objects.
    #[serde(default)]
    pub definitions: Option<OrderedMap<ObjectDesc>>,
    #[serde(default)]
    pub lights: Vec<LightDesc>,
    #[serde(default)]
    pub environment: Option<EnvironmentDesc>,
    #[serde(default)]
    pub render: Option<RenderDesc>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    pub position: V3,
    pub look_at: V3,
    #[serde(default)]
    pub up: Option<V3>,
    #[serde(default)]
    pub fov_y: Option<f64>,
    #[serde(default)]
    pub aperture_radius: Option<f64>,
    #[serde(default)]
    pub focus_distance: Option<f64>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilmDesc {
    #[serde(default)]
    pub width: Option<u32>,
    #[serde(default)]
    pub height: Option<u32>,
    #[serde(default)]
    pub filter: Option<FilterDesc>,
    #[serde(default)]
    pub exposure: Option<f64>,
    #[serde(default)]
    pub tonemap: Option<TonemapDesc>,
}

/// `"box"`, `"gaussian"` or `{"type": "gaussian", "stddev": 0.5}`.
#[derive(Debug, Clone, PartialEq)]
pub enum FilterDesc {
    Box,
    Gaussian { stddev: Option<f64> },
}

#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TonemapDesc {
    Clamp,
    Reinhard,
    Aces,
}

/// A material: the fields every type shares plus the type's own.
#[derive(Debug, Clone)]
pub struct MaterialDesc {
    pub common: MaterialCommon,
    pub kind: MaterialKindDesc,
}

/// Fields every material type accepts.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialCommon {
    #[serde(default)]
    pub emission: Option<Triple>,
    #[serde(default)]
    pub alpha_mask: Option<TextureRefDesc>,
    #[serde(default)]
    pub two_sided: Option<bool>,
}

#[derive(Debug, Clone)]
pub enum MaterialKindDesc {
    Diffuse(DiffuseDesc),
    Conductor(ConductorDesc),
    Dielectric(DielectricDesc),
    Principled(Box<PrincipledDesc>),
    Phong(PhongDesc),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiffuseDesc {
    #[serde(default)]
    pub reflectance: Option<ColorDesc>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConductorDesc {
    #[serde(default)]
    pub reflectance: Option<ColorDesc>,
    #[serde(default)]
    pub roughness: Option<ScalarDesc>,
    #[serde(default)]
    pub anisotropy: Option<ScalarDesc>,
    #[serde(default)]
    pub eta: Option<Triple>,
    #[serde(default)]
    pub k: Option<Triple>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DielectricDesc {
    #[serde(default)]
    pub ior: Option<f64>,
    #[serde(default)]
    pub roughness: Option<ScalarDesc>,
    #[serde(default)]
    pub transmittance: Option<ColorDesc>,
    #[serde(default)]
    pub reflectance: Option<ColorDesc>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PrincipledDesc {
    #[serde(default)]
    pub base_color: Option<ColorDesc>,
    #[serde(default)]
    pub metallic: Option<ScalarDesc>,
    #[serde(default)]
    pub roughness: Option<ScalarDesc>,
    #[serde(default)]
    pub specular: Option<ScalarDesc>,
    #[serde(default)]
    pub spec_tint: Option<ScalarDesc>,
    #[serde(default)]
    pub anisotropic: Option<ScalarDesc>,
    #[serde(default)]
    pub sheen: Option<ScalarDesc>,
    #[serde(default)]
    pub sheen_tint: Option<ScalarDesc>,
    #[serde(default)]
    pub spec_trans: Option<ScalarDesc>,
    #[serde(default)]
    pub ior: Option<f64>,
    #[serde(default)]
    pub subsurface: Option<ScalarDesc>,
    #[serde(default)]
    pub clearcoat: Option<ScalarDesc>,
    #[serde(default)]
    pub clearcoat_gloss: Option<ScalarDesc>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhongDesc {
    #[serde(default)]
    pub diffuse: Option<ColorDesc>,
    #[serde(default)]
    pub specular: Option<ColorDesc>,
    #[serde(default)]
    pub exponent: Option<f64>,
}

/// An object: the shared fields plus its shape.
#[derive(Debug, Clone)]
pub struct ObjectDesc {
    pub common: ObjectCommon,
    pub shape: ShapeDesc,
}

/// Fields every object type accepts.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectCommon {
    #[serde(default)]
    pub material: Option<String>,
    #[serde(default)]
    pub transform: Option<TransformDesc>,
}

#[derive(Debug, Clone)]
pub enum ShapeDesc {
    Mesh(MeshDesc),
    Triangles(TrianglesDesc),
    Sphere(SphereDesc),
    Quad(QuadDesc),
    Box(BoxDesc),
    Instance(InstanceDesc),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshDesc {
    pub file: String,
    #[serde(default)]
    pub smooth: Option<bool>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrianglesDesc {
    pub positions: NumList,
    pub indices: NumList,
    #[serde(default)]
    pub normals: Option<NumList>,
    #[serde(default)]
    pub uvs: Option<NumList>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereDesc {
    pub center: V3,
    pub radius: f64,
    #[serde(default)]
    pub flip_normals: Option<bool>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuadDesc {
    pub origin: V3,
    pub edge_u: V3,
    pub edge_v: V3,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxDesc {
    pub min: V3,
    pub max: V3,
}

/// An instance of a named definition (top-level `definitions`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InstanceDesc {
    pub definition: String,
}

/// `{"matrix": [16 numbers, row-major]}` or any of scale / rotate / translate.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformDesc {
    #[serde(default)]
    pub matrix: Option<[f64; 16]>,
    #[serde(default)]
    pub scale: Option<Triple>,
    #[serde(default)]
    pub rotate: Option<RotateDesc>,
    #[serde(default)]
    pub translate: Option<V3>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotateDesc {
    pub axis: V3,
    /// Degrees.
    pub angle: f64,
}

#[derive(Debug, Clone)]
pub enum LightDesc {
    Point(PointLightDesc),
    Spot(SpotLightDesc),
    Directional(DirectionalLightDesc),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointLightDesc {
    pub position: V3,
    pub intensity: Triple,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpotLightDesc {
    pub position: V3,
    pub look_at: V3,
    pub intensity: Triple,
    #[serde(default)]
    pub cutoff_angle: Option<f64>,
    #[serde(default)]
    pub beam_width: Option<f64>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DirectionalLightDesc {
    pub direction: V3,
    pub irradiance: Triple,
}

#[derive(Debug, Clone)]
pub enum EnvironmentDesc {
    Constant(ConstantEnvDesc),
    Map(MapEnvDesc),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstantEnvDesc {
    pub radiance: Triple,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapEnvDesc {
    pub file: String,
    #[serde(default)]
    pub scale: Option<f64>,
    #[serde(default)]
    pub rotate_y: Option<f64>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderDesc {
    #[serde(default)]
    pub integrator: Option<String>,
    #[serde(default)]
    pub max_depth: Option<i64>,
    #[serde(default)]
    pub spp: Option<u64>,
    #[serde(default)]
    pub accel: Option<String>,
    #[serde(default)]
    pub grid_resolution: Option<u64>,
    #[serde(default)]
    pub light_sampler: Option<String>,
}
