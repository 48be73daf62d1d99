//! Options of `vct` (`{"type": "vct", ...}`), their defaults and their validation. Every field
//! is optional; a bad value is rejected when the render starts, with an error naming the field.

use serde::{Deserialize, Serialize};

use crate::error::RenderError;
use crate::integrators::{OptionField, OptionsInfo};

/// Where the filtered voxels live.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum VctStorage {
    /// Sparse voxel octree: node pool + 3×3×3 brick pool (the default; any resolution).
    #[default]
    Octree,
    /// Dense 3D grid with an anisotropic mip chain (resolution ≤ [`DENSE_MAX_RESOLUTION`]).
    Dense,
}

/// How the direct light at shaded points is shadowed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum VctShadows {
    /// Shadow rays through the BVH (exact; the default).
    #[default]
    Rays,
    /// Shadow cones through the voxel volume (approximate, soft).
    Cone,
}

/// Options of `vct`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VctOptions {
    /// Mitsuba's max_depth: 1 = emitters seen directly, 2 = + exact direct light, ≥ 3 (or −1)
    /// = + cone-traced indirect light. Default: the scene's `render.max_depth`, else 6.
    pub max_depth: Option<i32>,
    /// Voxels per axis: a power of two, 128 to 1024 (64 is accepted for tests and previews).
    /// Default 128.
    pub resolution: Option<u32>,
    /// "octree" (default) or "dense".
    pub storage: Option<VctStorage>,
    /// Diffuse cones per shaded point (1..=32, default 6).
    pub cones: Option<u32>,
    /// Diffuse cones traced per sample (1..=cones, default 1): each sample traces this many
    /// consecutive directions of the `cones` spiral from a random one, weighted by
    /// cones / cones_per_sample, so the expected image is the same as with all of them and a
    /// frame is cheaper (on an H100 one cone per sample reached a lower error in equal time).
    pub cones_per_sample: Option<u32>,
    /// Full aperture of the diffuse cones in degrees (1..=120, default 60).
    pub cone_aperture: Option<f32>,
    /// Cone step as a fraction of the cone's diameter (0.1..=2, default 0.5).
    pub step: Option<f32>,
    /// Voxel bounces: 1 (direct light re-emitted by the voxels) or 2 (plus the first bounce's
    /// light re-injected). Default 1.
    pub bounces: Option<u32>,
    /// "rays" (default) or "cone".
    pub shadows: Option<VctShadows>,
    /// Render ambient occlusion instead of radiance (default false).
    pub ao: Option<bool>,
    /// Reach of the occlusion cones in scene units (default: an eighth of the grid's side).
    pub ao_distance: Option<f32>,
    /// Light samples per voxel for the injection (1..=1024, default 8: with the samples spread
    /// by a low-discrepancy sequence (inject.comp), 8 leave the injected radiance as noisy as 16
    /// independent ones did, at half the shadow rays; bench/RESULTS.md).
    pub inject_samples: Option<u32>,
    /// Coarsest level the cones read (0 = the voxels; default log2(resolution) − 4, i.e. cells
    /// of 1/16 of the grid). Past the diameter of that level's cells a cone keeps its footprint
    /// and steps by it. Coarse cells average a wall with what lies behind it, so walls thinner
    /// than 2^max_level voxels can leak light; lower values leak less and cost more steps.
    pub max_level: Option<u32>,
}

impl OptionsInfo for VctOptions {
    const FIELDS: &'static [OptionField] = &[
        OptionField {
            name: "max_depth",
            kind: "integer",
            help: "1 = emitters, 2 = + exact direct light, >= 3 or -1 = + cone-traced indirect light (default: the scene's render.max_depth, else 6)",
        },
        OptionField {
            name: "resolution",
            kind: "integer",
            help: "voxels per axis, a power of two 128..=1024, 64 for previews (default 128)",
        },
        OptionField {
            name: "storage",
            kind: "\"octree\" | \"dense\"",
            help: "sparse voxel octree (default) or dense mip volume (resolution <= 256)",
        },
        OptionField {
            name: "cones",
            kind: "integer",
            help: "diffuse cones per shaded point, 1..=32 (default 6)",
        },
        OptionField {
            name: "cones_per_sample",
            kind: "integer",
            help: "diffuse cones traced per sample, 1..=cones (default 1): a random run of them, weighted so the expected image is the same as with all",
        },
        OptionField {
            name: "cone_aperture",
            kind: "number",
            help: "full aperture of the diffuse cones in degrees, 1..=120 (default 60)",
        },
        OptionField {
            name: "step",
            kind: "number",
            help: "cone step as a fraction of the cone's diameter, 0.1..=2 (default 0.5)",
        },
        OptionField {
            name: "bounces",
            kind: "integer",
            help: "voxel bounces, 1 or 2 (default 1)",
        },
        OptionField {
            name: "shadows",
            kind: "\"rays\" | \"cone\"",
            help: "shadows of the direct light: BVH rays (default) or cones",
        },
        OptionField {
            name: "ao",
            kind: "boolean",
            help: "render ambient occlusion instead of radiance (default false)",
        },
        OptionField {
            name: "ao_distance",
            kind: "number",
            help: "reach of the occlusion cones in scene units (default: an eighth of the grid's side)",
        },
        OptionField {
            name: "inject_samples",
            kind: "integer",
            help: "light samples per voxel for the injection, 1..=1024 (default 8)",
        },
        OptionField {
            name: "max_level",
            kind: "integer",
            help: "coarsest level the cones read (default log2(resolution) - 4)",
        },
    ];
    fn max_depth(&self) -> Option<i32> {
        self.max_depth
    }
    fn set_max_depth(&mut self, d: i32) {
        self.max_depth = Some(d);
    }
    fn validate(&self) -> Result<(), RenderError> {
        self.settings().map(|_| ())
    }
}

/// Largest resolution the dense storage accepts (its level 0 alone is R³ cells).
pub const DENSE_MAX_RESOLUTION: u32 = 256;

/// The options with defaults filled in and checked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    pub resolution: u32,
    pub storage: VctStorage,
    pub cones: u32,
    pub cones_per_sample: u32,
    pub cone_aperture_deg: f32,
    pub step: f32,
    pub bounces: u32,
    pub shadows: VctShadows,
    pub ao: bool,
    pub ao_distance: Option<f32>,
    pub inject_samples: u32,
    pub max_level: u32,
}

fn bad(field: &str, msg: String) -> RenderError {
    RenderError::Invalid(format!("integrator.{field}: {msg}"))
}

impl VctOptions {
    /// Fills in defaults and rejects out-of-range values, naming the field.
    pub fn settings(&self) -> Result<Settings, RenderError> {
        let resolution = self.resolution.unwrap_or(128);
        if !resolution.is_power_of_two() || !(64..=1024).contains(&resolution) {
            return Err(bad(
                "resolution",
                format!("must be a power of two from 128 to 1024 (64 for tests), got {resolution}"),
            ));
        }
        let storage = self.storage.unwrap_or_default();
        if storage == VctStorage::Dense && resolution > DENSE_MAX_RESOLUTION {
            return Err(bad(
                "storage",
                format!(
                    "\"dense\" holds at most {DENSE_MAX_RESOLUTION}³ voxels (got resolution \
                     {resolution}); use \"octree\""
                ),
            ));
        }
        let cones = self.cones.unwrap_or(6);
        if !(1..=32).contains(&cones) {
            return Err(bad("cones", format!("must be 1..=32, got {cones}")));
        }
        let cones_per_sample = self.cones_per_sample.unwrap_or(1);
        if !(1..=cones).contains(&cones_per_sample) {
            return Err(bad(
                "cones_per_sample",
                format!("must be 1..=cones ({cones}), got {cones_per_sample}"),
            ));
        }
        let cone_aperture_deg = self.cone_aperture.unwrap_or(60.0);
        if !(1.0..=120.0).contains(&cone_aperture_deg) {
            return Err(bad(
                "cone_aperture",
                format!("must be 1..=120 degrees, got {cone_aperture_deg}"),
            ));
        }
        let step = self.step.unwrap_or(0.5);
        if !(0.1..=2.0).contains(&step) {
            return Err(bad("step", format!("must be 0.1..=2, got {step}")));
        }
        let bounces = self.bounces.unwrap_or(1);
        if !(1..=2).contains(&bounces) {
            return Err(bad("bounces", format!("must be 1 or 2, got {bounces}")));
        }
        if let Some(d) = self.ao_distance {
            if !(d > 0.0 && d.is_finite()) {
                return Err(bad("ao_distance", format!("must be positive, got {d}")));
            }
        }
        let inject_samples = self.inject_samples.unwrap_or(8);
        if !(1..=1024).contains(&inject_samples) {
            return Err(bad(
                "inject_samples",
                format!("must be 1..=1024, got {inject_samples}"),
            ));
        }
        let levels = resolution.trailing_zeros();
        let max_level = self.max_level.unwrap_or(levels - 4);
        if max_level >= levels {
            return Err(bad(
                "max_level",
                format!("must be below log2(resolution) = {levels}, got {max_level}"),
            ));
        }
        Ok(Settings {
            resolution,
            storage,
            cones,
            cones_per_sample,
            cone_aperture_deg,
            step,
            bounces,
            shadows: self.shadows.unwrap_or_default(),
            ao: self.ao.unwrap_or(false),
            ao_distance: self.ao_distance,
            inject_samples,
            max_level,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_and_errors_name_the_field() {
        let s = VctOptions::default().settings().unwrap();
        assert_eq!(
            (s.resolution, s.storage, s.cones, s.bounces),
            (128, VctStorage::Octree, 6, 1)
        );
        let o: VctOptions =
            serde_json::from_str(r#"{"resolution":256,"storage":"dense","shadows":"cone"}"#)
                .unwrap();
        assert_eq!(o.settings().unwrap().shadows, VctShadows::Cone);
        for (json, field) in [
            (r#"{"resolution":100}"#, "resolution"),
            (r#"{"resolution":512,"storage":"dense"}"#, "storage"),
            (r#"{"bounces":3}"#, "bounces"),
            (r#"{"cones":0}"#, "cones"),
            (r#"{"cones":4,"cones_per_sample":5}"#, "cones_per_sample"),
        ] {
            let o: VctOptions = serde_json::from_str(json).unwrap();
            let e = o.settings().unwrap_err().to_string();
            assert!(e.contains(field), "{json}: {e}");
        }
        assert!(serde_json::from_str::<VctOptions>(r#"{"storage":"sparse"}"#).is_err());
        assert!(serde_json::from_str::<VctOptions>(r#"{"resolutoin":128}"#).is_err());
    }
}
