//! Building the common kernels when the device opens, on a background thread, so the first jobs
//! find their kernels compiled (`--warm-kernels`). "Common" means the kernel variants that the
//! built-in scenes need: kernels are specialised per scene feature set (spheres, textures,
//! delta lights, ...), and the built-in scenes cover the usual sets. For each integrator asked
//! for and each distinct variant:
//!
//! 1. every kernel (path, defines) is compiled, all in parallel (gpu::compile_kernels), from
//!    the kernel cache when it holds them;
//! 2. a session of the scene at 8×8 pixels is created, on several threads at once, which
//!    creates the pipelines (the driver's compile, kept in its pipeline cache) and, for vct,
//!    builds the scene's volume (kept in the in-process volume cache). Integrators whose
//!    kernels take larger workgroups on large films (`IntegratorInfo::workgroup_tiles`, bdpt)
//!    build another variant there: the scene is also prepared at a film of
//!    `TILED_MIN_PIXELS`.
//!
//! It runs at the lowest CPU priority (nice 19), beside the jobs. Jobs do not wait for it: a job
//! that needs a kernel being compiled waits for that compile alone. Progress is in `GET
//! /api/health` (`kernels`). The in-memory caches keep only the most recently used of what it
//! builds (`--cache-kernels`, `--cache-pipelines`); the rest come back from the kernel cache on
//! disk and the driver's pipeline cache.

use std::collections::HashSet;
use std::sync::Arc;
use std::time::Instant;

use renderer::gpu::{kernel_stats, GpuContext, ShaderDefines};
use renderer::integrators::IntegratorOptions;
use renderer::prepare::{prepare, PrepareOptions, PreparedScene};
use renderer::render::RenderSession;
use tracing::{info, warn};

use crate::builtin_scenes::SCENES;
use crate::config::ServerConfig;
use crate::shared::{KernelWarmup, Shared};

/// Starts the warm-up of `ctx` (nothing when the configuration asks for none).
pub fn start(ctx: &Arc<GpuContext>, config: &Arc<ServerConfig>, shared: &Arc<Shared>) {
    let integrators = config.warm_kernels.integrators(&ctx.info.kind);
    if integrators.is_empty() {
        return;
    }
    // (The shared CPU pool started here, at the worker's priority: else the warm-up, at the
    // lowest, could be its first user and leave every pool thread there.)
    renderer::start_cpu_pool();
    info!(device = %ctx.info.name, integrators = integrators.len(), "warming kernels");
    let (ctx, config, shared) = (ctx.clone(), config.clone(), shared.clone());
    let spawned = std::thread::Builder::new()
        .name("kernel-warmup".into())
        .spawn(move || {
            lower_priority();
            run(&ctx, &config, &shared, &integrators)
        });
    if let Err(e) = spawned {
        warn!(error = %e, "starting the kernel warm-up");
    }
}

/// Runs the calling thread, and the threads it starts, at the lowest CPU priority (Linux: nice
/// values are per thread and inherited; the work it hands the shared CPU pool runs at the
/// pool's priority): the warm-up prepares for later jobs and must not slow
/// the ones rendering meanwhile (a farm worker's shard copies, file writes and merge: on a
/// 4-GPU host the four devices' warm-ups ran 8–10 s beside the first job).
fn lower_priority() {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: plain system calls on the calling thread's id; failure leaves it as it is.
        let done = unsafe {
            let tid = libc::syscall(libc::SYS_gettid) as libc::id_t;
            libc::setpriority(libc::PRIO_PROCESS, tid, 19)
        };
        if done != 0 {
            warn!("kernel warm-up: could not lower its priority");
        }
    }
}

/// One variant to build: a scene (prepared at 8×8, or at a large film) and an integrator.
struct Variant {
    scene: usize,
    options: IntegratorOptions,
}

fn run(ctx: &Arc<GpuContext>, config: &ServerConfig, shared: &Shared, integrators: &[String]) {
    let start = Instant::now();
    let before = kernel_stats();
    let mut status = KernelWarmup {
        state: "warming",
        ..Default::default()
    };
    shared.set_kernels(status.clone());
    // Step 1: the built-in scenes' feature sets (on a large film too where an integrator's
    // kernels differ there), and the distinct kernel lists per integrator.
    let tiled = integrators
        .iter()
        .any(|n| IntegratorOptions::from_name(n).is_some_and(|o| o.info().workgroup_tiles > 1));
    let mut scenes = prepared_scenes(config, (8, 8));
    if tiled {
        let width = 1024;
        let height = (renderer::render::TILED_MIN_PIXELS / width as u64) as u32;
        scenes.extend(prepared_scenes(config, (width, height)));
    }
    let mut seen: HashSet<Vec<(String, ShaderDefines)>> = HashSet::new();
    let mut variants = Vec::new();
    let mut kernels = Vec::new();
    for name in integrators {
        let Some(options) = IntegratorOptions::from_name(name) else {
            continue;
        };
        for (i, p) in scenes.iter().enumerate() {
            let list = RenderSession::kernels(
                ctx,
                &p.compiled,
                &options,
                p.scene_max_depth,
                renderer::compile::KernelMode::Specialized,
            );
            if seen.insert(list.clone()) {
                kernels.extend(list);
                variants.push(Variant { scene: i, options });
            }
        }
    }
    status.variants = variants.len();
    shared.set_kernels(status.clone());
    // Step 2: every kernel, compiled in parallel.
    if let Err(e) = ctx.compile_kernels(&kernels) {
        warn!(error = %e, "kernel warm-up: compiling");
    }
    // Step 3: one session per variant (pipelines, vct volumes), several at once: the
    // driver compiles pipelines on the calling thread.
    let next = std::sync::atomic::AtomicUsize::new(0);
    let status = std::sync::Mutex::new(status);
    let threads = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .clamp(1, 8);
    std::thread::scope(|scope| {
        for _ in 0..threads.min(variants.len()) {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(v) = variants.get(i) else { break };
                let p = &scenes[v.scene];
                if let Err(e) = p.session(ctx, &v.options, 0) {
                    warn!(integrator = v.options.name(), error = %e, "kernel warm-up: session");
                }
                let mut st = status.lock().unwrap_or_else(|e| e.into_inner());
                st.built += 1;
                let k = kernel_stats().since(&before);
                st.compiled = k.compiled;
                st.disk_hits = k.disk_hits;
                st.seconds = start.elapsed().as_secs_f64();
                shared.set_kernels(st.clone());
            });
        }
    });
    let mut status = status.into_inner().unwrap_or_else(|e| e.into_inner());
    ctx.save_pipeline_cache();
    status.state = "ready";
    status.seconds = start.elapsed().as_secs_f64();
    shared.set_kernels(status.clone());
    info!(
        variants = status.variants,
        compiled = status.compiled,
        from_cache = status.disk_hits,
        seconds = status.seconds,
        "kernels warm"
    );
}

/// Every built-in scene that loads, compiled at `film` pixels (no acceleration-structure cache).
fn prepared_scenes(config: &ServerConfig, film: (u32, u32)) -> Vec<PreparedScene> {
    let base = config.builtin_dir();
    let limits = config.limits.scene_limits();
    SCENES
        .iter()
        .filter_map(|(name, text)| {
            let scene = renderer::scene::load_str_with_limits(text, Some(&base), &limits)
                .map_err(|e| warn!(scene = name, error = %e, "kernel warm-up: scene"))
                .ok()?;
            let options = PrepareOptions {
                width: Some(film.0),
                height: Some(film.1),
                ..Default::default()
            };
            prepare(&scene, &options)
                .map_err(|e| warn!(scene = name, error = %e, "kernel warm-up: scene"))
                .ok()
        })
        .collect()
}
