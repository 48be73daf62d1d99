//! `whitted`: classic Whitted ray tracing (Whitted 1980, "An Improved Illumination Model for
//! Shaded Display"), made to agree with the physically based integrators wherever it can.
//! Kernel: shaders/whitted/whitted.comp (shade.glsl: material mapping; direct.glsl: shadow rays).
//! User documentation with measured figures: docs/whitted.md.
//!
//! # Algorithm
//! One thread per pixel; per sample one camera ray, then an explicit, fixed-size stack of
//! weighted rays (no recursion): pop a ray, find its closest hit, add what it sees, push its
//! mirror-reflected and refracted continuations (both branches, each with its own weight, e.g.
//! F and 1 − F for glass). A specialised kernel of a scene whose materials cannot branch (no
//! conductor, dielectric or principled surface) has no stack: the camera ray is the whole tree.
//! At every hit:
//! - **Emission**: emitters show their radiance (front side, as pt/nee), at every depth.
//! - **Direct light** on the surface's non-mirror ("local") lobes, evaluated with the exact BSDF
//!   of shaders/common/bsdf: one shadow ray to every point, spot and directional light
//!   (intensity / distance² for point and spot lights: the physical inverse-square law, which is
//!   also what phong's distance attenuation is here), and `area_samples` shadow rays to every
//!   emissive triangle and sphere, at a fixed point set (below). Shadow rays stop at any
//!   surface, glass included (opaque shadows, no caustics). Cost: `area_samples` rays per
//!   emissive triangle per hit, so large emissive meshes want a small `area_samples`. On
//!   lavapipe, whose llvmpipe ends an invocation's loops after 65535 iterations in all, a
//!   dispatch of many such samples would be silently truncated: the session splits passes
//!   there (`render::LLVMPIPE_MAX_DISPATCHES`, docs/whitted.md).
//! - **Ambient**: the environment radiance in the direction of the shading normal times the
//!   local lobes' albedo, no shadow ray. For a constant environment and an unoccluded diffuse
//!   surface this is exact (albedo × L_env); occlusion is ignored and an environment map is
//!   sampled only along the normal (not integrated over the hemisphere).
//! - Rays that leave the scene see the environment.
//!
//! # max_depth (Mitsuba's meaning)
//! Segments of a ray chain: 1 = only emitters (and the environment) seen directly; 2 = + direct
//! light and ambient at the first hit, and emitters seen in one mirror/refraction; each further
//! step one more specular bounce. −1 and values above [`DEPTH_CAP`] mean [`DEPTH_CAP`]. A branch
//! whose weight falls below [`MIN_WEIGHT`] (largest RGB component) is not followed.
//!
//! # Materials: their classic equivalents
//! - `diffuse`, `phong`: local only (Lambert; phong's diffuse + energy-normalised specular
//!   highlight). Ambient albedo: reflectance, resp. diffuse + specular.
//! - `conductor` with roughness below `mirror_roughness`: a perfect mirror weighted by
//!   reflectance × its Fresnel at the actual angle (eta/k given; else 1). Rougher: local only
//!   (the exact rough conductor lit by every light; no reflections of other objects), ambient
//!   albedo reflectance × F(normal incidence).
//! - `dielectric`, any roughness (roughness is ignored): reflection weighted by
//!   specular reflectance × F and refraction by transmittance × (1 − F) / η² (radiance
//!   compression, as Mitsuba), both followed; total internal reflection reflects all.
//! - `principled` with roughness below `mirror_roughness`: Lambertian diffuse
//!   base_color·(1 − metallic)·(1 − spec_trans) lit locally, a mirror weighted by
//!   (1 − metallic)·F_dielectric(η) + metallic·Schlick(base_color), and with spec_trans a
//!   refraction weighted by (1 − metallic)·spec_trans·(1 − F)·√base_color / η²; sheen,
//!   clearcoat and subsurface are dropped. Rougher: local only, the full principled BSDF.
//!
//! With local lobes evaluated exactly, `whitted` equals `nee` at max_depth 2 in scenes lit by
//! delta lights only (tests/tests/whitted.rs checks it); it has no indirect diffuse light, so
//! closed scenes come out darker.
//!
//! # Determinism and its bias
//! The only random numbers are the pixel-filter offsets of the camera rays (and the lens
//! position of a thin-lens camera): shading is deterministic, so 1 spp and 64 spp give the
//! same image apart from anti-aliasing. With `jitter: false` every sample is the ray through
//! the pixel centre (the lens centre), and the image does not depend on the sample count or
//! seed at all. Area lights are integrated with a fixed quadrature: `area_samples` points per
//! light from a Hammersley set ((j + ½)/N, radical inverse of j shifted by ½/N), warped like
//! nee's light sampling (uniform by area on triangles, uniform in the subtended cone on
//! spheres). This estimate is biased: the error does not average away with more samples per
//! pixel, and it shows as banded penumbrae; it falls as `area_samples` grows.
//!
//! # Options
//! `{"type": "whitted", "max_depth": 6, "area_samples": 16, "jitter": true,
//! "mirror_roughness": 0.2}`. All are compiled into the kernel as defines except max_depth.

use std::sync::Arc;

use super::{Integrator, OptionField, OptionsInfo};
use crate::compile::{CompiledScene, SceneConstants};
use crate::error::RenderError;
use crate::gpu::{
    Binding, ComputePipeline, Constant, GpuContext, GpuResult, Recorder, ShaderDefines,
};
use crate::layout::GpuPush;
use serde::{Deserialize, Serialize};

/// Most segments of a ray chain; also the ray stack's capacity (WHITTED_STACK), which a
/// depth-first traversal of at most DEPTH_CAP levels cannot overflow.
pub const DEPTH_CAP: i32 = 16;
/// Branches whose weight (largest RGB component) is below this are not followed
/// (WHITTED_MIN_WEIGHT in shaders/whitted/whitted.comp).
pub const MIN_WEIGHT: f32 = 1e-4;
/// Default points per area light.
pub const DEFAULT_AREA_SAMPLES: u32 = 16;
/// Largest `area_samples`.
pub const MAX_AREA_SAMPLES: u32 = 4096;
/// Default roughness below which conductors and principled specular lobes become mirrors.
pub const DEFAULT_MIRROR_ROUGHNESS: f32 = 0.2;

/// Options of `whitted`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WhittedOptions {
    /// Mitsuba's max_depth: 1 = emitters only, 2 = + direct light, each further step one more
    /// specular bounce; −1 (and anything above [`DEPTH_CAP`]) = [`DEPTH_CAP`]. Default: the
    /// scene's `render.max_depth`, else 6.
    pub max_depth: Option<i32>,
    /// Fixed shadow-ray points per emissive triangle or sphere (1..=4096, default 16).
    pub area_samples: Option<u32>,
    /// Pixel-filter jitter of the camera rays (default true); false: pixel centres only.
    pub jitter: Option<bool>,
    /// Roughness below which conductors and principled materials reflect as perfect mirrors
    /// (default 0.2); at or above it they are lit locally with their exact BSDF.
    pub mirror_roughness: Option<f32>,
}

impl OptionsInfo for WhittedOptions {
    const FIELDS: &'static [OptionField] = &[
        OptionField {
            name: "max_depth",
            kind: "integer",
            help: "Mitsuba's max_depth; each step past 2 is one more specular bounce; -1 = the cap (default: the scene's render.max_depth, else 6)",
        },
        OptionField {
            name: "area_samples",
            kind: "integer",
            help: "fixed shadow-ray points per emissive triangle or sphere, 1..=4096 (default 16)",
        },
        OptionField {
            name: "jitter",
            kind: "boolean",
            help: "pixel-filter jitter of camera rays (default true); false: pixel centres",
        },
        OptionField {
            name: "mirror_roughness",
            kind: "number",
            help: "roughness below which conductors and principled surfaces reflect as mirrors (default 0.2)",
        },
    ];
    fn max_depth(&self) -> Option<i32> {
        self.max_depth
    }
    fn set_max_depth(&mut self, d: i32) {
        self.max_depth = Some(d);
    }
    fn validate(&self) -> Result<(), RenderError> {
        new(self, None).validate()
    }
}

/// The integrator with its options resolved.
pub struct WhittedIntegrator {
    max_depth: i32,
    area_samples: u32,
    jitter: bool,
    mirror_roughness: f32,
}

/// Builds `whitted` from its options (checked in [`WhittedIntegrator::validate`]).
pub fn new(o: &WhittedOptions, scene_max_depth: Option<i32>) -> WhittedIntegrator {
    WhittedIntegrator {
        max_depth: o.max_depth.or(scene_max_depth).unwrap_or(6),
        area_samples: o.area_samples.unwrap_or(DEFAULT_AREA_SAMPLES),
        jitter: o.jitter.unwrap_or(true),
        mirror_roughness: o.mirror_roughness.unwrap_or(DEFAULT_MIRROR_ROUGHNESS),
    }
}

impl WhittedIntegrator {
    /// Checks the options, naming the offending field.
    pub fn validate(&self) -> Result<(), RenderError> {
        if !(1..=MAX_AREA_SAMPLES).contains(&self.area_samples) {
            return Err(RenderError::Invalid(format!(
                "area_samples: must be between 1 and {MAX_AREA_SAMPLES}, got {}",
                self.area_samples
            )));
        }
        if !(self.mirror_roughness.is_finite() && self.mirror_roughness >= 0.0) {
            return Err(RenderError::Invalid(format!(
                "mirror_roughness: must be a number >= 0, got {}",
                self.mirror_roughness
            )));
        }
        if self.max_depth < -1 {
            return Err(RenderError::Invalid(format!(
                "max_depth: must be -1 (unbounded) or >= 0, got {}",
                self.max_depth
            )));
        }
        Ok(())
    }

    /// max_depth as the kernel runs it: −1 and values above [`DEPTH_CAP`] become DEPTH_CAP.
    pub fn effective_depth(&self) -> i32 {
        if self.max_depth < 0 || self.max_depth > DEPTH_CAP {
            DEPTH_CAP
        } else {
            self.max_depth
        }
    }
}

/// `x`, or 0 where it is NaN or infinite (so a bad value still compiles; setup reports it).
fn finite_or_zero(x: f32) -> f32 {
    if x.is_finite() {
        x
    } else {
        0.0
    }
}

impl Integrator for WhittedIntegrator {
    fn max_depth(&self) -> i32 {
        self.max_depth
    }
    fn defines(&self) -> ShaderDefines {
        vec![
            ("WHITTED_STACK".into(), DEPTH_CAP.to_string()),
            ("WHITTED_MIN_WEIGHT".into(), format!("{:e}", MIN_WEIGHT)),
            // Clamped so that bad values still compile; setup() reports them.
            (
                "WHITTED_AREA_SAMPLES".into(),
                format!("{}u", self.area_samples.clamp(1, MAX_AREA_SAMPLES)),
            ),
            (
                "WHITTED_JITTER".into(),
                if self.jitter { "1" } else { "0" }.into(),
            ),
            (
                "WHITTED_MIRROR_ROUGHNESS".into(),
                format!(
                    "{:?}",
                    finite_or_zero(self.mirror_roughness).clamp(0.0, 1e30)
                ),
            ),
            // shaders/whitted/shade.glsl lights the diffuse part of smooth principled
            // materials as a Lambertian lobe: the kernel needs that model whatever the scene's
            // own materials are (a specialised kernel compiles only the scene's).
            ("HAS_MAT_DIFFUSE".into(), "1".into()),
        ]
    }
    fn setup(
        &mut self,
        _ctx: &Arc<GpuContext>,
        _scene: &CompiledScene,
        _shared: &[Binding<'_>],
        _defines: &ShaderDefines,
    ) -> Result<(), RenderError> {
        self.validate()
    }
    fn constants(&self, scene: &SceneConstants) -> ShaderDefines {
        let mut c = scene.all();
        c.push(Constant::Int(self.effective_depth()).define("PASS_MAX_DEPTH"));
        c
    }
    fn details(&self) -> Option<serde_json::Value> {
        Some(serde_json::json!({
            "max_depth": self.effective_depth(),
            "area_samples": self.area_samples,
            "jitter": self.jitter,
            "mirror_roughness": self.mirror_roughness,
            "min_weight": MIN_WEIGHT,
        }))
    }
    fn record_pass(
        &self,
        rec: &mut Recorder<'_>,
        pipeline: &ComputePipeline,
        mut push: GpuPush,
        groups: [u32; 3],
    ) -> GpuResult<()> {
        push.max_depth = self.effective_depth();
        rec.dispatch(pipeline, bytemuck::bytes_of(&push), groups, "whitted pass")
    }
}

#[cfg(test)]
mod tests {
    use super::super::IntegratorOptions;
    use super::*;

    #[test]
    fn whitted_options_parse_validate_and_reject_unknown_fields() {
        let o: IntegratorOptions = serde_json::from_str(
            r#"{"type":"whitted","max_depth":3,"area_samples":4,"jitter":false,"mirror_roughness":0.1}"#,
        )
        .unwrap();
        let IntegratorOptions::Whitted(w) = o else {
            panic!("{o:?}")
        };
        assert_eq!(w.area_samples, Some(4));
        let i = new(&w, None);
        assert!(i.validate().is_ok());
        assert_eq!(i.effective_depth(), 3);
        let e = serde_json::from_str::<IntegratorOptions>(r#"{"type":"whitted","area_sample":4}"#)
            .unwrap_err();
        assert!(e.to_string().contains("area_sample"), "{e}");
        let bad = new(
            &WhittedOptions {
                area_samples: Some(0),
                ..Default::default()
            },
            None,
        );
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("area_samples"), "{e}");
        let unbounded = new(
            &WhittedOptions {
                max_depth: Some(-1),
                ..Default::default()
            },
            Some(4),
        );
        assert_eq!(unbounded.effective_depth(), DEPTH_CAP);
    }
}
