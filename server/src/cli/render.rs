//! `candela render SCENE.json -o OUT.{exr,png}`: load, compile, render to an spp or time budget
//! (or until the estimated relMSE reaches a target, that budget being the cap), write the image,
//! report what happened (human-readable, or one JSON object with --json).

use std::path::PathBuf;

use clap::Args;
use renderer::accel::AccelRequest;
use renderer::compile::KernelMode;
use renderer::integrators::{IntegratorOptions, DEFAULT_INTEGRATOR};
use renderer::prepare::expands_instances;
use renderer::prepare::{prepare, FilmLimits, PrepareOptions};
use renderer::render::{render, render_until, Budget, RenderStats};

use super::CliError;

#[derive(Debug, Args)]
pub struct RenderArgs {
    /// Scene file: candela JSON (docs/scene-format.md), Mitsuba 3 XML, glTF, pbrt or .scn
    /// (docs/import.md).
    pub scene: PathBuf,
    /// Output image: .exr (linear float RGB) or .png (exposure, tonemap, sRGB).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Integrator (default: the scene's render.integrator, else nee).
    #[arg(long, long_help = super::integrator_help("Integrator; else the scene's render.integrator"))]
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
    /// Stop as soon as the relMSE estimated without a reference (from the even and odd halves of
    /// the samples; `rel_mse_estimate` in the report) is at most X, after at least 8 spp; --spp or
    /// --time (else the default spp) is the cap. The report's `stopped_by` says which ended it.
    #[arg(long, value_name = "X")]
    pub until_rel_mse: Option<f64>,
    /// Benchmarking: render this many seconds first, untimed and discarded, so that the timed
    /// render starts on a GPU already at its working clocks (after a cold kernel compile the
    /// device may have idled down).
    #[arg(long, value_name = "SECONDS")]
    pub warmup: Option<f64>,
    /// How light sampling picks a light: power or bvh (default: the scene's
    /// render.light_sampler, else power; docs/light-sampler.md).
    #[arg(long, value_name = "KIND")]
    pub light_sampler: Option<String>,
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
    #[arg(long, conflicts_with = "devices")]
    pub device: Option<String>,
    /// Split the render across devices by sample index: "all" (every GPU of the best kind) or
    /// indices from `candela devices`, e.g. 0,1 (an index may repeat: two contexts on one
    /// device). --spp is the total over the devices, --time each device's.
    #[arg(long, value_name = "all|0,1")]
    pub devices: Option<String>,
    /// Print the report as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Acceleration structure: auto (bvh with instances, cwbvh for 1M triangles or more, else
    /// whichever of the two has the lower surface-area cost estimate), bvh, cwbvh (compressed
    /// 8-wide BVH) or grid (default: the scene's render.accel, else auto).
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
    /// Kernels: "specialized" to what the scene uses (default), or "generic" (every feature
    /// compiled in; for comparison).
    #[arg(long, value_name = "MODE", value_parser = super::parse_kernels, default_value = "specialized")]
    pub kernels: KernelMode,
    #[command(flatten)]
    pub import: super::scene_file::ImportArgs,
    #[command(flatten)]
    pub kernel_cache: super::KernelCacheArgs,
}

/// The per-user accel cache: $XDG_CACHE_HOME/candela/accel, else ~/.cache/candela/accel; None
/// when neither variable is set.
pub fn default_accel_cache() -> Option<PathBuf> {
    super::user_cache("accel")
}

fn check_args(a: &RenderArgs) -> Result<(), CliError> {
    if a.spp == Some(0) {
        return Err(CliError::input("--spp: must be at least 1"));
    }
    if let Some(w) = a.warmup {
        if !(w.is_finite() && (0.0..=3600.0).contains(&w)) {
            return Err(CliError::input(format!(
                "--warmup: must be a number of seconds in [0, 3600], got {w}"
            )));
        }
    }
    if let Some(x) = a.until_rel_mse {
        if !(x.is_finite() && x > 0.0) {
            return Err(CliError::input(format!(
                "--until-rel-mse: must be a positive number, got {x}"
            )));
        }
    }
    if let Some(t) = a.time {
        if !(t.is_finite() && t > 0.0 && t <= 7.0 * 86400.0) {
            return Err(CliError::input(format!(
                "--time: must be a number of seconds in (0, 604800], got {t}"
            )));
        }
    }
    let max_side = FilmLimits::default().max_side;
    for (flag, v) in [("--width", a.width), ("--height", a.height)] {
        if let Some(v) = v {
            if v == 0 || v > max_side {
                return Err(CliError::input(format!(
                    "{flag}: must be in 1..={max_side}, got {v}"
                )));
            }
        }
    }
    if let Some(s) = &a.light_sampler {
        if !renderer::scene::LIGHT_SAMPLERS.contains(&s.as_str()) {
            return Err(CliError::input(format!(
                "--light-sampler: unknown light sampler \"{s}\", expected one of {}",
                renderer::scene::LIGHT_SAMPLERS.join(", ")
            )));
        }
    }
    if let Some(k) = &a.accel {
        renderer::accel::parse_request(k).map_err(|e| CliError::input(format!("--accel: {e}")))?;
    }
    if let Some(r) = a.grid_resolution {
        renderer::accel::grid::check_resolution(r.into())
            .map_err(|e| CliError::input(format!("--grid-resolution: {e}")))?;
        if a.accel.as_deref().is_some_and(|k| k != "grid") {
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
    // Step 1: the scene and the integrator.
    let load_start = std::time::Instant::now();
    let mut scene = super::scene_file::load_scene(&a.scene, &a.import)?;
    let load_time = load_start.elapsed();
    if let Some(s) = &a.light_sampler {
        scene.render.light_sampler = Some(s.clone());
    }
    // `auto`: chosen by a pilot of every unbiased integrator (renderer::auto).
    let auto = a.integrator.as_deref() == Some(renderer::auto::AUTO);
    let mut options = if auto {
        IntegratorOptions::from_name(DEFAULT_INTEGRATOR).expect("the default integrator")
    } else {
        integrator_options(&a, scene.render.integrator.as_deref())?
    };
    if auto && a.options.is_some() {
        return Err(CliError::input("--options: not with --integrator auto"));
    }
    if let Some(d) = a.max_depth {
        options.set_max_depth(d);
        options
            .check()
            .map_err(|e| CliError::input(format!("--max-depth: {e}")))?;
    }
    let budget = match (a.spp, a.time) {
        (_, Some(t)) => Budget::Time(t),
        (Some(n), None) => Budget::Spp(n),
        (None, None) => Budget::Spp(scene.render.spp.unwrap_or(256)),
    };
    // Step 2: the prepared scene (film, acceleration structure, compiled buffers).
    let cache = match (&a.accel_cache, a.no_accel_cache) {
        (_, true) => None,
        (Some(dir), false) => Some(dir.clone()),
        (None, false) => default_accel_cache(),
    };
    let prepared = prepare(
        &scene,
        &PrepareOptions {
            width: a.width,
            height: a.height,
            limits: FilmLimits::default(),
            accel: AccelRequest {
                kind: a.accel.as_deref(),
                grid_resolution: a.grid_resolution,
            },
            cache: cache.as_deref(),
            kernels: a.kernels,
            load_time,
            expand_instances: !auto && expands_instances(&options),
            max_triangles: None,
        },
    )
    .map_err(|e| CliError::input(format!("{}: {e}", a.scene.display())))?;
    // Step 3: device(s), session(s), render.
    if let Some(spec) = &a.devices {
        if auto || a.until_rel_mse.is_some() {
            return Err(CliError::input(
                "--devices: not with --integrator auto or --until-rel-mse (one device only)",
            ));
        }
        let indices = super::multi_device::parse_devices(spec)?;
        let mut sessions = super::multi_device::open_sessions(
            &indices,
            &prepared,
            &options,
            a.seed,
            a.kernel_cache.dir(),
        )?;
        let split =
            super::multi_device::render_on_devices(&mut sessions, budget, a.warmup, a.seed)?;
        let stats = split.total();
        let mut extra = serde_json::Map::new();
        extra.insert(
            "devices".into(),
            super::multi_device::device_json(&indices, &split),
        );
        extra.insert("wall_s".into(), split.wall.as_secs_f64().into());
        return finish(
            &a,
            &scene,
            &split.image,
            &stats,
            extra,
            &super::multi_device::device_lines(&indices, &split),
        );
    }
    let ctx = super::open_device(a.device.as_deref(), a.kernel_cache.dir())?;
    if auto {
        if a.until_rel_mse.is_some() || a.warmup.is_some() {
            return Err(CliError::input(
                "--integrator auto: not with --until-rel-mse or --warmup",
            ));
        }
        let max_depth = a.max_depth.or(scene.render.max_depth);
        let (image, stats) =
            renderer::auto::render_auto(&prepared, &ctx, a.seed, max_depth, budget)
                .map_err(|e| CliError::failure(e.to_string()))?;
        return finish(&a, &scene, &image, &stats, serde_json::Map::new(), &[]);
    }
    let mut session = prepared
        .session(&ctx, &options, a.seed)
        .map_err(|e| CliError::failure(e.to_string()))?;
    if let Some(w) = a.warmup {
        render(&mut session, Budget::Time(w))
            .and_then(|_| session.reset(a.seed))
            .map_err(|e| CliError::failure(format!("warm-up: {e}")))?;
    }
    let (image, stats) = render_until(&mut session, budget, a.until_rel_mse)
        .map_err(|e| CliError::failure(e.to_string()))?;
    finish(&a, &scene, &image, &stats, serde_json::Map::new(), &[])
}

/// Step 4: the image and the report (`extra` joins the JSON object, `lines` the text report).
fn finish(
    a: &RenderArgs,
    scene: &renderer::scene::Scene,
    image: &renderer::film::Image,
    stats: &RenderStats,
    extra: serde_json::Map<String, serde_json::Value>,
    lines: &[String],
) -> Result<(), CliError> {
    renderer::film::write_image(&a.output, image, scene.film.exposure, scene.film.tonemap)
        .map_err(|e| CliError::failure(e.to_string()))?;
    if a.json {
        let mut v = serde_json::to_value(stats).unwrap_or_default();
        if let Some(o) = v.as_object_mut() {
            o.extend(extra);
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
        print_report(stats, &a.output);
        for l in lines {
            println!("{l}");
        }
    }
    Ok(())
}

/// The human-readable report, one aligned line per topic.
fn print_report(stats: &RenderStats, output: &std::path::Path) {
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
        "scene       {} triangles, {} primitives, {} lights ({} sampler), BVH {} nodes (depth {})",
        stats.triangles,
        stats.primitives,
        stats.lights,
        stats.light_sampler,
        stats.bvh_nodes,
        stats.bvh_depth
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
    println!(
        "memory      GPU {} bytes (geometry {}, accel {}; {:.1} per triangle), host peak {}",
        stats.scene_gpu_bytes,
        stats.geometry_bytes,
        stats.accel_bytes,
        stats.gpu_bytes_per_triangle,
        stats
            .peak_rss_bytes
            .map_or("unknown".to_string(), |b| format!("{b} bytes"))
    );
    if stats.instances > 0 {
        println!(
            "instances   {} ({} triangles as rendered; {:.1} GPU bytes per instance)",
            stats.instances, stats.instanced_triangles, stats.gpu_bytes_per_instance
        );
    }
    println!(
        "load        {:.3} s, compile {:.3} s (accel {:.3} s)",
        stats.load_s, stats.compile_s, stats.accel_build_s
    );
    println!(
        "kernels     {}: {}",
        stats.kernels.name(),
        stats.features.join(", ")
    );
    println!("dropped     {} NaN/Inf samples", stats.dropped_samples);
    let estimate = stats
        .rel_mse_estimate
        .map_or("-".to_string(), |e| format!("{e:.3e}"));
    let stopped = stats.stopped_by.map_or("-", |s| s.name());
    println!("error       estimated relMSE {estimate} (no reference), stopped by {stopped}");
    if let Some(c) = &stats.estimate_checks {
        println!(
            "checks      {} estimates on the GPU: {:.3} ms GPU, {:.3} ms waiting for them",
            c.checks,
            c.gpu_ms,
            c.wait_ms.unwrap_or(0.0)
        );
    }
    if let Some(auto) = &stats.auto {
        let pilots: Vec<String> = auto
            .pilots
            .iter()
            .map(|p| {
                let e = p
                    .rel_mse_estimate
                    .map_or("-".into(), |e| format!("{e:.2e}"));
                format!("{} {e} in {:.3} s", p.integrator, p.time_s)
            })
            .collect();
        println!(
            "auto        chose {} (pilots: {})",
            auto.choice,
            pilots.join(", ")
        );
    }
    println!("wrote       {}", output.display());
}

/// `--integrator NAME` (else the scene's render.integrator, else the default) with `--options
/// JSON` (its fields besides `type`).
fn integrator_options(
    a: &RenderArgs,
    scene_default: Option<&str>,
) -> Result<IntegratorOptions, CliError> {
    let name = a
        .integrator
        .as_deref()
        .or(scene_default)
        .unwrap_or(DEFAULT_INTEGRATOR);
    let from_scene = a.integrator.is_none() && scene_default.is_some();
    IntegratorOptions::parse_named(name, a.options.as_deref()).map_err(|e| {
        let flag = match (a.options.is_some(), from_scene) {
            (true, _) => "--options",
            (false, true) => "render.integrator",
            (false, false) => "--integrator",
        };
        CliError::input(format!("{flag}: {e}"))
    })
}
