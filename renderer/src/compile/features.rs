//! What a scene uses, so that its kernels model only that ("model only what a scene requires"):
//! each flag becomes a `#define HAS_*` for every kernel the scene's renders compile, and buffers of
//! absent features are left at their 16-byte minimum. [`FeatureSet::GENERIC`] has every flag on:
//! the generic kernel (`--kernels generic`) that any scene can run, kept for comparison.
//!
//! Only what the primitives reach counts: a material defined but assigned to nothing adds no
//! BSDF code.

use serde::Serialize;

use crate::gpu::ShaderDefines;
use crate::scene::{ColorParam, Environment, MaterialKind, ScalarParam, Scene};

/// The features a kernel is compiled for.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize)]
pub struct FeatureSet {
    /// Analytic spheres (else triangles only).
    pub spheres: bool,
    /// Per-vertex normals or texture coordinates on some triangles.
    pub tri_shading: bool,
    /// Textured material parameters, alpha masks or an environment map.
    pub textures: bool,
    /// Alpha-masked (cut-out) primitives.
    pub alpha: bool,
    /// An environment, constant or a map: escaping rays see it and light sampling may pick it.
    pub environment: bool,
    /// An environment map (importance-sampled).
    pub env_map: bool,
    /// Point, spot or directional lights.
    pub delta_lights: bool,
    /// The material models the primitives use: only these BSDFs are compiled.
    pub mat_diffuse: bool,
    pub mat_conductor: bool,
    pub mat_dielectric: bool,
    pub mat_principled: bool,
    pub mat_phong: bool,
    /// Instances (`instance` objects): rays also walk the top-level BVH and the prototypes'
    /// BVHs (shaders/common/traverse.glsl). Off, the kernels have no trace of instancing.
    pub instances: bool,
}

/// Which kernels a render compiles.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum KernelMode {
    /// Specialised to the scene's [`FeatureSet`] (the default).
    #[default]
    Specialized,
    /// Every feature compiled in ([`FeatureSet::GENERIC`]), whatever the scene uses.
    Generic,
}

impl KernelMode {
    /// Every mode's name, as the CLI and jobs spell it.
    pub const NAMES: [&'static str; 2] = ["specialized", "generic"];

    pub fn from_name(name: &str) -> Option<KernelMode> {
        match name {
            "specialized" => Some(KernelMode::Specialized),
            "generic" => Some(KernelMode::Generic),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }
}

impl FeatureSet {
    /// Every feature on: the kernel any scene can run.
    pub const GENERIC: FeatureSet = FeatureSet {
        spheres: true,
        tri_shading: true,
        textures: true,
        alpha: true,
        environment: true,
        env_map: true,
        delta_lights: true,
        mat_diffuse: true,
        mat_conductor: true,
        mat_dielectric: true,
        mat_principled: true,
        mat_phong: true,
        instances: true,
    };

    /// Each flag with its name in reports and its kernel define.
    fn flags(&self) -> [(bool, &'static str, &'static str); 13] {
        [
            (self.spheres, "spheres", "HAS_SPHERES"),
            (self.tri_shading, "tri_shading", "HAS_TRI_SHADING"),
            (self.textures, "textures", "HAS_TEXTURES"),
            (self.alpha, "alpha", "HAS_ALPHA"),
            (self.environment, "environment", "HAS_ENV"),
            (self.env_map, "env_map", "HAS_ENV_MAP"),
            (self.delta_lights, "delta_lights", "HAS_DELTA_LIGHTS"),
            (self.mat_diffuse, "mat_diffuse", "HAS_MAT_DIFFUSE"),
            (self.mat_conductor, "mat_conductor", "HAS_MAT_CONDUCTOR"),
            (self.mat_dielectric, "mat_dielectric", "HAS_MAT_DIELECTRIC"),
            (self.mat_principled, "mat_principled", "HAS_MAT_PRINCIPLED"),
            (self.mat_phong, "mat_phong", "HAS_MAT_PHONG"),
            (self.instances, "instances", "HAS_INSTANCES"),
        ]
    }

    /// The kernel defines for this set. `MATERIALS_SPECIALISED` tells the BSDF dispatch
    /// (shaders/common/bsdf/bsdf.glsl) to compile only the `HAS_MAT_*` models; kernels built
    /// without it (the test kernels) get every model.
    pub fn defines(&self) -> ShaderDefines {
        std::iter::once("MATERIALS_SPECIALISED")
            .chain(self.flags().into_iter().filter(|f| f.0).map(|f| f.2))
            .map(|n| (n.to_string(), "1".to_string()))
            .collect()
    }

    /// The features of `mode`: the scene's own, or every one (instancing only where the scene
    /// has instances: its buffers exist only then, and the generic kernel of a scene without
    /// them stays the one it always was).
    pub fn for_mode(self, mode: KernelMode) -> FeatureSet {
        match mode {
            KernelMode::Specialized => self,
            KernelMode::Generic => FeatureSet {
                instances: self.instances,
                ..FeatureSet::GENERIC
            },
        }
    }

    /// What `scene`'s primitives, lights and environment use.
    pub fn detect(scene: &Scene) -> FeatureSet {
        // The materials the primitives reach (a triangle without one gets material 0).
        let mut used = vec![false; scene.materials.len()];
        let mut mark = |m: u32| {
            if let Some(u) = used.get_mut(m as usize) {
                *u = true;
            }
        };
        for mesh in &scene.meshes {
            for t in 0..mesh.indices.len() {
                mark(mesh.materials.get(t).copied().unwrap_or(0));
            }
        }
        for s in &scene.spheres {
            mark(s.material);
        }
        // Instances reach their prototype's materials, or the one replacing them.
        // (Each prototype is looked at once, however many instances place it.)
        let mut instanced = vec![false; scene.prototypes.len()];
        let mut own_materials = vec![false; scene.prototypes.len()];
        for i in &scene.instances {
            instanced[i.prototype as usize] = true;
            match i.material {
                Some(m) => mark(m),
                None => own_materials[i.prototype as usize] = true,
            }
        }
        for (mesh, _) in scene.prototypes.iter().zip(&own_materials).filter(|p| *p.1) {
            for t in 0..mesh.indices.len() {
                mark(mesh.materials.get(t).copied().unwrap_or(0));
            }
        }
        let shaded = |m: &&crate::scene::TriangleMesh| {
            !m.indices.is_empty() && (m.normals.is_some() || m.uvs.is_some())
        };
        let mut f = FeatureSet {
            spheres: !scene.spheres.is_empty(),
            tri_shading: scene.meshes.iter().any(|m| shaded(&m))
                || scene
                    .prototypes
                    .iter()
                    .zip(&instanced)
                    .any(|(m, &u)| u && shaded(&m)),
            delta_lights: !scene.lights.is_empty(),
            environment: scene.environment.is_some(),
            instances: !scene.instances.is_empty(),
            ..Default::default()
        };
        for (m, _) in scene.materials.iter().zip(&used).filter(|(_, u)| **u) {
            f.alpha |= m.alpha_mask.is_some();
            f.textures |= m.alpha_mask.is_some() || kind_uses_textures(&m.kind);
            match m.kind {
                MaterialKind::Diffuse { .. } => f.mat_diffuse = true,
                MaterialKind::Conductor { .. } => f.mat_conductor = true,
                MaterialKind::Dielectric { .. } => f.mat_dielectric = true,
                MaterialKind::Principled { .. } => f.mat_principled = true,
                MaterialKind::Phong { .. } => f.mat_phong = true,
            }
        }
        if let Some(Environment::Map { texture, .. }) = &scene.environment {
            if scene.textures.get(*texture as usize).is_some() {
                f.env_map = true;
                f.textures = true;
            }
        }
        f
    }

    /// The names of the features that are on (`spheres`, `mat_diffuse`, ...), for reports.
    pub fn names(&self) -> Vec<&'static str> {
        self.flags()
            .into_iter()
            .filter(|f| f.0)
            .map(|f| f.1)
            .collect()
    }
}

/// Whether a material model has a textured parameter.
fn kind_uses_textures(k: &MaterialKind) -> bool {
    let c = |p: &ColorParam| matches!(p, ColorParam::Texture(_));
    let s = |p: &ScalarParam| matches!(p, ScalarParam::Texture(_));
    match k {
        MaterialKind::Diffuse { reflectance } => c(reflectance),
        MaterialKind::Conductor {
            reflectance,
            roughness,
            anisotropy,
            ..
        } => c(reflectance) || s(roughness) || s(anisotropy),
        MaterialKind::Dielectric {
            roughness,
            transmittance,
            reflectance,
            ..
        } => s(roughness) || c(transmittance) || c(reflectance),
        MaterialKind::Principled {
            base_color,
            metallic,
            roughness,
            specular,
            spec_tint,
            anisotropic,
            sheen,
            sheen_tint,
            spec_trans,
            subsurface,
            clearcoat,
            clearcoat_gloss,
            ..
        } => {
            c(base_color)
                || [
                    metallic,
                    roughness,
                    specular,
                    spec_tint,
                    anisotropic,
                    sheen,
                    sheen_tint,
                    spec_trans,
                    subsurface,
                    clearcoat,
                    clearcoat_gloss,
                ]
                .into_iter()
                .any(s)
        }
        MaterialKind::Phong {
            diffuse, specular, ..
        } => c(diffuse) || c(specular),
    }
}
