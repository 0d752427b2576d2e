//! CPU twin of `shaders/line_search.wgsl`: a trial point x + alpha d at the
//! free vertices, the fixed ones copied.

use crate::metric::mat3::Vec3;

pub fn trial(x: &[Vec3], free_vertices: &[u32], alpha: f64, d: &[Vec3], out: &mut Vec<Vec3>) {
    out.clear();
    out.extend_from_slice(x);
    for (di, &v) in d.iter().zip(free_vertices) {
        let t = &mut out[v as usize];
        for c in 0..3 {
            t[c] = x[v as usize][c] + alpha * di[c];
        }
    }
}
