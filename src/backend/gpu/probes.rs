//! Device probes for tests: the test-only kernels (`shader::TEST_KERNELS`),
//! each the device twin of a CPU function, run on their own (no backend).
//! The per-element value, gradient and Hessian of the inverse mean ratio
//! (`shaders/mean_ratio_eval.wgsl`, twin of `TetShape::hessian` through
//! `cpu::mean_ratio_eval`) and the device cube root (`shaders/cbrt_eval.wgsl`,
//! twin of `f64::cbrt`).

use super::buffers::{BindingLimits, check_bindings, grid};
use super::context::GpuContext;
use super::layout::{Sizes, shape_values};
use super::shader::Kernel;
use crate::error::Result;
use crate::metric::TetShape;
use crate::metric::mat3::Vec3;

pub use crate::backend::ElementEval;

/// Per-tetrahedron inverse mean ratio, gradient and Hessian computed on the device (a probe for tests against the CPU).
pub fn mean_ratio_eval(ctx: &GpuContext, shape: &TetShape, tets: &[[u32; 4]], x: &[Vec3]) -> Result<ElementEval> {
    let n = tets.len();
    let r = ctx.real_size();
    check_bindings(
        &BindingLimits::of(&ctx.limits),
        &[
            ("positions", 3 * x.len() as u64 * r),
            ("tets", 16 * n as u64),
            ("hessians", 144 * n as u64 * r),
        ],
    )?;
    grid(n)?;
    let shape_buf = ctx.uniform_real("shape", &shape_values(shape));
    let sizes = ctx.uniform(
        "sizes",
        &Sizes {
            n_elements: n as u32,
            ..Default::default()
        },
    );
    let flat: Vec<f64> = x.iter().flatten().copied().collect();
    let xb = ctx.storage_real("positions", &flat);
    let tb = ctx.storage_u32("tets", bytemuck::cast_slice(tets));
    let value = ctx.zeros_real("value", n);
    let grad = ctx.zeros_real("grad", 12 * n);
    let hess = ctx.zeros_real("hess", 144 * n);
    let k = Kernel::MeanRatioEval.plain();
    let group = ctx.bind_each(
        k,
        &[
            ("shape", &shape_buf),
            ("sizes", &sizes),
            ("x", &xb),
            ("tets", &tb),
            ("value", &value),
            ("grad", &grad),
            ("hess", &hess),
        ],
    );
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        ctx.dispatch(&mut pass, k, &group, None, n)?;
    }
    ctx.queue.submit([enc.finish()]);
    ctx.check()?;
    Ok(ElementEval {
        value: ctx.read_real(&value, n)?,
        grad: ctx.read_real(&grad, 12 * n)?,
        hess: ctx.read_real(&hess, 144 * n)?,
    })
}

/// The device cube root of each value (`shaders/cbrt_eval.wgsl`); its CPU
/// twin is `f64::cbrt`.
pub fn cbrt_eval(ctx: &GpuContext, values: &[f64]) -> Result<Vec<f64>> {
    let n = values.len();
    grid(n)?;
    let sizes = ctx.uniform(
        "sizes",
        &Sizes {
            n_elements: n as u32,
            ..Default::default()
        },
    );
    let buf = ctx.storage_real("values", values);
    let k = Kernel::CbrtEval.plain();
    let group = ctx.bind_each(k, &[("sizes", &sizes), ("values", &buf)]);
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        ctx.dispatch(&mut pass, k, &group, None, n)?;
    }
    ctx.queue.submit([enc.finish()]);
    ctx.check()?;
    ctx.read_real(&buf, n)
}
