//! Partitioned smoothing over MPI (`Device::Mpi`): rank 0 holds the whole
//! problem, splits it (`partition`), ships each rank its part, runs its own
//! part and gathers the owned positions back; every other rank waits in
//! [`follow`] for parts to solve. All ranks run the same solver loop
//! (`run_scaled`) over a `DistributedBackend`, whose reductions make every
//! slot — and so every branch — the same on all ranks.
//!
//! Decisions that one rank could take alone would split the ranks, so a
//! partitioned run refuses them: a time limit (clocks differ), cancelling
//! from the progress callback (ignored), and the sequential sweeps (Laplace;
//! `bcd` runs colour by colour, as on a GPU). Sliding boundaries are not
//! distributed yet.

use super::{Info, Method, Options, Params, Record, Scale, run_scaled};
use crate::backend::distributed::DistributedBackend;
use crate::backend::distributed::comm::CommStats;
use crate::error::{Error, Result};
use crate::metric::mat3::Vec3;
use crate::partition::{self, Part, Partitioner, Quality};
use crate::problem::Problem;
use mpi::environment::Universe;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::cell::{Cell, RefCell};
use std::fmt;
use std::time::Instant;

const JOB_TAG: i32 = 3;
const RESULT_TAG: i32 = 4;

/// The MPI job this process is a rank of.
pub struct Cluster {
    universe: RefCell<Option<Universe>>,
    world: SimpleCommunicator,
    report: RefCell<Option<Report>>,
    partitioner: Cell<Partitioner>,
}

impl Cluster {
    /// True when started by an MPI launcher (mpirun, srun): the environment
    /// says so before MPI is initialised, so a plain run never touches MPI.
    pub fn launched() -> bool {
        ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"]
            .iter()
            .any(|v| std::env::var_os(v).is_some())
    }

    /// Initialises MPI; `None` if it was already initialised.
    pub fn init() -> Option<Cluster> {
        let universe = mpi::initialize()?;
        let world = universe.world();
        Some(Cluster {
            universe: RefCell::new(Some(universe)),
            world,
            report: RefCell::new(None),
            partitioner: Cell::new(Partitioner::default()),
        })
    }

    pub fn rank(&self) -> usize {
        self.world.rank() as usize
    }

    pub fn size(&self) -> usize {
        self.world.size() as usize
    }

    /// How the next solves share out the vertices (rank 0 decides).
    pub fn set_partitioner(&self, partitioner: Partitioner) {
        self.partitioner.set(partitioner);
    }

    /// The report of the last partitioned solve (rank 0).
    pub fn report(&self) -> Option<Report> {
        self.report.borrow().clone()
    }

    /// Rank 0 releases the waiting ranks; then MPI is finalised. Call once, at the end.
    pub fn finish(&self) {
        if self.rank() == 0 {
            for r in 1..self.size() {
                self.world
                    .process_at_rank(r as i32)
                    .send_with_tag(&[0u8; 0][..], JOB_TAG);
            }
        }
        drop(self.universe.borrow_mut().take());
    }
}

/// One rank's share of a partitioned solve.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RankReport {
    pub owned: usize,
    pub ghosts: usize,
    /// Wall time of the solver loop on this rank.
    pub seconds: f64,
    pub comm: CommStats,
}

/// What a partitioned solve reports besides `Info`.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// The partitioner that made the partition.
    pub partitioner: Partitioner,
    /// Why it is not the one asked for, if it is not.
    pub fallback: Option<String>,
    /// The owning rank of each vertex of the mesh (mesh numbering, as
    /// `Problem::order` maps it), so outputs can be written per rank.
    pub owner: Vec<u32>,
    pub quality: Quality,
    pub ranks: Vec<RankReport>,
    pub iterations: usize,
    /// CG iterations (Newton), else 0.
    pub cg_iterations: usize,
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let max = |g: &dyn Fn(&RankReport) -> f64| self.ranks.iter().map(g).fold(0.0, f64::max);
        let wall = max(&|r| r.seconds);
        let comm = max(&|r| r.comm.seconds);
        let bytes: usize = self.ranks.iter().map(|r| r.comm.halo_bytes).sum();
        let exchanges = self.ranks.iter().map(|r| r.comm.halo_exchanges).max().unwrap_or(0);
        let reductions = self.ranks.iter().map(|r| r.comm.reductions).max().unwrap_or(0);
        write!(
            f,
            "mpi: {} ranks; partitioner {}",
            self.ranks.len(),
            self.partitioner.name()
        )?;
        if let Some(why) = &self.fallback {
            write!(f, " ({why})")?;
        }
        writeln!(f, "; {}", self.quality)?;
        writeln!(
            f,
            "mpi time (slowest rank): {:.3} s, of which compute {:.3} s and communication {:.3} s ({:.1}%)",
            wall,
            (wall - comm).max(0.0),
            comm,
            100.0 * comm / wall.max(1e-300)
        )?;
        write!(
            f,
            "mpi traffic: {exchanges} halo exchanges ({bytes} bytes sent, all ranks; {:.0} bytes per exchange, {:.0} per iteration), {reductions} reductions",
            bytes as f64 / exchanges.max(1) as f64,
            bytes as f64 / self.iterations.max(1) as f64
        )?;
        if self.cg_iterations > 0 {
            // one exchange per product; the rest are the line searches' trial points
            write!(f, ", {} CG iterations", self.cg_iterations)?;
        }
        Ok(())
    }
}

/// What a rank sends back.
#[derive(serde::Serialize, serde::Deserialize)]
struct Outcome {
    /// Global ids and positions of the owned vertices.
    global: Vec<u32>,
    x: Vec<Vec3>,
    rank: RankReport,
    error: Option<String>,
}

fn encode<T: serde::Serialize>(value: &T) -> Vec<u8> {
    let mut buf = Vec::new();
    ciborium::into_writer(value, &mut buf).expect("a part serialises to memory");
    buf
}

fn decode<T: serde::de::DeserializeOwned>(bytes: &[u8]) -> Result<T> {
    ciborium::from_reader(bytes).map_err(|e| Error::InvalidArgument(format!("a malformed message from rank 0: {e}")))
}

/// Rank 0's side of `solve` on `Device::Mpi`: split, ship, solve, gather
/// into `x` (problem numbering).
pub fn lead(
    cluster: &Cluster,
    p: &Problem,
    x: &mut [Vec3],
    opts: &Options,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<Info> {
    refuse(p, opts)?;
    let size = cluster.size();
    let (partitioner, owner, fallback) = share_out(cluster.partitioner.get(), p, x, size)?;
    let parts = partition::split(p, x, &owner, size);
    let quality = Quality::of(p, &owner, &parts);
    for (r, part) in parts.iter().enumerate().skip(1) {
        let job = encode(&(part, opts.method, &opts.params));
        cluster.world.process_at_rank(r as i32).send_with_tag(&job[..], JOB_TAG);
    }
    // cancelling on one rank would leave the others waiting for it
    let mut report_progress = |r: &Record| {
        progress(r);
        true
    };
    let (result, own) = run_part(
        &cluster.world,
        &parts[0],
        opts.method,
        &opts.params,
        &mut report_progress,
    );
    let mut outcomes = vec![own];
    for r in 1..size {
        let (bytes, _) = cluster
            .world
            .process_at_rank(r as i32)
            .receive_vec_with_tag::<u8>(RESULT_TAG);
        outcomes.push(decode(&bytes)?);
    }
    let info = result?;
    for o in &outcomes {
        if let Some(e) = &o.error {
            return Err(Error::InvalidArgument(format!("a rank failed: {e}")));
        }
        for (&g, y) in o.global.iter().zip(&o.x) {
            x[g as usize] = *y;
        }
    }
    let mut mesh_owner = vec![0; p.order.len()];
    for (&old, &r) in p.order.iter().zip(&owner) {
        mesh_owner[old as usize] = r;
    }
    *cluster.report.borrow_mut() = Some(Report {
        partitioner,
        fallback,
        owner: mesh_owner,
        quality,
        ranks: outcomes.iter().map(|o| o.rank).collect(),
        iterations: info.iterations,
        cg_iterations: info.cg_iterations.unwrap_or(0),
    });
    Ok(info)
}

/// The owner of each vertex by `asked`, or by coordinate bisection when METIS
/// leaves a rank without vertices (a graph smaller than the rank count).
fn share_out(
    asked: Partitioner,
    p: &Problem,
    x: &[Vec3],
    size: usize,
) -> Result<(Partitioner, Vec<u32>, Option<String>)> {
    let owner = asked.owners(p, x, size)?;
    let mut count = vec![0usize; size];
    for &r in &owner {
        count[r as usize] += 1;
    }
    match count.iter().position(|&c| c == 0) {
        Some(r) if asked != Partitioner::Rcb => Ok((
            Partitioner::Rcb,
            partition::rcb(x, size),
            Some(format!("{} left rank {r} without vertices", asked.name())),
        )),
        _ => Ok((asked, owner, None)),
    }
}

/// What a partitioned run cannot do (see the module documentation).
fn refuse(p: &Problem, opts: &Options) -> Result<()> {
    let no = |what: &str| Err(Error::Unsupported(format!("{what} under MPI (partitioned runs)")));
    if p.sliding.is_some() {
        return no("sliding boundaries are not supported");
    }
    if opts.method == Method::Laplace {
        return no("method 'laplace' (sequential by nature) is not available");
    }
    if opts.params.time_limit.is_some() {
        return no("a time limit (ranks' clocks would disagree) is not supported");
    }
    Ok(())
}

/// Every rank but 0: solves the parts rank 0 sends until it says stop.
pub fn follow(cluster: &Cluster) -> Result<()> {
    loop {
        let (bytes, _) = cluster.world.process_at_rank(0).receive_vec_with_tag::<u8>(JOB_TAG);
        if bytes.is_empty() {
            return Ok(());
        }
        let (part, method, params): (Part, Method, Params) = decode(&bytes)?;
        let (_, outcome) = run_part(&cluster.world, &part, method, &params, &mut |_| true);
        cluster
            .world
            .process_at_rank(0)
            .send_with_tag(&encode(&outcome)[..], RESULT_TAG);
    }
}

fn run_part(
    world: &SimpleCommunicator,
    part: &Part,
    method: Method,
    params: &Params,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> (Result<Info>, Outcome) {
    let opts = Options {
        method,
        params: params.clone(),
        ..Default::default()
    };
    let scale = Scale {
        edge: part.edge,
        setup: part.setup,
        colors: part.problem.colors.len(),
    };
    let mut x = part.x.clone();
    let start = Instant::now();
    let (result, comm) = match DistributedBackend::new(part, world, &params.bcd.line_search) {
        Ok(mut be) => {
            let r = run_scaled(&mut be, &part.problem, scale, &mut x, &opts, progress);
            (r, be.comm_stats())
        }
        Err(e) => (Err(e), CommStats::default()),
    };
    let owned: Vec<usize> = (0..x.len()).filter(|&l| part.owned[l]).collect();
    let outcome = Outcome {
        global: owned.iter().map(|&l| part.global[l]).collect(),
        x: owned.iter().map(|&l| x[l]).collect(),
        rank: RankReport {
            owned: owned.len(),
            ghosts: part.ghosts(),
            seconds: start.elapsed().as_secs_f64(),
            comm,
        },
        error: result.as_ref().err().map(|e| e.to_string()),
    };
    (result, outcome)
}
