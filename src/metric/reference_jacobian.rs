//! The corner term of the reference-Jacobian objective (equation 4 of the
//! rezoning paper), det(Jr) |J - Jr|^2 / (det(J) |Jr|^2), as a metric of the
//! corner's S = J Jr^-1: the corner's target W is its reference Jacobian Jr,
//! so det(Jr) / det(J) = 1 / det(S) and J - Jr = (S - I) Jr, which gives
//!
//!   f(S) = tr(A M A^T) / det(S),  A = S - I,  M = Jr Jr^T / |Jr|^2.
//!
//! Unlike the other metrics the term depends on the target beyond S (through
//! M), so the caller passes M, which `weight` recovers from the corner's B
//! rows (b_1..b_3 are the rows of Jr^-1). CPU twin of
//! `shaders/metric/reference_jacobian.wgsl`.

use super::mat3::{Mat3, cofactor, inverse};
use super::shess::SHess;

/// M = Jr Jr^T / |Jr|^2 from Jr^-1 (rows b_1, b_2, b_3); `None` when singular.
pub fn weight(winv: &Mat3) -> Option<Mat3> {
    let w = inverse(winv)?;
    let norm: f64 = w.iter().flatten().map(|v| v * v).sum();
    let mut m = [[0.0; 3]; 3];
    for j in 0..3 {
        for k in 0..3 {
            m[j][k] = (0..3).map(|c| w[j][c] * w[k][c]).sum::<f64>() / norm;
        }
    }
    Some(m)
}

/// Value, gradient and (if `hess`) Hessian in S at det(S) = `d` > 0:
/// with q = tr(A M A^T), dq = 2 A M, d2q = 2 delta_ik M_jl, and u = 1/d,
/// du = -C / d^2, d2u = 2 C C^T / d^3 - D2 / d^2 (C = cofactor = d det / dS,
/// D2 its derivative), f = q u and the product rule: the Hessian is
/// I x (2M/d) - (2/d^2) (AM C^T + C (AM)^T) + (2q/d^3) C C^T - (q/d^2) D2.
pub fn rj(s: &Mat3, d: f64, m: &Mat3, hess: Option<&mut SHess>) -> (f64, Mat3) {
    let mut a = *s;
    for (i, row) in a.iter_mut().enumerate() {
        row[i] -= 1.0;
    }
    let mut am = [[0.0; 3]; 3];
    for i in 0..3 {
        for k in 0..3 {
            am[i][k] = (0..3).map(|j| a[i][j] * m[j][k]).sum();
        }
    }
    let mut q = 0.0;
    for i in 0..3 {
        for k in 0..3 {
            q += am[i][k] * a[i][k];
        }
    }
    let c = cofactor(s);
    let v = q / d;
    let mut g = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            g[i][j] = 2.0 * am[i][j] / d - q * c[i][j] / (d * d);
        }
    }
    if let Some(h) = hess {
        h.clear(3, 0.0);
        h.r = m.map(|r| r.map(|v| 2.0 * v / d));
        h.pair_c = -2.0 / (d * d);
        h.pair = [am, c];
        h.set_sq(0, 2.0 * q / (d * d * d), &c);
        h.p = s.map(|r| r.map(|v| -q / (d * d) * v));
    }
    (v, g)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::mat3::det;

    /// The term straight from the paper's formula, for comparison.
    fn paper(j: &Mat3, jr: &Mat3) -> f64 {
        let mut diff = 0.0;
        let mut norm = 0.0;
        for r in 0..3 {
            for c in 0..3 {
                diff += (j[r][c] - jr[r][c]).powi(2);
                norm += jr[r][c].powi(2);
            }
        }
        det(jr) * diff / (det(j) * norm)
    }

    fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
        std::array::from_fn(|i| std::array::from_fn(|k| (0..3).map(|j| a[i][j] * b[j][k]).sum()))
    }

    #[test]
    fn the_term_of_s_is_the_papers_term_of_j() {
        let jr = [[1.2, 0.3, -0.1], [0.2, 0.8, 0.25], [-0.1, 0.15, 1.4]];
        let j = [[0.9, 0.5, 0.1], [-0.2, 1.1, 0.3], [0.2, -0.1, 1.0]];
        let s = mul(&j, &inverse(&jr).unwrap());
        let m = weight(&inverse(&jr).unwrap()).unwrap();
        let (v, _) = rj(&s, det(&s), &m, None);
        assert!((v - paper(&j, &jr)).abs() < 1e-13 * v, "{v} vs {}", paper(&j, &jr));
        // zero exactly at the reference
        let id = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(rj(&id, 1.0, &m, None).0, 0.0);
    }

    #[test]
    fn gradient_and_hessian_match_finite_differences() {
        let jr = [[1.0, 0.4, 0.0], [0.1, 0.7, 0.3], [0.0, -0.2, 1.3]];
        let m = weight(&inverse(&jr).unwrap()).unwrap();
        let s = [[1.1, 0.3, -0.2], [0.1, 0.9, 0.4], [-0.3, 0.2, 1.3]];
        let f = |s: &Mat3| rj(s, det(s), &m, None);
        let mut h = SHess::default();
        let (_, g) = rj(&s, det(&s), &m, Some(&mut h));
        let h = h.dense();
        let step = 1e-5;
        for x in 0..9 {
            let at = |t: f64| {
                let mut p = s;
                p[x / 3][x % 3] += t * step;
                p
            };
            let fd = |e: &dyn Fn(&Mat3) -> f64| {
                (-e(&at(2.0)) + 8.0 * e(&at(1.0)) - 8.0 * e(&at(-1.0)) + e(&at(-2.0))) / (12.0 * step)
            };
            let gd = fd(&|p| f(p).0);
            assert!(
                (gd - g[x / 3][x % 3]).abs() < 1e-8,
                "grad {x}: {} vs {gd}",
                g[x / 3][x % 3]
            );
            for y in 0..9 {
                let hd = fd(&|p| f(p).1[y / 3][y % 3]);
                assert!((hd - h[x][y]).abs() < 1e-7, "H[{x}][{y}]: {} vs {hd}", h[x][y]);
            }
        }
    }
}
