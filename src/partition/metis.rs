//! Graph partitioning of the vertex graph with METIS 5 (multilevel k-way):
//! it minimises the edge cut — what the halo exchanges carry — where the
//! geometric bisection only balances, so it is the default where built in.
//! Vertices are unweighted, as in the bisection, so both balance the same
//! counts and their cuts compare.

use crate::error::{Error, Result};
use crate::problem::Problem;

/// METIS's part of each vertex (problem numbering), `parts` parts, within
/// METIS's default 3% imbalance.
pub fn metis(p: &Problem, parts: usize) -> Result<Vec<u32>> {
    let n = p.num_vertices();
    if parts <= 1 || n == 0 {
        return Ok(vec![0; n]);
    }
    let idx = |v: u32| {
        metis::Idx::try_from(v)
            .map_err(|_| Error::Unsupported(format!("METIS: {n} vertices do not fit its 32-bit indices")))
    };
    let xadj = p
        .neighbours
        .offsets
        .iter()
        .map(|&o| idx(o))
        .collect::<Result<Vec<_>>>()?;
    let adjncy = p.neighbours.items.iter().map(|&w| idx(w)).collect::<Result<Vec<_>>>()?;
    let nparts = metis::Idx::try_from(parts).map_err(|_| Error::InvalidArgument(format!("{parts} parts")))?;
    let mut part = vec![0 as metis::Idx; n];
    let fail =
        |e: &dyn std::fmt::Display| Error::InvalidArgument(format!("METIS could not partition the vertex graph: {e}"));
    metis::Graph::new(1, nparts, &xadj, &adjncy)
        .map_err(|e| fail(&e))?
        // a fixed seed: the same mesh gives the same partition on every run
        .set_option(metis::option::Seed(1))
        .part_kway(&mut part)
        .map_err(|e| fail(&e))?;
    Ok(part.into_iter().map(|r| r as u32).collect())
}
