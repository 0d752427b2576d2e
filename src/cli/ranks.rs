//! The command line under an MPI launcher: rank 0 runs the command as usual,
//! with every solve partitioned over the ranks (`Device::Mpi`); the other
//! ranks only solve the parts rank 0 sends them.

use meshsmooth::partition::Partitioner;
use meshsmooth::solve::distributed::{Cluster, Report, follow};
use std::cell::Cell;

thread_local! {
    /// Set on rank 0 while a command runs; the solves it starts use it.
    static CLUSTER: Cell<Option<&'static Cluster>> = const { Cell::new(None) };
}

/// Runs `command` on rank 0 and the follower loop elsewhere; the exit code.
pub fn run_under_mpi(command: impl FnOnce() -> i32) -> i32 {
    let Some(cluster) = Cluster::init() else {
        return command();
    };
    // the solves borrow it for the whole command; MPI ends in `finish`, not in a drop
    let cluster: &'static Cluster = Box::leak(Box::new(cluster));
    share_cores();
    let code = if cluster.rank() == 0 {
        CLUSTER.with(|c| c.set(Some(cluster)));
        let code = command();
        CLUSTER.with(|c| c.set(None));
        code
    } else {
        match follow(cluster) {
            Ok(()) => 0,
            Err(e) => {
                eprintln!(
                    "error (rank {}): {}",
                    cluster.rank(),
                    super::device::flagged(&e.to_string())
                );
                1
            }
        }
    };
    cluster.finish();
    code
}

/// Ranks on one machine share its cores: each gets its share of threads
/// (unless RAYON_NUM_THREADS says otherwise), instead of every rank starting
/// one thread per core.
fn share_cores() {
    if std::env::var_os("RAYON_NUM_THREADS").is_some() {
        return;
    }
    let local: usize = std::env::var("OMPI_COMM_WORLD_LOCAL_SIZE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads((cores / local.max(1)).max(1))
        .build_global();
}

/// This MPI job, on rank 0 while a command runs.
pub fn cluster() -> Option<&'static Cluster> {
    CLUSTER.with(|c| c.get())
}

/// The ranks of this MPI job (1 outside one).
pub fn size() -> usize {
    CLUSTER.with(|c| c.get()).map_or(1, |c| c.size())
}

/// How the solves of this command share out the vertices.
pub fn set_partitioner(partitioner: Partitioner) {
    if let Some(c) = CLUSTER.with(|c| c.get()) {
        c.set_partitioner(partitioner);
    }
}

/// The partition and communication report of the last solve, if it was partitioned.
pub fn report() -> Option<Report> {
    CLUSTER.with(|c| c.get()).and_then(|c| c.report())
}
