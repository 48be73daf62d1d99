//! The convergence chart as a hand-written SVG: error against render time on log-log axes, one
//! median line per integrator (`<polyline class="median" data-integrator="NAME">`) over a band
//! from the smallest to the largest value of the repeats (`<polygon class="band">`), decade grid,
//! the target as a dashed line, axis labels and a legend.

use std::fmt::Write;

use super::stats::{sig3, BudgetPoint, IntegratorSummary, Spread};

/// Which metric a chart plots.
#[derive(Debug, Clone, Copy)]
pub struct ChartMetric {
    /// Name for labels ("relMSE").
    pub label: &'static str,
    /// The time-to-quality target, drawn dashed.
    pub target: f64,
    /// The metric of a point.
    pub of: fn(&BudgetPoint) -> Spread,
}

/// What the chart is of, for its title.
#[derive(Debug, Clone)]
pub struct ChartTitle {
    /// Scene name.
    pub scene: String,
    /// Film size.
    pub width: u32,
    /// Film size.
    pub height: u32,
    /// Device name.
    pub device: String,
    /// Repeats per point.
    pub repeats: u32,
}

/// Line colours, one per integrator in order (then repeating).
const COLOURS: &[&str] = &[
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
];

// Canvas and plot area, in SVG user units.
const W: f64 = 800.0;
const H: f64 = 500.0;
const LEFT: f64 = 80.0;
const RIGHT: f64 = 210.0;
const TOP: f64 = 60.0;
const BOTTOM: f64 = 60.0;

/// A log10 axis over whole decades.
#[derive(Debug, Clone, Copy)]
struct LogAxis {
    lo: i32,
    hi: i32,
    from: f64,
    to: f64,
}

impl LogAxis {
    /// Decades covering every positive value (one decade around 1 when there is none).
    fn covering(values: impl Iterator<Item = f64>, from: f64, to: f64) -> Self {
        let logs: Vec<f64> = values
            .filter(|v| *v > 0.0 && v.is_finite())
            .map(f64::log10)
            .collect();
        let min = logs.iter().cloned().fold(f64::INFINITY, f64::min);
        let max = logs.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let (mut lo, mut hi) = if logs.is_empty() {
            (0, 1)
        } else {
            (min.floor() as i32, max.ceil() as i32)
        };
        if hi <= lo {
            hi = lo + 1;
        }
        lo = lo.max(-300);
        LogAxis { lo, hi, from, to }
    }

    /// Position of `v` (clamped into the axis).
    fn at(&self, v: f64) -> f64 {
        let l = if v > 0.0 {
            v.log10()
        } else {
            f64::from(self.lo)
        };
        let s = ((l - f64::from(self.lo)) / f64::from(self.hi - self.lo)).clamp(0.0, 1.0);
        self.from + s * (self.to - self.from)
    }
}

/// "0.001", "10", or "1e-5" beyond four decades from 1.
fn decade_label(k: i32) -> String {
    if (-4..=4).contains(&k) {
        let v = 10f64.powi(k);
        if k < 0 {
            format!("{v:.prec$}", prec = (-k) as usize)
        } else {
            format!("{v}")
        }
    } else {
        format!("1e{k}")
    }
}

/// Escapes text for XML character data and attribute values.
pub fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

/// The SVG document for `metric` over `summary`'s curves.
pub fn chart_svg(title: &ChartTitle, summary: &[IntegratorSummary], metric: ChartMetric) -> String {
    let (x0, x1, y0, y1) = (LEFT, W - RIGHT, TOP, H - BOTTOM);
    let points = || summary.iter().flat_map(|s| s.points.iter());
    let xa = LogAxis::covering(points().map(|p| p.time_s.median), x0, x1);
    let ya = LogAxis::covering(
        points()
            .flat_map(|p| {
                let s = (metric.of)(p);
                [s.min, s.max]
            })
            .chain([metric.target]),
        y1,
        y0,
    );
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" font-family="sans-serif" font-size="12">"#
    );
    let heading = format!(
        "{} {}x{}: {} against render time",
        title.scene, title.width, title.height, metric.label
    );
    let _ = writeln!(svg, "<title>{}</title>", xml_escape(&heading));
    let _ = writeln!(svg, r#"<rect width="{W}" height="{H}" fill="white"/>"#);
    let _ = writeln!(
        svg,
        r#"<text x="{x0}" y="22" font-size="15" font-weight="bold">{}</text>"#,
        xml_escape(&heading)
    );
    let _ = writeln!(
        svg,
        r##"<text x="{x0}" y="40" fill="#555">{}</text>"##,
        xml_escape(&format!(
            "{}; median of {} repeats, band min-max; dashed: {} = {}",
            title.device, title.repeats, metric.label, metric.target
        ))
    );
    grid(&mut svg, &xa, &ya, (x0, x1, y0, y1));
    // Target line.
    let ty = ya.at(metric.target);
    let _ = writeln!(
        svg,
        r##"<line class="target" x1="{x0}" y1="{ty:.2}" x2="{x1}" y2="{ty:.2}" stroke="#444" stroke-dasharray="6 4"/>"##
    );
    // Bands first, then lines and markers on top.
    for (i, s) in summary.iter().enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        let mut band: Vec<String> = s
            .points
            .iter()
            .map(|p| {
                format!(
                    "{:.2},{:.2}",
                    xa.at(p.time_s.median),
                    ya.at((metric.of)(p).max)
                )
            })
            .collect();
        band.extend(s.points.iter().rev().map(|p| {
            format!(
                "{:.2},{:.2}",
                xa.at(p.time_s.median),
                ya.at((metric.of)(p).min)
            )
        }));
        let _ = writeln!(
            svg,
            r#"<polygon class="band" data-integrator="{}" points="{}" fill="{c}" fill-opacity="0.18" stroke="none"/>"#,
            xml_escape(&s.integrator),
            band.join(" ")
        );
    }
    for (i, s) in summary.iter().enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        let name = xml_escape(&s.integrator);
        let line: Vec<String> = s
            .points
            .iter()
            .map(|p| {
                format!(
                    "{:.2},{:.2}",
                    xa.at(p.time_s.median),
                    ya.at((metric.of)(p).median)
                )
            })
            .collect();
        let _ = writeln!(
            svg,
            r#"<polyline class="median" data-integrator="{name}" points="{}" fill="none" stroke="{c}" stroke-width="2"/>"#,
            line.join(" ")
        );
        for p in &s.points {
            let (px, spread) = (xa.at(p.time_s.median), (metric.of)(p));
            let _ = writeln!(
                svg,
                r#"<line class="spread" x1="{px:.2}" y1="{:.2}" x2="{px:.2}" y2="{:.2}" stroke="{c}"/>"#,
                ya.at(spread.min),
                ya.at(spread.max)
            );
            let _ = writeln!(
                svg,
                r#"<circle cx="{px:.2}" cy="{:.2}" r="3" fill="{c}"/>"#,
                ya.at(spread.median)
            );
        }
        // Legend entry.
        let ly = y0 + 10.0 + 20.0 * i as f64;
        let lx = x1 + 20.0;
        let _ = writeln!(
            svg,
            r#"<line x1="{lx}" y1="{ly}" x2="{}" y2="{ly}" stroke="{c}" stroke-width="2"/>"#,
            lx + 24.0
        );
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="{}">{name} ({} Msamples/s)</text>"#,
            lx + 30.0,
            ly + 4.0,
            sig3(s.msamples_per_s)
        );
    }
    // Axis labels.
    let _ = writeln!(
        svg,
        r#"<text x="{:.1}" y="{}" text-anchor="middle">render time (s, log scale)</text>"#,
        0.5 * (x0 + x1),
        H - 15.0
    );
    let _ = writeln!(
        svg,
        r#"<text transform="translate(20 {:.1}) rotate(-90)" text-anchor="middle">{} against the reference (log scale)</text>"#,
        0.5 * (y0 + y1),
        xml_escape(metric.label)
    );
    svg.push_str("</svg>\n");
    svg
}

/// Frame, decade grid lines with labels, and unlabelled 2–9 minor lines.
fn grid(svg: &mut String, xa: &LogAxis, ya: &LogAxis, (x0, x1, y0, y1): (f64, f64, f64, f64)) {
    let minor = |axis: &LogAxis| axis.hi - axis.lo <= 8;
    for k in xa.lo..=xa.hi {
        let px = xa.at(10f64.powi(k));
        let _ = writeln!(
            svg,
            r##"<line class="grid" x1="{px:.2}" y1="{y0}" x2="{px:.2}" y2="{y1}" stroke="#ccc"/>"##
        );
        let _ = writeln!(
            svg,
            r#"<text x="{px:.2}" y="{}" text-anchor="middle">{}</text>"#,
            y1 + 18.0,
            decade_label(k)
        );
        if k < xa.hi && minor(xa) {
            for m in 2..10 {
                let px = xa.at(f64::from(m) * 10f64.powi(k));
                let _ = writeln!(
                    svg,
                    r##"<line class="grid" x1="{px:.2}" y1="{y0}" x2="{px:.2}" y2="{y1}" stroke="#eee"/>"##
                );
            }
        }
    }
    for k in ya.lo..=ya.hi {
        let py = ya.at(10f64.powi(k));
        let _ = writeln!(
            svg,
            r##"<line class="grid" x1="{x0}" y1="{py:.2}" x2="{x1}" y2="{py:.2}" stroke="#ccc"/>"##
        );
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="{:.2}" text-anchor="end">{}</text>"#,
            x0 - 6.0,
            py + 4.0,
            decade_label(k)
        );
        if k < ya.hi && minor(ya) {
            for m in 2..10 {
                let py = ya.at(f64::from(m) * 10f64.powi(k));
                let _ = writeln!(
                    svg,
                    r##"<line class="grid" x1="{x0}" y1="{py:.2}" x2="{x1}" y2="{py:.2}" stroke="#eee"/>"##
                );
            }
        }
    }
    let _ = writeln!(
        svg,
        r#"<rect x="{x0}" y="{y0}" width="{}" height="{}" fill="none" stroke="black"/>"#,
        x1 - x0,
        y1 - y0
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_and_escaping() {
        assert_eq!(decade_label(-3), "0.001");
        assert_eq!(decade_label(0), "1");
        assert_eq!(decade_label(2), "100");
        assert_eq!(decade_label(-7), "1e-7");
        assert_eq!(xml_escape("a<b & \"c\""), "a&lt;b &amp; &quot;c&quot;");
    }

    #[test]
    fn log_axis_maps_decades() {
        let a = LogAxis::covering([0.05, 0.8].into_iter(), 0.0, 100.0);
        assert_eq!((a.lo, a.hi), (-2, 0));
        assert!((a.at(0.1) - 50.0).abs() < 1e-9);
        assert_eq!(a.at(0.0), 0.0);
        let one = LogAxis::covering([1.0].into_iter(), 0.0, 1.0);
        assert_eq!((one.lo, one.hi), (0, 1));
    }
}
