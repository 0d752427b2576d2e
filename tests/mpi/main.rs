//! Partitioned smoothing under `mpirun`: built with `--features mpi`, empty without it.
//! The module keeps the former test crate's name: `cargo test --features mpi --test mpi mpi::`.

#[cfg(feature = "mpi")]
#[path = "../common/mod.rs"]
mod common;

#[cfg(feature = "mpi")]
mod mpi;
