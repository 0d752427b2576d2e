//! Inverse mean ratio of a tetrahedron, eta = |S|_F^2 / (3 det(S)^(2/3)) with
//! S = A W^-1, computed through the QR trick: W = Q R, only R^-1 is kept
//! (Frobenius norm and determinant ignore the rotation Q).
//!
//! Writing S = X B with X the 3x4 vertex coordinates and B = D R^-1 (D the
//! 4x3 edge-difference matrix) makes every derivative a contraction with the
//! rows of B; `b[k]` is vertex k's row.

use super::inv_cbrt::inv_cbrt_sq;
use super::mat3::{Mat3, Vec3, cofactor, det, frobenius_sq, mul_vec, upper_inverse};

/// Precomputed reference data for one tetrahedron shape.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TetShape {
    b: [Vec3; 4],
    /// b_k . b_l and (b_k x b_l), constants of the Hessian blocks.
    bb: [[f64; 4]; 4],
    bx: [[Vec3; 4]; 4],
}

/// A tetrahedral corner's value, gradient and the factors of its Hessian
/// blocks (`TetShape::block_factors`).
pub struct BlockFactors {
    /// The corner's inverse mean ratio.
    pub eta: f64,
    /// Its gradient with respect to the four vertices.
    pub grad: [Vec3; 4],
    s: Mat3,
    u: [Vec3; 4],
    v: [Vec3; 4],
    c: [Vec3; 4],
    diag: f64,
    skew: f64,
}

impl BlockFactors {
    /// The Hessian block (k, l), k <= l, of the corner `shape`.
    #[inline(always)]
    pub fn block(&self, shape: &TetShape, k: usize, l: usize) -> Mat3 {
        let (u, c, v) = (&self.u, &self.c, &self.v);
        let mut blk = [[0.0; 3]; 3];
        for i in 0..3 {
            for q in 0..3 {
                blk[i][q] = u[k][i] * c[l][q] + c[k][i] * v[l][q];
            }
            blk[i][i] += self.diag * shape.bb[k][l];
        }
        if k != l {
            let w = mul_vec(&self.s, &shape.bx[k][l]).map(|c| c * self.skew);
            blk[0][1] += w[2];
            blk[1][0] -= w[2];
            blk[1][2] += w[0];
            blk[2][1] -= w[0];
            blk[2][0] += w[1];
            blk[0][2] -= w[1];
        }
        blk
    }
}

/// The 9x9 second derivative of eta with respect to S, index 3*i + j for S[i][j].
type Hess9 = [[f64; 9]; 9];

/// Value and gradient of eta with respect to S, plus what the Hessian reuses.
struct SParts {
    s: Mat3,
    cof: Mat3,
    d: f64,
    /// d^(-2/3)
    h: f64,
    f: f64,
    eta: f64,
    grad_s: Mat3,
}

impl TetShape {
    /// The regular (equilateral) tetrahedron of unit edge as reference.
    pub fn equilateral() -> Self {
        let r = [
            [1.0, 0.5, 0.5],
            [0.0, 3f64.sqrt() / 2.0, 3f64.sqrt() / 6.0],
            [0.0, 0.0, (2.0f64 / 3.0).sqrt()],
        ];
        Self::from_r(&r)
    }

    /// From the upper-triangular factor R of a reference W = Q R.
    pub fn from_r(r: &Mat3) -> Self {
        Self::from_winv(&upper_inverse(r))
    }

    /// From W^-1 (any invertible reference corner, rotation included).
    pub fn from_winv(m: &Mat3) -> Self {
        let b0 = [
            -(m[0][0] + m[1][0] + m[2][0]),
            -(m[0][1] + m[1][1] + m[2][1]),
            -(m[0][2] + m[1][2] + m[2][2]),
        ];
        Self::from_b([b0, m[0], m[1], m[2]])
    }

    fn from_b(b: [Vec3; 4]) -> Self {
        let mut bb = [[0.0; 4]; 4];
        let mut bx = [[[0.0; 3]; 4]; 4];
        for k in 0..4 {
            for l in 0..4 {
                let (p, q) = (&b[k], &b[l]);
                bb[k][l] = p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
                bx[k][l] = [
                    p[1] * q[2] - p[2] * q[1],
                    p[2] * q[0] - p[0] * q[2],
                    p[0] * q[1] - p[1] * q[0],
                ];
            }
        }
        TetShape { b, bb, bx }
    }

    fn s_of(&self, x: &[Vec3; 4]) -> Mat3 {
        let mut s = [[0.0; 3]; 3];
        for (xk, bk) in x.iter().zip(&self.b) {
            for i in 0..3 {
                for j in 0..3 {
                    s[i][j] += xk[i] * bk[j];
                }
            }
        }
        s
    }

    /// Inverse mean ratio, or `None` when the element is inverted or degenerate.
    #[inline]
    pub fn value(&self, x: &[Vec3; 4]) -> Option<f64> {
        Self::value_of_s(&self.s_of(x))
    }

    /// Row `k` of B: how vertex `k` enters S.
    #[inline]
    pub fn b(&self, k: usize) -> &Vec3 {
        &self.b[k]
    }

    /// S without vertex `k`'s term, so that S(x_k = y) = rest + y b_k^T.
    /// Block coordinate descent evaluates a vertex's trial points from this.
    #[inline]
    pub fn s_rest(&self, x: &[Vec3; 4], k: usize) -> Mat3 {
        let mut s = [[0.0; 3]; 3];
        for (j, (xj, bj)) in x.iter().zip(&self.b).enumerate() {
            if j == k {
                continue;
            }
            for i in 0..3 {
                for c in 0..3 {
                    s[i][c] += xj[i] * bj[c];
                }
            }
        }
        s
    }

    /// rest + y b_k^T
    #[inline]
    pub fn s_with(&self, rest: &Mat3, k: usize, y: &Vec3) -> Mat3 {
        let b = &self.b[k];
        let mut s = *rest;
        for i in 0..3 {
            for c in 0..3 {
                s[i][c] += y[i] * b[c];
            }
        }
        s
    }

    /// Inverse mean ratio from S directly.
    #[inline]
    pub fn value_of_s(s: &Mat3) -> Option<f64> {
        let d = det(s);
        if d <= 0.0 || !d.is_finite() {
            return None;
        }
        let eta = frobenius_sq(s) * inv_cbrt_sq(d) / 3.0;
        eta.is_finite().then_some(eta)
    }

    #[inline]
    fn parts(&self, x: &[Vec3; 4]) -> Option<SParts> {
        Self::parts_of_s(self.s_of(x))
    }

    #[inline]
    fn parts_of_s(s: Mat3) -> Option<SParts> {
        let d = det(&s);
        if d <= 0.0 || !d.is_finite() {
            return None;
        }
        let h = inv_cbrt_sq(d);
        let f = frobenius_sq(&s);
        let eta = f * h / 3.0;
        if !eta.is_finite() {
            return None;
        }
        let cof = cofactor(&s);
        let a = 2.0 * h / 3.0;
        let c = 2.0 * eta / (3.0 * d);
        let mut grad_s = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                grad_s[i][j] = a * s[i][j] - c * cof[i][j];
            }
        }
        Some(SParts {
            s,
            cof,
            d,
            h,
            f,
            eta,
            grad_s,
        })
    }

    /// Value and gradient with respect to the four vertices.
    pub fn gradient(&self, x: &[Vec3; 4]) -> Option<(f64, [Vec3; 4])> {
        let p = self.parts(x)?;
        let g = self.b.map(|bk| mul_vec(&p.grad_s, &bk));
        Some((p.eta, g))
    }

    /// Value, gradient and the Hessian's upper blocks (k, l), k <= l, of
    /// the 4x4 blocks of 3x3 (the lower ones untouched: `Model::blocks`
    /// mirrors them), from the structure of the S-Hessian rather than a generic contraction:
    /// block (k,l) = (2h/3)(b_k.b_l) I - (4/9) d^(-5/3) (s_k c_l^T + c_k s_l^T)
    ///             + (10/27) f d^(-8/3) c_k c_l^T - (2/9) f d^(-5/3) [S (b_k x b_l)]_x
    /// with s_k = S b_k, c_k = C b_k and [w]_x[i][q] = sum_m eps_iqm w_m.
    /// This is what the Newton assembly calls; the blocks go to `out` (a
    /// 1 KiB array is cheaper to fill in place than to return).
    pub fn upper_hessian_blocks(&self, x: &[Vec3; 4], out: &mut [[Mat3; 4]; 4]) -> Option<(f64, [Vec3; 4])> {
        let f = self.block_factors(x)?;
        for k in 0..4 {
            for l in k..4 {
                out[k][l] = f.block(self, k, l);
            }
        }
        Some((f.eta, f.grad))
    }

    /// What every block (k, l) is made of, for an assembly that builds
    /// only the blocks it stores ([`BlockFactors::block`]).
    #[inline(always)]
    pub fn block_factors(&self, x: &[Vec3; 4]) -> Option<BlockFactors> {
        let p = self.parts(x)?;
        let grad = self.b.map(|bk| mul_vec(&p.grad_s, &bk));
        let sv = self.b.map(|bk| mul_vec(&p.s, &bk));
        let cv = self.b.map(|bk| mul_vec(&p.cof, &bk));
        let dm53 = p.h / p.d;
        let dm83 = dm53 / p.d;
        let cross = -(4.0 / 9.0) * dm53;
        let cc = (10.0 / 27.0) * p.f * dm83;
        // block (k,l) = u_k c_l^T + c_k v_l^T + diag (b_k.b_l) I + skew [S (b_k x b_l)]_x
        // with v = cross s and u = v + cc c (the two symmetric outer products folded)
        let v = sv.map(|sk| sk.map(|t| cross * t));
        let mut u = v;
        for k in 0..4 {
            for i in 0..3 {
                u[k][i] += cc * cv[k][i];
            }
        }
        Some(BlockFactors {
            eta: p.eta,
            grad,
            s: p.s,
            u,
            v,
            c: cv,
            diag: 2.0 * p.h / 3.0,
            skew: -(2.0 / 9.0) * p.f * dm53,
        })
    }

    /// Value, gradient and the 12x12 Hessian (index 3*vertex + coordinate).
    pub fn hessian(&self, x: &[Vec3; 4]) -> Option<(f64, [Vec3; 4], [[f64; 12]; 12])> {
        let p = self.parts(x)?;
        let g = self.b.map(|bk| mul_vec(&p.grad_s, &bk));
        let h9 = hess_s(&p);
        // Hess_X[(k,i),(l,q)] = sum_{j,n} H[(i,j),(q,n)] b_k[j] b_l[n]
        let mut hx = [[0.0; 12]; 12];
        for k in 0..4 {
            for l in k..4 {
                for i in 0..3 {
                    for q in 0..3 {
                        let mut v = 0.0;
                        for j in 0..3 {
                            let row = &h9[3 * i + j];
                            let t = row[3 * q] * self.b[l][0]
                                + row[3 * q + 1] * self.b[l][1]
                                + row[3 * q + 2] * self.b[l][2];
                            v += self.b[k][j] * t;
                        }
                        hx[3 * k + i][3 * l + q] = v;
                        hx[3 * l + q][3 * k + i] = v;
                    }
                }
            }
        }
        Some((p.eta, g, hx))
    }

    /// Value, gradient and 3x3 Hessian with respect to vertex `k` only — what
    /// block coordinate descent needs. The det-curvature term drops out here
    /// because det(S) is linear in each single vertex.
    #[inline]
    pub fn vertex_gradient_hessian(&self, x: &[Vec3; 4], k: usize) -> Option<(f64, Vec3, Mat3)> {
        self.vertex_gradient_hessian_of_s(self.s_of(x), k)
    }

    /// As `vertex_gradient_hessian`, from S = rest + x_k b_k^T.
    #[inline]
    pub fn vertex_gradient_hessian_of_s(&self, s: Mat3, k: usize) -> Option<(f64, Vec3, Mat3)> {
        Self::vertex_gradient_hessian_at(s, &self.b[k])
    }

    /// As `vertex_gradient_hessian_of_s`, for the vertex whose B row is `b`.
    #[inline]
    pub fn vertex_gradient_hessian_at(s: Mat3, b: &Vec3) -> Option<(f64, Vec3, Mat3)> {
        let p = Self::parts_of_s(s)?;
        let grad = mul_vec(&p.grad_s, b);
        let sb = mul_vec(&p.s, b);
        let cb = mul_vec(&p.cof, b);
        let bb = b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
        let h = p.h;
        let dm53 = h / p.d; // d^(-5/3)
        let dm83 = dm53 / p.d; // d^(-8/3)
        let diag = 2.0 * h * bb / 3.0;
        let cross = -(4.0 / 9.0) * dm53;
        let cc = (10.0 / 27.0) * p.f * dm83;
        let mut hess = [[0.0; 3]; 3];
        for i in 0..3 {
            for l in 0..3 {
                hess[i][l] = cross * (sb[i] * cb[l] + cb[i] * sb[l]) + cc * cb[i] * cb[l];
            }
            hess[i][i] += diag;
        }
        Some((p.eta, grad, hess))
    }
}

/// Hessian of eta = f h / 3 with f = |S|^2, h = det(S)^(-2/3):
/// (1/3) [2 h I + 2 S (x) dh + dh (x) 2 S + f d2h],
/// dh = -(2/3) d^(-5/3) C, d2h = (10/9) d^(-8/3) C (x) C - (2/3) d^(-5/3) d2(det),
/// d2(det)[(i,j),(k,l)] = sum_{m,n} eps_ikm eps_jln S[m][n].
fn hess_s(p: &SParts) -> Hess9 {
    let h = p.h;
    let dm53 = h / p.d;
    let dm83 = dm53 / p.d;
    let mut out = [[0.0; 9]; 9];
    for i in 0..3 {
        for j in 0..3 {
            for k in 0..3 {
                for l in 0..3 {
                    let a = 3 * i + j;
                    let b = 3 * k + l;
                    let mut v = -(4.0 / 9.0) * dm53 * (p.s[i][j] * p.cof[k][l] + p.cof[i][j] * p.s[k][l])
                        + (10.0 / 27.0) * p.f * dm83 * p.cof[i][j] * p.cof[k][l];
                    if a == b {
                        v += 2.0 * h / 3.0;
                    }
                    if i != k && j != l {
                        let m = 3 - i - k;
                        let n = 3 - j - l;
                        let sign = levi(i, k, m) * levi(j, l, n);
                        v -= (2.0 / 9.0) * p.f * dm53 * sign * p.s[m][n];
                    }
                    out[a][b] = v;
                }
            }
        }
    }
    out
}

fn levi(i: usize, j: usize, k: usize) -> f64 {
    match (i, j, k) {
        (0, 1, 2) | (1, 2, 0) | (2, 0, 1) => 1.0,
        (0, 2, 1) | (2, 1, 0) | (1, 0, 2) => -1.0,
        _ => 0.0,
    }
}

/// Signed volume determinant det[x1-x0, x2-x0, x3-x0] (six times the volume).
pub fn tet_det(x: &[Vec3; 4]) -> f64 {
    use super::mat3::sub;
    let a = sub(&x[1], &x[0]);
    let b = sub(&x[2], &x[0]);
    let c = sub(&x[3], &x[0]);
    det(&[[a[0], b[0], c[0]], [a[1], b[1], c[1]], [a[2], b[2], c[2]]])
}
