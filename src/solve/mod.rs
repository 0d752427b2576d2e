//! Solvers: they own the iteration loop, line searches, termination and
//! history; metrics and objective evaluation come from `metric` and `objective`.

pub mod bcd;
pub mod bsr;
pub mod history;
pub mod laplace;
pub mod newton;
pub mod pcg;

pub use history::{History, Record, StopReason};

use crate::Mesh;
use crate::error::{Error, Result};
use crate::metric::mat3::Vec3;
use crate::objective;
use crate::problem::{Problem, ProblemOptions};
use std::fmt;
use std::str::FromStr;
use std::time::{Duration, Instant};

/// Which optimiser moves the vertices.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Method {
    /// Block coordinate descent: per-vertex Newton with Armijo backtracking.
    #[default]
    Bcd,
    /// Block coordinate descent colour by colour, the vertices of a colour in parallel.
    BcdColored,
    /// Inexact Newton: block-Jacobi PCG on the global Hessian, Armijo on F.
    Newton,
    /// Smart Laplacian smoothing (a baseline, not an optimiser).
    Laplace,
}

impl FromStr for Method {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "bcd" => Ok(Method::Bcd),
            "bcd-colored" => Ok(Method::BcdColored),
            "newton" => Ok(Method::Newton),
            "laplace" => Ok(Method::Laplace),
            _ => Err(Error::InvalidArgument(format!(
                "unknown method '{s}' (expected bcd, bcd-colored, newton or laplace)"
            ))),
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Method::Bcd => "bcd",
            Method::BcdColored => "bcd-colored",
            Method::Newton => "newton",
            Method::Laplace => "laplace",
        })
    }
}

/// Termination and line-search settings shared by the solvers.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// Stop when the 2-norm of the free-vertex gradient of F is below this.
    pub tol: f64,
    /// Most sweeps (BCD, Laplace) or iterations.
    pub max_iter: usize,
    pub time_limit: Option<Duration>,
    pub line_search: bcd::LineSearch,
    /// Laplace stops when no vertex moves farther than this fraction of the mean edge length.
    pub min_move: f64,
    pub newton: newton::NewtonParams,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            tol: 1e-6,
            max_iter: 1000,
            time_limit: None,
            line_search: bcd::LineSearch::default(),
            min_move: 1e-9,
            newton: newton::NewtonParams::default(),
        }
    }
}

/// What a solve did.
#[derive(Clone, Debug, PartialEq)]
pub struct Info {
    pub method: Method,
    pub iterations: usize,
    pub stop: StopReason,
    pub history: History,
    pub objective: f64,
    pub grad_norm: f64,
    /// Wall time of the iterations (problem setup excluded).
    pub seconds: f64,
    pub setup_seconds: f64,
    /// Bytes the solver held: the problem, the positions and the method's own data.
    pub memory_bytes: usize,
    /// Colour classes of the free vertices (the dispatches of a coloured sweep).
    pub colors: usize,
}

/// What every backend checks before its first step: usable settings and a
/// feasible start.
pub(crate) fn check_start(p: &Problem, x: &[Vec3], params: &Params) -> Result<()> {
    if !(params.tol >= 0.0) {
        return Err(Error::InvalidArgument(format!(
            "tolerance must be non-negative, got {}",
            params.tol
        )));
    }
    p.check_feasible(x)
}

/// Runs `method` from positions `x` (problem numbering), updating them in place.
/// `progress` sees every history record and may return `false` to stop.
pub fn solve(
    p: &Problem,
    x: &mut [Vec3],
    method: Method,
    params: &Params,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    check_start(p, x, params)?;
    let mut newton = (method == Method::Newton).then(|| newton::Newton::new(p, params.newton));
    let setup_seconds = p.setup_time.as_secs_f64() + newton.as_ref().map_or(0.0, |n| n.setup_time.as_secs_f64());
    let start = Instant::now();
    let deadline = params.time_limit.map(|t| start + t);
    let edge = p.mean_edge_length(x);
    let evaluate = |x: &[Vec3]| -> Result<(f64, f64)> {
        let (f, g) = objective::gradient(p, x).ok_or_else(accepted_step_inverted)?;
        Ok((f, objective::norm(&g)))
    };
    let first = evaluate(x)?;
    let mut info = {
        let mut step = || -> Result<Sweep> {
            let max_move_sq = match method {
                Method::Bcd => bcd::sweep(p, x, &params.line_search, deadline),
                Method::BcdColored => bcd::sweep_colored(p, x, &params.line_search, deadline),
                Method::Laplace => laplace::sweep(p, x, deadline),
                Method::Newton => {
                    // Newton evaluates F and |grad F| at its new point itself
                    let n = newton.as_mut().expect("built above");
                    let (objective, grad_norm, max_move_sq) =
                        n.step(p, x, &params.line_search).ok_or_else(accepted_step_inverted)?;
                    return Ok(Sweep {
                        objective,
                        grad_norm,
                        max_move_sq,
                    });
                }
            };
            let (objective, grad_norm) = evaluate(x)?;
            Ok(Sweep {
                objective,
                grad_norm,
                max_move_sq,
            })
        };
        iterate(method, params, start, edge, setup_seconds, first, &mut step, progress)?
    };
    info.memory_bytes = p.bytes() + std::mem::size_of_val(x) + newton.as_ref().map_or(0, |n| n.bytes());
    info.colors = p.colors.len();
    Ok(info)
}

pub(crate) fn accepted_step_inverted() -> Error {
    Error::InvalidMesh("an accepted step inverted an element (solver bug)".into())
}

/// Iterations without progress after which a run counts as stalled: the
/// tolerance is below what the arithmetic can resolve (f32 on a GPU).
const STALL_WINDOW: usize = 50;

/// Laplace has no gradient to drive it: it has settled when nothing moves
/// farther than `min_move`. The optimisers move less and less as they converge,
/// so for them only a sweep in which no vertex moved at all means a halt.
fn no_move(method: Method, max_move_sq: f64, min_move: f64) -> bool {
    match method {
        Method::Laplace => max_move_sq.sqrt() <= min_move,
        _ => max_move_sq == 0.0,
    }
}

/// True when over the last `window` iterations F did not decrease and the
/// gradient norm did not even halve.
fn no_progress(h: &History, window: usize) -> bool {
    let r = &h.records;
    if r.len() <= window {
        return false;
    }
    let (now, then) = (&r[r.len() - 1], &r[r.len() - 1 - window]);
    now.objective >= then.objective && now.grad_norm > 0.5 * then.grad_norm
}

/// What one sweep of any backend reports to the shared loop.
pub(crate) struct Sweep {
    pub objective: f64,
    pub grad_norm: f64,
    /// Largest squared vertex displacement of the sweep.
    pub max_move_sq: f64,
}

/// The iteration loop shared by every backend: history, progress and the
/// stop rules. `first` is (F, |grad F|) at the start; `step` runs one sweep.
#[allow(clippy::too_many_arguments)]
pub(crate) fn iterate(
    method: Method,
    params: &Params,
    start: Instant,
    edge: f64,
    setup_seconds: f64,
    first: (f64, f64),
    step: &mut dyn FnMut() -> Result<Sweep>,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    let deadline = params.time_limit.map(|t| start + t);
    let mut history = History::default();
    let (mut f, mut gnorm) = first;
    let mut record = Record {
        iteration: 0,
        seconds: 0.0,
        objective: f,
        grad_norm: gnorm,
    };
    history.push(record);
    let mut stop = if progress(&record) {
        None
    } else {
        Some(StopReason::Cancelled)
    };
    let mut iterations = 0;
    while stop.is_none() {
        if gnorm < params.tol {
            stop = Some(StopReason::Converged);
            break;
        }
        if iterations >= params.max_iter {
            stop = Some(StopReason::MaxIterations);
            break;
        }
        if deadline.is_some_and(|d| Instant::now() >= d) {
            stop = Some(StopReason::TimeLimit);
            break;
        }
        let sweep = step()?;
        iterations += 1;
        (f, gnorm) = (sweep.objective, sweep.grad_norm);
        record = Record {
            iteration: iterations,
            seconds: start.elapsed().as_secs_f64(),
            objective: f,
            grad_norm: gnorm,
        };
        history.push(record);
        if !progress(&record) {
            stop = Some(StopReason::Cancelled);
        } else if gnorm >= params.tol
            && (no_move(method, sweep.max_move_sq, params.min_move * edge) || no_progress(&history, STALL_WINDOW))
        {
            stop = Some(StopReason::Stalled);
        }
    }
    Ok(Info {
        method,
        iterations,
        stop: stop.unwrap_or(StopReason::Converged),
        history,
        objective: f,
        grad_norm: gnorm,
        seconds: start.elapsed().as_secs_f64(),
        setup_seconds,
        memory_bytes: 0,
        colors: 0,
    })
}

/// Smooths `mesh` in place (the library's one-call entry point): builds the
/// problem, checks the start is feasible, runs `method` and writes the
/// optimised positions back in the mesh's own vertex numbering.
pub fn smooth_mesh(
    mesh: &mut Mesh,
    method: Method,
    params: &Params,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    smooth_mesh_with(mesh, &ProblemOptions::default(), method, params, progress)
}

/// `smooth_mesh` with a metric, template or reference mesh of choice.
pub fn smooth_mesh_with(
    mesh: &mut Mesh,
    options: &ProblemOptions,
    method: Method,
    params: &Params,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    let p = Problem::with_options(mesh, options)?;
    let mut x = p.gather(&mesh.points);
    let info = solve(&p, &mut x, method, params, progress)?;
    mesh.points = p.scatter(&x);
    Ok(info)
}
