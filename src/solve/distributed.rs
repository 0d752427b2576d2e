//! Partitioned smoothing over MPI (`Device::Mpi`): rank 0 holds the whole
//! problem, splits it (`partition`), ships each rank its part, runs its own
//! part and gathers the owned positions back; every other rank waits in
//! [`follow`] for parts to solve. All ranks run the same solver loop
//! (`run_scaled`) over a `DistributedBackend` around a CPU backend or, when
//! rank 0 was asked for a GPU (`Cluster::set_gpu`), a GPU backend on a
//! context each rank opens itself; its reductions make every slot — and so
//! every branch — the same on all ranks.
//!
//! Decisions that one rank could take alone would split the ranks: a time
//! limit is read from rank 0's clock and shared (`Backend::past`), so all
//! ranks stop at the same iteration (and the same colour of a sweep);
//! cancelling from the progress callback is ignored; the sequential sweeps
//! are refused (Laplace; `bcd` runs colour by colour, as on a GPU). Sliding
//! vertices carry their constraints into the parts (`Sliding::restrict`):
//! projecting is per vertex, so it gives the single-process bits.
//!
//! `--partitioner pieces` takes another road to the same `run_part`: the
//! ranks set up their own parts from a `.pvtu` input's pieces, and no rank
//! holds the whole problem (`super::pieces`).

use super::{Device, Info, Method, Options, Params, Record, Scale, run_scaled};
use crate::backend::Backend;
use crate::backend::distributed::DistributedBackend;
use crate::backend::distributed::comm::{self, Comm, CommStats};
#[cfg(feature = "gpu")]
use crate::backend::gpu::{GpuContext, GpuOptions, Precision};
use crate::error::{Error, Result};
use crate::io::{self, CellData, Format};
use crate::mesh::Mesh;
use crate::metric::mat3::Vec3;
use crate::partition::{self, Part, Partitioner, Quality};
use crate::problem::Problem;
use mpi::environment::Universe;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use rayon::prelude::*;
use std::cell::{Cell, RefCell};
use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub(super) const JOB_TAG: i32 = 3;
const RESULT_TAG: i32 = 4;

/// The MPI job this process is a rank of.
pub struct Cluster {
    universe: RefCell<Option<Universe>>,
    world: SimpleCommunicator,
    report: RefCell<Option<Report>>,
    partitioner: Cell<Partitioner>,
    gpu: RefCell<Option<RankGpu>>,
}

/// The GPU every rank smooths its part on (`--device gpu` under mpirun):
/// each rank opens its own context with these options, so ranks on one
/// machine may share one adapter.
#[cfg(feature = "gpu")]
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RankGpu {
    /// The adapter whose name contains this (else `MESHSMOOTH_ADAPTER`).
    pub adapter: Option<String>,
    /// The GPU arithmetic.
    pub precision: Precision,
}

/// Without feature `gpu` the ranks run on the CPU: there is no GPU to ask for.
#[cfg(not(feature = "gpu"))]
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum RankGpu {}

/// Calls `f` with this rank's device: the CPU, or the GPU `gpu` asks for,
/// on a context this rank opens (an error if it cannot).
fn on_rank_device<T>(gpu: Option<&RankGpu>, f: impl FnOnce(Result<Device>) -> T) -> T {
    match gpu {
        None => f(Ok(Device::Cpu)),
        #[cfg(feature = "gpu")]
        Some(g) => {
            let options = GpuOptions {
                adapter: g.adapter.clone(),
                precision: g.precision,
                ..Default::default()
            };
            match GpuContext::new(&options) {
                Ok(ctx) => f(Ok(Device::Gpu(&ctx))),
                Err(e) => f(Err(e)),
            }
        }
        #[cfg(not(feature = "gpu"))]
        Some(g) => match *g {},
    }
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
            gpu: RefCell::new(None),
        })
    }

    /// This rank's index.
    pub fn rank(&self) -> usize {
        self.world.rank() as usize
    }

    /// Number of ranks.
    pub fn size(&self) -> usize {
        self.world.size() as usize
    }

    /// How the next solves share out the vertices (rank 0 decides).
    pub fn set_partitioner(&self, partitioner: Partitioner) {
        self.partitioner.set(partitioner);
    }

    /// Where the ranks solve their parts: a GPU each, or the CPU (`None`).
    pub fn set_gpu(&self, gpu: Option<RankGpu>) {
        *self.gpu.borrow_mut() = gpu;
    }

    /// The report of the last partitioned solve (rank 0).
    pub fn report(&self) -> Option<Report> {
        self.report.borrow().clone()
    }

    pub(super) fn world(&self) -> &SimpleCommunicator {
        &self.world
    }

    pub(super) fn report_slot(&self) -> std::cell::RefMut<'_, Option<Report>> {
        self.report.borrow_mut()
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
    /// Vertices this rank owns.
    pub owned: usize,
    /// Ghost vertices this rank holds (owned by others).
    pub ghosts: usize,
    /// Iterations this rank ran: the same on every rank, since every stop
    /// decision is shared (checked by rank 0).
    pub iterations: usize,
    /// Wall time of the solver loop on this rank.
    pub seconds: f64,
    /// This rank's communication counters.
    pub comm: CommStats,
    /// Vertices (owned and ghosts) and elements of this rank's part.
    pub vertices: usize,
    /// Elements of this rank's part.
    pub elements: usize,
    /// Peak resident memory of this rank's process (VmHWM), MiB; 0 where unknown.
    pub peak_rss_mib: f64,
}

/// What a partitioned solve reports besides `Info`.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// The partitioner that made the partition.
    pub partitioner: Partitioner,
    /// Why it is not the one asked for, if it is not.
    pub fallback: Option<String>,
    /// The owning rank of each vertex of the mesh (mesh numbering, as
    /// `Problem::order` maps it), so outputs can be written per rank; empty
    /// when the ranks set up their own parts (no rank holds the mesh).
    pub owner: Vec<u32>,
    /// Vertices of the whole mesh.
    pub vertices: usize,
    /// Did rank 0 hold and split the whole problem (else each rank set up its own part)?
    pub whole_on_rank0: bool,
    /// Quality of the partition.
    pub quality: Quality,
    /// One report per rank, by rank.
    pub ranks: Vec<RankReport>,
    /// Iterations run (the same on every rank).
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
        let most = |g: &dyn Fn(&RankReport) -> usize| self.ranks.iter().map(g).max().unwrap_or(0);
        write!(
            f,
            "\nmpi memory: largest part {} vertices (owned and ghosts) and {} elements, of the mesh's {} vertices; {}",
            most(&|r| r.vertices),
            most(&|r| r.elements),
            self.vertices,
            if self.whole_on_rank0 {
                "rank 0 also held the whole mesh and problem"
            } else {
                "no rank held the whole mesh (parts set up on the ranks)"
            }
        )?;
        let rss = max(&|r| r.peak_rss_mib);
        if rss > 0.0 {
            let each: Vec<String> = self.ranks.iter().map(|r| format!("{:.1}", r.peak_rss_mib)).collect();
            write!(f, "; peak RSS per rank (MiB) {} (max {rss:.1})", each.join(", "))?;
        }
        Ok(())
    }
}

/// What rank 0 asks of another rank.
#[derive(serde::Serialize, serde::Deserialize)]
enum Job {
    /// Solve this part (on a GPU if given); answered with an `Outcome`.
    Solve(Box<Part>, Method, Params, Option<Box<RankGpu>>),
    /// Read these pieces (number, file) of an index; answered with each
    /// piece or the error reading it.
    Read(Vec<(usize, PathBuf)>),
    /// Write this piece atomically, with these cell arrays; answered with
    /// the error, if any.
    Write(PathBuf, Box<Mesh>, Format, Vec<(String, Vec<f64>)>),
    /// Smooth the pieces of an index, each rank setting up its own part
    /// (`Cluster::smooth_pieces`); every rank takes part, none answers.
    Pieces(Box<super::pieces::PiecesJob>),
}

/// `Job` as rank 0 sends it: borrowing what it sends (the same encoding).
#[derive(serde::Serialize)]
#[serde(rename = "Job")]
enum JobRef<'a> {
    Solve(&'a Part, Method, &'a Params, Option<&'a RankGpu>),
    Read(&'a [(usize, PathBuf)]),
    Write(&'a Path, &'a Mesh, Format, Vec<(&'a str, &'a [f64])>),
    Pieces(&'a super::pieces::PiecesJob),
}

/// The job that starts a pieces solve on a rank, encoded.
pub(super) fn encode_job(job: &super::pieces::PiecesJob) -> Vec<u8> {
    encode(&JobRef::Pieces(job))
}

/// What a rank sends back after a solve.
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct Outcome {
    /// Global ids and positions of the owned vertices.
    pub(super) global: Vec<u32>,
    pub(super) x: Vec<Vec3>,
    pub(super) rank: RankReport,
    error: Option<String>,
}

fn encode<T: serde::Serialize>(value: &T) -> Vec<u8> {
    let mut buf = Vec::new();
    ciborium::into_writer(value, &mut buf).expect("a part serialises to memory");
    buf
}

fn decode<T: serde::de::DeserializeOwned>(bytes: &[u8]) -> Result<T> {
    ciborium::from_reader(bytes).map_err(|e| Error::InvalidArgument(format!("a malformed MPI message: {e}")))
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
    refuse(opts)?;
    let size = cluster.size();
    let (partitioner, owner, fallback) = share_out(cluster.partitioner.get(), p, x, size)?;
    let parts = partition::split(p, x, &owner, size);
    let quality = Quality::of(p, &owner, &parts);
    let gpu = cluster.gpu.borrow().clone();
    for (r, part) in parts.iter().enumerate().skip(1) {
        let job = encode(&JobRef::Solve(part, opts.method, &opts.params, gpu.as_ref()));
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
        gpu.as_ref(),
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
    for (r, o) in outcomes.iter().enumerate() {
        if let Some(e) = &o.error {
            return Err(Error::InvalidArgument(format!("a rank failed: {e}")));
        }
        if o.rank.iterations != info.iterations {
            return Err(Error::InvalidArgument(format!(
                "rank {r} stopped after {} iterations, rank 0 after {} (a stop decision was not shared)",
                o.rank.iterations, info.iterations
            )));
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
        vertices: p.num_vertices(),
        whole_on_rank0: true,
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
fn refuse(opts: &Options) -> Result<()> {
    let no = |what: &str| Err(Error::Unsupported(format!("{what} under MPI (partitioned runs)")));
    if opts.method == Method::Laplace {
        return no("method 'laplace' (sequential by nature) is not available");
    }
    Ok(())
}

/// Every rank but 0: does what rank 0 asks (solve a part, read or write
/// pieces) until it says stop.
pub fn follow(cluster: &Cluster) -> Result<()> {
    loop {
        let (bytes, _) = cluster.world.process_at_rank(0).receive_vec_with_tag::<u8>(JOB_TAG);
        if bytes.is_empty() {
            return Ok(());
        }
        let answer = match decode(&bytes)? {
            Job::Solve(part, method, params, gpu) => {
                encode(&run_part(&cluster.world, &part, method, &params, gpu.as_deref(), &mut |_| true).1)
            }
            Job::Read(pieces) => encode(&read_own(&pieces)),
            Job::Pieces(job) => {
                // every rank learns the outcome in the collective steps; rank 0 reports it
                let _ = super::pieces::run_pieces(&cluster.world, &job, &mut |_| true);
                continue;
            }
            Job::Write(path, piece, format, cells) => {
                let cell_data: Vec<CellData> = cells.iter().map(|(name, values)| CellData { name, values }).collect();
                encode(
                    &io::write(&path, &piece, format, &cell_data)
                        .err()
                        .map(|e| e.to_string()),
                )
            }
        };
        cluster.world.process_at_rank(0).send_with_tag(&answer[..], RESULT_TAG);
    }
}

/// Pieces `pieces` (number, file), read here (in parallel), or why not.
fn read_own(pieces: &[(usize, PathBuf)]) -> Vec<std::result::Result<Mesh, String>> {
    pieces
        .par_iter()
        .map(|(_, file)| io::read_pvtu_piece(file).map_err(|e| e.to_string()))
        .collect()
}

/// The rank that reads piece `i` of `n` on `size` ranks: piece i on rank i
/// when there are as many pieces as ranks, else consecutive pieces to each
/// rank (ranks beyond the pieces read none).
pub fn piece_reader(i: usize, n: usize, size: usize) -> usize {
    if n <= size { i } else { i * size / n }
}

impl Cluster {
    /// The pieces `sources` of the `.pvtu` index `index`, each read (and
    /// parsed) by the rank [`piece_reader`] names and sent to rank 0, which
    /// gets them all, in order. Rank 0 then holds the whole mesh, as with a
    /// read of its own: what the ranks share is the reading and parsing.
    pub fn read_pieces(&self, index: &Path, sources: &[PathBuf]) -> Result<Vec<Mesh>> {
        let (n, size) = (sources.len(), self.size());
        let mut mine: Vec<Vec<(usize, PathBuf)>> = vec![Vec::new(); size];
        for (i, s) in sources.iter().enumerate() {
            mine[piece_reader(i, n, size)].push((i, s.clone()));
        }
        for (r, pieces) in mine.iter().enumerate().skip(1).filter(|(_, p)| !p.is_empty()) {
            let job = encode(&JobRef::Read(pieces));
            self.world.process_at_rank(r as i32).send_with_tag(&job[..], JOB_TAG);
        }
        let mut read: Vec<Option<Result<Mesh>>> = (0..n).map(|_| None).collect();
        let mut keep = |r: usize, got: Vec<std::result::Result<Mesh, String>>| {
            for ((i, file), m) in mine[r].iter().zip(got) {
                read[*i] = Some(m.map_err(|e| io::piece_error(index, *i, file, format!("{e} (read by rank {r})"))));
            }
        };
        keep(0, read_own(&mine[0]));
        // every answer is received, even after a bad one, so none is left for a later receive
        let mut malformed = None;
        for r in (1..size).filter(|&r| !mine[r].is_empty()) {
            let (bytes, _) = self
                .world
                .process_at_rank(r as i32)
                .receive_vec_with_tag::<u8>(RESULT_TAG);
            match decode(&bytes) {
                Ok(got) => keep(r, got),
                Err(e) => malformed = malformed.or(Some(e)),
            }
        }
        if let Some(e) = malformed {
            return Err(e);
        }
        read.into_iter()
            .enumerate()
            .map(|(i, m)| m.unwrap_or_else(|| Err(io::piece_error(index, i, &sources[i], "no rank returned it"))))
            .collect()
    }

    /// Writes pieces on the ranks: piece r on rank r (r modulo the ranks
    /// when there are more pieces than ranks), see [`io::PieceWriter`].
    pub fn piece_writer(&self) -> RankPieces<'_> {
        RankPieces {
            cluster: self,
            pending: Vec::new(),
            ranks: Vec::new(),
        }
    }
}

/// Pieces written by the ranks, each its own (`Cluster::piece_writer`).
pub struct RankPieces<'c> {
    cluster: &'c Cluster,
    /// Ranks with a piece in writing, in the order they were given one.
    pending: Vec<usize>,
    /// The rank that wrote each piece, in piece order.
    pub ranks: Vec<usize>,
}

impl io::PieceWriter for RankPieces<'_> {
    fn put(&mut self, r: usize, path: &Path, piece: &Mesh, format: Format, cell_data: &[CellData]) -> Result<()> {
        let rank = r % self.cluster.size();
        self.ranks.push(rank);
        if rank == 0 {
            return io::write(path, piece, format, cell_data);
        }
        let cells = cell_data.iter().map(|c| (c.name, c.values)).collect();
        let job = encode(&JobRef::Write(path, piece, format, cells));
        self.cluster
            .world
            .process_at_rank(rank as i32)
            .send_with_tag(&job[..], JOB_TAG);
        self.pending.push(rank);
        Ok(())
    }

    fn done(&mut self) -> Result<()> {
        let mut first = None;
        for rank in std::mem::take(&mut self.pending) {
            let (bytes, _) = self
                .cluster
                .world
                .process_at_rank(rank as i32)
                .receive_vec_with_tag::<u8>(RESULT_TAG);
            let failed = match decode::<Option<String>>(&bytes) {
                Ok(failed) => failed.map(|e| Error::InvalidArgument(format!("rank {rank}: {e}"))),
                Err(e) => Some(e),
            };
            first = first.or(failed);
        }
        first.map_or(Ok(()), Err)
    }
}

pub(super) fn run_part(
    world: &SimpleCommunicator,
    part: &Part,
    method: Method,
    params: &Params,
    gpu: Option<&RankGpu>,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> (Result<Info>, Outcome) {
    let opts = Options {
        method,
        params: params.clone(),
        ..Default::default()
    };
    let mut x = part.x.clone();
    let start = Instant::now();
    let ls = &params.bcd.line_search;
    let (result, comm) = on_rank_device(gpu, |device| {
        let inner = device.and_then(|d| d.backend(&part.problem, &part.x, ls));
        run_on(world, part, inner, &opts, &mut x, progress)
    });
    let owned: Vec<usize> = (0..x.len()).filter(|&l| part.owned[l]).collect();
    let outcome = Outcome {
        global: owned.iter().map(|&l| part.global[l]).collect(),
        x: owned.iter().map(|&l| x[l]).collect(),
        rank: RankReport {
            owned: owned.len(),
            ghosts: part.ghosts(),
            iterations: result.as_ref().map_or(0, |i| i.iterations),
            seconds: start.elapsed().as_secs_f64(),
            comm,
            vertices: part.owned.len(),
            elements: part.problem.num_elements(),
            peak_rss_mib: super::pieces::peak_rss_mib(),
        },
        error: result.as_ref().err().map(|e| e.to_string()),
    };
    (result, outcome)
}

/// The solver loop on `part` over `inner` wrapped in a `DistributedBackend`,
/// once every rank has its inner backend (a rank that could not build one,
/// say for want of a GPU, would leave the others waiting in a reduction).
fn run_on<B: Backend>(
    world: &SimpleCommunicator,
    part: &Part,
    inner: Result<B>,
    opts: &Options,
    x: &mut [Vec3],
    progress: &mut dyn FnMut(&Record) -> bool,
) -> (Result<Info>, CommStats) {
    let failed = f64::from(u8::from(inner.is_err()));
    let any_failed = Comm::new(world).reduce(&[failed], &[comm::max])[0] != 0.0;
    let be = match (inner, any_failed) {
        (Err(e), _) => return (Err(e), CommStats::default()),
        (Ok(_), true) => {
            let e = Error::InvalidArgument("another rank could not set up its backend".into());
            return (Err(e), CommStats::default());
        }
        (Ok(inner), false) => DistributedBackend::new(part, world, inner),
    };
    let scale = Scale {
        edge: part.edge,
        setup: part.setup,
        colors: part.problem.colors.len(),
    };
    match be {
        Ok(mut be) => {
            let r = run_scaled(&mut be, &part.problem, scale, x, opts, progress);
            (r, be.comm_stats())
        }
        Err(e) => (Err(e), CommStats::default()),
    }
}

#[cfg(test)]
mod tests {
    use super::piece_reader;

    #[test]
    fn every_piece_has_one_reader_in_rank_order() {
        for size in 1..=5 {
            for n in 1..=12 {
                let readers: Vec<usize> = (0..n).map(|i| piece_reader(i, n, size)).collect();
                assert!(
                    readers.windows(2).all(|w| w[0] <= w[1]),
                    "{n} pieces on {size} ranks: {readers:?}"
                );
                assert!(readers.iter().all(|&r| r < size));
                if n <= size {
                    assert_eq!(readers, (0..n).collect::<Vec<_>>());
                } else {
                    // every rank reads, none more than one piece beyond its share
                    for r in 0..size {
                        let k = readers.iter().filter(|&&x| x == r).count();
                        assert!(
                            k >= n / size && k <= n.div_ceil(size),
                            "{n} pieces on {size} ranks: {readers:?}"
                        );
                    }
                }
            }
        }
    }
}
