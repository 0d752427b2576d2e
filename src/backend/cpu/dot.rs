//! CPU twin of `shaders/dot.wgsl`: a . b and max_i |b_i|^2, summed in the
//! fixed chunks of `reduce` (the GPU's tree differs from it by rounding only).

use super::reduce::{CHUNK, in_order};
use crate::metric::mat3::Vec3;
use rayon::prelude::*;

/// (a . b, max_i |b_i|^2); the max only `with_max` (0 otherwise): most
/// callers do not need it, and it costs as much as the dot.
pub fn dot(a: &[Vec3], b: &[Vec3], with_max: bool) -> (f64, f64) {
    assert_eq!(a.len(), b.len());
    // one running sum per chunk, in index order: the bits of earlier versions
    let chunk = |(u, v): (&[Vec3], &[Vec3])| {
        let (mut s, mut m) = (0.0, 0.0f64);
        for (p, q) in u.iter().zip(v) {
            s += p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
            if with_max {
                m = m.max(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
            }
        }
        (s, m)
    };
    if a.len() <= CHUNK {
        return chunk((a, b));
    }
    let partials: Vec<(f64, f64)> = a.par_chunks(CHUNK).zip(b.par_chunks(CHUNK)).map(chunk).collect();
    let sum = in_order(&partials.iter().map(|p| p.0).collect::<Vec<_>>());
    (sum, partials.iter().fold(0.0f64, |m, p| m.max(p.1)))
}

/// (a . b, max |b_i|^2) over the entries `idx` only, in their order: a
/// part's share (`Backend::restrict_sums`).
pub fn dot_over(a: &[Vec3], b: &[Vec3], idx: &[u32]) -> (f64, f64) {
    let (mut s, mut m) = (0.0, 0.0f64);
    for &i in idx {
        let (x, y) = (&a[i as usize], &b[i as usize]);
        s += x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
        m = m.max(y[0] * y[0] + y[1] * y[1] + y[2] * y[2]);
    }
    (s, m)
}
