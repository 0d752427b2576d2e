//! Tables in the style of the reference-Jacobian paper's examples: element
//! quality under a chosen metric (min / avg / max and the fraction of elements
//! per quality band) and vertex displacement as a percentage of the local
//! spacing.

use crate::Mesh;
use crate::error::Result;
use crate::mesh::plane::in_plane;
use crate::mesh::topology;
use crate::metric::corner_model::{Model, Template};
use crate::metric::mat3::Vec3;
use crate::metric::smetric::MetricKind;
use crate::problem::{self, Numbering, ProblemOptions};
use serde::Serialize;
use std::fmt;

/// Quality bands of the paper's tables (lower edges; the last is open).
pub const PAPER_BANDS: [f64; 8] = [1.0, 1.25, 1.5, 2.0, 3.0, 5.0, 9.0, 17.0];

#[derive(Clone, Debug, Serialize)]
pub struct MetricSummary {
    pub metric: String,
    pub min: f64,
    pub avg: f64,
    pub max: f64,
    /// (lower edge, upper edge or None, percent of elements); inverted elements are left out.
    pub bands: Vec<(f64, Option<f64>, f64)>,
    pub inverted: usize,
}

/// Per-element value of `metric` (the mean over the element's corners) at `points`.
///
/// Runs only the `check` and `corners` stages of a problem, in the mesh's own
/// numbering: no ordering, adjacency or colours.
pub fn element_values(
    mesh: &Mesh,
    points: &[Vec3],
    metric: MetricKind,
    reference: Option<&Mesh>,
) -> Result<Vec<Option<f64>>> {
    let opts = ProblemOptions {
        metric,
        template: Template::Harmonic,
        reference,
        ..Default::default()
    };
    let plane = problem::check(mesh, points, &opts)?;
    let points = in_plane(plane.as_ref(), points);
    let corners = problem::corners(mesh, &points, &opts, &Numbering::identity(mesh))?;
    let model = Model {
        metric,
        template: opts.template,
        eps: 0.0,
    };
    Ok(corners.element_values(&model, &points, mesh.num_elements()))
}

pub fn metric_summary(
    mesh: &Mesh,
    points: &[Vec3],
    metric: MetricKind,
    reference: Option<&Mesh>,
) -> Result<MetricSummary> {
    let values = element_values(mesh, points, metric, reference)?;
    let ok: Vec<f64> = values.iter().flatten().copied().collect();
    let n = ok.len().max(1) as f64;
    let bands = PAPER_BANDS
        .iter()
        .enumerate()
        .map(|(i, &lo)| {
            let hi = PAPER_BANDS.get(i + 1).copied();
            let first = i == 0;
            let count = ok
                .iter()
                .filter(|&&v| (first || v >= lo) && hi.is_none_or(|h| v < h))
                .count();
            (lo, hi, 100.0 * count as f64 / n)
        })
        .collect();
    Ok(MetricSummary {
        metric: metric.to_string(),
        min: ok.iter().copied().fold(f64::INFINITY, f64::min),
        avg: ok.iter().sum::<f64>() / n,
        max: ok.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        bands,
        inverted: values.len() - ok.len(),
    })
}

/// Vertex displacement in percent of the average local spacing (the mean
/// length of the vertex's edges in the original mesh); min, avg, max over the
/// vertices that may move.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SpacingDisplacement {
    pub min: f64,
    pub avg: f64,
    pub max: f64,
}

pub fn displacement_percent(mesh: &Mesh, before: &[Vec3], after: &[Vec3]) -> SpacingDisplacement {
    let nb = topology::vertex_neighbours(mesh);
    let fixed = topology::fixed_vertices(mesh);
    let dist = |a: &Vec3, b: &Vec3| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    let pct: Vec<f64> = (0..mesh.num_points())
        .filter(|&v| !fixed[v] && !nb.of(v).is_empty())
        .map(|v| {
            let h = nb
                .of(v)
                .iter()
                .map(|&w| dist(&before[v], &before[w as usize]))
                .sum::<f64>()
                / nb.of(v).len() as f64;
            100.0 * dist(&before[v], &after[v]) / h
        })
        .collect();
    if pct.is_empty() {
        return SpacingDisplacement {
            min: 0.0,
            avg: 0.0,
            max: 0.0,
        };
    }
    let n = pct.len() as f64;
    SpacingDisplacement {
        min: pct.iter().copied().fold(f64::INFINITY, f64::min),
        avg: pct.iter().sum::<f64>() / n,
        max: pct.iter().copied().fold(0.0, f64::max),
    }
}

/// Before/after columns side by side, as the paper prints them.
pub struct Comparison<'a> {
    pub before: &'a MetricSummary,
    pub after: &'a MetricSummary,
    pub displacement: Option<SpacingDisplacement>,
}

impl fmt::Display for Comparison<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (b, a) = (self.before, self.after);
        writeln!(f, "element quality ({} per element, mean over corners)", b.metric)?;
        writeln!(f, "{:<16} {:>12} {:>12}", "", "original", "optimised")?;
        for (name, x, y) in [("min", b.min, a.min), ("avg", b.avg, a.avg), ("max", b.max, a.max)] {
            writeln!(f, "{name:<16} {x:>12.4} {y:>12.4}")?;
        }
        writeln!(f, "fraction of elements, %")?;
        for ((lo, hi, x), (_, _, y)) in b.bands.iter().zip(&a.bands) {
            let band = match hi {
                Some(h) => format!("{lo:.2} - {h:.2}"),
                None => format!("{lo:.2} - inf"),
            };
            writeln!(f, "{band:<16} {x:>12.1} {y:>12.1}")?;
        }
        if let Some(d) = self.displacement {
            writeln!(f, "node displacement, % of the average local spacing")?;
            writeln!(
                f,
                "{:<16} {:>12.1}\n{:<16} {:>12.1}\n{:<16} {:>12.1}",
                "min", d.min, "avg", d.avg, "max", d.max
            )?;
        }
        Ok(())
    }
}
