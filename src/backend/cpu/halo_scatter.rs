//! CPU twin of `shaders/halo_scatter.wgsl`: the receive side of a halo
//! exchange, the listed entries of a vec3 array overwritten in list order.

use crate::metric::mat3::Vec3;

/// `dst[at(idx[k])] = data[3k..3k + 3]` for each k.
pub fn scatter(dst: &mut [Vec3], idx: &[u32], at: impl Fn(u32) -> usize, data: &[f64]) {
    for (&i, v) in idx.iter().zip(data.chunks_exact(3)) {
        dst[at(i)] = [v[0], v[1], v[2]];
    }
}
