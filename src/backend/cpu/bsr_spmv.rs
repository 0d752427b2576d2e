//! CPU twin of `shaders/bsr_spmv.wgsl`: the symmetric Hessian in 3x3-block
//! compressed sparse rows and y = A x. Both triangles are stored so that a
//! row-parallel product needs no write conflicts (on the GPU there are no
//! float atomics either).

use crate::metric::mat3::Vec3;
use rayon::prelude::*;

pub use crate::backend::hessian_pattern::BlockCsr;

impl BlockCsr {
    /// y = A x
    pub fn mul(&self, x: &[Vec3], y: &mut [Vec3]) {
        y.par_iter_mut().with_min_len(512).enumerate().for_each(|(i, yi)| {
            let mut acc = [0.0; 3];
            for s in self.row_offsets[i] as usize..self.row_offsets[i + 1] as usize {
                let (b, xj) = (&self.blocks[s], &x[self.cols[s] as usize]);
                for r in 0..3 {
                    acc[r] += b[r][0] * xj[0] + b[r][1] * xj[1] + b[r][2] * xj[2];
                }
            }
            *yi = acc;
        });
    }
}
