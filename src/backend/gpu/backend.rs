//! `Backend` on a wgpu device. The problem is uploaded once; each operation
//! becomes one dispatch (its `Op` record in a uniform buffer at a dynamic
//! offset, so bind groups are built once per buffer combination and
//! reused), recorded into one command encoder; `flush` submits it and reads
//! the scalar slots back: the only read-back of a CG iteration or of a
//! line-search trial.

use super::buffers::{BindingLimits, check_bindings};
use super::context::{DeviceLayout, GpuContext};
use super::layout::{CORNER_STRIDE, ELEM_STRIDE, ModelUniform, Op, corner_tables};
use super::shader::{Access, Form, Kernel, Variant};
use super::sweep_layout::SweepLayout;
use crate::backend::cpu::hessian_assemble::HessianPattern;
use crate::backend::{Backend, Coef, Entries, EvalSlots, N_SLOTS, Points, Slot, Vector};
use crate::error::{Error, Result};
use crate::metric::mat3::Vec3;
use crate::problem::Problem;
use crate::solve::line_search::LineSearch;
use std::collections::HashMap;

/// Device buffers by role: the keys of the bind-group cache.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Buf {
    Model,
    LineSearch,
    Ops,
    X,
    Trial,
    Corners,
    Shapes,
    IncOffsets,
    Inc,
    Free,
    Colors,
    Moves,
    CornerGrad,
    Partials,
    Scalars,
    /// Bound in place of x when `axpby` has x == y.
    Dummy,
    Vector(u32),
    RowOffsets,
    Cols,
    Diag,
    ContribOffsets,
    ContribItems,
    Elem,
    Blocks,
    Factors,
    /// Sliding-boundary projectors and primitives (`boundary.wgsl`).
    SlideReal,
    /// Sliding-boundary candidate lists.
    SlideIdx,
    /// Step 1 of rezoning's output.
    Reference,
    /// The records of a part's owned corners (`restrict_sums`).
    OwnedCorners,
    /// Zeros for a part's ghost entries, masking them out of `dot`.
    GhostZeros,
    /// A halo list's device indices, and its values in list order.
    HaloIdx(u32),
    HaloData(u32),
}

/// What a part's sums cover (`Backend::restrict_sums`): the owned corners
/// (their records in `Buf::OwnedCorners`); the owned free entries, by
/// zeroing the ghost entries (halo list `ghosts`) of copies in `temps`.
struct Share {
    corners: usize,
    /// The halo list of the ghost entries and its length.
    ghosts: Option<(u32, usize)>,
    temps: [Vector; 2],
}

/// Operations recorded between two submissions (the `Op` buffer's capacity).
const OPS_PER_BATCH: usize = 512;

pub struct GpuBackend<'c> {
    ctx: &'c GpuContext,
    n_vertices: usize,
    n_corners: usize,
    n_free: usize,
    /// (offset, count) of each colour in `Buf::Colors`.
    colors: Vec<(u32, u32)>,
    /// Closed-form (tetrahedral mean ratio) kernels or the general ones.
    /// The instance of the corner kernels this problem's model compiles to.
    form: Form,
    max_backtracks: u32,
    /// Each array as its buffers: one, or the parts of an array split
    /// across bindings (`Binding::split`).
    bufs: HashMap<Buf, Vec<wgpu::Buffer>>,
    vectors: Vec<wgpu::Buffer>,
    staging: wgpu::Buffer,
    groups: HashMap<(Variant, Vec<Buf>), wgpu::BindGroup>,
    encoder: Option<wgpu::CommandEncoder>,
    /// Pending `Op` records, `ctx.op_stride()` apart.
    ops: Vec<u8>,
    n_blocks: usize,
    problem: &'c Problem,
    /// The device numbering of vertices and corners.
    layout: SweepLayout,
    /// Command buffers submitted so far.
    submissions: usize,
    /// Uploaded halo lists by (positions?, free-vector indices): the
    /// `k` of `Buf::HaloIdx(k)` and `Buf::HaloData(k)`.
    halo_lists: HashMap<(bool, Vec<u32>), u32>,
    share: Option<Share>,
}

fn groups_of(n: usize) -> usize {
    n.div_ceil(64).max(1)
}

impl<'c> GpuBackend<'c> {
    /// Uploads the problem and positions `x` (problem numbering); `ls` drives
    /// the per-vertex line searches of BCD.
    pub fn new(ctx: &'c GpuContext, p: &'c Problem, x: &[Vec3], ls: &LineSearch) -> Result<Self> {
        let (nv, nc, nf) = (p.num_vertices(), p.num_corners(), p.free_vertices.len());
        if x.len() != nv {
            return Err(Error::InvalidArgument(format!(
                "{} positions for a problem with {nv} vertices",
                x.len()
            )));
        }
        let r = ctx.real_size();
        let layout = match ctx.layout {
            DeviceLayout::Problem => SweepLayout::identity(p),
            DeviceLayout::ByColour => SweepLayout::colour_by_colour(p, false),
            DeviceLayout::ByValence => SweepLayout::colour_by_colour(p, true),
        };
        let (slide_real, slide_idx) = slide_tables(p, &layout);
        check_bindings(
            &BindingLimits::of(&ctx.limits),
            &[
                (
                    "sliding-boundary projectors and primitives",
                    slide_real.len() as u64 * r,
                ),
                ("sliding-boundary candidates", 4 * slide_idx.len() as u64),
                ("positions", 3 * nv as u64 * r),
                ("incidence offsets", 4 * (nv as u64 + 1)),
            ],
        )?;
        super::buffers::grid(nc)?;
        let model = ModelUniform::of(p);
        let (problem_corners, table) = corner_tables(p);
        let stride = CORNER_STRIDE as usize;
        let corner_items: Vec<u32> = layout
            .corner_of
            .iter()
            .flat_map(|&c| {
                let rec = &problem_corners[stride * c as usize..stride * (c as usize + 1)];
                rec[..4].iter().map(|&v| layout.vertex[v as usize]).chain([rec[4]])
            })
            .collect();
        drop(problem_corners);
        let incidence = layout.incidence(&p.incidence);
        let flat: Vec<f64> = layout.to_device(x.as_flattened(), 3);
        let partials = groups_of(nc.max(nv).max(nf));
        let mut single = HashMap::new();
        single.insert(Buf::Model, ctx.uniform_bytes("model", model.bytes(ctx.real)));
        single.insert(
            Buf::LineSearch,
            ctx.uniform_real("line search", &[ls.beta, ls.sigma, 0.0, 0.0]),
        );
        single.insert(
            Buf::Ops,
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("operations"),
                size: OPS_PER_BATCH as u64 * ctx.op_stride(),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
        );
        single.insert(Buf::X, ctx.storage_real("positions", &flat));
        single.insert(Buf::Trial, ctx.storage_real("trial positions", &flat));
        single.insert(Buf::Shapes, ctx.storage_real("corner shapes", &table));
        single.insert(
            Buf::IncOffsets,
            ctx.storage_u32("incidence offsets", &incidence.offsets),
        );
        single.insert(
            Buf::Free,
            ctx.storage_u32("free vertices", &layout.vertex_ids(&p.free_vertices)),
        );
        single.insert(Buf::Colors, ctx.storage_u32("colours", &layout.colours));
        single.insert(Buf::Moves, ctx.zeros_real("moves", 3 * nv));
        single.insert(Buf::Partials, ctx.zeros_real("partials", 4 * partials));
        single.insert(Buf::Scalars, ctx.zeros_real("scalar slots", N_SLOTS));
        single.insert(Buf::Dummy, ctx.zeros_real("unused", 4));
        single.insert(
            Buf::SlideReal,
            ctx.storage_real("sliding projectors and primitives", &slide_real),
        );
        single.insert(Buf::SlideIdx, ctx.storage_u32("sliding candidates", &slide_idx));
        let mut bufs: HashMap<Buf, Vec<wgpu::Buffer>> = single.into_iter().map(|(k, b)| (k, vec![b])).collect();
        bufs.insert(Buf::Corners, ctx.split_u32("corners", &corner_items));
        bufs.insert(Buf::Inc, ctx.split_u32("incidence", &incidence.items));
        bufs.insert(Buf::CornerGrad, ctx.split_zeros_real("corner gradients", 12 * nc));
        let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("scalar slots read back"),
            size: N_SLOTS as u64 * r,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let colors = (0..p.colors.len())
            .map(|c| (p.colors.offsets[c], p.colors.of(c).len() as u32))
            .collect();
        ctx.check()?;
        Ok(GpuBackend {
            ctx,
            n_vertices: nv,
            n_corners: nc,
            n_free: nf,
            colors,
            form: if ctx.general_only {
                Form::general(&model)
            } else {
                Form::of(&model)
            },
            max_backtracks: ls.max_backtracks as u32,
            bufs,
            vectors: Vec::new(),
            staging,
            groups: HashMap::new(),
            encoder: None,
            ops: Vec::new(),
            n_blocks: 0,
            problem: p,
            layout,
            submissions: 0,
            halo_lists: HashMap::new(),
            share: None,
        })
    }

    /// The buffers of array `b` (one unless it is split).
    fn buf(&self, b: Buf) -> &[wgpu::Buffer] {
        match b {
            Buf::Vector(i) => std::slice::from_ref(&self.vectors[i as usize]),
            other => &self.bufs[&other],
        }
    }

    /// `v` with its split bindings spanning the parts of the arrays in
    /// `bufs`; an error with the numbers where the kernel would need more
    /// storage bindings than the device has.
    fn split_variant(&self, mut v: Variant, bufs: &[Buf]) -> Result<Variant> {
        let def = v.kernel.def();
        let (mut j, mut storage) = (0, 0);
        for (b, binding) in bufs.iter().zip(def.bindings) {
            let n = self.buf(*b).len();
            if binding.split {
                v.extra[j] = u8::try_from(n - 1).unwrap_or(u8::MAX);
                j += 1;
            } else {
                debug_assert_eq!(n, 1, "{}: '{}' is not split", def.stem, binding.name);
            }
            if matches!(binding.access, Access::Read | Access::ReadWrite) {
                storage += n;
            }
        }
        let max = self.ctx.limits.max_storage_buffers_per_shader_stage as usize;
        if storage > max || v.extra.contains(&u8::MAX) {
            return Err(Error::Gpu(format!(
                "mesh too large for this device: the kernel '{}' would bind {storage} storage \
                 buffers (its large arrays split into parts of {:.1} MiB, the largest one \
                 binding holds) but the device allows {max} per shader stage",
                def.stem,
                self.ctx.part_bytes() as f64 / 1048576.0
            )));
        }
        Ok(v)
    }

    /// Records one dispatch of `v` over `threads` with `bufs` bound in table
    /// order and `op` as its `Op` record.
    fn record(&mut self, v: Variant, bufs: &[Buf], op: Op, threads: usize) -> Result<()> {
        let v = self.split_variant(v, bufs)?;
        let stride = self.ctx.op_stride() as usize;
        if self.ops.len() / stride >= OPS_PER_BATCH {
            self.submit()?;
        }
        let offset = self.ops.len();
        self.ops.extend_from_slice(&op.bytes(self.ctx.real));
        self.ops.resize(offset + stride, 0);
        let key = (v, bufs.to_vec());
        if !self.groups.contains_key(&key) {
            let buffers: Vec<&[wgpu::Buffer]> = bufs.iter().map(|b| self.buf(*b)).collect();
            let group = self.ctx.bind(v, &buffers);
            self.groups.insert(key.clone(), group);
        }
        let group = self.groups[&key].clone();
        let ctx = self.ctx;
        let mut pass = self.encoder().begin_compute_pass(&Default::default());
        ctx.dispatch(&mut pass, v, &group, Some(offset as u32), threads)
    }

    /// The encoder operations are recorded into, started on first use.
    fn encoder(&mut self) -> &mut wgpu::CommandEncoder {
        let ctx = self.ctx;
        self.encoder
            .get_or_insert_with(|| ctx.device.create_command_encoder(&Default::default()))
    }

    /// Copies between arrays of one buffer each (positions).
    fn copy(&mut self, src: Buf, dst: Buf) {
        let size = self.buf(src)[0].size().min(self.buf(dst)[0].size());
        let (src, dst) = (self.bufs[&src][0].clone(), self.bufs[&dst][0].clone());
        self.encoder().copy_buffer_to_buffer(&src, 0, &dst, 0, size);
    }

    /// Submits what was recorded (the `Op` records go first).
    fn submit(&mut self) -> Result<()> {
        if let Some(enc) = self.encoder.take() {
            if !self.ops.is_empty() {
                self.ctx.queue.write_buffer(&self.bufs[&Buf::Ops][0], 0, &self.ops);
                self.ops.clear();
            }
            self.ctx.queue.submit([enc.finish()]);
            self.submissions += 1;
        }
        self.ctx.check()
    }

    /// The final pass of a reduction over `n_partials` partials into slots.
    fn reduce(
        &mut self,
        sum: Option<Slot>,
        min: Option<Slot>,
        max: Option<Slot>,
        count: Option<Slot>,
        n_partials: usize,
    ) -> Result<()> {
        let op = Op {
            slot: Op::slot(sum),
            aux: Op::slot(min),
            aux2: Op::slot(max),
            aux3: Op::slot(count),
            ..Op::n(n_partials)
        };
        self.record(Kernel::Reduce.plain(), &[Buf::Ops, Buf::Partials, Buf::Scalars], op, 1)
    }

    fn read_vec3(&mut self, b: Buf, n: usize) -> Result<Vec<Vec3>> {
        self.submit()?;
        let flat = self.ctx.read_real(&self.buf(b)[0], 3 * n)?;
        Ok(flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }

    /// g <- P g at every free vertex, where the boundary slides.
    fn constrain(&mut self, g: Vector) -> Result<()> {
        if self.problem.sliding.is_none() {
            return Ok(());
        }
        self.record(
            Kernel::Constrain.plain(),
            &[Buf::Ops, Buf::SlideReal, Buf::SlideIdx, Buf::Free, Buf::Vector(g.0)],
            Op::n(self.n_free),
            self.n_free,
        )
    }

    /// The halo list `idx` (free-vector indices into positions or a
    /// vector), uploaded on first use with a values buffer of its length.
    fn halo_list(&mut self, points: bool, idx: &[u32]) -> u32 {
        let key = (points, idx.to_vec());
        if let Some(&k) = self.halo_lists.get(&key) {
            return k;
        }
        let k = self.halo_lists.len() as u32;
        let ids: Vec<u32> = match points {
            true => idx
                .iter()
                .map(|&i| self.layout.vertex[self.problem.free_vertices[i as usize] as usize])
                .collect(),
            false => idx.to_vec(),
        };
        let (index, values) = (
            self.ctx.storage_u32("halo entries", &ids),
            self.ctx.zeros_real("halo values", 3 * idx.len()),
        );
        self.bufs.insert(Buf::HaloIdx(k), vec![index]);
        self.bufs.insert(Buf::HaloData(k), vec![values]);
        self.halo_lists.insert(key, k);
        k
    }

    fn entries(of: Entries) -> (bool, Buf) {
        match of {
            Entries::Points(Points::Current) => (true, Buf::X),
            Entries::Points(Points::Trial) => (true, Buf::Trial),
            Entries::Vector(v) => (false, Buf::Vector(v.0)),
        }
    }

    /// `t` = `v` with the ghost entries of the share zeroed.
    fn owned_copy(&mut self, v: Vector, t: Vector, ghosts: Option<(u32, usize)>) -> Result<()> {
        self.axpby(Coef::value(1.0), v, Coef::value(0.0), t, None)?;
        match ghosts {
            Some((k, n)) => self.record(
                Kernel::HaloScatter.plain(),
                &[Buf::Ops, Buf::HaloIdx(k), Buf::GhostZeros, Buf::Vector(t.0)],
                Op::n(n),
                n,
            ),
            None => Ok(()),
        }
    }

    /// Records the objective kernel over the `n` corner records of `corners`.
    fn objective(&mut self, x: Buf, corners: Buf, n: usize) -> Result<()> {
        self.record(
            Kernel::Objective.with(self.form),
            &[
                Buf::Model,
                Buf::Ops,
                x,
                corners,
                Buf::Shapes,
                Buf::CornerGrad,
                Buf::Partials,
            ],
            Op::n(n),
            n,
        )
    }

    /// Command buffers submitted so far (read-backs of vectors and
    /// positions submit their own copies besides).
    pub fn submissions(&self) -> usize {
        self.submissions
    }

    /// The instance its kernels with variants are compiled as: the closed
    /// forms wherever the CPU takes them (`Model::fast`, `Model::planar`).
    pub fn form(&self) -> Form {
        self.form
    }

    /// The most buffers any one array is split across (1: none is split).
    pub fn max_parts(&self) -> usize {
        self.bufs.values().map(Vec::len).max().unwrap_or(1)
    }

    /// The block-Jacobi factors (after `factor_precond`), as `BlockJacobi::factors`.
    pub fn block_jacobi_factors(&mut self) -> Result<Vec<[f64; 6]>> {
        self.submit()?;
        let flat = self.ctx.read_real(&self.buf(Buf::Factors)[0], 6 * self.n_free)?;
        Ok(flat
            .chunks_exact(6)
            .map(|c| [c[0], c[1], c[2], c[3], c[4], c[5]])
            .collect())
    }

    /// The assembled Hessian blocks, in the order of `HessianPattern::matrix.blocks`.
    pub fn hessian_blocks(&mut self) -> Result<Vec<crate::metric::mat3::Mat3>> {
        self.submit()?;
        let flat = self.ctx.read_split_real(self.buf(Buf::Blocks), 9 * self.n_blocks)?;
        Ok(flat
            .chunks_exact(9)
            .map(|c| [[c[0], c[1], c[2]], [c[3], c[4], c[5]], [c[6], c[7], c[8]]])
            .collect())
    }
}

/// `boundary.wgsl`'s tables: projectors then primitives (reals), and the
/// vertex count, candidate offsets and candidates (u32s). Without sliding,
/// all offsets are zero: no vertex slides.
fn slide_tables(p: &Problem, layout: &SweepLayout) -> (Vec<f64>, Vec<u32>) {
    let nv = p.num_vertices();
    match &p.sliding {
        None => (
            vec![0.0; 4],
            [nv as u32].into_iter().chain(std::iter::repeat_n(0, nv + 1)).collect(),
        ),
        Some(s) => {
            let projector: Vec<f64> = s.projector.iter().flatten().flatten().copied().collect();
            let real = layout
                .to_device(&projector, 9)
                .into_iter()
                .chain(s.primitives.iter().flatten().flatten().copied())
                .collect();
            let candidates = layout.lists(&s.candidates);
            let idx = [nv as u32]
                .into_iter()
                .chain(candidates.offsets)
                .chain(candidates.items)
                .collect();
            (real, idx)
        }
    }
}

/// Per block slot, its element contributions `corner * 16 + 4 a + b` (the
/// device corner) in ascending problem corner order (the CPU assembly's sum order).
fn contributions(pattern: &HessianPattern, layout: &SweepLayout) -> (Vec<u32>, Vec<u32>) {
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
                items[fill[s as usize] as usize] = 16 * layout.corner[e] + ab as u32;
                fill[s as usize] += 1;
            }
        }
    }
    (offsets, items)
}

impl Backend for GpuBackend<'_> {
    fn describe(&self) -> String {
        format!(
            "gpu {} ({})",
            self.ctx.adapter_name(),
            if self.ctx.is_f64() { "f64" } else { "f32" }
        )
    }

    fn num_free(&self) -> usize {
        self.n_free
    }

    fn num_colors(&self) -> usize {
        self.colors.len()
    }

    fn vector(&mut self) -> Result<Vector> {
        check_bindings(
            &BindingLimits::of(&self.ctx.limits),
            &[("free-vertex vector", 3 * self.n_free as u64 * self.ctx.real_size())],
        )?;
        self.vectors.push(self.ctx.zeros_real("vector", 3 * self.n_free));
        Ok(Vector(self.vectors.len() as u32 - 1))
    }

    fn read_vector(&mut self, v: Vector) -> Result<Vec<Vec3>> {
        self.read_vec3(Buf::Vector(v.0), self.n_free)
    }

    fn write_vector(&mut self, v: Vector, data: &[Vec3]) -> Result<()> {
        if data.len() != self.n_free {
            return Err(Error::InvalidArgument(format!(
                "a vector of {} blocks for {} free vertices",
                data.len(),
                self.n_free
            )));
        }
        // after what is recorded, before what comes next
        self.submit()?;
        let flat: Vec<f64> = data.iter().flatten().copied().collect();
        self.ctx.write_real(&self.vectors[v.0 as usize], &flat);
        Ok(())
    }

    fn download(&mut self) -> Result<Vec<Vec3>> {
        let x = self.read_vec3(Buf::X, self.n_vertices)?;
        Ok(self.layout.to_problem(&x))
    }

    fn evaluate(&mut self, at: Points, out: EvalSlots, gradient: Option<Vector>) -> Result<()> {
        let x = match at {
            Points::Current => Buf::X,
            Points::Trial => Buf::Trial,
        };
        let nc = self.n_corners;
        let owned = self.share.as_ref().map(|s| s.corners);
        // a part's sums over its owned corners first: the whole pass after
        // it overwrites their gradients with the part's own, where wanted
        match owned {
            Some(0) => {
                self.set_slot(out.value, Coef::value(0.0), None)?;
                self.set_slot(out.infeasible, Coef::value(0.0), None)?;
                if let Some(s) = out.min_det {
                    self.set_slot(s, Coef::value(f64::INFINITY), None)?;
                }
            }
            Some(n) => {
                self.objective(x, Buf::OwnedCorners, n)?;
                self.reduce(Some(out.value), out.min_det, None, Some(out.infeasible), groups_of(n))?;
            }
            None => {}
        }
        if owned.is_none() || gradient.is_some() {
            self.objective(x, Buf::Corners, nc)?;
        }
        if owned.is_none() {
            self.reduce(Some(out.value), out.min_det, None, Some(out.infeasible), groups_of(nc))?;
        }
        if let Some(g) = gradient {
            let op = Op {
                aux: 12,
                ..Op::n(self.n_free)
            };
            self.record(
                Kernel::GradientGather.plain(),
                &[
                    Buf::Ops,
                    Buf::Free,
                    Buf::IncOffsets,
                    Buf::Inc,
                    Buf::CornerGrad,
                    Buf::Vector(g.0),
                ],
                op,
                self.n_free,
            )?;
            self.constrain(g)?;
        }
        Ok(())
    }

    fn trial(&mut self, alpha: Coef, d: Vector) -> Result<()> {
        let op = Op {
            a: alpha,
            ..Op::n(self.n_free)
        };
        self.record(
            Kernel::LineSearch.plain(),
            &[Buf::Ops, Buf::Scalars, Buf::Free, Buf::X, Buf::Vector(d.0), Buf::Trial],
            op,
            self.n_free,
        )?;
        if self.problem.sliding.is_some() {
            self.record(
                Kernel::ProjectBoundary.plain(),
                &[Buf::Ops, Buf::SlideReal, Buf::SlideIdx, Buf::Free, Buf::Trial],
                Op::n(self.n_free),
                self.n_free,
            )?;
        }
        Ok(())
    }

    fn accept_trial(&mut self) -> Result<()> {
        self.copy(Buf::Trial, Buf::X);
        Ok(())
    }

    fn inversion_fraction(&mut self, out: Slot) -> Result<()> {
        let nc = self.n_corners;
        self.record(
            Kernel::Inversion.plain(),
            &[
                Buf::Model,
                Buf::Ops,
                Buf::X,
                Buf::Corners,
                Buf::Shapes,
                Buf::Trial,
                Buf::Partials,
            ],
            Op::n(nc),
            nc,
        )?;
        self.reduce(None, Some(out), None, None, groups_of(nc))
    }

    fn bcd_color(&mut self, color: usize) -> Result<()> {
        let (offset, count) = self.colors[color];
        if count == 0 {
            return Ok(());
        }
        let op = Op {
            offset,
            aux: self.max_backtracks,
            ..Op::n(count as usize)
        };
        self.record(
            Kernel::Bcd.with(self.form),
            &[
                Buf::Model,
                Buf::LineSearch,
                Buf::Ops,
                Buf::X,
                Buf::Corners,
                Buf::Shapes,
                Buf::IncOffsets,
                Buf::Inc,
                Buf::Colors,
                Buf::Moves,
                Buf::SlideReal,
                Buf::SlideIdx,
            ],
            op,
            count as usize,
        )
    }

    fn max_move(&mut self, out: Slot) -> Result<()> {
        let nv = self.n_vertices;
        self.record(
            Kernel::Dot.plain(),
            &[Buf::Ops, Buf::Moves, Buf::Moves, Buf::Partials],
            Op::n(nv),
            nv,
        )?;
        self.reduce(None, None, Some(out), None, groups_of(nv))?;
        // "since the last call": the next colours start from no move
        let moves = self.bufs[&Buf::Moves][0].clone();
        self.encoder().clear_buffer(&moves, 0, None);
        Ok(())
    }

    fn reference_positions(&mut self, iters: usize) -> Result<Vec<Vec3>> {
        if !self.bufs.contains_key(&Buf::Reference) {
            let buf = self.ctx.zeros_real("reference positions", 3 * self.n_vertices);
            self.bufs.insert(Buf::Reference, vec![buf]);
        }
        // fixed vertices are their own reference
        self.copy(Buf::X, Buf::Reference);
        if self.n_free > 0 {
            let tol = crate::backend::cpu::reference_position::STEP_TOL;
            let op = Op {
                aux: self.max_backtracks,
                aux2: iters as u32,
                a: Coef::value(tol * tol),
                ..Op::n(self.n_free)
            };
            self.record(
                Kernel::ReferencePosition.with(self.form),
                &[
                    Buf::Model,
                    Buf::LineSearch,
                    Buf::Ops,
                    Buf::X,
                    Buf::Corners,
                    Buf::Shapes,
                    Buf::IncOffsets,
                    Buf::Inc,
                    Buf::Free,
                    Buf::Reference,
                ],
                op,
                self.n_free,
            )?;
        }
        let xr = self.read_vec3(Buf::Reference, self.n_vertices)?;
        Ok(self.layout.to_problem(&xr))
    }

    fn prepare_hessian(&mut self) -> Result<usize> {
        let ctx = self.ctx;
        let pattern = HessianPattern::new(self.problem);
        let nb = pattern.matrix.blocks.len();
        let (c_off, c_items) = contributions(&pattern, &self.layout);
        let r = ctx.real_size();
        check_bindings(
            &BindingLimits::of(&ctx.limits),
            &[
                ("Hessian row offsets", 4 * (self.n_free as u64 + 1)),
                ("diagonal blocks", 4 * self.n_free as u64),
                ("block-Jacobi factors", 6 * self.n_free as u64 * r),
            ],
        )?;
        super::buffers::grid(nb)?;
        let m = &pattern.matrix;
        let new = [
            (Buf::RowOffsets, vec![ctx.storage_u32("row offsets", &m.row_offsets)]),
            (Buf::Cols, ctx.split_u32("block columns", &m.cols)),
            (Buf::Diag, vec![ctx.storage_u32("diagonal blocks", &m.diag)]),
            (Buf::ContribOffsets, ctx.split_u32("contribution offsets", &c_off)),
            (Buf::ContribItems, ctx.split_u32("contributions", &c_items)),
            (
                Buf::Elem,
                ctx.split_zeros_real("corner blocks", ELEM_STRIDE as usize * self.n_corners),
            ),
            (Buf::Blocks, ctx.split_zeros_real("Hessian blocks", 9 * nb)),
            (
                Buf::Factors,
                vec![ctx.zeros_real("block-Jacobi factors", 6 * self.n_free)],
            ),
        ];
        let bytes = new.iter().flat_map(|(_, b)| b).map(|b| b.size() as usize).sum();
        self.bufs.extend(new);
        self.n_blocks = nb;
        ctx.check()?;
        Ok(bytes)
    }

    fn assemble(&mut self, g: Vector) -> Result<()> {
        let (nc, nb, nf) = (self.n_corners, self.n_blocks, self.n_free);
        self.record(
            Kernel::HessianAssemble.with(self.form),
            &[Buf::Model, Buf::Ops, Buf::X, Buf::Corners, Buf::Shapes, Buf::Elem],
            Op::n(nc),
            nc,
        )?;
        self.record(
            Kernel::HessianGather.plain(),
            &[Buf::Ops, Buf::ContribOffsets, Buf::ContribItems, Buf::Elem, Buf::Blocks],
            Op::n(nb),
            nb,
        )?;
        let op = Op {
            aux: ELEM_STRIDE,
            ..Op::n(nf)
        };
        self.record(
            Kernel::GradientGather.plain(),
            &[
                Buf::Ops,
                Buf::Free,
                Buf::IncOffsets,
                Buf::Inc,
                Buf::Elem,
                Buf::Vector(g.0),
            ],
            op,
            nf,
        )?;
        if self.problem.sliding.is_some() {
            self.constrain(g)?;
            self.record(
                Kernel::ConstrainBlocks.plain(),
                &[
                    Buf::Ops,
                    Buf::SlideReal,
                    Buf::SlideIdx,
                    Buf::Free,
                    Buf::RowOffsets,
                    Buf::Cols,
                    Buf::Diag,
                    Buf::Blocks,
                ],
                Op::n(nf),
                nf,
            )?;
        }
        Ok(())
    }

    fn hess_mul(&mut self, x: Vector, y: Vector) -> Result<()> {
        let nf = self.n_free;
        self.record(
            Kernel::BsrSpmv.plain(),
            &[
                Buf::Ops,
                Buf::RowOffsets,
                Buf::Cols,
                Buf::Blocks,
                Buf::Vector(x.0),
                Buf::Vector(y.0),
            ],
            Op::n(nf),
            nf,
        )
    }

    fn factor_precond(&mut self) -> Result<()> {
        let nf = self.n_free;
        self.record(
            Kernel::BlockJacobiFactor.plain(),
            &[Buf::Ops, Buf::Blocks, Buf::Diag, Buf::Factors],
            Op::n(nf),
            nf,
        )
    }

    fn precond(&mut self, x: Vector, y: Vector) -> Result<()> {
        let nf = self.n_free;
        self.record(
            Kernel::BlockJacobi.plain(),
            &[Buf::Ops, Buf::Factors, Buf::Vector(x.0), Buf::Vector(y.0)],
            Op::n(nf),
            nf,
        )
    }

    fn dot(&mut self, a: Vector, b: Vector, sum: Slot, max: Option<Slot>) -> Result<()> {
        let nf = self.n_free;
        let (a, b) = match self.share.as_ref().map(|s| (s.temps, s.ghosts)) {
            // ghost entries zeroed add exact zeros to the sum and the max
            Some(([ta, tb], ghosts)) => {
                self.owned_copy(a, ta, ghosts)?;
                if b == a {
                    (ta, ta)
                } else {
                    self.owned_copy(b, tb, ghosts)?;
                    (ta, tb)
                }
            }
            None => (a, b),
        };
        self.record(
            Kernel::Dot.plain(),
            &[Buf::Ops, Buf::Vector(a.0), Buf::Vector(b.0), Buf::Partials],
            Op::n(nf),
            nf,
        )?;
        self.reduce(Some(sum), None, max, None, groups_of(nf))
    }

    fn axpby(&mut self, a: Coef, x: Vector, b: Coef, y: Vector, guard: Option<Slot>) -> Result<()> {
        let (xb, flags) = if x == y { (Buf::Dummy, 1) } else { (Buf::Vector(x.0), 0) };
        let op = Op {
            guard: Op::slot(guard),
            flags,
            a,
            b,
            ..Op::n(self.n_free)
        };
        self.record(
            Kernel::Axpby.plain(),
            &[Buf::Ops, Buf::Scalars, xb, Buf::Vector(y.0)],
            op,
            self.n_free,
        )
    }

    fn set_slot(&mut self, dst: Slot, value: Coef, guard: Option<Slot>) -> Result<()> {
        let op = Op {
            slot: dst.0,
            guard: Op::slot(guard),
            a: value,
            ..Op::n(1)
        };
        self.record(Kernel::SetSlot.plain(), &[Buf::Ops, Buf::Scalars], op, 1)
    }

    fn flush(&mut self) -> Result<[f64; N_SLOTS]> {
        let ctx = self.ctx;
        let size = N_SLOTS as u64 * ctx.real_size();
        let (scalars, staging) = (self.bufs[&Buf::Scalars][0].clone(), self.staging.clone());
        self.encoder().copy_buffer_to_buffer(&scalars, 0, &staging, 0, size);
        self.submit()?;
        let v = ctx.map_read(&self.staging, N_SLOTS)?;
        let mut out = [0.0; N_SLOTS];
        out.copy_from_slice(&v);
        Ok(out)
    }

    fn read_entries(&mut self, of: Entries, idx: &[u32], out: &mut Vec<f64>) -> Result<()> {
        if idx.is_empty() {
            return Ok(());
        }
        let (points, src) = Self::entries(of);
        let k = self.halo_list(points, idx);
        let n = idx.len();
        self.record(
            Kernel::HaloGather.plain(),
            &[Buf::Ops, Buf::HaloIdx(k), src, Buf::HaloData(k)],
            Op::n(n),
            n,
        )?;
        self.submit()?;
        out.extend(self.ctx.read_real(&self.buf(Buf::HaloData(k))[0], 3 * n)?);
        Ok(())
    }

    fn write_entries(&mut self, of: Entries, idx: &[u32], data: &[f64]) -> Result<()> {
        if data.len() != 3 * idx.len() {
            return Err(Error::InvalidArgument(format!(
                "{} reals for {} entries",
                data.len(),
                idx.len()
            )));
        }
        if idx.is_empty() {
            return Ok(());
        }
        let (points, dst) = Self::entries(of);
        let k = self.halo_list(points, idx);
        // the upload lands after everything recorded (which may read the values buffer)
        self.submit()?;
        self.ctx.write_real(&self.buf(Buf::HaloData(k))[0], data);
        let n = idx.len();
        self.record(
            Kernel::HaloScatter.plain(),
            &[Buf::Ops, Buf::HaloIdx(k), Buf::HaloData(k), dst],
            Op::n(n),
            n,
        )
    }

    fn restrict_sums(&mut self, free: &[u32], corners: &[u32]) -> Result<()> {
        let p = self.problem;
        let (problem_corners, _) = corner_tables(p);
        let stride = CORNER_STRIDE as usize;
        let records: Vec<u32> = corners
            .iter()
            .flat_map(|&c| {
                let rec = &problem_corners[stride * c as usize..stride * (c as usize + 1)];
                rec[..4].iter().map(|&v| self.layout.vertex[v as usize]).chain([rec[4]])
            })
            .collect();
        if !records.is_empty() {
            self.bufs
                .insert(Buf::OwnedCorners, self.ctx.split_u32("owned corners", &records));
        }
        let mut owned = vec![false; self.n_free];
        for &i in free {
            owned[i as usize] = true;
        }
        let ghosts: Vec<u32> = (0..self.n_free as u32).filter(|&i| !owned[i as usize]).collect();
        let ghosts = (!ghosts.is_empty()).then(|| {
            let zeros = self.ctx.zeros_real("ghost zeros", 3 * ghosts.len());
            self.bufs.insert(Buf::GhostZeros, vec![zeros]);
            (self.halo_list(false, &ghosts), ghosts.len())
        });
        let temps = [self.vector()?, self.vector()?];
        self.share = Some(Share {
            corners: corners.len(),
            ghosts,
            temps,
        });
        self.ctx.check()
    }

    fn bytes(&self) -> usize {
        self.problem.bytes()
            + self
                .bufs
                .values()
                .flatten()
                .chain(&self.vectors)
                .chain([&self.staging])
                .map(|b| b.size() as usize)
                .sum::<usize>()
    }
}
