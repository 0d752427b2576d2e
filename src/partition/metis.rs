//! Graph partitioning of the vertex graph with METIS 5 (multilevel k-way):
//! it minimises the edge cut — what the halo exchanges carry — where the
//! geometric bisection only balances, so it is the default where built in.
//! Vertices are unweighted, as in the bisection, so both balance the same
//! counts and their cuts compare.

use crate::error::{Error, Result};
use crate::problem::Problem;
use std::sync::Mutex;

/// Some of METIS's (GKlib's) state outlives a call and is not reset by the
/// seed: a thread's earlier calls change its later partitions (seen in the
/// tests). Each call runs on a thread of its own, so a graph always gets the
/// same partition, and one at a time, in case a build keeps that state global.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// Stack of the thread METIS runs on (its recursion is shallow; the graph lives on the heap).
const STACK: usize = 16 << 20;

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
    let run = || -> Result<()> {
        metis::Graph::new(1, nparts, &xadj, &adjncy)
            .map_err(|e| fail(&e))?
            // a fixed seed: with fresh state, the same graph gets the same partition
            .set_option(metis::option::Seed(1))
            .part_kway(&mut part)
            .map_err(|e| fail(&e))?;
        Ok(())
    };
    let _only = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    std::thread::scope(|s| {
        std::thread::Builder::new()
            .name("metis".into())
            .stack_size(STACK)
            .spawn_scoped(s, run)
            .map_err(|e| Error::InvalidArgument(format!("METIS: cannot start its thread: {e}")))?
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    })?;
    Ok(part.into_iter().map(|r| r as u32).collect())
}
