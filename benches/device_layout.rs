//! The device layout (issue #14, item 2) on an irregular mesh and boxes of
//! about its size: one coloured BCD sweep on lavapipe (or `--adapter NAME`)
//! in each device numbering (`DeviceLayout`), interleaved rep by rep so
//! that a shared machine's load falls on all of them alike, and the CPU
//! coloured sweep beside them (the CPU path keeps the problem's numbering).
//! Median of `--reps` (default 7) sweeps after one warm-up, elements per second.
//! Each mesh runs under each problem numbering of `--orderings` (default
//! `rbfs,cuthill-mckee,input`: issue #11's question of how the vertex
//! renumbering changes coloured sweep throughput on the CPU and the device;
//! the colouring follows the numbering, so colour counts may differ).
//!
//! Run: `cargo bench --bench device_layout [-- --reps N] [--tet-sizes 26,27] [--mesh PATH] [--orderings rbfs,input]`

use meshsmooth::backend::cpu::bcd;
use meshsmooth::backend::gpu::{DeviceLayout, GpuBackend, GpuContext, GpuOptions, Precision};
use meshsmooth::backend::{Backend, Slot};
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::mesh::order::Ordering;
use meshsmooth::problem::{Problem, ProblemOptions};
use meshsmooth::{Mesh, io};
use std::path::PathBuf;

mod common;
use common::{arg, median};
use std::time::Instant;

const LAYOUTS: [DeviceLayout; 3] = [DeviceLayout::Problem, DeviceLayout::ByColour, DeviceLayout::ByValence];

fn main() {
    let reps: usize = arg("--reps").map_or(7, |s| s.parse().expect("--reps N"));
    let sizes: Vec<usize> = arg("--tet-sizes")
        .unwrap_or("26,27".into())
        .split(',')
        .map(|s| s.parse().expect("--tet-sizes N,N"))
        .collect();
    let mut meshes: Vec<(String, Mesh)> = sizes
        .iter()
        .map(|&n| {
            let mut m = generate::tet_box(n, n, n, [n as f64; 3]);
            let opts = PerturbOptions {
                perturbation: Perturbation::Random { alpha: 0.3 },
                fraction: 1.0,
                seed: 1,
            };
            generate::perturb(&mut m, &opts).unwrap();
            (format!("tet box {n}³"), m)
        })
        .collect();
    let path = arg("--mesh")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes/cub_wedge_like.vtk"));
    if path.exists() {
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        meshes.push((name, io::read(&path).unwrap()));
    }
    let adapter = arg("--adapter");
    let mut gpus: Vec<(Precision, Vec<GpuContext>)> = Vec::new();
    for precision in [Precision::F32, Precision::F64] {
        let ctxs: Option<Vec<GpuContext>> = LAYOUTS
            .iter()
            .map(|&layout| {
                GpuContext::new(&GpuOptions {
                    adapter: adapter.clone(),
                    precision,
                    layout,
                    ..Default::default()
                })
                .map_err(|e| eprintln!("no {precision:?} context: {e}"))
                .ok()
            })
            .collect();
        if let Some(c) = ctxs {
            gpus.push((precision, c));
        }
    }
    if let Some((_, c)) = gpus.first() {
        println!("GPU: {}", c[0].adapter_name());
    }
    println!("CPU threads: {}\n", rayon::current_num_threads());
    let orderings: Vec<(String, Ordering)> = arg("--orderings")
        .unwrap_or("rbfs,cuthill-mckee,input".into())
        .split(',')
        .map(|name| {
            let o = match name {
                "input" | "n" => Ordering::INPUT,
                other => other.parse().unwrap_or_else(|e| panic!("--orderings: {e}")),
            };
            (name.to_string(), o)
        })
        .collect();
    let mut header = String::from("| mesh | numbering | tets | colours | CPU coloured |");
    for (p, _) in &gpus {
        for l in LAYOUTS {
            header.push_str(&format!(" GPU {p:?} {l:?} |"));
        }
    }
    println!("{header}");
    println!("|{}", "---|".repeat(header.matches('|').count() - 1));
    let ls = Default::default();
    for ((name, mesh), (order_name, ordering)) in meshes.iter().flat_map(|m| orderings.iter().map(move |o| (m, o))) {
        let mut opts = ProblemOptions::default();
        opts.ordering = *ordering;
        let p = Problem::with_options(mesh, &opts).unwrap();
        let x0 = p.gather(&mesh.points);
        let ne = p.num_elements() as f64;
        let mut x = x0.clone();
        let mut cpu_sweep = || {
            let s = Instant::now();
            for c in 0..p.colors.len() {
                bcd::sweep_color(&p, &mut x, c, &ls);
            }
            s.elapsed().as_secs_f64()
        };
        cpu_sweep();
        let cpu = median((0..reps).map(|_| cpu_sweep()).collect());
        let rate = |s: f64| format!("{:.3} M/s ({:.0} ms)", ne / s / 1e6, s * 1e3);
        let mut row = format!(
            "| {name} | {order_name} | {} | {} | {} |",
            p.num_elements(),
            p.colors.len(),
            rate(cpu)
        );
        for (_, ctxs) in &gpus {
            let mut backends: Vec<GpuBackend> = ctxs
                .iter()
                .map(|ctx| GpuBackend::new(ctx, &p, &x0, &ls).unwrap())
                .collect();
            let sweep = |g: &mut GpuBackend| {
                let s = Instant::now();
                for c in 0..g.num_colors() {
                    g.bcd_color(c).unwrap();
                }
                g.max_move(Slot(0)).unwrap();
                g.flush().unwrap();
                s.elapsed().as_secs_f64()
            };
            let mut times = vec![Vec::new(); backends.len()];
            for g in backends.iter_mut() {
                sweep(g);
            }
            for _ in 0..reps {
                for (g, t) in backends.iter_mut().zip(&mut times) {
                    t.push(sweep(g));
                }
            }
            for t in times {
                row.push_str(&format!(" {} |", rate(median(t))));
            }
        }
        println!("{row}");
    }
}
