//! The CPU backend's tests: metrics, solvers, untangling, rezoning, problems and
//! boundaries, orderings and partitions, the generators and the studies' reports.
//!
//! Each module is one former test crate (same file name): `cargo test --test cpu MODULE::`
//! runs one.

#[path = "../common/mod.rs"]
mod common;

mod boundary;
mod coloring;
mod convergence;
mod generate;
mod generate_papers;
mod geometry;
mod metric_elements;
mod metric_fd;
mod newton;
mod newton_study;
mod nlcg;
mod orderings;
mod paper_examples;
#[cfg(feature = "metis")]
mod partition;
mod planar;
mod polyhedra;
mod problem;
mod real_meshes;
mod reference;
mod report;
mod rezone;
mod surface;
mod targets;
mod units;
mod untangle;
mod unused;
