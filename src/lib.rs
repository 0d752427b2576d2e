//! meshsmooth: mesh quality improvement by vertex repositioning.
//!
//! Data flows `io -> Mesh -> Problem -> solve -> positions -> io`; see the
//! README for the command-line tool and a library example.

pub mod backend;
pub mod compare;
pub mod error;
pub mod finding;
pub mod generate;
pub mod io;
pub mod mesh;
pub mod metric;
pub mod metric_report;
pub mod newton_study;
pub mod order_study;
pub mod partition;
pub use backend::cpu::objective;
pub mod plot;
pub mod problem;
pub mod report;
pub mod smoother;
pub mod solve;

pub use error::{Error, Result};
pub use mesh::{ElementKind, Mesh};
pub use smoother::{DeviceChoice, Smoother};
