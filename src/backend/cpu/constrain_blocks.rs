//! CPU twin of `shaders/constrain_blocks.wgsl`: the Hessian over the free
//! vertices restricted to the directions they may move in, H_ij <- P_i H_ij P_j,
//! plus I - P_i on each diagonal block so the system stays definite. PCG on
//! it, with a right-hand side -P g, stays in the tangent space (every block
//! and the block-Jacobi factors map tangent vectors to tangent vectors), so
//! Newton's direction is the Newton step of F restricted to the tangent
//! spaces: a reduced basis without a change of variables.

use super::bsr_spmv::BlockCsr;
use super::project_boundary::mul3;
use crate::metric::mat3::Mat3;
use rayon::prelude::*;

pub fn constrain_blocks(projector: &[Mat3], free_vertices: &[u32], m: &mut BlockCsr) {
    let mut row = vec![0u32; m.blocks.len()];
    for i in 0..m.rows() {
        row[m.row_offsets[i] as usize..m.row_offsets[i + 1] as usize].fill(i as u32);
    }
    let (cols, diag) = (&m.cols, &m.diag);
    m.blocks
        .par_iter_mut()
        .with_min_len(1024)
        .enumerate()
        .for_each(|(s, blk)| {
            let i = row[s] as usize;
            let pi = &projector[free_vertices[i] as usize];
            let pj = &projector[free_vertices[cols[s] as usize] as usize];
            let mut c = mul3(pi, &mul3(blk, pj));
            if s == diag[i] as usize {
                for r in 0..3 {
                    for q in 0..3 {
                        c[r][q] += if r == q { 1.0 } else { 0.0 } - pi[r][q];
                    }
                }
            }
            *blk = c;
        });
}
