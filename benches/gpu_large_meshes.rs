//! GPU BCD and Newton on perturbed tetrahedral boxes up to 10.4M tets (a
//! 120^3 box), f32 and f64, as far as the device's memory and bindings allow:
//! the per-corner and per-block arrays beyond one storage binding are split
//! across several (`Binding::split`). Prints a Markdown table row per run as
//! soon as it is measured, so a run stopped by memory keeps what it had.
//!
//! Run: `cargo bench --bench gpu_large_meshes [-- --sizes 20,55,80,100,120] [--iters 2]
//! [--precision f32|f64] [--method bcd|newton] [--alpha 0.3] [--max-binding-mib M]
//! [--max-storage-buffers K] [--forms auto|closed|general] [--adapter NAME]` (both precisions and methods unless
//! named; `--alpha`: the random perturbation, in edge lengths; `--max-binding-mib`: cap
//! a binding, to see what splitting into more parts costs; `--max-storage-buffers`: cap
//! the storage buffers a kernel binds, so that the corner kernels run in windows of
//! fewer parts; `--forms`: which corner kernels, `GpuOptions::forms`)
//!
//! Time per iteration = (time at the last iterate - time at the start) /
//! iterations, from the solver's history (setup and upload excluded, shown
//! apart): a BCD iteration is one coloured sweep, a Newton iteration one
//! assembly, PCG solve and line search.

use meshsmooth::backend::gpu::{GpuContext, GpuOptions, KernelForms, Precision};
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::problem::Problem;
use meshsmooth::solve::{self, Device, Method, Options, Params};

mod common;
use common::arg;
use std::time::Instant;

fn main() {
    let sizes: Vec<usize> = arg("--sizes")
        .unwrap_or("20,55,80,100,120".into())
        .split(',')
        .map(|s| s.parse().expect("--sizes N,N,..."))
        .collect();
    let iters: usize = arg("--iters").map_or(2, |s| s.parse().expect("--iters N"));
    let adapter = arg("--adapter");
    let alpha: f64 = arg("--alpha").map_or(0.3, |s| s.parse().expect("--alpha A"));
    let max_binding_bytes = arg("--max-binding-mib").map(|s| s.parse::<u64>().expect("--max-binding-mib M") << 20);
    let max_storage_buffers = arg("--max-storage-buffers").map(|s| s.parse().expect("--max-storage-buffers K"));
    let forms = arg("--forms").map_or(KernelForms::Auto, |s| {
        s.parse::<KernelForms>().expect("--forms auto|closed|general")
    });
    let precisions = match arg("--precision").as_deref() {
        Some("f32") => vec![Precision::F32],
        Some("f64") => vec![Precision::F64],
        _ => vec![Precision::F32, Precision::F64],
    };
    let methods = match arg("--method").as_deref() {
        Some("bcd") => vec![Method::BcdColored],
        Some("newton") => vec![Method::Newton],
        _ => vec![Method::BcdColored, Method::Newton],
    };
    let gpus: Vec<GpuContext> = precisions
        .into_iter()
        .filter_map(|precision| {
            GpuContext::new(&GpuOptions {
                adapter: adapter.clone(),
                precision,
                max_binding_bytes,
                max_storage_buffers,
                forms,
                ..Default::default()
            })
            .map_err(|e| eprintln!("no {precision:?} context: {e}"))
            .ok()
        })
        .collect();
    let Some(first) = gpus.first() else {
        return;
    };
    println!("GPU: {}\n", first.adapter_name());
    println!(
        "| box | tets | problem setup (CPU) | precision | method | GPU setup + upload | time per iteration | CG iterations | device memory |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for n in sizes {
        let t = Instant::now();
        let mut mesh = generate::tet_box(n, n, n, [n as f64; 3]);
        let opts = PerturbOptions {
            perturbation: Perturbation::Random { alpha },
            fraction: 1.0,
            seed: 1,
        };
        generate::perturb(&mut mesh, &opts).unwrap();
        let p = Problem::new(&mesh).unwrap();
        let x0 = p.gather(&mesh.points);
        drop(mesh);
        let setup = t.elapsed().as_secs_f64();
        for ctx in &gpus {
            for &method in &methods {
                let mut params = Params::default();
                params.max_iter = iters;
                params.tol = 0.0;
                let mut options = Options::default();
                options.method = method;
                options.params = params;
                options.device = Device::Gpu(ctx);
                let mut x = x0.clone();
                let precision = if ctx.is_f64() { "f64" } else { "f32" };
                let head = format!(
                    "| {n}³ | {} | {setup:.1} s | {precision} | {method:?} |",
                    p.num_elements()
                );
                match solve::solve(&p, &mut x, &options, &mut |_| true) {
                    Ok(info) => {
                        let r = &info.history.records;
                        let (a, b) = (&r[0], &r[r.len() - 1]);
                        let per = (b.seconds - a.seconds) / (b.iteration - a.iteration).max(1) as f64;
                        println!(
                            "{head} {:.1} s | {:.2} s | {} | {:.2} GiB |",
                            info.setup_seconds,
                            per,
                            info.cg_iterations
                                .map_or("-".into(), |c| format!("{c} in {}", info.iterations)),
                            info.memory_bytes as f64 / (1u64 << 30) as f64
                        );
                    }
                    Err(e) => println!("{head} failed: {e} | | | |"),
                }
            }
        }
    }
}
