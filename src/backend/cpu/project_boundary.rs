//! CPU twin of `shaders/project_boundary.wgsl`: puts each sliding vertex at
//! the closest point of its candidate primitives of the original boundary
//! (`problem::boundary`), and the constrained Newton step of one vertex that
//! BCD and smart Laplace share. The closest point on a triangle is Ericson's
//! (Real-Time Collision Detection, 5.1.5): the Voronoi region of the point
//! decides between a vertex, an edge and the face, so it is exact for every
//! triangle shape; a segment is stored as `[a, b, b]`.

use crate::metric::mat3::{Mat3, Vec3, dot, mul_vec, sub};
use crate::problem::boundary::Sliding;
use rayon::prelude::*;

fn lerp(a: &Vec3, d: &Vec3, t: f64) -> Vec3 {
    [a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2]]
}

/// The closest point to `p` on the segment from `a` to `b`.
pub fn closest_on_segment(p: &Vec3, a: &Vec3, b: &Vec3) -> Vec3 {
    let ab = sub(b, a);
    let len2 = dot(&ab, &ab);
    if !(len2 > 0.0) {
        return *a;
    }
    let t = (dot(&sub(p, a), &ab) / len2).clamp(0.0, 1.0);
    lerp(a, &ab, t)
}

/// The closest point to `p` on triangle `t` (a segment when `t[2] == t[1]`).
pub fn closest_on_triangle(p: &Vec3, t: &[Vec3; 3]) -> Vec3 {
    let (a, b, c) = (&t[0], &t[1], &t[2]);
    if b == c {
        return closest_on_segment(p, a, b);
    }
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(&ab, &ap);
    let d2 = dot(&ac, &ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return *a;
    }
    let bp = sub(p, b);
    let d3 = dot(&ab, &bp);
    let d4 = dot(&ac, &bp);
    if d3 >= 0.0 && d4 <= d3 {
        return *b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return lerp(a, &ab, d1 / (d1 - d3));
    }
    let cp = sub(p, c);
    let d5 = dot(&ab, &cp);
    let d6 = dot(&ac, &cp);
    if d6 >= 0.0 && d5 <= d6 {
        return *c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return lerp(a, &ac, d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let bc = sub(c, b);
        return lerp(b, &bc, (d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    [
        a[0] + ab[0] * v + ac[0] * w,
        a[1] + ab[1] * v + ac[1] * w,
        a[2] + ab[2] * v + ac[2] * w,
    ]
}

/// The closest point to `p` over the candidates of vertex `v` (the first
/// one on ties), or `p` itself when `v` does not slide.
pub fn project_vertex(s: &Sliding, v: usize, p: &Vec3) -> Vec3 {
    let mut best = *p;
    let mut best_d = f64::INFINITY;
    for &prim in s.candidates.of(v) {
        let q = closest_on_triangle(p, &s.primitives[prim as usize]);
        let e = sub(&q, p);
        let d = dot(&e, &e);
        if d < best_d {
            best_d = d;
            best = q;
        }
    }
    best
}

/// Every sliding vertex of `x` onto the original boundary.
pub fn project(s: &Sliding, free_vertices: &[u32], x: &mut [Vec3]) {
    let moved: Vec<(usize, Vec3)> = free_vertices
        .par_iter()
        .with_min_len(1024)
        .filter(|&&v| s.slides(v as usize))
        .map(|&v| (v as usize, project_vertex(s, v as usize, &x[v as usize])))
        .collect();
    for (v, q) in moved {
        x[v] = q;
    }
}

/// The Newton system of one constrained vertex: P g and P H P + (I - P),
/// whose solution lies in the range of P (the tangent directions) and is
/// the Newton step of F restricted to them.
pub fn constrain_block(p: &Mat3, g: &Vec3, h: &Mat3) -> (Vec3, Mat3) {
    let pg = mul_vec(p, g);
    let hp = mul3(h, p);
    let mut out = mul3(p, &hp);
    for i in 0..3 {
        for j in 0..3 {
            out[i][j] += if i == j { 1.0 } else { 0.0 } - p[i][j];
        }
    }
    (pg, out)
}

/// a b
pub fn mul3(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The brute-force answer: the best of a fine barycentric grid and the edges.
    fn dist(p: &Vec3, q: &Vec3) -> f64 {
        dot(&sub(p, q), &sub(p, q)).sqrt()
    }

    #[test]
    fn closest_point_on_triangle_beats_every_sample_and_lies_on_it() {
        let t = [[0.1, -0.3, 0.2], [1.3, 0.1, -0.2], [0.2, 0.9, 0.7]];
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 4.0 - 2.0
        };
        for _ in 0..200 {
            let p = [rnd(), rnd(), rnd()];
            let q = closest_on_triangle(&p, &t);
            let dq = dist(&p, &q);
            let n = 60;
            for i in 0..=n {
                for j in 0..=(n - i) {
                    let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                    let s = [0, 1, 2].map(|k| t[0][k] + u * (t[1][k] - t[0][k]) + v * (t[2][k] - t[0][k]));
                    assert!(dq <= dist(&p, &s) + 1e-12, "{p:?}: {q:?} farther than sample {s:?}");
                }
            }
            // q is in the triangle's plane and inside it (barycentric >= 0)
            let n = {
                let (a, b) = (sub(&t[1], &t[0]), sub(&t[2], &t[0]));
                [
                    a[1] * b[2] - a[2] * b[1],
                    a[2] * b[0] - a[0] * b[2],
                    a[0] * b[1] - a[1] * b[0],
                ]
            };
            assert!(dot(&n, &sub(&q, &t[0])).abs() < 1e-12);
        }
        let q = closest_on_triangle(&[0.5, 0.5, 3.0], &[[0.0; 3], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]);
        assert_eq!(q, [0.5, 0.0, 0.0]);
    }

    #[test]
    fn constrained_block_solves_in_the_tangent_plane() {
        let n = [0.6, 0.0, 0.8];
        let mut p = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        for i in 0..3 {
            for j in 0..3 {
                p[i][j] -= n[i] * n[j];
            }
        }
        let h = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]];
        let g = [1.0, -2.0, 0.5];
        let (pg, a) = constrain_block(&p, &g, &h);
        let d = crate::metric::mat3::cholesky_solve(&a, &pg.map(|c| -c)).unwrap();
        // d is tangent, and the tangent part of H d + g vanishes
        assert!(dot(&d, &n).abs() < 1e-14);
        let r = mul_vec(&p, &[0, 1, 2].map(|i| dot(&h[i], &d) + g[i]));
        assert!(r.iter().all(|c| c.abs() < 1e-14), "{r:?}");
    }
}
