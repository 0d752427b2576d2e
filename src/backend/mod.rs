//! Backends: where the numerics run. The CPU reference lives in `metric`,
//! `objective` and `solve`; `gpu` is the wgpu/WGSL one, written to do the same
//! arithmetic so that the two can be compared.

pub mod gpu;
