//! The wgpu backend: one long-lived `GpuContext` (device, queue, pipelines),
//! problem data uploaded once, scalars read back per sweep.

pub mod shader;
