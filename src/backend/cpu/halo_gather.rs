//! CPU twin of `shaders/halo_gather.wgsl`: the send side of a halo
//! exchange, the listed entries of a vec3 array appended in list order.

use crate::metric::mat3::Vec3;

/// Appends `src[at(i)]` for each `i` of `idx` to `out`.
pub fn gather(src: &[Vec3], idx: &[u32], at: impl Fn(u32) -> usize, out: &mut Vec<f64>) {
    out.reserve(3 * idx.len());
    for &i in idx {
        out.extend_from_slice(&src[at(i)]);
    }
}
