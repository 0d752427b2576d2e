//! The inverse mean ratio of a planar corner, eta = |S|^2 / (2 det S) for
//! the 2x2 S, in closed form: the CPU's path for triangles and quadrilaterals
//! under the harmonic template (the planar meshes the Newton comparisons with
//! Mesquite run on). It is `smetric::imr` with n = 2 and its structured
//! Hessian written out for 2x2 blocks; the tests hold the two together.
//!
//! With d = det S, C = cof S and eta as above, grad eta = (S - eta C) / d and
//! the block of B rows u, v is
//!
//! ```text
//! (u.v / d) I - ((S u)(C v)^T + (C u)(S v)^T) / d^2
//!     + 2 eta (C u)(C v)^T / d^2 - (eta / d) (u x v)_z J,   J = [[0, 1], [-1, 0]]
//! ```
//!
//! with z rows and columns zero (the caller puts 1 on a vertex's own z
//! diagonal, so that z never moves).

use super::mat3::{Mat3, Vec3};
use super::mean_ratio::TetShape;

/// What the value, gradient and blocks share.
pub struct Parts {
    /// The corner's inverse mean ratio.
    pub eta: f64,
    d: f64,
    s: [[f64; 2]; 2],
    c: [[f64; 2]; 2],
    g: [[f64; 2]; 2],
}

/// The leading 2x2 block of S = sum_k x_k b_k^T over a planar corner's
/// three vertices (the rest of S is never read in 2D).
#[inline]
pub fn s_of(tet: &TetShape, x: &[Vec3; 4]) -> Mat3 {
    let (b0, b1, b2) = (tet.b(0), tet.b(1), tet.b(2));
    let e = |i: usize, j: usize| x[0][i] * b0[j] + x[1][i] * b1[j] + x[2][i] * b2[j];
    [[e(0, 0), e(0, 1), 0.0], [e(1, 0), e(1, 1), 0.0], [0.0; 3]]
}

/// The inverse mean ratio of a planar corner from its 2x2 block of S; `None` when det <= 0 or not finite.
#[inline]
pub fn value_of_s(s: &Mat3) -> Option<f64> {
    let d = s[0][0] * s[1][1] - s[0][1] * s[1][0];
    if !(d > 0.0) {
        return None;
    }
    let f = s[0][0] * s[0][0] + s[0][1] * s[0][1] + s[1][0] * s[1][0] + s[1][1] * s[1][1];
    let eta = f / (2.0 * d);
    eta.is_finite().then_some(eta)
}

/// The shared parts of the value, gradient and blocks from the 2x2 block of S; `None` when infeasible.
#[inline]
pub fn parts(s: &Mat3) -> Option<Parts> {
    let eta = value_of_s(s)?;
    let d = s[0][0] * s[1][1] - s[0][1] * s[1][0];
    let s2 = [[s[0][0], s[0][1]], [s[1][0], s[1][1]]];
    let c = [[s[1][1], -s[1][0]], [-s[0][1], s[0][0]]];
    let g = std::array::from_fn(|i| std::array::from_fn(|j| (s2[i][j] - eta * c[i][j]) / d));
    Some(Parts { eta, d, s: s2, c, g })
}

fn mv(m: &[[f64; 2]; 2], v: &Vec3) -> [f64; 2] {
    [m[0][0] * v[0] + m[0][1] * v[1], m[1][0] * v[0] + m[1][1] * v[1]]
}

impl Parts {
    /// The gradient of eta with respect to the vertex whose B row is `b` (z component 0).
    #[inline]
    pub fn gradient(&self, b: &Vec3) -> Vec3 {
        let g = mv(&self.g, b);
        [g[0], g[1], 0.0]
    }

    /// The block of rows `u` and `v` (z row and column zero).
    #[inline]
    pub fn block(&self, u: &Vec3, v: &Vec3) -> Mat3 {
        let (su, cu, sv, cv) = (mv(&self.s, u), mv(&self.c, u), mv(&self.s, v), mv(&self.c, v));
        let d = self.d;
        let diag = (u[0] * v[0] + u[1] * v[1]) / d;
        let cross = -1.0 / (d * d);
        let cc = 2.0 * self.eta / (d * d);
        let skew = -self.eta / d * (u[0] * v[1] - u[1] * v[0]);
        let mut m = [[0.0; 3]; 3];
        for i in 0..2 {
            for q in 0..2 {
                m[i][q] = cross * (su[i] * cv[q] + cu[i] * sv[q]) + cc * cu[i] * cv[q];
            }
            m[i][i] += diag;
        }
        m[0][1] += skew;
        m[1][0] -= skew;
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::smetric::{MetricKind, eval};

    #[test]
    fn closed_form_is_the_general_inverse_mean_ratio() {
        let s = [[1.3, 0.45, 0.0], [-0.35, 0.8, 0.0], [0.0; 3]];
        let (v, g, h) = eval(MetricKind::InverseMeanRatio, 2, &s, true).unwrap();
        let p = parts(&s).unwrap();
        assert!((p.eta - v).abs() <= 1e-15 * v);
        let (u, w) = ([0.7, -1.1, 0.0], [-0.2, 0.9, 0.0]);
        let want = g.map(|r| r[0] * u[0] + r[1] * u[1]);
        let got = p.gradient(&u);
        for i in 0..3 {
            assert!(
                (got[i] - want[i]).abs() <= 1e-14,
                "gradient {i}: {} vs {}",
                got[i],
                want[i]
            );
        }
        for (a, b) in [(u, w), (w, u), (u, u)] {
            let want = h.block(&h.row(&a), &h.row(&b));
            let got = p.block(&a, &b);
            for i in 0..3 {
                for q in 0..3 {
                    assert!(
                        (got[i][q] - want[i][q]).abs() <= 1e-14,
                        "block [{i}][{q}]: {} vs {}",
                        got[i][q],
                        want[i][q]
                    );
                }
            }
        }
        // the 2x2 block of S from three points is the general S's
        let tet = TetShape::from_winv(&[[1.1, 0.2, 0.0], [-0.3, 0.9, 0.0], [0.0; 3]]);
        let x = [[0.1, 0.2, 5.0], [1.3, -0.1, 5.0], [0.4, 1.2, 5.0], [0.0; 3]];
        let (a, b) = (s_of(&tet, &x), tet.s_rest(&x, usize::MAX));
        for i in 0..2 {
            for j in 0..2 {
                assert!((a[i][j] - b[i][j]).abs() <= 1e-15, "S[{i}][{j}]");
            }
        }
        let mut flip = s;
        flip[0] = flip[0].map(|t| -t);
        assert!(parts(&flip).is_none() && value_of_s(&flip).is_none());
    }
}
