//! CPU twin of `shaders/block_jacobi_factor.wgsl`: the block-Jacobi
//! preconditioner's factors, an LDL^T of each 3x3 diagonal block of the Hessian.

use crate::metric::mat3::Mat3;
use rayon::prelude::*;

/// LDL^T of each 3x3 diagonal block, D^-1 stored so that applying it is
/// multiplications only: y = L^-T (D^-1 (L^-1 x)).
#[derive(Clone, Debug, Default)]
pub struct BlockJacobi {
    /// Per block: l10, l20, l21 and 1/d0, 1/d1, 1/d2.
    factors: Vec<[f64; 6]>,
}

impl BlockJacobi {
    /// Factors the diagonal blocks; a block that is not positive definite
    /// (cannot happen for the mean ratio, but rounding is rounding) is
    /// replaced by the identity scaled to its diagonal.
    pub fn new(diag_blocks: impl IndexedParallelIterator<Item = Mat3>) -> BlockJacobi {
        BlockJacobi {
            factors: diag_blocks.map(|h| ldlt(&h)).collect(),
        }
    }

    pub fn factors(&self) -> &[[f64; 6]] {
        &self.factors
    }

    pub fn bytes(&self) -> usize {
        self.factors.len() * std::mem::size_of::<[f64; 6]>()
    }
}

fn ldlt(h: &Mat3) -> [f64; 6] {
    let d0 = h[0][0];
    let l10 = h[1][0] / d0;
    let l20 = h[2][0] / d0;
    let d1 = h[1][1] - l10 * l10 * d0;
    let l21 = (h[2][1] - l20 * l10 * d0) / d1;
    let d2 = h[2][2] - l20 * l20 * d0 - l21 * l21 * d1;
    if d0 > 0.0 && d1 > 0.0 && d2 > 0.0 && l21.is_finite() {
        [l10, l20, l21, 1.0 / d0, 1.0 / d1, 1.0 / d2]
    } else {
        let s = (h[0][0].abs() + h[1][1].abs() + h[2][2].abs()) / 3.0;
        let inv = if s > 0.0 { 1.0 / s } else { 1.0 };
        [0.0, 0.0, 0.0, inv, inv, inv]
    }
}
