//! CPU twin of `shaders/gradient_gather.wgsl`: each vertex's gradient of F
//! gathered over its incident corners in ascending corner order (a gather,
//! not a scatter, so the sum order is fixed and the result repeats bit for
//! bit). The kernel's order is the device's corners' (`hessian_gather.rs`).

use crate::metric::mat3::Vec3;
use crate::problem::Problem;
use rayon::prelude::*;

/// Per vertex (problem numbering), the sum of its corners' weighted
/// gradients `corner_grads[c].1[k]`; zero at fixed vertices.
pub fn gather(p: &Problem, corner_grads: &[(f64, [Vec3; 4])]) -> Vec<Vec3> {
    (0..p.num_vertices())
        .into_par_iter()
        .with_min_len(1024)
        .map(|v| {
            let mut acc = [0.0; 3];
            if p.free[v] {
                for &packed in p.incidence.of(v) {
                    let gv = &corner_grads[(packed >> 2) as usize].1[(packed & 3) as usize];
                    for i in 0..3 {
                        acc[i] += gv[i];
                    }
                }
            }
            acc
        })
        .collect()
}
