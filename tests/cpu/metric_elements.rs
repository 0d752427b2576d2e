//! Every metric x element kind x template through the corner model: element
//! values, gradients and Hessians against finite differences, ideal values,
//! and the reference-mesh targets.

use meshsmooth::ElementKind;
use meshsmooth::metric::corner::ideal_corner;
use meshsmooth::metric::corner_model::{CornerShape, Model, Template};
use meshsmooth::metric::smetric::MetricKind;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

type Vec3 = [f64; 3];

const METRICS: [MetricKind; 3] = [
    MetricKind::InverseMeanRatio,
    MetricKind::ConditionNumber,
    MetricKind::TargetShapeSize,
];

/// The ideal element of each kind (edge 1), vertices in VTK order.
fn ideal(kind: ElementKind) -> Vec<Vec3> {
    let h = 3f64.sqrt() / 2.0;
    let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, h, 0.0]];
    let quad = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
    match kind {
        ElementKind::Triangle => tri.to_vec(),
        ElementKind::Quadrilateral => quad.to_vec(),
        ElementKind::Tetrahedron => {
            vec![tri[0], tri[1], tri[2], [0.5, 3f64.sqrt() / 6.0, (2.0f64 / 3.0).sqrt()]]
        }
        // the polyhedron is the cube given by its faces: its corners are
        // the octant corners, the polyhedron's ideal (W = I)
        ElementKind::Hexahedron | ElementKind::Polyhedron => (0..8)
            .map(|i| [quad[i % 4][0], quad[i % 4][1], (i / 4) as f64])
            .collect(),
        ElementKind::Prism => (0..6).map(|i| [tri[i % 3][0], tri[i % 3][1], (i / 3) as f64]).collect(),
    }
}

/// The cube's faces, outward, in the order of VTK's polyhedron example.
const CUBE_FACES: [[u32; 4]; 6] = [
    [0, 3, 2, 1],
    [0, 4, 7, 3],
    [4, 5, 6, 7],
    [5, 1, 2, 6],
    [0, 1, 5, 4],
    [2, 3, 7, 6],
];

/// The corners the solvers use: simplices one, the others all; the
/// polyhedron's computed from its faces.
fn corners(kind: ElementKind) -> Vec<[usize; 4]> {
    match kind {
        ElementKind::Polyhedron => {
            let vs: Vec<u32> = (0..8).collect();
            meshsmooth::mesh::polyhedron::corners(&vs, CUBE_FACES.iter().map(|f| &f[..])).unwrap()
        }
        _ => kind.optimised_corners().to_vec(),
    }
}

struct Element {
    kind: ElementKind,
    shapes: Vec<CornerShape>,
    model: Model,
}

impl Element {
    fn new(kind: ElementKind, model: Model, reference: Option<&[Vec3]>) -> Element {
        let n = kind.dim();
        let shapes = corners(kind)
            .iter()
            .map(|c| {
                let w = match reference {
                    None => ideal_corner(kind),
                    Some(r) => {
                        let mut w = [[0.0; 3]; 3];
                        for col in 0..n {
                            for row in 0..n {
                                w[row][col] = r[c[col + 1]][row] - r[c[0]][row];
                            }
                        }
                        w
                    }
                };
                CornerShape::from_w(&w, n).unwrap()
            })
            .collect();
        Element { kind, shapes, model }
    }

    fn local(&self, x: &[Vec3], c: &[usize; 4]) -> [Vec3; 4] {
        let n = self.kind.dim();
        let mut p = [x[c[0]]; 4];
        for k in 0..=n {
            p[k] = x[c[k]];
        }
        p
    }

    /// Mean corner term.
    fn value(&self, x: &[Vec3]) -> Option<f64> {
        let cs = corners(self.kind);
        let mut sum = 0.0;
        for (c, shape) in cs.iter().zip(&self.shapes) {
            sum += self.model.value(shape, &self.local(x, c))?;
        }
        Some(sum / cs.len() as f64)
    }

    /// Gradient and Hessian over the element's vertices (3 per vertex; in 2D the
    /// z entries carry the solver's padding and are skipped by the checks).
    fn derivatives(&self, x: &[Vec3]) -> (Vec<f64>, Vec<Vec<f64>>) {
        let cs = corners(self.kind);
        let nv = x.len();
        let n = self.kind.dim();
        let mut g = vec![0.0; 3 * nv];
        let mut h = vec![vec![0.0; 3 * nv]; 3 * nv];
        for (c, shape) in cs.iter().zip(&self.shapes) {
            let mut blocks = [[[[0.0; 3]; 3]; 4]; 4];
            let (_, gc) = self.model.blocks(shape, &self.local(x, c), &mut blocks).unwrap();
            for a in 0..=n {
                for i in 0..3 {
                    g[3 * c[a] + i] += gc[a][i] / cs.len() as f64;
                    for b in 0..=n {
                        for q in 0..3 {
                            h[3 * c[a] + i][3 * c[b] + q] += blocks[a][b][i][q] / cs.len() as f64;
                        }
                    }
                }
            }
            // the per-vertex blocks BCD uses agree with the full ones
            for a in 0..=n {
                let s = shape.tet.s_rest(&self.local(x, c), usize::MAX);
                let (_, gv, hv) = self
                    .model
                    .vertex_gradient_hessian_of_s(shape, s, shape.tet.b(a))
                    .unwrap();
                for i in 0..n {
                    assert!((gv[i] - gc[a][i]).abs() <= 1e-12 * (1.0 + gc[a][i].abs()));
                    for q in 0..n {
                        assert!((hv[i][q] - blocks[a][a][i][q]).abs() <= 1e-10 * (1.0 + hv[i][q].abs()));
                    }
                }
            }
        }
        (g, h)
    }
}

fn perturbed(kind: ElementKind, rng: &mut ChaCha8Rng, amount: f64) -> Vec<Vec3> {
    let n = kind.dim();
    ideal(kind)
        .into_iter()
        .map(|mut p| {
            for c in p.iter_mut().take(n) {
                *c = *c * 1.3 + amount * rng.random_range(-1.0..1.0);
            }
            p
        })
        .collect()
}

fn check_fd(el: &Element, x: &[Vec3], label: &str) {
    let (g, h) = el.derivatives(x);
    let n = el.kind.dim();
    let gs = g.iter().map(|v| v.abs()).fold(1e-12, f64::max);
    let hs = h.iter().flatten().map(|v| v.abs()).fold(1e-12, f64::max);
    let step = 1e-4;
    for v in 0..x.len() {
        for i in 0..n {
            let at = |t: f64| {
                let mut y = x.to_vec();
                y[v][i] += t * step;
                y
            };
            let fd4 = |f: &dyn Fn(&[Vec3]) -> f64| {
                (-f(&at(2.0)) + 8.0 * f(&at(1.0)) - 8.0 * f(&at(-1.0)) + f(&at(-2.0))) / (12.0 * step)
            };
            let fd = fd4(&|y| el.value(y).unwrap());
            let a = g[3 * v + i];
            assert!(
                (fd - a).abs() <= 1e-6 * gs,
                "{label}: gradient v{v}.{i}: {a} vs fd {fd}"
            );
            for w in 0..x.len() {
                for q in 0..n {
                    let fdh = fd4(&|y| el.derivatives(y).0[3 * w + q]);
                    let a = h[3 * v + i][3 * w + q];
                    assert!(
                        (fdh - a).abs() <= 1e-6 * hs,
                        "{label}: H v{v}.{i} w{w}.{q}: {a} vs fd {fdh}"
                    );
                }
            }
        }
    }
}

#[test]
fn every_metric_and_element_kind_matches_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for kind in ElementKind::ALL {
        for metric in METRICS {
            for template in [Template::Harmonic, Template::Average] {
                if metric == MetricKind::TargetShapeSize && template == Template::Average {
                    continue;
                }
                let reference = perturbed(kind, &mut rng, 0.1);
                let el = Element::new(
                    kind,
                    Model {
                        metric,
                        template,
                        eps: 0.0,
                    },
                    Some(&reference),
                );
                // an infeasible draw is redrawn, so every case checks four elements
                let mut checked = 0;
                for draw in 0..100 {
                    if checked == 4 {
                        break;
                    }
                    let x = perturbed(kind, &mut rng, 0.15);
                    if el.value(&x).is_none() {
                        continue;
                    }
                    check_fd(&el, &x, &format!("{kind} {metric} {template:?} #{draw}"));
                    checked += 1;
                }
                assert_eq!(checked, 4, "{kind} {metric} {template:?}: too few feasible trials");
            }
        }
    }
}

#[test]
fn ideal_elements_have_the_ideal_values() {
    for kind in ElementKind::ALL {
        let x = ideal(kind);
        let scaled: Vec<Vec3> = x.iter().map(|p| p.map(|c| 2.5 * c)).collect();
        for metric in [MetricKind::InverseMeanRatio, MetricKind::ConditionNumber] {
            let el = Element::new(
                kind,
                Model {
                    metric,
                    template: Template::Harmonic,
                    eps: 0.0,
                },
                None,
            );
            for pts in [&x, &scaled] {
                let v = el.value(pts).unwrap();
                assert!((v - 1.0).abs() < 1e-13, "{kind} {metric}: {v}");
            }
            let avg = Element::new(
                kind,
                Model {
                    metric,
                    template: Template::Average,
                    eps: 0.0,
                },
                None,
            );
            assert!(avg.value(&x).unwrap().abs() < 1e-13, "{kind} {metric} average");
        }
        // the target metric is zero exactly when the element equals its reference
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let r = perturbed(kind, &mut rng, 0.1);
        let el = Element::new(
            kind,
            Model {
                metric: MetricKind::TargetShapeSize,
                template: Template::Harmonic,
                eps: 0.0,
            },
            Some(&r),
        );
        assert!(el.value(&r).unwrap() < 1e-24, "{kind} tmp at the reference");
        assert!(el.value(&scaled).unwrap() > 1e-3, "{kind} tmp elsewhere");
    }
}
