//! CPU twin of `shaders/block_jacobi.wgsl`: y = M^-1 x with the factors of
//! `block_jacobi_factor`.

pub use super::block_jacobi_factor::BlockJacobi;
use crate::metric::mat3::Vec3;
use rayon::prelude::*;

impl BlockJacobi {
    /// y = M^-1 x
    pub fn apply(&self, x: &[Vec3], y: &mut [Vec3]) {
        y.par_iter_mut()
            .with_min_len(1024)
            .zip(x)
            .zip(self.factors())
            .for_each(|((yi, xi), f)| {
                let [l10, l20, l21, i0, i1, i2] = *f;
                // L^-1
                let z0 = xi[0];
                let z1 = xi[1] - l10 * z0;
                let z2 = xi[2] - l20 * z0 - l21 * z1;
                // D^-1
                let (w0, w1, w2) = (z0 * i0, z1 * i1, z2 * i2);
                // L^-T
                let y2 = w2;
                let y1 = w1 - l21 * y2;
                let y0 = w0 - l10 * y1 - l20 * y2;
                *yi = [y0, y1, y2];
            });
    }
}
