//! CPU twin of `shaders/project_boundary.wgsl`: puts each sliding vertex at
//! the closest point of its candidate primitives of the original boundary
//! (`problem::boundary`), and the constrained Newton step of one vertex that
//! BCD and smart Laplace share. The closest point on a triangle is Ericson's
//! (Real-Time Collision Detection, 5.1.5): the Voronoi region of the point
//! decides between a vertex, an edge and the face, so it is exact for every
//! triangle shape; a segment is stored as `[a, b, b]`.

use crate::metric::mat3::{Mat3, Vec3, cross, dot, mul_vec, sub, unit};
use crate::problem::boundary::{IDENTITY, Sliding, line_projector, plane_projector};
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

/// The gradient mapping's step, in lengths of a vertex's nearest primitive
/// (its longest edge): short enough that inside a face it reads the face's
/// own tangential gradient, long enough that f32 resolves where it ends.
pub const MAPPING_STEP: f64 = 1e-2;

/// The mapping counts as not moving, two points as on one edge and two
/// distances as tied, within this fraction of its step: far above f32's
/// rounding, so that a GPU in f32 decides as the CPU in f64 does. What a
/// vertex held or kept on a crease this way still has of the gradient
/// mapping is below this fraction of its gradient.
pub const MAPPING_EPS: f64 = 1e-3;

/// The candidate of vertex `v` nearest to `p` and the closest point on it,
/// decided the same whatever the candidates' order: among those within
/// `eps` of the nearest distance, one that passes within `eps` of `at`
/// (the face a step from `at` travels in), then the lowest index.
fn nearest_from(s: &Sliding, v: usize, p: &Vec3, at: &Vec3, eps: f64) -> (usize, Vec3) {
    let near = s
        .candidates
        .of(v)
        .iter()
        .map(|&c| dist(&closest_on_triangle(p, &s.primitives[c as usize]), p))
        .fold(f64::INFINITY, f64::min);
    let mut best: Option<(bool, usize, Vec3)> = None;
    for &c in s.candidates.of(v) {
        let t = &s.primitives[c as usize];
        let q = closest_on_triangle(p, t);
        if dist(&q, p) > near + eps {
            continue;
        }
        let holds = dist(&closest_on_triangle(at, t), at) <= eps;
        let better = match &best {
            None => true,
            Some((h, i, _)) => (holds, std::cmp::Reverse(c as usize)) > (*h, std::cmp::Reverse(*i)),
        };
        if better {
            best = Some((holds, c as usize, q));
        }
    }
    let (_, i, q) = best.expect("a sliding vertex has candidates");
    (i, q)
}

/// The longest edge of the candidates of vertex `v`: the length the
/// gradient mapping's step scales with.
fn candidate_length(s: &Sliding, v: usize) -> f64 {
    s.candidates
        .of(v)
        .iter()
        .map(|&c| {
            let t = &s.primitives[c as usize];
            dist(&t[0], &t[1]).max(dist(&t[1], &t[2])).max(dist(&t[2], &t[0]))
        })
        .fold(0.0, f64::max)
}

fn dist(a: &Vec3, b: &Vec3) -> f64 {
    let d = sub(a, b);
    dot(&d, &d).sqrt()
}

/// The projector of the constraint that is active for sliding vertex `v` at
/// `x` with unconstrained gradient `g`: the boundary is piecewise flat, so
/// the directions a vertex may move in are those of the face, crease or
/// point the gradient mapping Proj(x - t g) leads it to (t|g| a short step,
/// `MAPPING_STEP`):
/// - the mapping does not move (-g lies in the normal cone, as at a crease
///   the minimiser sits on, or g is zero): zero, the vertex holds this step;
/// - it stays on an edge of a triangle that the vertex lies on too, where
///   the faces meeting there are not coplanar (a crease), or ends on a
///   segment of a feature curve: that line's t t^T;
/// - otherwise the plane of the face it ends in, I - n n^T.
///
/// So |P g| is the norm of the gradient mapping (zero exactly where the
/// vertex is stationary on the faceted boundary), and Newton's model holds
/// on the face or crease the step stays on; a fixed projector from the
/// start's averaged normal is neither.
pub fn active_projector(s: &Sliding, v: usize, x: &Vec3, g: &Vec3) -> Mat3 {
    if !s.slides(v) {
        return IDENTITY;
    }
    let len = candidate_length(s, v);
    let q0 = project_vertex(s, v, x);
    let gg = dot(g, g);
    let step = MAPPING_STEP * len;
    let eps = MAPPING_EPS * step;
    if !(gg > 0.0) {
        return [[0.0; 3]; 3];
    }
    let t = step / gg.sqrt();
    let back = [x[0] - t * g[0], x[1] - t * g[1], x[2] - t * g[2]];
    let (i1, q1) = nearest_from(s, v, &back, &q0, eps);
    if dist(&q1, &q0) <= eps {
        return [[0.0; 3]; 3];
    }
    let [a, b, c] = &s.primitives[i1];
    if b == c {
        return line_projector(&unit(sub(b, a)));
    }
    for (e0, e1) in [(a, b), (b, c), (c, a)] {
        let on = |q: &Vec3| dist(&closest_on_segment(q, e0, e1), q) <= eps;
        if on(&q0) && on(&q1) && is_crease(s, v, i1, e0, e1) {
            return line_projector(&unit(sub(e1, e0)));
        }
    }
    plane_projector(&normal(&s.primitives[i1]))
}

/// Two faces meeting at an edge form a crease when the sine of the angle
/// between their normals exceeds this: coplanar faces (a flat side split
/// into triangles) do not, whatever rounding says.
pub const CREASE_SIN: f64 = 1e-5;

fn normal(t: &[Vec3; 3]) -> Vec3 {
    unit(cross(&sub(&t[1], &t[0]), &sub(&t[2], &t[0])))
}

/// Whether the edge (e0, e1) of candidate triangle `t` of vertex `v` is a
/// crease: another candidate triangle shares it at an angle, or none shares
/// it (the rim of the candidates, past which the vertex cannot go).
fn is_crease(s: &Sliding, v: usize, t: usize, e0: &Vec3, e1: &Vec3) -> bool {
    let n = normal(&s.primitives[t]);
    let mut shared = false;
    for &c in s.candidates.of(v) {
        let tri = &s.primitives[c as usize];
        if c as usize == t || tri[1] == tri[2] {
            continue;
        }
        if tri.contains(e0) && tri.contains(e1) {
            shared = true;
            let m = cross(&n, &normal(tri));
            if dot(&m, &m) > CREASE_SIN * CREASE_SIN {
                return true;
            }
        }
    }
    !shared
}

/// The active projector (`active_projector`) of every free vertex, in the
/// problem's numbering (the identity where a vertex does not slide), for
/// the gradient `g` (free numbering) at `x`.
pub fn active_projectors(s: &Sliding, free_vertices: &[u32], x: &[Vec3], g: &[Vec3]) -> Vec<Mat3> {
    let mut out = vec![IDENTITY; x.len()];
    let found: Vec<(usize, Mat3)> = free_vertices
        .par_iter()
        .with_min_len(1024)
        .zip(g)
        .filter(|(v, _)| s.slides(**v as usize))
        .map(|(&v, gv)| (v as usize, active_projector(s, v as usize, &x[v as usize], gv)))
        .collect();
    for (v, m) in found {
        out[v] = m;
    }
    out
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

    /// One vertex sliding on two triangles sharing the edge from the origin
    /// to (1, 0, 0): a convex ridge, or a flat pair with `drop` zero.
    fn ridge(drop: f64) -> Sliding {
        let (p0, p1) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]);
        Sliding {
            projector: vec![IDENTITY],
            candidates: crate::mesh::topology::Csr::from_pairs(1, [(0, 0), (0, 1)].into_iter()),
            primitives: vec![[p0, p1, [0.5, 1.0, -drop]], [p0, [0.5, -1.0, -drop], p1]],
            counts: [1, 0, 0],
        }
    }

    fn close(a: &Mat3, b: &Mat3) -> bool {
        (0..3).all(|i| (0..3).all(|j| (a[i][j] - b[i][j]).abs() < 1e-12))
    }

    /// The gradient mapping (x - Proj(x - t g)) / t for a short step t.
    fn mapping(s: &Sliding, x: &Vec3, g: &Vec3) -> Vec3 {
        let t = 1e-4;
        let q = project_vertex(s, 0, &[x[0] - t * g[0], x[1] - t * g[1], x[2] - t * g[2]]);
        sub(x, &q).map(|c| c / t)
    }

    /// On a crease the projector follows the gradient mapping: zero where
    /// -g lies between the two faces' normals (the vertex is stationary
    /// though g is not zero), the crease's direction where g also runs along
    /// it, a face's plane where -g leads into that face; inside a face, that
    /// face's plane, and P g is the gradient mapping.
    #[test]
    fn the_active_projector_follows_the_gradient_mapping() {
        let s = ridge(0.2);
        let on = [0.5, 0.0, 0.0];
        let zero = [[0.0; 3]; 3];
        let up = [0.0, 0.0, -1.0];
        assert!(close(&active_projector(&s, 0, &on, &up), &zero));
        assert!(mapping(&s, &on, &up).iter().all(|c| c.abs() < 1e-12));
        let along = [0.3, 0.0, -1.0];
        assert!(close(
            &active_projector(&s, 0, &on, &along),
            &line_projector(&[1.0, 0.0, 0.0])
        ));
        let n_a = unit(cross(&[1.0, 0.0, 0.0], &[0.5, 1.0, -0.2]));
        assert!(close(
            &active_projector(&s, 0, &on, &[0.0, -1.0, 0.0]),
            &plane_projector(&n_a)
        ));
        // inside face A
        let x = [0.5, 0.3, -0.06];
        let g = [1.0, 2.0, 3.0];
        let p = active_projector(&s, 0, &x, &g);
        assert!(close(&p, &plane_projector(&n_a)));
        let (pg, m) = (mul_vec(&p, &g), mapping(&s, &x, &g));
        assert!(dist(&pg, &m) < 1e-9, "{pg:?} vs {m:?}");
        // the same edge between coplanar faces is no crease
        let flat = ridge(0.0);
        let p = active_projector(&flat, 0, &on, &[0.3, 0.0, 0.0]);
        assert!(close(&p, &plane_projector(&[0.0, 0.0, 1.0])), "{p:?}");
    }

    /// The decision does not depend on the order of the candidates.
    #[test]
    fn the_active_projector_does_not_depend_on_candidate_order() {
        let s = ridge(0.2);
        let mut r = s.clone();
        r.primitives.swap(0, 1);
        for g in [[0.0, -1.0, 0.0], [0.0, 1.0, 0.0], [0.3, 0.0, -1.0], [0.2, 0.5, -0.1]] {
            for x in [[0.5, 0.0, 0.0], [0.0, 0.0, 0.0], [0.4, 0.2, -0.04]] {
                assert!(close(
                    &active_projector(&s, 0, &x, &g),
                    &active_projector(&r, 0, &x, &g)
                ));
            }
        }
    }
}
