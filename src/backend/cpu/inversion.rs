//! CPU twin of `shaders/inversion.wgsl`: the fraction of the way from the
//! current positions to the trial at which a corner first inverts
//! (`metric::det_path`), the minimum over the corners (+inf if none does;
//! the GPU writes its largest real instead).

use super::reduce::CHUNK;
use crate::metric::mat3::Vec3;
use crate::problem::Problem;
use rayon::prelude::*;

/// The smallest first-inversion fraction over all corners from `x` to `y`.
pub fn first_inversion(p: &Problem, x: &[Vec3], y: &[Vec3]) -> f64 {
    (0..p.num_corners())
        .into_par_iter()
        .with_min_len(CHUNK)
        .map(|c| corner_first_inversion(p, x, y, c))
        .reduce(|| f64::INFINITY, f64::min)
}

/// One corner's fraction.
pub fn corner_first_inversion(p: &Problem, x: &[Vec3], y: &[Vec3], c: usize) -> f64 {
    let shape = p.shape(c);
    let tet = &shape.tet;
    let s0 = tet.s_rest(&p.corner_points(x, c), usize::MAX);
    let s1 = tet.s_rest(&p.corner_points(y, c), usize::MAX);
    let e = [0, 1, 2].map(|i| [0, 1, 2].map(|j| s1[i][j] - s0[i][j]));
    if shape.is_surface() {
        let c = crate::metric::det_path::facing_coefficients(&s0, &e, &shape.normal);
        return crate::metric::det_path::first_root(c);
    }
    crate::metric::det_path::first_inversion(&s0, &e, p.dim)
}
