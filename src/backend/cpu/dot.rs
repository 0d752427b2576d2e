//! CPU twin of `shaders/dot.wgsl` and `shaders/reduce.wgsl` for vectors:
//! a . b and max_i |b_i|^2, summed in fixed chunks so that the result repeats
//! bit for bit (the GPU's tree differs from it by rounding only).

use crate::metric::mat3::Vec3;
use rayon::prelude::*;

const CHUNK: usize = 4096;

/// (a . b, max_i |b_i|^2)
pub fn dot(a: &[Vec3], b: &[Vec3]) -> (f64, f64) {
    let parts: Vec<(f64, f64)> = a
        .par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(x, y)| {
            x.iter().zip(y).fold((0.0, 0.0f64), |(s, m), (u, v)| {
                (
                    s + (u[0] * v[0] + u[1] * v[1] + u[2] * v[2]),
                    m.max(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]),
                )
            })
        })
        .collect();
    parts
        .iter()
        .fold((0.0, 0.0f64), |(s, m), &(ps, pm)| (s + ps, m.max(pm)))
}
