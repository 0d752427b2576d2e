//! Box and duct generators, and the perturbations of the initial-configuration study.

use meshsmooth::generate::{PerturbOptions, Perturbation, duct, perturb, tet_box};
use meshsmooth::mesh::topology::fixed_vertices;
use meshsmooth::metric::{element_eta, element_min_det, inverted_elements};
use meshsmooth::{ElementKind, Mesh};

/// Inverse mean ratio of a Kuhn tet of a cube (Mesquite's optimum on perturbed_box_tet_20).
const KUHN_ETA: f64 = 1.32283;

fn opts(perturbation: Perturbation, fraction: f64, seed: u64) -> PerturbOptions {
    PerturbOptions {
        perturbation,
        fraction,
        seed,
    }
}

fn all_kinds(alpha: f64) -> [Perturbation; 4] {
    [
        Perturbation::Random { alpha },
        Perturbation::ShiftR { alpha },
        Perturbation::ShiftNe { alpha },
        Perturbation::Oscillatory {
            alpha,
            omega: 6.0 * std::f64::consts::PI,
        },
    ]
}

#[test]
fn box_20_has_expected_counts_and_is_valid() {
    let m = tet_box(20, 20, 20, [1.0; 3]);
    assert_eq!(m.num_points(), 9261);
    assert_eq!(m.num_elements(), 48_000);
    assert_eq!(m.count_kind(ElementKind::Tetrahedron), 48_000);
    m.validate().unwrap();
    assert_eq!(m.points[1], [0.05, 0.0, 0.0], "x varies fastest");
    assert_eq!(m.points[21], [0.0, 0.05, 0.0]);
}

#[test]
fn box_tets_are_positively_oriented() {
    let m = tet_box(3, 4, 5, [1.0, 2.0, 0.5]);
    for e in 0..m.num_elements() {
        let v = m.element(e);
        let x: Vec<[f64; 3]> = v.iter().map(|&i| m.points[i as usize]).collect();
        let d = |a: usize| std::array::from_fn::<f64, 3, _>(|i| x[a][i] - x[0][i]);
        let (a, b, c) = (d(1), d(2), d(3));
        let det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0]);
        assert!(det > 0.0, "tet {e} has det {det}");
        assert!(element_min_det(&m, &m.points, e) > 0.0);
    }
}

#[test]
fn box_cube_cells_have_optimal_eta() {
    let m = tet_box(20, 20, 20, [1.0; 3]);
    for e in 0..m.num_elements() {
        let eta = element_eta(&m, &m.points, e).unwrap();
        assert!((eta - KUHN_ETA).abs() < 1e-5, "tet {e}: eta {eta}");
    }
}

#[test]
fn box_is_conforming_so_only_box_faces_are_skin() {
    let m = tet_box(4, 3, 2, [1.0; 3]);
    let fixed = fixed_vertices(&m);
    let interior = (0..m.num_points()).filter(|&v| !fixed[v]).count();
    assert_eq!(interior, 3 * 2);
}

#[test]
fn duct_is_four_times_longer_than_wide() {
    let m = duct(3);
    assert_eq!(m.num_points(), 13 * 4 * 4);
    assert_eq!(m.num_elements(), 24 * 27);
    let max_x = m.points.iter().map(|p| p[0]).fold(0.0, f64::max);
    let max_y = m.points.iter().map(|p| p[1]).fold(0.0, f64::max);
    assert_eq!((max_x, max_y), (4.0, 1.0));
    m.validate().unwrap();
}

#[test]
fn perturbations_leave_boundary_and_never_invert() {
    let base = tet_box(10, 10, 10, [1.0; 3]);
    let fixed = fixed_vertices(&base);
    for alpha in [0.3, 2.0] {
        for p in all_kinds(alpha) {
            let mut m = base.clone();
            let stats = perturb(&mut m, &opts(p, 1.0, 7)).unwrap();
            assert!(inverted_elements(&m, &m.points).is_empty(), "{p}");
            for (v, _) in fixed.iter().enumerate().filter(|(_, f)| **f) {
                assert_eq!(m.points[v], base.points[v], "{p}: boundary vertex {v} moved");
            }
            assert_eq!(stats.selected, 9 * 9 * 9, "{p}");
            assert_eq!(stats.moved + stats.untouched, stats.selected, "{p}");
            assert!(stats.moved > 0, "{p}: {stats:?}");
            assert_ne!(m.points, base.points, "{p}");
        }
    }
}

#[test]
fn big_random_perturbation_backtracks() {
    let mut m = tet_box(10, 10, 10, [1.0; 3]);
    let stats = perturb(&mut m, &opts(Perturbation::Random { alpha: 2.0 }, 1.0, 3)).unwrap();
    assert!(stats.backtracked > 0, "{stats:?}");
    assert!(inverted_elements(&m, &m.points).is_empty());
}

#[test]
fn user_fixed_vertices_stay() {
    let mut m = tet_box(6, 6, 6, [1.0; 3]);
    let centre = 3 + 7 * (3 + 7 * 3);
    m.fixed = vec![false; m.num_points()];
    m.fixed[centre] = true;
    let before = m.points[centre];
    perturb(&mut m, &opts(Perturbation::Random { alpha: 0.3 }, 1.0, 1)).unwrap();
    assert_eq!(m.points[centre], before);
}

#[test]
fn perturbation_is_deterministic_per_seed() {
    let base = tet_box(8, 8, 8, [1.0; 3]);
    let run = |seed| {
        let mut m = base.clone();
        perturb(&mut m, &opts(Perturbation::Random { alpha: 0.3 }, 0.5, seed)).unwrap();
        m.points
    };
    let (a, b, c) = (run(42), run(42), run(43));
    assert!(
        a.iter()
            .zip(&b)
            .all(|(p, q)| p.map(f64::to_bits) == q.map(f64::to_bits))
    );
    assert_ne!(a, c);
}

#[test]
fn fraction_moves_that_share_of_free_vertices() {
    let base = tet_box(10, 10, 10, [1.0; 3]);
    for fraction in [0.01, 0.1, 0.25] {
        let mut m = base.clone();
        let stats = perturb(&mut m, &opts(Perturbation::Random { alpha: 0.2 }, fraction, 5)).unwrap();
        let changed = m.points.iter().zip(&base.points).filter(|(p, q)| p != q).count();
        let expected = fraction * 729.0;
        assert!((stats.selected as f64 - expected).abs() <= 1.0, "{fraction}: {stats:?}");
        assert!(
            (changed as f64 - expected).abs() <= 0.05 * expected + 1.0,
            "{fraction}: {changed}"
        );
    }
}

#[test]
fn planar_meshes_move_in_plane() {
    // 5x5 quads at z = 2
    let n = 6;
    let pts = (0..n * n).map(|i| [(i % n) as f64, (i / n) as f64, 2.0]).collect();
    let mut m = Mesh::new(pts);
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let v = (i + n * j) as u32;
            m.push_element(ElementKind::Quadrilateral, &[v, v + 1, v + 1 + n as u32, v + n as u32]);
        }
    }
    let base = m.clone();
    for p in all_kinds(0.3) {
        let mut m = base.clone();
        let stats = perturb(&mut m, &opts(p, 1.0, 9)).unwrap();
        assert!(stats.moved > 0);
        assert!(m.points.iter().all(|p| p[2] == 2.0), "{p}");
        assert!(inverted_elements(&m, &m.points).is_empty());
    }
}

#[test]
fn perturb_refuses_bad_options_and_inverted_meshes() {
    let base = tet_box(3, 3, 3, [1.0; 3]);
    for fraction in [0.0, -0.1, 1.5, f64::NAN] {
        let mut m = base.clone();
        assert!(perturb(&mut m, &opts(Perturbation::Random { alpha: 0.1 }, fraction, 0)).is_err());
    }
    let mut m = base.clone();
    assert!(perturb(&mut m, &opts(Perturbation::Random { alpha: f64::NAN }, 1.0, 0)).is_err());
    let mut m = base.clone();
    m.points[0][0] = 0.9; // folds the corner cell
    assert!(perturb(&mut m, &opts(Perturbation::Random { alpha: 0.1 }, 1.0, 0)).is_err());
}

#[test]
fn perturbation_text_round_trips() {
    for text in ["random:0.3", "shift-r:0.5", "shift-ne:0.5", "osc:0.1:6.28"] {
        let p: Perturbation = text.parse().unwrap();
        assert_eq!(p.to_string(), text);
        assert_eq!(p.to_string().parse::<Perturbation>().unwrap(), p);
    }
    assert_eq!(
        "osc:0.1:3.5".parse::<Perturbation>().unwrap(),
        Perturbation::Oscillatory { alpha: 0.1, omega: 3.5 }
    );
    let p = Perturbation::Random { alpha: 0.1 + 0.2 };
    assert_eq!(p.to_string().parse::<Perturbation>().unwrap(), p);
}

#[test]
fn perturbation_text_rejects_bad_input() {
    for text in [
        "random",
        "osc:1",
        "foo:1",
        "random:-1",
        "random:NaN",
        "random:inf",
        "random:x",
        "shift-r:1:2",
        "",
        "osc:1:nan",
    ] {
        let err = text.parse::<Perturbation>().unwrap_err().to_string();
        assert!(err.contains("perturbation"), "{text}: {err}");
    }
}

/// The study's duct is unstructured (a spread of shapes like the paper's
/// CUBIT ducts), and a shift moves the vertices together: a larger NE shift
/// squeezes the elements at the wall harder instead of saturating (on the
/// default duct of `generate duct`; a narrower one fills up sooner).
#[test]
fn unstructured_duct_has_a_spread_and_large_shifts_do_not_saturate() {
    if !crate::common::gmsh_for("the unstructured duct's test") {
        return;
    }
    let duct = meshsmooth::generate::unstructured_duct(meshsmooth::generate::duct_size_for(4200)).unwrap();
    let n = duct.num_points();
    assert!((3800..4600).contains(&n), "{n} vertices");
    let q = meshsmooth::report::quality_report(&duct, &duct.points);
    assert!(
        q.eta.sigma_n > 0.05 && q.eta.avg > 1.05 && q.eta.avg < 1.5,
        "{:?}",
        q.eta
    );
    let worst = |alpha: f64| {
        let mut m = duct.clone();
        perturb(&mut m, &opts(Perturbation::ShiftNe { alpha }, 1.0, 1)).unwrap();
        assert!(
            meshsmooth::metric::inverted_elements(&m, &m.points).is_empty(),
            "shift {alpha}"
        );
        meshsmooth::report::quality_report(&m, &m.points).eta.max
    };
    let (w5, w15) = (worst(5.0), worst(15.0));
    assert!(
        w15 >= 2.0 * w5,
        "worst eta {w5} after shift-ne:5, {w15} after shift-ne:15"
    );
}
