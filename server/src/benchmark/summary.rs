//! `summary.md` (what was measured, time-to-quality per integrator, medians per budget, the
//! chart) and the short table `candela bench` prints.

use std::fmt::Write;

use super::stats::{sig3, Spread};
use super::{BenchReport, FLIP_TARGET, REL_MSE_TARGET};
use renderer::metrics::REL_MSE_FORMULA;

/// How the reference is described in reports.
pub fn reference_line(r: &BenchReport) -> String {
    let x = &r.reference;
    match (x.source, &x.integrator, x.spp) {
        ("rendered", Some(i), Some(spp)) => format!(
            "rendered with {i} at {spp} spp (seed {}, {} s), {}",
            x.seed.unwrap_or(0),
            sig3(x.time_s.unwrap_or(0.0)),
            x.path
        ),
        _ => format!("file {}", x.path),
    }
}

/// `median (min–max)` with three significant digits.
fn spread(s: &Spread) -> String {
    format!("{} ({}–{})", sig3(s.median), sig3(s.min), sig3(s.max))
}

/// The Markdown summary.
pub fn summary_md(r: &BenchReport) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# candela bench: {}\n", r.scene);
    let _ = writeln!(md, "- scene: `{}`, {}×{}", r.scene_path, r.width, r.height);
    let _ = writeln!(
        md,
        "- device: {} ({}, Vulkan {}), driver {}",
        r.device.name, r.device.kind, r.device.api_version, r.device.driver
    );
    let _ = writeln!(
        md,
        "- commit: {}",
        r.commit.as_deref().unwrap_or("unknown (no git)")
    );
    let _ = writeln!(md, "- reference: {}", reference_line(r));
    let budgets: Vec<String> = r.budgets_s.iter().map(|t| format!("{t}")).collect();
    let _ = writeln!(
        md,
        "- budgets: {} s; {} repeats each, every run a cleared session with its own seed",
        budgets.join(", "),
        r.repeats
    );
    let _ = writeln!(
        md,
        "- display for PSNR, SSIM, FLIP: exposure {} EV, tonemap {}, sRGB8",
        r.display.exposure_ev, r.display.tonemap
    );
    let _ = writeln!(md, "- relMSE = {REL_MSE_FORMULA}");
    let _ = writeln!(
        md,
        "\n## Time to quality (relMSE ≤ {REL_MSE_TARGET} and FLIP ≤ {FLIP_TARGET})\n"
    );
    let _ = writeln!(
        md,
        "| integrator | Msamples/s | time to relMSE ≤ {REL_MSE_TARGET} | time to FLIP ≤ {FLIP_TARGET} | time to both |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|");
    for s in &r.summary {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} |",
            s.integrator,
            sig3(s.msamples_per_s),
            s.time_to_rel_mse.label(),
            s.time_to_flip.label(),
            s.time_to_quality.label()
        );
    }
    let _ = writeln!(
        md,
        "\nTimes are render times (passes only) of the median curves, interpolated linearly in \
         log time and log error between the two budgets that bracket the target; \"<= t\" means \
         the smallest budget already reached it; Msamples/s is the median over all runs.\n"
    );
    let _ = writeln!(md, "## Medians per budget (min–max over repeats)\n");
    let _ = writeln!(
        md,
        "| integrator | budget s | time s | spp | relMSE | FLIP | SSIM | PSNR dB |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|");
    for s in &r.summary {
        for p in &s.points {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} | {} | {} | {} |",
                s.integrator,
                p.budget_s,
                sig3(p.time_s.median),
                sig3(p.spp.median),
                spread(&p.rel_mse),
                spread(&p.flip),
                p.ssim.as_ref().map_or("n/a".into(), spread),
                p.psnr_db.as_ref().map_or("n/a".into(), spread),
            );
        }
    }
    let _ = writeln!(
        md,
        "\n![relMSE against time](chart.svg)\n\n![FLIP against time](chart_flip.svg)"
    );
    md
}

/// The short table for stdout: medians per integrator and budget, then time to quality.
pub fn stdout_table(r: &BenchReport) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{} {}x{} on {}; reference {}; medians of {} repeats",
        r.scene,
        r.width,
        r.height,
        r.device.name,
        reference_line(r),
        r.repeats
    );
    let _ = writeln!(
        out,
        "{:<10} {:>9} {:>9} {:>8} {:>11} {:>11} {:>8} {:>8}",
        "integrator", "budget_s", "time_s", "spp", "Msamples/s", "relMSE", "FLIP", "SSIM"
    );
    for s in &r.summary {
        for p in &s.points {
            let _ = writeln!(
                out,
                "{:<10} {:>9} {:>9} {:>8} {:>11} {:>11.4e} {:>8.4} {:>8}",
                s.integrator,
                p.budget_s,
                sig3(p.time_s.median),
                sig3(p.spp.median),
                sig3(p.msamples_per_s.median),
                p.rel_mse.median,
                p.flip.median,
                p.ssim.map_or("n/a".into(), |v| format!("{:.4}", v.median)),
            );
        }
    }
    let _ = writeln!(
        out,
        "time to relMSE <= {REL_MSE_TARGET} and FLIP <= {FLIP_TARGET} (relMSE = {REL_MSE_FORMULA}):"
    );
    for s in &r.summary {
        let _ = writeln!(
            out,
            "  {:<10} {:<14} (relMSE {}, FLIP {}), {} Msamples/s",
            s.integrator,
            s.time_to_quality.label(),
            s.time_to_rel_mse.label(),
            s.time_to_flip.label(),
            sig3(s.msamples_per_s)
        );
    }
    out
}
