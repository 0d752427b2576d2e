//! Results must not depend on units: scaling or shifting the coordinates
//! changes nothing but the coordinates — the same F, the same iterations,
//! the same mesh in the new units — for every method on the CPU and the GPU.

use crate::common;
use common::{context, options, perturbed_box};

use meshsmooth::Mesh;
use meshsmooth::backend::gpu::Precision;
use meshsmooth::solve::{self, Device, Info, Method, Params, StopReason};

/// A perturbed box whose coordinates are multiples of 1/64, so that shifting
/// by 1e9 is exact and the shifted mesh is the same mesh.
fn start() -> Mesh {
    let mut m = perturbed_box(5, 0.3, 11);
    for p in &mut m.points {
        *p = p.map(|c| (c * 64.0).round() / 64.0);
    }
    m
}

fn run(mesh: &Mesh, scale: f64, shift: f64, method: Method, device: Device) -> (Info, Mesh) {
    let mut m = mesh.clone();
    for p in &mut m.points {
        *p = p.map(|c| c * scale + shift);
    }
    let mut params = Params::default();
    params.tol = 1e-8;
    let info = solve::smooth_mesh(
        &mut m,
        &Default::default(),
        &options(method, &params, device),
        &mut |_| true,
    )
    .unwrap();
    (info, m)
}

fn check(device: Device, label: &str) {
    let mesh = start();
    for method in [Method::Bcd, Method::Newton, Method::Nlcg] {
        let (base, out) = run(&mesh, 1.0, 0.0, method, device);
        assert!(base.iterations > 2, "{label} {method}: the start should need work");
        for (scale, shift) in [(1e-9, 0.0), (1e9, 0.0), (1.0, 1e9), (1.0, -1e9), (1e9, 1e9)] {
            let (info, m) = run(&mesh, scale, shift, method, device);
            let case = format!("{label} {method} x{scale:e} {shift:+e}");
            eprintln!(
                "{case}: F {:.15} ({} iterations) vs {:.15} ({})",
                info.objective, info.iterations, base.objective, base.iterations
            );
            assert!(
                (info.objective - base.objective).abs() <= 1e-8 * base.objective,
                "{case}: F {} vs {}",
                info.objective,
                base.objective
            );
            assert!(info.iterations.abs_diff(base.iterations) <= 1, "{case}: iterations");
            // NLCG one iteration from |grad F| < tol may find no decrease
            // of F above its rounding (the line search's floor): a small
            // step there is the same end as converging
            let near = |s: StopReason| match (method, s) {
                (Method::Nlcg, StopReason::SmallStep) => StopReason::Converged,
                _ => s,
            };
            assert_eq!(near(info.stop), near(base.stop), "{case}");
            // the same mesh in the new units: vertex by vertex, to the rounding of the
            // new coordinates and the solver's tolerance
            let edge = scale;
            let worst = m
                .points
                .iter()
                .zip(&out.points)
                .map(|(a, b)| {
                    (0..3)
                        .map(|k| (a[k] - (b[k] * scale + shift)).abs())
                        .fold(0.0, f64::max)
                })
                .fold(0.0, f64::max);
            let rounding = 4.0 * f64::EPSILON * (shift.abs() + 8.0 * scale);
            assert!(worst <= 1e-5 * edge + rounding, "{case}: vertices differ by {worst:e}");
        }
    }
}

#[test]
fn scaling_and_shifting_change_nothing_but_the_coordinates_on_the_cpu() {
    check(Device::Cpu, "cpu");
}

#[test]
fn scaling_and_shifting_change_nothing_but_the_coordinates_on_the_gpu() {
    let Some(ctx) = context(Precision::Auto) else {
        return;
    };
    check(Device::Gpu(&ctx), "gpu");
}

#[test]
fn extreme_units_smooth_to_the_same_mesh_and_report_the_same_quality() {
    // lengths of 1e-150 or 1e150: the solve's frame takes them to unit size,
    // and the checks for inverted elements and the quality report must not
    // read the underflowing or overflowing determinants as degenerate
    let mesh = start();
    let smoother = meshsmooth::Smoother::default();
    let mut base = mesh.clone();
    let unit = smoother.smooth(&mut base).unwrap();
    let f = unit.quality.objective.unwrap();
    for scale in [1e-150, 1e150] {
        let mut m = mesh.clone();
        for p in &mut m.points {
            *p = p.map(|c| c * scale);
        }
        assert!(
            meshsmooth::metric::inverted_elements(&m, &m.points).is_empty(),
            "x{scale:e}"
        );
        let report = smoother.smooth(&mut m).unwrap_or_else(|e| panic!("x{scale:e}: {e}"));
        let g = report
            .quality
            .objective
            .unwrap_or_else(|| panic!("x{scale:e}: no objective"));
        assert!((g - f).abs() <= 1e-9 * f, "x{scale:e}: {g} vs {f}");
        let worst = m
            .points
            .iter()
            .zip(&base.points)
            .map(|(a, b)| (0..3).map(|k| (a[k] / scale - b[k]).abs()).fold(0.0, f64::max))
            .fold(0.0, f64::max);
        assert!(worst < 1e-6, "x{scale:e}: vertices differ by {worst:e} of the unit");
    }
}
