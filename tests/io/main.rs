//! Reading and writing meshes: round trips, bad input, other tools' files and
//! partitioned (`.pvtu`) output.
//!
//! Each module is one former test crate (same file name): `cargo test --test io MODULE::`
//! runs one.

#[path = "../common/mod.rs"]
mod common;

mod abaqus;
mod bad_input_io;
mod bombs;
#[cfg(feature = "exodus")]
mod exodus;
mod interop;
mod io_roundtrip;
mod lossless;
mod openfoam;
mod pvtu;
mod surface_formats;
#[cfg(feature = "vtkhdf")]
mod vtkhdf;
