//! Mesh generators and perturbations for tests and benchmarks.

pub mod box_mesh;
pub mod perturb;

pub use box_mesh::{duct, tet_box};
pub use perturb::{PerturbOptions, PerturbStats, Perturbation, perturb};
