//! How good a partition is for a distributed solve: the edge cut (what the
//! halo exchanges carry grows with it), the ghost fraction (duplicated work
//! and memory) and the imbalance (the slowest part sets the pace).

use super::Part;
use crate::problem::Problem;
use std::fmt;

/// Quality measures of a partition.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Quality {
    /// Number of parts.
    pub parts: usize,
    /// Mesh edges whose ends have different owners.
    pub edge_cut: usize,
    /// Mesh edges in all.
    pub edges: usize,
    /// Ghost vertices over all parts / vertices of the whole.
    pub ghost_fraction: f64,
    /// Largest owned vertex count over the mean.
    pub vertex_imbalance: f64,
    /// Largest count of corners summed (owned elements) over the mean.
    pub corner_imbalance: f64,
    /// Free ghost values received per halo exchange, all parts together.
    pub halo_values: usize,
}

impl Quality {
    /// The quality of the partition `owner` (owning part per vertex) into `parts` of `p`.
    pub fn of(p: &Problem, owner: &[u32], parts: &[Part]) -> Quality {
        let edges = (0..p.num_vertices())
            .map(|v| p.neighbours.of(v).iter().filter(|&&w| (w as usize) > v).count())
            .sum();
        let edge_cut = super::edge_cut(p, owner);
        let max_mean = |counts: Vec<usize>| {
            let mean = counts.iter().sum::<usize>() as f64 / counts.len().max(1) as f64;
            counts.into_iter().max().unwrap_or(0) as f64 / mean.max(1e-300)
        };
        Quality {
            parts: parts.len(),
            edge_cut,
            edges,
            ghost_fraction: parts.iter().map(Part::ghosts).sum::<usize>() as f64 / p.num_vertices().max(1) as f64,
            vertex_imbalance: max_mean(parts.iter().map(|q| q.owned.iter().filter(|&&o| o).count()).collect()),
            corner_imbalance: max_mean(parts.iter().map(|q| q.owned_corners.len()).collect()),
            halo_values: parts.iter().map(Part::halo_in).sum(),
        }
    }
}

impl fmt::Display for Quality {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} parts: edge cut {} of {} edges ({:.2}%), ghost fraction {:.3}, imbalance {:.3} (vertices) {:.3} (corners), {} ghost positions per halo exchange",
            self.parts,
            self.edge_cut,
            self.edges,
            100.0 * self.edge_cut as f64 / self.edges.max(1) as f64,
            self.ghost_fraction,
            self.vertex_imbalance,
            self.corner_imbalance,
            self.halo_values
        )
    }
}
