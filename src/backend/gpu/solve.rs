//! The BCD solve loop on the device: the loop, history and stop rules are
//! `solve::iterate`, shared with the CPU; positions come back once, at the end.

use super::bcd::GpuBcd;
use super::context::GpuContext;
use super::newton::GpuNewton;
use crate::error::{Error, Result};
use crate::metric::mat3::Vec3;
use crate::problem::{Problem, ProblemOptions};
use crate::solve::{self, Info, Method, Params, Record, Sweep};
use std::time::Instant;

/// How the device run guards against losing work.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GpuRunOptions {
    /// Download the positions every this many sweeps, so that a failure
    /// mid-run (device lost, out of memory) leaves the last feasible positions
    /// in `x`. `None`: positions come back only at the end.
    pub checkpoint_every: Option<usize>,
    /// Testing aid: fail as a lost device would, after this many sweeps.
    #[doc(hidden)]
    pub fail_after: Option<usize>,
}

/// Runs coloured BCD on the device from `x` (problem numbering), updating `x`
/// at the end. The time limit is checked between sweeps (a sweep is one
/// submission); `Info::method` is `BcdColored`, the CPU method it mirrors.
pub fn solve_gpu(
    ctx: &GpuContext,
    p: &Problem,
    x: &mut [Vec3],
    params: &Params,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    solve_gpu_with(ctx, p, x, params, &GpuRunOptions::default(), progress)
}

/// `solve_gpu` with checkpoints. On an error after the start, `x` holds the
/// positions of the last checkpoint (or of the last sweep, when the device
/// can still be read); every checkpoint is a feasible state.
pub fn solve_gpu_with(
    ctx: &GpuContext,
    p: &Problem,
    x: &mut [Vec3],
    params: &Params,
    opts: &GpuRunOptions,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    solve::check_start(p, x, params)?;
    let start = Instant::now();
    let edge = p.mean_edge_length(x);
    let mut gpu = GpuBcd::with_line_search(ctx, p, x, &params.line_search)?;
    let first = gpu.objective_and_grad_norm()?.ok_or_else(|| {
        Error::Gpu(
            "the device finds inverted elements the CPU does not (f32 rounding of a nearly flat element?)".into(),
        )
    })?;
    let setup_seconds = p.setup_time.as_secs_f64();
    drive(
        &mut gpu,
        Method::BcdColored,
        p,
        x,
        params,
        opts,
        (start, edge, setup_seconds),
        first,
        progress,
    )
}

/// A solver whose state lives on the device, as the shared loop drives it.
trait DeviceSolver {
    /// One sweep or iteration, with F and |grad F| read back.
    fn step(&mut self) -> Result<Sweep>;
    fn download(&self) -> Result<Vec<Vec3>>;
    fn device_bytes(&self) -> usize;
}

impl DeviceSolver for GpuBcd<'_> {
    fn step(&mut self) -> Result<Sweep> {
        self.sweep()?;
        let s = self.evaluate()?;
        let objective = s.objective.ok_or_else(solve::accepted_step_inverted)?;
        Ok(Sweep {
            objective,
            grad_norm: s.grad_norm,
            max_move_sq: s.max_move_sq,
        })
    }
    fn download(&self) -> Result<Vec<Vec3>> {
        GpuBcd::download(self)
    }
    fn device_bytes(&self) -> usize {
        GpuBcd::device_bytes(self)
    }
}

impl DeviceSolver for GpuNewton<'_> {
    fn step(&mut self) -> Result<Sweep> {
        let (objective, grad_norm, max_move_sq) = GpuNewton::step(self)?;
        Ok(Sweep {
            objective,
            grad_norm,
            max_move_sq,
        })
    }
    fn download(&self) -> Result<Vec<Vec3>> {
        GpuNewton::download(self)
    }
    fn device_bytes(&self) -> usize {
        GpuNewton::device_bytes(self)
    }
}

/// The shared loop (`solve::iterate`) over a device solver, with the
/// checkpoints of `GpuRunOptions`: on success `x` gets the final positions, on
/// failure the last checkpoint.
#[allow(clippy::too_many_arguments)]
fn drive(
    gpu: &mut dyn DeviceSolver,
    method: Method,
    p: &Problem,
    x: &mut [Vec3],
    params: &Params,
    opts: &GpuRunOptions,
    (start, edge, setup_seconds): (Instant, f64, f64),
    first: (f64, f64),
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    let mut steps = 0;
    let mut checkpoint: Option<Vec<Vec3>> = None;
    let result = {
        let mut step = || -> Result<Sweep> {
            if opts.fail_after.is_some_and(|n| steps >= n) {
                return Err(Error::Gpu("device lost (simulated for testing)".into()));
            }
            let sweep = gpu.step()?;
            steps += 1;
            if opts.checkpoint_every.is_some_and(|k| steps % k.max(1) == 0) {
                checkpoint = Some(gpu.download()?);
            }
            Ok(sweep)
        };
        solve::iterate(method, params, start, edge, setup_seconds, first, &mut step, progress)
    };
    match result {
        Ok(mut info) => {
            x.copy_from_slice(&gpu.download()?);
            info.memory_bytes = p.bytes() + std::mem::size_of_val(x) + gpu.device_bytes();
            info.colors = p.colors.len();
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

/// Smooths `mesh` in place on the device (coloured BCD), like `solve::smooth_mesh`.
pub fn smooth_mesh_gpu(
    ctx: &GpuContext,
    mesh: &mut crate::Mesh,
    params: &Params,
    opts: &GpuRunOptions,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    smooth_mesh_gpu_method(ctx, mesh, Method::BcdColored, params, opts, progress)
}

/// Runs inexact Newton on the device from `x` (problem numbering), updating
/// `x` at the end; the twin of `solve::solve` with `Method::Newton`, sharing
/// its loop and stop rules. Checkpoints as in `solve_gpu_with`.
pub fn solve_newton_gpu(
    ctx: &GpuContext,
    p: &Problem,
    x: &mut [Vec3],
    params: &Params,
    opts: &GpuRunOptions,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    solve::check_start(p, x, params)?;
    let mut gpu = GpuNewton::new(ctx, p, x, params.newton, &params.line_search)?;
    let setup_seconds = p.setup_time.as_secs_f64() + gpu.setup_time.as_secs_f64();
    let start = Instant::now();
    let edge = p.mean_edge_length(x);
    let first = gpu.assemble()?;
    drive(
        &mut gpu,
        Method::Newton,
        p,
        x,
        params,
        opts,
        (start, edge, setup_seconds),
        first,
        progress,
    )
}

/// Smooths `mesh` in place on the device with `method`: `Bcd` and
/// `BcdColored` run coloured BCD, `Newton` inexact Newton; Laplace has no
/// device version. On failure the mesh gets the last checkpoint.
pub fn smooth_mesh_gpu_method(
    ctx: &GpuContext,
    mesh: &mut crate::Mesh,
    method: Method,
    params: &Params,
    opts: &GpuRunOptions,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    smooth_mesh_gpu_with(ctx, mesh, &ProblemOptions::default(), method, params, opts, progress)
}

/// `smooth_mesh_gpu_method` with a metric, template and reference mesh, the
/// device twin of `solve::smooth_mesh_with`.
pub fn smooth_mesh_gpu_with(
    ctx: &GpuContext,
    mesh: &mut crate::Mesh,
    options: &ProblemOptions,
    method: Method,
    params: &Params,
    opts: &GpuRunOptions,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    let run = match method {
        Method::Bcd | Method::BcdColored => solve_gpu_with,
        Method::Newton => solve_newton_gpu,
        Method::Laplace => {
            return Err(Error::InvalidArgument(format!(
                "method '{method}' has no GPU version (use bcd, bcd-colored or newton)"
            )));
        }
    };
    let p = Problem::with_options(mesh, options)?;
    let mut x = p.gather(&mesh.points);
    let result = run(ctx, &p, &mut x, params, opts, progress);
    mesh.points = p.scatter(&x);
    result
}
