//! CPU twin of `shaders/objective.wgsl`: the objective F = sum over corners of w_c m(S_c) (the mean over elements of
//! the mean corner term; for the inverse mean ratio under the harmonic template,
//! equation 2 of the Newton paper), its gradient over the free vertices and
//! that gradient's 2-norm.

use crate::metric::mat3::Vec3;
use crate::problem::Problem;
use rayon::prelude::*;

use super::reduce::CHUNK;

/// Objective value; `None` when any corner is inverted or degenerate.
pub fn value(p: &Problem, x: &[Vec3]) -> Option<f64> {
    let n = p.num_corners();
    // fixed chunks summed in a fixed order: the value repeats bit for bit
    let partial: Option<Vec<f64>> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| (c * CHUNK..((c + 1) * CHUNK).min(n)).map(|k| p.corner_term(x, k)).sum())
        .collect();
    partial.map(|v| super::reduce::in_order(&v))
}

/// Objective and its gradient (zero at fixed vertices); `None` if infeasible.
pub fn gradient(p: &Problem, x: &[Vec3]) -> Option<(f64, Vec<Vec3>)> {
    let n = p.num_corners();
    let grads: Option<Vec<(f64, [Vec3; 4])>> = (0..n)
        .into_par_iter()
        .with_min_len(CHUNK)
        .map(|c| {
            let (v, g) = p.model.gradient(p.shape(c), &p.corner_points(x, c))?;
            let w = p.corner_weight[c];
            Some((w * v, g.map(|gk| gk.map(|t| t * w))))
        })
        .collect();
    let grads = grads?;
    let g = super::gradient_gather::gather(p, &grads);
    let f = super::reduce::sum(&grads, |(t, _)| *t);
    Some((f, g))
}

/// Euclidean norm of a gradient field.
pub fn norm(g: &[Vec3]) -> f64 {
    g.iter().flatten().map(|c| c * c).sum::<f64>().sqrt()
}

/// F and the free gradient (indexed like `Problem::free_vertices`); `None` if infeasible.
pub fn free_gradient(p: &Problem, x: &[Vec3]) -> Option<(f64, Vec<Vec3>)> {
    let (f, g) = gradient(p, x)?;
    Some((f, p.free_vertices.iter().map(|&v| g[v as usize]).collect()))
}

/// Corners whose term is infeasible at `x`.
pub fn infeasible_corners(p: &Problem, x: &[Vec3]) -> usize {
    (0..p.num_corners())
        .into_par_iter()
        .with_min_len(CHUNK)
        .filter(|&c| p.corner_term(x, c).is_none())
        .count()
}

/// Smallest det(S) over the corners (the leading n x n block in 2D).
pub fn min_det(p: &Problem, x: &[Vec3]) -> f64 {
    (0..p.num_corners())
        .into_par_iter()
        .with_min_len(CHUNK)
        .map(|c| {
            let shape = p.shape(c);
            let s = shape.tet.s_rest(&p.corner_points(x, c), usize::MAX);
            if shape.is_surface() {
                crate::metric::surface::facing_area(&s, &shape.normal)
            } else if p.dim == 2 {
                s[0][0] * s[1][1] - s[0][1] * s[1][0]
            } else {
                crate::metric::mat3::det(&s)
            }
        })
        .reduce(|| f64::INFINITY, f64::min)
}

/// F over the corners `corners` only, infeasible ones counted as 0, and how
/// many of them are infeasible: a part's share of F (`Backend::restrict_sums`).
pub fn partial_value(p: &Problem, x: &[Vec3], corners: &[u32]) -> (f64, f64) {
    // fixed chunks added in order: the partial sum does not depend on the thread count
    let partial: Vec<(f64, f64)> = corners
        .par_chunks(CHUNK)
        .map(|cs| {
            cs.iter()
                .fold((0.0, 0.0), |(f, bad), &c| match p.corner_term(x, c as usize) {
                    Some(t) => (f + t, bad),
                    None => (f, bad + 1.0),
                })
        })
        .collect();
    partial.iter().fold((0.0, 0.0), |(f, b), &(pf, pb)| (f + pf, b + pb))
}
