//! The optimisers on generated meshes: convergence to the known optimum,
//! monotone decrease, fixed boundary, feasibility, invariances.

use crate::common;
use common::{perturbed_box, smooth};
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::mesh::topology;
use meshsmooth::metric;
use meshsmooth::problem::Problem;
use meshsmooth::solve::{self, Method, Params, StopReason};
use meshsmooth::{Mesh, objective};
use std::time::Duration;

/// Inverse mean ratio of each tet of a Kuhn-split cube: the optimum of the box.
const BOX_OPTIMUM: f64 = 1.322_834_2;

#[test]
fn bcd_converges_on_perturbed_20_box_to_the_known_optimum() {
    let mut mesh = perturbed_box(20, 0.3, 7);
    assert_eq!(mesh.num_elements(), 48_000);
    let start = mesh.points.clone();
    let fixed = topology::fixed_vertices(&mesh);
    let info = smooth(&mut mesh, Method::Bcd, &Params::default());

    assert_eq!(info.stop, StopReason::Converged, "{:?}", info.history.last());
    assert!(info.grad_norm < 1e-6);
    let h = &info.history.records;
    assert!(
        h[0].objective > BOX_OPTIMUM + 0.05,
        "the perturbation should matter: F0 = {}",
        h[0].objective
    );
    for w in h.windows(2) {
        assert!(
            w[1].objective <= w[0].objective,
            "objective rose: {:?} -> {:?}",
            w[0],
            w[1]
        );
    }
    assert!((info.objective - BOX_OPTIMUM).abs() < 1e-5, "F = {}", info.objective);
    for v in 0..mesh.num_points() {
        if fixed[v] {
            assert_eq!(mesh.points[v], start[v], "fixed vertex {v} moved");
        }
    }
    assert!(metric::inverted_elements(&mesh, &mesh.points).is_empty());
    // the reported objective is the objective of the returned mesh
    let p = Problem::new(&mesh).unwrap();
    let f = objective::value(&p, &p.gather(&mesh.points)).unwrap();
    assert!((f - info.objective).abs() < 1e-12);
}

#[test]
fn bcd_returns_to_the_unperturbed_grid() {
    // the paper's perturbation study: the optimum is the grid the vertices came from
    let grid = generate::tet_box(6, 6, 6, [6.0; 3]);
    let mut mesh = perturbed_box(6, 0.25, 3);
    let info = smooth(&mut mesh, Method::Bcd, &{
        let mut p = Params::default();
        p.tol = 1e-9;
        p
    });
    assert_eq!(info.stop, StopReason::Converged);
    let worst = mesh
        .points
        .iter()
        .zip(&grid.points)
        .map(|(a, b)| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    assert!(worst < 1e-4, "largest distance to the grid: {worst}");
}

#[test]
fn smoothing_commutes_with_similarity_transforms() {
    let mesh = perturbed_box(5, 0.3, 11);
    let mut a = mesh.clone();
    let mut params = Params::default();
    params.tol = 1e-10;
    smooth(&mut a, Method::Bcd, &params);
    let (c, s) = (0.6f64.cos(), 0.6f64.sin());
    let transform = |p: [f64; 3]| {
        [
            3.0 * (c * p[0] - s * p[1]) + 10.0,
            3.0 * (s * p[0] + c * p[1]) - 4.0,
            3.0 * p[2] + 0.5,
        ]
    };
    let mut b = mesh.clone();
    b.points = b.points.iter().map(|&p| transform(p)).collect();
    // the gradient scales as 1/length and the objective is invariant
    smooth(&mut b, Method::Bcd, &{
        let mut p = Params::default();
        p.tol = 1e-10 / 3.0;
        p
    });
    for (pa, pb) in a.points.iter().zip(&b.points) {
        let ta = transform(*pa);
        for i in 0..3 {
            assert!((ta[i] - pb[i]).abs() < 1e-6, "{ta:?} vs {pb:?}");
        }
    }
}

#[test]
fn laplace_keeps_the_mesh_valid_and_never_worsens_the_worst_element() {
    let mut mesh = perturbed_box(8, 0.3, 5);
    let worst = |m: &Mesh| {
        (0..m.num_elements())
            .map(|e| metric::element_eta(m, &m.points, e).unwrap())
            .fold(0.0, f64::max)
    };
    let fixed = topology::fixed_vertices(&mesh);
    let start = mesh.clone();
    let info = smooth(&mut mesh, Method::Laplace, &{
        let mut p = Params::default();
        p.max_iter = 50;
        p
    });
    assert!(info.iterations > 0);
    assert!(metric::inverted_elements(&mesh, &mesh.points).is_empty());
    assert!(worst(&mesh) <= worst(&start));
    assert!(
        info.objective < info.history.records[0].objective,
        "Laplace should improve this mesh"
    );
    for v in 0..mesh.num_points() {
        if fixed[v] {
            assert_eq!(mesh.points[v], start.points[v]);
        }
    }
}

#[test]
fn limits_stop_the_solver_with_a_valid_mesh() {
    let mut mesh = perturbed_box(10, 0.3, 2);
    let info = smooth(&mut mesh, Method::Bcd, &{
        let mut p = Params::default();
        p.max_iter = 3;
        p
    });
    assert_eq!(info.stop, StopReason::MaxIterations);
    assert_eq!(info.iterations, 3);
    assert_eq!(info.history.records.len(), 4);
    let info = smooth(&mut mesh, Method::Bcd, &{
        let mut p = Params::default();
        p.time_limit = Some(Duration::from_nanos(1));
        p
    });
    assert_eq!(info.stop, StopReason::TimeLimit);
    let mut calls = 0;
    let info = solve::smooth_mesh(
        &mut mesh,
        &Default::default(),
        &solve::Options::cpu(Method::Bcd, &Params::default()),
        &mut |_| {
            calls += 1;
            calls < 3
        },
    )
    .unwrap();
    assert_eq!(info.stop, StopReason::Cancelled);
    assert_eq!(info.iterations, 2);
    assert!(metric::inverted_elements(&mesh, &mesh.points).is_empty());
}

#[test]
fn an_inverted_start_is_refused_with_element_ids() {
    let mut mesh = generate::tet_box(3, 3, 3, [3.0; 3]);
    let centre = mesh.points.iter().position(|p| *p == [1.0, 1.0, 1.0]).unwrap();
    mesh.points[centre] = [2.6, 2.6, 2.6];
    let bad = metric::inverted_elements(&mesh, &mesh.points);
    assert!(!bad.is_empty());
    let err = solve::smooth_mesh(
        &mut mesh,
        &Default::default(),
        &solve::Options::cpu(Method::Bcd, &Params::default()),
        &mut |_| true,
    )
    .unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains(&format!("{} inverted", bad.len())), "{msg}");
    assert!(msg.contains(&bad[0].to_string()), "{msg}");
}

#[test]
fn mixed_tet_prism_hex_meshes_optimise_with_every_metric() {
    use meshsmooth::metric::corner_model::Template;
    use meshsmooth::metric::smetric::MetricKind;
    use meshsmooth::problem::ProblemOptions;
    let mut base = generate::mixed_block(4, 3);
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: 0.2 },
        fraction: 1.0,
        seed: 4,
    };
    generate::perturb(&mut base, &opts).unwrap();
    for metric in [MetricKind::InverseMeanRatio, MetricKind::ConditionNumber] {
        for method in [Method::Newton, Method::Bcd, Method::Nlcg] {
            let mut mesh = base.clone();
            let mut po = ProblemOptions::default();
            po.metric = metric;
            po.template = Template::Harmonic;
            po.reference = None;
            let info = solve::smooth_mesh(
                &mut mesh,
                &po,
                &solve::Options::cpu(method, &Params::default()),
                &mut |_| true,
            )
            .unwrap();
            assert_eq!(info.stop, StopReason::Converged, "{metric} {method}");
            assert!(info.objective < info.history.records[0].objective, "{metric} {method}");
            assert!(metric::inverted_elements(&mesh, &mesh.points).is_empty());
        }
    }
}

#[test]
fn clockwise_planar_meshes_are_smoothed_like_counter_clockwise_ones() {
    let mut ccw = generate::quad_grid(6, 5, [6.0, 5.0]);
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: 0.25 },
        fraction: 1.0,
        seed: 9,
    };
    generate::perturb(&mut ccw, &opts).unwrap();
    // the same mesh wound the other way round
    let mut cw = ccw.clone();
    for e in 0..cw.num_elements() {
        let o = cw.offsets[e];
        cw.conn.swap(o + 1, o + 3);
    }
    assert_eq!(metric::inverted_elements(&cw, &cw.points), Vec::<usize>::new());
    let report = meshsmooth::report::quality_report(&cw, &cw.points);
    assert_eq!(report.inverted, 0);
    let (mut a, mut b) = (ccw.clone(), cw.clone());
    let ia = smooth(&mut a, Method::Newton, &Params::default());
    let ib = smooth(&mut b, Method::Newton, &Params::default());
    assert_eq!(ia.stop, StopReason::Converged);
    assert!(
        (ia.objective - ib.objective).abs() < 1e-12,
        "{} vs {}",
        ia.objective,
        ib.objective
    );
    for (p, q) in a.points.iter().zip(&b.points) {
        assert!((0..3).all(|i| (p[i] - q[i]).abs() < 1e-9), "{p:?} vs {q:?}");
    }
    // and the perturbation works on the clockwise mesh too
    let mut cw2 = cw.clone();
    generate::perturb(&mut cw2, &opts).unwrap();
    assert!(metric::inverted_elements(&cw2, &cw2.points).is_empty());
}

#[test]
fn a_target_objective_stops_at_the_first_iterate_that_reaches_it() {
    for method in [Method::Newton, Method::Bcd, Method::Nlcg] {
        let mesh = perturbed_box(6, 0.3, 5);
        let mut full = mesh.clone();
        let done = smooth(&mut full, method, &Params::default());
        let f0 = done.history.first().unwrap().objective;
        // halfway between the start and the optimum
        let target = 0.5 * (f0 + done.objective);
        let mut m = mesh.clone();
        let mut params = Params::default();
        params.target_objective = Some(target);
        let info = smooth(&mut m, method, &params);
        assert_eq!(info.stop, StopReason::TargetReached, "{method}");
        assert!(
            info.objective <= target,
            "{method}: F {} above {target}",
            info.objective
        );
        let h = &info.history.records;
        assert!(
            h[..h.len() - 1].iter().all(|r| r.objective > target),
            "{method}: went past the first crossing"
        );
        assert!(info.iterations < done.iterations, "{method}");
        // the same iterates as the unstopped run, up to the stop
        for (a, b) in h.iter().zip(&done.history.records) {
            assert_eq!(a.objective, b.objective, "{method}: iteration {}", a.iteration);
        }
    }
}
