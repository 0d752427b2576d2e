//! Finite-difference checks of the analytic metric derivatives, known values,
//! and invariances of the inverse mean ratio.

use crate::common;
use common::Tet;
use meshsmooth::metric::{TetShape, tet_det};

fn regular_tet() -> Tet {
    [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.5, 3f64.sqrt() / 2.0, 0.0],
        [0.5, 3f64.sqrt() / 6.0, (2.0f64 / 3.0).sqrt()],
    ]
}

/// Random positively oriented tets; `flatten` squeezes z to make poor shapes:
/// badly shaped, but not so close to degenerate that finite differences lose all digits.
fn random_tets(seed: u64, count: usize, flatten: f64) -> Vec<Tet> {
    common::random_tets(seed, count, flatten, 200.0)
}

fn max_edge_sq(x: &Tet) -> f64 {
    let mut m: f64 = 0.0;
    for a in 0..4 {
        for b in a + 1..4 {
            m = m.max((0..3).map(|i| (x[a][i] - x[b][i]).powi(2)).sum());
        }
    }
    m
}

fn rel_err(a: f64, b: f64, scale: f64) -> f64 {
    (a - b).abs() / scale.max(1e-300)
}

fn check_derivatives(shape: &TetShape, tets: &[Tet]) {
    for (n, x) in tets.iter().enumerate() {
        let (eta, g, h) = shape.hessian(x).unwrap();
        let gscale = g.iter().flatten().map(|v| v.abs()).fold(0.0, f64::max);
        let hscale = h.iter().flatten().map(|v| v.abs()).fold(0.0, f64::max);
        assert!((shape.value(x).unwrap() - eta).abs() <= 1e-14 * eta);
        for k in 0..4 {
            for i in 0..3 {
                // fourth-order central differences, the step scaled to the element's
                // smallest height (volume over the largest squared edge)
                let step = 1e-4 * tet_det(x) / max_edge_sq(x);
                let at = |t: f64| {
                    let mut p = *x;
                    p[k][i] += t * step;
                    p
                };
                let fd4 = |f: &dyn Fn(&Tet) -> f64| {
                    (-f(&at(2.0)) + 8.0 * f(&at(1.0)) - 8.0 * f(&at(-1.0)) + f(&at(-2.0))) / (12.0 * step)
                };
                let fd = fd4(&|t| shape.value(t).unwrap());
                let e = rel_err(fd, g[k][i], gscale);
                assert!(
                    e < 1e-6,
                    "tet {n}: gradient[{k}][{i}] analytic {} fd {fd} rel {e}",
                    g[k][i]
                );
                for l in 0..4 {
                    for q in 0..3 {
                        let fdh = fd4(&|t| shape.gradient(t).unwrap().1[l][q]);
                        let e = rel_err(fdh, h[3 * k + i][3 * l + q], hscale);
                        assert!(
                            e < 1e-6,
                            "tet {n}: H[{k}{i}][{l}{q}] analytic {} fd {fdh}",
                            h[3 * k + i][3 * l + q]
                        );
                    }
                }
            }
            let (ev, gv, hv) = shape.vertex_gradient_hessian(x, k).unwrap();
            assert_eq!(ev, eta);
            for i in 0..3 {
                assert!(rel_err(gv[i], g[k][i], gscale) < 1e-13);
                for q in 0..3 {
                    let e = rel_err(hv[i][q], h[3 * k + i][3 * k + q], hscale);
                    assert!(
                        e < 1e-12,
                        "tet {n}: vertex block {k} [{i}][{q}]: {} vs {}",
                        hv[i][q],
                        h[3 * k + i][3 * k + q]
                    );
                }
            }
        }
        for a in 0..12 {
            for b in 0..12 {
                assert_eq!(h[a][b], h[b][a], "Hessian not symmetric");
            }
        }
    }
}

#[test]
fn mean_ratio_derivatives_match_finite_differences_on_good_tets() {
    check_derivatives(&TetShape::equilateral(), &random_tets(1, 300, 1.0));
}

#[test]
fn mean_ratio_derivatives_match_finite_differences_on_flat_tets() {
    check_derivatives(&TetShape::equilateral(), &random_tets(2, 300, 0.02));
}

#[test]
fn mean_ratio_derivatives_match_finite_differences_with_general_reference() {
    let r = [[1.3, 0.2, -0.4], [0.0, 0.7, 0.3], [0.0, 0.0, 2.1]];
    check_derivatives(&TetShape::from_r(&r), &random_tets(3, 200, 0.5));
}

#[test]
fn regular_tet_has_inverse_mean_ratio_one_and_zero_gradient() {
    let shape = TetShape::equilateral();
    let (eta, g) = shape.gradient(&regular_tet()).unwrap();
    assert!((eta - 1.0).abs() < 1e-14, "eta = {eta}");
    assert!(g.iter().flatten().all(|v| v.abs() < 1e-13), "{g:?}");
    // any other shape is worse
    for t in random_tets(4, 100, 1.0) {
        assert!(shape.value(&t).unwrap() > 1.0);
    }
}

#[test]
fn inverted_and_degenerate_tets_are_infeasible() {
    let shape = TetShape::equilateral();
    let mut t = regular_tet();
    t.swap(1, 2);
    assert!(shape.value(&t).is_none());
    assert!(shape.gradient(&t).is_none());
    assert!(shape.hessian(&t).is_none());
    assert!(shape.vertex_gradient_hessian(&t, 0).is_none());
    let mut flat = regular_tet();
    flat[3][2] = 0.0;
    assert!(shape.value(&flat).is_none());
}

#[test]
fn mean_ratio_is_invariant_under_translation_rotation_and_scaling() {
    let shape = TetShape::equilateral();
    let (c, s) = (0.7f64.cos(), 0.7f64.sin());
    let (c2, s2) = (1.9f64.cos(), 1.9f64.sin());
    let rot = |p: [f64; 3]| {
        let q = [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]];
        [q[0], c2 * q[1] - s2 * q[2], s2 * q[1] + c2 * q[2]]
    };
    for t in random_tets(5, 200, 0.3) {
        let eta = shape.value(&t).unwrap();
        let (_, g) = shape.gradient(&t).unwrap();
        let moved = t.map(|p| [p[0] + 12.5, p[1] - 3.0, p[2] + 1e3]);
        let rotated = t.map(rot);
        let scaled = t.map(|p| p.map(|v| v * 37.0));
        for (name, other) in [("translated", moved), ("rotated", rotated), ("scaled", scaled)] {
            let e = shape.value(&other).unwrap();
            assert!((e - eta).abs() < 1e-10 * eta, "{name}: {e} vs {eta}");
        }
        // the gradient rotates with the element and scales as 1/length
        let (_, gs) = shape.gradient(&scaled).unwrap();
        let (_, gr) = shape.gradient(&rotated).unwrap();
        for k in 0..4 {
            let grot = rot(g[k]);
            for i in 0..3 {
                assert!((gs[k][i] * 37.0 - g[k][i]).abs() < 1e-9 * (1.0 + g[k][i].abs()));
                assert!((gr[k][i] - grot[i]).abs() < 1e-9 * (1.0 + grot[i].abs()));
            }
        }
    }
}

#[test]
fn all_corner_orderings_agree_for_tets() {
    // Footnote 4 of the Newton paper: with the equilateral reference every
    // corner of a tet gives the same mean ratio, so one corner suffices.
    let shape = TetShape::equilateral();
    for t in random_tets(6, 100, 0.4) {
        let eta = shape.value(&t).unwrap();
        for c in meshsmooth::ElementKind::Tetrahedron.corners() {
            let p = [t[c[0]], t[c[1]], t[c[2]], t[c[3]]];
            assert!((shape.value(&p).unwrap() - eta).abs() < 1e-12 * eta);
        }
    }
}

#[test]
fn structured_hessian_blocks_equal_the_generic_hessian() {
    let shape = TetShape::equilateral();
    for x in random_tets(8, 300, 0.3) {
        let (eta, g, h) = shape.hessian(&x).unwrap();
        let mut blocks = [[[[0.0; 3]; 3]; 4]; 4];
        let (eta2, g2) = shape.upper_hessian_blocks(&x, &mut blocks).unwrap();
        assert_eq!(eta, eta2);
        assert_eq!(g, g2);
        let scale = h.iter().flatten().map(|v| v.abs()).fold(0.0, f64::max);
        for k in 0..4 {
            for l in k..4 {
                for i in 0..3 {
                    for q in 0..3 {
                        let (a, b) = (blocks[k][l][i][q], h[3 * k + i][3 * l + q]);
                        assert!((a - b).abs() <= 1e-13 * scale, "block ({k},{l}) [{i}][{q}]: {a} vs {b}");
                    }
                }
            }
        }
    }
}
