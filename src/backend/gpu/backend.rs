//! `Backend` on a wgpu device. The problem is uploaded once; each operation
//! becomes one dispatch (its `Op` record in a uniform buffer at a dynamic
//! offset, so bind groups are built once per buffer combination and
//! reused), recorded into one command encoder; `flush` submits it and reads
//! the scalar slots back: the only read-back of a CG iteration or of a
//! line-search trial.

use super::buffers::{BindingLimits, check_bindings};
use super::context::{DeviceLayout, GpuContext};
use super::layout::{CORNER_STRIDE, ELEM_STRIDE, ModelUniform, Op, corner_tables};
use super::shader::{Access, Elem, Form, Kernel, MAX_SPLIT, Variant};
use super::sweep_layout::SweepLayout;
use crate::backend::hessian_pattern::HessianPattern;
use crate::backend::settings::{LineSearch, STEP_TOL};
use crate::backend::{Backend, Coef, Entries, EvalSlots, N_SLOTS, Points, Slot, Vector};
use crate::error::{Error, Result};
use crate::metric::mat3::Vec3;
use crate::problem::Problem;
use std::collections::HashMap;
use std::ops::Range;

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
    /// Incidence lists in the problem's corner order (the sweeps').
    Inc,
    /// The same lists in ascending device corner order (the gradient gathers').
    GatherInc,
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

/// What a dispatch binds: each binding of the kernel by its name in the
/// kernel table (the WGSL variable's), in any order (`binds!`).
type Binds<'a> = &'a [(&'static str, Buf)];

/// A [`Binds`] list: `binds![op: Buf::Ops, y: Buf::Vector(v.0)]`; a bare
/// name binds the variable of that name (`binds![x, corners]`).
macro_rules! binds {
    (@one $name:ident) => {
        (stringify!($name), $name)
    };
    (@one $name:ident: $buf:expr) => {
        (stringify!($name), $buf)
    };
    ($($name:ident $(: $buf:expr)?),* $(,)?) => {
        &[$(binds!(@one $name $(: $buf)?)),*]
    };
}

/// The arrays of `binds` in the kernel table's order (checked by name:
/// `KernelDef::in_binding_order`); the backend runs no test-only kernel.
fn in_table_order(v: Variant, binds: Binds) -> Vec<Buf> {
    assert!(
        !v.kernel.is_test_only(),
        "{}: a test-only kernel in the backend",
        v.label()
    );
    v.kernel.def().in_binding_order(binds)
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

/// The GPU [`Backend`]: a problem, its positions and vectors on a device of a [`GpuContext`].
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
    /// Each vector as its parts (`Binding::split`).
    vectors: Vec<Vec<wgpu::Buffer>>,
    staging: wgpu::Buffer,
    /// Bind groups by kernel instance, arrays and first part of each split
    /// binding (`Op::base`).
    groups: HashMap<(Variant, Vec<Buf>, [u32; MAX_SPLIT]), wgpu::BindGroup>,
    encoder: Option<wgpu::CommandEncoder>,
    /// Pending `Op` records, `ctx.op_stride()` apart.
    ops: Vec<u8>,
    n_blocks: usize,
    problem: &'c Problem,
    /// The device numbering of vertices and corners.
    layout: SweepLayout,
    /// Command buffers submitted so far.
    submissions: usize,
    /// Dispatches recorded one window of parts at a time.
    window_dispatches: usize,
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
        let gather_incidence = layout.gather_incidence(&p.incidence);
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
        bufs.insert(
            Buf::GatherInc,
            ctx.split_u32("incidence by device corner", &gather_incidence.items),
        );
        bufs.insert(Buf::CornerGrad, ctx.split_zeros_real("corner gradients", 12 * nc));
        bufs.insert(Buf::X, ctx.split_real("positions", &flat));
        bufs.insert(Buf::Trial, ctx.split_real("trial positions", &flat));
        bufs.insert(Buf::Moves, ctx.split_zeros_real("moves", 3 * nv));
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
            form: Form::on(&model, ctx),
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
            window_dispatches: 0,
            halo_lists: HashMap::new(),
            share: None,
        })
    }

    /// The buffers of array `b` (one unless it is split).
    fn buf(&self, b: Buf) -> &[wgpu::Buffer] {
        match b {
            Buf::Vector(i) => &self.vectors[i as usize],
            other => &self.bufs[&other],
        }
    }

    /// The storage buffers `v` binds with `bufs` in table order, every part
    /// of each split array.
    fn storage_buffers(&self, v: Variant, bufs: &[Buf]) -> usize {
        bufs.iter()
            .zip(v.kernel.def().bindings)
            .filter(|(_, b)| matches!(b.access, Access::Read | Access::ReadWrite))
            .map(|(buf, _)| self.buf(*buf).len())
            .sum()
    }

    fn too_wide(&self, v: Variant, storage: usize) -> Error {
        Error::Gpu(format!(
            "mesh too large for this device: the kernel '{}' would bind {storage} storage \
             buffers (its large arrays split into parts of {:.1} MiB, the largest one \
             binding holds) but the device allows {} per shader stage",
            v.kernel.name(),
            self.ctx.part_bytes() as f64 / 1048576.0,
            self.ctx.limits.max_storage_buffers_per_shader_stage
        ))
    }

    /// `v` with its split bindings spanning the parts of the arrays in
    /// `bufs`; an error with the numbers where the kernel would need more
    /// storage bindings than the device has.
    fn split_variant(&self, mut v: Variant, bufs: &[Buf]) -> Result<Variant> {
        let def = v.kernel.def();
        let mut j = 0;
        for (b, binding) in bufs.iter().zip(def.bindings) {
            let n = self.buf(*b).len();
            if binding.split {
                v.extra[j] = u8::try_from(n - 1).unwrap_or(u8::MAX);
                j += 1;
            } else {
                debug_assert_eq!(n, 1, "{}: '{}' is not split", def.stem, binding.name);
            }
        }
        let storage = self.storage_buffers(v, bufs);
        let max = self.ctx.limits.max_storage_buffers_per_shader_stage as usize;
        if storage > max || v.extra.contains(&u8::MAX) {
            return Err(self.too_wide(v, storage));
        }
        Ok(v)
    }

    /// Records one dispatch of `v` over `threads` with the arrays `binds`
    /// bound by name and `op` as its `Op` record.
    fn record(&mut self, v: Variant, binds: Binds, op: Op, threads: usize) -> Result<()> {
        let bufs = in_table_order(v, binds);
        let v = self.split_variant(v, &bufs)?;
        self.record_parts(v, &bufs, [0; MAX_SPLIT], op, threads)
    }

    /// Records `v` with `binds` over `units` (corners), whose data sit in
    /// the bindings `windowed` (name, elements per unit, in ascending unit
    /// order): one dispatch binding every part of every array where the
    /// device has the storage bindings for it, else one dispatch per window of units, each binding
    /// only the parts of `windowed` that its units touch (and all parts of
    /// the other arrays). `place` gives a window's `Op` and thread count: the
    /// thread-indexed kernels run the window's units, the gathers run all
    /// their threads and add the window's units to what the windows before
    /// stored (the windows ascend, so the sums keep their order and a split
    /// device gives the bits of an unsplit one). Windows start at multiples
    /// of `align` units (a workgroup's, where the kernel reduces per workgroup).
    #[allow(clippy::too_many_arguments)]
    fn record_windowed(
        &mut self,
        v: Variant,
        binds: Binds,
        op: Op,
        units: usize,
        windowed: &[(&str, usize)],
        align: usize,
        place: impl Fn(Op, Range<usize>) -> (Op, usize),
    ) -> Result<()> {
        let bufs = &in_table_order(v, binds)[..];
        if let Ok(full) = self.split_variant(v, bufs) {
            let (op, threads) = place(op, 0..units);
            return self.record_parts(full, bufs, [0; MAX_SPLIT], op, threads);
        }
        let def = v.kernel.def();
        // (binding index, elements per part, elements per unit) of each windowed array
        let arrays: Vec<(usize, u64, u64)> = windowed
            .iter()
            .map(|&(name, per_unit)| {
                let i = def
                    .bindings
                    .iter()
                    .position(|b| b.name == name)
                    .unwrap_or_else(|| panic!("{}: no binding '{name}' to window", def.stem));
                let size = match def.bindings[i].elem {
                    Elem::Real => self.ctx.real_size(),
                    _ => 4,
                };
                debug_assert!(def.bindings[i].split, "{}: a windowed array is split", def.stem);
                (i, self.ctx.part_bytes() / size, per_unit as u64)
            })
            .collect();
        let fixed: usize = bufs
            .iter()
            .zip(def.bindings)
            .enumerate()
            .filter(|(i, (_, b))| {
                matches!(b.access, Access::Read | Access::ReadWrite) && !arrays.iter().any(|a| a.0 == *i)
            })
            .map(|(_, (buf, _))| self.buf(*buf).len())
            .sum();
        let max = self.ctx.limits.max_storage_buffers_per_shader_stage as usize;
        // a binding spans at most 256 parts (`Variant::extra`), windowed or not
        let whole_too_long = bufs
            .iter()
            .zip(def.bindings)
            .enumerate()
            .any(|(i, (buf, b))| b.split && !arrays.iter().any(|a| a.0 == i) && self.buf(*buf).len() > 256);
        if whole_too_long {
            return Err(self.too_wide(v, self.storage_buffers(v, bufs)));
        }
        // the parts [first, last] of each windowed array that units [u0, u1) touch
        let span = |&(_, per_part, per_unit): &(usize, u64, u64), u: &Range<usize>| {
            let first = per_unit * u.start as u64 / per_part;
            let last = (per_unit * u.end as u64 - 1) / per_part;
            (first as usize, (last - first + 1) as usize)
        };
        let fits = |u: &Range<usize>| {
            let spans = arrays.iter().map(|a| span(a, u));
            fixed + spans.clone().map(|s| s.1).sum::<usize>() <= max && spans.clone().all(|s| s.1 <= 256)
        };
        let mut start = 0;
        while start < units {
            let end = |k: usize| (start + k * align).min(units);
            if !fits(&(start..end(1))) {
                return Err(self.too_wide(v, self.storage_buffers(v, bufs)));
            }
            // the longest window that fits, in steps of `align` (fitting
            // shrinks as a window grows)
            let (mut lo, mut hi) = (1, (units - start).div_ceil(align));
            while lo < hi {
                let mid = lo + (hi - lo).div_ceil(2);
                if fits(&(start..end(mid))) {
                    lo = mid
                } else {
                    hi = mid - 1
                }
            }
            let window = start..end(lo);
            let mut w = v;
            w.window = true;
            let mut first = [0u32; MAX_SPLIT];
            for (j, (i, _)) in def.bindings.iter().enumerate().filter(|(_, b)| b.split).enumerate() {
                let (f, count) = match arrays.iter().find(|a| a.0 == i) {
                    Some(a) => span(a, &window),
                    None => (0, self.buf(bufs[i]).len()),
                };
                first[j] = f as u32;
                w.extra[j] = (count - 1) as u8;
            }
            let (op, threads) = place(op, window.clone());
            self.record_parts(w, bufs, first, op, threads)?;
            self.window_dispatches += 1;
            start = window.end;
        }
        Ok(())
    }

    /// Records one dispatch of `v` (its part counts set) with each split
    /// array bound from part `first[j]` on.
    fn record_parts(
        &mut self,
        v: Variant,
        bufs: &[Buf],
        first: [u32; MAX_SPLIT],
        op: Op,
        threads: usize,
    ) -> Result<()> {
        let stride = self.ctx.op_stride() as usize;
        if self.ops.len() / stride >= OPS_PER_BATCH {
            self.submit()?;
        }
        let offset = self.ops.len();
        let op = Op { base: first, ..op };
        self.ops.extend_from_slice(&op.bytes(self.ctx.real));
        self.ops.resize(offset + stride, 0);
        let key = (v, bufs.to_vec(), first);
        if !self.groups.contains_key(&key) {
            let mut j = 0;
            let buffers: Vec<&[wgpu::Buffer]> = bufs
                .iter()
                .zip(v.kernel.def().bindings)
                .map(|(b, binding)| {
                    let all = self.buf(*b);
                    if binding.split {
                        let from = first[j] as usize;
                        let to = from + 1 + v.extra[j] as usize;
                        j += 1;
                        &all[from..to]
                    } else {
                        all
                    }
                })
                .collect();
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

    /// Copies between arrays of the same length (positions), part by part.
    fn copy(&mut self, src: Buf, dst: Buf) {
        let pairs: Vec<(wgpu::Buffer, wgpu::Buffer)> = self.bufs[&src]
            .iter()
            .cloned()
            .zip(self.bufs[&dst].iter().cloned())
            .collect();
        for (src, dst) in pairs {
            let size = src.size().min(dst.size());
            self.encoder().copy_buffer_to_buffer(&src, 0, &dst, 0, size);
        }
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
        self.record(
            Kernel::Reduce.plain(),
            binds![op: Buf::Ops, partials: Buf::Partials, scalars: Buf::Scalars],
            op,
            1,
        )
    }

    fn read_vec3(&mut self, b: Buf, n: usize) -> Result<Vec<Vec3>> {
        self.submit()?;
        let flat = self.ctx.read_split_real(self.buf(b), 3 * n)?;
        Ok(flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }

    /// g <- P g at every free vertex, where the boundary slides, with P the
    /// projector of the constraint active at `x` (kept for `constrain_blocks`).
    fn constrain(&mut self, g: Vector, x: Buf) -> Result<()> {
        if self.problem.sliding.is_none() {
            return Ok(());
        }
        self.record(
            Kernel::Constrain.plain(),
            binds![
                op: Buf::Ops,
                slide_real: Buf::SlideReal,
                slide_idx: Buf::SlideIdx,
                free_vertices: Buf::Free,
                x,
                y: Buf::Vector(g.0),
            ],
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
                binds![op: Buf::Ops, idx: Buf::HaloIdx(k), data: Buf::GhostZeros, dst: Buf::Vector(t.0)],
                Op::n(n),
                n,
            ),
            None => Ok(()),
        }
    }

    /// Records the objective kernel over the `n` corner records of `corners`.
    fn objective(&mut self, x: Buf, corners: Buf, n: usize) -> Result<()> {
        self.record_windowed(
            Kernel::Objective.with(self.form),
            binds![
                model: Buf::Model,
                op: Buf::Ops,
                x,
                corners,
                shapes: Buf::Shapes,
                grad: Buf::CornerGrad,
                partials: Buf::Partials,
            ],
            Op::n(n),
            n,
            &[("corners", CORNER_STRIDE as usize), ("grad", 12)],
            64,
            corner_window,
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

    /// Dispatches recorded one window of parts at a time so far
    /// (`record_windowed`; 0 where every kernel binds all its parts).
    pub fn window_dispatches(&self) -> usize {
        self.window_dispatches
    }

    /// The buffers the positions are split across.
    pub fn position_parts(&self) -> usize {
        self.bufs[&Buf::X].len()
    }

    /// The buffers a free-vertex vector is split across.
    pub fn vector_parts(&self) -> usize {
        (3 * self.n_free as u64 * self.ctx.real_size())
            .div_ceil(self.ctx.part_bytes())
            .max(1) as usize
    }

    /// The most buffers any one array is split across (1: none is split).
    pub fn max_parts(&self) -> usize {
        self.bufs.values().map(Vec::len).max().unwrap_or(1)
    }

    /// g <- the gradient at each free vertex, gathered from the per-corner
    /// data in `corner_data` (`stride` reals per corner, gradient first).
    fn gradient_gather(&mut self, corner_data: Buf, stride: u32, g: Vector) -> Result<()> {
        let (nc, nf) = (self.n_corners, self.n_free);
        let op = Op {
            aux: stride,
            ..Op::n(nf)
        };
        self.record_windowed(
            Kernel::GradientGather.plain(),
            binds![
                op: Buf::Ops,
                free_vertices: Buf::Free,
                inc_offsets: Buf::IncOffsets,
                inc_items: Buf::GatherInc,
                elem: corner_data,
                grad: Buf::Vector(g.0),
            ],
            op,
            nc,
            &[("elem", stride as usize)],
            1,
            |op, corners| (passes(op, corners), nf),
        )
    }

    /// The block-Jacobi factors (after `factor_precond`), as `BlockJacobi::factors`.
    pub fn block_jacobi_factors(&mut self) -> Result<Vec<[f64; 6]>> {
        self.submit()?;
        let flat = self.ctx.read_split_real(self.buf(Buf::Factors), 6 * self.n_free)?;
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

/// A thread-per-corner kernel over the corners `corners` (`Op::offset`, `Op::n`).
fn corner_window(op: Op, corners: Range<usize>) -> (Op, usize) {
    let threads = corners.len();
    let op = Op {
        offset: corners.start as u32,
        n: corners.end as u32,
        ..op
    };
    (op, threads)
}

/// A gather's pass over the corners `corners` (`Op::aux2`, `Op::aux3`).
fn passes(op: Op, corners: Range<usize>) -> Op {
    Op {
        aux2: corners.start as u32,
        aux3: corners.end as u32,
        ..op
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
/// device corner) in ascending device corner order: the order in which
/// `hessian_gather` adds them, in one pass or in windows of corners. (The
/// CPU adds in problem corner order, the same under `DeviceLayout::Problem`.)
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
    for s in 0..nb {
        items[offsets[s] as usize..offsets[s + 1] as usize].sort_unstable();
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
        self.vectors.push(self.ctx.split_zeros_real("vector", 3 * self.n_free));
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
        self.ctx.write_split_real(&self.vectors[v.0 as usize], &flat);
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
            self.gradient_gather(Buf::CornerGrad, 12, g)?;
            self.constrain(g, x)?;
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
            binds![
                op: Buf::Ops,
                scalars: Buf::Scalars,
                free_vertices: Buf::Free,
                x: Buf::X,
                d: Buf::Vector(d.0),
                trial: Buf::Trial,
            ],
            op,
            self.n_free,
        )?;
        if self.problem.sliding.is_some() {
            self.record(
                Kernel::ProjectBoundary.plain(),
                binds![
                    op: Buf::Ops,
                    slide_real: Buf::SlideReal,
                    slide_idx: Buf::SlideIdx,
                    free_vertices: Buf::Free,
                    x: Buf::Trial,
                ],
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
            binds![
                model: Buf::Model,
                op: Buf::Ops,
                x: Buf::X,
                corners: Buf::Corners,
                shapes: Buf::Shapes,
                trial: Buf::Trial,
                partials: Buf::Partials,
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
            binds![
                model: Buf::Model,
                ls: Buf::LineSearch,
                op: Buf::Ops,
                x: Buf::X,
                corners: Buf::Corners,
                shapes: Buf::Shapes,
                inc_offsets: Buf::IncOffsets,
                inc_items: Buf::Inc,
                colors: Buf::Colors,
                moves: Buf::Moves,
                slide_real: Buf::SlideReal,
                slide_idx: Buf::SlideIdx,
            ],
            op,
            count as usize,
        )
    }

    fn max_move(&mut self, out: Slot) -> Result<()> {
        let nv = self.n_vertices;
        self.record(
            Kernel::Dot.plain(),
            binds![op: Buf::Ops, a: Buf::Moves, b: Buf::Moves, partials: Buf::Partials],
            Op::n(nv),
            nv,
        )?;
        self.reduce(None, None, Some(out), None, groups_of(nv))?;
        // "since the last call": the next colours start from no move
        for moves in self.bufs[&Buf::Moves].clone() {
            self.encoder().clear_buffer(&moves, 0, None);
        }
        Ok(())
    }

    fn reference_positions(&mut self, iters: usize) -> Result<Vec<Vec3>> {
        if !self.bufs.contains_key(&Buf::Reference) {
            let parts = self.ctx.split_zeros_real("reference positions", 3 * self.n_vertices);
            self.bufs.insert(Buf::Reference, parts);
        }
        // fixed vertices are their own reference
        self.copy(Buf::X, Buf::Reference);
        if self.n_free > 0 {
            let tol = STEP_TOL;
            let op = Op {
                aux: self.max_backtracks,
                aux2: iters as u32,
                a: Coef::value(tol * tol),
                ..Op::n(self.n_free)
            };
            self.record(
                Kernel::ReferencePosition.with(self.form),
                binds![
                    model: Buf::Model,
                    ls: Buf::LineSearch,
                    op: Buf::Ops,
                    x: Buf::X,
                    corners: Buf::Corners,
                    shapes: Buf::Shapes,
                    inc_offsets: Buf::IncOffsets,
                    inc_items: Buf::Inc,
                    free_vertices: Buf::Free,
                    xr: Buf::Reference,
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
        check_bindings(
            &BindingLimits::of(&ctx.limits),
            &[
                ("Hessian row offsets", 4 * (self.n_free as u64 + 1)),
                ("diagonal blocks", 4 * self.n_free as u64),
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
                ctx.split_zeros_real("block-Jacobi factors", 6 * self.n_free),
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
        let elem = ELEM_STRIDE as usize;
        self.record_windowed(
            Kernel::HessianAssemble.with(self.form),
            binds![
                model: Buf::Model,
                op: Buf::Ops,
                x: Buf::X,
                corners: Buf::Corners,
                shapes: Buf::Shapes,
                elem: Buf::Elem,
            ],
            Op::n(nc),
            nc,
            &[("corners", CORNER_STRIDE as usize), ("elem", elem)],
            1,
            corner_window,
        )?;
        self.record_windowed(
            Kernel::HessianGather.plain(),
            binds![
                op: Buf::Ops,
                contrib_offsets: Buf::ContribOffsets,
                contrib_items: Buf::ContribItems,
                elem: Buf::Elem,
                blocks: Buf::Blocks,
            ],
            Op::n(nb),
            nc,
            &[("elem", elem)],
            1,
            |op, corners| (passes(op, corners), nb),
        )?;
        self.gradient_gather(Buf::Elem, ELEM_STRIDE, g)?;
        if self.problem.sliding.is_some() {
            self.constrain(g, Buf::X)?;
            self.record(
                Kernel::ConstrainBlocks.plain(),
                binds![
                    op: Buf::Ops,
                    slide_real: Buf::SlideReal,
                    slide_idx: Buf::SlideIdx,
                    free_vertices: Buf::Free,
                    row_offsets: Buf::RowOffsets,
                    cols: Buf::Cols,
                    diag: Buf::Diag,
                    blocks: Buf::Blocks,
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
            binds![
                op: Buf::Ops,
                row_offsets: Buf::RowOffsets,
                cols: Buf::Cols,
                blocks: Buf::Blocks,
                x: Buf::Vector(x.0),
                y: Buf::Vector(y.0),
            ],
            Op::n(nf),
            nf,
        )
    }

    fn factor_precond(&mut self) -> Result<()> {
        let nf = self.n_free;
        self.record(
            Kernel::BlockJacobiFactor.plain(),
            binds![op: Buf::Ops, blocks: Buf::Blocks, diag: Buf::Diag, factors: Buf::Factors],
            Op::n(nf),
            nf,
        )
    }

    fn precond(&mut self, x: Vector, y: Vector) -> Result<()> {
        let nf = self.n_free;
        self.record(
            Kernel::BlockJacobi.plain(),
            binds![op: Buf::Ops, factors: Buf::Factors, x: Buf::Vector(x.0), y: Buf::Vector(y.0)],
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
            binds![op: Buf::Ops, a: Buf::Vector(a.0), b: Buf::Vector(b.0), partials: Buf::Partials],
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
            binds![op: Buf::Ops, scalars: Buf::Scalars, x: xb, y: Buf::Vector(y.0)],
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
        self.record(
            Kernel::SetSlot.plain(),
            binds![op: Buf::Ops, scalars: Buf::Scalars],
            op,
            1,
        )
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
            binds![op: Buf::Ops, idx: Buf::HaloIdx(k), src, dst: Buf::HaloData(k)],
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
            binds![op: Buf::Ops, idx: Buf::HaloIdx(k), data: Buf::HaloData(k), dst],
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
                .chain(self.vectors.iter().flatten())
                .chain([&self.staging])
                .map(|b| b.size() as usize)
                .sum::<usize>()
    }
}
