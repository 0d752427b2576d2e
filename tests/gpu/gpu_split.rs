//! Meshes whose arrays exceed one storage binding: the device is told that a
//! binding holds only a few KiB (`GpuOptions::max_binding_bytes`), so the
//! per-corner and per-block arrays of a small box are split across several
//! bindings. BCD and Newton must give the CPU's results (the tolerances of
//! `gpu_matches_cpu.rs` and `gpu_newton.rs`) and the unsplit device's bit
//! for bit (only the addressing differs).

use crate::common;
use common::{assert_histories_agree, context, context_with, max_abs_diff, perturbed_box, solve_on};

use meshsmooth::backend::gpu::{GpuBackend, GpuContext, GpuOptions, Precision};
use meshsmooth::problem::Problem;
use meshsmooth::solve::{Device, Method, Params};

fn capped(precision: Precision, bytes: u64) -> Option<GpuContext> {
    capped_with(precision, bytes, None)
}

/// Bindings capped at `bytes`, and at most `storage` storage buffers per kernel.
fn capped_with(precision: Precision, bytes: u64, storage: Option<u32>) -> Option<GpuContext> {
    context_with(GpuOptions {
        precision,
        max_binding_bytes: Some(bytes),
        max_storage_buffers: storage,
        ..Default::default()
    })
}

/// Runs `method` for `iters` iterations on the CPU, the device and the
/// device with bindings capped at `cap` bytes; checks the split happened.
fn split_matches(method: Method, precision: Precision, cap: u64, iters: usize, tol_edge: f64, rel: f64) {
    let (Some(ctx), Some(small)) = (context(precision), capped(precision, cap)) else {
        return;
    };
    split_matches_on(&ctx, &small, method, precision, iters, tol_edge, rel);
}

/// `split_matches` on the device `small`, whose arrays are split.
fn split_matches_on(
    ctx: &GpuContext,
    small: &GpuContext,
    method: Method,
    precision: Precision,
    iters: usize,
    tol_edge: f64,
    rel: f64,
) {
    let mesh = perturbed_box(8, 0.3, 1);
    let p = Problem::new(&mesh).unwrap();
    let x0 = p.gather(&mesh.points);
    {
        let mut be = GpuBackend::new(small, &p, &x0, &Default::default()).unwrap();
        if method == Method::Newton {
            meshsmooth::backend::Backend::prepare_hessian(&mut be).unwrap();
        }
        eprintln!(
            "{method:?} {precision:?}: arrays split into up to {} bindings",
            be.max_parts()
        );
        assert!(be.max_parts() >= 3, "the cap should split arrays");
    }
    let mut params = Params::default();
    params.max_iter = iters;
    params.tol = 0.0;
    let run = |device| {
        let mut x = x0.clone();
        let info = solve_on(&p, &mut x, method, &params, device);
        (x, info)
    };
    let (cx, cpu) = run(Device::Cpu);
    let (gx, gpu) = run(Device::Gpu(ctx));
    let (sx, split) = run(Device::Gpu(small));
    assert_eq!(split.iterations, iters);
    assert_eq!(sx, gx, "split and unsplit bindings give the same positions");
    assert_eq!(split.objective.to_bits(), gpu.objective.to_bits());
    assert_eq!(split.cg_iterations, gpu.cg_iterations);
    if precision == Precision::F64 {
        assert_eq!(split.cg_iterations, cpu.cg_iterations);
        assert_histories_agree(&cpu, &split, rel, rel);
    }
    assert!((split.objective - cpu.objective).abs() <= rel * cpu.objective);
    let edge = p.mean_edge_length(&x0);
    let worst = max_abs_diff(&cx, &sx);
    eprintln!(
        "worst coordinate difference from the CPU {:.1e} mean edges",
        worst / edge
    );
    assert!(worst <= tol_edge * edge, "{worst} vs edge {edge}");
}

#[test]
fn bcd_on_split_bindings_matches_cpu_f64() {
    // corners, incidence and corner gradients over 2, 2 and 9 bindings
    split_matches(Method::BcdColored, Precision::F64, 32 << 10, 3, 1e-9, 1e-9);
}

#[test]
fn bcd_on_split_bindings_matches_cpu_f32() {
    split_matches(Method::BcdColored, Precision::F32, 16 << 10, 3, 1e-2, 1e-4);
}

#[test]
fn newton_on_split_bindings_matches_cpu_f64() {
    // the corner blocks over 10 bindings, the Hessian blocks over 2
    split_matches(Method::Newton, Precision::F64, 256 << 10, 3, 1e-9, 1e-9);
}

#[test]
fn newton_on_split_bindings_matches_cpu_f32() {
    // F to 1e-3: the first two iterates' F agree with the f64 CPU's to 3e-6;
    // after the third step, whose f32 CG solve runs to the tighter forcing of
    // a convex-looking step, they differ by 2e-4 (same CG and trial counts)
    split_matches(Method::Newton, Precision::F32, 128 << 10, 3, 1e-2, 1e-3);
}

/// Newton where the corner blocks have more parts than a kernel may bind
/// (`storage` storage buffers): the assembly and the gathers run one window
/// of parts at a time, and must still give the unsplit device's bits.
fn windowed_newton_matches(precision: Precision, cap: u64, storage: u32, tol_edge: f64, rel: f64) {
    let (Some(ctx), Some(small)) = (context(precision), capped_with(precision, cap, Some(storage))) else {
        return;
    };
    assert_eq!(small.max_storage_buffers(), storage.min(ctx.max_storage_buffers()));
    let mesh = perturbed_box(8, 0.3, 1);
    let p = Problem::new(&mesh).unwrap();
    let x0 = p.gather(&mesh.points);
    {
        use meshsmooth::backend::Backend;
        let mut be = GpuBackend::new(&small, &p, &x0, &Default::default()).unwrap();
        Backend::prepare_hessian(&mut be).unwrap();
        // binding every part of the corner blocks, as before windows, is
        // beyond what the device allows
        let parts = be.max_parts();
        eprintln!("Newton {precision:?}: corner blocks in {parts} parts, {storage} storage buffers a kernel");
        assert!(parts > storage as usize, "{parts} parts");
        let g = be.vector().unwrap();
        be.assemble(g).unwrap();
        be.flush().unwrap();
        // the assembly and both gathers, each in at least two windows
        assert!(
            be.window_dispatches() >= 6,
            "{} windowed dispatches",
            be.window_dispatches()
        );
        let mut unsplit = GpuBackend::new(&ctx, &p, &x0, &Default::default()).unwrap();
        Backend::prepare_hessian(&mut unsplit).unwrap();
        // the positions come back from their parts as they went up
        assert_eq!(be.download().unwrap(), unsplit.download().unwrap());
        let gu = unsplit.vector().unwrap();
        unsplit.assemble(gu).unwrap();
        unsplit.flush().unwrap();
        assert_eq!(unsplit.window_dispatches(), 0);
        assert_eq!(be.hessian_blocks().unwrap(), unsplit.hessian_blocks().unwrap());
        assert_eq!(be.read_vector(g).unwrap(), unsplit.read_vector(gu).unwrap());
    }
    split_matches_on(&ctx, &small, Method::Newton, precision, 3, tol_edge, rel);
}

#[test]
fn newton_in_windows_of_parts_matches_cpu_f64() {
    // the corner blocks in 77 parts of 32 KiB; 20 storage buffers a kernel
    windowed_newton_matches(Precision::F64, 32 << 10, 20, 1e-9, 1e-9);
}

#[test]
fn newton_in_windows_of_parts_matches_cpu_f32() {
    // the corner blocks in 77 parts of 16 KiB; lavapipe's 32 storage buffers
    windowed_newton_matches(Precision::F32, 16 << 10, 32, 1e-2, 1e-3);
}

/// `method` with the positions and free-vertex vectors (arrays that grow
/// with vertices) in several bindings each; the per-corner arrays then have
/// more parts than lavapipe's 32 storage buffers, so the objective runs in
/// windows of corners as well.
/// At least `parts` (positions, vectors) buffers each.
fn vertex_arrays_split_match(
    method: Method,
    precision: Precision,
    cap: u64,
    parts: (usize, usize),
    tol_edge: f64,
    rel: f64,
) {
    let (Some(ctx), Some(small)) = (context(precision), capped(precision, cap)) else {
        return;
    };
    let mesh = perturbed_box(8, 0.3, 1);
    let p = Problem::new(&mesh).unwrap();
    let x0 = p.gather(&mesh.points);
    {
        use meshsmooth::backend::{Backend, EvalSlots, Points, Slot};
        let mut be = GpuBackend::new(&small, &p, &x0, &Default::default()).unwrap();
        eprintln!(
            "{method:?} {precision:?}: positions in {} parts, vectors in {}, corner gradients in {}",
            be.position_parts(),
            be.vector_parts(),
            be.max_parts()
        );
        assert!(be.position_parts() >= parts.0, "{} position parts", be.position_parts());
        assert!(be.vector_parts() >= parts.1, "{} vector parts", be.vector_parts());
        let g = be.vector().unwrap();
        let out = EvalSlots {
            value: Slot(0),
            min_det: None,
            infeasible: Slot(1),
        };
        be.evaluate(Points::Current, out, Some(g)).unwrap();
        be.flush().unwrap();
        // the objective in windows exactly where its corner gradients alone
        // have more parts than a kernel may bind
        let windows = be.max_parts() > small.max_storage_buffers() as usize;
        assert_eq!(
            be.window_dispatches() >= 2,
            windows,
            "{} windows",
            be.window_dispatches()
        );
        let mut unsplit = GpuBackend::new(&ctx, &p, &x0, &Default::default()).unwrap();
        // the positions come back from their parts as they went up
        assert_eq!(be.download().unwrap(), unsplit.download().unwrap());
        let gu = unsplit.vector().unwrap();
        unsplit.evaluate(Points::Current, out, Some(gu)).unwrap();
        let (a, b) = (be.flush().unwrap(), unsplit.flush().unwrap());
        assert_eq!(a[0].to_bits(), b[0].to_bits(), "the objective");
        assert_eq!(be.read_vector(g).unwrap(), unsplit.read_vector(gu).unwrap());
    }
    split_matches_on(&ctx, &small, method, precision, 3, tol_edge, rel);
}

#[test]
fn bcd_with_vertex_arrays_split_matches_cpu_f64() {
    // positions in 3 parts of 8 KiB, vectors in 2, corner gradients in 36
    vertex_arrays_split_match(Method::BcdColored, Precision::F64, 8 << 10, (3, 2), 1e-9, 1e-9);
}

#[test]
fn bcd_with_vertex_arrays_split_matches_cpu_f32() {
    // positions in 2 parts (at 4 KiB the sweep kernel itself would bind 38
    // storage buffers, and it reads corners through the incidence lists, in
    // no order a window could follow)
    vertex_arrays_split_match(Method::BcdColored, Precision::F32, 8 << 10, (2, 1), 1e-2, 1e-4);
}

#[test]
fn nlcg_with_vertex_arrays_split_matches_cpu_f64() {
    // the free-vertex vectors (search directions, gradients) in 2 parts
    vertex_arrays_split_match(Method::Nlcg, Precision::F64, 8 << 10, (3, 2), 1e-9, 1e-9);
}

#[test]
fn too_many_parts_for_the_device_is_an_error_with_the_numbers() {
    let Some(small) = capped(Precision::F64, 256) else {
        return;
    };
    let mesh = perturbed_box(8, 0.3, 1);
    let p = Problem::new(&mesh).unwrap();
    let x0 = p.gather(&mesh.points);
    let e = match GpuBackend::new(&small, &p, &x0, &Default::default()) {
        Err(e) => e.to_string(),
        Ok(mut be) => {
            use meshsmooth::backend::{Backend, EvalSlots, Points, Slot};
            let out = EvalSlots {
                value: Slot(0),
                min_det: None,
                infeasible: Slot(1),
            };
            be.evaluate(Points::Current, out, None).unwrap_err().to_string()
        }
    };
    assert!(e.contains("too large"), "{e}");
}
