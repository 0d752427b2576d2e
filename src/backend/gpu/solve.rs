//! The BCD solve loop on the device: the loop, history and stop rules are
//! `solve::iterate`, shared with the CPU; positions come back once, at the end.

use super::bcd::GpuBcd;
use super::context::GpuContext;
use crate::error::{Error, Result};
use crate::metric::mat3::Vec3;
use crate::problem::Problem;
use crate::solve::{self, Info, Method, Params, Record, Sweep};
use std::time::Instant;

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
    if !(params.tol >= 0.0) {
        return Err(Error::InvalidArgument(format!(
            "tolerance must be non-negative, got {}",
            params.tol
        )));
    }
    p.check_feasible(x)?;
    let start = Instant::now();
    let edge = p.mean_edge_length(x);
    let mut gpu = GpuBcd::with_line_search(ctx, p, x, &params.line_search)?;
    let first = gpu.objective_and_grad_norm()?.ok_or_else(|| {
        Error::Gpu(
            "the device finds inverted elements the CPU does not (f32 rounding of a nearly flat element?)".into(),
        )
    })?;
    let mut step = || -> Result<Sweep> {
        gpu.sweep()?;
        let s = gpu.evaluate()?;
        let objective = s.objective.ok_or_else(solve::accepted_step_inverted)?;
        Ok(Sweep {
            objective,
            grad_norm: s.grad_norm,
            max_move_sq: s.max_move_sq,
        })
    };
    let info = solve::iterate(
        Method::BcdColored,
        params,
        start,
        edge,
        p.setup_time.as_secs_f64(),
        first,
        &mut step,
        progress,
    )?;
    x.copy_from_slice(&gpu.download()?);
    Ok(info)
}
