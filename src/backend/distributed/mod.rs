//! The distributed backend: one rank's part of a partitioned problem
//! (`partition::Part`) on a CPU backend, with the reductions and halo
//! exchanges that make the solvers — unchanged — solve the whole problem.
//!
//! - **Vectors** cover the part's free vertices, owned and ghost. Owned
//!   entries are exact; ghost entries may hold anything (partial Hessian
//!   rows, a preconditioner built from a partial block) until a halo exchange
//!   overwrites them, which happens before every use that reads them: before
//!   each product `hess_mul`, and for positions after each trial point and
//!   after each colour of a sweep (that colour's ghosts only).
//! - **Reductions** (`dot`, `evaluate`, `max_move`) sum only what the part
//!   owns (owned free entries; corners of owned elements, so each corner is
//!   counted once) and combine the ranks' partial values in rank order
//!   (`comm`). Every rank then holds the same slots, so every guard,
//!   coefficient and stopping test takes the same branch on every rank.
//! - **Per-vertex work** (a BCD step, a gradient entry, a Hessian row) on an
//!   owned vertex sees the same corners in the same order as one process
//!   does, so it gives the same bits: coloured BCD follows the single-process
//!   iterates exactly, and only the reductions' summation order differs.

pub mod comm;

use super::cpu::reduce::CHUNK;
use super::cpu::{CpuBackend, objective};
use super::{Backend, Coef, EvalSlots, N_SLOTS, Points, Slot, Vector};
use crate::error::Result;
use crate::metric::mat3::Vec3;
use crate::partition::{Exchange, Part};
use crate::solve::line_search::LineSearch;
use comm::{Comm, CommStats};
use mpi::topology::SimpleCommunicator;
use rayon::prelude::*;

pub struct DistributedBackend<'p> {
    part: &'p Part,
    inner: CpuBackend<'p>,
    comm: Comm<'p>,
    /// Per colour, the halo of that colour's vertices: a colour of a sweep
    /// moves only them, so only they are sent.
    colour_halos: Vec<Vec<Exchange>>,
}

impl<'p> DistributedBackend<'p> {
    pub fn new(part: &'p Part, world: &'p SimpleCommunicator, ls: &LineSearch) -> Result<Self> {
        Ok(DistributedBackend {
            part,
            inner: CpuBackend::new(&part.problem, &part.x, ls)?,
            comm: Comm::new(world),
            colour_halos: (0..part.problem.colors.len() as u32)
                .map(|c| part.colour_halo(c))
                .collect(),
        })
    }

    pub fn comm_stats(&self) -> CommStats {
        self.comm.stats
    }

    fn exchange_points(&mut self, at: Points) {
        let free = &self.part.problem.free_vertices;
        self.comm.exchange(&self.part.halo, self.inner.points_mut(at), |i| {
            free[i as usize] as usize
        });
    }

    fn exchange_vector(&mut self, v: Vector) {
        self.comm
            .exchange(&self.part.halo, self.inner.vector_mut(v), |i| i as usize);
    }
}

impl Backend for DistributedBackend<'_> {
    fn describe(&self) -> String {
        format!("mpi ({} ranks) x {}", self.comm.size(), self.inner.describe())
    }

    fn num_free(&self) -> usize {
        self.inner.num_free()
    }

    fn num_colors(&self) -> usize {
        self.inner.num_colors()
    }

    fn vector(&mut self) -> Result<Vector> {
        self.inner.vector()
    }

    /// This rank's entries only (owned and ghost free vertices).
    fn read_vector(&mut self, v: Vector) -> Result<Vec<Vec3>> {
        self.inner.read_vector(v)
    }

    fn write_vector(&mut self, v: Vector, data: &[Vec3]) -> Result<()> {
        self.inner.write_vector(v, data)
    }

    /// This rank's positions (part numbering); ghosts are up to date.
    fn download(&mut self) -> Result<Vec<Vec3>> {
        self.inner.download()
    }

    fn evaluate(&mut self, at: Points, out: EvalSlots, gradient: Option<Vector>) -> Result<()> {
        let p = &self.part.problem;
        let x = self.inner.points_ref(at);
        // fixed chunks added in order: the partial sum does not depend on the thread count
        let partial: Vec<(f64, f64)> = self
            .part
            .owned_corners
            .par_chunks(CHUNK)
            .map(|cs| {
                cs.iter()
                    .fold((0.0, 0.0), |(f, bad), &c| match p.corner_term(x, c as usize) {
                        Some(t) => (f + t, bad),
                        None => (f, bad + 1.0),
                    })
            })
            .collect();
        let (f, bad) = partial.iter().fold((0.0, 0.0), |(f, b), &(pf, pb)| (f + pf, b + pb));
        // every corner of the part is a real corner with current ghosts, so
        // the minimum over parts is the minimum over the whole
        let det = out.min_det.map_or(f64::INFINITY, |_| objective::min_det(p, x));
        let global = self.comm.reduce(&[f, bad, det], &[comm::sum, comm::sum, comm::min]);
        let feasible = global[1] == 0.0;
        if let (Some(g), true) = (gradient, feasible) {
            self.inner.evaluate(at, out, Some(g))?;
        }
        self.inner.set(out.value, if feasible { global[0] } else { f64::NAN });
        self.inner.set(out.infeasible, global[1]);
        if let Some(s) = out.min_det {
            self.inner.set(s, global[2]);
        }
        Ok(())
    }

    fn trial(&mut self, alpha: Coef, d: Vector) -> Result<()> {
        self.inner.trial(alpha, d)?;
        self.exchange_points(Points::Trial);
        Ok(())
    }

    fn accept_trial(&mut self) -> Result<()> {
        self.inner.accept_trial()
    }

    fn inversion_fraction(&mut self, out: Slot) -> Result<()> {
        let p = &self.part.problem;
        let (x, y) = (
            self.inner.points_ref(Points::Current),
            self.inner.points_ref(Points::Trial),
        );
        // a minimum: the same on any partition and in any order
        let local = self
            .part
            .owned_corners
            .par_iter()
            .map(|&c| super::cpu::inversion::corner_first_inversion(p, x, y, c as usize))
            .reduce(|| f64::INFINITY, f64::min);
        let global = self.comm.reduce(&[local], &[comm::min]);
        self.inner.set(out, global[0]);
        Ok(())
    }

    fn reference_positions(&mut self, _iters: usize) -> Result<Vec<Vec3>> {
        // `rezone::reference_positions` runs step 1 on rank 0's whole problem
        Err(crate::error::Error::InvalidArgument(
            "reference positions are computed on rank 0, not per rank".into(),
        ))
    }

    fn bcd_color(&mut self, color: usize) -> Result<()> {
        self.inner.bcd_color(color)?;
        let free = &self.part.problem.free_vertices;
        self.comm
            .exchange(&self.colour_halos[color], self.inner.points_mut(Points::Current), |i| {
                free[i as usize] as usize
            });
        Ok(())
    }

    fn max_move(&mut self, out: Slot) -> Result<()> {
        self.inner.max_move(out)?;
        let m = self.comm.reduce(&[self.inner.slot(out)], &[comm::max])[0];
        self.inner.set(out, m);
        Ok(())
    }

    fn prepare_hessian(&mut self) -> Result<usize> {
        self.inner.prepare_hessian()
    }

    fn assemble(&mut self, g: Vector) -> Result<()> {
        self.inner.assemble(g)
    }

    fn hess_mul(&mut self, x: Vector, y: Vector) -> Result<()> {
        self.exchange_vector(x);
        self.inner.hess_mul(x, y)
    }

    fn factor_precond(&mut self) -> Result<()> {
        self.inner.factor_precond()
    }

    fn precond(&mut self, x: Vector, y: Vector) -> Result<()> {
        self.inner.precond(x, y)
    }

    fn dot(&mut self, a: Vector, b: Vector, sum: Slot, max: Option<Slot>) -> Result<()> {
        let (va, vb) = (self.inner.vector_ref(a), self.inner.vector_ref(b));
        let (mut s, mut m) = (0.0, 0.0f64);
        for &i in &self.part.owned_free {
            let (x, y) = (&va[i as usize], &vb[i as usize]);
            s += x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
            m = m.max(y[0] * y[0] + y[1] * y[1] + y[2] * y[2]);
        }
        let global = self.comm.reduce(&[s, m], &[comm::sum, comm::max]);
        self.inner.set(sum, global[0]);
        if let Some(slot) = max {
            self.inner.set(slot, global[1]);
        }
        Ok(())
    }

    fn axpby(&mut self, a: Coef, x: Vector, b: Coef, y: Vector, guard: Option<Slot>) -> Result<()> {
        self.inner.axpby(a, x, b, y, guard)
    }

    fn set_slot(&mut self, dst: Slot, value: Coef, guard: Option<Slot>) -> Result<()> {
        self.inner.set_slot(dst, value, guard)
    }

    fn flush(&mut self) -> Result<[f64; N_SLOTS]> {
        self.inner.flush()
    }

    fn bytes(&self) -> usize {
        self.inner.bytes()
    }

    fn past(&mut self, deadline: std::time::Instant) -> bool {
        let late = f64::from(u8::from(std::time::Instant::now() >= deadline));
        self.comm.from_root(late) != 0.0
    }
}
