//! Sweep throughput of coloured BCD, CPU (`sweep_colored`, rayon) against the
//! device in f32 and f64, on the perturbed 20x20x20 box (48,000 tets). Ten
//! sweeps from the perturbed start after a warm-up run; prints tets/s.
//! Run: cargo run --release --example gpu_sweep_throughput

use meshsmooth::backend::gpu::{GpuBcd, GpuContext, GpuOptions, Precision};
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::problem::Problem;
use meshsmooth::solve::bcd;
use std::time::Instant;

const SWEEPS: usize = 10;

fn main() {
    let mut mesh = generate::tet_box(20, 20, 20, [20.0; 3]);
    generate::perturb(
        &mut mesh,
        &PerturbOptions {
            perturbation: Perturbation::Random { alpha: 0.3 },
            fraction: 1.0,
            seed: 1,
        },
    )
    .unwrap();
    let p = Problem::new(&mesh).unwrap();
    let x0 = p.gather(&mesh.points);
    let ne = p.num_elements() as f64;
    println!(
        "{} tets, {} free vertices, {} colours, {} rayon threads",
        p.num_elements(),
        p.free_vertices.len(),
        p.colors.len(),
        rayon::current_num_threads()
    );

    for _ in 0..2 {
        let mut x = x0.clone();
        let t = Instant::now();
        for _ in 0..SWEEPS {
            bcd::sweep_colored(&p, &mut x, &Default::default(), None);
        }
        let s = t.elapsed().as_secs_f64() / SWEEPS as f64;
        println!(
            "cpu sweep_colored f64: {:.2} ms/sweep, {:.2} M tets/s",
            s * 1e3,
            ne / s / 1e6
        );
    }

    for precision in [Precision::F32, Precision::F64] {
        let ctx = match GpuContext::new(&GpuOptions {
            adapter: None,
            precision,
        }) {
            Ok(c) => c,
            Err(e) => {
                println!("{precision:?}: {e}");
                continue;
            }
        };
        for round in 0..2 {
            let mut gpu = GpuBcd::new(&ctx, &p, &x0).unwrap();
            gpu.objective_and_grad_norm().unwrap();
            let t = Instant::now();
            for _ in 0..SWEEPS {
                gpu.sweep().unwrap();
                gpu.wait().unwrap();
            }
            let sweep = t.elapsed().as_secs_f64() / SWEEPS as f64;
            let t = Instant::now();
            for _ in 0..SWEEPS {
                gpu.evaluate().unwrap();
            }
            let eval = t.elapsed().as_secs_f64() / SWEEPS as f64;
            println!(
                "{} {precision:?}{}: sweep {:.2} ms ({:.2} M tets/s), objective+|grad| read-back {:.2} ms",
                ctx.adapter_name(),
                if round == 0 { " (cold)" } else { "" },
                sweep * 1e3,
                ne / sweep / 1e6,
                eval * 1e3
            );
        }
    }
}
