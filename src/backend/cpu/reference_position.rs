//! CPU twin of `shaders/reference_position.wgsl`: step 1 of reference-Jacobian
//! rezoning (equation 1 of the rezoning paper). Every free vertex, on its own
//! and with every other vertex at its Lagrangian position, minimises the
//! objective of the corners it belongs to (the paper's F_i: for the
//! `cn-paper` problem the condition numbers of its corners and of its
//! neighbours' corners that it moves; the paper's 1/(C 4 N_T) factor does not
//! move the minimiser) by up to `iters` safeguarded Newton steps, the step of
//! block coordinate descent. No vertex moves: the answers are virtual, so all
//! vertices run in parallel. Fixed vertices are their own reference.

use super::bcd::{Patch, patch_step};
use crate::backend::settings::LineSearch;
pub use crate::backend::settings::STEP_TOL;
use crate::metric::mat3::Vec3;
use crate::problem::Problem;
use rayon::prelude::*;

/// The squared local size of vertex `v`: the largest squared distance from
/// it to a vertex of its corners (the kernel's sum order).
pub fn local_size_sq(p: &Problem, x: &[Vec3], v: usize) -> f64 {
    let mut h: f64 = 0.0;
    for &packed in p.incidence.of(v) {
        for q in p.corner_points(x, (packed >> 2) as usize) {
            let e = [q[0] - x[v][0], q[1] - x[v][1], q[2] - x[v][2]];
            h = h.max(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
        }
    }
    h
}

/// The reference position of free vertex `v`: up to `iters` Newton steps
/// from `x[v]`, stopping at the first that the line search refuses or whose
/// direction is below [`STEP_TOL`] of the local size.
pub fn reference_position(p: &Problem, x: &[Vec3], v: usize, ls: &LineSearch, iters: usize, patch: &mut Patch) -> Vec3 {
    patch.load(p, x, v);
    let min_step_sq = STEP_TOL * STEP_TOL * local_size_sq(p, x, v);
    let mut y = x[v];
    for _ in 0..iters {
        match patch_step(p, patch, v, &y, ls, min_step_sq) {
            Some(next) => y = next,
            None => break,
        }
    }
    y
}

/// Every vertex's reference position (problem numbering).
pub fn reference_positions(p: &Problem, x: &[Vec3], ls: &LineSearch, iters: usize) -> Vec<Vec3> {
    (0..p.num_vertices())
        .into_par_iter()
        .with_min_len(256)
        .map_init(Patch::default, |patch, v| {
            if p.free[v] {
                reference_position(p, x, v, ls, iters, patch)
            } else {
                x[v]
            }
        })
        .collect()
}
