//! CPU twin of `shaders/hessian_assemble.wgsl` and `shaders/hessian_gather.wgsl`:
//! the global Hessian over the free vertices in 3x3-block compressed sparse
//! rows, and the free gradient. The CPU fuses the two kernels: each row range
//! evaluates its corners' blocks (`Model::blocks`, times the corner weight, as
//! `hessian_assemble.wgsl` stores them) and sums them into its own rows in
//! ascending corner order (the order `hessian_gather.wgsl` sums them in).

pub use crate::backend::hessian_pattern::{HessianPattern, RowRange};
use crate::metric::mat3::Vec3;
use crate::problem::Problem;
use rayon::prelude::*;

impl HessianPattern {
    /// Assembles the free gradient and the Hessian of F at `x` into `grad`
    /// (indexed by free index) and `self.matrix`. `false` if an element is infeasible.
    pub fn assemble(&mut self, p: &Problem, x: &[Vec3], grad: &mut [Vec3]) -> bool {
        let nslots = p.dim + 1;
        let offsets = &self.matrix.row_offsets;
        // hand each range its own rows of blocks and gradient
        let mut parts = Vec::with_capacity(self.ranges.len());
        let (mut blocks, mut grads) = (&mut self.matrix.blocks[..], &mut grad[..]);
        for r in &self.ranges {
            let nb = (offsets[r.end as usize] - offsets[r.start as usize]) as usize;
            let (b, rest_b) = blocks.split_at_mut(nb);
            let (g, rest_g) = grads.split_at_mut((r.end - r.start) as usize);
            parts.push((r, b, g));
            blocks = rest_b;
            grads = rest_g;
        }
        let (free_index, slots) = (&self.free_index, &self.slots);
        parts.into_par_iter().all(|(r, blocks, grads)| {
            blocks.iter_mut().for_each(|b| *b = [[0.0; 3]; 3]);
            grads.iter_mut().for_each(|g| *g = [0.0; 3]);
            let base = offsets[r.start as usize];
            let mut h = [[[[0.0; 3]; 3]; 4]; 4];
            for &e in &r.elements {
                let e = e as usize;
                let Some((_, g)) = p.model.blocks(p.shape(e), &p.corner_points(x, e), &mut h) else {
                    return false;
                };
                let scale = p.corner_weight[e];
                let t = &p.corners[e];
                for a in 0..nslots {
                    let i = free_index[t[a] as usize];
                    if i < r.start || i >= r.end {
                        continue;
                    }
                    let gi = &mut grads[(i - r.start) as usize];
                    for c in 0..3 {
                        gi[c] += g[a][c] * scale;
                    }
                    super::hessian_gather::add_row(blocks, base, &slots[e][4 * a..4 * a + nslots], &h[a], scale);
                }
            }
            true
        })
    }
}
