//! Untangling: from a mesh with inverted corners to one whose every corner
//! has a positive Jacobian determinant, through the same solvers and backends
//! as smoothing.
//!
//! The method is that of Garanzha, Kaporin, Kudryavtseva, Protais, Ray and
//! Sokolov, "Foldover-free maps in 50 lines of code" (ACM TOG 40(4), 2021;
//! reference code github.com/ssloy/invertible-maps): det S is replaced by the
//! regularised chi(det S, eps) = (det S + sqrt(eps^2 + det S^2)) / 2 in the
//! metric (`smetric::eval_regularised`, `Model::eps`), so that an inverted
//! corner has a finite term whose gradient unfolds it. For a decreasing
//! sequence of eps the regularised F is minimised (inner solve: the chosen
//! method, Newton by default), and eps follows their schedule from the
//! smallest determinant and the relative decrease of F:
//!
//! ```text
//! sigma = max(1 - F_end / F_start, 0.1)
//! mu    = (1 - sigma) chi(min det, eps)
//! eps   = 2 sqrt(mu (mu - min det))   if min det < mu, else the floor
//! ```
//!
//! It stops as soon as every corner is positive with a margin: det S above
//! `UntangleParams::margin` times (|S|^2 / n)^(n/2), the determinant of the
//! scaled rotation of the same size, so that the margin is unit-free, holds
//! for small elements of a graded mesh as for large ones, and keeps f32
//! rounding on a GPU from seeing a corner inverted that f64 sees valid. The
//! barrier optimisation (`solve`) then takes over and keeps it so.
//!
//! The inverse mean ratio and the condition number are regularised as they
//! are; the target metric `tmp` has no determinant to regularise, so a
//! problem with `tmp` untangles with the inverse mean ratio towards the same
//! targets. The template is always the harmonic one (the average template's
//! 1 - 1/m is bounded and would let an inverted corner stay cheap).

use super::{Options, Record, StopReason, in_mesh_frame, run};
use crate::Mesh;
use crate::error::{Error, Result};
use crate::metric::corner_model::{Model, Template};
use crate::metric::mat3::Vec3;
use crate::metric::smetric::{self, MetricKind};
use crate::problem::{Problem, ProblemOptions};
use std::time::Instant;

/// Untangling's settings (the inner solves take the method, device and line
/// searches of `Options`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UntangleParams {
    /// Most eps updates (outer iterations).
    pub max_rounds: usize,
    /// Iterations of each inner solve.
    pub inner_max_iter: usize,
    /// Unit-free gradient tolerance of each inner solve.
    pub inner_tol: f64,
    /// A corner counts as untangled when det S > margin (|S|^2 / n)^(n/2)
    /// (its mean ratio to the power n/2 exceeds `margin`).
    pub margin: f64,
}

impl Default for UntangleParams {
    fn default() -> Self {
        UntangleParams {
            max_rounds: 60,
            inner_max_iter: 30,
            inner_tol: 1e-4,
            margin: 1e-4,
        }
    }
}

/// What untangling did.
#[derive(Clone, Debug, PartialEq)]
pub struct UntangleInfo {
    /// Elements with an inverted or degenerate corner before and after.
    pub inverted_before: usize,
    /// Elements with an inverted or degenerate corner after.
    pub inverted_after: usize,
    /// Corners with det S <= 0 before.
    pub inverted_corners_before: usize,
    /// Corners below the margin before and after.
    pub corners_before: usize,
    /// Corners below the margin after.
    pub corners_after: usize,
    /// Outer iterations (eps values tried) and inner iterations in all.
    pub rounds: usize,
    /// Inner iterations over all rounds.
    pub iterations: usize,
    /// (eps, smallest det S after the round's solve), one per round, in the
    /// solver's frame.
    pub schedule: Vec<(f64, f64)>,
    /// Wall-clock seconds of the untangling.
    pub seconds: f64,
    /// Where the inner solves ran.
    pub device: String,
}

impl UntangleInfo {
    /// True when no element and no corner is left inverted or below the margin.
    pub fn untangled(&self) -> bool {
        self.inverted_after == 0 && self.corners_after == 0
    }
}

/// The model untangling minimises for a problem's model (see the module
/// documentation), at `eps`.
pub fn untangling_model(model: Model, eps: f64) -> Model {
    Model {
        metric: match model.metric {
            MetricKind::TargetShapeSize => MetricKind::InverseMeanRatio,
            m => m,
        },
        template: Template::Harmonic,
        eps,
    }
}

/// Corners whose det S is not above `margin` (|S|^2 / n)^(n/2), and the
/// smallest det S.
pub fn corners_below_margin(p: &Problem, x: &[Vec3], margin: f64) -> (Vec<usize>, f64) {
    let n = p.dim;
    let mut min_det = f64::INFINITY;
    let mut bad = Vec::new();
    for c in 0..p.num_corners() {
        let s = p.shape(c).tet.s_rest(&p.corner_points(x, c), usize::MAX);
        let d = smetric::det_n(&s, n);
        let mut f = 0.0;
        for row in s.iter().take(n) {
            for v in row.iter().take(n) {
                f += v * v;
            }
        }
        let size = (f / n as f64).powf(0.5 * n as f64);
        min_det = min_det.min(d);
        if !(d > margin * size) {
            bad.push(c);
        }
    }
    (bad, min_det)
}

/// Inverted elements (mesh numbering) whose vertices are all fixed: no
/// untangler can move them.
pub fn pinned_inverted(p: &Problem, x: &[Vec3]) -> Vec<usize> {
    let inverted = p.infeasible_elements(x);
    let mut new_of_old = vec![0u32; p.num_elements()];
    for (new, &old) in p.elem_order.iter().enumerate() {
        new_of_old[old as usize] = new as u32;
    }
    inverted
        .into_iter()
        .filter(|&e| {
            p.elements
                .of(new_of_old[e] as usize)
                .iter()
                .all(|&v| !p.free[v as usize])
        })
        .collect()
}

/// The error for a mesh that stays tangled: which elements, and why.
fn failure(p: &Problem, x: &[Vec3], rounds: usize, timed_out: bool) -> Error {
    let remaining = p.infeasible_elements(x);
    let pinned = pinned_inverted(p, x);
    let ids = |v: &[usize]| v.iter().take(10).map(|e| e.to_string()).collect::<Vec<_>>().join(", ");
    let reason = if !pinned.is_empty() {
        format!(
            "{} of them have every vertex fixed (on the boundary or marked fixed), so no move of free vertices can \
             change them: element(s) {}",
            pinned.len(),
            ids(&pinned)
        )
    } else if timed_out {
        format!("the time limit ran out after {rounds} rounds")
    } else {
        format!(
            "no positions of their free vertices making them valid were found in {rounds} rounds (the fixed \
             vertices may leave no room for a valid element)"
        )
    };
    Error::Untangle {
        count: remaining.len(),
        first: remaining.into_iter().take(10).collect(),
        reason,
    }
}

/// Garanzha et al.'s update of eps after a round that took F from `f0` to
/// `f1` and left `min_det` as the smallest det S: with sigma = max(1 - f1/f0,
/// 0.1) and mu = (1 - sigma) chi(min_det, eps), eps = 2 sqrt(mu (mu -
/// min_det)) when min_det < mu, else `floor` (never below it). It solves
/// chi(min_det, eps_new) = mu: the worst corner's regularised determinant is
/// asked to shrink by the factor F shrank by.
pub fn next_eps(eps: f64, min_det: f64, f0: f64, f1: f64, floor: f64) -> f64 {
    let sigma = (1.0 - f1 / f0).max(0.1);
    let mu = (1.0 - sigma) * smetric::chi(min_det, eps).0;
    if min_det < mu {
        (2.0 * (mu * (mu - min_det)).sqrt()).max(floor)
    } else {
        floor
    }
}

/// Untangles positions `x` (problem numbering) in place on `opts.device`
/// with `opts.method`. Returns `Err(Error::Untangle)`, with `x` at the last
/// round's positions, when elements stay inverted.
pub fn untangle(
    p: &Problem,
    x: &mut [Vec3],
    opts: &Options,
    params: &UntangleParams,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<UntangleInfo> {
    let start = Instant::now();
    if opts.method == super::Method::Laplace {
        return Err(Error::InvalidArgument(
            "method 'laplace' cannot untangle (use newton, bcd or bcd-colored)".into(),
        ));
    }
    let inverted_before = p.infeasible_elements(x).len();
    let (bad, _) = corners_below_margin(p, x, params.margin);
    let (inverted_corners, _) = corners_below_margin(p, x, 0.0);
    let mut info = UntangleInfo {
        inverted_before,
        inverted_corners_before: inverted_corners.len(),
        inverted_after: inverted_before,
        corners_before: bad.len(),
        corners_after: bad.len(),
        rounds: 0,
        iterations: 0,
        schedule: Vec::new(),
        seconds: 0.0,
        device: String::new(),
    };
    if bad.is_empty() {
        return Ok(info);
    }
    if !pinned_inverted(p, x).is_empty() {
        return Err(failure(p, x, 0, false));
    }
    // unit-free: the determinant of a corner with the mean edge length
    let scale = p.mean_edge_length(x).powi(p.dim as i32);
    let floor = 1e-9 * scale;
    let mut eps = scale;
    let mut q = p.clone();
    let mut inner = opts.clone();
    inner.params.max_iter = params.inner_max_iter;
    inner.params.tol = params.inner_tol;
    inner.params.target_objective = None;
    inner.checkpoint_every = None;
    let ls = opts.params.bcd.line_search;
    // the time limit covers all rounds together
    let deadline = opts.params.time_limit.map(|t| start + t);
    let mut timed_out = false;
    while info.rounds < params.max_rounds {
        if let Some(d) = deadline {
            let left = d.saturating_duration_since(Instant::now());
            if left.is_zero() {
                timed_out = true;
                break;
            }
            inner.params.time_limit = Some(left);
        }
        q.model = untangling_model(p.model, eps);
        #[cfg(feature = "mpi")]
        if let super::Device::Mpi(_) = opts.device {
            return Err(Error::InvalidArgument(
                "untangling runs on one process: untangle first (meshsmooth untangle), then smooth under mpirun".into(),
            ));
        }
        let solved = run(&mut opts.device.backend(&q, x, &ls)?, &q, x, &inner, progress)?;
        info.rounds += 1;
        info.iterations += solved.iterations;
        info.device = solved.device;
        let (bad, min_det) = corners_below_margin(p, x, params.margin);
        info.schedule.push((eps, min_det));
        info.corners_after = bad.len();
        info.inverted_after = p.infeasible_elements(x).len();
        if bad.is_empty() || solved.stop == StopReason::Cancelled {
            break;
        }
        let records = &solved.history.records;
        let (f0, f1) = (records[0].objective, records[records.len() - 1].objective);
        eps = next_eps(eps, min_det, f0, f1, floor);
    }
    info.seconds = start.elapsed().as_secs_f64();
    if info.inverted_after > 0 {
        return Err(failure(p, x, info.rounds, timed_out));
    }
    Ok(info)
}

/// Untangles `mesh` in place (the library's entry point next to
/// `smooth_mesh`, and what `meshsmooth untangle` runs): builds the problem,
/// refuses a node-ordering problem (`convention_problem`), untangles in the
/// mesh's frame and writes the moved free vertices back. On failure the
/// mesh keeps its input positions and the error names the elements left
/// inverted and why; `untangle_mesh_partial` keeps the last positions instead.
pub fn untangle_mesh(
    mesh: &mut Mesh,
    problem: &ProblemOptions,
    opts: &Options,
    params: &UntangleParams,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<UntangleInfo> {
    untangle_mesh_with(mesh, problem, opts, params, progress, false)
}

/// `untangle_mesh` that writes the last positions back even when it fails
/// (the CLI's `--save-partial`).
pub fn untangle_mesh_partial(
    mesh: &mut Mesh,
    problem: &ProblemOptions,
    opts: &Options,
    params: &UntangleParams,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<UntangleInfo> {
    untangle_mesh_with(mesh, problem, opts, params, progress, true)
}

fn untangle_mesh_with(
    mesh: &mut Mesh,
    problem: &ProblemOptions,
    opts: &Options,
    params: &UntangleParams,
    progress: &mut dyn FnMut(&Record) -> bool,
    keep_partial: bool,
) -> Result<UntangleInfo> {
    if let Some(msg) = convention_problem(mesh) {
        return Err(Error::InvalidMesh(msg));
    }
    in_mesh_frame(mesh, problem, keep_partial, |p, x| {
        untangle(p, x, opts, params, progress)
    })
}

/// A node-ordering convention problem rather than a tangle: every element of
/// one kind (two or more of them) inverted with every corner mirrored, as a
/// file written with another program's node order (wedges with reversed bases in a VTK
/// file) reads. Untangling would "fix" it by turning every such element inside
/// out; the message says so instead.
pub fn convention_problem(mesh: &Mesh) -> Option<String> {
    let points = crate::metric::oriented(mesh, &mesh.points);
    let mut kinds: Vec<crate::ElementKind> = mesh.kinds.clone();
    kinds.sort_unstable();
    kinds.dedup();
    for kind in kinds {
        let of_kind: Vec<usize> = (0..mesh.num_elements()).filter(|&e| mesh.kinds[e] == kind).collect();
        if of_kind.len() < 2 {
            continue;
        }
        let mirrored = of_kind.iter().all(|&e| {
            let xs: Vec<Vec3> = mesh.element(e).iter().map(|&v| points[v as usize]).collect();
            every_corner_negative(kind, &xs)
        });
        if mirrored {
            return Some(format!(
                "every one of the {} {} elements is inverted, each with all its corners mirrored: this is a \
                 node-ordering convention problem, not a tangle (the file orders the nodes of a {} differently \
                 from the convention of its format, as a writer that reverses each wedge's base does); reorder \
                 their nodes instead of untangling",
                of_kind.len(),
                kind.name(),
                kind.name()
            ));
        }
    }
    None
}

/// Every corner determinant of an element negative (2D kinds in the xy plane).
fn every_corner_negative(kind: crate::ElementKind, x: &[Vec3]) -> bool {
    use crate::metric::mat3::{det, sub};
    kind.corners().iter().all(|c| {
        let o = &x[c[0]];
        let d = if kind.dim() == 2 {
            let (a, b) = (sub(&x[c[1]], o), sub(&x[c[2]], o));
            a[0] * b[1] - a[1] * b[0]
        } else {
            let (a, b, e) = (sub(&x[c[1]], o), sub(&x[c[2]], o), sub(&x[c[3]], o));
            det(&[[a[0], b[0], e[0]], [a[1], b[1], e[1]], [a[2], b[2], e[2]]])
        };
        d < 0.0
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_eps_solves_for_the_target_regularised_determinant() {
        // chi(min_det, eps_new) = mu = (1 - sigma) chi(min_det, eps)
        for (eps, min_det, f0, f1) in [(1.0, -0.5, 10.0, 4.0), (0.3, -2.0, 5.0, 4.9), (0.1, 0.01, 2.0, 1.0)] {
            let sigma = f64::max(1.0 - f1 / f0, 0.1);
            let mu = (1.0 - sigma) * smetric::chi(min_det, eps).0;
            let new = next_eps(eps, min_det, f0, f1, 1e-12);
            assert!(new < eps, "eps must decrease: {eps} -> {new}");
            assert!((smetric::chi(min_det, new).0 - mu).abs() <= 1e-12 * mu.abs().max(1.0));
        }
        // a worst corner already above mu: the floor
        assert_eq!(next_eps(0.1, 1.0, 2.0, 1.0, 1e-9), 1e-9);
        // never below the floor
        assert_eq!(next_eps(1e-9, -1e-30, 1.0, 0.0, 1e-9), 1e-9);
    }
}
