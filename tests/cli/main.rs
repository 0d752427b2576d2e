//! The `meshsmooth` binary end to end.
//!
//! Each module is one former test crate (same file name): `cargo test --test cli MODULE::`
//! runs one.

#[path = "../common/mod.rs"]
mod common;

mod cli;
mod cli_rezone;
mod front_ends;
mod outputs;
mod untangle_cli;
