//! Coloured BCD sweep throughput per metric x template x element kind: the
//! CPU coloured sweep (all cores) against the GPU sweep (f32, and f64 where
//! the adapter has it), elements per second and the GPU:CPU ratio. Every
//! general corner kernel goes through the structured S-Hessian
//! (`shaders/metric/shess.wgsl`); the tetrahedral inverse mean ratio under the
//! harmonic template through its own closed forms, and the planar inverse
//! mean ratio and condition number under it through `planar.wgsl`. Issue
//! #14's target for lavapipe is a ratio of at least 1/3 in every row.
//!
//! Run: `cargo bench --bench corner_kernels [-- --quick] [--adapter NAME]
//! [--kinds triangle,tetrahedron,...] [--closed] [--general]` (`--kinds`: only
//! those rows; the plain GPU columns are `KernelForms::Auto`'s choice for the
//! adapter; `--closed` / `--general`: also every closed form / only the general
//! kernels where a closed form applies, `GpuOptions::forms`, as "GPU f32
//! closed", "GPU f32 general" and so on). The CPU and
//! the GPU sweeps of a row are timed in turn, rep by rep, so that a change
//! of load hits all of them alike.

use meshsmooth::backend::cpu::bcd;
use meshsmooth::backend::gpu::{GpuBackend, GpuOptions, KernelForms};
use meshsmooth::backend::{Backend, Slot};
use meshsmooth::generate::{self, PerturbOptions, Perturbation, VoronoiOptions};
use meshsmooth::metric::corner_model::Template;
use meshsmooth::metric::smetric::MetricKind;
use meshsmooth::problem::{Problem, ProblemOptions};
use meshsmooth::{ElementKind, Mesh};

mod common;
use common::{gpu_contexts, median};
use std::time::Instant;

fn perturbed(mut m: Mesh, alpha: f64) -> Mesh {
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha },
        fraction: 1.0,
        seed: 3,
    };
    generate::perturb(&mut m, &opts).unwrap();
    m
}

/// (kind, reference mesh, perturbed mesh) at about `scale` elements.
fn meshes(scale: usize) -> Vec<(ElementKind, Mesh, Mesh)> {
    let side = |per: usize, dim: u32| ((scale / per) as f64).powf(1.0 / dim as f64).round().max(2.0) as usize;
    let (n2t, n2q, n3t, n3h) = (side(2, 2), side(1, 2), side(6, 3), side(1, 3));
    let mut out = vec![
        (ElementKind::Triangle, generate::tri_grid(n2t, n2t, [n2t as f64; 2])),
        (
            ElementKind::Quadrilateral,
            generate::quad_grid(n2q, n2q, [n2q as f64; 2]),
        ),
        (
            ElementKind::Tetrahedron,
            generate::tet_box(n3t, n3t, n3t, [n3t as f64; 3]),
        ),
        (
            ElementKind::Hexahedron,
            generate::hex_box(n3h, n3h, n3h, [n3h as f64; 3]),
        ),
        (ElementKind::Prism, generate::prism_mesh(false, 0)),
    ];
    if let Ok(v) = generate::voronoi_mesh(&VoronoiOptions::default()) {
        out.push((ElementKind::Polyhedron, v));
    }
    out.into_iter()
        .map(|(k, m)| {
            // the Voronoi cells' 120-degree corners flatten sooner under the same noise
            let alpha = if k == ElementKind::Polyhedron { 0.05 } else { 0.25 };
            (k, m.clone(), perturbed(m, alpha))
        })
        .collect()
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let adapter = common::arg("--adapter");
    let reps = if quick { 2 } else { 5 };
    let kinds = common::arg("--kinds");
    let wanted = |k: ElementKind| kinds.as_ref().is_none_or(|s| s.split(',').any(|n| n == k.to_string()));
    let mut gpus = gpu_contexts(&GpuOptions {
        adapter: adapter.clone(),
        ..Default::default()
    });
    // the default columns are `KernelForms::Auto`'s choice on this adapter
    for (flag, forms, name) in [
        ("--closed", KernelForms::Closed, "closed"),
        ("--general", KernelForms::General, "general"),
    ] {
        if common::flag(flag) {
            let more = gpu_contexts(&GpuOptions {
                adapter: adapter.clone(),
                forms,
                ..Default::default()
            });
            gpus.extend(more.into_iter().map(|(p, c)| (format!("{p} {name}"), c)));
        }
    }
    if let Some((_, ctx)) = gpus.first() {
        println!("GPU: {}", ctx.adapter_name());
    }
    println!("CPU threads: {}\n", rayon::current_num_threads());
    let mut header = String::from("| kind | metric | template | elements | CPU coloured |");
    for (p, _) in &gpus {
        header.push_str(&format!(" GPU {p} | GPU {p} : CPU |"));
    }
    println!("{header}");
    println!("|{}", "---|".repeat(header.matches('|').count() - 1));
    let models = [
        (MetricKind::InverseMeanRatio, Template::Harmonic),
        (MetricKind::InverseMeanRatio, Template::Average),
        (MetricKind::ConditionNumber, Template::Harmonic),
        (MetricKind::ConditionNumber, Template::Average),
        (MetricKind::TargetShapeSize, Template::Harmonic),
        (MetricKind::ConditionNumberPaper, Template::Harmonic),
    ];
    for (kind, reference, mesh) in meshes(if quick { 2000 } else { 20000 }) {
        if !wanted(kind) {
            continue;
        }
        for (metric, template) in models {
            if metric == MetricKind::ConditionNumberPaper && kind.dim() == 2 {
                continue;
            }
            let mut opts = ProblemOptions::default();
            opts.metric = metric;
            opts.template = template;
            opts.reference = (metric == MetricKind::TargetShapeSize).then_some(&reference);
            let p = match Problem::with_options(&mesh, &opts) {
                Ok(p) => p,
                Err(e) => {
                    eprintln!("{kind} {metric} {template:?}: {e}");
                    continue;
                }
            };
            let x0 = p.gather(&mesh.points);
            let ne = p.num_elements() as f64;
            let ls = Default::default();
            let closed = p.model.fast(p.dim) || p.model.planar(p.dim);
            let mut x = x0.clone();
            let mut backends: Vec<Option<GpuBackend>> = Vec::new();
            let mut cells: Vec<String> = Vec::new();
            for (name, ctx) in &gpus {
                if (name.ends_with("general") || name.ends_with("closed")) && !closed {
                    // the same kernels as the column without "general"
                    backends.push(None);
                    cells.push(" - | - |".into());
                    continue;
                }
                match GpuBackend::new(ctx, &p, &x0, &ls) {
                    Ok(g) => {
                        backends.push(Some(g));
                        cells.push(String::new());
                    }
                    Err(e) => {
                        backends.push(None);
                        cells.push(format!(" {e} | |"));
                    }
                }
            }
            let mut cpu_sweep = || {
                for c in 0..p.colors.len() {
                    bcd::sweep_color(&p, &mut x, c, &ls);
                }
            };
            let gpu_sweep = |g: &mut GpuBackend| {
                for c in 0..g.num_colors() {
                    g.bcd_color(c).unwrap();
                }
                g.max_move(Slot(0)).unwrap();
                g.flush().unwrap();
            };
            // rep 0 warms up (pipelines, caches) and is not counted
            let mut cpu_t = Vec::new();
            let mut gpu_t: Vec<Vec<f64>> = vec![Vec::new(); backends.len()];
            for rep in 0..=reps {
                let s = Instant::now();
                cpu_sweep();
                if rep > 0 {
                    cpu_t.push(s.elapsed().as_secs_f64());
                }
                for (g, t) in backends.iter_mut().zip(&mut gpu_t) {
                    if let Some(g) = g {
                        let s = Instant::now();
                        gpu_sweep(g);
                        if rep > 0 {
                            t.push(s.elapsed().as_secs_f64());
                        }
                    }
                }
            }
            let cpu = median(cpu_t);
            let rate = |s: f64| format!("{:.3} M/s ({:.1} ms)", ne / s / 1e6, s * 1e3);
            let mut row = format!(
                "| {kind} | {metric} | {template:?} | {} | {} |",
                p.num_elements(),
                rate(cpu)
            );
            for (cell, t) in cells.iter().zip(gpu_t) {
                if t.is_empty() {
                    row.push_str(cell);
                } else {
                    let s = median(t);
                    row.push_str(&format!(" {} | {:.2} |", rate(s), cpu / s));
                }
            }
            println!("{row}");
        }
    }
}
