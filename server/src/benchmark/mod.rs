//! The speed/accuracy benchmark behind `candela bench`: render a scene with each integrator for
//! each wall-time budget, several times with fresh seeds, measure every image against a reference
//! (given, or rendered by a long `nee` run) and summarise the trade: medians and spread per budget,
//! time to reach relMSE ≤ 0.01 and FLIP ≤ 0.05, samples/s.
//!
//! Stages: [`gpu`] renders (reference, runs), [`stats`] reduces repeats and interpolates
//! time-to-quality, [`csv`], [`chart`] and [`summary`] write the results; [`provenance`] finds
//! the commit.

pub mod chart;
pub mod csv;
mod gpu;
pub mod provenance;
pub mod stats;
pub mod summary;

use std::path::PathBuf;

use renderer::gpu::DeviceInfo;
use renderer::metrics::{DisplaySettings, MetricNotes, Metrics};
use serde::Serialize;

pub use gpu::run_bench;
pub use stats::IntegratorSummary;

/// The quality a run must reach to count in time-to-quality: relMSE at most this...
pub const REL_MSE_TARGET: f64 = 0.01;
/// ...and FLIP at most this.
pub const FLIP_TARGET: f64 = 0.05;
/// The integrator that renders the reference when none is given.
pub const REFERENCE_INTEGRATOR: &str = "nee";
/// The reference's seed: far from the bench seeds (1, 2, 3, ... one per run), so no run shares
/// its samples.
pub const REFERENCE_SEED: u64 = u32::MAX as u64;

/// What to benchmark (already validated by the CLI).
#[derive(Debug, Clone)]
pub struct BenchConfig {
    /// The scene file.
    pub scene: PathBuf,
    /// A reference EXR to compare with; `None` renders one.
    pub reference: Option<PathBuf>,
    /// The integrators, each with its default options, in the order asked for.
    pub integrators: Vec<renderer::integrators::IntegratorOptions>,
    /// Wall-time budgets in seconds, ascending, distinct, positive.
    pub times: Vec<f64>,
    /// Runs per (integrator, budget), each with its own seed.
    pub repeats: u32,
    /// Film size override.
    pub width: Option<u32>,
    /// Film size override.
    pub height: Option<u32>,
    /// Samples per pixel of a rendered reference.
    pub reference_spp: u32,
    /// Where the reference is written when rendered (`DIR/reference.exr`).
    pub out_dir: PathBuf,
    /// Specialised or generic kernels for the measured runs (the reference is always rendered
    /// with specialised kernels).
    pub kernels: renderer::compile::KernelMode,
}

/// Why a benchmark failed: bad input (exit 2) or anything else (exit 1).
#[derive(Debug)]
pub enum BenchError {
    /// Bad input: a one-line message naming what and where.
    Input(String),
    /// Any other failure.
    Failure(String),
}

/// Where the reference came from.
#[derive(Debug, Clone, Serialize)]
pub struct ReferenceInfo {
    /// "file" (given with --reference) or "rendered".
    pub source: &'static str,
    /// The EXR (given, or written by the bench).
    pub path: String,
    /// Integrator of a rendered reference.
    pub integrator: Option<String>,
    /// Samples per pixel of a rendered reference.
    pub spp: Option<u32>,
    /// Seed of a rendered reference.
    pub seed: Option<u64>,
    /// Render time of a rendered reference, seconds.
    pub time_s: Option<f64>,
}

/// One timed render and its metrics against the reference.
#[derive(Debug, Clone, Serialize)]
pub struct RunRecord {
    /// The scene's name (file stem).
    pub scene: String,
    /// Integrator name.
    pub integrator: String,
    /// The wall-time budget asked for, seconds.
    pub budget_s: f64,
    /// Which repeat (0-based).
    pub repeat: u32,
    /// The render's seed (distinct for every run and from the reference's).
    pub seed: u64,
    /// Wall time the passes took, seconds (at least the budget, by up to one pass).
    pub time_s: f64,
    /// GPU time of the passes from timestamp queries, seconds.
    pub gpu_time_s: f64,
    /// Samples per pixel rendered.
    pub spp: u32,
    /// Passes run.
    pub passes: u32,
    /// Throughput: width × height × spp / time_s, millions.
    pub msamples_per_s: f64,
    /// NaN/Inf samples the kernels dropped.
    pub dropped_samples: u64,
    /// Kernel build and scene upload, seconds (not part of time_s).
    pub setup_s: f64,
    /// Every metric against the reference.
    #[serde(flatten)]
    pub metrics: Metrics,
    /// The device's name.
    pub device: String,
    /// The commit (`git rev-parse`), "-dirty" when the tree has changes; `None` outside git.
    pub commit: Option<String>,
}

/// The targets of time-to-quality, for reports.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Targets {
    /// relMSE at most this.
    pub rel_mse: f64,
    /// FLIP at most this.
    pub flip: f64,
}

/// Everything a benchmark measured: what `results.json` holds.
#[derive(Debug, Clone, Serialize)]
pub struct BenchReport {
    /// The scene's name (file stem).
    pub scene: String,
    /// The scene file as given.
    pub scene_path: String,
    /// Film width.
    pub width: u32,
    /// Film height.
    pub height: u32,
    /// The Vulkan device.
    pub device: DeviceInfo,
    /// The commit, if `git rev-parse` works here.
    pub commit: Option<String>,
    /// The display transform of PSNR, SSIM and FLIP (the scene's film settings).
    pub display: DisplaySettings,
    /// Where the reference came from.
    pub reference: ReferenceInfo,
    /// Integrators, in the order asked.
    pub integrators: Vec<String>,
    /// Budgets, seconds, ascending.
    pub budgets_s: Vec<f64>,
    /// Runs per (integrator, budget).
    pub repeats: u32,
    /// Time-to-quality targets.
    pub targets: Targets,
    /// Definitions of the metrics.
    pub notes: MetricNotes,
    /// Every run, in the order they ran.
    pub runs: Vec<RunRecord>,
    /// Per integrator: medians and spread per budget, time to quality, throughput.
    pub summary: Vec<IntegratorSummary>,
}
