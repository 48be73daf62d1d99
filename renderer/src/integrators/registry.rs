//! The one list of integrators. Each is declared once, in [`integrators!`] below: its name, its
//! options type (a variant of [`IntegratorOptions`], the serde union jobs and `--options` are
//! parsed into), its pass kernel, whether it is unbiased, its documentation and its constructor.
//! Everything else reads this list: scene validation (`render.integrator`), the CLI's help and
//! `--integrator`, the server's `GET /api/integrators` and job validation, the benchmark, and the
//! web viewer's form (through the API).
//!
//! Adding an integrator: write its module (options type implementing [`OptionsInfo`], a
//! constructor returning an [`Integrator`]) and add one entry to the list.

use serde::Serialize;
use serde_json::Value;

use super::{bdpt, deferred, nee, pt, vct, whitted, BdptOptions, Integrator, PathOptions};
use crate::error::RenderError;

/// The integrator used when neither the job nor the scene names one.
pub const DEFAULT_INTEGRATOR: &str = "nee";

/// One integrator option, for help texts, the API and the web form.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct OptionField {
    /// The JSON field name.
    pub name: &'static str,
    /// Its JSON type as users write it: "integer", "number", "boolean", "[s, t]", or a list of
    /// accepted strings.
    pub kind: &'static str,
    /// What it does and its default.
    pub help: &'static str,
}

/// What every integrator's options type provides besides serde.
pub trait OptionsInfo {
    /// Every field, in declaration order (a test checks these against what serde accepts).
    const FIELDS: &'static [OptionField];
    /// Mitsuba's max_depth as given (None: the scene's `render.max_depth`, else the default).
    fn max_depth(&self) -> Option<i32>;
    /// Overrides max_depth (e.g. from `--max-depth`).
    fn set_max_depth(&mut self, d: i32);
    /// Checks values and combinations without a device, naming the field. Default: all valid.
    fn validate(&self) -> Result<(), RenderError> {
        Ok(())
    }
}

/// What the rest of candela knows about an integrator.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct IntegratorInfo {
    /// The name jobs, scenes and the CLI use.
    pub name: &'static str,
    /// One line: what it does.
    pub summary: &'static str,
    /// Converges to the exact image (for its max_depth) as samples grow.
    pub unbiased: bool,
    /// Its kernels pick lights with the light BVH where the scene has one
    /// (`render.light_sampler: "bvh"`: the session defines LIGHT_BVH for them,
    /// shaders/common/lights.glsl); false: they keep the power sampler whatever the scene says
    /// (an integrator whose MIS weights assume the power pick). All take it now.
    pub light_bvh: bool,
    /// Its paths can reach delta lights (point, spot, directional): false for pt, whose paths
    /// only find light by hitting it, so on a scene with delta lights it converges to another
    /// image (their light missing) and is no candidate for `auto`.
    pub delta_lights: bool,
    /// It renders scenes with instances (`instance` objects): its rays go through the shared
    /// traversal and surface code. False where it reads primitives by index on its own (vct's
    /// voxelisation, deferred's G-buffer passes): such scenes are refused with an error.
    pub instances: bool,
    /// The per-pass kernel, relative to shaders/ (its other stages live in the same folder).
    pub kernel: &'static str,
    /// Tiles of 8 × 8 threads per workgroup of its film kernels (`WG_TILES`,
    /// common/dispatch.glsl). The driver must fit one workgroup on an SM, so a workgroup of
    /// 64·n threads caps a kernel's registers at 65536 / (64·n): 10 tiles hold bdpt's kernels
    /// at 96 registers instead of the 167 the compiler picks alone, 20 resident warps per SM
    /// instead of 12: 12–41% more samples per second on nine project scenes, 4% fewer on the
    /// furnace (bench/RESULTS.md, "Register caps through the workgroup size"); 16 hold vct's
    /// gather at 64 registers, 32 warps per SM: +5..+20% on seven project scenes, 3% fewer on
    /// the furnace (bench/RESULTS.md, "Whitted's shadow-ray origins and vct's register cap").
    /// 1 where a cap was measured not to pay (pt, nee, whitted); deferred's kernels declare
    /// their own workgroups. Films below `render::dispatch::TILED_MIN_PIXELS` keep one tile
    /// (too few large workgroups to fill the GPU), and the device's workgroup limits lower it.
    pub workgroup_tiles: u32,
    /// Its documentation page in the repository, if it has one.
    pub doc: Option<&'static str>,
    /// Its options (besides `type`).
    pub options: &'static [OptionField],
}

/// Declares the integrators: the [`IntegratorOptions`] enum, the [`INTEGRATORS`] table and the
/// dispatch from options to name, info, constructor and option checks, all from one list.
macro_rules! integrators {
    ($(
        $variant:ident($opts:ty) {
            name: $name:literal,
            summary: $summary:literal,
            unbiased: $unbiased:literal,
            light_bvh: $light_bvh:literal,
            delta_lights: $delta_lights:literal,
            instances: $instances:literal,
            kernel: $kernel:literal,
            workgroup_tiles: $tiles:literal,
            doc: $doc:expr,
            build: $build:path $(,)?
        }
    )*) => {
        /// Which integrator, with its options: `{"type": NAME, ...fields}`, unknown fields
        /// refused.
        #[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
        #[serde(tag = "type", deny_unknown_fields)]
        pub enum IntegratorOptions {
            $(
                #[doc = $summary]
                #[serde(rename = $name)]
                $variant($opts),
            )*
        }

        /// Every integrator, in the order help texts and the viewer list them.
        pub const INTEGRATORS: &[IntegratorInfo] = &[$(
            IntegratorInfo {
                name: $name,
                summary: $summary,
                unbiased: $unbiased,
                light_bvh: $light_bvh,
                delta_lights: $delta_lights,
                instances: $instances,
                kernel: $kernel,
                workgroup_tiles: $tiles,
                doc: $doc,
                options: <$opts as OptionsInfo>::FIELDS,
            },
        )*];

        impl IntegratorOptions {
            /// Default options for an integrator name; None for an unknown name.
            pub fn from_name(name: &str) -> Option<Self> {
                match name {
                    $($name => Some(IntegratorOptions::$variant(<$opts>::default())),)*
                    _ => None,
                }
            }

            /// The integrator's name.
            pub fn name(&self) -> &'static str {
                match self {
                    $(IntegratorOptions::$variant(_) => $name,)*
                }
            }

            /// The options as their type's common interface.
            fn fields(&self) -> &dyn OptionsInfoDyn {
                match self {
                    $(IntegratorOptions::$variant(o) => o,)*
                }
            }

            fn fields_mut(&mut self) -> &mut dyn OptionsInfoDyn {
                match self {
                    $(IntegratorOptions::$variant(o) => o,)*
                }
            }

            /// Builds the integrator for these options; `scene_max_depth` is the scene's
            /// `render.max_depth` (the default of max_depth).
            pub fn build(&self, scene_max_depth: Option<i32>) -> Box<dyn Integrator> {
                match self {
                    $(IntegratorOptions::$variant(o) => Box::new($build(o, scene_max_depth)),)*
                }
            }
        }
    };
}

integrators! {
    Pt(PathOptions) {
        name: "pt",
        summary: "Path tracing with BSDF sampling only: the simplest unbiased reference.",
        unbiased: true,
        light_bvh: true,
        delta_lights: false,
        instances: true,
        kernel: "pt/pt.comp",
        workgroup_tiles: 1,
        doc: None,
        build: pt::new,
    }
    Nee(PathOptions) {
        name: "nee",
        summary: "Path tracing with next-event estimation and MIS (power heuristic).",
        unbiased: true,
        light_bvh: true,
        delta_lights: true,
        instances: true,
        kernel: "nee/nee.comp",
        workgroup_tiles: 1,
        doc: None,
        build: nee::new,
    }
    Bdpt(BdptOptions) {
        name: "bdpt",
        summary: "Bidirectional path tracing: every (s, t) strategy, MIS, light-tracing splats.",
        unbiased: true,
        light_bvh: true,
        delta_lights: true,
        instances: true,
        kernel: "bdpt/bdpt.comp",
        workgroup_tiles: 10,
        doc: None,
        build: bdpt::new,
    }
    Whitted(whitted::WhittedOptions) {
        name: "whitted",
        summary: "Whitted ray tracing: mirror and refraction recursion, shadow rays; deterministic.",
        unbiased: false,
        light_bvh: true,
        delta_lights: true,
        instances: true,
        kernel: "whitted/whitted.comp",
        workgroup_tiles: 1,
        doc: Some("docs/whitted.md"),
        build: whitted::new,
    }
    Deferred(deferred::DeferredOptions) {
        name: "deferred",
        summary: "Deferred many-light shading: packed G-buffer, tiled light culling.",
        unbiased: false,
        light_bvh: true,
        delta_lights: true,
        instances: false,
        kernel: "deferred/deferred.comp",
        workgroup_tiles: 1,
        doc: Some("docs/deferred.md"),
        build: deferred::new,
    }
    Vct(vct::VctOptions) {
        name: "vct",
        summary: "Voxel cone tracing over a GPU-built sparse voxel octree.",
        unbiased: false,
        light_bvh: true,
        delta_lights: true,
        instances: false,
        kernel: "vct/vct.comp",
        workgroup_tiles: 16,
        doc: Some("docs/vct.md"),
        build: vct::new,
    }
}

/// [`OptionsInfo`] without its associated constant, so that it can be a trait object.
trait OptionsInfoDyn {
    fn max_depth(&self) -> Option<i32>;
    fn set_max_depth(&mut self, d: i32);
    fn validate(&self) -> Result<(), RenderError>;
}

impl<T: OptionsInfo> OptionsInfoDyn for T {
    fn max_depth(&self) -> Option<i32> {
        OptionsInfo::max_depth(self)
    }
    fn set_max_depth(&mut self, d: i32) {
        OptionsInfo::set_max_depth(self, d)
    }
    fn validate(&self) -> Result<(), RenderError> {
        OptionsInfo::validate(self)
    }
}

/// Every integrator name, in [`INTEGRATORS`] order.
pub fn names() -> impl Iterator<Item = &'static str> {
    INTEGRATORS.iter().map(|i| i.name)
}

/// The registry entry of `name`.
pub fn info(name: &str) -> Option<&'static IntegratorInfo> {
    INTEGRATORS.iter().find(|i| i.name == name)
}

/// Why an integrator specification was refused: the JSON path of the offending value (relative
/// to the specification, "" for the whole) and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OptionsError {
    pub path: String,
    pub message: String,
}

impl std::fmt::Display for OptionsError {
    /// `path: message`, or the message alone for the whole specification.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.path.is_empty() {
            f.write_str(&self.message)
        } else {
            write!(f, "{}: {}", self.path, self.message)
        }
    }
}

impl std::error::Error for OptionsError {}

impl OptionsError {
    fn new(path: &str, message: impl Into<String>) -> Self {
        OptionsError {
            path: path.to_string(),
            message: message.into(),
        }
    }
}

fn unknown_name(name: &str) -> OptionsError {
    OptionsError::new(
        "",
        format!(
            "unknown integrator \"{name}\" (available: {})",
            names().collect::<Vec<_>>().join(", ")
        ),
    )
}

impl IntegratorOptions {
    /// The registry entry of these options' integrator.
    pub fn info(&self) -> &'static IntegratorInfo {
        info(self.name()).expect("every IntegratorOptions variant is in INTEGRATORS")
    }

    /// max_depth as given in the options (None: the scene's, else the integrator's default).
    pub fn max_depth(&self) -> Option<i32> {
        self.fields().max_depth()
    }

    /// Overrides max_depth (e.g. from `--max-depth`).
    pub fn set_max_depth(&mut self, d: i32) {
        self.fields_mut().set_max_depth(d)
    }

    /// Checks the options' values (ranges, combinations) without a device, naming the field, so
    /// that a server can refuse a job when it is submitted instead of failing it when it starts.
    /// `RenderSession::new` checks them again.
    pub fn validate(&self) -> Result<(), RenderError> {
        self.fields().validate()
    }

    /// Parses an integrator specification as jobs and the CLI write it: a name (`"nee"`) or an
    /// object (`{"type": "nee", "max_depth": 4}`); `null` means `default`. Unknown names and
    /// fields, wrong types and out-of-range values are refused, naming the field.
    pub fn parse(spec: &Value, default: &str) -> Result<IntegratorOptions, OptionsError> {
        let options = match spec {
            Value::Null => {
                IntegratorOptions::from_name(default).ok_or_else(|| unknown_name(default))?
            }
            Value::String(name) => {
                IntegratorOptions::from_name(name).ok_or_else(|| unknown_name(name))?
            }
            Value::Object(map) => {
                match map.get("type") {
                    Some(Value::String(name)) if info(name).is_none() => {
                        return Err(OptionsError {
                            path: "type".into(),
                            ..unknown_name(name)
                        })
                    }
                    Some(Value::String(_)) => {}
                    _ => {
                        return Err(OptionsError::new(
                            "type",
                            "missing or not a name (e.g. {\"type\": \"nee\"})",
                        ))
                    }
                }
                serde_json::from_value(spec.clone())
                    .map_err(|e| OptionsError::new("", tidy_serde_message(&e.to_string())))?
            }
            _ => {
                return Err(OptionsError::new(
                    "",
                    "expected a name (\"nee\") or an object ({\"type\": \"nee\", ...})",
                ))
            }
        };
        options.check()?;
        Ok(options)
    }

    /// [`Self::validate`] with the field at fault as a path: max_depth must be −1 or at least
    /// 1 for every integrator; the rest is the integrator's own checks.
    pub fn check(&self) -> Result<(), OptionsError> {
        if let Some(d) = self.max_depth() {
            if d == 0 || d < -1 {
                return Err(OptionsError::new(
                    "max_depth",
                    format!("must be -1 or at least 1, got {d}"),
                ));
            }
        }
        self.validate()
            .map_err(|e| OptionsError::new("", e.to_string()))
    }

    /// The integrator of a render: `spec` as [`Self::parse`] takes it, where `null` means the
    /// scene's `render.integrator` (`scene_default`), else [`DEFAULT_INTEGRATOR`]. An unknown
    /// scene default is refused with the path `render.integrator`.
    pub fn resolve(
        spec: &Value,
        scene_default: Option<&str>,
    ) -> Result<IntegratorOptions, OptionsError> {
        let default = scene_default.unwrap_or(DEFAULT_INTEGRATOR);
        if spec.is_null() && info(default).is_none() {
            return Err(OptionsError {
                path: "render.integrator".into(),
                ..unknown_name(default)
            });
        }
        IntegratorOptions::parse(spec, default)
    }

    /// The specification of the CLI's `--integrator NAME --options JSON`: the options object's
    /// fields with `type` = `name` (a contradicting `type` is refused).
    pub fn parse_named(
        name: &str,
        options: Option<&str>,
    ) -> Result<IntegratorOptions, OptionsError> {
        let Some(json) = options else {
            return IntegratorOptions::parse(&Value::String(name.to_string()), name);
        };
        let mut v: Value = serde_json::from_str(json)
            .map_err(|e| OptionsError::new("", format!("not JSON: {e}")))?;
        let Some(map) = v.as_object_mut() else {
            return Err(OptionsError::new(
                "",
                format!("expected a JSON object, got {json}"),
            ));
        };
        match map.get("type").and_then(Value::as_str) {
            Some(t) if t != name => {
                return Err(OptionsError::new(
                    "type",
                    format!("\"{t}\" contradicts the integrator \"{name}\""),
                ))
            }
            _ => {}
        }
        map.insert("type".into(), Value::String(name.into()));
        IntegratorOptions::parse(&v, name)
    }
}

/// serde's messages for internally tagged enums end in " at line 1 column N" for values that
/// never were text; drop that.
fn tidy_serde_message(m: &str) -> String {
    match m.rfind(" at line ") {
        Some(i) => m[..i].to_string(),
        None => m.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_entry_round_trips_by_name() {
        for i in INTEGRATORS {
            let o = IntegratorOptions::from_name(i.name).unwrap();
            assert_eq!(o.name(), i.name);
            assert_eq!(o.info().kernel, i.kernel);
            let v = serde_json::to_value(o).unwrap();
            assert_eq!(v["type"], i.name, "serde's tag is the registry name");
            assert!(
                crate::gpu::shader_source(i.kernel).is_some(),
                "{}: kernel {} is not under shaders/",
                i.name,
                i.kernel
            );
        }
    }

    /// Documented fields are exactly the fields serde accepts: the serialised defaults list every
    /// field (all are `Option`s serialised as null), and each documented one parses.
    #[test]
    fn option_fields_are_documented_and_accepted() {
        for i in INTEGRATORS {
            let v = serde_json::to_value(IntegratorOptions::from_name(i.name).unwrap()).unwrap();
            let mut accepted: Vec<&str> = v
                .as_object()
                .unwrap()
                .keys()
                .map(String::as_str)
                .filter(|k| *k != "type")
                .collect();
            let mut documented: Vec<&str> = i.options.iter().map(|f| f.name).collect();
            accepted.sort();
            documented.sort();
            assert_eq!(
                accepted, documented,
                "{}: documented vs accepted fields",
                i.name
            );
            assert!(i
                .options
                .iter()
                .all(|f| !f.help.is_empty() && !f.kind.is_empty()));
        }
    }

    #[test]
    fn parse_names_objects_and_refusals() {
        let o = IntegratorOptions::parse(&serde_json::json!("bdpt"), "nee").unwrap();
        assert_eq!(o.name(), "bdpt");
        let o = IntegratorOptions::parse(&Value::Null, "pt").unwrap();
        assert_eq!(o.name(), "pt");
        let o =
            IntegratorOptions::parse(&serde_json::json!({"type": "nee", "max_depth": 3}), "nee")
                .unwrap();
        assert_eq!(o.max_depth(), Some(3));
        let e = IntegratorOptions::parse(&serde_json::json!("mlt"), "nee").unwrap_err();
        assert!(e.message.contains("unknown integrator \"mlt\""), "{e}");
        assert!(e.message.contains("pt, nee, bdpt"), "{e}");
        let e = IntegratorOptions::parse(&serde_json::json!({"max_depth": 3}), "nee").unwrap_err();
        assert_eq!(e.path, "type");
        let e = IntegratorOptions::parse(&serde_json::json!({"type": "pt", "max_dpeth": 3}), "nee")
            .unwrap_err();
        assert!(e.message.contains("max_dpeth"), "{e}");
        assert!(!e.message.contains("at line"), "{e}");
        let e =
            IntegratorOptions::parse(&serde_json::json!({"type": "vct", "resolution": 96}), "nee")
                .unwrap_err();
        assert!(e.message.contains("resolution"), "{e}");
        let e = IntegratorOptions::parse_named("pt", Some(r#"{"type": "nee"}"#)).unwrap_err();
        assert_eq!(e.path, "type");
        let e = IntegratorOptions::resolve(&Value::Null, Some("mlt")).unwrap_err();
        assert_eq!(e.path, "render.integrator");
        let o = IntegratorOptions::resolve(&serde_json::json!("pt"), Some("mlt")).unwrap();
        assert_eq!(o.name(), "pt");
        let o = IntegratorOptions::resolve(&Value::Null, None).unwrap();
        assert_eq!(o.name(), DEFAULT_INTEGRATOR);
        let o = IntegratorOptions::parse_named("whitted", Some(r#"{"max_depth": 2}"#)).unwrap();
        assert_eq!((o.name(), o.max_depth()), ("whitted", Some(2)));
    }
}
