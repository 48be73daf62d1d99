//! `candela compare A.exr B.exr`: every image metric of A against the reference B (MSE, RMSE,
//! relMSE on linear radiance; PSNR, SSIM, FLIP on display images), the fraction of NaN/Inf pixels,
//! and optionally the FLIP error map as a magma-coloured PNG.

use std::path::{Path, PathBuf};

use clap::Args;
use renderer::film::{read_exr, Image};
use renderer::metrics::{
    tonemap_from_name, Display, MetricError, Metrics, METRIC_NOTES, REL_MSE_FORMULA,
};

use super::CliError;

/// Arguments of `candela compare`.
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// The image to judge (EXR, linear radiance).
    pub image: PathBuf,
    /// The reference image (EXR, linear radiance), same size.
    pub reference: PathBuf,
    /// Print one JSON object (metrics, their definitions, paths).
    #[arg(long)]
    pub json: bool,
    /// Write the FLIP error map here as a PNG (magma colour map: black 0, pale yellow 1).
    #[arg(long, value_name = "OUT.png")]
    pub heatmap: Option<PathBuf>,
    /// Exposure in EV applied before the display metrics (PSNR, SSIM, FLIP).
    #[arg(
        long,
        default_value_t = 0.0,
        allow_hyphen_values = true,
        value_name = "EV"
    )]
    pub exposure: f32,
    /// Tone curve before the display metrics: clamp, reinhard or aces.
    #[arg(long, default_value = "clamp")]
    pub tonemap: String,
}

/// Largest |exposure| accepted, in EV.
const MAX_EV: f32 = 64.0;

/// Checks the options and returns the display transform they name.
fn display_of(a: &CompareArgs) -> Result<Display, CliError> {
    if !(a.exposure.is_finite() && a.exposure.abs() <= MAX_EV) {
        return Err(CliError::input(format!(
            "--exposure: must be a number of EV in [-{MAX_EV}, {MAX_EV}], got {}",
            a.exposure
        )));
    }
    let tonemap = tonemap_from_name(&a.tonemap).ok_or_else(|| {
        CliError::input(format!(
            "--tonemap: unknown tone curve \"{}\" (available: clamp, reinhard, aces)",
            a.tonemap
        ))
    })?;
    if let Some(h) = &a.heatmap {
        let is_png = h
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if !is_png {
            return Err(CliError::input(format!(
                "--heatmap {}: the heatmap is a PNG, its name must end in .png",
                h.display()
            )));
        }
    }
    Ok(Display {
        exposure_ev: a.exposure,
        tonemap,
    })
}

/// Reads an EXR; any failure (missing, unreadable, not an EXR) is bad input.
fn read_input(path: &Path) -> Result<Image, CliError> {
    read_exr(path).map_err(|e| CliError::input(e.to_string()))
}

/// Runs `candela compare`.
pub fn run(a: CompareArgs) -> Result<(), CliError> {
    let display = display_of(&a)?;
    let image = read_input(&a.image)?;
    let reference = read_input(&a.reference)?;
    let (metrics, map) =
        Metrics::compute_with_map(&image, &reference, display).map_err(|e| match e {
            MetricError::SizeMismatch { .. } => CliError::input(format!(
                "{} is {}x{} but the reference {} is {}x{}",
                a.image.display(),
                image.width,
                image.height,
                a.reference.display(),
                reference.width,
                reference.height
            )),
            MetricError::NoFinitePixels { .. } => CliError::input(format!(
                "{} against {}: {e}",
                a.image.display(),
                a.reference.display()
            )),
            e => CliError::failure(e.to_string()),
        })?;
    if let Some(path) = &a.heatmap {
        let png = map
            .encode_png()
            .map_err(|e| CliError::failure(e.to_string()))?;
        std::fs::write(path, png)
            .map_err(|e| CliError::failure(format!("cannot write {}: {e}", path.display())))?;
    }
    if a.json {
        let report = serde_json::json!({
            "image": a.image.display().to_string(),
            "reference": a.reference.display().to_string(),
            "metrics": metrics,
            "notes": METRIC_NOTES,
            "heatmap": a.heatmap.as_ref().map(|p| p.display().to_string()),
        });
        println!("{report}");
    } else {
        print_text(&a, &metrics);
    }
    Ok(())
}

/// The human-readable report: one metric a line, its definition beside it.
fn print_text(a: &CompareArgs, m: &Metrics) {
    let opt = |v: Option<f64>, fmt: &dyn Fn(f64) -> String, none: &str| match v {
        Some(v) => fmt(v),
        None => none.to_string(),
    };
    println!(
        "image      {} ({}x{})",
        a.image.display(),
        m.width,
        m.height
    );
    println!("reference  {}", a.reference.display());
    println!(
        "display    exposure {} EV, tonemap {}, sRGB8 (for PSNR, SSIM, FLIP)",
        m.display.exposure_ev, m.display.tonemap
    );
    println!(
        "MSE        {:<12.6e} mean of (x-r)^2 over pixels and RGB, linear radiance",
        m.mse
    );
    println!("RMSE       {:<12.6e} sqrt(MSE)", m.rmse);
    println!("relMSE     {:<12.6e} {REL_MSE_FORMULA}", m.rel_mse);
    println!(
        "PSNR       {:<12} 10 log10(1/MSE) of the display images, peak 1",
        opt(m.psnr_db, &|v| format!("{v:.3} dB"), "inf (same)")
    );
    println!(
        "SSIM       {:<12} Wang et al. 2004, Gaussian 11x11 sigma 1.5, display luma",
        opt(m.ssim, &|v| format!("{v:.6}"), "n/a (<11px)")
    );
    println!(
        "FLIP       {:<12.6} mean LDR-FLIP of the display images (0 = identical)",
        m.flip
    );
    println!(
        "NaN/Inf    {:.4}% of image pixels, {:.4}% of reference pixels",
        100.0 * m.nan_fraction,
        100.0 * m.reference_nan_fraction
    );
    if let Some(h) = &a.heatmap {
        println!(
            "heatmap    {} (FLIP error, magma: black 0 to yellow 1)",
            h.display()
        );
    }
}
