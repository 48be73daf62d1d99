//! The rendering side of the benchmark: load and compile the scene once, obtain the reference
//! (read, or rendered by a long `nee` run), warm the device up, then render every
//! (repeat, budget, integrator) from a reset session (cleared film and counters, its own seed) and measure it.

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use renderer::film::{read_exr, write_exr, Image};
use renderer::gpu::GpuContext;
use renderer::integrators::IntegratorOptions;
use renderer::metrics::{Display, Metrics};
use renderer::prepare::{prepare, PrepareOptions, PreparedScene};
use renderer::render::{render, Budget, PassSizer, RenderSession};

use super::{
    provenance, stats, BenchConfig, BenchError, BenchReport, ReferenceInfo, RunRecord, Targets,
    FLIP_TARGET, REFERENCE_INTEGRATOR, REFERENCE_SEED, REL_MSE_TARGET,
};
use renderer::metrics::METRIC_NOTES;

/// How often a long reference render reports progress.
const REFERENCE_PROGRESS_EVERY: Duration = Duration::from_secs(2);

/// Runs the whole benchmark on `ctx`; `progress` receives one line per step (for stderr).
pub fn run_bench(
    ctx: &Arc<GpuContext>,
    cfg: &BenchConfig,
    progress: &mut dyn FnMut(&str),
) -> Result<BenchReport, BenchError> {
    // Step 1: scene, given reference, film size.
    let load_start = std::time::Instant::now();
    let loaded = renderer::import::load_file(&cfg.scene, &cfg.import).map_err(|e| match e {
        renderer::scene::SceneError::Import { .. } => BenchError::Input(e.to_string()),
        e => BenchError::Input(format!("{}: {e}", cfg.scene.display())),
    })?;
    for w in &loaded.warnings {
        progress(&format!("warning: {w}"));
    }
    let scene = loaded.scene;
    let options = &cfg.integrators;
    let given = match &cfg.reference {
        Some(path) => Some(read_exr(path).map_err(|e| BenchError::Input(e.to_string()))?),
        None => None,
    };
    let (width, height) = film_size(cfg, &scene, given.as_ref())?;
    let display = Display {
        exposure_ev: scene.film.exposure,
        tonemap: scene.film.tonemap,
    };
    let scene_name = cfg
        .scene
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    // Step 2: the prepared scene (the scene's own acceleration structure, built afresh).
    let prepared = prepare(
        &scene,
        &PrepareOptions {
            width: Some(width),
            height: Some(height),
            kernels: cfg.kernels,
            load_time: load_start.elapsed(),
            // (One prepared scene for every integrator: written out for all when one of
            // them has no second level.)
            expand_instances: options.iter().any(renderer::prepare::expands_instances),
            ..Default::default()
        },
    )
    .map_err(|e| BenchError::Input(format!("{}: {e}", cfg.scene.display())))?;
    let device = ctx.info.clone();
    let commit = provenance::commit();
    progress(&format!(
        "bench: {scene_name} {width}x{height} on {} ({}), commit {}",
        device.name,
        device.driver,
        commit.as_deref().unwrap_or("unknown")
    ));
    // Step 3: the reference.
    let (reference, reference_info) = match (given, &cfg.reference) {
        (Some(img), Some(path)) => {
            progress(&format!("reference: {}", path.display()));
            let info = ReferenceInfo {
                source: "file",
                path: path.display().to_string(),
                integrator: None,
                spp: None,
                seed: None,
                time_s: None,
            };
            (img, info)
        }
        _ => render_reference(ctx, &prepared, cfg, progress)?,
    };
    // Step 4: one session per integrator (kernel build and upload untimed), warmed up with a short
    // untimed pass; each timed run then starts from `reset(seed)`, as fresh as a new session.
    let mut sessions = Vec::with_capacity(options.len());
    for o in options {
        let mut s = new_session(ctx, &prepared, o, 0)?;
        s.run_pass(1).map_err(fail)?;
        sessions.push(s);
    }
    // Step 5: the timed runs, repeats outermost so slow drifts spread over all cells.
    let total = cfg.repeats as usize * cfg.times.len() * options.len();
    let mut runs = Vec::with_capacity(total);
    for repeat in 0..cfg.repeats {
        for &budget in &cfg.times {
            for (o, session) in options.iter().zip(sessions.iter_mut()) {
                let seed = 1 + runs.len() as u64;
                session.reset(seed).map_err(fail)?;
                let (image, st) = render(session, Budget::Time(budget)).map_err(fail)?;
                let metrics = Metrics::compute(&image, &reference, display)
                    .map_err(|e| BenchError::Failure(format!("{} run: {e}", o.name())))?;
                progress(&format!(
                    "[{}/{total}] {} {budget} s #{repeat}: {} spp in {:.3} s, relMSE {:.4e}, FLIP {:.4}",
                    runs.len() + 1,
                    o.name(),
                    st.spp,
                    st.time_s,
                    metrics.rel_mse,
                    metrics.flip
                ));
                runs.push(RunRecord {
                    scene: scene_name.clone(),
                    integrator: o.name().to_string(),
                    budget_s: budget,
                    repeat,
                    seed,
                    time_s: st.time_s,
                    gpu_time_s: st.gpu_time_s,
                    spp: st.spp,
                    passes: st.passes,
                    msamples_per_s: st.msamples_per_s,
                    dropped_samples: st.dropped_samples,
                    setup_s: st.setup_s,
                    metrics,
                    device: device.name.clone(),
                    commit: commit.clone(),
                });
            }
        }
    }
    let names: Vec<String> = options.iter().map(|o| o.name().to_string()).collect();
    let summary = stats::summarise(&names, &cfg.times, &runs);
    Ok(BenchReport {
        scene: scene_name,
        scene_path: cfg.scene.display().to_string(),
        width,
        height,
        device,
        commit,
        display: display.into(),
        reference: reference_info,
        integrators: names,
        budgets_s: cfg.times.clone(),
        repeats: cfg.repeats,
        targets: Targets {
            rel_mse: REL_MSE_TARGET,
            flip: FLIP_TARGET,
        },
        notes: METRIC_NOTES,
        runs,
        summary,
    })
}

/// Any renderer failure is a failure (exit 1).
fn fail(e: impl std::fmt::Display) -> BenchError {
    BenchError::Failure(e.to_string())
}

/// The film size: --width/--height, else the given reference's size, else the scene's film; a
/// given reference must match it.
fn film_size(
    cfg: &BenchConfig,
    scene: &renderer::scene::Scene,
    reference: Option<&Image>,
) -> Result<(u32, u32), BenchError> {
    let (default_w, default_h) = match reference {
        Some(r) => (r.width, r.height),
        None => (scene.film.width, scene.film.height),
    };
    let (w, h) = (
        cfg.width.unwrap_or(default_w),
        cfg.height.unwrap_or(default_h),
    );
    if let (Some(r), Some(path)) = (reference, &cfg.reference) {
        if (r.width, r.height) != (w, h) {
            return Err(BenchError::Input(format!(
                "--reference {}: the reference is {}x{} but the bench renders {w}x{h}",
                path.display(),
                r.width,
                r.height
            )));
        }
    }
    Ok((w, h))
}

/// A fresh session (kernel build and upload are not part of any timing).
fn new_session(
    ctx: &Arc<GpuContext>,
    prepared: &PreparedScene,
    options: &IntegratorOptions,
    seed: u64,
) -> Result<RenderSession, BenchError> {
    prepared.session(ctx, options, seed).map_err(fail)
}

/// Renders the reference with [`REFERENCE_INTEGRATOR`] at `cfg.reference_spp` and writes it to
/// `DIR/reference.exr`, reporting progress every couple of seconds.
fn render_reference(
    ctx: &Arc<GpuContext>,
    prepared: &PreparedScene,
    cfg: &BenchConfig,
    progress: &mut dyn FnMut(&str),
) -> Result<(Image, ReferenceInfo), BenchError> {
    let options = IntegratorOptions::from_name(REFERENCE_INTEGRATOR)
        .ok_or_else(|| fail("the reference integrator is not available"))?;
    let total = cfg.reference_spp;
    progress(&format!(
        "reference: rendering {REFERENCE_INTEGRATOR} at {total} spp (seed {REFERENCE_SEED})"
    ));
    let mut session = new_session(ctx, prepared, &options, REFERENCE_SEED)?;
    let mut sizer = PassSizer::default();
    let mut last_report = Instant::now();
    while session.spp() < total {
        let n = sizer
            .next(Duration::from_millis(250))
            .min(total - session.spp());
        let pass = session.run_pass(n).map_err(fail)?;
        sizer.observe(&pass);
        if last_report.elapsed() >= REFERENCE_PROGRESS_EVERY {
            last_report = Instant::now();
            progress(&format!(
                "reference: {}/{total} spp, {:.1} s",
                session.spp(),
                session.elapsed().as_secs_f64()
            ));
        }
    }
    let image = session.image().map_err(fail)?;
    let st = session.stats();
    std::fs::create_dir_all(&cfg.out_dir).map_err(|e| {
        BenchError::Failure(format!("cannot create {}: {e}", cfg.out_dir.display()))
    })?;
    let path = cfg.out_dir.join("reference.exr");
    write_exr(&path, &image).map_err(fail)?;
    progress(&format!(
        "reference: {} spp in {:.2} s ({:.2} Msamples/s), wrote {}",
        st.spp,
        st.time_s,
        st.msamples_per_s,
        path.display()
    ));
    Ok((
        image,
        ReferenceInfo {
            source: "rendered",
            path: display_path(&path),
            integrator: Some(REFERENCE_INTEGRATOR.to_string()),
            spp: Some(st.spp),
            seed: Some(REFERENCE_SEED),
            time_s: Some(st.time_s),
        },
    ))
}

/// A path for reports.
fn display_path(p: &Path) -> String {
    p.display().to_string()
}
