//! The distributed backend: one rank's part of a partitioned problem
//! (`partition::Part`) on an inner backend (the CPU one, or a GPU per rank),
//! with the reductions and halo exchanges that make the solvers — unchanged
//! — solve the whole problem. It reaches the inner backend only
//! through the `Backend` contract: `restrict_sums` once, `read_entries` and
//! `write_entries` per exchange (on a GPU one gather and one read-back, then
//! one upload and one scatter), `flush` per reduction.
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

use super::{Backend, Coef, Entries, EvalSlots, N_SLOTS, Points, Slot, Vector};
use crate::error::Result;
use crate::metric::mat3::Vec3;
use crate::partition::{Exchange, Part};
use comm::{Comm, CommStats};
use mpi::topology::SimpleCommunicator;

/// A halo with its send and receive lists concatenated in neighbour order,
/// so one exchange is one `read_entries` and one `write_entries`.
struct Halo {
    exchanges: Vec<Exchange>,
    send: Vec<u32>,
    recv: Vec<u32>,
}

impl Halo {
    fn new(exchanges: Vec<Exchange>) -> Halo {
        Halo {
            send: exchanges.iter().flat_map(|h| h.send.iter().copied()).collect(),
            recv: exchanges.iter().flat_map(|h| h.recv.iter().copied()).collect(),
            exchanges,
        }
    }
}

/// A [`Backend`](crate::backend::Backend) over MPI: an inner backend on this rank's part, its sums combined over the ranks and its halos exchanged.
pub struct DistributedBackend<'p, B> {
    inner: B,
    comm: Comm<'p>,
    halo: Halo,
    /// Per colour, the halo of that colour's vertices: a colour of a sweep
    /// moves only them, so only they are sent.
    colour_halos: Vec<Halo>,
    /// The send side of an exchange, kept to reuse its allocation.
    send: Vec<f64>,
}

impl<'p, B: Backend> DistributedBackend<'p, B> {
    /// `inner` holds `part`'s problem and start; its sums are restricted
    /// here to what the part owns.
    pub fn new(part: &'p Part, world: &'p SimpleCommunicator, mut inner: B) -> Result<Self> {
        inner.restrict_sums(&part.owned_free, &part.owned_corners)?;
        Ok(DistributedBackend {
            inner,
            comm: Comm::new(world),
            halo: Halo::new(part.halo.clone()),
            colour_halos: (0..part.problem.colors.len() as u32)
                .map(|c| Halo::new(part.colour_halo(c)))
                .collect(),
            send: Vec::new(),
        })
    }

    /// This rank's communication counters so far.
    pub fn comm_stats(&self) -> CommStats {
        self.comm.stats
    }

    /// Overwrites the ghost entries of `of` named by `halo` (a colour's, or
    /// the whole one) with their owners' values.
    fn exchange(&mut self, of: Entries, colour: Option<usize>) -> Result<()> {
        let halo = match colour {
            Some(c) => &self.colour_halos[c],
            None => &self.halo,
        };
        if halo.exchanges.is_empty() {
            return Ok(());
        }
        self.send.clear();
        self.inner.read_entries(of, &halo.send, &mut self.send)?;
        let recv = self.comm.exchange(&halo.exchanges, &self.send);
        self.inner.write_entries(of, &halo.recv, &recv)
    }

    /// The partial values of `slots` on this rank, combined over the ranks
    /// (`combine` per slot), written back to the same slots on every rank.
    fn reduce(&mut self, slots: &[Slot], combine: &[fn(f64, f64) -> f64]) -> Result<Vec<f64>> {
        let local = self.inner.flush()?;
        let mine: Vec<f64> = slots.iter().map(|s| local[s.0 as usize]).collect();
        let global = self.comm.reduce(&mine, combine);
        for (s, &v) in slots.iter().zip(&global) {
            self.inner.set_slot(*s, Coef::value(v), None)?;
        }
        Ok(global)
    }
}

impl<B: Backend> Backend for DistributedBackend<'_, B> {
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
        // the inner sums cover the owned corners; its minimum covers every
        // corner of the part, each a real corner with current ghosts, so the
        // minimum over parts is the minimum over the whole
        self.inner.evaluate(at, out, gradient)?;
        let mut slots = vec![out.value, out.infeasible];
        let mut combine: Vec<fn(f64, f64) -> f64> = vec![comm::sum, comm::sum];
        if let Some(s) = out.min_det {
            slots.push(s);
            combine.push(comm::min);
        }
        let global = self.reduce(&slots, &combine)?;
        if global[1] != 0.0 {
            self.inner.set_slot(out.value, Coef::value(f64::NAN), None)?;
        }
        Ok(())
    }

    fn trial(&mut self, alpha: Coef, d: Vector) -> Result<()> {
        self.inner.trial(alpha, d)?;
        self.exchange(Entries::Points(Points::Trial), None)
    }

    fn accept_trial(&mut self) -> Result<()> {
        self.inner.accept_trial()
    }

    fn inversion_fraction(&mut self, out: Slot) -> Result<()> {
        // a minimum over the part's corners, all real corners with current
        // ghosts: the same on any partition and in any order
        self.inner.inversion_fraction(out)?;
        self.reduce(&[out], &[comm::min])?;
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
        self.exchange(Entries::Points(Points::Current), Some(color))
    }

    fn max_move(&mut self, out: Slot) -> Result<()> {
        self.inner.max_move(out)?;
        self.reduce(&[out], &[comm::max])?;
        Ok(())
    }

    fn prepare_hessian(&mut self) -> Result<usize> {
        self.inner.prepare_hessian()
    }

    fn assemble(&mut self, g: Vector) -> Result<()> {
        self.inner.assemble(g)
    }

    fn hess_mul(&mut self, x: Vector, y: Vector) -> Result<()> {
        self.exchange(Entries::Vector(x), None)?;
        self.inner.hess_mul(x, y)
    }

    fn factor_precond(&mut self) -> Result<()> {
        self.inner.factor_precond()
    }

    fn precond(&mut self, x: Vector, y: Vector) -> Result<()> {
        self.inner.precond(x, y)
    }

    fn dot(&mut self, a: Vector, b: Vector, sum: Slot, max: Option<Slot>) -> Result<()> {
        self.inner.dot(a, b, sum, max)?;
        match max {
            Some(m) => self.reduce(&[sum, m], &[comm::sum, comm::max])?,
            None => self.reduce(&[sum], &[comm::sum])?,
        };
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
