//! Nonlinear CG on meshes (the line search and NLCG on plain functions are
//! unit-tested in `solve::wolfe` and `solve::nlcg`): it reaches Newton's
//! optimum for every metric and element kind, never accepts an inverted
//! element, and stops on its step tolerance.

use crate::common;
use common::{KINDS, meshes, models, perturbed_box, problem, solve_on};

use meshsmooth::metric;
use meshsmooth::objective;
use meshsmooth::problem::Problem;
use meshsmooth::solve::nlcg::NlcgParams;
use meshsmooth::solve::{self, Device, Method, Params, StopReason};

/// Every accepted iterate is feasible and lowers F; `smooth` reports the
/// F of the positions it returns.
fn assert_monotone_and_feasible(info: &solve::Info, p: &Problem, x: &[[f64; 3]], case: &str) {
    let r = &info.history.records;
    // (non-strictly: at the optimum the decrease is below the rounding of F)
    assert!(r.windows(2).all(|w| w[1].objective <= w[0].objective), "{case}: F rose");
    let f = objective::value(p, x).unwrap_or_else(|| panic!("{case}: inverted result"));
    assert!(
        (f - info.objective).abs() <= 1e-12 * f.abs().max(1.0),
        "{case}: {f} vs {}",
        info.objective
    );
}

#[test]
fn nlcg_reaches_newtons_objective_on_a_perturbed_tet_box() {
    for seed in [1, 2] {
        let mesh = perturbed_box(6, 0.3, seed);
        let p = Problem::new(&mesh).unwrap();
        let x0 = p.gather(&mesh.points);
        let mut params = Params::default();
        params.tol = 1e-7;
        let mut xn = x0.clone();
        let newton = solve_on(&p, &mut xn, Method::Newton, &params, Device::Cpu);
        let mut xc = x0.clone();
        let info = solve_on(&p, &mut xc, Method::Nlcg, &params, Device::Cpu);
        eprintln!(
            "seed {seed}: NLCG {} iterations F {:.12}, Newton {} iterations F {:.12}",
            info.iterations, info.objective, newton.iterations, newton.objective
        );
        assert_eq!(info.method, Method::Nlcg);
        assert_eq!(info.stop, StopReason::Converged);
        assert!(info.grad_norm < params.tol);
        assert!((info.objective - newton.objective).abs() <= 1e-10 * newton.objective);
        assert_monotone_and_feasible(&info, &p, &xc, &format!("seed {seed}"));
        // the same minimiser, vertex by vertex (F is flat near it: looser)
        let edge = p.mean_edge_length(&x0);
        let worst = xc
            .iter()
            .flatten()
            .zip(xn.iter().flatten())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            worst <= 1e-5 * edge,
            "seed {seed}: vertices differ by {:.1e} edges",
            worst / edge
        );
    }
}

#[test]
fn nlcg_reaches_newtons_objective_for_every_metric_and_element_kind() {
    for kind in KINDS {
        let (mesh, reference) = meshes(kind, 3);
        for (metric, template) in models() {
            let p = problem(&mesh, &reference, metric, template);
            let x0 = p.gather(&mesh.points);
            // a tighter tolerance is below what a line search on values of
            // F can resolve (F's rounding hides the decrease)
            let mut params = Params::default();
            params.tol = 1e-7;
            let mut xn = x0.clone();
            let newton = solve_on(&p, &mut xn, Method::Newton, &params, Device::Cpu);
            let mut xc = x0.clone();
            let info = solve_on(&p, &mut xc, Method::Nlcg, &params, Device::Cpu);
            let case = format!("{kind:?} {metric} {template:?}");
            eprintln!(
                "{case}: NLCG {} iterations F {:.12} |g| {:.1e} ({:?}), Newton {} F {:.12}",
                info.iterations, info.objective, info.grad_norm, info.stop, newton.iterations, newton.objective
            );
            assert_eq!(info.stop, StopReason::Converged, "{case}");
            assert!(
                (info.objective - newton.objective).abs() <= 1e-10 * newton.objective.abs().max(1.0),
                "{case}: {} vs {}",
                info.objective,
                newton.objective
            );
            assert!(info.objective < info.history.records[0].objective, "{case}");
            assert_monotone_and_feasible(&info, &p, &xc, &case);
        }
    }
}

#[test]
fn nlcg_keeps_a_nearly_inverted_mesh_valid() {
    // large perturbations leave elements close to inversion: long trial
    // steps invert them, and the line search must step back
    let mut mesh = perturbed_box(5, 0.45, 7);
    let p = Problem::new(&mesh).unwrap();
    let mut x = p.gather(&mesh.points);
    let params = NlcgParams {
        first_move: 2.0,
        ..NlcgParams::default()
    };
    let info = solve_on(
        &p,
        &mut x,
        Method::Nlcg,
        &{
            let mut p = Params::default();
            p.nlcg = params;
            p
        },
        Device::Cpu,
    );
    assert_eq!(info.stop, StopReason::Converged);
    assert_monotone_and_feasible(&info, &p, &x, "nearly inverted");
    mesh.points = p.scatter(&x);
    assert!(metric::inverted_elements(&mesh, &mesh.points).is_empty());
}

#[test]
fn a_step_below_tol_x_stops_nlcg() {
    let mesh = perturbed_box(5, 0.3, 4);
    let p = Problem::new(&mesh).unwrap();
    let x0 = p.gather(&mesh.points);
    let edge = p.mean_edge_length(&x0);
    let tol_x = 1e-3;
    let params = |max_iter| {
        let mut p = Params::default();
        p.tol = 1e-12;
        p.max_iter = max_iter;
        p.nlcg = NlcgParams {
            tol_x,
            ..NlcgParams::default()
        };
        p
    };
    let mut x = x0.clone();
    let info = solve_on(&p, &mut x, Method::Nlcg, &params(1000), Device::Cpu);
    assert_eq!(info.stop, StopReason::SmallStep);
    let k = info.iterations;
    assert!(k > 3);
    // the iterates again, run by run (a run of j iterations repeats the
    // first j): only the last step moved no vertex farther than tol_x
    let mut prev = x0.clone();
    for j in 1..=k {
        let mut y = x0.clone();
        solve_on(&p, &mut y, Method::Nlcg, &params(j), Device::Cpu);
        let moved = y
            .iter()
            .zip(&prev)
            .map(|(a, b)| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt())
            .fold(0.0, f64::max)
            / edge;
        assert!(moved > 0.0);
        assert_eq!(moved <= tol_x, j == k, "iteration {j} of {k} moved {moved:.2e} edges");
        prev = y;
    }
    assert_eq!(prev, x);
}

/// The line search's evaluations per iteration, with the paper's fixed
/// bracketing increment and with the doubling one, for the README:
/// `cargo test --release --test cpu nlcg:: -- --ignored --nocapture`.
#[test]
#[ignore]
fn nlcg_line_search_costs() {
    use meshsmooth::backend::cpu::CpuBackend;
    use meshsmooth::solve::nlcg::Nlcg;
    use meshsmooth::solve::wolfe::Wolfe;
    use std::time::Instant;
    let mut hexes = meshsmooth::generate::hex_box(16, 16, 16, [16.0; 3]);
    let perturb = meshsmooth::generate::PerturbOptions {
        perturbation: meshsmooth::generate::Perturbation::Random { alpha: 0.3 },
        fraction: 1.0,
        seed: 1,
    };
    meshsmooth::generate::perturb(&mut hexes, &perturb).unwrap();
    for (name, mesh) in [("tet box 20^3", perturbed_box(20, 0.3, 1)), ("hex box 16^3", hexes)] {
        let p = Problem::new(&mesh).unwrap();
        let x0 = p.gather(&mesh.points);
        let edge = p.mean_edge_length(&x0);
        for growth in [1.0, 2.0] {
            for first_move in [0.01, 0.1, 1.0] {
                let params = NlcgParams {
                    first_move,
                    line_search: Wolfe {
                        growth,
                        ..Wolfe::default()
                    },
                    ..NlcgParams::default()
                };
                let mut be = CpuBackend::new(&p, &x0, &Default::default()).unwrap();
                let mut nlcg = Nlcg::new(&mut be, params, edge).unwrap();
                let t = Instant::now();
                let (_, mut g) = nlcg.start(&mut be).unwrap().unwrap();
                let mut f = 0.0;
                let mut iterations = 0;
                while g * edge >= 1e-6 && iterations < 1000 {
                    let s = nlcg.step(&mut be).unwrap();
                    if s.max_move_sq == 0.0 {
                        break;
                    }
                    (f, g) = (s.objective, s.grad_norm);
                    iterations += 1;
                }
                eprintln!(
                    "{name}: growth {growth}, first move {first_move}: {iterations} iterations, {} evaluations ({:.2}/iteration), {}/{} strong Wolfe, F {f:.10}, {:.2} s",
                    nlcg.evaluations,
                    nlcg.evaluations as f64 / iterations as f64,
                    nlcg.wolfe_steps,
                    nlcg.searches,
                    t.elapsed().as_secs_f64()
                );
            }
        }
    }
}
