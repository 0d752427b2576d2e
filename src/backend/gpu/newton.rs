//! Inexact Newton on the device, the twin of `solve::newton::Newton`: the
//! problem, the Hessian and every vector stay on the device; the host drives
//! the PCG loop and the line search from scalars read back (one read per CG
//! iteration, one per line-search trial).

use super::buffers::{BindingLimits, check_bindings, grid};
use super::context::GpuContext;
use super::layout::{Dims, ModelUniform, Sizes, corner_tables};
use super::shader::Kernel;
use crate::error::{Error, Result};
use crate::metric::mat3::{Mat3, Vec3};
use crate::problem::Problem;
use crate::solve::bcd::LineSearch;
use crate::solve::bsr::HessianPattern;
use crate::solve::newton::NewtonParams;
use crate::solve::pcg::{NegativeCurvature, PcgInfo, PcgParams, PcgStop};
use std::time::{Duration, Instant};

/// Scalar slots on the device (`shaders/vector.wgsl` names those it reads).
const SLOT_BB: u32 = 0;
const SLOT_RZ: u32 = 1;
const SLOT_CURVATURE: u32 = 2;
const SLOT_RR: u32 = 3;
const SLOT_RZ_NEW: u32 = 4;
const SLOT_PB: u32 = 5;
const SLOT_SLOPE: u32 = 6;
const SLOT_GG: u32 = 7;
const SLOT_DD: u32 = 8;
const SLOT_DMAX: u32 = 9;
const N_SLOTS: usize = 16;
/// `reduce.wgsl`'s output: sum of eta, min det, infeasible count, ...
const OUT_LEN: usize = 5;
const NO_SLOT: u32 = u32::MAX;

/// Reals per element in the assembly buffer (`ELEM_STRIDE` in `layout.wgsl`).
const ELEM_STRIDE: u64 = 102;

/// The `vector.wgsl` operations.
const OP_CG_STEP: u32 = 0;
const OP_P_UPDATE: u32 = 1;
const OP_SHIFT_RZ: u32 = 2;
const OP_NEGATIVE_CURVATURE: u32 = 3;

/// Per block slot, its element contributions `element * 16 + 4 a + b` in
/// ascending element order (the CPU assembly's sum order).
fn contributions(pattern: &HessianPattern) -> (Vec<u32>, Vec<u32>) {
    let nb = pattern.matrix.blocks.len();
    let mut offsets = vec![0u32; nb + 1];
    for s in pattern.slots.iter().flatten() {
        if *s != u32::MAX {
            offsets[*s as usize + 1] += 1;
        }
    }
    for i in 0..nb {
        offsets[i + 1] += offsets[i];
    }
    let mut fill = offsets.clone();
    let mut items = vec![0u32; offsets[nb] as usize];
    for (e, slots) in pattern.slots.iter().enumerate() {
        for (ab, &s) in slots.iter().enumerate() {
            if s != u32::MAX {
                items[fill[s as usize] as usize] = 16 * e as u32 + ab as u32;
                fill[s as usize] += 1;
            }
        }
    }
    (offsets, items)
}

/// A dot product's two passes, writing scalar slots.
struct Dot {
    partial: wgpu::BindGroup,
    fin: wgpu::BindGroup,
}

struct Groups {
    assemble: wgpu::BindGroup,
    gather: wgpu::BindGroup,
    gradient: wgpu::BindGroup,
    spmv: wgpu::BindGroup,
    factor: wgpu::BindGroup,
    precond_rz: wgpu::BindGroup,
    precond_fallback: wgpu::BindGroup,
    cg_step: wgpu::BindGroup,
    p_update: wgpu::BindGroup,
    shift_rz: wgpu::BindGroup,
    negative_curvature: wgpu::BindGroup,
    trial: wgpu::BindGroup,
    objective_trial: wgpu::BindGroup,
    objective_x: wgpu::BindGroup,
    reduce: wgpu::BindGroup,
    dot_bb: Dot,
    dot_rz: Dot,
    dot_pq: Dot,
    dot_rr: Dot,
    dot_rz_new: Dot,
    dot_pb: Dot,
    dot_gd: Dot,
    dot_gg: Dot,
    dot_dd: Dot,
}

/// Vectors over the free vertices, 3 reals each.
struct Vectors {
    g: wgpu::Buffer,
    rhs: wgpu::Buffer,
    d: wgpu::Buffer,
    r: wgpu::Buffer,
    z: wgpu::Buffer,
    p: wgpu::Buffer,
    q: wgpu::Buffer,
}

pub struct GpuNewton<'c> {
    ctx: &'c GpuContext,
    pub params: NewtonParams,
    ls: LineSearch,
    n_vertices: usize,
    n_corners: usize,
    n_free: usize,
    n_blocks: usize,
    /// Closed-form (tetrahedral mean ratio) kernels or the general ones.
    fast: bool,
    x: wgpu::Buffer,
    trial: wgpu::Buffer,
    blocks: wgpu::Buffer,
    v: Vectors,
    groups: Groups,
    scalars: wgpu::Buffer,
    out: wgpu::Buffer,
    staging: wgpu::Buffer,
    step_alpha: wgpu::Buffer,
    g0: Option<f64>,
    /// (F, |grad F|) at the current point when gradient and Hessian are assembled there.
    current: Option<(f64, f64)>,
    /// What the last PCG solve did.
    pub last_pcg: Option<PcgInfo>,
    pub cg_iterations: usize,
    /// Time to build the pattern and upload everything.
    pub setup_time: Duration,
    device_bytes: u64,
}

impl<'c> GpuNewton<'c> {
    /// Uploads the problem, its Hessian pattern and positions `x` (problem numbering).
    pub fn new(
        ctx: &'c GpuContext,
        p: &Problem,
        x: &[Vec3],
        params: NewtonParams,
        ls: &LineSearch,
    ) -> Result<GpuNewton<'c>> {
        let start = Instant::now();
        let (nv, ne, nf) = (p.num_vertices(), p.num_corners(), p.free_vertices.len());
        if x.len() != nv {
            return Err(Error::InvalidArgument(format!(
                "{} positions for a problem with {nv} vertices",
                x.len()
            )));
        }
        let pattern = HessianPattern::new(p);
        let nb = pattern.matrix.blocks.len();
        let (contrib_offsets, contrib_items) = contributions(&pattern);
        let r = ctx.real_size();
        check_bindings(
            &BindingLimits::of(&ctx.limits),
            &[
                ("positions", 3 * nv as u64 * r),
                ("corners", 20 * ne as u64),
                ("corner gradients and Hessian blocks", ELEM_STRIDE * ne as u64 * r),
                ("Hessian blocks", 9 * nb as u64 * r),
                ("Hessian contributions", 4 * contrib_items.len() as u64),
                ("incidence", 4 * p.incidence.items.len() as u64),
                ("corner gradients", 12 * ne as u64 * r),
            ],
        )?;
        grid(ne)?;
        grid(nb)?;
        let n_obj = ne.div_ceil(64).max(1);
        let sizes = ctx.uniform(
            "sizes",
            &Sizes {
                n_elements: ne as u32,
                n_free: nf as u32,
                n_obj_partials: n_obj as u32,
                n_vert_partials: 0,
            },
        );
        let dims = |label: &str, n: usize, op: u32, slot: u32, aux: u32| {
            ctx.uniform(
                label,
                &Dims {
                    n: n as u32,
                    op,
                    slot,
                    aux,
                },
            )
        };
        let model_u = ModelUniform::of(p);
        let fast = model_u.fast != 0;
        let model = ctx.uniform("model", &model_u);
        let (corner_items, table) = corner_tables(p);
        let shapes = ctx.storage_real("corner shapes", &table);
        let flat: Vec<f64> = x.iter().flatten().copied().collect();
        let xb = ctx.storage_real("positions", &flat);
        let trial = ctx.storage_real("trial positions", &flat);
        let tets = ctx.storage_u32("corners", &corner_items);
        let inc_off = ctx.storage_u32("incidence offsets", &p.incidence.offsets);
        let inc = ctx.storage_u32("incidence", &p.incidence.items);
        let free = ctx.storage_u32("free vertices", &pattern.free_vertex);
        let m = &pattern.matrix;
        let row_offsets = ctx.storage_u32("row offsets", &m.row_offsets);
        let cols = ctx.storage_u32("block columns", &m.cols);
        let diag = ctx.storage_u32("diagonal blocks", &m.diag);
        let c_off = ctx.storage_u32("contribution offsets", &contrib_offsets);
        let c_items = ctx.storage_u32("contributions", &contrib_items);
        let elem = ctx.zeros_real("corner gradients and Hessian blocks", ELEM_STRIDE as usize * ne);
        let elem_grad = ctx.zeros_real("corner gradients", 12 * ne);
        let blocks = ctx.zeros_real("Hessian blocks", 9 * nb);
        let factors = ctx.zeros_real("block-Jacobi factors", 6 * nf);
        let vec = |label: &str| ctx.zeros_real(label, 3 * nf);
        let v = Vectors {
            g: vec("gradient"),
            rhs: vec("right-hand side"),
            d: vec("direction"),
            r: vec("residual"),
            z: vec("preconditioned residual"),
            p: vec("search direction"),
            q: vec("A p"),
        };
        let partials = ctx.zeros_real("dot partials", 2 * nf.div_ceil(64).max(1));
        let scalars = ctx.zeros_real("scalars", N_SLOTS);
        let obj_partials = ctx.zeros_real("objective partials", 3 * n_obj);
        let vert_partials = ctx.zeros_real("vertex partials (unused)", 2);
        let out = ctx.zeros_real("objective scalars", OUT_LEN);
        let step_alpha = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("line-search step"),
            size: 4 * r,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("scalars read back"),
            size: (N_SLOTS + OUT_LEN) as u64 * r,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });

        let dims_rows = |op: u32| dims("rows", nf, op, 0, 0);
        let dot = |a: &wgpu::Buffer, b: &wgpu::Buffer, slot: u32, aux: u32| {
            let d = dims("dot", nf, 0, slot, aux);
            Dot {
                partial: ctx.bind(Kernel::Dot, &[&d, a, b, &partials]),
                fin: ctx.bind(Kernel::DotFinal, &[&d, &partials, &scalars]),
            }
        };
        let (dims_factor, dims_apply) = (dims_rows(0), dims_rows(1));
        let vector = |op: u32, bufs: [&wgpu::Buffer; 4]| {
            let d = dims_rows(op);
            ctx.bind(Kernel::Vector, &[&d, &scalars, bufs[0], bufs[1], bufs[2], bufs[3]])
        };
        let cg_bufs = [&v.p, &v.q, &v.d, &v.r];
        let groups = Groups {
            assemble: ctx.bind(
                Kernel::HessianAssemble.for_model(fast),
                &[&model, &sizes, &xb, &tets, &shapes, &elem],
            ),
            gather: ctx.bind(
                Kernel::HessianGather,
                &[&dims("blocks", nb, 0, 0, 0), &c_off, &c_items, &elem, &blocks],
            ),
            gradient: ctx.bind(
                Kernel::GradientGather,
                &[&sizes, &free, &inc_off, &inc, &elem, &v.g, &v.rhs],
            ),
            spmv: ctx.bind(
                Kernel::BsrSpmv,
                &[&dims_rows(0), &row_offsets, &cols, &blocks, &v.p, &v.q],
            ),
            factor: ctx.bind(
                Kernel::BlockJacobi,
                &[&dims_factor, &blocks, &diag, &factors, &v.r, &v.z],
            ),
            precond_rz: ctx.bind(
                Kernel::BlockJacobi,
                &[&dims_apply, &blocks, &diag, &factors, &v.r, &v.z],
            ),
            precond_fallback: ctx.bind(
                Kernel::BlockJacobi,
                &[&dims_apply, &blocks, &diag, &factors, &v.rhs, &v.d],
            ),
            cg_step: vector(OP_CG_STEP, cg_bufs),
            p_update: vector(OP_P_UPDATE, [&v.z, &v.q, &v.p, &v.d]),
            shift_rz: vector(OP_SHIFT_RZ, cg_bufs),
            negative_curvature: vector(OP_NEGATIVE_CURVATURE, cg_bufs),
            trial: ctx.bind(Kernel::LineSearch, &[&step_alpha, &sizes, &free, &xb, &v.d, &trial]),
            objective_trial: ctx.bind(
                Kernel::Objective.for_model(fast),
                &[&model, &sizes, &trial, &tets, &shapes, &elem_grad, &obj_partials],
            ),
            objective_x: ctx.bind(
                Kernel::Objective.for_model(fast),
                &[&model, &sizes, &xb, &tets, &shapes, &elem_grad, &obj_partials],
            ),
            reduce: ctx.bind(Kernel::Reduce, &[&sizes, &obj_partials, &vert_partials, &out]),
            dot_bb: dot(&v.rhs, &v.rhs, SLOT_BB, NO_SLOT),
            dot_rz: dot(&v.r, &v.z, SLOT_RZ, NO_SLOT),
            dot_pq: dot(&v.p, &v.q, SLOT_CURVATURE, NO_SLOT),
            dot_rr: dot(&v.r, &v.r, SLOT_RR, NO_SLOT),
            dot_rz_new: dot(&v.r, &v.z, SLOT_RZ_NEW, NO_SLOT),
            dot_pb: dot(&v.p, &v.rhs, SLOT_PB, NO_SLOT),
            dot_gd: dot(&v.g, &v.d, SLOT_SLOPE, NO_SLOT),
            dot_gg: dot(&v.g, &v.g, SLOT_GG, NO_SLOT),
            dot_dd: dot(&v.d, &v.d, SLOT_DD, SLOT_DMAX),
        };
        ctx.check()?;
        // uniforms are 16 bytes each; counted in bulk
        let device_bytes = [
            &model,
            &shapes,
            &sizes,
            &xb,
            &trial,
            &tets,
            &inc_off,
            &inc,
            &free,
            &row_offsets,
            &cols,
            &diag,
            &c_off,
            &c_items,
            &elem,
            &elem_grad,
            &blocks,
            &factors,
            &v.g,
            &v.rhs,
            &v.d,
            &v.r,
            &v.z,
            &v.p,
            &v.q,
            &partials,
            &scalars,
            &obj_partials,
            &vert_partials,
            &out,
            &step_alpha,
            &staging,
        ]
        .iter()
        .map(|b| b.size())
        .sum::<u64>()
            + 16 * 16;
        Ok(GpuNewton {
            ctx,
            params,
            ls: *ls,
            n_vertices: nv,
            n_corners: ne,
            n_free: nf,
            n_blocks: nb,
            fast,
            x: xb,
            trial,
            blocks,
            v,
            groups,
            scalars,
            out,
            staging,
            step_alpha,
            g0: None,
            current: None,
            last_pcg: None,
            cg_iterations: 0,
            setup_time: start.elapsed(),
            device_bytes,
        })
    }

    /// Bytes held on the device.
    pub fn device_bytes(&self) -> usize {
        self.device_bytes as usize
    }

    /// Runs `record` (copies, then one compute pass), then reads the scalar
    /// slots and `reduce`'s output back.
    fn run(
        &self,
        copies: &[(&wgpu::Buffer, &wgpu::Buffer)],
        record: impl FnOnce(&Self, &mut wgpu::ComputePass<'_>) -> Result<()>,
    ) -> Result<Vec<f64>> {
        let ctx = self.ctx;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        for (src, dst) in copies {
            enc.copy_buffer_to_buffer(src, 0, dst, 0, src.size().min(dst.size()));
        }
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            record(self, &mut pass)?;
        }
        let r = ctx.real_size();
        enc.copy_buffer_to_buffer(&self.scalars, 0, &self.staging, 0, N_SLOTS as u64 * r);
        enc.copy_buffer_to_buffer(&self.out, 0, &self.staging, N_SLOTS as u64 * r, OUT_LEN as u64 * r);
        ctx.queue.submit([enc.finish()]);
        ctx.map_read(&self.staging, N_SLOTS + OUT_LEN)
    }

    fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>, k: Kernel, g: &wgpu::BindGroup, threads: usize) -> Result<()> {
        self.ctx.dispatch(pass, k, g, threads)
    }

    fn dot(&self, pass: &mut wgpu::ComputePass<'_>, d: &Dot) -> Result<()> {
        self.dispatch(pass, Kernel::Dot, &d.partial, self.n_free)?;
        self.dispatch(pass, Kernel::DotFinal, &d.fin, 1)
    }

    /// Gradient, right-hand side -g, Hessian blocks and |g|^2 at the current positions.
    fn record_assembly(&self, pass: &mut wgpu::ComputePass<'_>) -> Result<()> {
        let g = &self.groups;
        self.dispatch(
            pass,
            Kernel::HessianAssemble.for_model(self.fast),
            &g.assemble,
            self.n_corners,
        )?;
        self.dispatch(pass, Kernel::HessianGather, &g.gather, self.n_blocks)?;
        self.dispatch(pass, Kernel::GradientGather, &g.gradient, self.n_free)?;
        self.dot(pass, &g.dot_gg)
    }

    /// F from `reduce`'s output, `None` when some element is infeasible.
    fn objective_of(&self, v: &[f64]) -> Option<f64> {
        let out = &v[N_SLOTS..];
        (out[2] == 0.0 && out[0].is_finite()).then_some(out[0])
    }

    /// Assembles gradient and Hessian at the current positions; returns
    /// (F, |grad F|). An error when the positions are infeasible.
    pub fn assemble(&mut self) -> Result<(f64, f64)> {
        let v = self.run(&[], |s, pass| {
            s.record_assembly(pass)?;
            s.dispatch(
                pass,
                Kernel::Objective.for_model(s.fast),
                &s.groups.objective_x,
                s.n_corners,
            )?;
            s.dispatch(pass, Kernel::Reduce, &s.groups.reduce, 1)
        })?;
        let f = self.objective_of(&v).ok_or_else(|| {
            Error::Gpu(
                "the device finds inverted elements the CPU does not (f32 rounding of a nearly flat element?)".into(),
            )
        })?;
        let fg = (f, v[SLOT_GG as usize].sqrt());
        self.current = Some(fg);
        Ok(fg)
    }

    fn ensure_assembled(&mut self) -> Result<(f64, f64)> {
        match self.current {
            Some(fg) => Ok(fg),
            None => self.assemble(),
        }
    }

    /// PCG on H d = -g at the assembled point, from d = 0: the twin of
    /// `solve::pcg::pcg` with the block-Jacobi preconditioner. One read-back
    /// per iteration; alpha, beta and the guards run on the device.
    pub fn pcg(&mut self, params: &PcgParams) -> Result<PcgInfo> {
        let nf = self.n_free;
        let g = &self.groups;
        let s = self.run(&[(&self.v.rhs, &self.v.r)], |me, pass| {
            me.dispatch(pass, Kernel::BlockJacobi, &g.factor, nf)?;
            me.dot(pass, &g.dot_bb)?;
            me.dispatch(pass, Kernel::BlockJacobi, &g.precond_rz, nf)?;
            me.dot(pass, &g.dot_rz)
        })?;
        // d = 0 and p = z, by copies ahead of the first iteration's pass
        self.ctx.write_real(&self.v.d, &vec![0.0; 3 * nf]);
        let bnorm = s[SLOT_BB as usize].sqrt();
        if bnorm == 0.0 {
            return Ok(PcgInfo {
                iterations: 0,
                stop: PcgStop::Converged,
                relative_residual: 0.0,
            });
        }
        let mut first_copy = Some((&self.v.z, &self.v.p));
        let mut rel = 1.0;
        for k in 0..params.max_iter {
            let copies: Vec<(&wgpu::Buffer, &wgpu::Buffer)> = first_copy.take().into_iter().collect();
            let s = self.run(&copies, |me, pass| {
                me.dispatch(pass, Kernel::BsrSpmv, &g.spmv, nf)?;
                me.dot(pass, &g.dot_pq)?;
                me.dispatch(pass, Kernel::Vector, &g.cg_step, nf)?;
                me.dot(pass, &g.dot_rr)?;
                me.dispatch(pass, Kernel::BlockJacobi, &g.precond_rz, nf)?;
                me.dot(pass, &g.dot_rz_new)?;
                me.dispatch(pass, Kernel::Vector, &g.p_update, nf)?;
                me.dispatch(pass, Kernel::Vector, &g.shift_rz, 1)
            })?;
            let curvature = s[SLOT_CURVATURE as usize];
            if !(curvature > 0.0) {
                if k > 0 && params.negative_curvature == NegativeCurvature::Iterate {
                    // d already holds the iterate
                } else if k > 0 {
                    self.run(&[], |me, pass| {
                        me.dot(pass, &g.dot_pb)?;
                        me.dispatch(pass, Kernel::Vector, &g.negative_curvature, nf)
                    })?;
                } else {
                    self.run(&[(&self.v.p, &self.v.d)], |_, _| Ok(()))?;
                }
                return Ok(PcgInfo {
                    iterations: k,
                    stop: PcgStop::NegativeCurvature,
                    relative_residual: rel,
                });
            }
            rel = s[SLOT_RR as usize].sqrt() / bnorm;
            if rel <= params.rtol {
                return Ok(PcgInfo {
                    iterations: k + 1,
                    stop: PcgStop::Converged,
                    relative_residual: rel,
                });
            }
        }
        Ok(PcgInfo {
            iterations: params.max_iter,
            stop: PcgStop::MaxIterations,
            relative_residual: rel,
        })
    }

    /// One Newton iteration, the twin of `Newton::step`: (F, |grad F|) at the
    /// new point and the largest squared vertex displacement (0 when the line
    /// search found no acceptable step).
    pub fn step(&mut self) -> Result<(f64, f64, f64)> {
        let (f, gnorm) = self.ensure_assembled()?;
        let g0 = *self.g0.get_or_insert(gnorm);
        let rtol = self.params.forcing_max.min((gnorm / g0).sqrt());
        let info = self.pcg(&PcgParams {
            max_iter: self.params.cg_max_iter,
            rtol,
            negative_curvature: self.params.negative_curvature,
        })?;
        self.cg_iterations += info.iterations;
        self.last_pcg = Some(info);
        let g = &self.groups;
        let mut slope = self.run(&[], |me, pass| me.dot(pass, &g.dot_gd))?[SLOPE];
        if !(slope < 0.0) {
            // not downhill (rounding at a near-stationary point): preconditioned steepest descent
            slope = self.run(&[], |me, pass| {
                me.dispatch(pass, Kernel::BlockJacobi, &g.precond_fallback, me.n_free)?;
                me.dot(pass, &g.dot_gd)
            })?[SLOPE];
            if !(slope < 0.0) {
                return Ok((f, gnorm, 0.0));
            }
        }
        let mut alpha = 1.0;
        for _ in 0..=self.ls.max_backtracks {
            self.ctx.write_real(&self.step_alpha, &[alpha, 0.0, 0.0, 0.0]);
            let v = self.run(&[], |me, pass| {
                me.dispatch(pass, Kernel::LineSearch, &g.trial, me.n_free)?;
                me.dispatch(
                    pass,
                    Kernel::Objective.for_model(me.fast),
                    &g.objective_trial,
                    me.n_corners,
                )?;
                me.dispatch(pass, Kernel::Reduce, &g.reduce, 1)
            })?;
            if let Some(ft) = self.objective_of(&v)
                && ft <= f + self.ls.sigma * alpha * slope
            {
                // the next iteration's gradient and Hessian, and this one's |grad F|
                let v = self.run(&[(&self.trial, &self.x)], |me, pass| {
                    me.record_assembly(pass)?;
                    me.dot(pass, &g.dot_dd)
                })?;
                let gnorm_new = v[SLOT_GG as usize].sqrt();
                self.current = Some((ft, gnorm_new));
                return Ok((ft, gnorm_new, alpha * alpha * v[SLOT_DMAX as usize]));
            }
            alpha *= self.ls.beta;
        }
        Ok((f, gnorm, 0.0))
    }

    fn read_vec3(&self, b: &wgpu::Buffer, n: usize) -> Result<Vec<Vec3>> {
        let flat = self.ctx.read_real(b, 3 * n)?;
        Ok(flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }

    fn write_vec3(&self, b: &wgpu::Buffer, v: &[Vec3]) -> Result<()> {
        if v.len() != self.n_free {
            return Err(Error::InvalidArgument(format!(
                "a vector of {} blocks for {} free vertices",
                v.len(),
                self.n_free
            )));
        }
        let flat: Vec<f64> = v.iter().flatten().copied().collect();
        self.ctx.write_real(b, &flat);
        Ok(())
    }

    /// The current positions (problem numbering).
    pub fn download(&self) -> Result<Vec<Vec3>> {
        self.read_vec3(&self.x, self.n_vertices)
    }

    /// The assembled free gradient (free-vertex numbering).
    pub fn gradient(&self) -> Result<Vec<Vec3>> {
        self.read_vec3(&self.v.g, self.n_free)
    }

    /// The last direction from `pcg` or `step`.
    pub fn direction(&self) -> Result<Vec<Vec3>> {
        self.read_vec3(&self.v.d, self.n_free)
    }

    /// The assembled Hessian blocks, in the order of `HessianPattern::matrix.blocks`.
    pub fn hessian_blocks(&self) -> Result<Vec<Mat3>> {
        let flat = self.ctx.read_real(&self.blocks, 9 * self.n_blocks)?;
        Ok(flat
            .chunks_exact(9)
            .map(|c| [[c[0], c[1], c[2]], [c[3], c[4], c[5]], [c[6], c[7], c[8]]])
            .collect())
    }

    /// A x with the assembled Hessian (for tests against `BlockCsr::mul`).
    pub fn mul(&mut self, x: &[Vec3]) -> Result<Vec<Vec3>> {
        self.write_vec3(&self.v.p, x)?;
        self.run(&[], |me, pass| {
            me.dispatch(pass, Kernel::BsrSpmv, &me.groups.spmv, me.n_free)
        })?;
        self.read_vec3(&self.v.q, self.n_free)
    }

    /// M^-1 x with the block-Jacobi factors of the assembled Hessian (for
    /// tests against `BlockJacobi`).
    pub fn precondition(&mut self, x: &[Vec3]) -> Result<Vec<Vec3>> {
        self.write_vec3(&self.v.r, x)?;
        self.run(&[], |me, pass| {
            me.dispatch(pass, Kernel::BlockJacobi, &me.groups.factor, me.n_free)?;
            me.dispatch(pass, Kernel::BlockJacobi, &me.groups.precond_rz, me.n_free)
        })?;
        self.read_vec3(&self.v.z, self.n_free)
    }

    /// a . b on the device (for tests against the CPU dot product).
    pub fn dot_of(&mut self, a: &[Vec3], b: &[Vec3]) -> Result<f64> {
        self.write_vec3(&self.v.r, a)?;
        self.write_vec3(&self.v.z, b)?;
        Ok(self.run(&[], |me, pass| me.dot(pass, &me.groups.dot_rz))?[SLOT_RZ as usize])
    }

    /// y + alpha x through PCG's update kernel (for tests against the CPU axpy).
    pub fn axpy(&mut self, alpha: f64, x: &[Vec3], y: &[Vec3]) -> Result<Vec<Vec3>> {
        self.write_vec3(&self.v.p, x)?;
        self.write_vec3(&self.v.q, &vec![[0.0; 3]; self.n_free])?;
        self.write_vec3(&self.v.d, y)?;
        let mut s = vec![0.0; N_SLOTS];
        s[SLOT_RZ as usize] = alpha;
        s[SLOT_CURVATURE as usize] = 1.0;
        self.ctx.write_real(&self.scalars, &s);
        self.run(&[], |me, pass| {
            me.dispatch(pass, Kernel::Vector, &me.groups.cg_step, me.n_free)
        })?;
        self.read_vec3(&self.v.d, self.n_free)
    }
}

const SLOPE: usize = SLOT_SLOPE as usize;
