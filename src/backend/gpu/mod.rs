//! The wgpu backend: one long-lived `GpuContext` (device, queue, pipelines
//! built from the kernel table), and `GpuBackend`, the `Backend` whose
//! problem, positions and vectors live on the device and whose operations
//! are recorded into command buffers, read back as scalar slots per flush.

pub mod backend;
pub mod buffers;
pub mod context;
pub(crate) mod layout;
pub mod probes;
// Public only for the integration tests and benches: the WGSL kernel table.
#[doc(hidden)]
pub mod shader;
pub(crate) mod sweep_layout;

pub use backend::GpuBackend;
pub use buffers::{BindingLimits, check_bindings};
pub use context::{
    AdapterSummary, DeviceLayout, GpuContext, GpuOptions, KernelForms, Precision, list_adapters,
    list_adapters_in_background,
};
pub use probes::{ElementEval, cbrt_eval, mean_ratio_eval};
