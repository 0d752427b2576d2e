//! CPU twin of `shaders/axpby.wgsl`: y = a x + b y, with b = 0 meaning
//! "overwrite" (y is not read, so a NaN in it does not survive).

use crate::metric::mat3::Vec3;
use rayon::prelude::*;

pub fn axpby(a: f64, x: &[Vec3], b: f64, y: &mut [Vec3]) {
    y.par_iter_mut().with_min_len(4096).zip(x).for_each(|(yi, xi)| {
        for c in 0..3 {
            yi[c] = if b == 0.0 { a * xi[c] } else { a * xi[c] + b * yi[c] };
        }
    });
}

/// y = (a + b) y, the aliased case x == y.
pub fn scale(a: f64, b: f64, y: &mut [Vec3]) {
    y.par_iter_mut().with_min_len(4096).for_each(|yi| {
        for c in 0..3 {
            yi[c] = if b == 0.0 { a * yi[c] } else { a * yi[c] + b * yi[c] };
        }
    });
}
