//! Inexact Newton on the device against its CPU twins: each kernel, PCG, the
//! Newton iterates and the converged result. Without an adapter these tests
//! print why and pass — except under `CI`, where they fail.

mod common;
use common::context;

use meshsmooth::backend::gpu::{self, GpuNewton, GpuRunOptions, Precision};
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::metric::{self, mat3::Mat3};
use meshsmooth::problem::Problem;
use meshsmooth::solve::bsr::HessianPattern;
use meshsmooth::solve::pcg::{self, BlockJacobi, NegativeCurvature, PcgParams, Precond};
use meshsmooth::solve::{self, Method, Params};
use meshsmooth::{Error, Mesh, objective};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::time::Instant;

type Vec3 = [f64; 3];

fn perturbed_box(n: usize, seed: u64) -> Mesh {
    let mut m = generate::tet_box(n, n, n, [n as f64; 3]);
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: 0.3 },
        fraction: 1.0,
        seed,
    };
    generate::perturb(&mut m, &opts).unwrap();
    m
}

/// Largest |a - b| over the largest |b|: errors measured against the vector's scale.
fn rel_diff(a: &[Vec3], b: &[Vec3]) -> f64 {
    let scale = b.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let worst = a
        .iter()
        .flatten()
        .zip(b.iter().flatten())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    worst / scale.max(f64::MIN_POSITIVE)
}

/// Largest entry error of each block over that block's largest entry.
fn block_rel_diff(a: &[Mat3], b: &[Mat3]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| {
            let scale = y.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
            let worst = x
                .iter()
                .flatten()
                .zip(y.iter().flatten())
                .map(|(u, v)| (u - v).abs())
                .fold(0.0, f64::max);
            worst / scale.max(f64::MIN_POSITIVE)
        })
        .fold(0.0, f64::max)
}

/// Seeded vectors quantised to multiples of 1/64, so products are exact-ish
/// and differences show the kernels, not the inputs.
fn random_vec(n: usize, seed: u64) -> Vec<Vec3> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| [0; 3].map(|_: i32| rng.random_range(-64i32..=64) as f64 / 64.0))
        .collect()
}

struct Assembled {
    p: Problem,
    x: Vec<Vec3>,
    pattern: HessianPattern,
    grad: Vec<Vec3>,
}

fn cpu_assembled(n: usize) -> Assembled {
    let mesh = perturbed_box(n, 1);
    let p = Problem::new(&mesh).unwrap();
    let x = p.gather(&mesh.points);
    let mut pattern = HessianPattern::new(&p);
    let mut grad = vec![[0.0; 3]; pattern.free_vertex.len()];
    assert!(pattern.assemble(&p, &x, &mut grad));
    Assembled { p, x, pattern, grad }
}

fn kernels_match(precision: Precision, tol: f64) {
    let Some(ctx) = context(precision) else {
        return;
    };
    let a = cpu_assembled(7);
    let m = &a.pattern.matrix;
    let mut gpu = GpuNewton::new(&ctx, &a.p, &a.x, Default::default(), &Default::default()).unwrap();
    let (f, gnorm) = gpu.assemble().unwrap();
    let cf = objective::value(&a.p, &a.x).unwrap();
    let cg = objective::norm(&a.grad);
    assert!((f - cf).abs() <= tol * cf, "F {f} vs {cf}");
    assert!((gnorm - cg).abs() <= tol * cg, "|g| {gnorm} vs {cg}");

    let eg = rel_diff(&gpu.gradient().unwrap(), &a.grad);
    let eh = block_rel_diff(&gpu.hessian_blocks().unwrap(), &m.blocks);
    let n = a.grad.len();
    let (u, w) = (random_vec(n, 2), random_vec(n, 3));
    let mut cpu_y = vec![[0.0; 3]; n];
    m.mul(&u, &mut cpu_y);
    let es = rel_diff(&gpu.mul(&u).unwrap(), &cpu_y);
    let jac = BlockJacobi::new(m.diag.par_iter().map(|&s| m.blocks[s as usize]));
    let mut cpu_z = vec![[0.0; 3]; n];
    jac.apply(&u, &mut cpu_z);
    let ej = rel_diff(&gpu.precondition(&u).unwrap(), &cpu_z);
    let cpu_dot: f64 = u
        .iter()
        .zip(&w)
        .map(|(p, q)| p[0] * q[0] + p[1] * q[1] + p[2] * q[2])
        .sum();
    let ed = (gpu.dot_of(&u, &w).unwrap() - cpu_dot).abs() / cpu_dot.abs();
    let cpu_axpy: Vec<Vec3> = u
        .iter()
        .zip(&w)
        .map(|(p, q)| [0, 1, 2].map(|c| q[c] + 0.375 * p[c]))
        .collect();
    let ea = rel_diff(&gpu.axpy(0.375, &u, &w).unwrap(), &cpu_axpy);
    eprintln!(
        "{precision:?} kernels vs CPU: gradient {eg:.1e} Hessian blocks {eh:.1e} SpMV {es:.1e} \
         block-Jacobi {ej:.1e} dot {ed:.1e} axpy {ea:.1e}"
    );
    for (name, e) in [
        ("gradient", eg),
        ("Hessian", eh),
        ("SpMV", es),
        ("block-Jacobi", ej),
        ("dot", ed),
        ("axpy", ea),
    ] {
        assert!(e <= tol, "{name}: {e:.2e} > {tol:.0e}");
    }
}

#[test]
fn newton_kernels_match_cpu_f64() {
    kernels_match(Precision::F64, 1e-12);
}

#[test]
fn newton_kernels_match_cpu_f32() {
    kernels_match(Precision::F32, 1e-4);
}

#[test]
fn pcg_matches_cpu_pcg_f64() {
    let Some(ctx) = context(Precision::F64) else {
        return;
    };
    let a = cpu_assembled(7);
    let m = &a.pattern.matrix;
    let jac = BlockJacobi::new(m.diag.par_iter().map(|&s| m.blocks[s as usize]));
    let rhs: Vec<Vec3> = a.grad.iter().map(|g| g.map(|c| -c)).collect();
    let mut gpu = GpuNewton::new(&ctx, &a.p, &a.x, Default::default(), &Default::default()).unwrap();
    gpu.assemble().unwrap();
    // this start meets negative curvature at CG iteration 5: both answers to it, and a cut-off before
    for (rtol, max_iter, negative_curvature) in [
        (0.5, 100, NegativeCurvature::Direction),
        (1e-3, 100, NegativeCurvature::Direction),
        (1e-3, 100, NegativeCurvature::Iterate),
        (1e-10, 3, NegativeCurvature::Direction),
    ] {
        let params = PcgParams {
            max_iter,
            rtol,
            negative_curvature,
        };
        let mut d = vec![[0.0; 3]; rhs.len()];
        let cpu = pcg::pcg(m, &jac, &rhs, &mut d, &params);
        let info = gpu.pcg(&params).unwrap();
        let e = rel_diff(&gpu.direction().unwrap(), &d);
        eprintln!(
            "PCG rtol {rtol:.0e} {negative_curvature:?}: CPU {:?} in {} (residual {:.2e}), GPU {:?} in {} (residual {:.2e}); direction {e:.1e}",
            cpu.stop, cpu.iterations, cpu.relative_residual, info.stop, info.iterations, info.relative_residual
        );
        assert_eq!((info.stop, info.iterations), (cpu.stop, cpu.iterations));
        assert!(
            (info.relative_residual - cpu.relative_residual).abs() <= 1e-9 * cpu.relative_residual.max(1e-300)
                || (info.relative_residual - cpu.relative_residual).abs() <= 1e-9 * rtol
        );
        assert!(e <= 1e-9, "direction differs by {e:.2e}");
    }
}

#[test]
fn newton_first_iterates_match_cpu_f64() {
    let Some(ctx) = context(Precision::F64) else {
        return;
    };
    let mesh = perturbed_box(8, 1);
    let p = Problem::new(&mesh).unwrap();
    let x0 = p.gather(&mesh.points);
    let params = Params {
        max_iter: 3,
        ..Params::default()
    };
    let mut cx = x0.clone();
    let cpu = solve::solve(&p, &mut cx, Method::Newton, &params, &mut |_| true).unwrap();
    let mut gx = x0.clone();
    let info = gpu::solve_newton_gpu(&ctx, &p, &mut gx, &params, &GpuRunOptions::default(), &mut |_| true).unwrap();
    assert_eq!(info.method, Method::Newton);
    assert_eq!(info.iterations, 3);
    for (c, g) in cpu.history.records.iter().zip(&info.history.records) {
        eprintln!(
            "iteration {}: F CPU {:.15} GPU {:.15}, |g| CPU {:.6e} GPU {:.6e}",
            c.iteration, c.objective, g.objective, c.grad_norm, g.grad_norm
        );
        assert!((c.objective - g.objective).abs() <= 1e-9 * c.objective);
        assert!((c.grad_norm - g.grad_norm).abs() <= 1e-9 * c.grad_norm);
    }
    let edge = p.mean_edge_length(&x0);
    let worst = cx
        .iter()
        .flatten()
        .zip(gx.iter().flatten())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    eprintln!(
        "after 3 iterations: worst coordinate difference {:.1e} mean edges",
        worst / edge
    );
    assert!(worst <= 1e-9 * edge);
}

fn converged_matches(precision: Precision, gpu_tol: f64, rel: f64) {
    let Some(ctx) = context(precision) else {
        return;
    };
    let mut mesh = perturbed_box(8, 2);
    let p = Problem::new(&mesh).unwrap();
    let x0 = p.gather(&mesh.points);
    let mut cx = x0.clone();
    let cpu = solve::solve(&p, &mut cx, Method::Newton, &Params::default(), &mut |_| true).unwrap();
    let params = Params {
        tol: gpu_tol,
        ..Params::default()
    };
    let mut gx = x0.clone();
    let info = gpu::solve_newton_gpu(&ctx, &p, &mut gx, &params, &GpuRunOptions::default(), &mut |_| true).unwrap();
    eprintln!(
        "{precision:?} Newton: GPU {} iterations in {:.2} s ({:?}) F = {:.12}, CPU {} iterations in {:.2} s F = {:.12}",
        info.iterations, info.seconds, info.stop, info.objective, cpu.iterations, cpu.seconds, cpu.objective
    );
    assert!((info.objective - cpu.objective).abs() <= rel * cpu.objective);
    let f = objective::value(&p, &gx).unwrap();
    assert!((f - info.objective).abs() <= rel * f, "{f} vs {}", info.objective);
    mesh.points = p.scatter(&gx);
    assert!(metric::inverted_elements(&mesh, &mesh.points).is_empty());
    assert!(info.memory_bytes > p.bytes());

    if precision == Precision::F64 {
        // BCD on the device reaches the same minimiser
        let mut bx = x0.clone();
        gpu::solve_gpu(&ctx, &p, &mut bx, &Params::default(), &mut |_| true).unwrap();
        let edge = p.mean_edge_length(&x0);
        let worst = bx
            .iter()
            .zip(&gx)
            .map(|(a, b)| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt())
            .fold(0.0, f64::max);
        eprintln!(
            "GPU Newton vs GPU BCD: worst vertex distance {:.1e} mean edges",
            worst / edge
        );
        assert!(worst <= 0.01 * edge);
    }
}

#[test]
fn newton_converges_to_cpu_objective_f64() {
    converged_matches(Precision::F64, 1e-6, 1e-6);
}

#[test]
fn newton_converges_to_cpu_objective_f32() {
    converged_matches(Precision::F32, 1e-5, 1e-4);
}

#[test]
fn smooth_mesh_gpu_method_dispatches_by_method() {
    let Some(ctx) = context(Precision::Auto) else {
        return;
    };
    let mut mesh = perturbed_box(4, 3);
    let start = mesh.points.clone();
    let opts = GpuRunOptions::default();
    let e = gpu::smooth_mesh_gpu_method(&ctx, &mut mesh, Method::Laplace, &Params::default(), &opts, &mut |_| {
        true
    })
    .unwrap_err();
    assert!(matches!(e, Error::InvalidArgument(_)), "{e}");
    assert_eq!(mesh.points, start);
    let info = gpu::smooth_mesh_gpu_method(&ctx, &mut mesh, Method::Newton, &Params::default(), &opts, &mut |_| {
        true
    })
    .unwrap();
    assert_eq!(info.method, Method::Newton);
    assert_ne!(mesh.points, start);
    assert!(metric::inverted_elements(&mesh, &mesh.points).is_empty());
}

/// Timings for the report: `cargo test --release --test gpu_newton -- --ignored --nocapture`.
#[test]
#[ignore]
fn newton_timings() {
    let shared = std::path::Path::new("/work/shared/meshes/perturbed_box_tet_20.vtk");
    let mut meshes = vec![("box 20^3".to_string(), perturbed_box(20, 1))];
    if shared.exists() {
        meshes.push((shared.display().to_string(), meshsmooth::io::read(shared).unwrap()));
    }
    for (name, mesh) in &meshes {
        let p = Problem::new(mesh).unwrap();
        let x0 = p.gather(&mesh.points);
        let mut x = x0.clone();
        let t = Instant::now();
        let cpu = solve::solve(&p, &mut x, Method::Newton, &Params::default(), &mut |_| true).unwrap();
        eprintln!(
            "{name} ({} tets): CPU Newton {} it, {:.2} s (loop {:.2} s), F = {:.10}, {:?}",
            p.num_elements(),
            cpu.iterations,
            t.elapsed().as_secs_f64(),
            cpu.seconds,
            cpu.objective,
            cpu.stop
        );
        for (precision, tol) in [(Precision::F32, 1e-5), (Precision::F64, 1e-6)] {
            let Some(ctx) = context(precision) else {
                return;
            };
            // warm the pipelines (JIT) on a small problem first
            let mut small = perturbed_box(3, 1);
            gpu::smooth_mesh_gpu_method(
                &ctx,
                &mut small,
                Method::Newton,
                &Params::default(),
                &Default::default(),
                &mut |_| true,
            )
            .unwrap();
            let params = Params {
                tol,
                ..Params::default()
            };
            let mut x = x0.clone();
            let t = Instant::now();
            let info = gpu::solve_newton_gpu(&ctx, &p, &mut x, &params, &Default::default(), &mut |_| true).unwrap();
            eprintln!(
                "{name}: GPU {precision:?} Newton {} it, {:.2} s (loop {:.2} s, setup {:.2} s), F = {:.10}, {:?}, {:.1} MiB",
                info.iterations,
                t.elapsed().as_secs_f64(),
                info.seconds,
                info.setup_seconds,
                info.objective,
                info.stop,
                info.memory_bytes as f64 / 1048576.0
            );
        }
    }
}
