//! The backend contract: the only door between the solvers and a device.
//!
//! Every solver (`solve::bcd`, `solve::newton` with `solve::pcg`) is written
//! once over [`Backend`]; the CPU backend (`cpu`, f64, rayon) is the reference
//! and the wgpu backend (`gpu`, WGSL, f32 or f64) the fast one. Tests run one
//! solver on both from one start and compare the iterates.
//!
//! ```text
//!   solver ──ops──▶ Backend ──▶ CPU: executes each call at once (Vec<Vec3>, f64)
//!      ▲                    └─▶ GPU: records each call into a command buffer
//!      └──── flush() ◀── scalar slots (one read-back per flush)
//! ```
//!
//! - **Data lives on the backend.** Two position sets (`Points::Current`, the
//!   state; `Points::Trial`, a line-search candidate) over all vertices, and
//!   vectors over the free vertices (3 reals each) that the solver allocates
//!   with [`Backend::vector`] and names by [`Vector`] handles.
//! - **Reductions write scalar slots.** `dot`, `evaluate` and `max_move` write
//!   into [`Slot`]s that stay on the backend; coefficients of the vector
//!   updates ([`Coef`]) may be ratios of slots, and an update may be guarded by
//!   a slot (skipped unless that slot is > 0), so a whole CG iteration runs
//!   without the host seeing a number. [`Backend::flush`] runs what was
//!   recorded and returns every slot: once per CG iteration, once per
//!   line-search trial. On the CPU the same calls run immediately and `flush`
//!   just copies the slots.
//! - **Solvers own their slots**: each solver module names the slot indices it
//!   uses (below [`N_SLOTS`]); the backend gives them no meaning.
//! - **Problem data is uploaded once**, at construction; the Newton extras
//!   (Hessian pattern, block-Jacobi factors) by [`Backend::prepare_hessian`], whose
//!   time the solver reports as setup.
//!
//! The distributed backend (`distributed`, feature `mpi`) wraps a CPU or a
//! GPU backend on each rank's part, through this contract only: the inner
//! backend sums only what the part owns ([`Backend::restrict_sums`]) and
//! hands halo entries in and out ([`Backend::read_entries`],
//! [`Backend::write_entries`]); every reduction is then combined over the
//! ranks in rank order, with halo exchanges after each colour, each trial
//! point and before each product.

pub mod cpu;
#[cfg(feature = "mpi")]
pub mod distributed;
#[cfg(feature = "gpu")]
pub mod gpu;
// Public only for the integration tests and benches: an internal of the Newton backends.
#[doc(hidden)]
pub mod hessian_pattern;
pub mod settings;

use crate::error::Result;
use crate::metric::mat3::Vec3;
pub use settings::{LineSearch, Preconditioner};
use std::time::Instant;

/// Scalar slots per backend.
pub const N_SLOTS: usize = 32;

/// A scalar slot on the backend.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Slot(pub u32);

/// A vector over the free vertices (3 reals each), allocated by `Backend::vector`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Vector(pub u32);

/// Which position set an operation reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Points {
    /// The solver's state.
    Current,
    /// A line-search candidate (`Backend::trial`).
    Trial,
}

/// A coefficient evaluated on the backend: `scale * slots[num] / slots[den]`,
/// a missing slot counting as 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coef {
    /// The constant factor.
    pub scale: f64,
    /// The slot in the numerator; `None` counts as 1.
    pub num: Option<Slot>,
    /// The slot in the denominator; `None` counts as 1.
    pub den: Option<Slot>,
}

impl Coef {
    /// The constant `v`.
    pub const fn value(v: f64) -> Coef {
        Coef {
            scale: v,
            num: None,
            den: None,
        }
    }

    /// The value of slot `s`.
    pub const fn slot(s: Slot) -> Coef {
        Coef {
            scale: 1.0,
            num: Some(s),
            den: None,
        }
    }

    /// `sign * num / den`
    pub const fn ratio(sign: f64, num: Slot, den: Slot) -> Coef {
        Coef {
            scale: sign,
            num: Some(num),
            den: Some(den),
        }
    }

    /// The value from slot values, as every backend computes it.
    pub fn eval(&self, slots: &[f64]) -> f64 {
        let n = self.num.map_or(1.0, |s| slots[s.0 as usize]);
        let d = self.den.map_or(1.0, |s| slots[s.0 as usize]);
        self.scale * n / d
    }
}

/// Where `evaluate` writes: F (the sum of the weighted corner terms, those of
/// infeasible corners counted as 0), the number of infeasible corners and the
/// smallest corner determinant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EvalSlots {
    /// Where F goes.
    pub value: Slot,
    /// Where the number of infeasible corners goes.
    pub infeasible: Slot,
    /// Where the smallest corner determinant goes, if wanted.
    pub min_det: Option<Slot>,
}

/// What a halo exchange reads or overwrites: a position set or a vector,
/// at free-vector indices (only free vertices ever change).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Entries {
    /// A position set.
    Points(Points),
    /// A vector over the free vertices.
    Vector(Vector),
}

/// How a sequential sweep visits the free vertices.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Visit<'a> {
    /// Free-vertex indices (into `Problem::free_vertices`) in visiting
    /// order; `None`: all, ascending.
    pub order: Option<&'a [u32]>,
    /// Safeguarded Newton steps per visit (0 counts as 1).
    pub inner_iterations: usize,
    /// Where to write each visited vertex's displacement over its visit
    /// (for the movement-based reorderings); vertices not visited keep theirs.
    pub moves: Option<Vector>,
}

/// Per element: `value` (-1 when infeasible), 12 gradient and 144 Hessian
/// entries; what `gpu::mean_ratio_eval` and its CPU twin
/// `cpu::mean_ratio_eval` return.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ElementEval {
    /// Per element: the inverse mean ratio, -1 when infeasible.
    pub value: Vec<f64>,
    /// Per element: 12 gradient entries.
    pub grad: Vec<f64>,
    /// Per element: 144 Hessian entries.
    pub hess: Vec<f64>,
}

/// True when a guard slot lets an update run: NaN-safe, so a NaN guard skips.
#[inline]
pub fn guard_passes(slots: &[f64], guard: Option<Slot>) -> bool {
    guard.is_none_or(|g| slots[g.0 as usize] > 0.0)
}

/// The operations the solvers need. See the module documentation for the
/// model; every method records (GPU) or runs (CPU) one operation.
pub trait Backend {
    /// Where it runs, for reports: "cpu (f64, N threads)", "gpu ADAPTER (f32|f64)".
    fn describe(&self) -> String;
    /// Free vertices: the length of every `Vector`.
    fn num_free(&self) -> usize;
    /// Colour classes of the coloured sweep.
    fn num_colors(&self) -> usize;

    /// A new zeroed vector.
    fn vector(&mut self) -> Result<Vector>;
    /// Reads a vector back (flushes first); for tests and checkpoints.
    fn read_vector(&mut self, v: Vector) -> Result<Vec<Vec3>>;
    /// Overwrites a vector (ordered after everything recorded so far).
    fn write_vector(&mut self, v: Vector, data: &[Vec3]) -> Result<()>;
    /// The current positions, in the problem's numbering (flushes first).
    fn download(&mut self) -> Result<Vec<Vec3>>;

    /// F, its infeasibility and optionally the free gradient at `at`.
    fn evaluate(&mut self, at: Points, out: EvalSlots, gradient: Option<Vector>) -> Result<()>;
    /// Trial = Current + alpha d at the free vertices.
    fn trial(&mut self, alpha: Coef, d: Vector) -> Result<()>;
    /// Current = Trial.
    fn accept_trial(&mut self) -> Result<()>;
    /// slots[out] = the fraction of the way from Current to Trial at which a
    /// corner first inverts: the smallest root on (0, 1] of the corners'
    /// determinant polynomials, +inf if none inverts (the GPU: its largest
    /// real). A backend without it writes NaN, and the line search then
    /// halves its steps blindly.
    fn inversion_fraction(&mut self, out: Slot) -> Result<()> {
        self.set_slot(out, Coef::value(f64::NAN), None)
    }

    /// One colour of a BCD sweep at the current positions: a safeguarded
    /// Newton step per vertex of the colour (they share no element).
    fn bcd_color(&mut self, color: usize) -> Result<()>;
    /// The largest squared vertex move of the colours swept since the last call.
    fn max_move(&mut self, out: Slot) -> Result<()>;
    /// Whether `bcd_sequential` runs (the CPU) or declines (the GPU): a sweep
    /// order is only worth computing where there is a sequential sweep.
    fn has_sequential_sweep(&self) -> bool {
        false
    }
    /// A sweep over the free vertices one at a time, as `visit` says, if the
    /// backend has one (`Ok(false)` otherwise: only the CPU has, the GPU runs
    /// colours). Stops early, in a valid state, at `deadline`; the largest
    /// squared move goes to `out`.
    fn bcd_sequential(&mut self, _visit: &Visit, _out: Slot, _deadline: Option<Instant>) -> Result<bool> {
        Ok(false)
    }

    /// A smart-Laplace sweep, if the backend has one (`Ok(false)` otherwise:
    /// only the CPU has, the baseline is sequential by nature).
    fn laplace(&mut self, _out: Slot, _deadline: Option<Instant>) -> Result<bool> {
        Ok(false)
    }

    /// Step 1 of reference-Jacobian rezoning: every free vertex's position
    /// minimising the objective of its corners with all other vertices at
    /// the current positions, by up to `iters` safeguarded Newton steps (the
    /// BCD step); nothing moves. Fixed vertices are their own reference.
    /// Returns positions for every vertex (a read-back).
    fn reference_positions(&mut self, iters: usize) -> Result<Vec<Vec3>>;

    /// Builds the Hessian's block pattern and the preconditioner's storage;
    /// returns the bytes they hold. Called once, before `assemble`.
    fn prepare_hessian(&mut self) -> Result<usize>;
    /// Free gradient into `g` and the Hessian of F at the current positions
    /// (which are feasible: they were accepted).
    fn assemble(&mut self, g: Vector) -> Result<()>;
    /// y = H x
    fn hess_mul(&mut self, x: Vector, y: Vector) -> Result<()>;
    /// Chooses Newton's preconditioner (before `factor_precond`); block
    /// Jacobi, the paper's, is the default and the only one every backend has.
    fn set_preconditioner(&mut self, kind: Preconditioner) -> Result<()> {
        match kind {
            // auto: block Jacobi unless a backend says otherwise
            Preconditioner::Jacobi | Preconditioner::Auto => Ok(()),
            other => Err(crate::error::Error::InvalidArgument(format!(
                "preconditioner '{other}' has no version on {} (use jacobi)",
                self.describe()
            ))),
        }
    }
    /// Factors the diagonal blocks of the assembled Hessian.
    fn factor_precond(&mut self) -> Result<()>;
    /// y = M^-1 x (block Jacobi, or what `set_preconditioner` chose).
    fn precond(&mut self, x: Vector, y: Vector) -> Result<()>;

    /// slots[sum] = a . b; slots[max] = max_i |b_i|^2.
    fn dot(&mut self, a: Vector, b: Vector, sum: Slot, max: Option<Slot>) -> Result<()>;
    /// y = a x + b y, skipped unless `guard` passes. `b` = 0 overwrites y
    /// without reading it; `x == y` is allowed.
    fn axpby(&mut self, a: Coef, x: Vector, b: Coef, y: Vector, guard: Option<Slot>) -> Result<()>;
    /// slots[dst] = value, skipped unless `guard` passes.
    fn set_slot(&mut self, dst: Slot, value: Coef, guard: Option<Slot>) -> Result<()>;

    /// Runs what was recorded and returns every slot.
    fn flush(&mut self) -> Result<[f64; N_SLOTS]>;
    /// Bytes the backend holds for the problem and the solver's data.
    fn bytes(&self) -> usize;

    /// Appends the entries `idx` (free-vector indices) of `of` to `out`, 3
    /// reals each, in `idx` order, after running what was recorded: the
    /// send side of a halo exchange (on a GPU one gather and one read-back).
    fn read_entries(&mut self, _of: Entries, _idx: &[u32], _out: &mut Vec<f64>) -> Result<()> {
        Err(crate::error::Error::Unsupported(format!(
            "halo exchanges on {}",
            self.describe()
        )))
    }
    /// Overwrites the entries `idx` of `of` with `data` (3 reals each),
    /// ordered after everything recorded so far: the receive side.
    fn write_entries(&mut self, _of: Entries, _idx: &[u32], _data: &[f64]) -> Result<()> {
        Err(crate::error::Error::Unsupported(format!(
            "halo exchanges on {}",
            self.describe()
        )))
    }
    /// From now on `evaluate` sums F and counts infeasible corners over
    /// `corners` only, and `dot` sums and maximises over the free entries
    /// `free` only (both ascending): a part's owned share, so that over all
    /// parts each corner and each free vertex of the whole counts once. The
    /// gradient and everything else still cover the whole part; `min_det`
    /// may cover either (the minimum over the parts is the whole's both ways).
    fn restrict_sums(&mut self, _free: &[u32], _corners: &[u32]) -> Result<()> {
        Err(crate::error::Error::Unsupported(format!(
            "partial sums on {}",
            self.describe()
        )))
    }

    /// Has `deadline` passed? Stopping is a decision every process of a
    /// solve must take at the same point: a distributed backend answers with
    /// rank 0's clock on every rank.
    fn past(&mut self, deadline: Instant) -> bool {
        Instant::now() >= deadline
    }

    // conveniences over `axpby`

    /// y = x
    fn copy(&mut self, x: Vector, y: Vector) -> Result<()> {
        self.axpby(Coef::value(1.0), x, Coef::value(0.0), y, None)
    }
    /// y += a x
    fn axpy(&mut self, a: Coef, x: Vector, y: Vector) -> Result<()> {
        self.axpby(a, x, Coef::value(1.0), y, None)
    }
    /// y *= a
    fn scale(&mut self, a: Coef, y: Vector) -> Result<()> {
        self.axpby(a, y, Coef::value(0.0), y, None)
    }
    /// slots[out] = |a|^2
    fn norm_sq(&mut self, a: Vector, out: Slot) -> Result<()> {
        self.dot(a, a, out, None)
    }
}

/// A boxed backend is a backend (`solve::Device::backend` hands them out):
/// every method, the provided ones too, goes to the boxed one.
impl<B: Backend + ?Sized> Backend for Box<B> {
    fn describe(&self) -> String {
        (**self).describe()
    }
    fn num_free(&self) -> usize {
        (**self).num_free()
    }
    fn num_colors(&self) -> usize {
        (**self).num_colors()
    }
    fn vector(&mut self) -> Result<Vector> {
        (**self).vector()
    }
    fn read_vector(&mut self, v: Vector) -> Result<Vec<Vec3>> {
        (**self).read_vector(v)
    }
    fn write_vector(&mut self, v: Vector, data: &[Vec3]) -> Result<()> {
        (**self).write_vector(v, data)
    }
    fn download(&mut self) -> Result<Vec<Vec3>> {
        (**self).download()
    }
    fn evaluate(&mut self, at: Points, out: EvalSlots, gradient: Option<Vector>) -> Result<()> {
        (**self).evaluate(at, out, gradient)
    }
    fn trial(&mut self, alpha: Coef, d: Vector) -> Result<()> {
        (**self).trial(alpha, d)
    }
    fn accept_trial(&mut self) -> Result<()> {
        (**self).accept_trial()
    }
    fn inversion_fraction(&mut self, out: Slot) -> Result<()> {
        (**self).inversion_fraction(out)
    }
    fn bcd_color(&mut self, color: usize) -> Result<()> {
        (**self).bcd_color(color)
    }
    fn max_move(&mut self, out: Slot) -> Result<()> {
        (**self).max_move(out)
    }
    fn has_sequential_sweep(&self) -> bool {
        (**self).has_sequential_sweep()
    }
    fn bcd_sequential(&mut self, visit: &Visit, out: Slot, deadline: Option<Instant>) -> Result<bool> {
        (**self).bcd_sequential(visit, out, deadline)
    }
    fn laplace(&mut self, out: Slot, deadline: Option<Instant>) -> Result<bool> {
        (**self).laplace(out, deadline)
    }
    fn reference_positions(&mut self, iters: usize) -> Result<Vec<Vec3>> {
        (**self).reference_positions(iters)
    }
    fn prepare_hessian(&mut self) -> Result<usize> {
        (**self).prepare_hessian()
    }
    fn assemble(&mut self, g: Vector) -> Result<()> {
        (**self).assemble(g)
    }
    fn hess_mul(&mut self, x: Vector, y: Vector) -> Result<()> {
        (**self).hess_mul(x, y)
    }
    fn set_preconditioner(&mut self, kind: Preconditioner) -> Result<()> {
        (**self).set_preconditioner(kind)
    }
    fn factor_precond(&mut self) -> Result<()> {
        (**self).factor_precond()
    }
    fn precond(&mut self, x: Vector, y: Vector) -> Result<()> {
        (**self).precond(x, y)
    }
    fn dot(&mut self, a: Vector, b: Vector, sum: Slot, max: Option<Slot>) -> Result<()> {
        (**self).dot(a, b, sum, max)
    }
    fn axpby(&mut self, a: Coef, x: Vector, b: Coef, y: Vector, guard: Option<Slot>) -> Result<()> {
        (**self).axpby(a, x, b, y, guard)
    }
    fn set_slot(&mut self, dst: Slot, value: Coef, guard: Option<Slot>) -> Result<()> {
        (**self).set_slot(dst, value, guard)
    }
    fn flush(&mut self) -> Result<[f64; N_SLOTS]> {
        (**self).flush()
    }
    fn bytes(&self) -> usize {
        (**self).bytes()
    }
    fn read_entries(&mut self, of: Entries, idx: &[u32], out: &mut Vec<f64>) -> Result<()> {
        (**self).read_entries(of, idx, out)
    }
    fn write_entries(&mut self, of: Entries, idx: &[u32], data: &[f64]) -> Result<()> {
        (**self).write_entries(of, idx, data)
    }
    fn restrict_sums(&mut self, free: &[u32], corners: &[u32]) -> Result<()> {
        (**self).restrict_sums(free, corners)
    }
    fn past(&mut self, deadline: Instant) -> bool {
        (**self).past(deadline)
    }
    fn copy(&mut self, x: Vector, y: Vector) -> Result<()> {
        (**self).copy(x, y)
    }
    fn axpy(&mut self, a: Coef, x: Vector, y: Vector) -> Result<()> {
        (**self).axpy(a, x, y)
    }
    fn scale(&mut self, a: Coef, y: Vector) -> Result<()> {
        (**self).scale(a, y)
    }
    fn norm_sq(&mut self, a: Vector, out: Slot) -> Result<()> {
        (**self).norm_sq(a, out)
    }
}
