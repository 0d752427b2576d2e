//! CPU twin of `shaders/dot.wgsl`: a . b and max_i |b_i|^2, summed in the
//! fixed chunks of `reduce` (the GPU's tree differs from it by rounding only).

use crate::metric::mat3::Vec3;

/// (a . b, max_i |b_i|^2)
pub fn dot(a: &[Vec3], b: &[Vec3]) -> (f64, f64) {
    assert_eq!(a.len(), b.len());
    let pairs: Vec<(&Vec3, &Vec3)> = a.iter().zip(b).collect();
    super::reduce::sum_max(&pairs, |(u, v)| {
        (
            u[0] * v[0] + u[1] * v[1] + u[2] * v[2],
            v[0] * v[0] + v[1] * v[1] + v[2] * v[2],
        )
    })
}
