//! The CPU backend: f64, rayon, every operation executed when called. It is
//! the reference every GPU result is checked against; each file here is the
//! CPU twin of the WGSL kernel with the same stem in `shaders/`.

// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod axpby;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod bcd;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod block_jacobi;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod block_jacobi_factor;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod bsr_spmv;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod cbrt_eval;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod constrain;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod constrain_blocks;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod dot;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod gradient_gather;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod halo_gather;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod halo_scatter;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod hessian_assemble;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod hessian_gather;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod inversion;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod laplace;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod line_search;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod mean_ratio_eval;
pub mod objective;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod project_boundary;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod reduce;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod reference_position;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod set_slot;
// Per-kernel CPU twin, public only for the integration tests and benches.
#[doc(hidden)]
pub mod sym_hessian;

use super::{Backend, Coef, Entries, EvalSlots, N_SLOTS, Points, Slot, Vector, Visit, guard_passes};
use crate::backend::settings::{LineSearch, Preconditioner};
use crate::error::{Error, Result};
use crate::metric::mat3::Vec3;
use crate::problem::Problem;
use block_jacobi::BlockJacobi;
use bsr_spmv::BlockCsr;
use rayon::prelude::*;
use std::time::Instant;
use sym_hessian::{SymBlockCsr, SymHessian};

/// The CPU [`Backend`]: f64, multithreaded with rayon, each operation run when called.
pub struct CpuBackend<'p> {
    /// `None` for a bare linear system (`CpuBackend::linear`).
    p: Option<&'p Problem>,
    n_free: usize,
    /// The matrix of a bare linear system.
    system: Option<SymBlockCsr>,
    ls: LineSearch,
    x: Vec<Vec3>,
    trial: Vec<Vec3>,
    vectors: Vec<Vec<Vec3>>,
    slots: [f64; N_SLOTS],
    /// Largest squared move since the last `max_move`.
    moved: f64,
    hessian: Option<SymHessian>,
    precond: Option<BlockJacobi>,
    preconditioner: Preconditioner,
    /// What `evaluate` and `dot` sum over when restricted (`restrict_sums`).
    share: Option<Share>,
}

/// A part's owned share: free-vector indices and corners, ascending.
struct Share {
    free: Vec<u32>,
    corners: Vec<u32>,
}

impl<'p> CpuBackend<'p> {
    /// Positions `x` in the problem's numbering; `ls` drives the per-vertex
    /// line searches of BCD.
    pub fn new(p: &'p Problem, x: &[Vec3], ls: &LineSearch) -> Result<Self> {
        if x.len() != p.num_vertices() {
            return Err(Error::InvalidArgument(format!(
                "{} positions for a problem with {} vertices",
                x.len(),
                p.num_vertices()
            )));
        }
        Ok(CpuBackend {
            p: Some(p),
            n_free: p.free_vertices.len(),
            system: None,
            ls: *ls,
            x: x.to_vec(),
            trial: x.to_vec(),
            vectors: Vec::new(),
            slots: [0.0; N_SLOTS],
            moved: 0.0,
            hessian: None,
            precond: None,
            preconditioner: Preconditioner::Jacobi,
            share: None,
        })
    }

    /// A backend holding only the symmetric system `matrix` (for testing
    /// the linear algebra: PCG, the preconditioner, the vector operations);
    /// the geometric operations fail.
    pub fn linear(matrix: BlockCsr) -> CpuBackend<'static> {
        CpuBackend {
            p: None,
            n_free: matrix.rows(),
            system: Some(SymBlockCsr::from_full(&matrix)),
            ls: LineSearch::default(),
            x: Vec::new(),
            trial: Vec::new(),
            vectors: Vec::new(),
            slots: [0.0; N_SLOTS],
            moved: 0.0,
            hessian: None,
            precond: None,
            preconditioner: Preconditioner::Jacobi,
            share: None,
        }
    }

    fn problem(&self) -> Result<&'p Problem> {
        self.p
            .ok_or_else(|| Error::InvalidArgument("a linear-system backend has no mesh".into()))
    }

    fn matrix(&self) -> Result<&SymBlockCsr> {
        match (&self.hessian, &self.system) {
            (Some(h), _) => Ok(&h.matrix),
            (None, Some(m)) => Ok(m),
            (None, None) => Err(Error::InvalidArgument("no assembled Hessian".into())),
        }
    }

    /// The block-Jacobi factors (after `factor_precond`), for tests.
    pub fn block_jacobi_factors(&self) -> Option<&[[f64; 6]]> {
        self.precond.as_ref().map(|m| m.factors())
    }

    /// The assembled Hessian (after `assemble`), for tests.
    pub fn hessian(&self) -> Option<&SymHessian> {
        self.hessian.as_ref()
    }

    fn points(&self, at: Points) -> &[Vec3] {
        match at {
            Points::Current => &self.x,
            Points::Trial => &self.trial,
        }
    }

    fn pair(&mut self, x: Vector, y: Vector) -> (&[Vec3], &mut [Vec3]) {
        let (xi, yi) = (x.0 as usize, y.0 as usize);
        assert_ne!(xi, yi);
        if xi < yi {
            let (a, b) = self.vectors.split_at_mut(yi);
            (&a[xi], &mut b[0])
        } else {
            let (a, b) = self.vectors.split_at_mut(xi);
            (&b[0], &mut a[yi])
        }
    }

    pub(crate) fn set(&mut self, s: Slot, v: f64) {
        self.slots[s.0 as usize] = v;
    }
}

impl Backend for CpuBackend<'_> {
    fn describe(&self) -> String {
        format!("cpu (f64, {} threads)", rayon::current_num_threads())
    }

    fn num_free(&self) -> usize {
        self.n_free
    }

    fn num_colors(&self) -> usize {
        self.p.map_or(0, |p| p.colors.len())
    }

    fn vector(&mut self) -> Result<Vector> {
        self.vectors.push(vec![[0.0; 3]; self.num_free()]);
        Ok(Vector(self.vectors.len() as u32 - 1))
    }

    fn read_vector(&mut self, v: Vector) -> Result<Vec<Vec3>> {
        Ok(self.vectors[v.0 as usize].clone())
    }

    fn write_vector(&mut self, v: Vector, data: &[Vec3]) -> Result<()> {
        let dst = &mut self.vectors[v.0 as usize];
        if data.len() != dst.len() {
            return Err(Error::InvalidArgument(format!(
                "a vector of {} blocks for {} free vertices",
                data.len(),
                dst.len()
            )));
        }
        dst.copy_from_slice(data);
        Ok(())
    }

    fn download(&mut self) -> Result<Vec<Vec3>> {
        Ok(self.x.clone())
    }

    fn evaluate(&mut self, at: Points, out: EvalSlots, gradient: Option<Vector>) -> Result<()> {
        let (p, x) = (self.problem()?, self.points(at));
        let min_det = out.min_det.map(|_| objective::min_det(p, x));
        let (f, bad, g) = match &self.share {
            // a part sums its owned corners only; its gradient is written
            // where the part is feasible (elsewhere the whole is not either)
            Some(share) => {
                let (f, bad) = objective::partial_value(p, x, &share.corners);
                (
                    f,
                    bad,
                    gradient.and_then(|_| objective::free_gradient(p, x)).map(|(_, g)| g),
                )
            }
            None => {
                let value = match gradient {
                    Some(_) => objective::free_gradient(p, x),
                    None => objective::value(p, x).map(|f| (f, Vec::new())),
                };
                match value {
                    Some((f, g)) => (f, 0.0, gradient.map(|_| g)),
                    None => (f64::NAN, objective::infeasible_corners(p, x) as f64, None),
                }
            }
        };
        if let (Some(v), Some(mut g)) = (gradient, g) {
            if let Some(s) = &p.sliding {
                let active = project_boundary::active_projectors(s, &p.free_vertices, x, &g);
                constrain::constrain(&active, &p.free_vertices, &mut g);
            }
            self.vectors[v.0 as usize] = g;
        }
        self.set(out.value, f);
        self.set(out.infeasible, bad);
        if let (Some(s), Some(d)) = (out.min_det, min_det) {
            self.set(s, d);
        }
        Ok(())
    }

    fn inversion_fraction(&mut self, out: Slot) -> Result<()> {
        let t = inversion::first_inversion(self.problem()?, &self.x, &self.trial);
        self.set(out, t);
        Ok(())
    }

    fn trial(&mut self, alpha: Coef, d: Vector) -> Result<()> {
        let a = alpha.eval(&self.slots);
        line_search::trial(
            &self.x,
            &self.problem()?.free_vertices,
            a,
            &self.vectors[d.0 as usize],
            &mut self.trial,
        );
        if let Some(s) = &self.problem()?.sliding {
            project_boundary::project(s, &self.problem()?.free_vertices, &mut self.trial);
        }
        Ok(())
    }

    fn accept_trial(&mut self) -> Result<()> {
        self.x.copy_from_slice(&self.trial);
        Ok(())
    }

    fn bcd_color(&mut self, color: usize) -> Result<()> {
        let m = bcd::sweep_color(self.problem()?, &mut self.x, color, &self.ls);
        self.moved = self.moved.max(m);
        Ok(())
    }

    fn max_move(&mut self, out: Slot) -> Result<()> {
        let m = std::mem::take(&mut self.moved);
        self.set(out, m);
        Ok(())
    }

    fn has_sequential_sweep(&self) -> bool {
        self.p.is_some()
    }

    fn bcd_sequential(&mut self, visit: &Visit, out: Slot, deadline: Option<Instant>) -> Result<bool> {
        let p = self.problem()?;
        if let Some(order) = visit.order
            && order.iter().any(|&i| i as usize >= self.n_free)
        {
            return Err(Error::InvalidArgument(
                "a sweep order entry is not a free vertex".into(),
            ));
        }
        let moves = visit.moves.map(|v| &mut self.vectors[v.0 as usize]);
        let m = bcd::sweep(p, &mut self.x, &self.ls, visit, moves, deadline);
        self.set(out, m);
        Ok(true)
    }

    fn laplace(&mut self, out: Slot, deadline: Option<Instant>) -> Result<bool> {
        let m = laplace::sweep(self.problem()?, &mut self.x, deadline);
        self.set(out, m);
        Ok(true)
    }

    fn reference_positions(&mut self, iters: usize) -> Result<Vec<Vec3>> {
        Ok(reference_position::reference_positions(
            self.problem()?,
            &self.x,
            &self.ls,
            iters,
        ))
    }

    fn prepare_hessian(&mut self) -> Result<usize> {
        let pattern = SymHessian::new(self.problem()?);
        let bytes = pattern.bytes() + 48 * pattern.matrix.rows();
        self.hessian = Some(pattern);
        Ok(bytes)
    }

    fn assemble(&mut self, g: Vector) -> Result<()> {
        let p = self.problem()?;
        let h = self
            .hessian
            .as_mut()
            .ok_or_else(|| Error::InvalidArgument("assemble before prepare_hessian".into()))?;
        let grad = &mut self.vectors[g.0 as usize];
        if !h.assemble(p, &self.x, grad) {
            return Err(crate::error::accepted_step_inverted());
        }
        if let Some(s) = &p.sliding {
            let active = project_boundary::active_projectors(s, &p.free_vertices, &self.x, grad);
            constrain::constrain(&active, &p.free_vertices, grad);
            h.matrix.constrain(&active, &p.free_vertices);
        }
        Ok(())
    }

    fn hess_mul(&mut self, x: Vector, y: Vector) -> Result<()> {
        // the matrix is taken out for the call, so that the vectors can be borrowed
        let (h, m) = (self.hessian.take(), self.system.take());
        let result = match h.as_ref().map(|h| &h.matrix).or(m.as_ref()) {
            Some(a) => {
                let (xs, ys) = self.pair(x, y);
                a.mul(xs, ys);
                Ok(())
            }
            None => Err(Error::InvalidArgument("hess_mul before assemble".into())),
        };
        (self.hessian, self.system) = (h, m);
        result
    }

    fn set_preconditioner(&mut self, kind: Preconditioner) -> Result<()> {
        self.preconditioner = match kind {
            Preconditioner::Auto if self.p.is_some_and(|p| p.dim == 2) => Preconditioner::Sgs,
            Preconditioner::Auto => Preconditioner::Jacobi,
            k => k,
        };
        Ok(())
    }

    fn factor_precond(&mut self) -> Result<()> {
        let m = self.matrix()?;
        self.precond = Some(BlockJacobi::new(m.diag.par_iter().copied()));
        Ok(())
    }

    fn precond(&mut self, x: Vector, y: Vector) -> Result<()> {
        let m = self
            .precond
            .take()
            .ok_or_else(|| Error::InvalidArgument("precond before factor_precond".into()))?;
        let kind = self.preconditioner;
        let (h, sys) = (self.hessian.take(), self.system.take());
        let (xs, ys) = self.pair(x, y);
        let result = match (kind, h.as_ref().map(|h| &h.matrix).or(sys.as_ref())) {
            (Preconditioner::Jacobi | Preconditioner::Auto, _) => {
                m.apply(xs, ys);
                Ok(())
            }
            (Preconditioner::Sgs, Some(a)) => {
                a.sgs(&m, xs, ys);
                Ok(())
            }
            (Preconditioner::Sgs, None) => Err(Error::InvalidArgument("precond before assemble".into())),
        };
        (self.hessian, self.system) = (h, sys);
        self.precond = Some(m);
        result
    }

    fn dot(&mut self, a: Vector, b: Vector, sum: Slot, max: Option<Slot>) -> Result<()> {
        let (va, vb) = (&self.vectors[a.0 as usize], &self.vectors[b.0 as usize]);
        let (s, m) = match &self.share {
            Some(share) => dot::dot_over(va, vb, &share.free),
            None => dot::dot(va, vb, max.is_some()),
        };
        self.set(sum, s);
        if let Some(slot) = max {
            self.set(slot, m);
        }
        Ok(())
    }

    fn axpby(&mut self, a: Coef, x: Vector, b: Coef, y: Vector, guard: Option<Slot>) -> Result<()> {
        if !guard_passes(&self.slots, guard) {
            return Ok(());
        }
        let (a, b) = (a.eval(&self.slots), b.eval(&self.slots));
        if x == y {
            axpby::scale(a, b, &mut self.vectors[y.0 as usize]);
        } else {
            let (xs, ys) = self.pair(x, y);
            axpby::axpby(a, xs, b, ys);
        }
        Ok(())
    }

    fn set_slot(&mut self, dst: Slot, value: Coef, guard: Option<Slot>) -> Result<()> {
        set_slot::set_slot(&mut self.slots, dst, value, guard);
        Ok(())
    }

    fn flush(&mut self) -> Result<[f64; N_SLOTS]> {
        Ok(self.slots)
    }

    // in place: no copy beyond the exchange's own buffers
    fn read_entries(&mut self, of: Entries, idx: &[u32], out: &mut Vec<f64>) -> Result<()> {
        let free = &self.problem()?.free_vertices;
        match of {
            Entries::Points(at) => halo_gather::gather(self.points(at), idx, |i| free[i as usize] as usize, out),
            Entries::Vector(v) => halo_gather::gather(&self.vectors[v.0 as usize], idx, |i| i as usize, out),
        }
        Ok(())
    }

    fn write_entries(&mut self, of: Entries, idx: &[u32], data: &[f64]) -> Result<()> {
        let free = &self.problem()?.free_vertices;
        if data.len() != 3 * idx.len() {
            return Err(Error::InvalidArgument(format!(
                "{} reals for {} entries",
                data.len(),
                idx.len()
            )));
        }
        match of {
            Entries::Points(Points::Current) => {
                halo_scatter::scatter(&mut self.x, idx, |i| free[i as usize] as usize, data)
            }
            Entries::Points(Points::Trial) => {
                halo_scatter::scatter(&mut self.trial, idx, |i| free[i as usize] as usize, data)
            }
            Entries::Vector(v) => halo_scatter::scatter(&mut self.vectors[v.0 as usize], idx, |i| i as usize, data),
        }
        Ok(())
    }

    fn restrict_sums(&mut self, free: &[u32], corners: &[u32]) -> Result<()> {
        self.share = Some(Share {
            free: free.to_vec(),
            corners: corners.to_vec(),
        });
        Ok(())
    }

    fn bytes(&self) -> usize {
        let n = self.x.len();
        self.p.map_or(0, |p| p.bytes())
            + 24 * (n + self.trial.capacity())
            + self.vectors.iter().map(|v| 24 * v.len()).sum::<usize>()
            + self.hessian.as_ref().map_or(0, |h| h.bytes())
            + self.precond.as_ref().map_or(0, |m| m.bytes())
    }
}
