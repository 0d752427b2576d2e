//! A metric's Hessian in S kept in the few structured terms every metric's
//! Hessian is made of, so that vertex blocks come out in closed form instead
//! of through a dense 9x9 matrix. With H[(i,j),(k,l)] the second derivative
//! in S[i][j] and S[k][l]:
//!
//! - `r`:    delta_ik R_jl (the identity for |S|^2, I x M for the
//!   reference-Jacobian term);
//! - `p`:    sum_mn eps_ikm eps_jln P_mn, the second derivative of det S
//!   when P = S (it is linear in its argument, so several such terms add into
//!   one P; in 2D it is P = p e3 e3^T);
//! - `gram`: D2(S)^T D2(S), the Hessian of |cof S|^2 less its D2(cof S) part;
//! - `sq`:   c vec(U) vec(U)^T, rank-one terms;
//! - `pair`: c (vec(U) vec(V)^T + vec(V) vec(U)^T).
//!
//! A vertex pair's 3x3 block is H contracted with the pair's B rows u, v:
//! block[i][q] = sum_jl H[(i,j),(q,l)] u_j v_l, which per term is
//! delta_iq u.R v; the cross-product matrix of P (u x v); delta_iq tr G - G_qi
//! with G_kk' = (u x s_k).(v x s_k') (s_k = row k of S); c (U u)_i (U v)_q;
//! c ((U u)_i (V v)_q + (V u)_i (U v)_q). For u = v the P term vanishes.
//! CPU twin of `shaders/metric/shess.wgsl` (same names, same sum orders).

use super::mat3::{Mat3, Vec3, mul_vec};
use crate::metric::mat3::cross;

/// Most rank-one terms a metric and template need (the condition number's
/// four plus the average template's one).
pub const NSQ: usize = 5;
/// The rank-one slot of the average template's g g^T.
pub const TEMPLATE_SLOT: usize = 4;

/// A structured Hessian in S (see the module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SHess {
    /// The dimension: in 2D the delta_iq of the `r` term stops at 2, so the
    /// z rows and columns of every block stay zero.
    pub n: usize,
    pub r: Mat3,
    pub p: Mat3,
    pub gram: f64,
    /// The S whose rows the `gram` term reads.
    pub s: Mat3,
    pub sq_c: [f64; NSQ],
    pub sq: [Mat3; NSQ],
    pub pair_c: f64,
    pub pair: [Mat3; 2],
}

/// The products of one B row with the terms' matrices, shared by every block
/// that row enters.
#[derive(Clone, Copy, Debug, Default)]
pub struct Row {
    pub b: Vec3,
    rb: Vec3,
    sq: [Vec3; NSQ],
    pu: Vec3,
    pv: Vec3,
    w: [Vec3; 3],
}

fn dot(a: &Vec3, b: &Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn scaled(m: &Mat3, c: f64) -> Mat3 {
    m.map(|r| r.map(|v| v * c))
}

impl SHess {
    /// c times the identity on the leading n x n block.
    pub fn identity(c: f64, n: usize) -> SHess {
        let mut h = SHess { n, ..SHess::default() };
        for i in 0..n {
            h.r[i][i] = c;
        }
        h
    }

    /// Resets to c times the identity on the leading n x n block, every
    /// other term off. The matrices of the terms that are off are left as
    /// they were: no product reads them (`row` and `block` skip them).
    #[inline]
    pub fn clear(&mut self, n: usize, c: f64) {
        self.n = n;
        self.r = [[0.0; 3]; 3];
        for i in 0..n {
            self.r[i][i] = c;
        }
        self.p = [[0.0; 3]; 3];
        self.gram = 0.0;
        self.sq_c = [0.0; NSQ];
        self.pair_c = 0.0;
    }

    /// c vec(U) vec(U)^T as rank-one term `slot`: the metrics use slots
    /// 0..4, the average template slot `TEMPLATE_SLOT`.
    pub fn set_sq(&mut self, slot: usize, c: f64, u: &Mat3) {
        self.sq_c[slot] = c;
        self.sq[slot] = *u;
    }

    /// Every term times c (a chain rule's outer derivative).
    pub fn scale(&mut self, c: f64) {
        self.r = scaled(&self.r, c);
        self.p = scaled(&self.p, c);
        self.gram *= c;
        for v in &mut self.sq_c {
            *v *= c;
        }
        self.pair_c *= c;
    }

    #[inline]
    pub fn row(&self, b: &Vec3) -> Row {
        let mut out = Row {
            b: *b,
            rb: mul_vec(&self.r, b),
            ..Row::default()
        };
        // most metrics use a few of the terms: the others' products stay zero
        if self.pair_c != 0.0 {
            out.pu = mul_vec(&self.pair[0], b);
            out.pv = mul_vec(&self.pair[1], b);
        }
        for t in 0..NSQ {
            if self.sq_c[t] != 0.0 {
                out.sq[t] = mul_vec(&self.sq[t], b);
            }
        }
        if self.gram != 0.0 {
            for k in 0..3 {
                out.w[k] = cross(b, &self.s[k]);
            }
        }
        out
    }

    /// The 3x3 block of rows `a` and `c` (vertex k's and vertex l's B rows).
    #[inline]
    pub fn block(&self, a: &Row, c: &Row) -> Mat3 {
        let mut m = [[0.0; 3]; 3];
        let d = dot(&a.b, &c.rb);
        for t in 0..NSQ {
            let ct = self.sq_c[t];
            if ct == 0.0 {
                continue;
            }
            for i in 0..3 {
                for q in 0..3 {
                    m[i][q] += ct * a.sq[t][i] * c.sq[t][q];
                }
            }
        }
        if self.pair_c != 0.0 {
            for i in 0..3 {
                for q in 0..3 {
                    m[i][q] += self.pair_c * (a.pu[i] * c.pv[q] + a.pv[i] * c.pu[q]);
                }
            }
        }
        for i in 0..self.n {
            m[i][i] += d;
        }
        if self.gram != 0.0 {
            let mut g = [[0.0; 3]; 3];
            for k in 0..3 {
                for l in 0..3 {
                    g[k][l] = dot(&a.w[k], &c.w[l]);
                }
            }
            let tr = g[0][0] + g[1][1] + g[2][2];
            for i in 0..3 {
                for q in 0..3 {
                    m[i][q] -= self.gram * g[q][i];
                }
                m[i][i] += self.gram * tr;
            }
        }
        let z = mul_vec(&self.p, &cross(&a.b, &c.b));
        m[0][1] += z[2];
        m[1][0] -= z[2];
        m[1][2] += z[0];
        m[2][1] -= z[0];
        m[2][0] += z[1];
        m[0][2] -= z[1];
        m
    }

    /// The dense 9x9 matrix (tests and finite-difference checks): entry
    /// [(i,j),(k,l)] is block(e_j, e_l)[i][k].
    pub fn dense(&self) -> [[f64; 9]; 9] {
        let e = |j: usize| {
            let mut v = [0.0; 3];
            v[j] = 1.0;
            self.row(&v)
        };
        let mut h = [[0.0; 9]; 9];
        for j in 0..3 {
            for l in 0..3 {
                let blk = self.block(&e(j), &e(l));
                for i in 0..3 {
                    for k in 0..3 {
                        h[3 * i + j][3 * k + l] = blk[i][k];
                    }
                }
            }
        }
        h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The terms written out entrywise from their definitions.
    fn dense_by_definition(h: &SHess) -> [[f64; 9]; 9] {
        let eps = |i: usize, j: usize, k: usize| -> f64 {
            match (i, j, k) {
                (0, 1, 2) | (1, 2, 0) | (2, 0, 1) => 1.0,
                (0, 2, 1) | (2, 1, 0) | (1, 0, 2) => -1.0,
                _ => 0.0,
            }
        };
        let cof_d = |x: usize, y: usize, s: &Mat3| -> f64 {
            // d^2 det / dS_x dS_y at s
            let (i, j, k, l) = (x / 3, x % 3, y / 3, y % 3);
            let mut v = 0.0;
            for m in 0..3 {
                for n in 0..3 {
                    v += eps(i, k, m) * eps(j, l, n) * s[m][n];
                }
            }
            v
        };
        let mut out = [[0.0; 9]; 9];
        for x in 0..9 {
            for y in 0..9 {
                let (i, j, k, l) = (x / 3, x % 3, y / 3, y % 3);
                let mut v = if i == k && i < h.n { h.r[j][l] } else { 0.0 };
                v += cof_d(x, y, &h.p);
                v += h.gram * (0..9).map(|b| cof_d(b, x, &h.s) * cof_d(b, y, &h.s)).sum::<f64>();
                for t in 0..NSQ {
                    v += h.sq_c[t] * h.sq[t][i][j] * h.sq[t][k][l];
                }
                let (u, w) = (&h.pair[0], &h.pair[1]);
                v += h.pair_c * (u[i][j] * w[k][l] + w[i][j] * u[k][l]);
                out[x][y] = v;
            }
        }
        out
    }

    #[test]
    fn blocks_are_the_contracted_terms() {
        let m = |a: f64| [[1.1 * a, 0.3, -0.2], [0.1, 0.9, 0.4 * a], [-0.3, 0.2 * a, 1.3]];
        let mut h = SHess::identity(0.7, 3);
        let mut planar = SHess::identity(0.7, 2);
        planar.r[0][1] = 0.2;
        planar.r[1][0] = 0.2;
        planar.p[2][2] = -0.3;
        planar.set_sq(1, 0.9, &[[0.5, 1.5, 0.0], [-0.7, 0.2, 0.0], [0.0; 3]]);
        let d = planar.dense();
        for x in 0..9 {
            for y in 0..9 {
                if x % 3 == 2 || x / 3 == 2 || y % 3 == 2 || y / 3 == 2 {
                    assert_eq!(d[x][y], 0.0, "planar [{x}][{y}]");
                }
            }
        }
        h.r[0][2] = 0.25;
        h.r[2][0] = 0.25;
        h.p = m(0.5);
        h.gram = 0.4;
        h.s = m(1.7);
        h.set_sq(0, -1.3, &m(0.2));
        h.set_sq(3, 2.1, &m(-0.9));
        h.pair_c = 0.6;
        h.pair = [m(1.1), m(-0.4)];
        let want = dense_by_definition(&h);
        let got = h.dense();
        for x in 0..9 {
            for y in 0..9 {
                assert!(
                    (want[x][y] - got[x][y]).abs() < 1e-13,
                    "[{x}][{y}] {} vs {}",
                    got[x][y],
                    want[x][y]
                );
            }
        }
        // a block of two rows is the dense matrix contracted with them
        let (u, v) = ([0.3, -1.2, 0.5], [0.8, 0.1, -0.6]);
        let blk = h.block(&h.row(&u), &h.row(&v));
        for i in 0..3 {
            for q in 0..3 {
                let mut want = 0.0;
                for j in 0..3 {
                    for l in 0..3 {
                        want += got[3 * i + j][3 * q + l] * u[j] * v[l];
                    }
                }
                assert!((blk[i][q] - want).abs() < 1e-13, "block [{i}][{q}]");
            }
        }
    }
}
