//! Element quality metrics in f64: value, gradient and Hessian per element and
//! per vertex. Each file here is the CPU twin of a WGSL kernel in `shaders/metric/`.

pub mod mat3;
pub mod mean_ratio;

pub use mean_ratio::{TetShape, tet_det};
