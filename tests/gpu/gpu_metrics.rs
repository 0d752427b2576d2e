//! Every metric x element kind x template on the device against the CPU:
//! objective and gradient norm, one coloured BCD sweep, full BCD solves and
//! the first Newton iterates. Without an adapter these tests print why and
//! pass — except under `CI`, where they fail.

use crate::common;
use common::{KINDS, context, max_abs_diff, meshes, models, problem, solve_on};

use meshsmooth::backend::Backend;
use meshsmooth::backend::cpu::CpuBackend;
use meshsmooth::backend::gpu::{GpuBackend, Precision};
use meshsmooth::generate;
use meshsmooth::metric::corner_model::Template;
use meshsmooth::metric::smetric::MetricKind;
use meshsmooth::solve::bcd::Bcd;
use meshsmooth::solve::{Device, Method, Params};
use meshsmooth::{ElementKind, objective};

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
}

/// Objective, gradient norm and (in f64) one coloured sweep of every case.
fn every_case(precision: Precision, tol_rel: f64, tol_edge: Option<f64>) {
    let Some(ctx) = context(precision) else {
        return;
    };
    for kind in KINDS {
        let (mesh, reference) = meshes(kind, 7);
        for (metric, template) in models() {
            let case = format!("{kind} {metric} {template:?} {precision:?}");
            let p = problem(&mesh, &reference, metric, template);
            let x0 = p.gather(&mesh.points);
            let ls = Default::default();
            let mut gpu = GpuBackend::new(&ctx, &p, &x0, &ls).unwrap();
            let mut gb = Bcd::new(&mut gpu, &p, false, &Default::default()).unwrap();
            let (cf, cg) = objective::gradient(&p, &x0).unwrap();
            let cg = objective::norm(&cg);
            let (f, g) = gb.start(&mut gpu).unwrap().expect("feasible start");
            eprintln!(
                "{case}: F {:.1e} |g| {:.1e} relative differences",
                rel(f, cf),
                rel(g, cg)
            );
            assert!(rel(f, cf) <= tol_rel, "{case}: F GPU {f} CPU {cf}");
            assert!(rel(g, cg) <= tol_rel, "{case}: |g| GPU {g} CPU {cg}");
            let Some(tol_edge) = tol_edge else {
                continue;
            };
            let mut cpu = CpuBackend::new(&p, &x0, &ls).unwrap();
            let mut cb = Bcd::new(&mut cpu, &p, false, &Default::default()).unwrap();
            cb.step(&mut cpu, None).unwrap();
            gb.step(&mut gpu, None).unwrap();
            let (gx, cx) = (gpu.download().unwrap(), cpu.download().unwrap());
            let edge = p.mean_edge_length(&x0);
            let worst = max_abs_diff(&gx, &cx) / edge;
            eprintln!("{case}: sweep differs by {worst:.1e} mean edges");
            assert!(worst <= tol_edge, "{case}: sweep differs by {worst:.1e} mean edges");
            assert!(max_abs_diff(&cx, &x0) > 1e-3 * edge, "{case}: the sweep moved nothing");
            if p.dim == 2 {
                assert!(
                    gx.iter().zip(&x0).all(|(a, b)| a[2].to_bits() == b[2].to_bits()),
                    "{case}: z moved"
                );
            }
        }
    }
}

#[test]
fn every_metric_kind_template_matches_cpu_f64() {
    every_case(Precision::F64, 1e-10, Some(1e-9));
}

#[test]
fn every_metric_kind_template_matches_cpu_f32() {
    every_case(Precision::F32, 1e-4, None);
}

fn full_solve(kind: ElementKind, metric: MetricKind) {
    let Some(ctx) = context(Precision::F64) else {
        return;
    };
    let (mesh, reference) = if kind == ElementKind::Hexahedron {
        // a distorted boundary, so that the optimum is not the regular grid
        let m = generate::distorted_hex_box(4, 3);
        (m.clone(), m)
    } else {
        meshes(kind, 3)
    };
    let p = problem(&mesh, &reference, metric, Template::Harmonic);
    let x0 = p.gather(&mesh.points);
    let mut params = Params::default();
    params.tol = 1e-8;
    let mut cx = x0.clone();
    let cpu = solve_on(&p, &mut cx, Method::BcdColored, &params, Device::Cpu);
    let mut gx = x0.clone();
    let info = solve_on(&p, &mut gx, Method::BcdColored, &params, Device::Gpu(&ctx));
    eprintln!(
        "{kind} {metric}: GPU {} sweeps F = {:.12} ({:?}), CPU {} sweeps F = {:.12}",
        info.iterations, info.objective, info.stop, cpu.iterations, cpu.objective
    );
    assert!(rel(info.objective, cpu.objective) <= 1e-6);
    assert!(p.check_feasible(&gx).is_ok());
    if p.dim == 2 {
        assert!(gx.iter().zip(&x0).all(|(a, b)| a[2].to_bits() == b[2].to_bits()));
    }
}

#[test]
#[ignore = "a full GPU solve (slow on lavapipe): run with --include-ignored"]
fn full_solve_quad_grid_matches_cpu_f64() {
    full_solve(ElementKind::Quadrilateral, MetricKind::InverseMeanRatio);
}

#[test]
#[ignore = "a full GPU solve (slow on lavapipe): run with --include-ignored"]
fn full_solve_hex_box_condition_number_matches_cpu_f64() {
    full_solve(ElementKind::Hexahedron, MetricKind::ConditionNumber);
}

fn newton_first_iterates(kind: ElementKind, metric: MetricKind, template: Template) {
    let Some(ctx) = context(Precision::F64) else {
        return;
    };
    let (mesh, reference) = meshes(kind, 5);
    let p = problem(&mesh, &reference, metric, template);
    let x0 = p.gather(&mesh.points);
    let mut params = Params::default();
    params.max_iter = 3;
    let mut cx = x0.clone();
    let cpu = solve_on(&p, &mut cx, Method::Newton, &params, Device::Cpu);
    let mut gx = x0.clone();
    let info = solve_on(&p, &mut gx, Method::Newton, &params, Device::Gpu(&ctx));
    assert_eq!(info.iterations, cpu.iterations);
    for (c, g) in cpu.history.records.iter().zip(&info.history.records) {
        eprintln!(
            "{kind} {metric} {template:?} iteration {}: F CPU {:.15} GPU {:.15}",
            c.iteration, c.objective, g.objective
        );
        assert!(rel(g.objective, c.objective) <= 1e-9);
        assert!(rel(g.grad_norm, c.grad_norm) <= 1e-9);
    }
    let worst = max_abs_diff(&gx, &cx) / p.mean_edge_length(&x0);
    eprintln!("{kind} {metric} {template:?}: iterates differ by {worst:.1e} mean edges");
    assert!(worst <= 1e-9);
    if p.dim == 2 {
        assert!(gx.iter().zip(&x0).all(|(a, b)| a[2].to_bits() == b[2].to_bits()));
    }
}

#[test]
fn newton_first_iterates_hex_condition_number_match_cpu_f64() {
    newton_first_iterates(ElementKind::Hexahedron, MetricKind::ConditionNumber, Template::Harmonic);
}

#[test]
fn newton_first_iterates_prism_average_match_cpu_f64() {
    newton_first_iterates(ElementKind::Prism, MetricKind::InverseMeanRatio, Template::Average);
}

#[test]
fn newton_first_iterates_quad_target_match_cpu_f64() {
    newton_first_iterates(
        ElementKind::Quadrilateral,
        MetricKind::TargetShapeSize,
        Template::Harmonic,
    );
}

#[test]
fn newton_first_iterates_hex_shape_size_match_cpu_f64() {
    newton_first_iterates(ElementKind::Hexahedron, MetricKind::ShapeSize, Template::Harmonic);
}

#[test]
fn newton_first_iterates_tri_shape_size_match_cpu_f64() {
    newton_first_iterates(ElementKind::Triangle, MetricKind::ShapeSize, Template::Harmonic);
}

#[test]
fn newton_first_iterates_tri_condition_number_average_match_cpu_f64() {
    newton_first_iterates(ElementKind::Triangle, MetricKind::ConditionNumber, Template::Average);
}

/// Input targets (per-corner W from the regularised mesh) with the
/// shape+size metric: the GPU's first Newton iterates are the CPU's, on a
/// perturbed quad boundary layer under triangles and on a hex box graded
/// toward a wall.
#[test]
fn newton_first_iterates_with_input_targets_match_cpu_f64() {
    use meshsmooth::generate::{PerturbOptions, Perturbation};
    use meshsmooth::problem::{InputTargets, Problem, ProblemOptions, Target};
    let Some(ctx) = context(Precision::F64) else {
        return;
    };
    for mut mesh in [
        generate::boundary_layer_2d(16, 1e-3, 1.25, 10).unwrap(),
        generate::graded_hex_box(5, 1e-3, 1.5).unwrap(),
    ] {
        let perturb = PerturbOptions {
            perturbation: Perturbation::RandomShortest { alpha: 0.3 },
            seed: 2,
            ..Default::default()
        };
        generate::perturb(&mut mesh, &perturb).unwrap();
        let mut opts = ProblemOptions::default();
        opts.metric = MetricKind::ShapeSize;
        opts.target = Target::Input(InputTargets::default());
        let p = Problem::with_options(&mesh, &opts).unwrap();
        let x0 = p.gather(&mesh.points);
        let mut params = Params::default();
        params.max_iter = 3;
        let mut cx = x0.clone();
        let cpu = solve_on(&p, &mut cx, Method::Newton, &params, Device::Cpu);
        let mut gx = x0.clone();
        let gpu = solve_on(&p, &mut gx, Method::Newton, &params, Device::Gpu(&ctx));
        assert_eq!(gpu.iterations, cpu.iterations);
        for (c, g) in cpu.history.records.iter().zip(&gpu.history.records) {
            assert!(
                rel(g.objective, c.objective) <= 1e-9,
                "F {} vs {}",
                g.objective,
                c.objective
            );
            assert!(rel(g.grad_norm, c.grad_norm) <= 1e-9);
        }
        let worst = max_abs_diff(&gx, &cx) / p.mean_edge_length(&x0);
        eprintln!(
            "{}D input targets: F {:.12}, iterates differ by {worst:.1e} mean edges",
            p.dim, cpu.objective
        );
        assert!(cpu.objective < cpu.history.records[0].objective);
        assert!(worst <= 1e-9);
    }
}
