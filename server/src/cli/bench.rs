//! `candela bench SCENE`: the speed/accuracy benchmark. Renders the scene with each integrator for
//! each time budget, several times with fresh seeds, compares every image with a reference and
//! writes `results.csv`, `results.json`, `chart.svg` (relMSE), `chart_flip.svg` (FLIP) and
//! `summary.md` into the output folder; progress goes to stderr, a short table to stdout.
//! The work itself is in [`crate::benchmark`].

use std::path::{Path, PathBuf};

use clap::Args;
use renderer::integrators::IntegratorOptions;

use super::CliError;
use crate::benchmark::chart::{chart_svg, ChartMetric, ChartTitle};
use crate::benchmark::{
    csv, run_bench, summary, BenchConfig, BenchError, BenchReport, FLIP_TARGET, REL_MSE_TARGET,
};

/// Arguments of `candela bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Scene file: candela JSON (docs/scene-format.md) or any format of docs/import.md.
    pub scene: PathBuf,
    /// Reference image (EXR); default: render one with nee at --reference-spp.
    #[arg(long, value_name = "REF.exr")]
    pub reference: Option<PathBuf>,
    /// Integrators to measure, comma-separated.
    #[arg(long, default_value = "pt,nee", long_help = super::integrator_help("Integrators to measure, comma-separated"))]
    pub integrators: String,
    /// Wall-time budgets in seconds, comma-separated.
    #[arg(long, default_value = "0.1,0.3,1,3,10")]
    pub times: String,
    /// Runs per integrator and budget, each with its own seed.
    #[arg(long, default_value_t = 3)]
    pub repeats: u32,
    /// Output folder (created if missing).
    #[arg(long, value_name = "DIR", default_value = "bench-out")]
    pub out: PathBuf,
    /// Film width override (pixels).
    #[arg(long)]
    pub width: Option<u32>,
    /// Film height override (pixels).
    #[arg(long)]
    pub height: Option<u32>,
    /// Samples per pixel of the rendered reference (nee).
    #[arg(long, default_value_t = 4096)]
    pub reference_spp: u32,
    /// Use the first Vulkan device whose name contains this text.
    #[arg(long)]
    pub device: Option<String>,
    /// Kernels: "specialized" to what the scene uses (default) or "generic".
    #[arg(long, value_name = "MODE", value_parser = super::parse_kernels, default_value = "specialized")]
    pub kernels: renderer::compile::KernelMode,
    #[command(flatten)]
    pub import: super::scene_file::ImportArgs,
    #[command(flatten)]
    pub kernel_cache: super::KernelCacheArgs,
}

/// Longest budget accepted, seconds.
const MAX_TIME_S: f64 = 86400.0;
/// Most repeats accepted.
const MAX_REPEATS: u32 = 1000;

/// Checks the arguments and turns them into a [`BenchConfig`].
fn config(a: &BenchArgs) -> Result<BenchConfig, CliError> {
    let mut integrators: Vec<IntegratorOptions> = Vec::new();
    for name in a.integrators.split(',').map(str::trim) {
        let o = IntegratorOptions::parse(&serde_json::Value::String(name.into()), name)
            .map_err(|e| CliError::input(format!("--integrators: {e}")))?;
        if !integrators.contains(&o) {
            integrators.push(o);
        }
    }
    let mut times: Vec<f64> = Vec::new();
    for t in a.times.split(',').map(str::trim) {
        let v: f64 = t
            .parse()
            .map_err(|_| CliError::input(format!("--times: \"{t}\" is not a number of seconds")))?;
        if !(v.is_finite() && v > 0.0 && v <= MAX_TIME_S) {
            return Err(CliError::input(format!(
                "--times: each budget must be in (0, {MAX_TIME_S}] seconds, got {t}"
            )));
        }
        times.push(v);
    }
    times.sort_by(f64::total_cmp);
    times.dedup();
    if a.repeats == 0 || a.repeats > MAX_REPEATS {
        return Err(CliError::input(format!(
            "--repeats: must be in 1..={MAX_REPEATS}, got {}",
            a.repeats
        )));
    }
    if a.reference_spp == 0 {
        return Err(CliError::input("--reference-spp: must be at least 1"));
    }
    for (flag, v) in [("--width", a.width), ("--height", a.height)] {
        if v == Some(0) {
            return Err(CliError::input(format!("{flag}: must be at least 1")));
        }
    }
    Ok(BenchConfig {
        scene: a.scene.clone(),
        reference: a.reference.clone(),
        integrators,
        times,
        repeats: a.repeats,
        width: a.width,
        height: a.height,
        reference_spp: a.reference_spp,
        kernels: a.kernels,
        out_dir: a.out.clone(),
        import: a.import.options()?,
    })
}

/// Runs `candela bench`.
pub fn run(a: BenchArgs) -> Result<(), CliError> {
    let cfg = config(&a)?;
    std::fs::create_dir_all(&cfg.out_dir)
        .map_err(|e| CliError::failure(format!("cannot create {}: {e}", cfg.out_dir.display())))?;
    let ctx = super::open_device(a.device.as_deref(), a.kernel_cache.dir())?;
    let report = run_bench(&ctx, &cfg, &mut |line| eprintln!("{line}")).map_err(|e| match e {
        BenchError::Input(m) => CliError::input(m),
        BenchError::Failure(m) => CliError::failure(m),
    })?;
    let written = write_outputs(&cfg.out_dir, &report)?;
    print!("{}", summary::stdout_table(&report));
    println!("wrote {}", written.join(", "));
    Ok(())
}

/// Writes the five result files; returns their paths.
fn write_outputs(dir: &Path, report: &BenchReport) -> Result<Vec<String>, CliError> {
    let title = ChartTitle {
        scene: report.scene.clone(),
        width: report.width,
        height: report.height,
        device: report.device.name.clone(),
        repeats: report.repeats,
    };
    let json = serde_json::to_string_pretty(report)
        .map_err(|e| CliError::failure(format!("results.json: {e}")))?;
    let files = [
        ("results.csv", csv::to_csv(&report.runs)),
        ("results.json", json + "\n"),
        (
            "chart.svg",
            chart_svg(
                &title,
                &report.summary,
                ChartMetric {
                    label: "relMSE",
                    target: REL_MSE_TARGET,
                    of: |p| p.rel_mse,
                },
            ),
        ),
        (
            "chart_flip.svg",
            chart_svg(
                &title,
                &report.summary,
                ChartMetric {
                    label: "FLIP",
                    target: FLIP_TARGET,
                    of: |p| p.flip,
                },
            ),
        ),
        ("summary.md", summary::summary_md(report)),
    ];
    let mut written = Vec::new();
    for (name, text) in files {
        let path = dir.join(name);
        std::fs::write(&path, text)
            .map_err(|e| CliError::failure(format!("cannot write {}: {e}", path.display())))?;
        written.push(path.display().to_string());
    }
    Ok(written)
}
