//! Sweep throughput of coloured BCD: CPU sequential, CPU coloured on all
//! cores, and the GPU (f32, and f64 where the adapter has it), on perturbed
//! tetrahedral boxes (inverse mean ratio: the closed-form kernels) and
//! hexahedral boxes (`cn`, average template: the general corner path), plus
//! `cub_wedge_like` when `../shared/meshes` is there. Prints Markdown tables.
//!
//! Run: `cargo bench --bench sweep_scaling [-- --quick] [--gpu] [--adapter NAME] [--max-tets N]`
//! - `--gpu`: leave out the CPU sequential sweep and go up to 10.4M tets
//!   (a 120^3 box), for hardware GPUs;
//! - `--adapter NAME`: the adapter whose name contains NAME (else the best one);
//! - `--max-tets N`: skip meshes with more elements;
//! - `--tet-sizes N,N,...`: these tetrahedral boxes instead (N^3 cubes, 6 N^3 tets);
//! - `--no-hex`: leave out the hexahedral boxes;
//! - `--layout by-valence|by-colour|problem`: the device numbering
//!   (`GpuOptions::layout`; `problem` is the layout before issue #14's item 2).
//!
//! Bytes moved per sweep are a model, not a counter: per free vertex its
//! incidence offsets (8 B) and, for each incident corner, the incidence item
//! (4 B), the corner record (`CORNER_STRIDE` = 5 u32, 20 B) and its four
//! points (12 reals), read twice (the gradient-Hessian pass and the first
//! line-search trial, which is usually accepted), and the new position and
//! move written (6 reals). The shape table is a few entries and stays in cache.
//! GFLOP/s likewise counts a model of about 350 flops per incidence and
//! sweep for the closed-form tetrahedral path (rest-S 54, S 18, determinant
//! and Frobenius norm 34, gradient and 3x3 block about 150, one trial about
//! 100) and 800 for the general path (hexahedra with `cn`: the metric, its
//! structured S-Hessian's products with b_k and the 3x3 block, one trial);
//! both are estimates, quoted to compare devices, not kernels.

use meshsmooth::backend::cpu::bcd;
use meshsmooth::backend::gpu::{DeviceLayout, GpuBackend, GpuOptions};
use meshsmooth::backend::{Backend, Slot};
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::metric::corner_model::Template;
use meshsmooth::metric::smetric::MetricKind;
use meshsmooth::problem::{Problem, ProblemOptions};
use meshsmooth::{Mesh, io};
use std::path::PathBuf;

mod common;
use common::{arg, gpu_contexts, time};
use std::time::Instant;

fn perturbed(mut m: Mesh) -> Mesh {
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: 0.3 },
        fraction: 1.0,
        seed: 1,
    };
    generate::perturb(&mut m, &opts).unwrap();
    m
}

struct Case {
    name: String,
    mesh: Mesh,
    general: bool,
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let gpu_only = std::env::args().any(|a| a == "--gpu");
    let adapter = arg("--adapter");
    let max_elems: usize = arg("--max-tets")
        .map(|s| s.parse().expect("--max-tets N"))
        .unwrap_or(usize::MAX);
    let layout = arg("--layout").map_or(DeviceLayout::default(), |s| {
        s.parse::<DeviceLayout>()
            .expect("--layout by-valence|by-colour|problem")
    });
    let listed: Option<Vec<usize>> =
        arg("--tet-sizes").map(|s| s.split(',').map(|n| n.parse().expect("--tet-sizes N,N")).collect());
    let tet_sizes: &[usize] = match (&listed, quick, gpu_only) {
        (Some(l), _, _) => l,
        (None, true, _) => &[12, 20],
        (None, false, false) => &[12, 20, 32, 55],
        (None, false, true) => &[20, 32, 55, 80, 100, 120],
    };
    let hex_sizes: &[usize] = match (std::env::args().any(|a| a == "--no-hex"), quick, gpu_only) {
        (true, _, _) => &[],
        (false, true, _) => &[6],
        (false, false, false) => &[10, 20],
        (false, false, true) => &[10, 20, 40, 64],
    };
    let mut cases: Vec<Case> = Vec::new();
    for &n in tet_sizes.iter().filter(|&&n| 6 * n * n * n <= max_elems) {
        cases.push(Case {
            name: format!("tet box {n}^3, imr"),
            mesh: perturbed(generate::tet_box(n, n, n, [n as f64; 3])),
            general: false,
        });
    }
    let wedge = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes/cub_wedge_like.vtk");
    if wedge.exists() {
        cases.push(Case {
            name: "cub_wedge_like, imr".into(),
            mesh: io::read(&wedge).unwrap(),
            general: false,
        });
    }
    for &n in hex_sizes.iter().filter(|&&n| n * n * n <= max_elems) {
        cases.push(Case {
            name: format!("hex box {n}^3, cn average"),
            mesh: perturbed(generate::hex_box(n, n, n, [n as f64; 3])),
            general: true,
        });
    }
    let gpus = gpu_contexts(&GpuOptions {
        adapter: adapter.clone(),
        layout,
        ..Default::default()
    });
    if let Some((_, ctx)) = gpus.first() {
        println!("GPU: {}, device layout {layout:?}", ctx.adapter_name());
    }
    println!("CPU threads: {}\n", rayon::current_num_threads());
    let mut header = String::from("| mesh | elements | colours |");
    if !gpu_only {
        header.push_str(" CPU sequential |");
    }
    header.push_str(" CPU coloured |");
    for (p, _) in &gpus {
        header.push_str(&format!(" GPU {p} | GPU {p} GB/s, GFLOP/s |"));
    }
    println!("{header}");
    println!("|{}", "---|".repeat(header.matches('|').count() - 1));
    let reps = if quick { 3 } else { 5 };
    for case in &cases {
        let mut opts = ProblemOptions::default();
        opts.metric = if case.general {
            MetricKind::ConditionNumber
        } else {
            MetricKind::InverseMeanRatio
        };
        opts.template = if case.general {
            Template::Average
        } else {
            Template::Harmonic
        };
        let setup = Instant::now();
        let p = Problem::with_options(&case.mesh, &opts).unwrap();
        let setup = setup.elapsed().as_secs_f64();
        let x0 = p.gather(&case.mesh.points);
        let ne = p.num_elements() as f64;
        let ls = Default::default();
        let rate = |s: f64| format!("{:.2} M/s ({:.1} ms)", ne / s / 1e6, s * 1e3);
        let mut row = format!("| {} | {} | {} |", case.name, p.num_elements(), p.colors.len());
        if !gpu_only {
            let mut x = x0.clone();
            row.push_str(&format!(
                " {} |",
                rate(time(reps, || {
                    bcd::sweep(&p, &mut x, &ls, &Default::default(), None, None);
                }))
            ));
        }
        let mut x = x0.clone();
        let col = time(reps, || {
            for c in 0..p.colors.len() {
                bcd::sweep_color(&p, &mut x, c, &ls);
            }
        });
        row.push_str(&format!(" {} |", rate(col)));
        let incidences: usize = p.free_vertices.iter().map(|&v| p.incidence.of(v as usize).len()).sum();
        let flops_per_incidence = if case.general { 800.0 } else { 350.0 };
        for (_, ctx) in &gpus {
            let r = if ctx.is_f64() { 8.0 } else { 4.0 };
            let bytes = p.free_vertices.len() as f64 * (8.0 + 6.0 * r) + incidences as f64 * 2.0 * (24.0 + 12.0 * r);
            match GpuBackend::new(ctx, &p, &x0, &ls) {
                Ok(mut g) => {
                    // the colours, then one read-back of the largest move
                    let s = time(reps, || {
                        for c in 0..g.num_colors() {
                            g.bcd_color(c).unwrap();
                        }
                        g.max_move(Slot(0)).unwrap();
                        g.flush().unwrap();
                    });
                    row.push_str(&format!(
                        " {} | {:.0} MB, {:.1} GB/s, {:.1} GFLOP/s |",
                        rate(s),
                        bytes / 1e6,
                        bytes / s / 1e9,
                        incidences as f64 * flops_per_incidence / s / 1e9
                    ));
                }
                Err(e) => row.push_str(&format!(" {e} | |")),
            }
        }
        println!("{row}");
        eprintln!("  ({}: setup {:.2} s)", case.name, setup);
    }
}
