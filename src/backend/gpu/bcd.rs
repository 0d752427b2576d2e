//! Block coordinate descent on the device: the problem is uploaded once, a
//! sweep is one dispatch per colour (`shaders/bcd.wgsl`), and only a few
//! scalars come back per evaluation (`objective`, `vertex_gradient`, `reduce`).

use super::buffers::{BindingLimits, check_bindings, grid};
use super::context::GpuContext;
use super::layout::{Color, ModelUniform, Sizes, corner_tables};
use super::shader::Kernel;
use crate::error::{Error, Result};
use crate::metric::mat3::Vec3;
use crate::problem::Problem;
use crate::solve::bcd::LineSearch;

/// What one evaluation reads back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scalars {
    /// F, or `None` when some element is inverted or degenerate.
    pub objective: Option<f64>,
    /// 2-norm of the free-vertex gradient of F.
    pub grad_norm: f64,
    /// Smallest det(S) over the corners.
    pub min_det: f64,
    /// Largest squared vertex displacement of the last sweep.
    pub max_move_sq: f64,
}

pub struct GpuBcd<'c> {
    ctx: &'c GpuContext,
    n_vertices: usize,
    n_corners: usize,
    n_free: usize,
    x: wgpu::Buffer,
    /// One bind group per non-empty colour, with its vertex count.
    colors: Vec<(wgpu::BindGroup, usize)>,
    objective: wgpu::BindGroup,
    vertex_gradient: wgpu::BindGroup,
    reduce: wgpu::BindGroup,
    out: wgpu::Buffer,
    staging: wgpu::Buffer,
    /// Bytes of every buffer this solver allocated on the device.
    device_bytes: u64,
    /// Closed-form (tetrahedral mean ratio) kernels or the general ones.
    fast: bool,
}

const OUT_LEN: usize = 5;

impl<'c> GpuBcd<'c> {
    /// Uploads the problem and positions `x` (problem numbering).
    pub fn new(ctx: &'c GpuContext, p: &Problem, x: &[Vec3]) -> Result<Self> {
        Self::with_line_search(ctx, p, x, &LineSearch::default())
    }

    pub fn with_line_search(ctx: &'c GpuContext, p: &Problem, x: &[Vec3], ls: &LineSearch) -> Result<Self> {
        let (nv, ne, nf) = (p.num_vertices(), p.num_corners(), p.free_vertices.len());
        if x.len() != nv {
            return Err(Error::InvalidArgument(format!(
                "{} positions for a problem with {nv} vertices",
                x.len()
            )));
        }
        let r = ctx.real_size();
        let n_obj = ne.div_ceil(64).max(1);
        let n_vert = nf.div_ceil(64).max(1);
        check_bindings(
            &BindingLimits::of(&ctx.limits),
            &[
                ("positions", 3 * nv as u64 * r),
                ("corners", 20 * ne as u64),
                ("incidence", 4 * p.incidence.items.len() as u64),
                ("incidence offsets", 4 * p.incidence.offsets.len() as u64),
                ("corner gradients", 12 * ne as u64 * r),
                ("displacements", nv as u64 * r),
            ],
        )?;
        grid(ne)?;
        let sizes = ctx.uniform(
            "sizes",
            &Sizes {
                n_elements: ne as u32,
                n_free: nf as u32,
                n_obj_partials: n_obj as u32,
                n_vert_partials: n_vert as u32,
            },
        );
        let model_u = ModelUniform::of(p);
        let fast = model_u.fast != 0;
        let model = ctx.uniform("model", &model_u);
        let ls_buf = ctx.uniform_real("line search", &[ls.beta, ls.sigma, 0.0, 0.0]);
        let (corner_items, table) = corner_tables(p);
        let shapes = ctx.storage_real("corner shapes", &table);
        let flat: Vec<f64> = x.iter().flatten().copied().collect();
        let xb = ctx.storage_real("positions", &flat);
        let tets = ctx.storage_u32("corners", &corner_items);
        let inc_off = ctx.storage_u32("incidence offsets", &p.incidence.offsets);
        let inc = ctx.storage_u32("incidence", &p.incidence.items);
        let free = ctx.storage_u32("free vertices", &p.free_vertices);
        let color_items = ctx.storage_u32("colours", &p.colors.items);
        let disp = ctx.zeros_real("displacements", nv);
        let grad = ctx.zeros_real("corner gradients", 12 * ne);
        let obj_partials = ctx.zeros_real("objective partials", 3 * n_obj);
        let vert_partials = ctx.zeros_real("vertex partials", 2 * n_vert);
        let out = ctx.zeros_real("scalars", OUT_LEN);
        let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("scalars read back"),
            size: OUT_LEN as u64 * r,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut colors = Vec::new();
        for c in 0..p.colors.len() {
            let count = p.colors.of(c).len();
            if count == 0 {
                continue;
            }
            let params = ctx.uniform(
                "colour",
                &Color {
                    offset: p.colors.offsets[c],
                    count: count as u32,
                    max_backtracks: ls.max_backtracks as u32,
                    pad: 0,
                },
            );
            let group = ctx.bind(
                Kernel::Bcd.for_model(fast),
                &[
                    &model,
                    &ls_buf,
                    &params,
                    &xb,
                    &tets,
                    &shapes,
                    &inc_off,
                    &inc,
                    &color_items,
                    &disp,
                ],
            );
            colors.push((group, count));
        }
        let objective = ctx.bind(
            Kernel::Objective.for_model(fast),
            &[&model, &sizes, &xb, &tets, &shapes, &grad, &obj_partials],
        );
        let vertex_gradient = ctx.bind(
            Kernel::VertexGradient,
            &[&sizes, &free, &inc_off, &inc, &grad, &disp, &vert_partials],
        );
        let reduce = ctx.bind(Kernel::Reduce, &[&sizes, &obj_partials, &vert_partials, &out]);
        ctx.check()?;
        let device_bytes = [
            &sizes,
            &model,
            &ls_buf,
            &shapes,
            &xb,
            &tets,
            &inc_off,
            &inc,
            &free,
            &color_items,
            &disp,
            &grad,
            &obj_partials,
            &vert_partials,
            &out,
            &staging,
        ]
        .iter()
        .map(|b| b.size())
        .sum::<u64>()
            + 16 * colors.len() as u64;
        Ok(GpuBcd {
            ctx,
            n_vertices: nv,
            n_corners: ne,
            n_free: nf,
            x: xb,
            colors,
            objective,
            vertex_gradient,
            reduce,
            out,
            staging,
            device_bytes,
            fast,
        })
    }

    /// One sweep, colour by colour; returns once it is submitted.
    pub fn sweep(&mut self) -> Result<()> {
        let ctx = self.ctx;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            // wgpu orders the dispatches of one pass on the storage they share
            let mut pass = enc.begin_compute_pass(&Default::default());
            for (group, count) in &self.colors {
                ctx.dispatch(&mut pass, Kernel::Bcd.for_model(self.fast), group, *count)?;
            }
        }
        ctx.queue.submit([enc.finish()]);
        ctx.check()
    }

    /// Waits until submitted sweeps have run (for timing).
    pub fn wait(&self) -> Result<()> {
        self.ctx.wait()
    }

    /// F, |grad F| and the sweep's largest move, read back as a few scalars.
    pub fn evaluate(&mut self) -> Result<Scalars> {
        let ctx = self.ctx;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            ctx.dispatch(
                &mut pass,
                Kernel::Objective.for_model(self.fast),
                &self.objective,
                self.n_corners,
            )?;
            ctx.dispatch(&mut pass, Kernel::VertexGradient, &self.vertex_gradient, self.n_free)?;
            ctx.dispatch(&mut pass, Kernel::Reduce, &self.reduce, 1)?;
        }
        enc.copy_buffer_to_buffer(&self.out, 0, &self.staging, 0, OUT_LEN as u64 * ctx.real_size());
        ctx.queue.submit([enc.finish()]);
        let v = ctx.map_read(&self.staging, OUT_LEN)?;
        Ok(Scalars {
            objective: (v[2] == 0.0).then_some(v[0]),
            grad_norm: v[3].sqrt(),
            min_det: v[1],
            max_move_sq: v[4],
        })
    }

    /// (F, |grad F|), or `None` when some element is inverted.
    pub fn objective_and_grad_norm(&mut self) -> Result<Option<(f64, f64)>> {
        let s = self.evaluate()?;
        Ok(s.objective.map(|f| (f, s.grad_norm)))
    }

    /// The current positions (problem numbering).
    /// Bytes held on the device.
    pub fn device_bytes(&self) -> usize {
        self.device_bytes as usize
    }

    pub fn download(&self) -> Result<Vec<Vec3>> {
        let flat = self.ctx.read_real(&self.x, 3 * self.n_vertices)?;
        Ok(flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }
}
