//! Host mirrors of the WGSL structs in `shaders/common/layout.wgsl` and
//! `shaders/bcd.wgsl`.

use super::context::GpuContext;
use super::shader::Kernel;
use crate::metric::TetShape;
use crate::metric::corner_model::Template;
use crate::metric::smetric::MetricKind;
use crate::problem::Problem;
use bytemuck::{Pod, Zeroable};
use std::collections::HashMap;

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

/// `struct Model` of `layout.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct ModelUniform {
    pub dim: u32,
    pub metric: u32,
    pub tmpl: u32,
    pub fast: u32,
}
const _: () = assert!(std::mem::size_of::<ModelUniform>() == 16);

impl ModelUniform {
    pub fn of(p: &Problem) -> ModelUniform {
        let m = p.model;
        ModelUniform {
            dim: p.dim as u32,
            metric: match m.metric {
                MetricKind::InverseMeanRatio => 0,
                MetricKind::ConditionNumber => 1,
                MetricKind::TargetShapeSize => 2,
            },
            tmpl: match m.template {
                Template::Harmonic => 0,
                Template::Average => 1,
            },
            // the closed forms `Model::blocks` and friends take on the CPU
            fast: (p.dim == 3 && m.metric == MetricKind::InverseMeanRatio && m.template == Template::Harmonic) as u32,
        }
    }
}

/// Reals per `shapes` table entry: four `vec4` rows, b_k in .xyz, the weight in row 0's w.
const TABLE_ENTRY: usize = 16;

/// The corners as the solver kernels read them (`CORNER_STRIDE` = 5 u32 each:
/// the 4 vertex ids, then an index into the table) and the table of distinct
/// (B, weight) pairs: weights differ by element kind, so the table stays a
/// few entries long however many corners share it.
pub(crate) fn corner_tables(p: &Problem) -> (Vec<u32>, Vec<f64>) {
    let mut ids: HashMap<(u32, u64), u32> = HashMap::new();
    let mut table = Vec::new();
    let mut corners = Vec::with_capacity(5 * p.num_corners());
    for (c, vs) in p.corners.iter().enumerate() {
        let (shape, w) = (p.corner_shape[c], p.corner_weight[c]);
        let id = *ids.entry((shape, w.to_bits())).or_insert_with(|| {
            let tet = &p.shapes[shape as usize].tet;
            for k in 0..4 {
                table.extend_from_slice(tet.b(k));
                table.push(if k == 0 { w } else { 0.0 });
            }
            (table.len() / TABLE_ENTRY - 1) as u32
        });
        corners.extend_from_slice(vs);
        corners.push(id);
    }
    (corners, table)
}

/// `struct Shape { b: array<vec4<real>, 4>, ls: vec4<real> }` as 20 reals
/// (the per-element test kernels; `ls` is unused there).
pub(crate) fn shape_values(shape: &TetShape) -> [f64; 20] {
    let mut v = [0.0; 20];
    for k in 0..4 {
        v[4 * k..4 * k + 3].copy_from_slice(shape.b(k));
    }
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
