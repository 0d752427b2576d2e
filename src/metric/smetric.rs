//! Metrics as functions of one corner's S = A W^-1 (n x n, n = 2 or 3), with
//! value, gradient and Hessian in S. Solvers turn these into vertex
//! derivatives by contracting with the corner's B rows (`corner_model.rs`).
//!
//! Index convention: S[i][j] for i, j < n; the Hessian is 9x9 with index
//! 3*i + j (in 2D only the entries with i, j < 2 are used).

use super::mat3::{Mat3, cofactor, det};
use super::shess::SHess;

/// The element metrics meshsmooth optimises (all: lower is better).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum MetricKind {
    /// Inverse mean ratio |S|^2 / (n det(S)^(2/n)) >= 1, 1 only for S a scaled rotation.
    #[default]
    #[cfg_attr(feature = "cli", value(name = "imr"))]
    InverseMeanRatio,
    /// Frobenius condition number |S| |S^-1| / n >= 1 (equal to the inverse mean ratio in 2D).
    #[cfg_attr(feature = "cli", value(name = "cn"))]
    ConditionNumber,
    /// Target-matrix shape+size |S - I|^2 >= 0, 0 only when the corner equals its target.
    #[cfg_attr(feature = "cli", value(name = "tmp"))]
    TargetShapeSize,
    /// Shape and size against the targets: eta(S) + (tau - 1)^2 / tau with
    /// tau = det S, >= 1, 1 only when S is a rotation (the corner has its
    /// target's shape and size); a barrier at tau -> 0.
    #[cfg_attr(feature = "cli", value(name = "shape-size"))]
    ShapeSize,
    /// The rezoning paper's shape measure: the Frobenius condition number
    /// |J| |J^-1| / 3 of the raw edge matrix J at every corner of every
    /// element (target: the octant corner, W = I), each corner weighted
    /// 1 / (corners in the mesh); an element's value is the mean over all its
    /// corners (its "SQM").
    #[cfg_attr(feature = "cli", value(name = "cn-paper"))]
    ConditionNumberPaper,
    /// The reference-Jacobian rezoning objective's corner term (equation 4 of
    /// the rezoning paper) over every corner; its per-corner references come
    /// from `rezone`, so it is not offered on the command line.
    #[cfg_attr(feature = "cli", value(skip))]
    ReferenceJacobian,
}

impl MetricKind {
    /// The metric's short name (`imr`, ...), as the command line spells it.
    pub fn name(self) -> &'static str {
        crate::error::Named::name(&self)
    }

    /// Evaluated at every corner of every element against the octant corner
    /// (W = I unless a corner's reference is set), each corner weighted
    /// 1 / (corners in the mesh), as the rezoning paper does.
    pub fn every_corner(self) -> bool {
        matches!(self, MetricKind::ConditionNumberPaper | MetricKind::ReferenceJacobian)
    }
}

crate::error::by_name!(MetricKind: "metric" {
    InverseMeanRatio = "imr",
    ConditionNumber = "cn",
    TargetShapeSize = "tmp",
    ShapeSize = "shape-size",
    ConditionNumberPaper = "cn-paper",
} unnamed {
    ReferenceJacobian = "rj",
});

/// det of the leading n x n block.
pub fn det_n(s: &Mat3, n: usize) -> f64 {
    if n == 2 {
        s[0][0] * s[1][1] - s[0][1] * s[1][0]
    } else {
        det(s)
    }
}

/// d det / dS of the leading n x n block.
fn cof_n(s: &Mat3, n: usize) -> Mat3 {
    if n == 2 {
        [[s[1][1], -s[1][0], 0.0], [-s[0][1], s[0][0], 0.0], [0.0; 3]]
    } else {
        cofactor(s)
    }
}

fn frob_n(s: &Mat3, n: usize) -> f64 {
    let mut f = 0.0;
    for i in 0..n {
        for j in 0..n {
            f += s[i][j] * s[i][j];
        }
    }
    f
}

/// The argument of the det-Hessian term for c D2(S): c S in 3D, c e3 e3^T in
/// 2D (where D2 is constant); see `shess`.
fn d2det_term(s: &Mat3, n: usize, c: f64) -> Mat3 {
    if n == 2 {
        [[0.0; 3], [0.0; 3], [0.0, 0.0, c]]
    } else {
        s.map(|r| r.map(|v| v * c))
    }
}

/// Value, gradient and (if `hess`) Hessian of `metric` at S; `None` when the
/// corner is inverted or degenerate (det <= 0), which every metric treats as
/// infeasible.
///
/// # Panics
/// For the reference-Jacobian metric, which needs the corner's M: use [`eval_with`].
pub fn eval(metric: MetricKind, n: usize, s: &Mat3, hess: bool) -> Option<(f64, Mat3, SHess)> {
    owned(metric, n, s, None, hess, 0.0)
}

/// [`eval_full`] with the Hessian returned (tests and one-off callers; the
/// solvers pass their own `SHess` to fill).
fn owned(
    metric: MetricKind,
    n: usize,
    s: &Mat3,
    rj: Option<&Mat3>,
    hess: bool,
    eps: f64,
) -> Option<(f64, Mat3, SHess)> {
    let mut h = SHess::default();
    let (v, g) = eval_full(metric, n, s, rj, hess.then_some(&mut h), eps)?;
    Some((v, g, h))
}

/// The regularised determinant of Garanzha et al. ("Foldover-free maps in 50
/// lines of code", ACM TOG 2021): chi(d, eps) = (d + sqrt(eps^2 + d^2)) / 2,
/// positive for every d when eps > 0 and equal to d when eps = 0 and d > 0.
/// Returns (chi, d chi / d d, d^2 chi / d d^2).
pub fn chi(d: f64, eps: f64) -> (f64, f64, f64) {
    if eps == 0.0 {
        return (d, 1.0, 0.0);
    }
    let r = (eps * eps + d * d).sqrt();
    // for d < 0 the sum d + r cancels: the conjugate form keeps its digits
    let c = if d > 0.0 {
        0.5 * (d + r)
    } else {
        0.5 * eps * eps / (r - d)
    };
    (c, c / r, 0.5 * eps * eps / (r * r * r))
}

/// `eval` with det S replaced by `chi(det S, eps)` wherever a metric divides
/// by it (the inverse mean ratio and the condition number), so that with
/// eps > 0 an inverted corner has a finite value and a gradient that points
/// towards untangling it. The target metric has no determinant and is the
/// same for every eps. eps = 0 is `eval`.
pub fn eval_regularised(metric: MetricKind, n: usize, s: &Mat3, hess: bool, eps: f64) -> Option<(f64, Mat3, SHess)> {
    owned(metric, n, s, None, hess, eps)
}

/// [`eval`] with the reference-Jacobian metric's per-corner weight M
/// (`reference_jacobian::weight`), which the other metrics ignore.
pub fn eval_with(metric: MetricKind, n: usize, s: &Mat3, rj: Option<&Mat3>, hess: bool) -> Option<(f64, Mat3, SHess)> {
    owned(metric, n, s, rj, hess, 0.0)
}

/// [`eval_with`] and [`eval_regularised`] in one: the reference-Jacobian
/// weight and untangling's eps (the reference-Jacobian term is never
/// regularised: rezoning starts from a valid mesh). The Hessian goes into
/// `hess` when given. In 2D only the leading 2x2 block of S is read, and
/// every matrix returned is zero outside it.
#[inline]
pub fn eval_full(
    metric: MetricKind,
    n: usize,
    s: &Mat3,
    rj: Option<&Mat3>,
    hess: Option<&mut SHess>,
    eps: f64,
) -> Option<(f64, Mat3)> {
    let s = &leading(s, n);
    let d = det_n(s, n);
    if !d.is_finite() || (eps == 0.0 && !(d > 0.0)) {
        return None;
    }
    let x = chi(d, eps);
    let out = match metric {
        MetricKind::InverseMeanRatio => imr(n, s, x, hess),
        MetricKind::ConditionNumber | MetricKind::ConditionNumberPaper if n == 2 => imr(n, s, x, hess),
        MetricKind::ConditionNumber | MetricKind::ConditionNumberPaper => cn3(s, x, hess),
        MetricKind::TargetShapeSize => tmp(n, s, hess),
        MetricKind::ShapeSize => shape_size(n, s, x, hess),
        MetricKind::ReferenceJacobian => {
            if !(d > 0.0) {
                return None;
            }
            let m = rj.expect("the reference-Jacobian metric needs its corner's M");
            super::reference_jacobian::rj(s, d, m, hess)
        }
    };
    out.0.is_finite().then_some(out)
}

/// S with the rows and columns past n zeroed.
pub fn leading(s: &Mat3, n: usize) -> Mat3 {
    if n == 3 {
        return *s;
    }
    [[s[0][0], s[0][1], 0.0], [s[1][0], s[1][1], 0.0], [0.0; 3]]
}

/// eta = f h / n with f = |S|^2, h = chi^(-2/n) for `(chi, chi', chi'')`
/// (`chi` = det S when not regularised). With grad chi = chi' C and
/// Hess chi = chi' D2 + chi'' C C^T the Hessian is
/// (2h/n) I + cross chi' (S C^T + C S^T) + (cc chi'^2 + dd chi'') C C^T + dd chi' D2.
#[inline]
fn imr(n: usize, s: &Mat3, (d, d1, d2c): (f64, f64, f64), hess: Option<&mut SHess>) -> (f64, Mat3) {
    let nf = n as f64;
    let h = if n == 2 {
        1.0 / d
    } else {
        super::inv_cbrt::inv_cbrt_sq(d)
    };
    let f = frob_n(s, n);
    let eta = f * h / nf;
    let c = cof_n(s, n);
    let p = 2.0 / nf; // d h / d chi = -p h / chi
    let mut g = [[0.0; 3]; 3];
    for i in 0..n {
        for j in 0..n {
            g[i][j] = (2.0 * h * s[i][j] - f * p * h / d * (d1 * c[i][j])) / nf;
        }
    }
    if let Some(hm) = hess {
        let cross = -2.0 * p * h / d / nf;
        let cc = f * p * (p + 1.0) * h / (d * d) / nf;
        let dd = -f * p * h / d / nf;
        hm.clear(n, 2.0 * h / nf);
        hm.pair_c = cross * d1;
        hm.pair = [*s, c];
        hm.set_sq(0, cc * d1 * d1 + dd * d2c, &c);
        hm.p = d2det_term(s, n, dd * d1);
    }
    (eta, g)
}

/// eta(S) + sigma(tau), sigma(tau) = tau + 1/tau - 2 = (tau - 1)^2 / tau with
/// tau = chi(det S): with grad tau = chi' C and Hess tau = chi' D2 + chi'' C C^T,
/// the size term adds sigma' chi' C to the gradient, (sigma'' chi'^2 +
/// sigma' chi'') C C^T to the rank-one slot 0 and sigma' chi' D2 to P.
#[inline]
fn shape_size(n: usize, s: &Mat3, x: (f64, f64, f64), mut hess: Option<&mut SHess>) -> (f64, Mat3) {
    let (tau, d1, d2c) = x;
    let c = cof_n(s, n);
    let (s1, s2) = (1.0 - 1.0 / (tau * tau), 2.0 / (tau * tau * tau));
    let (eta, mut g) = imr(n, s, x, hess.as_deref_mut());
    for i in 0..n {
        for j in 0..n {
            g[i][j] += s1 * d1 * c[i][j];
        }
    }
    if let Some(hm) = hess {
        hm.sq_c[0] += s2 * d1 * d1 + s1 * d2c;
        let extra = d2det_term(s, n, s1 * d1);
        for i in 0..3 {
            for j in 0..3 {
                hm.p[i][j] += extra[i][j];
            }
        }
    }
    (eta + tau + 1.0 / tau - 2.0, g)
}

/// |S - I|^2: gradient 2 (S - I), Hessian 2 I.
fn tmp(n: usize, s: &Mat3, hess: Option<&mut SHess>) -> (f64, Mat3) {
    let mut v = 0.0;
    let mut g = [[0.0; 3]; 3];
    for i in 0..n {
        for j in 0..n {
            let e = s[i][j] - if i == j { 1.0 } else { 0.0 };
            v += e * e;
            g[i][j] = 2.0 * e;
        }
    }
    if let Some(h) = hess {
        h.clear(n, 2.0);
    }
    (v, g)
}

/// grad |cof S|^2 = 2 (|S|^2 S - S S^T S) (3x3: |cof S|^2 is the second
/// elementary symmetric function of the squared singular values).
fn cof_norm_gradient(s: &Mat3, a: f64) -> Mat3 {
    let mut sst = [[0.0; 3]; 3];
    for i in 0..3 {
        for k in 0..3 {
            sst[i][k] = s[i][0] * s[k][0] + s[i][1] * s[k][1] + s[i][2] * s[k][2];
        }
    }
    let mut out = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let ssts = sst[i][0] * s[0][j] + sst[i][1] * s[1][j] + sst[i][2] * s[2][j];
            out[i][j] = 2.0 * (a * s[i][j] - ssts);
        }
    }
    out
}

/// 3D condition number kappa = |S| |C| / (3 d) through L = ln kappa:
/// grad kappa = kappa grad L, Hess kappa = kappa (Hess L + grad L grad L^T), with
/// |S^-1| = |C| / d, grad |C|^2 = 2 D2 vec(C), Hess |C|^2 = 2 (D2^T D2 + D2(C))
/// (D2(C): the det-Hessian form with C in place of S).
/// Regularised: d becomes chi, so ln kappa has -ln chi with gradient
/// chi' C / chi and Hessian (chi' D2 + chi'' C C^T) / chi - chi'^2 C C^T / chi^2.
#[inline]
fn cn3(s: &Mat3, (d, d1, d2c): (f64, f64, f64), hess: Option<&mut SHess>) -> (f64, Mat3) {
    let c = cofactor(s);
    let a = frob_n(s, 3);
    let cc = frob_n(&c, 3);
    let kappa = (a * cc).sqrt() / (3.0 * d);
    let gc = cof_norm_gradient(s, a);
    let mut gl = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            gl[i][j] = s[i][j] / a + 0.5 * gc[i][j] / cc - d1 * c[i][j] / d;
        }
    }
    let g = gl.map(|r| r.map(|v| kappa * v));
    if let Some(hm) = hess {
        hm.clear(3, kappa / a);
        hm.set_sq(0, -2.0 * kappa / (a * a), s);
        hm.set_sq(1, -0.5 * kappa / (cc * cc), &gc);
        hm.set_sq(2, kappa * (d1 * d1 / (d * d) - d2c / d), &c);
        hm.set_sq(3, kappa, &gl);
        hm.gram = kappa / cc;
        hm.s = *s;
        for i in 0..3 {
            for j in 0..3 {
                hm.p[i][j] = kappa * (c[i][j] / cc - d1 * s[i][j] / d);
            }
        }
    }
    (kappa, g)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fd_check(metric: MetricKind, n: usize, s: Mat3) {
        fd_check_eps(metric, n, s, 0.0)
    }

    fn fd_check_eps(metric: MetricKind, n: usize, s: Mat3, eps: f64) {
        let eval = |metric, n, s: &Mat3, hess| eval_regularised(metric, n, s, hess, eps);
        let (v, g, h) = eval(metric, n, &s, true).unwrap();
        let h = h.dense();
        let step = 1e-5;
        let gs = g.iter().flatten().map(|x| x.abs()).fold(1e-12, f64::max);
        let hs = h.iter().flatten().map(|x| x.abs()).fold(1e-12, f64::max);
        for i in 0..n {
            for j in 0..n {
                let at = |t: f64| {
                    let mut m = s;
                    m[i][j] += t * step;
                    m
                };
                let f4 = |f: &dyn Fn(&Mat3) -> f64| {
                    (-f(&at(2.0)) + 8.0 * f(&at(1.0)) - 8.0 * f(&at(-1.0)) + f(&at(-2.0))) / (12.0 * step)
                };
                let fd = f4(&|m| eval(metric, n, m, false).unwrap().0);
                assert!(
                    (fd - g[i][j]).abs() < 1e-7 * gs,
                    "{metric} n={n} eps={eps} grad[{i}][{j}] {} vs {fd}",
                    g[i][j]
                );
                for k in 0..n {
                    for l in 0..n {
                        let fdh = f4(&|m| eval(metric, n, m, false).unwrap().1[k][l]);
                        let an = h[3 * i + j][3 * k + l];
                        assert!(
                            (fdh - an).abs() < 1e-6 * hs,
                            "{metric} n={n} eps={eps} H[{i}{j}][{k}{l}] {an} vs {fdh}"
                        );
                    }
                }
            }
        }
        assert!(v.is_finite());
    }

    #[test]
    fn every_metric_matches_finite_differences_in_s() {
        let s3 = [[1.1, 0.3, -0.2], [0.1, 0.9, 0.4], [-0.3, 0.2, 1.3]];
        let s2 = [[1.2, 0.4, 0.0], [-0.3, 0.8, 0.0], [0.0, 0.0, 0.0]];
        for m in [
            MetricKind::InverseMeanRatio,
            MetricKind::ConditionNumber,
            MetricKind::TargetShapeSize,
            MetricKind::ShapeSize,
        ] {
            fd_check(m, 3, s3);
            fd_check(m, 2, s2);
        }
    }

    #[test]
    fn ideal_values_and_infeasibility() {
        let id = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let rot = [[0.0, -2.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 2.0]];
        for n in [2, 3] {
            assert!((eval(MetricKind::InverseMeanRatio, n, &rot, false).unwrap().0 - 1.0).abs() < 1e-14);
            assert!((eval(MetricKind::ConditionNumber, n, &rot, false).unwrap().0 - 1.0).abs() < 1e-14);
            assert_eq!(eval(MetricKind::TargetShapeSize, n, &id, false).unwrap().0, 0.0);
            // shape+size: 1 at any rotation, above 1 at a scaled rotation
            let mut r1 = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
            assert!((eval(MetricKind::ShapeSize, n, &r1, false).unwrap().0 - 1.0).abs() < 1e-14);
            r1[0][1] = -1.1;
            r1[1][0] = 1.1;
            r1[2][2] = 1.1;
            assert!(eval(MetricKind::ShapeSize, n, &r1, false).unwrap().0 > 1.01);
            assert!((eval(MetricKind::ShapeSize, n, &rot, false).unwrap().0 - 1.0).abs() > 0.1);
            let mut flip = id;
            flip[0][0] = -1.0;
            assert!(eval(MetricKind::InverseMeanRatio, n, &flip, false).is_none());
            assert!(eval(MetricKind::TargetShapeSize, n, &flip, false).is_none());
        }
    }

    #[test]
    fn regularised_metrics_match_finite_differences_on_both_sides_of_zero() {
        // positive, inverted and nearly flat corners, with eps large and small
        // against |det S|
        let s3 = [[1.1, 0.3, -0.2], [0.1, 0.9, 0.4], [-0.3, 0.2, 1.3]];
        let mut inv3 = s3;
        inv3[0] = inv3[0].map(|v| -v);
        let flat3 = [[1.0, 0.2, 0.1], [0.3, 1.1, -0.2], [1.3, 1.3, -0.1]];
        let s2 = [[1.2, 0.4, 0.0], [-0.3, 0.8, 0.0], [0.0, 0.0, 0.0]];
        let inv2 = [[-1.2, -0.4, 0.0], [-0.3, 0.8, 0.0], [0.0, 0.0, 0.0]];
        for m in [
            MetricKind::InverseMeanRatio,
            MetricKind::ConditionNumber,
            MetricKind::TargetShapeSize,
            MetricKind::ShapeSize,
        ] {
            for eps in [1e-2, 0.3, 2.0] {
                for s in [s3, inv3, flat3] {
                    fd_check_eps(m, 3, s, eps);
                }
                for s in [s2, inv2] {
                    fd_check_eps(m, 2, s, eps);
                }
            }
        }
    }

    #[test]
    fn regularised_determinant_is_positive_monotone_and_exact_at_zero_eps() {
        for d in [-1e3, -1.0, -1e-8, 0.0, 1e-8, 1.0, 1e3] {
            for eps in [1e-6, 1e-2, 1.0] {
                let (c, c1, c2) = chi(d, eps);
                assert!(c > 0.0 && c1 > 0.0 && c2 > 0.0, "chi({d}, {eps}) = {c}, {c1}, {c2}");
                // chi >= max(d, 0) and the bound is approached as eps -> 0
                assert!(c >= d.max(0.0));
                let (small, _, _) = chi(d, eps * 1e-3);
                assert!((small - d.max(0.0)).abs() <= (c - d.max(0.0)).abs());
            }
        }
        // at eps = 0 the metric is the barrier metric, bit for bit
        let s3 = [[1.1, 0.3, -0.2], [0.1, 0.9, 0.4], [-0.3, 0.2, 1.3]];
        for m in [MetricKind::InverseMeanRatio, MetricKind::ConditionNumber] {
            let a = eval(m, 3, &s3, true).unwrap();
            let b = eval_regularised(m, 3, &s3, true, 0.0).unwrap();
            assert_eq!(a, b);
            let c = eval_regularised(m, 3, &s3, true, 1e-4).unwrap();
            assert!((a.0 - c.0).abs() < 1e-8 * a.0, "{m}: {} vs {}", a.0, c.0);
        }
    }

    #[test]
    fn regularised_value_of_an_inverted_corner_is_finite_and_decreases_as_it_unfolds() {
        // S = diag(t, 1, 1): det = t; unfolding (t from -1 to 1) lowers the imr
        // with eps > 0, and with eps = 0 the inverted corner is infeasible
        let at = |t: f64| [[t, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        for m in [MetricKind::InverseMeanRatio, MetricKind::ConditionNumber] {
            assert!(eval(m, 3, &at(-0.5), false).is_none());
            let vals: Vec<f64> = [-1.0, -0.5, -0.1, 0.1, 0.5, 1.0]
                .iter()
                .map(|&t| eval_regularised(m, 3, &at(t), false, 0.1).unwrap().0)
                .collect();
            assert!(vals.windows(2).all(|w| w[1] < w[0]), "{m}: {vals:?}");
        }
    }
}
