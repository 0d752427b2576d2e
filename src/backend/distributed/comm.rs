//! What a rank says to the others during a solve: halo exchanges of free
//! positions or vector entries, and reductions of scalars. Reductions gather
//! every rank's partial value and combine them in rank order on every rank,
//! so the result is the same on all ranks and from run to run, whatever the
//! timing (an MPI sum would be free to pick its own order). Time and bytes
//! are counted for the report.

use crate::metric::mat3::Vec3;
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
    pub halo_exchanges: usize,
    /// Bytes this rank sent in halo exchanges.
    pub halo_bytes: usize,
    pub reductions: usize,
    /// Bytes this rank contributed to reductions.
    pub reduction_bytes: usize,
}

pub struct Comm<'w> {
    world: &'w SimpleCommunicator,
    pub stats: CommStats,
}

impl<'w> Comm<'w> {
    pub fn new(world: &'w SimpleCommunicator) -> Self {
        Comm {
            world,
            stats: CommStats::default(),
        }
    }

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

    /// Overwrites the ghost entries of `data` (indexed through `at`, from a
    /// free-vector index) with their owners' values.
    pub fn exchange(&mut self, halo: &[Exchange], data: &mut [Vec3], at: impl Fn(u32) -> usize) {
        if halo.is_empty() {
            return;
        }
        let start = Instant::now();
        let sends: Vec<(i32, Vec<f64>)> = halo
            .iter()
            .filter(|h| !h.send.is_empty())
            .map(|h| (h.rank as i32, h.send.iter().flat_map(|&i| data[at(i)]).collect()))
            .collect();
        let mut recvs: Vec<Vec<f64>> = halo.iter().map(|h| vec![0.0; 3 * h.recv.len()]).collect();
        let world = self.world;
        mpi::request::scope(|scope| {
            let pending: Vec<_> = sends
                .iter()
                .map(|(r, buf)| {
                    world
                        .process_at_rank(*r)
                        .immediate_send_with_tag(scope, &buf[..], HALO_TAG)
                })
                .collect();
            for (h, buf) in halo.iter().zip(recvs.iter_mut()) {
                if !h.recv.is_empty() {
                    world
                        .process_at_rank(h.rank as i32)
                        .receive_into_with_tag(&mut buf[..], HALO_TAG);
                }
            }
            for p in pending {
                p.wait();
            }
        });
        for (h, buf) in halo.iter().zip(&recvs) {
            for (k, &i) in h.recv.iter().enumerate() {
                data[at(i)] = [buf[3 * k], buf[3 * k + 1], buf[3 * k + 2]];
            }
        }
        self.stats.halo_exchanges += 1;
        self.stats.halo_bytes += sends.iter().map(|(_, b)| 8 * b.len()).sum::<usize>();
        self.stats.seconds += start.elapsed().as_secs_f64();
    }
}

pub fn sum(a: f64, b: f64) -> f64 {
    a + b
}

/// NaN-propagating, so an infeasible rank's NaN reaches every rank.
pub fn max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() { f64::NAN } else { a.max(b) }
}

pub fn min(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() { f64::NAN } else { a.min(b) }
}
