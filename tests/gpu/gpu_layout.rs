//! The device numbering (`DeviceLayout`) changes where data sits, not what
//! is computed: BCD sweeps give the same positions bit for bit in every
//! layout (each vertex sums its corners in the problem's order), Newton the
//! same iterates to rounding (the objective's reduction tree and the Hessian
//! and gradient gathers follow the device's corner order), all handed back in
//! the problem's numbering.

use crate::common;
use common::{context, context_with, max_abs_diff, perturbed_box, solve_on};

use meshsmooth::backend::gpu::{DeviceLayout, GpuBackend, GpuOptions, Precision};
use meshsmooth::backend::{Backend, Slot};
use meshsmooth::problem::Problem;
use meshsmooth::solve::{Device, Method, Params};

fn layouts_agree(method: Method, precision: Precision, tol_edge: f64) {
    let ctxs: Option<Vec<_>> = [DeviceLayout::Problem, DeviceLayout::ByColour, DeviceLayout::ByValence]
        .into_iter()
        .map(|layout| {
            context_with(GpuOptions {
                precision,
                layout,
                ..Default::default()
            })
        })
        .collect();
    let Some(ctxs) = ctxs else {
        return;
    };
    let mesh = perturbed_box(7, 0.3, 3);
    let p = Problem::new(&mesh).unwrap();
    let x0 = p.gather(&mesh.points);
    let mut params = Params::default();
    params.max_iter = 3;
    params.tol = 0.0;
    let runs: Vec<Vec<_>> = ctxs
        .iter()
        .map(|ctx| {
            let mut x = x0.clone();
            solve_on(&p, &mut x, method, &params, Device::Gpu(ctx));
            x
        })
        .collect();
    let edge = p.mean_edge_length(&x0);
    assert!(max_abs_diff(&runs[0], &x0) > 1e-3 * edge, "the vertices moved");
    for x in &runs[1..] {
        let d = max_abs_diff(x, &runs[0]);
        eprintln!(
            "{method:?} {precision:?}: {:.1e} mean edges from the problem numbering",
            d / edge
        );
        assert!(d <= tol_edge * edge, "{d} vs edge {edge}");
    }
}

#[test]
fn bcd_sweeps_are_the_same_in_every_layout_f64() {
    layouts_agree(Method::BcdColored, Precision::F64, 0.0);
}

#[test]
fn bcd_sweeps_are_the_same_in_every_layout_f32() {
    layouts_agree(Method::BcdColored, Precision::F32, 0.0);
}

#[test]
fn newton_iterates_agree_in_every_layout_f64() {
    // the Hessian and gradient gathers add in device corner order (so that
    // windows of parts give the one-pass bits, `gpu_split.rs`): rounding
    // that differs between layouts, carried by three CG solves
    layouts_agree(Method::Newton, Precision::F64, 1e-8);
}

#[test]
fn a_whole_sweep_is_one_submission() {
    let Some(ctx) = context(Precision::F32) else {
        return;
    };
    let mesh = perturbed_box(6, 0.3, 1);
    let p = Problem::new(&mesh).unwrap();
    let x0 = p.gather(&mesh.points);
    let mut g = GpuBackend::new(&ctx, &p, &x0, &Default::default()).unwrap();
    assert!(g.num_colors() >= 8);
    for _ in 0..2 {
        let before = g.submissions();
        for c in 0..g.num_colors() {
            g.bcd_color(c).unwrap();
        }
        g.max_move(Slot(0)).unwrap();
        let moved = g.flush().unwrap()[0];
        assert!(moved > 0.0);
        assert_eq!(g.submissions() - before, 1, "every colour in one command buffer");
    }
}
