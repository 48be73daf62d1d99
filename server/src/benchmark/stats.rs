//! Reducing repeats to a convergence curve, and time-to-quality: per integrator and budget the
//! median and min–max of each metric over the repeats; the time at which the median curves reach
//! relMSE ≤ 0.01 and FLIP ≤ 0.05, interpolated linearly in (log time, log error) between the two
//! budgets that bracket the target.

use serde::Serialize;

use super::{RunRecord, FLIP_TARGET, REL_MSE_TARGET};

/// Median, smallest and largest value over the repeats.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Spread {
    /// The median (mean of the middle two for an even count).
    pub median: f64,
    /// The smallest value.
    pub min: f64,
    /// The largest value.
    pub max: f64,
}

impl Spread {
    /// The spread of `values`; `None` when there are none.
    pub fn of(values: &[f64]) -> Option<Spread> {
        if values.is_empty() {
            return None;
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let median = if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        };
        Some(Spread {
            median,
            min: v[0],
            max: v[n - 1],
        })
    }
}

/// One integrator at one budget, over its repeats.
#[derive(Debug, Clone, Serialize)]
pub struct BudgetPoint {
    /// The budget asked for, seconds.
    pub budget_s: f64,
    /// Runs at this point.
    pub runs: usize,
    /// Actual wall time of the passes, seconds.
    pub time_s: Spread,
    /// Samples per pixel.
    pub spp: Spread,
    /// Throughput, Msamples/s.
    pub msamples_per_s: Spread,
    /// relMSE against the reference.
    pub rel_mse: Spread,
    /// FLIP against the reference.
    pub flip: Spread,
    /// SSIM (absent below 11×11).
    pub ssim: Option<Spread>,
    /// PSNR in dB (runs with identical display images, infinite PSNR, left out).
    pub psnr_db: Option<Spread>,
}

/// When a median curve reaches a target.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "how", rename_all = "snake_case")]
pub enum TimeToQuality {
    /// Between two budgets; `time_s` interpolated in log-log.
    Interpolated {
        /// Seconds.
        time_s: f64,
    },
    /// Already at the smallest budget: `time_s` is that budget's median time, an upper bound.
    AtFirstBudget {
        /// Seconds.
        time_s: f64,
    },
    /// Not within the largest budget.
    NotReached,
}

impl TimeToQuality {
    /// "0.42 s", "≤ 0.05 s" or "not reached".
    pub fn label(&self) -> String {
        match self {
            TimeToQuality::Interpolated { time_s } => format!("{} s", sig3(*time_s)),
            TimeToQuality::AtFirstBudget { time_s } => format!("<= {} s", sig3(*time_s)),
            TimeToQuality::NotReached => "not reached".into(),
        }
    }
}

/// `v` with three significant digits, no exponent for ordinary magnitudes.
pub fn sig3(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    if !(1e-4..1e6).contains(&v.abs()) {
        return format!("{v:.2e}");
    }
    format!("{v:.digits$}")
}

/// One integrator's curve and its time to quality.
#[derive(Debug, Clone, Serialize)]
pub struct IntegratorSummary {
    /// Integrator name.
    pub integrator: String,
    /// Median Msamples/s over all its runs.
    pub msamples_per_s: f64,
    /// One point per budget, ascending.
    pub points: Vec<BudgetPoint>,
    /// Time until the median relMSE ≤ [`REL_MSE_TARGET`].
    pub time_to_rel_mse: TimeToQuality,
    /// Time until the median FLIP ≤ [`FLIP_TARGET`].
    pub time_to_flip: TimeToQuality,
    /// Time until both hold.
    pub time_to_quality: TimeToQuality,
}

/// Summarises `runs` per integrator (in `integrators` order) and budget (in `times` order).
pub fn summarise(
    integrators: &[String],
    times: &[f64],
    runs: &[RunRecord],
) -> Vec<IntegratorSummary> {
    integrators
        .iter()
        .map(|name| {
            let mine: Vec<&RunRecord> = runs.iter().filter(|r| &r.integrator == name).collect();
            let points: Vec<BudgetPoint> = times.iter().filter_map(|&t| point(t, &mine)).collect();
            let throughput: Vec<f64> = mine.iter().map(|r| r.msamples_per_s).collect();
            let curve = |f: fn(&BudgetPoint) -> f64| -> Vec<(f64, f64)> {
                points.iter().map(|p| (p.time_s.median, f(p))).collect()
            };
            let rel = curve(|p| p.rel_mse.median);
            let flip = curve(|p| p.flip.median);
            IntegratorSummary {
                integrator: name.clone(),
                msamples_per_s: Spread::of(&throughput).map_or(0.0, |s| s.median),
                time_to_rel_mse: time_to(&[(&rel, REL_MSE_TARGET)]),
                time_to_flip: time_to(&[(&flip, FLIP_TARGET)]),
                time_to_quality: time_to(&[(&rel, REL_MSE_TARGET), (&flip, FLIP_TARGET)]),
                points,
            }
        })
        .collect()
}

/// The point of the runs at `budget`, `None` if there are none.
fn point(budget: f64, runs: &[&RunRecord]) -> Option<BudgetPoint> {
    let at: Vec<&&RunRecord> = runs.iter().filter(|r| r.budget_s == budget).collect();
    let of =
        |f: &dyn Fn(&RunRecord) -> f64| Spread::of(&at.iter().map(|r| f(r)).collect::<Vec<_>>());
    let opt = |f: &dyn Fn(&RunRecord) -> Option<f64>| {
        Spread::of(&at.iter().filter_map(|r| f(r)).collect::<Vec<_>>())
    };
    Some(BudgetPoint {
        budget_s: budget,
        runs: at.len(),
        time_s: of(&|r| r.time_s)?,
        spp: of(&|r| f64::from(r.spp))?,
        msamples_per_s: of(&|r| r.msamples_per_s)?,
        rel_mse: of(&|r| r.metrics.rel_mse)?,
        flip: of(&|r| r.metrics.flip)?,
        ssim: opt(&|r| r.metrics.ssim),
        psnr_db: opt(&|r| r.metrics.psnr_db),
    })
}

/// When every `(curve, target)` first holds together. Each curve is (time, error) per budget,
/// ascending in budget, all curves sampled at the same times. At the first budget `k` where all
/// errors are within target, each curve that was not already within target at `k − 1` is
/// interpolated between `k − 1` and `k`; the latest of those times is the answer.
pub fn time_to(curves: &[(&[(f64, f64)], f64)]) -> TimeToQuality {
    let n = curves.iter().map(|(c, _)| c.len()).min().unwrap_or(0);
    let ok = |k: usize| curves.iter().all(|(c, target)| c[k].1 <= *target);
    let Some(k) = (0..n).find(|&k| ok(k)) else {
        return TimeToQuality::NotReached;
    };
    if k == 0 {
        return TimeToQuality::AtFirstBudget {
            time_s: curves.iter().map(|(c, _)| c[0].0).fold(0.0, f64::max),
        };
    }
    let time_s = curves
        .iter()
        .map(|(c, target)| {
            let (a, b) = (c[k - 1], c[k]);
            if a.1 <= *target {
                a.0
            } else {
                log_log_crossing(a, b, *target)
            }
        })
        .fold(0.0, f64::max);
    TimeToQuality::Interpolated { time_s }
}

/// The time at which the line through `a` and `b` in (log t, log e) reaches `target`, for
/// `a.1 > target ≥ b.1`; clamped to `[a.0, b.0]`.
pub fn log_log_crossing(a: (f64, f64), b: (f64, f64), target: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let (lt0, lt1) = (a.0.max(TINY).ln(), b.0.max(TINY).ln());
    let (le0, le1) = (a.1.max(TINY).ln(), b.1.max(TINY).ln());
    if le0 == le1 {
        return b.0;
    }
    let s = ((target.ln() - le0) / (le1 - le0)).clamp(0.0, 1.0);
    (lt0 + s * (lt1 - lt0))
        .exp()
        .clamp(a.0.min(b.0), a.0.max(b.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_median_odd_even() {
        let s = Spread::of(&[3.0, 1.0, 2.0]).unwrap();
        assert_eq!((s.median, s.min, s.max), (2.0, 1.0, 3.0));
        assert_eq!(Spread::of(&[4.0, 1.0, 2.0, 3.0]).unwrap().median, 2.5);
        assert!(Spread::of(&[]).is_none());
    }

    #[test]
    fn crossing_is_exact_on_a_power_law() {
        // e = 0.1 / t: crosses 0.01 at t = 10.
        let a = (1.0, 0.1);
        let b = (100.0, 0.001);
        assert!((log_log_crossing(a, b, 0.01) - 10.0).abs() < 1e-9);
    }

    #[test]
    fn time_to_cases() {
        let rel = [(0.1, 0.1), (1.0, 0.02), (10.0, 0.002)];
        let flip = [(0.1, 0.2), (1.0, 0.04), (10.0, 0.01)];
        // relMSE crosses between 1 and 10: 0.02 → 0.002 per decade, 0.01 at 10^0.301.
        let TimeToQuality::Interpolated { time_s } = time_to(&[(&rel, 0.01)]) else {
            panic!()
        };
        assert!((time_s - 10f64.powf(2f64.log10())).abs() < 1e-9, "{time_s}");
        // FLIP crosses between 0.1 and 1; both hold first at t = 10, where FLIP was already
        // within target at 1, so the answer is relMSE's crossing.
        let both = time_to(&[(&rel, 0.01), (&flip, 0.05)]);
        assert_eq!(both, TimeToQuality::Interpolated { time_s });
        assert_eq!(
            time_to(&[(&rel, 0.5)]),
            TimeToQuality::AtFirstBudget { time_s: 0.1 }
        );
        assert_eq!(time_to(&[(&rel, 1e-4)]), TimeToQuality::NotReached);
        assert_eq!(time_to(&[(&[], 1.0)]), TimeToQuality::NotReached);
    }

    #[test]
    fn labels() {
        assert_eq!(TimeToQuality::NotReached.label(), "not reached");
        assert_eq!(
            TimeToQuality::AtFirstBudget { time_s: 0.05 }.label(),
            "<= 0.0500 s"
        );
        assert_eq!(sig3(12.345), "12.3");
        assert_eq!(sig3(0.5), "0.500");
        assert_eq!(sig3(1234.4), "1234");
    }
}
