//! `results.csv`: one row per run (RFC 4180: comma-separated, a header row, fields with commas,
//! quotes or newlines quoted). Numbers are written in Rust's shortest round-trip form; an absent
//! value (SSIM below 11×11, infinite PSNR, no commit) is an empty field.

use super::RunRecord;

/// The header, in column order.
pub const COLUMNS: &[&str] = &[
    "scene",
    "integrator",
    "budget_s",
    "repeat",
    "seed",
    "time_s",
    "gpu_time_s",
    "spp",
    "passes",
    "msamples_per_s",
    "mse",
    "rmse",
    "rel_mse",
    "psnr_db",
    "ssim",
    "flip",
    "nan_fraction",
    "dropped_samples",
    "width",
    "height",
    "device",
    "commit",
];

/// The CSV text of `runs`, header first, `\n` line ends.
pub fn to_csv(runs: &[RunRecord]) -> String {
    let mut out = COLUMNS.join(",");
    out.push('\n');
    for r in runs {
        let m = &r.metrics;
        let opt = |v: Option<f64>| v.map(|v| v.to_string()).unwrap_or_default();
        let fields = [
            quote(&r.scene),
            quote(&r.integrator),
            r.budget_s.to_string(),
            r.repeat.to_string(),
            r.seed.to_string(),
            r.time_s.to_string(),
            r.gpu_time_s.to_string(),
            r.spp.to_string(),
            r.passes.to_string(),
            r.msamples_per_s.to_string(),
            m.mse.to_string(),
            m.rmse.to_string(),
            m.rel_mse.to_string(),
            opt(m.psnr_db),
            opt(m.ssim),
            m.flip.to_string(),
            m.nan_fraction.to_string(),
            r.dropped_samples.to_string(),
            m.width.to_string(),
            m.height.to_string(),
            quote(&r.device),
            quote(r.commit.as_deref().unwrap_or("")),
        ];
        debug_assert_eq!(fields.len(), COLUMNS.len());
        out.push_str(&fields.join(","));
        out.push('\n');
    }
    out
}

/// A text field, quoted (with inner quotes doubled) when it holds a comma, quote or line break.
pub fn quote(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quoting() {
        assert_eq!(quote("pt"), "pt");
        assert_eq!(
            quote("llvmpipe (LLVM 15.0.6, 256 bits)"),
            "\"llvmpipe (LLVM 15.0.6, 256 bits)\""
        );
        assert_eq!(quote("a\"b"), "\"a\"\"b\"");
    }
}
