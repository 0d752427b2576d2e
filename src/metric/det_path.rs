//! Where a corner inverts along a straight move: det(S0 + t E) is a
//! polynomial of degree n in t (n = 2 or 3), so the first t at which it
//! vanishes is found from its coefficients instead of by trial evaluations.
//! Newton's line search uses it to place its first feasible trial: on the
//! hard planar meshes most of its trials were steps halved until nothing
//! inverted.

use super::mat3::{Mat3, Vec3, cofactor, cross, det, dot, frob_dot};

/// Coefficients (c0, c1, c2, c3) of det(A + t B) (the leading 2x2 blocks when `dim` is 2).
pub fn det_coefficients(a: &Mat3, b: &Mat3, dim: usize) -> [f64; 4] {
    if dim == 2 {
        let c0 = a[0][0] * a[1][1] - a[0][1] * a[1][0];
        let c1 = a[0][0] * b[1][1] + b[0][0] * a[1][1] - a[0][1] * b[1][0] - b[0][1] * a[1][0];
        let c2 = b[0][0] * b[1][1] - b[0][1] * b[1][0];
        return [c0, c1, c2, 0.0];
    }
    // det(A + tB) = det A + t tr(adj(A) B) + t^2 tr(adj(B) A) + t^3 det B,
    // tr(adj(X) Y) being the Frobenius product of X's cofactors with Y
    [det(a), frob_dot(&cofactor(a), b), frob_dot(&cofactor(b), a), det(b)]
}

/// Coefficients (c0, c1, c2, 0) of the area of a surface corner's S = A + t B
/// facing its reference normal `n` (`surface::facing_area`):
/// n . ((a0 + t b0) x (a1 + t b1)) for the columns a_j, b_j.
pub fn facing_coefficients(a: &Mat3, b: &Mat3, n: &Vec3) -> [f64; 4] {
    let col = |m: &Mat3, j: usize| [m[0][j], m[1][j], m[2][j]];
    let (a0, a1, b0, b1) = (col(a, 0), col(a, 1), col(b, 0), col(b, 1));
    let c1 = dot(&cross(&a0, &b1), n) + dot(&cross(&b0, &a1), n);
    [dot(&cross(&a0, &a1), n), c1, dot(&cross(&b0, &b1), n), 0.0]
}

/// The smallest t in (0, 1] with det(A + t B) <= 0, +inf when the
/// determinant stays positive on (0, 1], 0 when det A <= 0 already.
pub fn first_inversion(a: &Mat3, b: &Mat3, dim: usize) -> f64 {
    first_root(det_coefficients(a, b, dim))
}

/// The smallest t in (0, 1] at which the cubic with coefficients `c` is not
/// positive (+inf when there is none, 0 when c0 <= 0).
pub fn first_root(c: [f64; 4]) -> f64 {
    let p = |t: f64| c[0] + t * (c[1] + t * (c[2] + t * c[3]));
    if !(c[0] > 0.0) {
        return 0.0;
    }
    if c[1] >= 0.0 && c[2] >= 0.0 && c[3] >= 0.0 {
        return f64::INFINITY;
    }
    // p is monotone between its critical points: cut (0, 1] there and take
    // the first piece whose right end is not positive
    let mut cuts = [1.0; 3];
    let mut n = 0;
    let (qa, qb, qc) = (3.0 * c[3], 2.0 * c[2], c[1]);
    if qa != 0.0 {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc >= 0.0 {
            let r = disc.sqrt();
            // the stable pair of roots of qa t^2 + qb t + qc
            let q = -0.5 * (qb + r.copysign(qb));
            for t in [q / qa, if q != 0.0 { qc / q } else { f64::NAN }] {
                if t > 0.0 && t < 1.0 {
                    cuts[n] = t;
                    n += 1;
                }
            }
        }
    } else if qb != 0.0 {
        let t = -qc / qb;
        if t > 0.0 && t < 1.0 {
            cuts[n] = t;
            n += 1;
        }
    }
    cuts[..n].sort_by(f64::total_cmp);
    let mut lo = 0.0;
    for &hi in &cuts[..=n] {
        if p(hi) <= 0.0 {
            return bracketed_root(&p, lo, hi);
        }
        lo = hi;
    }
    f64::INFINITY
}

/// A root of the monotone `p` on (lo, hi] with p(lo) > 0 >= p(hi), to
/// about 1e-12 of the interval: the Illinois variant of false position,
/// which keeps the bracket and converges superlinearly.
fn bracketed_root(p: &impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    let (mut flo, mut fhi) = (p(lo), p(hi));
    let mut side = 0;
    let tol = 1e-12 * (hi - lo);
    for _ in 0..100 {
        if hi - lo <= tol || fhi == 0.0 {
            break;
        }
        let t = (lo * fhi - hi * flo) / (fhi - flo);
        let t = if t > lo && t < hi { t } else { 0.5 * (lo + hi) };
        let ft = p(t);
        if ft > 0.0 {
            (lo, flo) = (t, ft);
            if side == -1 {
                fhi *= 0.5;
            }
            side = -1;
        } else {
            (hi, fhi) = (t, ft);
            if side == 1 {
                flo *= 0.5;
            }
            side = 1;
        }
    }
    // the bracket's right end: p <= 0 there, and it is within tol of the root
    hi
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    fn random(seed: &mut u64) -> Mat3 {
        [0, 1, 2].map(|_| [0, 1, 2].map(|_| lcg(seed)))
    }

    fn add(a: &Mat3, b: &Mat3, t: f64) -> Mat3 {
        [0, 1, 2].map(|i| [0, 1, 2].map(|j| a[i][j] + t * b[i][j]))
    }

    fn det_dim(m: &Mat3, dim: usize) -> f64 {
        if dim == 2 {
            m[0][0] * m[1][1] - m[0][1] * m[1][0]
        } else {
            det(m)
        }
    }

    /// The coefficients reproduce det(A + tB) at several t: they are what
    /// the roots are found from.
    #[test]
    fn coefficients_match_the_determinant() {
        let mut seed = 7;
        for dim in [2, 3] {
            for _ in 0..200 {
                let (a, b) = (random(&mut seed), random(&mut seed));
                let c = det_coefficients(&a, &b, dim);
                for t in [-1.3, 0.0, 0.4, 1.0, 2.5] {
                    let want = det_dim(&add(&a, &b, t), dim);
                    let got = c[0] + t * (c[1] + t * (c[2] + t * c[3]));
                    assert!(
                        (got - want).abs() <= 1e-12 * (1.0 + want.abs()),
                        "dim {dim} t {t}: {got} vs {want}"
                    );
                }
            }
        }
    }

    /// Against a fine scan of det along the segment: the first sign change
    /// found by sampling is where `first_inversion` puts it, including
    /// paths that dip below zero and come back positive before t = 1.
    #[test]
    fn first_inversion_matches_a_scan() {
        let mut seed = 11;
        let (mut found, mut none) = (0, 0);
        for dim in [2, 3] {
            for _ in 0..2000 {
                let (mut a, b) = (random(&mut seed), random(&mut seed));
                if det_dim(&a, dim) <= 0.0 {
                    a.swap(0, 1);
                }
                let t = first_inversion(&a, &b, dim);
                let samples = 20000;
                let scan = (1..=samples)
                    .map(|k| k as f64 / samples as f64)
                    .find(|&s| det_dim(&add(&a, &b, s), dim) <= 0.0);
                match scan {
                    Some(s) => {
                        found += 1;
                        assert!(
                            t <= s + 1e-12 && t > s - 1.0 / samples as f64 - 1e-12,
                            "dim {dim}: root {t}, scan {s}"
                        );
                        assert!(det_dim(&add(&a, &b, t), dim) <= 1e-12, "p(t) > 0 at the returned root");
                    }
                    // a dip narrower than the scan's spacing is the only miss allowed
                    None => {
                        none += 1;
                        assert!(t == f64::INFINITY || det_dim(&add(&a, &b, t), dim) <= 1e-12);
                    }
                }
            }
        }
        assert!(
            found > 200 && none > 200,
            "both cases exercised: {found} roots, {none} without"
        );
    }

    /// A path that inverts and recovers within the step: the first root, not the last.
    #[test]
    fn a_dip_below_zero_counts() {
        // det = (1 - 4t)(1 - 2t) ... with dim 2: a diagonal A + tB
        let a = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let b = [[-4.0, 0.0, 0.0], [0.0, -2.0, 0.0], [0.0, 0.0, 0.0]];
        // roots at 0.25 and 0.5, positive again at 1
        let t = first_inversion(&a, &b, 2);
        assert!((t - 0.25).abs() < 1e-12, "{t}");
        assert_eq!(
            first_inversion(&a, &[[0.5, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0; 3]], 2),
            f64::INFINITY
        );
        // scale invariance: the root is a fraction of the step
        let s = 1e-7;
        let (a2, b2) = (a.map(|r| r.map(|v| v * s)), b.map(|r| r.map(|v| v * s)));
        assert!((first_inversion(&a2, &b2, 3) - first_inversion(&a, &b, 3)).abs() < 1e-12);
    }
}
