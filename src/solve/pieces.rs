//! A partitioned solve whose parts are the pieces of a `.pvtu` input
//! (`--partitioner pieces`): each rank reads its pieces, sets up its own part
//! with the others (`partition::local`), solves it, and writes its pieces
//! back with the new positions — no rank ever holds, merges or partitions
//! the whole mesh. Only a single-file output gathers the pieces on rank 0,
//! at the end.

use super::distributed::{Cluster, Report, encode_job, piece_reader, run_part};
use super::{Info, Method, Params, Record};
use crate::backend::cpu::{halo_gather, halo_scatter};
use crate::backend::distributed::comm::Comm;
use crate::error::{Error, Result};
use crate::io::{self, CellData, Format};
use crate::mesh::{Mesh, order::Ordering};
use crate::metric::corner_model::Template;
use crate::metric::mat3::Vec3;
use crate::metric::smetric::MetricKind;
use crate::partition::local::{self, Network, agree, swap};
use crate::partition::{Exchange, Partitioner};
use crate::problem::ProblemOptions;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::collections::HashMap;
use std::path::PathBuf;

const SWAP_TAG: i32 = 21;

/// What every rank needs to smooth the pieces of an index.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct PiecesJob {
    /// The .pvtu index file read.
    pub index: PathBuf,
    /// The pieces' files, in index order.
    pub sources: Vec<PathBuf>,
    /// The optimiser.
    pub method: Method,
    /// Termination and per-method settings.
    pub params: Params,
    /// The corner metric.
    pub metric: MetricKind,
    /// How corner values combine into the objective.
    pub template: Template,
    /// The vertex order within each part (`Ordering`'s name).
    pub ordering: String,
    /// The targets asked for (`Target`'s spelling): the parts are smoothed
    /// toward the ideal ones only, so anything that would construct targets
    /// is refused rather than smoothed away.
    pub target: String,
    /// Seed of the random orders.
    pub order_seed: u64,
    /// The output file (or the index, with `pieces`).
    pub output: PathBuf,
    /// The output format.
    pub format: Format,
    /// Write the pieces (piece i by the rank that read it) and an index, not one gathered file.
    pub pieces: bool,
    /// Each rank's GPU, or `None` for the CPU.
    pub gpu: Option<super::distributed::RankGpu>,
}

/// What rank 0 learns from `Cluster::smooth_pieces`.
pub struct PiecesOutcome {
    /// What the solve did.
    pub info: Info,
    /// The partitioned solve's report.
    pub report: Report,
    /// The rank that read (and wrote) each piece, in piece order.
    pub readers: Vec<usize>,
    /// Files written: the pieces then the index, or the one gathered file.
    pub written: Vec<PathBuf>,
}

impl Cluster {
    /// Rank 0: smooths the pieces of `job.index` on all ranks, each setting up its own part.
    pub fn smooth_pieces(&self, job: &PiecesJob, progress: &mut dyn FnMut(&Record) -> bool) -> Result<PiecesOutcome> {
        if job.method == Method::Laplace {
            return Err(Error::Unsupported(
                "method 'laplace' (sequential by nature) is not available under MPI (partitioned runs)".into(),
            ));
        }
        if job.sources.len() < self.size() {
            return Err(Error::Unsupported(format!(
                "`partitioner pieces`: {} has {} pieces for {} ranks; run with at most as many ranks as pieces",
                job.index.display(),
                job.sources.len(),
                self.size()
            )));
        }
        let bytes = encode_job(job);
        for r in 1..self.size() {
            self.world()
                .process_at_rank(r as i32)
                .send_with_tag(&bytes[..], super::distributed::JOB_TAG);
        }
        let (outcome, report) = run_pieces(self.world(), job, progress)?;
        *self.report_slot() = Some(report.clone());
        Ok(PiecesOutcome { report, ..outcome })
    }
}

/// The ranks as `partition::local` needs them.
struct World<'w>(&'w SimpleCommunicator);

impl Network for World<'_> {
    fn rank(&self) -> usize {
        self.0.rank() as usize
    }

    fn size(&self) -> usize {
        self.0.size() as usize
    }

    fn all_to_all(&self, out: Vec<Vec<u8>>) -> Vec<Vec<u8>> {
        let me = self.rank();
        let mut got: Vec<Vec<u8>> = vec![Vec::new(); out.len()];
        mpi::request::scope(|scope| {
            let pending: Vec<_> = out
                .iter()
                .enumerate()
                .filter(|&(r, _)| r != me)
                .map(|(r, buf)| {
                    self.0
                        .process_at_rank(r as i32)
                        .immediate_send_with_tag(scope, &buf[..], SWAP_TAG)
                })
                .collect();
            for (r, slot) in got.iter_mut().enumerate().filter(|&(r, _)| r != me) {
                *slot = self.0.process_at_rank(r as i32).receive_vec_with_tag::<u8>(SWAP_TAG).0;
            }
            for p in pending {
                p.wait();
            }
        });
        got[me] = out.into_iter().nth(me).unwrap_or_default();
        got
    }

    fn all_gather(&self, local: &[f64]) -> Vec<f64> {
        let mut all = vec![0.0; local.len() * self.size()];
        self.0.all_gather_into(local, &mut all[..]);
        all
    }

    fn exchange(&self, halo: &[Exchange], data: &mut [Vec3]) {
        // the CPU backend's halo twins, one neighbour's list after another
        let mut send = Vec::new();
        for h in halo {
            halo_gather::gather(data, &h.send, |i| i as usize, &mut send);
        }
        let recv = Comm::new(self.0).exchange(halo, &send);
        let mut rest = &recv[..];
        for h in halo {
            let (theirs, tail) = rest.split_at(3 * h.recv.len());
            halo_scatter::scatter(data, &h.recv, |i| i as usize, theirs);
            rest = tail;
        }
    }
}

/// Refuses targets the parts cannot be given: each part would need the
/// targets of its neighbours' elements, which no rank builds. With `auto`,
/// a part with stretched elements (which the default may keep with input
/// targets) is refused, never smoothed toward the ideal shape that would
/// destroy a boundary layer.
fn ideal_targets_only(job: &PiecesJob, share: &Mesh, me: usize) -> Result<()> {
    let asked = crate::problem::Target::parse(&job.target)?;
    let keep = match asked {
        // a part is not the mesh: a cut through a layer hides the wall the
        // default's detection looks for, so any part with the share of
        // coherently stretched elements that sets the detection going is refused
        crate::problem::Target::Auto => {
            use crate::problem::targets;
            let stretched = || -> Result<bool> {
                let shapes = targets::Shapes::of(share, &share.points)?;
                Ok(shapes.raw_share(share.dim()) >= targets::ANISOTROPIC_SHARE
                    && targets::intent_of(share, &shapes).anisotropic_share >= targets::ANISOTROPIC_SHARE)
            };
            job.metric == MetricKind::InverseMeanRatio && stretched()?
        }
        t => t.is_constructed(),
    };
    if !keep {
        return Ok(());
    }
    let why = if asked == crate::problem::Target::Auto {
        format!(
            "rank {me}'s part has stretched elements, which the default keeps with `target input` where they were built on purpose (`target ideal` smooths them toward the ideal shape)"
        )
    } else {
        format!("`target {}` was asked for", job.target)
    };
    Err(Error::Unsupported(format!(
        "`partitioner pieces` smooths toward the ideal targets only, and {why} (use `partitioner metis` or rcb, which build the targets)"
    )))
}

/// Every rank: read its pieces, set up its part, solve, write. Rank 0's
/// outcome carries the whole run's; the others' are theirs alone.
pub(super) fn run_pieces(
    world: &SimpleCommunicator,
    job: &PiecesJob,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<(PiecesOutcome, Report)> {
    let net = World(world);
    let (me, size, n) = (net.rank(), net.size(), job.sources.len());
    let readers: Vec<usize> = (0..n).map(|i| piece_reader(i, n, size)).collect();
    let mine: Vec<usize> = (0..n).filter(|&i| readers[i] == me).collect();
    let names: Vec<PathBuf> = mine.iter().map(|&i| job.sources[i].clone()).collect();
    let read: Result<Vec<Mesh>> = mine
        .iter()
        .map(|&i| {
            io::read_pvtu_piece(&job.sources[i])
                .map_err(|e| io::piece_error(&job.index, i, &job.sources[i], format!("{e} (read by rank {me})")))
        })
        .collect();
    let pieces = agree(&net, read)?;
    let (share, ids) = agree(&net, io::merge_share(&job.index, &pieces, &names))?;
    let ordering: Ordering = agree(
        &net,
        job.ordering
            .parse()
            .map_err(|e| Error::InvalidArgument(format!("`order {}`: {e:?}", job.ordering))),
    )?;
    agree(&net, ideal_targets_only(job, &share, me))?;
    let opts = ProblemOptions {
        metric: job.metric,
        template: job.template,
        ordering,
        order_seed: job.order_seed,
        ..Default::default()
    };
    let local = local::build(&net, &share, ids.as_deref(), &opts)?;
    let part = &local.part;
    let bad = part.problem.infeasible_elements(&part.x).len();
    agree(
        &net,
        if bad == 0 {
            Ok(())
        } else {
            Err(Error::Unsupported(format!(
                "`partitioner pieces`: {bad} inverted elements in rank {me}'s part; it does not untangle (use `partitioner metis` or rcb)"
            )))
        },
    )?;
    // cancelling on one rank would leave the others waiting for it
    let mut report_progress = |r: &Record| {
        progress(r);
        true
    };
    let (result, outcome) = run_part(
        world,
        part,
        job.method,
        &job.params,
        job.gpu.as_ref(),
        &mut report_progress,
    );
    // the ranks' reports, at rank 0
    let to_root: Vec<Vec<_>> = (0..size)
        .map(|r| if r == 0 { vec![outcome.rank] } else { Vec::new() })
        .collect();
    let ranks: Vec<_> = swap(&net, &to_root)?.into_iter().flatten().collect();
    let info = agree(&net, result)?;
    if let Some((r, o)) = ranks.iter().enumerate().find(|(_, o)| o.iterations != info.iterations) {
        return Err(Error::InvalidArgument(format!(
            "rank {r} stopped after {} iterations, rank 0 after {} (a stop decision was not shared)",
            o.iterations, info.iterations
        )));
    }
    // the new position of every point this rank read: its own, or its owner's
    let mut at: HashMap<u32, Vec3> = outcome.global.iter().copied().zip(outcome.x.iter().copied()).collect();
    let mut asked: Vec<Vec<u32>> = vec![Vec::new(); size];
    for (&g, &o) in local.gid.iter().zip(&local.owner) {
        if o as usize != me {
            asked[o as usize].push(g);
        }
    }
    let heard = swap(&net, &asked)?;
    let answers: Vec<Vec<Vec3>> = heard.iter().map(|gs| gs.iter().map(|g| at[g]).collect()).collect();
    for (gs, xs) in asked.iter().zip(swap(&net, &answers)?) {
        at.extend(gs.iter().copied().zip(xs));
    }
    let share_at: Vec<Vec3> = local.gid.iter().map(|g| at[g]).collect();
    let moved = agree(&net, move_pieces(pieces, &share, ids.as_deref(), &share_at))?;
    let written = if job.pieces {
        write_pieces(&net, job, &mine, &moved)?
    } else {
        let to_root: Vec<Vec<Mesh>> = (0..size)
            .map(|r| if r == 0 { moved.clone() } else { Vec::new() })
            .collect();
        let all: Vec<Mesh> = swap(&net, &to_root)?.into_iter().flatten().collect();
        if me == 0 {
            // the memory of one process holding the whole mesh, at the end only
            let whole = io::merge_pieces(&job.index, &all, &job.sources)?;
            io::write_mesh(&job.output, &whole, job.format)?;
        }
        vec![job.output.clone()]
    };
    let report = Report {
        partitioner: Partitioner::Pieces,
        fallback: None,
        owner: Vec::new(),
        vertices: local.total_vertices,
        whole_on_rank0: false,
        quality: local.quality,
        iterations: info.iterations,
        cg_iterations: info.cg_iterations.unwrap_or(0),
        ranks,
    };
    Ok((
        PiecesOutcome {
            info,
            report: report.clone(),
            readers,
            written,
        },
        report,
    ))
}

/// The pieces with their points at `share_at` (the positions of the merged
/// `share`'s points), matched as the merge matched them: by global id, else
/// by coordinates. Points the merge dropped (no cell uses them) stay.
fn move_pieces(mut pieces: Vec<Mesh>, share: &Mesh, ids: Option<&[i64]>, share_at: &[Vec3]) -> Result<Vec<Mesh>> {
    let id_of = |m: &Mesh| io::point_ids(m).map(|a| (0..m.num_points()).map(|l| a.get_i64(l)).collect::<Vec<_>>());
    match ids {
        Some(ids) => {
            let index: HashMap<i64, usize> = ids.iter().enumerate().map(|(l, &g)| (g, l)).collect();
            for piece in &mut pieces {
                let pids = id_of(piece).ok_or_else(|| Error::InvalidMesh("a piece lost its point ids".into()))?;
                for (p, g) in piece.points.iter_mut().zip(pids) {
                    if let Some(&l) = index.get(&g) {
                        *p = share_at[l];
                    }
                }
            }
        }
        None => {
            let index: HashMap<[u64; 3], usize> = share
                .points
                .iter()
                .enumerate()
                .map(|(l, p)| (p.map(f64::to_bits), l))
                .collect();
            for piece in &mut pieces {
                for p in &mut piece.points {
                    if let Some(&l) = index.get(&p.map(f64::to_bits)) {
                        *p = share_at[l];
                    }
                }
            }
        }
    }
    Ok(pieces)
}

/// Each rank writes the pieces it read (`mine`, moved), with their quality;
/// rank 0 writes the index once every piece is written.
fn write_pieces(net: &dyn Network, job: &PiecesJob, mine: &[usize], moved: &[Mesh]) -> Result<Vec<PathBuf>> {
    let cell = |piece: &Mesh| io::eta_field(piece);
    let wrote: Result<Vec<PathBuf>> = mine
        .iter()
        .zip(moved)
        .map(|(&i, piece)| {
            crate::metric::refuse_inverted(piece)?;
            let path = io::piece_path(&job.output, i);
            let eta = cell(piece);
            io::write(&path, piece, job.format, &[eta_data(&eta)])?;
            Ok(path)
        })
        .collect();
    agree(net, wrote)?;
    let n = job.sources.len();
    let paths: Vec<PathBuf> = (0..n).map(|i| io::piece_path(&job.output, i)).collect();
    if net.rank() == 0 {
        let sources: Vec<String> = paths
            .iter()
            .map(|p| {
                p.file_name()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default()
            })
            .collect();
        let eta = cell(&moved[0]);
        io::write_index(&job.output, &moved[0], &[eta_data(&eta)], &sources)?;
    }
    Ok(paths.into_iter().chain([job.output.clone()]).collect())
}

fn eta_data(values: &[f64]) -> CellData<'_> {
    CellData {
        name: "inverse_mean_ratio",
        values,
    }
}

/// This process's peak resident memory (Linux's VmHWM), MiB; 0 elsewhere.
pub fn peak_rss_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(0.0, |kib| kib / 1024.0)
}
