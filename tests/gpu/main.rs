//! The GPU backend's tests: every kernel and solver on the device against its CPU
//! twin. Without an adapter they skip (saying so on stderr), except under `CI`, where
//! they fail: CI installs lavapipe.
//!
//! Each module is one former test crate (same file name): `cargo test --test gpu MODULE::`
//! runs one.

#[path = "../common/mod.rs"]
mod common;

mod gpu_layout;
mod gpu_matches_cpu;
mod gpu_metrics;
mod gpu_newton;
mod gpu_nlcg;
mod gpu_split;
mod gpu_surface;
mod gpu_untangle;
mod kernels;
