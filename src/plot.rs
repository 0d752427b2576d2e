//! A small SVG chart of solver histories (objective and gradient norm
//! against time, as in Figures 2-3 of the Newton paper). Plain SVG text keeps
//! the tool free of font and rendering dependencies.

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
}
