//! meshsmooth: mesh quality improvement by vertex repositioning.
//!
//! Data flows `io -> Mesh -> Problem -> solve -> positions -> io`; see the
//! README for the command-line tool and a library example.
//!
//! Cargo features: `gpu` (the wgpu backend, `backend::gpu` and
//! `solve::Device::Gpu`), `cli` (the `meshsmooth` tool; implies `gpu`),
//! `studies` (the two papers' studies, `newton_study` and `order_study`), all
//! on by default; `mpi` (partitioned runs, `solve::Device::Mpi`, with or
//! without `gpu`) and `metis`. Without default features the crate is the
//! CPU library alone.

#![warn(missing_docs)]

pub mod backend;
pub mod compare;
pub mod error;
// The papers' studies (feature `studies`): for the tool and the benches, not a library API.
#[doc(hidden)]
#[cfg(feature = "studies")]
pub mod finding;
pub mod generate;
pub mod io;
pub mod mesh;
pub mod metric;
pub mod metric_report;
// The papers' studies (feature `studies`): for the tool and the benches, not a library API.
#[doc(hidden)]
#[cfg(feature = "studies")]
pub mod newton_study;
// The papers' studies (feature `studies`): for the tool and the benches, not a library API.
#[doc(hidden)]
#[cfg(feature = "studies")]
pub mod order_study;
pub mod partition;
pub use backend::cpu::objective;
pub mod plot;
pub mod problem;
pub mod report;
pub mod smoother;
pub mod solve;
// The studies' statistics (feature `studies`): for the tool and the benches, not a library API.
#[doc(hidden)]
#[cfg(feature = "studies")]
pub mod stats;

pub use error::{Error, Result};
pub use mesh::{ElementKind, Mesh};
pub use smoother::{DeviceChoice, Smoother};
