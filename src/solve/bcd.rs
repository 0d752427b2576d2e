//! Block coordinate descent (section 3.1 of the Newton paper): one Newton
//! step per free vertex on its 3x3 block, Armijo backtracking on the elements
//! around it, vertices in the problem's locality order.

use crate::metric::mat3::{Mat3, Vec3, cholesky_solve, dot};
use crate::problem::Problem;
use std::time::Instant;

/// Armijo backtracking constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineSearch {
    /// Step reduction factor.
    pub beta: f64,
    /// Sufficient-decrease constant.
    pub sigma: f64,
    /// Reductions tried before the vertex is left where it is.
    pub max_backtracks: usize,
}

impl Default for LineSearch {
    fn default() -> Self {
        LineSearch {
            beta: 0.5,
            sigma: 1e-4,
            max_backtracks: 40,
        }
    }
}

/// Sum of the inverse mean ratios around `v` with `v` at `at`; `None` if any
/// of those elements would be inverted.
#[inline]
pub fn patch_value(p: &Problem, x: &[Vec3], v: usize, at: &Vec3) -> Option<f64> {
    let mut sum = 0.0;
    for &packed in p.incidence.of(v) {
        let (e, k) = ((packed >> 2) as usize, (packed & 3) as usize);
        let mut xe = p.tet_points(x, e);
        xe[k] = *at;
        sum += p.shape.value(&xe)?;
    }
    Some(sum)
}

/// Gradient and 3x3 Hessian of the patch sum with respect to `v`, with the sum itself.
#[inline]
pub fn patch_gradient_hessian(p: &Problem, x: &[Vec3], v: usize) -> Option<(f64, Vec3, Mat3)> {
    let mut f = 0.0;
    let mut g = [0.0; 3];
    let mut h = [[0.0; 3]; 3];
    for &packed in p.incidence.of(v) {
        let (e, k) = ((packed >> 2) as usize, (packed & 3) as usize);
        let (eta, ge, he) = p.shape.vertex_gradient_hessian(&p.tet_points(x, e), k)?;
        f += eta;
        for i in 0..3 {
            g[i] += ge[i];
            for j in 0..3 {
                h[i][j] += he[i][j];
            }
        }
    }
    Some((f, g, h))
}

/// Moves vertex `v` by one safeguarded Newton step; returns the squared
/// displacement (0 when it stays).
#[inline]
pub fn relax_vertex(p: &Problem, x: &mut [Vec3], v: usize, ls: &LineSearch) -> f64 {
    let Some((f0, g, h)) = patch_gradient_hessian(p, x, v) else {
        return 0.0;
    };
    let neg_g = [-g[0], -g[1], -g[2]];
    // the block is positive definite for the mean ratio; fall back to a scaled
    // steepest descent step should rounding say otherwise
    let d = cholesky_solve(&h, &neg_g).unwrap_or_else(|| {
        let tr = h[0][0] + h[1][1] + h[2][2];
        let s = if tr > 0.0 { 3.0 / tr } else { 1.0 };
        neg_g.map(|c| c * s)
    });
    let slope = dot(&g, &d);
    if !(slope < 0.0) {
        return 0.0;
    }
    let mut alpha = 1.0;
    for _ in 0..=ls.max_backtracks {
        let trial = [
            x[v][0] + alpha * d[0],
            x[v][1] + alpha * d[1],
            x[v][2] + alpha * d[2],
        ];
        if let Some(f) = patch_value(p, x, v, &trial)
            && f <= f0 + ls.sigma * alpha * slope
        {
            x[v] = trial;
            return alpha * alpha * dot(&d, &d);
        }
        alpha *= ls.beta;
    }
    0.0
}

/// One sweep over all free vertices; stops early (leaving a valid state) at
/// `deadline`. Returns the largest squared displacement.
pub fn sweep(p: &Problem, x: &mut [Vec3], ls: &LineSearch, deadline: Option<Instant>) -> f64 {
    let mut max_sq: f64 = 0.0;
    for (i, &v) in p.free_vertices.iter().enumerate() {
        if i % 4096 == 4095 && deadline.is_some_and(|d| Instant::now() >= d) {
            break;
        }
        max_sq = max_sq.max(relax_vertex(p, x, v as usize, ls));
    }
    max_sq
}
