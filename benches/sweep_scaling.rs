//! Sweep throughput (tetrahedra per second) of CPU sequential BCD, CPU
//! coloured BCD on all cores and GPU coloured BCD (f32 and f64 where the
//! adapter has it), on boxes from 10k to 1M tets and on cub_wedge_like.
//! Prints a Markdown table.
//!
//! Run: cargo bench --bench sweep_scaling [-- --quick]

use meshsmooth::backend::cpu::bcd;
use meshsmooth::backend::gpu::{GpuBackend, GpuContext, GpuOptions, Precision};
use meshsmooth::backend::{Backend, Slot};
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::problem::Problem;
use meshsmooth::{Mesh, io};
use std::path::PathBuf;
use std::time::Instant;

fn perturbed_box(n: usize) -> Mesh {
    let mut m = generate::tet_box(n, n, n, [n as f64; 3]);
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: 0.3 },
        fraction: 1.0,
        seed: 1,
    };
    generate::perturb(&mut m, &opts).unwrap();
    m
}

/// Median seconds per call of `f` over `reps` calls after one warm-up call.
fn time(reps: usize, mut f: impl FnMut()) -> f64 {
    f();
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let mut meshes: Vec<(String, Mesh)> = [12usize, 20, 32, 55]
        .iter()
        .filter(|&&n| !quick || n <= 20)
        .map(|&n| (format!("box {n}^3"), perturbed_box(n)))
        .collect();
    let wedge = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes/cub_wedge_like.vtk");
    if wedge.exists() {
        meshes.push(("cub_wedge_like".into(), io::read(&wedge).unwrap()));
    }
    let gpus: Vec<(String, GpuContext)> = [Precision::F32, Precision::F64]
        .into_iter()
        .filter_map(|precision| {
            let ctx = GpuContext::new(&GpuOptions {
                adapter: None,
                precision,
            })
            .ok()?;
            Some((format!("{precision:?}").to_lowercase(), ctx))
        })
        .collect();
    if let Some((_, ctx)) = gpus.first() {
        eprintln!("GPU: {}", ctx.adapter_name());
    }
    let mut header = String::from("| mesh | tets | colours | CPU sequential | CPU coloured |");
    for (p, _) in &gpus {
        header.push_str(&format!(" GPU {p} |"));
    }
    println!("{header}");
    println!("|{}", "---|".repeat(5 + gpus.len()));
    let reps = if quick { 3 } else { 5 };
    for (name, mesh) in &meshes {
        let p = Problem::new(mesh).unwrap();
        let x0 = p.gather(&mesh.points);
        let ne = p.num_elements() as f64;
        let ls = Default::default();
        let mut x = x0.clone();
        let seq = time(reps, || {
            bcd::sweep(&p, &mut x, &ls, &Default::default(), None, None);
        });
        let mut x = x0.clone();
        let col = time(reps, || {
            for c in 0..p.colors.len() {
                bcd::sweep_color(&p, &mut x, c, &ls);
            }
        });
        let rate = |s: f64| format!("{:.2} M/s ({:.1} ms)", ne / s / 1e6, s * 1e3);
        let mut row = format!(
            "| {name} | {} | {} | {} | {} |",
            p.num_elements(),
            p.colors.len(),
            rate(seq),
            rate(col)
        );
        for (_, ctx) in &gpus {
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
                    row.push_str(&format!(" {} |", rate(s)));
                }
                Err(e) => row.push_str(&format!(" {e} |")),
            }
        }
        println!("{row}");
    }
}
