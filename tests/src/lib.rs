//! Shared helpers of the end-to-end tests: locating (and building) the `candela` binary, the
//! repository's scenes, rendering through the library on one shared GPU context with the
//! validation layer on, and Mitsuba 3 reference renders via tests/mitsuba/render_reference.py.

pub mod accel;
pub mod database;
pub mod farm;
pub mod server;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Arc, OnceLock};

use renderer::compile::{compile, CompiledScene};
use renderer::film::Image;
use renderer::gpu::{GpuContext, GpuOptions};
use renderer::integrators::IntegratorOptions;
use renderer::render::{render, Budget, RenderSession, RenderStats};

/// The repository root.
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("repo root")
        .to_path_buf()
}

/// A scene of the repository's `scenes/` folder.
pub fn scene_path(name: &str) -> PathBuf {
    repo_root().join("scenes").join(name)
}

/// A scratch folder for one test, emptied first.
pub fn scratch(name: &str) -> PathBuf {
    // A test's SQLite and PostgreSQL variants (`on_both_databases!`) run in parallel: each gets
    // its own folder.
    let name = match database::backend() {
        database::Backend::Sqlite => name.to_string(),
        database::Backend::Postgres => format!("{name}.postgres"),
    };
    let dir = repo_root().join("target").join("test-scratch").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

/// The `candela` binary, built once per test process with the same profile as the tests.
pub fn candela() -> PathBuf {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let status = Command::new(cargo)
            .args(["build", "-q", "-p", "candela-server", "--bin", "candela"])
            .current_dir(repo_root())
            .status()
            .expect("run cargo build");
        assert!(status.success(), "building candela failed");
        let target = std::env::var("CARGO_TARGET_DIR")
            .map(PathBuf::from)
            .unwrap_or_else(|_| repo_root().join("target"));
        target.join("debug").join("candela")
    })
    .clone()
}

/// One GPU context per test process (validation layer on when installed).
pub fn gpu() -> Arc<GpuContext> {
    static CTX: OnceLock<Arc<GpuContext>> = OnceLock::new();
    CTX.get_or_init(|| {
        Arc::new(
            GpuContext::new(&GpuOptions {
                device: None,
                validation: true,
                ..Default::default()
            })
            .expect("a Vulkan device (install mesa-vulkan-drivers)"),
        )
    })
    .clone()
}

/// Renders a scene file with the library at `w`×`h`.
pub fn render_scene(
    path: &Path,
    integrator: &str,
    spp: u32,
    w: u32,
    h: u32,
    seed: u64,
    max_depth: Option<i32>,
) -> (Image, RenderStats) {
    let scene =
        renderer::scene::load_file(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    render_loaded(&scene, integrator, spp, w, h, seed, max_depth)
}

/// Renders an already loaded scene.
pub fn render_loaded(
    scene: &renderer::scene::Scene,
    integrator: &str,
    spp: u32,
    w: u32,
    h: u32,
    seed: u64,
    max_depth: Option<i32>,
) -> (Image, RenderStats) {
    let compiled = compile(scene, w, h).expect("compile");
    render_compiled(scene, &compiled, integrator, spp, seed, max_depth)
}

/// Renders an already compiled scene (`scene` gives its `render.max_depth`).
pub fn render_compiled(
    scene: &renderer::scene::Scene,
    compiled: &CompiledScene,
    integrator: &str,
    spp: u32,
    seed: u64,
    max_depth: Option<i32>,
) -> (Image, RenderStats) {
    let ctx = gpu();
    let mut options = IntegratorOptions::from_name(integrator).expect("integrator");
    if let Some(d) = max_depth {
        options.set_max_depth(d);
    }
    let mut session = RenderSession::new(&ctx, compiled, &options, scene.render.max_depth, seed)
        .expect("session");
    let out = render(&mut session, Budget::Spp(spp)).expect("render");
    ctx.check_validation().expect("validation layer messages");
    out
}

/// Whether Mitsuba 3 can be imported.
pub fn mitsuba_available() -> bool {
    Command::new("python3")
        .args(["-c", "import mitsuba"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}

/// Renders `scene` with Mitsuba 3 (scalar_rgb) into `out` and reads it back.
pub fn render_mitsuba(
    scene: &Path,
    out: &Path,
    spp: u32,
    w: u32,
    h: u32,
    seed: u64,
    max_depth: Option<i32>,
) -> anyhow::Result<Image> {
    let script = repo_root().join("tests/mitsuba/render_reference.py");
    let mut cmd = Command::new("python3");
    cmd.arg(script).arg(scene).arg(out).args([
        "--spp",
        &spp.to_string(),
        "--width",
        &w.to_string(),
        "--height",
        &h.to_string(),
        "--seed",
        &seed.to_string(),
    ]);
    if let Some(d) = max_depth {
        cmd.args(["--max-depth", &d.to_string()]);
    }
    run_mitsuba_script(cmd, out)
}

/// Runs a tests/mitsuba script that writes `out`, and reads the image back.
fn run_mitsuba_script(mut cmd: Command, out: &Path) -> anyhow::Result<Image> {
    let o = cmd.output()?;
    anyhow::ensure!(
        o.status.success(),
        "mitsuba failed ({}): {}",
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
    Ok(renderer::film::read_exr(out)?)
}

/// Renders a Mitsuba 3 XML scene with Mitsuba itself (scalar_rgb, the scene's own integrator,
/// sensor and film; `defines` set `$NAME` parameters) via tests/mitsuba/render_xml.py.
pub fn render_mitsuba_xml(
    scene: &Path,
    out: &Path,
    spp: u32,
    seed: u64,
    defines: &[(&str, &str)],
) -> anyhow::Result<Image> {
    let script = repo_root().join("tests/mitsuba/render_xml.py");
    let mut cmd = Command::new("python3");
    cmd.arg(script).arg(scene).arg(out).args([
        "--spp",
        &spp.to_string(),
        "--seed",
        &seed.to_string(),
    ]);
    for (k, v) in defines {
        cmd.arg("-D").arg(format!("{k}={v}"));
    }
    run_mitsuba_script(cmd, out)
}

/// The verdict of every Mitsuba comparison: candela's two renders (different seeds) against
/// Mitsuba's two. Thresholds (stated, not tuned per scene): means within 2% per channel;
/// relMSE after 4×4 block averaging (where noise shrinks 16× and bias does not) below 3× the
/// expected noise (half the seed-to-seed block relMSE of each renderer, summed) plus 2e-4; mean
/// FLIP below 0.1. Prints the figures with `what` (how each side was rendered).
pub fn assert_matches_mitsuba(name: &str, candela: [&Image; 2], mitsuba: [&Image; 2], what: &str) {
    use renderer::metrics::{downsample_box, flip, rel_mse, REL_MSE_FORMULA};
    let ([c1, c2], [mi, mi2]) = (candela, mitsuba);
    let block = |a, b| rel_mse(&downsample_box(a, 4), &downsample_box(b, 4)).unwrap();
    let full = rel_mse(c1, mi).unwrap();
    let blocked = block(c1, mi);
    let noise = block(c1, c2) / 2.0 + block(mi, mi2) / 2.0;
    let fl = flip(c1, mi, 0.0, renderer::scene::Tonemap::Clamp).unwrap();
    let (mc, mm) = (c1.mean(), mi.mean());
    println!(
        "{name} {}x{}: {what}: relMSE {full:.3e}, 4x4-block relMSE {blocked:.3e} (noise {noise:.3e}), FLIP {fl:.4}; means candela {mc:.4?} mitsuba {mm:.4?}; relMSE = {REL_MSE_FORMULA}",
        c1.width, c1.height
    );
    for c in 0..3 {
        if mm[c] > 1e-3 {
            assert!(
                (mc[c] / mm[c] - 1.0).abs() < 0.02,
                "{name}: means differ: candela {mc:?} mitsuba {mm:?}"
            );
        }
    }
    assert!(
        blocked < 3.0 * noise + 2e-4,
        "{name}: block relMSE {blocked:.3e} vs noise {noise:.3e}"
    );
    assert!(fl < 0.1, "{name}: FLIP {fl}");
}

/// Per-channel mean of an image.
pub fn mean(img: &Image) -> [f64; 3] {
    img.mean()
}

/// Runs the `candela` binary with `args` from the repository root (on the running test's
/// database backend for the `--data-dir`/`--data` it names; see [`database`]).
pub fn run_candela(args: &[&str]) -> std::process::Output {
    run_candela_env(args, &[])
}

/// [`run_candela`] with extra environment variables.
pub fn run_candela_env(args: &[&str], env: &[(&str, &str)]) -> std::process::Output {
    let mut cmd = Command::new(candela());
    cmd.args(args)
        .current_dir(repo_root())
        .env_remove("CANDELA_DATABASE")
        .envs(env.iter().copied());
    let data = args
        .windows(2)
        .find(|w| w[0] == "--data-dir" || w[0] == "--data")
        .map(|w| w[1]);
    if let Some(url) = database::database_env(Path::new(data.unwrap_or("candela-data"))) {
        cmd.env("CANDELA_DATABASE", url);
    }
    cmd.output().expect("run candela")
}

/// Renders project scene `scene` (e.g. "cornell.json") through the CLI into `out` at
/// `width`×`height` and `spp`, with further arguments `extra` and environment `env`; asserts that
/// it succeeded (stderr in the message) and reads the image.
pub fn cli_render(
    scene: &str,
    out: &Path,
    (width, height, spp): (u32, u32, u32),
    extra: &[&str],
    env: &[(&str, &str)],
) -> Image {
    let (w, h, n) = (width.to_string(), height.to_string(), spp.to_string());
    let scene = format!("scenes/{scene}");
    let out_s = out.to_str().expect("a UTF-8 path");
    let mut args = vec![
        "render",
        scene.as_str(),
        "-o",
        out_s,
        "--width",
        &w,
        "--height",
        &h,
    ];
    args.extend(["--spp", n.as_str()]);
    args.extend_from_slice(extra);
    let o = run_candela_env(&args, env);
    assert!(o.status.success(), "{args:?}: {}", text(&o.stderr));
    renderer::film::read_exr(out).unwrap_or_else(|e| panic!("{}: {e}", out.display()))
}

/// Runs `candela ARGS` (a `--json` report), asserts that it succeeded (stderr in the message)
/// and parses stdout as one JSON object.
pub fn run_json(args: &[&str]) -> serde_json::Value {
    let o = run_candela(args);
    assert!(o.status.success(), "{}", text(&o.stderr));
    serde_json::from_slice(&o.stdout).expect("one JSON object on stdout")
}

/// Lossy UTF-8 of a process output stream.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Asserts exit code 2, a single non-empty stderr line containing every `needle`, and no panic:
/// the contract for bad input on every subcommand.
pub fn assert_bad_input(o: &std::process::Output, needles: &[&str]) {
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    assert!(!err.contains("panicked"), "panic: {err}");
    let lines: Vec<_> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "expected one line, got: {err}");
    for n in needles {
        assert!(err.contains(n), "expected {n:?} in: {err}");
    }
}

/// The average of renders of one image with different seeds, and that average's own relative
/// variance on `block`×`block` box averages: per block and channel the sample variance of the
/// parts over their count, divided by (x̄² + 0.01) as `REL_MSE_FORMULA` does, then averaged. Two
/// independent estimates of one image are then expected at relMSE noise₁ + noise₂ (on blocks).
pub fn seed_average(parts: &[Image], block: u32) -> (Image, f64) {
    assert!(parts.len() >= 2, "a spread needs at least two renders");
    let n = parts.len() as f64;
    let img = Image::from_fn(parts[0].width, parts[0].height, |x, y| {
        let mut p = [0f32; 3];
        for part in parts {
            for (acc, v) in p.iter_mut().zip(part.get(x, y)) {
                *acc += v / n as f32;
            }
        }
        p
    });
    let mean_b = renderer::metrics::downsample_box(&img, block);
    let parts_b: Vec<Image> = parts
        .iter()
        .map(|p| renderer::metrics::downsample_box(p, block))
        .collect();
    let (mut sum, mut count) = (0.0, 0usize);
    for (i, m) in mean_b.pixels.iter().enumerate() {
        for (c, &mc) in m.iter().enumerate() {
            let var = parts_b
                .iter()
                .map(|p| (p.pixels[i][c] as f64 - mc as f64).powi(2))
                .sum::<f64>()
                / (n - 1.0);
            sum += var / n / ((mc as f64).powi(2) + 0.01);
            count += 1;
        }
    }
    (img, sum / count as f64)
}

/// Renders `compiled` with integrator `name` (its cheapest settings: vct at its smallest volume;
/// 2 spp, seed 3) with the specialised and then the generic kernels, and returns the largest
/// relative difference between the two images (per channel, dark pixels compared absolutely
/// below 1e-3) and the tolerance it must meet (bdpt's splats add with float atomics in any
/// order). Used by the kernel audits (tests/tests/kernels.rs, random_scenes.rs).
///
/// whitted takes one area sample per light in scenes of more than [`LAVAPIPE_WHITTED_LIGHTS`]
/// lights: lavapipe ends every loop of an invocation once their iterations add up to 65535
/// (docs/whitted.md, "lavapipe"), which 16 shadow walks to each of a few hundred triangle lights
/// pass, and then both kernels come out wrong, each in its own way (random seed 103's emissive
/// uv sphere of 528 triangles: 0.63 apart and neither near nee; with one sample both equal and
/// match nee).
pub fn specialised_vs_generic(
    scene: &renderer::scene::Scene,
    compiled: &CompiledScene,
    name: &str,
) -> anyhow::Result<(f32, f32)> {
    let spec = match name {
        "vct" => serde_json::json!({"type": "vct", "resolution": 64}),
        "whitted" if compiled.lights.len() > LAVAPIPE_WHITTED_LIGHTS => {
            serde_json::json!({"type": "whitted", "area_samples": 1})
        }
        _ => serde_json::Value::String(name.into()),
    };
    specialised_vs_generic_with(scene, compiled, &spec)
}

/// The most lights whitted's 16 area samples each stay within lavapipe's loop limit for
/// ([`specialised_vs_generic`]; failures began between 32 and 50 triangle lights).
pub const LAVAPIPE_WHITTED_LIGHTS: usize = 32;

/// [`specialised_vs_generic`] for the integrator `spec` (a job's "integrator" value: a name or
/// an object with its options), so that renders with other options (and so other constants
/// compiled into the specialised kernels) are compared too.
pub fn specialised_vs_generic_with(
    scene: &renderer::scene::Scene,
    compiled: &CompiledScene,
    spec: &serde_json::Value,
) -> anyhow::Result<(f32, f32)> {
    use renderer::compile::KernelMode;
    let name = spec
        .as_str()
        .or_else(|| spec["type"].as_str())
        .ok_or_else(|| anyhow::anyhow!("integrator spec without a type: {spec}"))?;
    let options = IntegratorOptions::parse(spec, name)?;
    let ctx = gpu();
    let image = |kernels| -> anyhow::Result<Image> {
        let mut s = RenderSession::with_kernels(
            &ctx,
            compiled,
            &options,
            scene.render.max_depth,
            3,
            kernels,
        )?;
        Ok(render(&mut s, Budget::Spp(2))?.0)
    };
    let (a, b) = (image(KernelMode::Specialized)?, image(KernelMode::Generic)?);
    let d = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs() / p[c].abs().max(1e-3)))
        .fold(0.0f32, f32::max);
    Ok((d, if name == "bdpt" { 1e-3 } else { 1e-5 }))
}
