//! Solvers: they own the iteration loop, line searches, termination and
//! history, and reach the numerics only through `backend::Backend`. Each
//! method is written once (`bcd`, `newton` with `pcg`, `nlcg` with `wolfe`);
//! `solve` picks the backend from a `Device` and runs the one loop
//! (`iterate`) over it.

pub mod bcd;
#[cfg(feature = "mpi")]
pub mod distributed;
#[cfg(test)]
mod function_backend;
pub mod history;
pub mod laplace;
pub mod line_search;
pub mod newton;
pub mod nlcg;
pub mod pcg;
#[cfg(feature = "mpi")]
pub mod pieces;
pub mod reorder;
pub mod rezone;
pub mod untangle;
pub mod wolfe;

pub use history::{History, Record, StopReason};
pub use untangle::{UntangleInfo, UntangleParams, untangle, untangle_mesh};

use crate::Mesh;
use crate::backend::Backend;
use crate::backend::cpu::CpuBackend;
#[cfg(feature = "gpu")]
use crate::backend::gpu::{GpuBackend, GpuContext};
use crate::error::{Error, Result};
use crate::mesh::frame::Frame;
use crate::metric::mat3::Vec3;
use crate::problem::{Problem, ProblemOptions};
use line_search::LineSearch;
use newton::{Newton, NewtonParams};
use nlcg::{Nlcg, NlcgParams};
use std::time::{Duration, Instant};

/// Which optimiser moves the vertices.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Method {
    /// Block coordinate descent: per-vertex Newton with Armijo backtracking,
    /// one vertex at a time in locality order (on a GPU: colour by colour).
    Bcd,
    /// Block coordinate descent colour by colour, the vertices of a colour in parallel.
    BcdColored,
    /// Inexact Newton: block-Jacobi PCG on the global Hessian, Armijo on F.
    #[default]
    Newton,
    /// Smart Laplacian smoothing (a baseline, not an optimiser; CPU only).
    Laplace,
    /// Nonlinear conjugate gradients (Polak–Ribière+) with a feasibility-aware
    /// strong-Wolfe line search: gradients only, no Hessian.
    Nlcg,
}

impl Method {
    /// Why the method has no GPU version, if it has none; one wording for
    /// [`Device::supports`] and the settings' check made before a GPU exists.
    pub(crate) fn cpu_only(self) -> Option<String> {
        (self == Method::Laplace).then(|| {
            format!("{self} runs on the CPU only (the GPU runs bcd, colour by colour, bcd-colored, newton and nlcg)")
        })
    }

    /// The method's name, as the command line and settings spell it.
    pub fn name(self) -> &'static str {
        crate::error::Named::name(&self)
    }
}

crate::error::by_name!(Method: "method" {
    Bcd = "bcd",
    BcdColored = "bcd-colored",
    Newton = "newton",
    Laplace = "laplace",
    Nlcg = "nlcg",
});

/// Block coordinate descent's settings.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BcdParams {
    /// The per-vertex Armijo line search.
    pub line_search: LineSearch,
    /// The sequential sweep with a paper scheme ([`Problem::sweep_order`]):
    /// reorder the list after every this many sweeps (the paper's dynamic
    /// strategy); `None` or 0: once, before the first sweep (static).
    pub reorder_every: Option<usize>,
    /// Safeguarded Newton steps per vertex visit of the sequential sweep
    /// (the paper's inner iterations; at least 1).
    pub inner_iterations: usize,
}

impl Default for BcdParams {
    fn default() -> Self {
        BcdParams {
            line_search: LineSearch::default(),
            reorder_every: None,
            inner_iterations: 1,
        }
    }
}

/// Smart Laplace's settings.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LaplaceParams {
    /// Stop when no vertex moves farther than this fraction of the mean edge length.
    pub min_move: f64,
}

impl Default for LaplaceParams {
    fn default() -> Self {
        LaplaceParams { min_move: 1e-9 }
    }
}

/// Termination (shared by every method) and each method's own settings.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[non_exhaustive]
pub struct Params {
    /// Stop when the 2-norm of the free-vertex gradient of F, with lengths
    /// measured in mean edge lengths of the start (so unit-free, like F), is
    /// below this.
    pub tol: f64,
    /// Most sweeps (BCD, Laplace) or iterations (Newton, NLCG).
    pub max_iter: usize,
    /// Stop after this much wall time (the solve alone, setup excluded).
    pub time_limit: Option<Duration>,
    /// Stop as soon as F is at or below this (a baseline-derived stop, as in
    /// the reordering paper's comparisons).
    pub target_objective: Option<f64>,
    /// Settings of `Method::Bcd` and `Method::BcdColored`.
    pub bcd: BcdParams,
    /// Settings of `Method::Newton`.
    pub newton: NewtonParams,
    /// Settings of `Method::Laplace`.
    pub laplace: LaplaceParams,
    /// Settings of `Method::Nlcg`.
    pub nlcg: NlcgParams,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            tol: 1e-6,
            max_iter: 1000,
            time_limit: None,
            target_objective: None,
            bcd: BcdParams::default(),
            newton: NewtonParams::default(),
            laplace: LaplaceParams::default(),
            nlcg: NlcgParams::default(),
        }
    }
}

/// Where a solve runs.
#[derive(Clone, Copy, Default)]
pub enum Device<'a> {
    /// The f64 reference backend.
    #[default]
    Cpu,
    /// A wgpu device (`GpuContext::new` picks the adapter and precision).
    #[cfg(feature = "gpu")]
    Gpu(&'a GpuContext),
    /// The ranks of an MPI job, each on its part of the problem: on the CPU
    /// (f64), or each on a GPU (`distributed::Cluster::set_gpu`).
    #[cfg(feature = "mpi")]
    Mpi(&'a distributed::Cluster),
    /// Never built: it keeps the lifetime in a build with neither `gpu` nor `mpi`.
    #[doc(hidden)]
    #[cfg(not(any(feature = "gpu", feature = "mpi")))]
    _Never(std::convert::Infallible, std::marker::PhantomData<&'a ()>),
}

impl<'a> Device<'a> {
    /// Whether `method` runs here: smart Laplace's sweep is sequential, and
    /// only the CPU has it.
    pub fn supports(self, method: Method) -> Result<()> {
        let gpu = match self {
            #[cfg(feature = "gpu")]
            Device::Gpu(_) => true,
            _ => false,
        };
        match method.cpu_only() {
            Some(why) if gpu => Err(Error::InvalidArgument(why)),
            _ => Ok(()),
        }
    }

    /// The backend of this device holding problem `p` and positions `x`
    /// (problem numbering); `ls` drives the per-vertex line searches of BCD.
    /// The ranks of an MPI job are no one backend: `solve` leads them
    /// (`distributed::lead`), and `Device::Mpi` is refused here.
    pub fn backend<'p>(self, p: &'p Problem, x: &[Vec3], ls: &LineSearch) -> Result<Box<dyn Backend + 'p>>
    where
        'a: 'p,
    {
        Ok(match self {
            Device::Cpu => Box::new(CpuBackend::new(p, x, ls)?),
            #[cfg(feature = "gpu")]
            Device::Gpu(ctx) => Box::new(GpuBackend::new(ctx, p, x, ls)?),
            #[cfg(feature = "mpi")]
            Device::Mpi(_) => {
                return Err(Error::InvalidArgument(
                    "an MPI job's ranks are no single backend: solve on Device::Mpi leads them".into(),
                ));
            }
            #[cfg(not(any(feature = "gpu", feature = "mpi")))]
            Device::_Never(never, _) => match never {},
        })
    }
}

/// How a run is carried out: method, settings, device, and the guard against
/// losing work on a device that fails midway.
#[derive(Clone, Default)]
#[non_exhaustive]
pub struct Options<'a> {
    /// The optimiser.
    pub method: Method,
    /// Termination and per-method settings.
    pub params: Params,
    /// Where it runs.
    pub device: Device<'a>,
    /// Download the positions every this many iterations, so that a failure
    /// mid-run (device lost, out of memory) leaves the last feasible
    /// positions in `x`. `None`: positions come back only at the end.
    pub checkpoint_every: Option<usize>,
    /// Testing aid (feature `test-hooks`, not part of the API): fail as a
    /// lost device would, after this many iterations.
    #[doc(hidden)]
    #[cfg(feature = "test-hooks")]
    pub fail_after: Option<usize>,
}

impl Options<'_> {
    /// `method` with `params` on the CPU.
    pub fn cpu(method: Method, params: &Params) -> Options<'static> {
        Options {
            method,
            params: params.clone(),
            ..Default::default()
        }
    }
}

/// What a solve did.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct Info {
    /// The method that ran.
    pub method: Method,
    /// Where it ran (`Backend::describe`).
    pub device: String,
    /// Iterations (sweeps for BCD and Laplace) run.
    pub iterations: usize,
    /// Why it stopped.
    pub stop: StopReason,
    /// Objective and gradient norm per iteration.
    pub history: History,
    /// The final objective F.
    pub objective: f64,
    /// The final gradient norm (as `Params::tol` measures it).
    pub grad_norm: f64,
    /// Wall time of the iterations (problem and solver setup excluded): the
    /// reordering paper's total time TT.
    pub seconds: f64,
    /// Time in the optimisation proper (the paper's COT): for the sequential
    /// BCD sweep, the sweeps without the reorderings and the evaluations
    /// between them; for the other methods, whose steps evaluate as they go,
    /// the whole steps.
    pub optimise_seconds: f64,
    /// Time spent ordering the sweep list (the paper's RT; 0 without a paper scheme).
    pub reorder_seconds: f64,
    /// Times the sweep list was ordered (0 without a paper scheme).
    pub reorderings: usize,
    /// Problem setup plus the solver's own (Newton's Hessian pattern).
    pub setup_seconds: f64,
    /// Bytes the backend held: the problem, the positions and the method's data.
    pub memory_bytes: usize,
    /// Colour classes of the free vertices (the dispatches of a coloured sweep).
    pub colors: usize,
    /// CG iterations over all Newton steps (Newton only).
    pub cg_iterations: Option<usize>,
    /// Newton steps whose CG met negative curvature (Newton only): the
    /// paper's explanation of Newton's slow start on heterogeneous meshes.
    pub negative_curvature_steps: Option<usize>,
    /// Objective evaluations in Newton's line searches (Newton only): many
    /// per step when the direction is poor.
    pub line_search_trials: Option<usize>,
    /// Of the `iterations`, the coloured BCD sweeps before the first Newton
    /// step (Newton only; `NewtonParams::start_sweeps`).
    pub start_sweeps: Option<usize>,
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
    params.newton.check()?;
    p.check_feasible(x)
}

/// Runs `opts.method` on `opts.device` from positions `x` (problem
/// numbering), updating them in place; on a failure after the start, `x`
/// holds the last checkpoint. `progress` sees every history record and may
/// return `false` to stop.
pub fn solve(p: &Problem, x: &mut [Vec3], opts: &Options, progress: &mut dyn FnMut(&Record) -> bool) -> Result<Info> {
    check_start(p, x, &opts.params)?;
    // the backends' own line search is the per-vertex one of BCD; Newton
    // carries its global one in `NewtonParams`
    let ls = opts.params.bcd.line_search;
    match opts.device {
        #[cfg(feature = "mpi")]
        Device::Mpi(cluster) => distributed::lead(cluster, p, x, opts, progress),
        device => {
            device.supports(opts.method)?;
            run(&mut device.backend(p, x, &ls)?, p, x, opts, progress)
        }
    }
}

/// The method's state between iterations.
enum Solver<'p> {
    Bcd(Box<bcd::Bcd<'p>>),
    /// Newton, after the coloured BCD sweeps of its start while they last.
    Newton(Box<Newton>, Option<StartSweeps<'p>>),
    Laplace(laplace::Laplace),
    Nlcg(Box<Nlcg>),
}

/// Newton's start by coloured BCD sweeps (`NewtonParams::start_sweeps`).
struct StartSweeps<'p> {
    bcd: Box<bcd::Bcd<'p>>,
    /// F before the last sweep and that sweep's decrease.
    f: f64,
    decrease: Option<f64>,
    left: usize,
}

impl StartSweeps<'_> {
    /// Whether to go on sweeping after a sweep that ended at `f`; updates the state.
    fn go_on(&mut self, f: f64) -> bool {
        let decrease = self.f - f;
        let slowed = self.decrease.is_some_and(|d| decrease > newton::START_SLOWDOWN * d);
        self.left -= 1;
        (self.f, self.decrease) = (f, Some(decrease));
        self.left > 0 && decrease > 0.0 && !slowed
    }
}

/// `solve` on a backend already holding the problem and the start.
pub fn run<B: Backend + ?Sized>(
    be: &mut B,
    p: &Problem,
    x: &mut [Vec3],
    opts: &Options,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    // F is unit-free; its gradient scales as 1/length: measured in mean edge
    // lengths it is unit-free too, and so is the stopping test
    let scale = Scale {
        edge: p.mean_edge_length(x),
        setup: p.setup_time,
        colors: p.colors.len(),
    };
    run_scaled(be, p, scale, x, opts, progress)
}

/// What `run` takes from the whole problem; a rank of a partitioned run has
/// only its part (the `p` of `run_scaled`), and gets these from the whole.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Scale {
    /// Mean edge length of the start.
    pub edge: f64,
    pub setup: Duration,
    pub colors: usize,
}

/// `run` with the whole problem's scale given.
pub(crate) fn run_scaled<B: Backend + ?Sized>(
    be: &mut B,
    p: &Problem,
    scale: Scale,
    x: &mut [Vec3],
    opts: &Options,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    let params = &opts.params;
    let method = opts.method;
    let edge = scale.edge;
    let mut solver = match method {
        Method::Bcd | Method::BcdColored => {
            Solver::Bcd(Box::new(bcd::Bcd::new(be, p, method == Method::Bcd, &params.bcd)?))
        }
        Method::Newton => {
            let newton = Box::new(Newton::new(be, params.newton)?);
            let start = if params.newton.start_sweeps > 0 && be.num_colors() > 0 {
                Some(StartSweeps {
                    bcd: Box::new(bcd::Bcd::new(be, p, false, &params.bcd)?),
                    f: f64::NAN,
                    decrease: None,
                    left: params.newton.start_sweeps,
                })
            } else {
                None
            };
            Solver::Newton(newton, start)
        }
        Method::Laplace => Solver::Laplace(laplace::Laplace::new(be)?),
        Method::Nlcg => Solver::Nlcg(Box::new(Nlcg::new(be, params.nlcg, edge)?)),
    };
    let solver_setup = match &solver {
        Solver::Newton(n, _) => n.setup_time,
        _ => Duration::ZERO,
    };
    let start = Instant::now();
    let deadline = params.time_limit.map(|t| start + t);
    let unit_free = |(f, g): (f64, f64)| (f, g * edge);
    let first = match &mut solver {
        Solver::Bcd(b) => b.start(be)?,
        Solver::Newton(_, Some(w)) => {
            let first = w.bcd.start(be)?;
            w.f = first.map_or(f64::NAN, |(f, _)| f);
            first
        }
        Solver::Newton(n, None) => n.start(be)?,
        Solver::Laplace(l) => l.start(be)?,
        Solver::Nlcg(n) => n.start(be)?,
    }
    .map(unit_free)
    .ok_or_else(|| {
        Error::Gpu(format!(
            "the device ({}) finds inverted elements the CPU does not (f32 rounding of a nearly flat element?)",
            be.describe()
        ))
    })?;
    let first_reorder = match &solver {
        Solver::Bcd(b) => b.reorder.as_ref().map_or((0.0, 0), |r| (r.seconds, r.count)),
        _ => (0.0, 0),
    };
    let setup = Setup {
        seconds: scale.setup.as_secs_f64() + solver_setup.as_secs_f64(),
        memory_bytes: be.bytes(),
        colors: scale.colors,
        device: be.describe(),
    };
    let mut steps = 0;
    let mut checkpoint: Option<Vec<Vec3>> = None;
    let result = {
        let mut step = |be: &mut B| -> Result<Sweep> {
            #[cfg(feature = "test-hooks")]
            if opts.fail_after.is_some_and(|n| steps >= n) {
                return Err(Error::Gpu("device lost (simulated for testing)".into()));
            }
            let t = Instant::now();
            let mut sweep = match &mut solver {
                Solver::Bcd(b) => b.step(be, deadline)?,
                Solver::Newton(n, start) => match start {
                    Some(w) => {
                        let sweep = w.bcd.step(be, deadline)?;
                        if !w.go_on(sweep.objective) {
                            *start = None;
                            // Newton takes over at the sweeps' end: its gradient and Hessian there
                            if n.start(be)?.is_none() {
                                return Err(accepted_step_inverted());
                            }
                        }
                        Sweep {
                            start_sweep: true,
                            ..sweep
                        }
                    }
                    None => n.step(be)?,
                },
                Solver::Laplace(l) => l.step(be, deadline)?,
                Solver::Nlcg(n) => n.step(be)?,
            };
            sweep.grad_norm *= edge;
            if sweep.optimise_seconds.is_none() {
                sweep.optimise_seconds = Some(t.elapsed().as_secs_f64());
            }
            steps += 1;
            if opts.checkpoint_every.is_some_and(|k| steps % k.max(1) == 0) {
                checkpoint = Some(be.download()?);
            }
            Ok(sweep)
        };
        let begin = Start {
            at: start,
            edge,
            first,
            first_reorder,
        };
        // the loop asks the backend both for steps and for the clock (`Backend::past`)
        let be = std::cell::RefCell::new(&mut *be);
        iterate(
            method,
            params,
            begin,
            setup,
            &mut || step(&mut be.borrow_mut()),
            &mut |d| be.borrow_mut().past(d),
            progress,
        )
    };
    match result {
        Ok(info) => {
            x.copy_from_slice(&be.download()?);
            Ok(info)
        }
        Err(e) => {
            if let Some(c) = checkpoint {
                x.copy_from_slice(&c);
            }
            Err(e)
        }
    }
}

pub(crate) use crate::error::accepted_step_inverted;

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
#[derive(Clone, Copy, Debug, Default)]
pub struct Sweep {
    /// F after the sweep.
    pub objective: f64,
    /// The gradient norm after the sweep (as `Params::tol` measures it).
    pub grad_norm: f64,
    /// Largest squared vertex displacement of the sweep.
    pub max_move_sq: f64,
    /// CG iterations of the step (Newton).
    pub cg_iterations: usize,
    /// Whether the step's CG met negative curvature (Newton).
    pub negative_curvature: bool,
    /// Trial points the step's line search evaluated (Newton).
    pub line_search_trials: usize,
    /// A coloured BCD sweep of Newton's start (`NewtonParams::start_sweeps`).
    pub start_sweep: bool,
    /// Time of the optimisation proper within the step, where the method
    /// separates it (BCD: the sweep); otherwise the whole step counts.
    pub optimise_seconds: Option<f64>,
    /// Time spent reordering the sweep list in this step (cumulative RT when
    /// the start's static ordering is included: see `Bcd::step`).
    pub reorder_seconds: f64,
    /// Reorderings done in this step.
    pub reorderings: usize,
}

/// What the loop reports besides the iterations, known before they start.
struct Setup {
    seconds: f64,
    memory_bytes: usize,
    colors: usize,
    device: String,
}

/// The state at the start of the loop.
struct Start {
    at: Instant,
    /// Mean edge length: the scale of `LaplaceParams::min_move`.
    edge: f64,
    /// (F, |grad F|) at the start.
    first: (f64, f64),
    /// Seconds and count of the sweep-list ordering done at the start.
    first_reorder: (f64, usize),
}

/// The iteration loop shared by every method and backend: history, progress
/// and the stop rules; `step` runs one sweep or iteration, `past` says
/// whether a deadline has passed (the same answer on every rank).
fn iterate(
    method: Method,
    params: &Params,
    begin: Start,
    setup: Setup,
    step: &mut dyn FnMut() -> Result<Sweep>,
    past: &mut dyn FnMut(Instant) -> bool,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    let start = begin.at;
    let deadline = params.time_limit.map(|t| start + t);
    let mut history = History::default();
    let (mut f, mut gnorm) = begin.first;
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
    let mut cg_iterations = 0;
    let (mut negative_curvature_steps, mut line_search_trials, mut start_sweeps) = (0, 0, 0);
    let mut optimise_seconds = 0.0;
    let (mut reorder_seconds, mut reorderings) = begin.first_reorder;
    while stop.is_none() {
        if params.target_objective.is_some_and(|t| f <= t) {
            stop = Some(StopReason::TargetReached);
            break;
        }
        if gnorm < params.tol {
            stop = Some(StopReason::Converged);
            break;
        }
        if iterations >= params.max_iter {
            stop = Some(StopReason::MaxIterations);
            break;
        }
        if deadline.is_some_and(&mut *past) {
            stop = Some(StopReason::TimeLimit);
            break;
        }
        let sweep = step()?;
        iterations += 1;
        cg_iterations += sweep.cg_iterations;
        negative_curvature_steps += sweep.negative_curvature as usize;
        line_search_trials += sweep.line_search_trials;
        start_sweeps += sweep.start_sweep as usize;
        optimise_seconds += sweep.optimise_seconds.unwrap_or(0.0);
        reorder_seconds += sweep.reorder_seconds;
        reorderings += sweep.reorderings;
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
            && method == Method::Nlcg
            && sweep.max_move_sq.sqrt() <= params.nlcg.tol_x * begin.edge
        {
            // no move at all counts too: the line search resolves steps down
            // to tol_x, so it found none that long that decreases F
            stop = Some(StopReason::SmallStep);
        } else if gnorm >= params.tol
            && (no_move(method, sweep.max_move_sq, params.laplace.min_move * begin.edge)
                || no_progress(&history, STALL_WINDOW))
        {
            stop = Some(StopReason::Stalled);
        }
    }
    Ok(Info {
        method,
        device: setup.device,
        iterations,
        stop: stop.unwrap_or(StopReason::Converged),
        history,
        objective: f,
        grad_norm: gnorm,
        seconds: start.elapsed().as_secs_f64(),
        optimise_seconds,
        reorder_seconds,
        reorderings,
        setup_seconds: setup.seconds,
        memory_bytes: setup.memory_bytes,
        colors: setup.colors,
        cg_iterations: (method == Method::Newton).then_some(cg_iterations),
        negative_curvature_steps: (method == Method::Newton).then_some(negative_curvature_steps),
        line_search_trials: (method == Method::Newton).then_some(line_search_trials),
        start_sweeps: (method == Method::Newton).then_some(start_sweeps),
    })
}

/// Smooths `mesh` in place (the library's one-call entry point): builds the
/// problem with `problem` (metric, template, reference, ordering), checks the
/// start is feasible, runs `opts` and writes the optimised positions back in
/// the mesh's own vertex numbering (on a failure midway, the last checkpoint).
///
/// The solve runs in the mesh's `Frame` (centred, scaled by a power of two),
/// so the answer does not depend on the units or the position of the mesh; a
/// planar mesh in any plane runs in that plane's coordinates. Only what a
/// solver moves is written back: fixed vertices keep their bits, and so does
/// the constant coordinate of a mesh in a plane z, y or x = constant.
pub fn smooth_mesh(
    mesh: &mut Mesh,
    problem: &ProblemOptions,
    opts: &Options,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    in_mesh_frame(mesh, problem, true, |p, x| solve(p, x, opts, progress))
}

/// Builds the problem of `mesh` in its `Frame` (see [`smooth_mesh`]), runs
/// `run` on it and writes back what moved, in the mesh's numbering and units:
/// always when `keep_failed`, otherwise only when `run` succeeds.
pub(crate) fn in_mesh_frame<T>(
    mesh: &mut Mesh,
    problem: &ProblemOptions,
    keep_failed: bool,
    run: impl FnOnce(&Problem, &mut Vec<Vec3>) -> Result<T>,
) -> Result<T> {
    let (problem, _) = problem.resolved(mesh)?;
    let frame = Frame::of(&mesh.points);
    let local = |m: &Mesh| -> Vec<Vec3> { m.points.iter().map(|q| frame.to_local(q)).collect() };
    let reference = problem.reference.map(|r| Mesh {
        points: local(r),
        ..r.clone()
    });
    let surface = problem.surface.map(|g| Mesh {
        points: local(g),
        ..g.clone()
    });
    let problem = ProblemOptions {
        reference: reference.as_ref(),
        surface: surface.as_ref(),
        length_unit: frame.scale
            * if problem.length_unit > 0.0 {
                problem.length_unit
            } else {
                1.0
            },
        ..problem
    };
    let in_frame = local(mesh);
    let original = std::mem::replace(&mut mesh.points, in_frame);
    let built = Problem::with_options(mesh, &problem);
    let local_points = std::mem::replace(&mut mesh.points, original);
    let p = built?;
    let mut x = p.gather(&local_points);
    let x0 = x.clone();
    if let (Some(s), Some(_)) = (&p.sliding, problem.surface) {
        // a given geometry is where the skin lies: every sliding vertex starts on it
        for (v, xv) in x.iter_mut().enumerate() {
            *xv = crate::backend::cpu::project_boundary::project_vertex(s, v, xv);
        }
    }
    let result = run(&p, &mut x);
    if result.is_ok() || keep_failed {
        // back from the plane (a planar mesh outside z = constant moves in all
        // three coordinates, on its plane) and from the frame; a vertex that
        // did not move keeps its bits
        let moved = p.scatter(&x);
        let coords = if p.plane.is_some() || p.surface_mesh { 3 } else { p.dim };
        for (new, &old) in p.order.iter().enumerate() {
            if p.free[new] && x[new] != x0[new] {
                let global = frame.to_global(&moved[old as usize]);
                mesh.points[old as usize][..coords].copy_from_slice(&global[..coords]);
            }
        }
    }
    result
}
