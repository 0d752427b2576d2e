//! CPU twin of `shaders/dot.wgsl`: a . b and max_i |b_i|^2, summed in the
//! fixed chunks of `reduce` (the GPU's tree differs from it by rounding only).

use super::reduce::{CHUNK, in_order};
use crate::metric::mat3::Vec3;
use rayon::prelude::*;

/// Independent partial sums within a chunk: one running sum is bound by the
/// latency of an add, and CG's dots are most of a small problem's CG time.
const LANES: usize = 4;

/// (a . b, max_i |b_i|^2); the max only `with_max` (0 otherwise), since most
/// callers do not need it and it costs as much as the dot.
pub fn dot(a: &[Vec3], b: &[Vec3], with_max: bool) -> (f64, f64) {
    assert_eq!(a.len(), b.len());
    let chunk = |(u, v): (&[Vec3], &[Vec3])| {
        let (mut s, mut m) = ([0.0; LANES], [0.0f64; LANES]);
        let (uc, vc) = (u.chunks_exact(LANES), v.chunks_exact(LANES));
        let (ur, vr) = (uc.remainder(), vc.remainder());
        for (p, q) in uc.zip(vc) {
            for l in 0..LANES {
                s[l] += p[l][0] * q[l][0] + p[l][1] * q[l][1] + p[l][2] * q[l][2];
                if with_max {
                    m[l] = m[l].max(q[l][0] * q[l][0] + q[l][1] * q[l][1] + q[l][2] * q[l][2]);
                }
            }
        }
        for (l, (p, q)) in ur.iter().zip(vr).enumerate() {
            s[l] += p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
            if with_max {
                m[l] = m[l].max(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
            }
        }
        ((s[0] + s[1]) + (s[2] + s[3]), m[0].max(m[1]).max(m[2].max(m[3])))
    };
    if a.len() <= CHUNK {
        return chunk((a, b));
    }
    let partials: Vec<(f64, f64)> = a.par_chunks(CHUNK).zip(b.par_chunks(CHUNK)).map(chunk).collect();
    let sum = in_order(&partials.iter().map(|p| p.0).collect::<Vec<_>>());
    (sum, partials.iter().fold(0.0f64, |m, p| m.max(p.1)))
}
