//! Host mirrors of the WGSL structs in `shaders/common/layout.wgsl` and
//! `shaders/bcd.wgsl`.

use super::context::GpuContext;
use super::shader::Kernel;
use crate::metric::TetShape;
use crate::solve::bcd::LineSearch;
use bytemuck::{Pod, Zeroable};

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct Sizes {
    pub n_elements: u32,
    pub n_free: u32,
    pub n_obj_partials: u32,
    pub n_vert_partials: u32,
}
const _: () = assert!(std::mem::size_of::<Sizes>() == 16);

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct Color {
    pub offset: u32,
    pub count: u32,
    pub max_backtracks: u32,
    pub pad: u32,
}
const _: () = assert!(std::mem::size_of::<Color>() == 16);

/// `struct Dims` of `layout.wgsl`: per-dispatch parameters of the Newton kernels.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct Dims {
    pub n: u32,
    pub op: u32,
    pub slot: u32,
    pub aux: u32,
}
const _: () = assert!(std::mem::size_of::<Dims>() == 16);

/// `struct Shape { b: array<vec4<real>, 4>, ls: vec4<real> }` as 20 reals.
pub(crate) fn shape_values(shape: &TetShape, ls: &LineSearch, n_elements: usize) -> [f64; 20] {
    let mut v = [0.0; 20];
    for k in 0..4 {
        v[4 * k..4 * k + 3].copy_from_slice(shape.b(k));
    }
    v[16] = ls.beta;
    v[17] = ls.sigma;
    v[18] = 1.0 / n_elements.max(1) as f64;
    v
}

impl GpuContext {
    /// A bind group for `kernel` with `buffers` at bindings 0, 1, ...
    pub(crate) fn bind(&self, kernel: Kernel, buffers: &[&wgpu::Buffer]) -> wgpu::BindGroup {
        let layout = self.pipeline(kernel).get_bind_group_layout(0);
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(kernel.name()),
            layout: &layout,
            entries: &entries,
        })
    }

    /// Records one dispatch of `kernel` covering `threads` (2D grid).
    pub(crate) fn dispatch(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        kernel: Kernel,
        group: &wgpu::BindGroup,
        threads: usize,
    ) -> crate::Result<()> {
        let (x, y) = super::buffers::grid(threads)?;
        pass.set_pipeline(self.pipeline(kernel));
        pass.set_bind_group(0, group, &[]);
        pass.dispatch_workgroups(x, y, 1);
        Ok(())
    }
}
