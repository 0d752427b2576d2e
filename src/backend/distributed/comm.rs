//! What a rank says to the others during a solve: halo exchanges of free
//! positions or vector entries, and reductions of scalars. Reductions gather
//! every rank's partial value and combine them in rank order on every rank,
//! so the result is the same on all ranks and from run to run, whatever the
//! timing (an MPI sum would be free to pick its own order). Time and bytes
//! are counted for the report.

use crate::partition::Exchange;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::time::Instant;

const HALO_TAG: i32 = 17;

/// Communication counters of one rank.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CommStats {
    /// Wall time spent in exchanges and reductions (waiting included).
    pub seconds: f64,
    /// Halo exchanges done.
    pub halo_exchanges: usize,
    /// Bytes this rank sent in halo exchanges.
    pub halo_bytes: usize,
    /// Reductions over the ranks done.
    pub reductions: usize,
    /// Bytes this rank contributed to reductions.
    pub reduction_bytes: usize,
}

/// A rank's communicator with its counters.
pub struct Comm<'w> {
    world: &'w SimpleCommunicator,
    /// The counters so far.
    pub stats: CommStats,
}

impl<'w> Comm<'w> {
    /// A communicator over `world`, counters at zero.
    pub fn new(world: &'w SimpleCommunicator) -> Self {
        Comm {
            world,
            stats: CommStats::default(),
        }
    }

    /// Number of ranks.
    pub fn size(&self) -> usize {
        self.world.size() as usize
    }

    /// Every rank's `local` values, rank after rank.
    fn gather(&mut self, local: &[f64]) -> Vec<f64> {
        let start = Instant::now();
        let mut all = vec![0.0; local.len() * self.size()];
        self.world.all_gather_into(local, &mut all[..]);
        self.stats.reductions += 1;
        self.stats.reduction_bytes += 8 * local.len();
        self.stats.seconds += start.elapsed().as_secs_f64();
        all
    }

    /// Per component `k`, `combine[k]` folded over the ranks in rank order.
    pub fn reduce(&mut self, local: &[f64], combine: &[fn(f64, f64) -> f64]) -> Vec<f64> {
        let k = local.len();
        let all = self.gather(local);
        (0..k)
            .map(|j| (1..self.size()).fold(all[j], |acc, r| combine[j](acc, all[r * k + j])))
            .collect()
    }

    /// Rank 0's `local`, on every rank: for what one rank decides for all.
    pub fn from_root(&mut self, local: f64) -> f64 {
        let start = Instant::now();
        let mut value = local;
        self.world.process_at_rank(0).broadcast_into(&mut value);
        self.stats.reductions += 1;
        self.stats.reduction_bytes += 8;
        self.stats.seconds += start.elapsed().as_secs_f64();
        value
    }

    /// Sends each neighbour its entries of `send` (3 reals per entry of the
    /// neighbours' `send` lists, concatenated in `halo` order) and returns
    /// what they sent back, concatenated in the order of the `recv` lists.
    pub fn exchange(&mut self, halo: &[Exchange], send: &[f64]) -> Vec<f64> {
        let mut recv = vec![0.0; 3 * halo.iter().map(|h| h.recv.len()).sum::<usize>()];
        if halo.is_empty() {
            return recv;
        }
        let start = Instant::now();
        let world = self.world;
        mpi::request::scope(|scope| {
            let mut rest = send;
            let mut pending = Vec::with_capacity(halo.len());
            for h in halo {
                let (mine, tail) = rest.split_at(3 * h.send.len());
                rest = tail;
                if !mine.is_empty() {
                    pending.push(
                        world
                            .process_at_rank(h.rank as i32)
                            .immediate_send_with_tag(scope, mine, HALO_TAG),
                    );
                }
            }
            let mut rest = &mut recv[..];
            for h in halo {
                let (theirs, tail) = rest.split_at_mut(3 * h.recv.len());
                rest = tail;
                if !theirs.is_empty() {
                    world
                        .process_at_rank(h.rank as i32)
                        .receive_into_with_tag(theirs, HALO_TAG);
                }
            }
            for p in pending {
                p.wait();
            }
        });
        self.stats.halo_exchanges += 1;
        self.stats.halo_bytes += 8 * send.len();
        self.stats.seconds += start.elapsed().as_secs_f64();
        recv
    }
}

/// a + b: the sum reduction.
pub fn sum(a: f64, b: f64) -> f64 {
    a + b
}

/// NaN-propagating, so an infeasible rank's NaN reaches every rank.
pub fn max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() { f64::NAN } else { a.max(b) }
}

/// NaN-propagating minimum, like [`max`].
pub fn min(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() { f64::NAN } else { a.min(b) }
}
