//! Small SVG charts: solver histories (objective and gradient norm against
//! time, as in Figures 2-3 of the Newton paper), time-ratio curves, and
//! plain curves on linear axes (objective against time per ordering, as in
//! Figure 5 of the reordering paper). Plain SVG text keeps the tool free of
//! font and rendering dependencies.

use crate::solve::History;
use std::fmt::Write;

const W: f64 = 420.0;
const H: f64 = 300.0;
const PAD: f64 = 55.0;
const COLORS: [&str; 6] = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"];

struct Panel<'a> {
    title: &'a str,
    log: bool,
    value: fn(&crate::solve::Record) -> f64,
}

/// Two panels side by side: F(t) on a linear axis, |grad F|(t) on a log axis.
pub fn histories_svg(series: &[(String, &History)]) -> String {
    let panels = [
        Panel {
            title: "objective F",
            log: false,
            value: |r| r.objective,
        },
        Panel {
            title: "|grad F| (log10)",
            log: true,
            value: |r| r.grad_norm,
        },
    ];
    let tmax = series
        .iter()
        .flat_map(|(_, h)| h.records.iter().map(|r| r.seconds))
        .fold(0.0, f64::max)
        .max(1e-9);
    let mut svg = String::new();
    let width = 2.0 * W + 20.0;
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{}" font-family="sans-serif" font-size="11">"#,
        H + 40.0
    );
    let _ = writeln!(svg, r#"<rect width="100%" height="100%" fill="white"/>"#);
    for (pi, panel) in panels.iter().enumerate() {
        let x0 = pi as f64 * (W + 20.0);
        let tr = |v: f64| if panel.log { v.max(1e-300).log10() } else { v };
        let vals: Vec<f64> = series
            .iter()
            .flat_map(|(_, h)| h.records.iter().map(|r| tr((panel.value)(r))))
            .collect();
        let (mut lo, mut hi) = vals
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        if !(hi > lo) {
            lo -= 0.5;
            hi += 0.5;
        }
        let sx = |t: f64| x0 + PAD + (W - PAD - 10.0) * t / tmax;
        let sy = |v: f64| 20.0 + (H - PAD) * (1.0 - (v - lo) / (hi - lo));
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="14" text-anchor="middle" font-weight="bold">{}</text>"#,
            x0 + W / 2.0,
            panel.title
        );
        let _ = writeln!(
            svg,
            r#"<rect x="{}" y="20" width="{}" height="{}" fill="none" stroke="black"/>"#,
            x0 + PAD,
            W - PAD - 10.0,
            H - PAD
        );
        for k in 0..=4 {
            let v = lo + (hi - lo) * k as f64 / 4.0;
            let t = tmax * k as f64 / 4.0;
            let label = if panel.log {
                format!("1e{v:.1}")
            } else {
                format!("{v:.5}")
            };
            let _ = writeln!(
                svg,
                r#"<text x="{}" y="{}" text-anchor="end">{label}</text>"#,
                x0 + PAD - 4.0,
                sy(v) + 4.0
            );
            let _ = writeln!(
                svg,
                r#"<text x="{}" y="{}" text-anchor="middle">{t:.3}</text>"#,
                sx(t),
                H - PAD + 36.0
            );
        }
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="{}" text-anchor="middle">seconds</text>"#,
            x0 + W / 2.0,
            H - PAD + 52.0
        );
        for (si, (name, h)) in series.iter().enumerate() {
            let color = COLORS[si % COLORS.len()];
            let pts: Vec<String> = h
                .records
                .iter()
                .map(|r| format!("{:.2},{:.2}", sx(r.seconds), sy(tr((panel.value)(r)))))
                .collect();
            let _ = writeln!(
                svg,
                r#"<polyline fill="none" stroke="{color}" stroke-width="1.5" points="{}"/>"#,
                pts.join(" ")
            );
            let _ = writeln!(
                svg,
                r#"<text x="{}" y="{}" fill="{color}" text-anchor="end">{name}</text>"#,
                x0 + W - 16.0,
                36.0 + 14.0 * si as f64
            );
        }
    }
    svg.push_str("</svg>\n");
    svg
}

/// Time-ratio curves (Figures 3 and 5-7 of the Newton paper): for each
/// series, Newton's time over BCD's against the improvement level in
/// percent, on a log axis with the line at 1 where the preferred method
/// changes. Missing points break nothing: a series is drawn through the
/// levels it has.
pub fn ratios_svg(title: &str, levels: &[f64], series: &[(String, Vec<Option<f64>>)]) -> String {
    let vals: Vec<f64> = series
        .iter()
        .flat_map(|(_, r)| r.iter().flatten().map(|v| v.max(1e-6).log10()))
        .chain([0.0])
        .collect();
    let (mut lo, mut hi) = vals
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    lo = lo.floor().min(-0.5);
    hi = hi.ceil().max(0.5);
    let width = W + 160.0;
    let sx = |l: f64| PAD + (W - PAD - 10.0) * l / 100.0;
    let sy = |v: f64| 20.0 + (H - PAD) * (1.0 - (v - lo) / (hi - lo));
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{}" font-family="sans-serif" font-size="11">"#,
        H + 40.0
    );
    let _ = writeln!(svg, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="14" text-anchor="middle" font-weight="bold">{title}</text>"#,
        W / 2.0
    );
    let _ = writeln!(
        svg,
        r#"<rect x="{PAD}" y="20" width="{}" height="{}" fill="none" stroke="black"/>"#,
        W - PAD - 10.0,
        H - PAD
    );
    let _ = writeln!(
        svg,
        r#"<line x1="{PAD}" y1="{y}" x2="{}" y2="{y}" stroke="gray" stroke-dasharray="4,3"/>"#,
        W - 10.0,
        y = sy(0.0)
    );
    let mut v = lo;
    while v <= hi + 1e-9 {
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="{}" text-anchor="end">{:.2}</text>"#,
            PAD - 4.0,
            sy(v) + 4.0,
            10f64.powf(v)
        );
        v += 0.5;
    }
    for l in [0.0, 25.0, 50.0, 75.0, 100.0] {
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="{}" text-anchor="middle">{l}</text>"#,
            sx(l),
            H - PAD + 36.0
        );
    }
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="{}" text-anchor="middle">improvement (%); Newton time / BCD time, above 1: BCD faster</text>"#,
        W / 2.0,
        H - PAD + 52.0
    );
    for (si, (name, r)) in series.iter().enumerate() {
        let color = COLORS[si % COLORS.len()];
        let pts: Vec<String> = levels
            .iter()
            .zip(r)
            .filter_map(|(&l, v)| v.map(|v| format!("{:.2},{:.2}", sx(l), sy(v.max(1e-6).log10()))))
            .collect();
        let _ = writeln!(
            svg,
            r#"<polyline fill="none" stroke="{color}" stroke-width="1.5" points="{}"/>"#,
            pts.join(" ")
        );
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="{}" fill="{color}">{name}</text>"#,
            W + 4.0,
            30.0 + 14.0 * si as f64
        );
    }
    svg.push_str("</svg>\n");
    svg
}

/// Ten distinguishable colours (a pair of curves may share one, told apart
/// by dashing).
const PALETTE: [&str; 10] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
];

/// One curve of [`curves_svg`].
#[derive(Clone, Debug)]
pub struct Curve {
    /// The legend's entry.
    pub name: String,
    /// Index into a ten-colour palette (taken modulo 10).
    pub color: usize,
    /// Drawn dashed.
    pub dashed: bool,
    /// (x, y) in data units; non-finite points are left out.
    pub points: Vec<(f64, f64)>,
}

/// Curves of y against x on linear axes (x from 0), one polyline each with
/// a `data-series` attribute naming it, and a legend on the right. The plot
/// frame (`class="frame"`) carries its data ranges as `data-x` and `data-y`
/// ("low high"), so that a reader can map the points back to data.
pub fn curves_svg(title: &str, x_label: &str, y_label: &str, curves: &[Curve]) -> String {
    let finite = |&(x, y): &(f64, f64)| x.is_finite() && y.is_finite();
    let pts = || curves.iter().flat_map(|c| c.points.iter().filter(|p| finite(p)));
    let xhi = pts().map(|p| p.0).fold(0.0, f64::max).max(1e-9);
    let (mut ylo, mut yhi) = pts().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.1), b.max(p.1)));
    if !(yhi > ylo) {
        let mid = if ylo.is_finite() { ylo } else { 0.0 };
        (ylo, yhi) = (mid - 0.5, mid + 0.5);
    }
    let (left, top, width, height) = (PAD + 20.0, 20.0, W - PAD - 10.0, H - PAD);
    let sx = |x: f64| left + width * x / xhi;
    let sy = |y: f64| top + height * (1.0 - (y - ylo) / (yhi - ylo));
    let legend_rows = curves.len().div_ceil(2);
    let total_h = (H + 40.0).max(40.0 + 14.0 * legend_rows as f64);
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{total_h}" font-family="sans-serif" font-size="11">"#,
        W + 20.0 + 190.0
    );
    let _ = writeln!(svg, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="14" text-anchor="middle" font-weight="bold">{}</text>"#,
        left + width / 2.0,
        escape(title)
    );
    let _ = writeln!(
        svg,
        r#"<rect class="frame" x="{left}" y="{top}" width="{width}" height="{height}" fill="none" stroke="black" data-x="0 {xhi}" data-y="{ylo} {yhi}"/>"#
    );
    for k in 0..=4 {
        let y = ylo + (yhi - ylo) * k as f64 / 4.0;
        let x = xhi * k as f64 / 4.0;
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="{}" text-anchor="end">{}</text>"#,
            left - 4.0,
            sy(y) + 4.0,
            short(y, yhi - ylo)
        );
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
            sx(x),
            top + height + 16.0,
            short(x, xhi)
        );
    }
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
        left + width / 2.0,
        top + height + 32.0,
        escape(x_label)
    );
    let _ = writeln!(
        svg,
        r#"<text transform="translate(12,{}) rotate(-90)" text-anchor="middle">{}</text>"#,
        top + height / 2.0,
        escape(y_label)
    );
    for (i, c) in curves.iter().enumerate() {
        let color = PALETTE[c.color % PALETTE.len()];
        let dash = if c.dashed { r#" stroke-dasharray="5,3""# } else { "" };
        let points: Vec<String> = c
            .points
            .iter()
            .filter(|p| finite(p))
            .map(|&(x, y)| format!("{:.3},{:.3}", sx(x), sy(y)))
            .collect();
        let _ = writeln!(
            svg,
            r#"<polyline data-series="{}" fill="none" stroke="{color}" stroke-width="1.2"{dash} points="{}"/>"#,
            escape(&c.name),
            points.join(" ")
        );
        // two legend columns
        let (lx, ly) = (W + 20.0 + 95.0 * (i % 2) as f64, 30.0 + 14.0 * (i / 2) as f64);
        let _ = writeln!(
            svg,
            r#"<line x1="{lx}" y1="{y}" x2="{}" y2="{y}" stroke="{color}" stroke-width="1.5"{dash}/>"#,
            lx + 18.0,
            y = ly - 4.0
        );
        let _ = writeln!(svg, r#"<text x="{}" y="{ly}">{}</text>"#, lx + 22.0, escape(&c.name));
    }
    svg.push_str("</svg>\n");
    svg
}

/// An axis label with as many digits as the axis span needs.
fn short(v: f64, span: f64) -> String {
    let digits = (2.0 - span.abs().max(1e-12).log10().floor()).clamp(0.0, 10.0) as usize;
    format!("{v:.digits$}")
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::Record;

    #[test]
    fn ratio_svg_draws_each_series_and_the_unit_line() {
        let levels = [10.0, 50.0, 90.0];
        let svg = ratios_svg(
            "t",
            &levels,
            &[
                ("a".into(), vec![Some(2.0), None, Some(0.5)]),
                ("b".into(), vec![None, None, None]),
            ],
        );
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert!(svg.contains("stroke-dasharray") && !svg.contains("NaN") && !svg.contains("inf"));
    }

    #[test]
    fn svg_has_a_polyline_per_series_and_panel() {
        let mut h = History::default();
        for i in 0..5 {
            h.push(Record {
                iteration: i,
                seconds: i as f64 * 0.1,
                objective: 2.0 - 0.1 * i as f64,
                grad_norm: 10f64.powi(-(i as i32)),
            });
        }
        let svg = histories_svg(&[("bcd".into(), &h), ("newton".into(), &h)]);
        assert_eq!(svg.matches("<polyline").count(), 4);
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
    }

    #[test]
    fn curves_keep_their_data_behind_the_frames_ranges() {
        let curves = vec![
            Curve {
                name: "N".into(),
                color: 0,
                dashed: false,
                points: vec![(0.0, 2.0), (0.5, 1.5), (1.0, 1.25)],
            },
            Curve {
                name: "-N".into(),
                color: 0,
                dashed: true,
                points: vec![(0.0, 2.0), (0.8, 1.0), (f64::NAN, 3.0)],
            },
        ];
        let svg = curves_svg("t", "seconds", "F", &curves);
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert!(
            svg.contains(r#"data-x="0 1""#) && svg.contains(r#"data-y="1 2""#),
            "{svg}"
        );
        // (0.8, 1.0): four fifths across the frame, on its bottom edge
        let (left, width, bottom) = (PAD + 20.0, W - PAD - 10.0, 20.0 + H - PAD);
        assert!(
            svg.contains(&format!("{:.3},{:.3}", left + 0.8 * width, bottom)),
            "{svg}"
        );
        assert!(svg.contains("stroke-dasharray") && !svg.contains("NaN"));
    }
}
