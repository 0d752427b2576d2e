//! CPU twin of `shaders/hessian_gather.wgsl`: the Hessian blocks as sums of
//! their corners' weighted contributions, in ascending (problem) corner
//! order. The CPU fuses this with `hessian_assemble` (each row range adds a
//! corner's blocks as soon as they are evaluated). The kernel adds in
//! ascending device corner order (so that it can run in windows of corners),
//! which is this order under `DeviceLayout::Problem` and a reordering of it
//! otherwise.

use crate::metric::mat3::Mat3;

/// Adds the row `a` of a corner's 4x4 vertex blocks `h_a`, times `scale`,
/// into the matrix slots `slots` (offset by `base`; `u32::MAX` = a fixed vertex).
#[inline]
pub fn add_row(blocks: &mut [Mat3], base: u32, slots: &[u32], h_a: &[Mat3; 4], scale: f64) {
    for (b, &s) in slots.iter().enumerate() {
        if s != u32::MAX {
            let blk = &mut blocks[(s - base) as usize];
            for c in 0..3 {
                for q in 0..3 {
                    blk[c][q] += h_a[b][c][q] * scale;
                }
            }
        }
    }
}
