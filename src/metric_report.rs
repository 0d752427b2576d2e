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
use crate::problem::{self, Numbering, ProblemOptions, Target};
use rayon::prelude::*;
use serde::Serialize;
use std::fmt;

/// Quality bands of the paper's tables (lower edges; the last is open).
pub const PAPER_BANDS: [f64; 8] = [1.0, 1.25, 1.5, 2.0, 3.0, 5.0, 9.0, 17.0];

/// Quality of a mesh under one metric, banded as in the paper's tables.
#[derive(Clone, Debug, Serialize)]
pub struct MetricSummary {
    /// The metric's name.
    pub metric: String,
    /// Smallest element value (inverted elements left out).
    pub min: f64,
    /// Mean element value (inverted elements left out).
    pub avg: f64,
    /// Largest element value (inverted elements left out).
    pub max: f64,
    /// (lower edge, upper edge or None, percent of elements); inverted elements are left out.
    pub bands: Vec<(f64, Option<f64>, f64)>,
    /// Percent of elements below the first band (values under 1, which some
    /// metrics reach: tmp's ideal is 0); not counted in any band.
    pub below: f64,
    /// Number of inverted elements.
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
    values(mesh, points, points, &opts)
}

/// Per-element value of each of `metrics` at `points` against the
/// constructed `target` built once from the vertices at `targets_at` (for
/// [`Target::Input`]: the mesh before smoothing, whose regularised corners
/// are what smoothing aimed for; `points` itself to measure a mesh against
/// its own). The metrics must use the same corners (not `cn-paper`).
pub fn target_values(
    mesh: &Mesh,
    points: &[Vec3],
    metrics: &[MetricKind],
    target: Target,
    targets_at: &[Vec3],
) -> Result<Vec<Vec<Option<f64>>>> {
    let Some(&first) = metrics.first() else {
        return Ok(Vec::new());
    };
    assert!(
        metrics.iter().all(|m| m.every_corner() == first.every_corner()),
        "target_values: metrics over different corners"
    );
    let opts = ProblemOptions {
        metric: first,
        template: Template::Harmonic,
        target,
        ..Default::default()
    };
    corner_values(mesh, points, targets_at, &opts, metrics)
}

/// `opts.metric` per element at `points`, its corners (and targets) built at
/// `built_at`; both sets in the plane fitted to `built_at`.
fn values(mesh: &Mesh, points: &[Vec3], built_at: &[Vec3], opts: &ProblemOptions) -> Result<Vec<Option<f64>>> {
    Ok(corner_values(mesh, points, built_at, opts, &[opts.metric])?.remove(0))
}

/// [`values`] for each of `metrics`, from one build of the corners.
fn corner_values(
    mesh: &Mesh,
    points: &[Vec3],
    built_at: &[Vec3],
    opts: &ProblemOptions,
    metrics: &[MetricKind],
) -> Result<Vec<Vec<Option<f64>>>> {
    if points.len() != built_at.len() {
        return Err(crate::Error::InvalidArgument(format!(
            "the mesh the targets are built from has {} points, this one {}",
            built_at.len(),
            points.len()
        )));
    }
    let plane = problem::check(mesh, built_at, opts)?;
    let built = in_plane(plane.as_ref(), built_at);
    let points = in_plane(plane.as_ref(), points);
    let corners = problem::corners(mesh, &built, opts, &Numbering::identity(mesh))?;
    Ok(metrics
        .iter()
        .map(|&metric| {
            let model = Model {
                metric,
                template: opts.template,
                eps: 0.0,
            };
            corners.element_values(&model, &points, mesh.num_elements())
        })
        .collect())
}

/// The banded summary of `metric` over the elements at `points`.
pub fn metric_summary(
    mesh: &Mesh,
    points: &[Vec3],
    metric: MetricKind,
    reference: Option<&Mesh>,
) -> Result<MetricSummary> {
    Ok(summary(
        metric.to_string(),
        &element_values(mesh, points, metric, reference)?,
    ))
}

/// The banded summary of per-element `values` (`None`: inverted) under the name `metric`.
pub fn summary(metric: String, values: &[Option<f64>]) -> MetricSummary {
    let ok: Vec<f64> = values.iter().flatten().copied().collect();
    let n = ok.len().max(1) as f64;
    let bands = PAPER_BANDS
        .iter()
        .enumerate()
        .map(|(i, &lo)| {
            let hi = PAPER_BANDS.get(i + 1).copied();
            let count = ok.iter().filter(|&&v| v >= lo && hi.is_none_or(|h| v < h)).count();
            (lo, hi, 100.0 * count as f64 / n)
        })
        .collect();
    let below = 100.0 * ok.iter().filter(|&&v| v < PAPER_BANDS[0]).count() as f64 / n;
    MetricSummary {
        metric,
        min: ok.iter().copied().fold(f64::INFINITY, f64::min),
        avg: ok.iter().sum::<f64>() / n,
        max: ok.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        bands,
        below,
        inverted: values.len() - ok.len(),
    }
}

/// Vertex displacement in percent of the average local spacing (the mean
/// length of the vertex's edges in the original mesh); min, avg, max over the
/// vertices that may move.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SpacingDisplacement {
    /// Smallest, in percent.
    pub min: f64,
    /// Mean, in percent.
    pub avg: f64,
    /// Largest, in percent.
    pub max: f64,
}

/// How far the movable vertices went from `before` to `after`, in percent of their local spacing.
pub fn displacement_percent(mesh: &Mesh, before: &[Vec3], after: &[Vec3]) -> SpacingDisplacement {
    displacement_percent_on(
        mesh,
        &topology::fixed_vertices(mesh),
        &topology::vertex_neighbours(mesh),
        before,
        after,
    )
}

/// [`displacement_percent`] with the mesh's fixed vertices
/// ([`topology::fixed_vertices`]) and vertex neighbours at hand.
pub fn displacement_percent_on(
    mesh: &Mesh,
    fixed: &[bool],
    nb: &topology::Csr,
    before: &[Vec3],
    after: &[Vec3],
) -> SpacingDisplacement {
    let dist = |a: &Vec3, b: &Vec3| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    let pct: Vec<f64> = (0..mesh.num_points())
        .into_par_iter()
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
    /// The original mesh's quality.
    pub before: &'a MetricSummary,
    /// The optimised mesh's quality.
    pub after: &'a MetricSummary,
    /// The vertex displacement, if measured.
    pub displacement: Option<SpacingDisplacement>,
}

impl fmt::Display for Comparison<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let table = SideBySide {
            quality: vec![("original", self.before), ("optimised", self.after)],
            displacement: self.displacement.map(|d| ("optimised", d)).into_iter().collect(),
        };
        table.fmt(f)
    }
}

/// Any number of columns side by side, as section 6 of the rezoning paper
/// prints Original / RJ-optimised / CN-optimised: element quality (min, avg,
/// max, bands) per column, then node displacement per column.
pub struct SideBySide<'a> {
    /// (column name, quality) per column.
    pub quality: Vec<(&'a str, &'a MetricSummary)>,
    /// (column name, displacement) per column.
    pub displacement: Vec<(&'a str, SpacingDisplacement)>,
}

impl fmt::Display for SideBySide<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let row = |f: &mut fmt::Formatter<'_>, name: &str, values: &mut dyn Iterator<Item = String>| {
            write!(f, "{name:<16}")?;
            for v in values {
                write!(f, " {v:>12}")?;
            }
            writeln!(f)
        };
        if let Some((_, first)) = self.quality.first() {
            writeln!(f, "element quality ({} per element, mean over corners)", first.metric)?;
            row(f, "", &mut self.quality.iter().map(|(n, _)| n.to_string()))?;
            type Pick = fn(&MetricSummary) -> f64;
            let stats: [(&str, Pick); 3] = [("min", |s| s.min), ("avg", |s| s.avg), ("max", |s| s.max)];
            for (name, pick) in stats {
                row(
                    f,
                    name,
                    &mut self.quality.iter().map(|(_, s)| format!("{:.4}", pick(s))),
                )?;
            }
            writeln!(f, "fraction of elements, %")?;
            if self.quality.iter().any(|(_, s)| s.below > 0.0) {
                let label = format!("below {:.2}", PAPER_BANDS[0]);
                row(
                    f,
                    &label,
                    &mut self.quality.iter().map(|(_, s)| format!("{:.1}", s.below)),
                )?;
            }
            for (i, (lo, hi, _)) in first.bands.iter().enumerate() {
                let band = match hi {
                    Some(h) => format!("{lo:.2} - {h:.2}"),
                    None => format!("{lo:.2} - inf"),
                };
                row(
                    f,
                    &band,
                    &mut self.quality.iter().map(|(_, s)| format!("{:.1}", s.bands[i].2)),
                )?;
            }
        }
        if !self.displacement.is_empty() {
            writeln!(f, "node displacement, % of the average local spacing")?;
            row(f, "", &mut self.displacement.iter().map(|(n, _)| n.to_string()))?;
            type Pick = fn(&SpacingDisplacement) -> f64;
            let stats: [(&str, Pick); 3] = [("min", |d| d.min), ("avg", |d| d.avg), ("max", |d| d.max)];
            for (name, pick) in stats {
                row(
                    f,
                    name,
                    &mut self.displacement.iter().map(|(_, d)| format!("{:.1}", pick(d))),
                )?;
            }
        }
        Ok(())
    }
}

/// A mesh measured against the targets smoothing aims for: their shape
/// alone and their shape and size, and how the first layer on the walls
/// changed where the mesh before smoothing is known.
#[derive(Clone, Debug, Serialize)]
pub struct TargetReport {
    /// The targets, as settings name them (`input`, `size:h`, ...).
    pub target: String,
    /// The inverse mean ratio against the targets: 1 where a corner has its target's shape.
    pub shape: MetricSummary,
    /// The shape+size metric against the targets: 1 where a corner is its target.
    pub shape_size: MetricSummary,
    /// The first-layer height change from the mesh before to this one.
    pub first_layer: Option<crate::problem::targets::LayerChange>,
}

/// The mesh at `points` (`None`: at `before`'s own points) measured against
/// `target` built from `before`, the mesh as it was before smoothing.
/// [`Target::Auto`] is decided on `before` as smoothing decides it; `None`
/// where that is the ideal target, which the plain quality report measures.
pub fn target_report(before: &Mesh, points: Option<&[Vec3]>, target: Target) -> Result<Option<TargetReport>> {
    let target = match target {
        Target::Auto => ProblemOptions::default().resolved(before)?.0.target,
        t => t,
    };
    if !target.is_constructed() {
        return Ok(None);
    }
    let at = points.unwrap_or(&before.points);
    let metrics = [MetricKind::InverseMeanRatio, MetricKind::ShapeSize];
    let values = target_values(before, at, &metrics, target, &before.points)?;
    let [shape, shape_size] = [0, 1].map(|k| summary(metrics[k].to_string(), &values[k]));
    Ok(Some(TargetReport {
        target: target.name(),
        shape,
        shape_size,
        first_layer: points.and_then(|p| crate::problem::targets::first_layer_change(before, &before.points, p)),
    }))
}

impl fmt::Display for TargetReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let line = |f: &mut fmt::Formatter<'_>, what: &str, s: &MetricSummary| {
            writeln!(
                f,
                "  {what:<44} min {:.4}  avg {:.4}  max {:.4}{}",
                s.min,
                s.avg,
                s.max,
                if s.inverted > 0 {
                    format!("  ({} inverted)", s.inverted)
                } else {
                    String::new()
                }
            )
        };
        writeln!(f, "against the targets ({}):", self.target)?;
        line(f, "shape (imr; 1: the target's shape)", &self.shape)?;
        line(f, "shape and size (shape-size; 1: the target)", &self.shape_size)?;
        if let Some(change) = &self.first_layer {
            writeln!(f, "  {change}")?;
        }
        Ok(())
    }
}
