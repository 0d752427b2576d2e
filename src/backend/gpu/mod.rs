//! The wgpu backend: one long-lived `GpuContext` (device, queue, pipelines),
//! problem data uploaded once, scalars read back per sweep.

pub mod bcd;
pub mod buffers;
pub mod context;
mod layout;
pub mod mean_ratio_eval;
pub mod newton;
pub mod shader;
pub mod solve;

pub use bcd::{GpuBcd, Scalars};
pub use buffers::{BindingLimits, check_bindings};
pub use context::{AdapterSummary, GpuContext, GpuOptions, Precision, list_adapters};
pub use mean_ratio_eval::{ElementEval, cbrt_eval, mean_ratio_eval};
pub use newton::GpuNewton;
pub use solve::{
    GpuRunOptions, smooth_mesh_gpu, smooth_mesh_gpu_method, smooth_mesh_gpu_with, solve_gpu, solve_gpu_with,
    solve_newton_gpu,
};
