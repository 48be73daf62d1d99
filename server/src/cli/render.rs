//! `candela render SCENE.json -o OUT.{exr,png}`: load, compile, render to an spp or time budget,
//! write the image, report what happened (human-readable, or one JSON object with --json).

use std::path::PathBuf;
use std::sync::Arc;

use clap::Args;
use renderer::accel::{AccelKind, AccelOptions};
use renderer::compile::{compile_with, CompileOptions};
use renderer::gpu::{GpuContext, GpuOptions};
use renderer::integrators::{IntegratorOptions, NAMES};
use renderer::render::{render, Budget, RenderSession};

use super::CliError;

/// Largest film side and pixel count the CLI accepts.
const MAX_SIDE: u32 = 16384;
const MAX_PIXELS: u64 = 64 * 1024 * 1024;

#[derive(Debug, Args)]
pub struct RenderArgs {
    /// Scene file: candela JSON (docs/scene-format.md), Mitsuba 3 XML, glTF, pbrt or .scn
    /// (docs/import.md).
    pub scene: PathBuf,
    /// Output image: .exr (linear float RGB) or .png (exposure, tonemap, sRGB).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Integrator: pt, nee, bdpt, ... (default: the scene's render.integrator, else nee).
    #[arg(long)]
    pub integrator: Option<String>,
    /// The integrator's options as a JSON object, e.g. '{"max_depth": 3}' (the fields of
    /// `{"type": NAME, ...}` besides the type; unknown fields are refused).
    #[arg(long, value_name = "JSON")]
    pub options: Option<String>,
    /// Samples per pixel (default: the scene's render.spp, else 256).
    #[arg(long, conflicts_with = "time")]
    pub spp: Option<u32>,
    /// Render for this many seconds instead of a sample count.
    #[arg(long)]
    pub time: Option<f64>,
    /// Random seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Mitsuba's max_depth: 1 = emitters only, 2 = direct light, -1 = unbounded.
    #[arg(long, allow_hyphen_values = true)]
    pub max_depth: Option<i32>,
    /// Override the film width (pixels).
    #[arg(long)]
    pub width: Option<u32>,
    /// Override the film height (pixels).
    #[arg(long)]
    pub height: Option<u32>,
    /// Use the first Vulkan device whose name contains this text.
    #[arg(long)]
    pub device: Option<String>,
    /// Print the report as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Acceleration structure: bvh or grid (default: the scene's render.accel, else bvh).
    #[arg(long, value_name = "KIND")]
    pub accel: Option<String>,
    /// Grid cells along the scene's longest axis, 1..=512 (default: the scene's
    /// render.grid_resolution, else about 3 cells per primitive).
    #[arg(long, value_name = "N")]
    pub grid_resolution: Option<u32>,
    /// Cache built acceleration structures in DIR (default: $XDG_CACHE_HOME/candela/accel or
    /// ~/.cache/candela/accel).
    #[arg(long, value_name = "DIR", conflicts_with = "no_accel_cache")]
    pub accel_cache: Option<PathBuf>,
    /// Always build the acceleration structure; read and write no cache.
    #[arg(long)]
    pub no_accel_cache: bool,
    #[command(flatten)]
    pub import: super::scene_file::ImportArgs,
}

/// The per-user accel cache: $XDG_CACHE_HOME/candela/accel, else ~/.cache/candela/accel; None
/// when neither variable is set.
pub fn default_accel_cache() -> Option<PathBuf> {
    let nonempty = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    nonempty("XDG_CACHE_HOME")
        .or_else(|| nonempty("HOME").map(|h| h.join(".cache")))
        .map(|c| c.join("candela").join("accel"))
}

fn check_args(a: &RenderArgs) -> Result<(), CliError> {
    if a.spp == Some(0) {
        return Err(CliError::input("--spp: must be at least 1"));
    }
    if let Some(t) = a.time {
        if !(t.is_finite() && t > 0.0 && t <= 7.0 * 86400.0) {
            return Err(CliError::input(format!(
                "--time: must be a number of seconds in (0, 604800], got {t}"
            )));
        }
    }
    if let Some(d) = a.max_depth {
        if d == 0 || d < -1 {
            return Err(CliError::input(format!(
                "--max-depth: must be -1 or at least 1, got {d}"
            )));
        }
    }
    for (flag, v) in [("--width", a.width), ("--height", a.height)] {
        if let Some(v) = v {
            if v == 0 || v > MAX_SIDE {
                return Err(CliError::input(format!(
                    "{flag}: must be in 1..={MAX_SIDE}, got {v}"
                )));
            }
        }
    }
    if let Some(k) = &a.accel {
        if AccelKind::from_name(k).is_none() {
            return Err(CliError::input(format!(
                "--accel: unknown acceleration structure \"{k}\", expected one of {}",
                AccelKind::NAMES.join(", ")
            )));
        }
    }
    if let Some(r) = a.grid_resolution {
        let max = renderer::accel::grid::MAX_AXIS;
        if r == 0 || r > max {
            return Err(CliError::input(format!(
                "--grid-resolution: must be in 1..={max} (cells along the longest axis), got {r}"
            )));
        }
        if a.accel.as_deref() == Some("bvh") {
            return Err(CliError::input(
                "--grid-resolution: only applies to --accel grid",
            ));
        }
    }
    let ext = a
        .output
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    if !matches!(ext.as_deref(), Some("exr" | "png")) {
        return Err(CliError::input(format!(
            "-o {}: the output must end in .exr or .png",
            a.output.display()
        )));
    }
    Ok(())
}

pub fn run(a: RenderArgs) -> Result<(), CliError> {
    check_args(&a)?;
    // Step 1: the scene.
    let scene = super::scene_file::load_scene(&a.scene, &a.import)?;
    let name = a
        .integrator
        .clone()
        .or_else(|| scene.render.integrator.clone())
        .unwrap_or_else(|| "nee".into());
    let mut options = IntegratorOptions::from_name(&name).ok_or_else(|| {
        CliError::input(format!(
            "--integrator: unknown or not yet available \"{name}\" (available: {})",
            NAMES.join(", ")
        ))
    })?;
    if let Some(json) = &a.options {
        options = integrator_options(&name, json)?;
    }
    if let Some(d) = a.max_depth {
        options.set_max_depth(d);
    }
    let width = a.width.unwrap_or(scene.film.width);
    let height = a.height.unwrap_or(scene.film.height);
    if width as u64 * height as u64 > MAX_PIXELS {
        return Err(CliError::input(format!(
            "film: {width}x{height} is more than {MAX_PIXELS} pixels"
        )));
    }
    let budget = match (a.spp, a.time) {
        (_, Some(t)) => Budget::Time(t),
        (Some(n), None) => Budget::Spp(n),
        (None, None) => Budget::Spp(scene.render.spp.unwrap_or(256)),
    };
    // Step 2: device, compile, render.
    let ctx = GpuContext::new(&GpuOptions {
        device: a.device.clone(),
        validation: false,
    })
    .map_err(|e| match e {
        renderer::gpu::GpuError::NoDevice(_) if a.device.is_some() => {
            CliError::input(format!("--device: {e}"))
        }
        e => CliError::failure(e.to_string()),
    })?;
    let ctx = Arc::new(ctx);
    let accel = AccelOptions::resolve(&scene.render, a.accel.as_deref(), a.grid_resolution)
        .map_err(|e| CliError::input(format!("--accel: {e}")))?;
    let cache = match (&a.accel_cache, a.no_accel_cache) {
        (_, true) => None,
        (Some(dir), false) => Some(dir.clone()),
        (None, false) => default_accel_cache(),
    };
    let copts = CompileOptions {
        accel,
        cache: cache.as_deref(),
    };
    let compiled = compile_with(&scene, width, height, &copts)
        .map_err(|e| CliError::input(format!("{}: {e}", a.scene.display())))?;
    let mut session = RenderSession::new(&ctx, &compiled, &options, scene.render.max_depth, a.seed)
        .map_err(|e| CliError::failure(e.to_string()))?;
    let (image, stats) =
        render(&mut session, budget).map_err(|e| CliError::failure(e.to_string()))?;
    // Step 3: the image and the report.
    renderer::film::write_image(&a.output, &image, scene.film.exposure, scene.film.tonemap)
        .map_err(|e| CliError::failure(e.to_string()))?;
    if a.json {
        let mut v = serde_json::to_value(&stats).unwrap_or_default();
        if let Some(o) = v.as_object_mut() {
            o.insert(
                "output".into(),
                serde_json::Value::String(a.output.display().to_string()),
            );
            o.insert(
                "scene".into(),
                serde_json::Value::String(a.scene.display().to_string()),
            );
        }
        println!("{v}");
    } else {
        println!(
            "device      {} ({})",
            stats.device.name, stats.device.driver
        );
        println!(
            "integrator  {} (max_depth {})",
            stats.integrator, stats.max_depth
        );
        println!(
            "image       {}x{}, {} spp in {} passes, seed {}",
            stats.width, stats.height, stats.spp, stats.passes, stats.seed
        );
        println!(
            "time        {:.3} s (GPU {:.3} s), setup {:.3} s",
            stats.time_s, stats.gpu_time_s, stats.setup_s
        );
        println!(
            "throughput  {:.2} Msamples/s, {:.2} Mrays/s",
            stats.msamples_per_s,
            stats.rays_per_s * 1e-6
        );
        println!(
            "scene       {} triangles, {} primitives, {} lights, BVH {} nodes (depth {})",
            stats.triangles, stats.primitives, stats.lights, stats.bvh_nodes, stats.bvh_depth
        );
        let grid = match (stats.grid_resolution, stats.grid_refs) {
            (Some([x, y, z]), Some(refs)) => format!(", {x}x{y}x{z} cells, {refs} references"),
            _ => String::new(),
        };
        println!(
            "accel       {}{grid}, {} bytes, {:.3} s, cache {}",
            stats.accel,
            stats.accel_bytes,
            stats.accel_build_s,
            serde_json::to_value(stats.accel_cache)
                .ok()
                .and_then(|v| v.as_str().map(String::from))
                .unwrap_or_default()
        );
        println!("dropped     {} NaN/Inf samples", stats.dropped_samples);
        println!("wrote       {}", a.output.display());
    }
    Ok(())
}

/// `--options`: the integrator's fields as a JSON object, parsed as `{"type": name, ...}`.
fn integrator_options(name: &str, json: &str) -> Result<IntegratorOptions, CliError> {
    let bad = |m: String| CliError::input(format!("--options: {m}"));
    let mut v: serde_json::Value =
        serde_json::from_str(json).map_err(|e| bad(format!("not JSON: {e}")))?;
    let Some(map) = v.as_object_mut() else {
        return Err(bad(format!("expected a JSON object, got {json}")));
    };
    match map.get("type").and_then(|t| t.as_str()) {
        Some(t) if t != name => {
            return Err(bad(format!(
                "\"type\": \"{t}\" contradicts the integrator \"{name}\""
            )))
        }
        _ => {}
    }
    map.insert("type".into(), serde_json::Value::String(name.into()));
    let options: IntegratorOptions =
        serde_json::from_value(v).map_err(|e| bad(format!("{name}: {e}")))?;
    options.validate().map_err(|e| bad(e.to_string()))?;
    Ok(options)
}
