//! The default terminal report: what was read, why vertices are fixed, and
//! the quality before and after in a few plain lines (`-v` prints the full
//! reports instead).

use meshsmooth::mesh::fixing::RuleCount;
use meshsmooth::metric_report::{MetricSummary, SpacingDisplacement};
use meshsmooth::report::{QualityReport, num};
use meshsmooth::smoother::{Fixed, Start};

/// The column titles of the before/after rows, with what the numbers are.
const QUALITY_HEAD: &str = "quality: inverse mean ratio of each element, 1 for the ideal shape, higher is worse\n\
                            (F, the objective, is its mean)";

/// What was read: dimension, counts, kinds.
pub fn mesh_line(q: &QualityReport) -> String {
    let kinds: Vec<String> = q.kinds.iter().map(|(k, c)| format!("{c} {k}")).collect();
    format!(
        "{} mesh: {} vertices, {} elements ({})",
        q.kind_name(),
        q.vertices,
        q.elements,
        kinds.join(", ")
    )
}

/// How many vertices stay where they are, and why.
pub fn fixed_line(fixed: &Fixed, vertices: usize, sliding: bool) -> String {
    if fixed.total() == 0 {
        return format!("all {vertices} vertices may move");
    }
    let mut why = Vec::new();
    if fixed.skin > 0 {
        why.push(if sliding {
            format!(
                "{} on the boundary (with --boundary slide only corners and marked vertices stay)",
                fixed.skin
            )
        } else {
            format!(
                "{} on the boundary (the default; --boundary slide lets them slide)",
                fixed.skin
            )
        });
    }
    if fixed.file > 0 {
        why.push(format!("{} inside, marked fixed in the file", fixed.file));
    }
    if fixed.rules > 0 {
        why.push(format!("{} inside, by the options below", fixed.rules));
    }
    if fixed.unused > 0 {
        why.push(format!("{} used by no element", fixed.unused));
    }
    format!("fixed {} of {vertices} vertices: {}", fixed.total(), why.join("; "))
}

/// What one fixed-vertex rule did, in a line.
pub fn rule(c: &RuleCount) -> String {
    format!(
        "  {} {}: {} vertices",
        super::device::flag(c.option),
        c.value,
        c.vertices
    )
}

/// The lines printed as the run starts (after the notes).
pub fn start(start: &Start) -> String {
    let q = &start.quality;
    let mut out = vec![
        mesh_line(q),
        fixed_line(&start.fixed, q.vertices, start.sliding.is_some()),
    ];
    out.extend(start.rules.iter().map(rule));
    if let Some(s) = &start.sliding {
        out.push(format!(
            "{} vertices slide on {}, {} along feature edges; {} corners fixed (feature angle {}°)",
            s.surface,
            if s.geometry {
                "the --surface geometry"
            } else {
                "boundary faces"
            },
            s.edge,
            s.corners,
            s.feature_angle
        ));
    }
    if let Some(note) = &start.targets {
        out.push(note.clone());
    }
    out.push(QUALITY_HEAD.to_string());
    out.push(quality_row(
        "",
        ["mean", "median", "worst", "inverted"].map(String::from),
    ));
    out.push(row("before", q));
    out.join("\n")
}

/// The quality row after the run.
pub fn after(q: &QualityReport) -> String {
    row("after", q)
}

fn row(name: &str, q: &QualityReport) -> String {
    quality_row(
        name,
        [
            num(q.eta.avg),
            num(q.eta.median),
            num(q.eta.max),
            q.inverted.to_string(),
        ],
    )
}

fn quality_row(name: &str, cells: [String; 4]) -> String {
    format!(
        "  {name:<8}{:>12}{:>12}{:>12}{:>10}",
        cells[0], cells[1], cells[2], cells[3]
    )
}

/// How far vertices moved, in a line.
pub fn moved(d: &SpacingDisplacement) -> String {
    format!(
        "moved {:.1}% of the local edge length on average, {:.1}% at most",
        d.avg, d.max
    )
}

/// Another metric's values before and after, in a line.
pub fn metric(before: &MetricSummary, after: &MetricSummary) -> String {
    format!(
        "{} (lower is better): mean {} -> {}, worst {} -> {}",
        before.metric,
        num(before.avg),
        num(after.avg),
        num(before.max),
        num(after.max)
    )
}
