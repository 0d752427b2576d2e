//! CPU twin of `shaders/constrain.wgsl`: a free-vertex vector restricted to
//! the directions each vertex may move in, v_i <- P_i v_i (P the identity
//! off a sliding boundary). Applied to the gradient wherever it is made, so
//! that every solver and the stopping test see the gradient of F on the
//! constrained set.

use crate::metric::mat3::{Mat3, Vec3, mul_vec};
use rayon::prelude::*;

pub fn constrain(projector: &[Mat3], free_vertices: &[u32], v: &mut [Vec3]) {
    v.par_iter_mut()
        .with_min_len(1024)
        .zip(free_vertices)
        .for_each(|(vi, &w)| *vi = mul_vec(&projector[w as usize], vi));
}
