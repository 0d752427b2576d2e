//! Corners of a surface mesh: a triangle or quadrilateral corner in 3D,
//! measured in its own tangent plane. S = D W^-1 has two columns s0, s1 in
//! R^3 (the third is zero); the planar metrics depend on S only through
//! f = |S|^2 and the in-plane determinant, which in 3D is the area of the
//! parallelogram, d = |s0 x s1|. So the metric of the corner in its own
//! tangent frame is m(f, d) without building the frame, and its derivatives
//! follow from those of f and d in the six entries of S.
//!
//! Orientation: a corner is feasible when s0 x s1 points along its element's
//! reference normal (the element's own normal at the start), so a triangle
//! cannot fold over without its term passing through the barrier d -> 0, and
//! a step that jumps over it is refused as an inversion.

use super::corner_model::Template;
use super::mat3::{Mat3, Vec3, cross, dot};
use super::smetric::MetricKind;

/// Value of the corner metric and its derivatives in the columns s0, s1.
pub struct Parts {
    /// The objective term (after the template).
    pub value: f64,
    /// d value / d s_j.
    pub grad: [Vec3; 2],
    /// d^2 value / d s_i d s_j.
    pub hess: [[Mat3; 2]; 2],
}

/// Whether `metric` can measure a surface corner: those that depend on S
/// only through |S| and its determinant in 2D.
pub fn supports(metric: MetricKind) -> bool {
    matches!(metric, MetricKind::InverseMeanRatio | MetricKind::ConditionNumber)
}

fn columns(s: &Mat3) -> [Vec3; 2] {
    [[s[0][0], s[1][0], s[2][0]], [s[0][1], s[1][1], s[2][1]]]
}

/// [a]x: the matrix of v -> a x v.
fn skew(a: &Vec3) -> Mat3 {
    [[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]]
}

fn outer(a: &Vec3, b: &Vec3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| a[i] * b[j]))
}

fn at_b(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[k][i] * b[k][j]).sum()))
}

/// The signed area d (positive along `normal`) and f = |S|^2; `None` when
/// the corner is degenerate or folded against `normal`.
/// (s0 x s1) . `normal`: the corner's area as seen along its reference
/// normal, positive while it faces that way.
pub fn facing_area(s: &Mat3, normal: &Vec3) -> f64 {
    let sc = columns(s);
    dot(&cross(&sc[0], &sc[1]), normal)
}

fn invariants(s: &Mat3, normal: &Vec3) -> Option<(f64, f64, Vec3, [Vec3; 2])> {
    let sc = columns(s);
    let c = cross(&sc[0], &sc[1]);
    if !(dot(&c, normal) > 0.0) {
        return None;
    }
    let d = dot(&c, &c).sqrt();
    let f = dot(&sc[0], &sc[0]) + dot(&sc[1], &sc[1]);
    Some((f, d, c.map(|v| v / d), sc))
}

/// The inverse mean ratio f / (2 d) and its partial derivatives
/// (m, m_f, m_d, m_ff, m_fd, m_dd).
fn imr(f: f64, d: f64) -> [f64; 6] {
    [
        f / (2.0 * d),
        1.0 / (2.0 * d),
        -f / (2.0 * d * d),
        0.0,
        -1.0 / (2.0 * d * d),
        f / (d * d * d),
    ]
}

/// The term of a surface corner at S; `None` when infeasible.
pub fn value(template: Template, s: &Mat3, normal: &Vec3) -> Option<f64> {
    let (f, d, _, _) = invariants(s, normal)?;
    let m = f / (2.0 * d);
    Some(match template {
        Template::Harmonic => m,
        Template::Average => 1.0 - 1.0 / m,
    })
}

/// Term, gradient and Hessian of a surface corner at S; `None` when infeasible.
pub fn parts(template: Template, s: &Mat3, normal: &Vec3) -> Option<Parts> {
    let (f, d, ch, sc) = invariants(s, normal)?;
    let [m, mf, md, mff, mfd, mdd] = imr(f, d);
    let gf = [sc[0].map(|v| 2.0 * v), sc[1].map(|v| 2.0 * v)];
    let gd = [cross(&sc[1], &ch), cross(&ch, &sc[0])];
    // d c / d s0 = -[s1]x, d c / d s1 = [s0]x
    let s1x = skew(&sc[1]);
    let l = [s1x.map(|r| r.map(|v| -v)), skew(&sc[0])];
    let chx = skew(&ch);
    let mut grad = [[0.0; 3]; 2];
    let mut hess = [[[[0.0; 3]; 3]; 2]; 2];
    for i in 0..2 {
        grad[i] = std::array::from_fn(|a| mf * gf[i][a] + md * gd[i][a]);
        for j in 0..2 {
            let ll = at_b(&l[i], &l[j]);
            let (ff, fd, df, dd) = (
                outer(&gf[i], &gf[j]),
                outer(&gf[i], &gd[j]),
                outer(&gd[i], &gf[j]),
                outer(&gd[i], &gd[j]),
            );
            for a in 0..3 {
                for b in 0..3 {
                    // d^2 d: (|dc|^2 - (c^ . dc)^2) / d + 2 c^ . (ds0 x ds1)
                    let mut hd = (ll[a][b] - dd[a][b]) / d;
                    if i == 0 && j == 1 {
                        hd -= chx[a][b];
                    } else if i == 1 && j == 0 {
                        hd -= chx[b][a];
                    }
                    let hf = if i == j && a == b { 2.0 } else { 0.0 };
                    hess[i][j][a][b] =
                        mff * ff[a][b] + mfd * (fd[a][b] + df[a][b]) + mdd * dd[a][b] + mf * hf + md * hd;
                }
            }
        }
    }
    Some(match template {
        Template::Harmonic => Parts { value: m, grad, hess },
        Template::Average => {
            let (d1, d2) = (1.0 / (m * m), -2.0 / (m * m * m));
            for i in 0..2 {
                for j in 0..2 {
                    let gg = outer(&grad[i], &grad[j]);
                    hess[i][j] =
                        std::array::from_fn(|a| std::array::from_fn(|b| d1 * hess[i][j][a][b] + d2 * gg[a][b]));
                }
            }
            Parts {
                value: 1.0 - 1.0 / m,
                grad: grad.map(|g| g.map(|v| v * d1)),
                hess,
            }
        }
    })
}

impl Parts {
    /// The gradient with respect to a vertex whose B row is `b`.
    pub fn gradient(&self, b: &Vec3) -> Vec3 {
        std::array::from_fn(|a| b[0] * self.grad[0][a] + b[1] * self.grad[1][a])
    }

    /// The 3x3 Hessian block of two vertices with B rows `bk`, `bl`.
    pub fn block(&self, bk: &Vec3, bl: &Vec3) -> Mat3 {
        let mut out = [[0.0; 3]; 3];
        for i in 0..2 {
            for j in 0..2 {
                let w = bk[i] * bl[j];
                if w != 0.0 {
                    for a in 0..3 {
                        for b in 0..3 {
                            out[a][b] += w * self.hess[i][j][a][b];
                        }
                    }
                }
            }
        }
        out
    }
}

/// The unit Newell normal of the polygon `vs` at `points`; `None` when it has no area.
pub fn element_normal(points: &[Vec3], vs: &[u32]) -> Option<Vec3> {
    let mut n = [0.0; 3];
    let o = points[vs[0] as usize];
    for i in 1..vs.len() - 1 {
        let c = cross(
            &super::mat3::sub(&points[vs[i] as usize], &o),
            &super::mat3::sub(&points[vs[i + 1] as usize], &o),
        );
        for k in 0..3 {
            n[k] += c[k];
        }
    }
    let l = dot(&n, &n).sqrt();
    (l > 0.0 && l.is_finite()).then(|| n.map(|c| c / l))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s_of(cols: [Vec3; 2]) -> Mat3 {
        std::array::from_fn(|i| [cols[0][i], cols[1][i], 0.0])
    }

    fn rotation(axis: Vec3, angle: f64) -> Mat3 {
        let l = dot(&axis, &axis).sqrt();
        let u = axis.map(|v| v / l);
        let (c, s) = (angle.cos(), angle.sin());
        let k = skew(&u);
        std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                let id = if i == j { 1.0 } else { 0.0 };
                c * id + s * k[i][j] + (1.0 - c) * u[i] * u[j]
            })
        })
    }

    fn rot(r: &Mat3, v: &Vec3) -> Vec3 {
        std::array::from_fn(|i| (0..3).map(|k| r[i][k] * v[k]).sum())
    }

    #[test]
    fn a_tilted_corner_measures_as_the_same_corner_in_the_plane() {
        // a planar corner (in z = 0) against its rotation into a tilted plane
        let planar = s_of([[1.3, 0.2, 0.0], [0.4, 0.9, 0.0]]);
        let flat = super::super::smetric::eval(MetricKind::InverseMeanRatio, 2, &planar, false)
            .unwrap()
            .0;
        let r = rotation([0.3, -0.7, 0.5], 1.1);
        let n = rot(&r, &[0.0, 0.0, 1.0]);
        let tilted = s_of([rot(&r, &[1.3, 0.2, 0.0]), rot(&r, &[0.4, 0.9, 0.0])]);
        let v = value(Template::Harmonic, &tilted, &n).unwrap();
        assert!((v - flat).abs() < 1e-14 * flat, "{v} vs {flat}");
        // folded against its normal: infeasible
        assert!(value(Template::Harmonic, &tilted, &n.map(|c| -c)).is_none());
    }

    #[test]
    fn gradient_and_hessian_match_finite_differences() {
        let cols = [[1.1, 0.3, -0.2], [0.2, 0.8, 0.45]];
        let normal = {
            let c = cross(&cols[0], &cols[1]);
            let l = dot(&c, &c).sqrt();
            c.map(|v| v / l)
        };
        for template in [Template::Harmonic, Template::Average] {
            let p = parts(template, &s_of(cols), &normal).unwrap();
            assert_eq!(p.value, value(template, &s_of(cols), &normal).unwrap());
            let h = 1e-6;
            for i in 0..2 {
                for a in 0..3 {
                    let moved = |t: f64| {
                        let mut c = cols;
                        c[i][a] += t;
                        parts(template, &s_of(c), &normal).unwrap()
                    };
                    let (pp, pm) = (moved(h), moved(-h));
                    let fd = (pp.value - pm.value) / (2.0 * h);
                    assert!(
                        (fd - p.grad[i][a]).abs() < 1e-8,
                        "{template:?} grad {i} {a}: {fd} vs {}",
                        p.grad[i][a]
                    );
                    for j in 0..2 {
                        for b in 0..3 {
                            let fd = (pp.grad[j][b] - pm.grad[j][b]) / (2.0 * h);
                            let an = p.hess[j][i][b][a];
                            assert!(
                                (fd - an).abs() < 1e-7 * (1.0 + an.abs()),
                                "{template:?} hess {j}{b} {i}{a}: {fd} vs {an}"
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn frames_are_right_handed_and_the_facing_area_is_its_polynomial() {
        let n = {
            let v = [0.2, -0.9, 0.4];
            let l = dot(&v, &v).sqrt();
            v.map(|c| c / l)
        };
        // the axes the reports measure a surface element in
        let ax = crate::mesh::plane::axes_with_normal(&n);
        assert!(dot(&cross(&ax[0], &ax[1]), &ax[2]) > 1.0 - 1e-14);
        // S in those axes has the facing area as its leading 2x2 determinant
        let s = s_of([[1.0, 0.2, 0.3], [-0.1, 0.5, 0.7]]);
        let r: Mat3 = std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| ax[i][k] * s[k][j]).sum()));
        let det2 = r[0][0] * r[1][1] - r[0][1] * r[1][0];
        assert!((det2 - facing_area(&s, &n)).abs() < 1e-14);
        // the inversion bound's coefficients give the facing area along a straight move
        let e = s_of([[-0.4, 0.9, 0.1], [0.3, -0.8, 0.2]]);
        let c = super::super::det_path::facing_coefficients(&s, &e, &n);
        for t in [0.0, 0.3, 1.0, 2.5] {
            let st: Mat3 = std::array::from_fn(|i| std::array::from_fn(|j| s[i][j] + t * e[i][j]));
            let want = facing_area(&st, &n);
            let got = c[0] + t * (c[1] + t * (c[2] + t * c[3]));
            assert!(
                (got - want).abs() < 1e-14 * (1.0 + want.abs()),
                "t {t}: {got} vs {want}"
            );
        }
    }
}
