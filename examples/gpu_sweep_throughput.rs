//! Sweep throughput of coloured BCD, CPU (`sweep_colored`, rayon) against the
//! device in f32 and f64, on the perturbed 20x20x20 box (48,000 tets). Ten
//! sweeps from the perturbed start after a warm-up run; prints tets/s.
//! Run: cargo run --release --example gpu_sweep_throughput

use meshsmooth::backend::cpu::CpuBackend;
use meshsmooth::backend::gpu::{GpuBackend, GpuContext, GpuOptions, Precision};
use meshsmooth::backend::{Backend, EvalSlots, Points, Slot};
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::problem::Problem;
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

    let ls = Default::default();
    for _ in 0..2 {
        let mut cpu = CpuBackend::new(&p, &x0, &ls).unwrap();
        let t = Instant::now();
        for _ in 0..SWEEPS {
            sweep(&mut cpu);
        }
        let s = t.elapsed().as_secs_f64() / SWEEPS as f64;
        println!(
            "cpu coloured f64: {:.2} ms/sweep, {:.2} M tets/s",
            s * 1e3,
            ne / s / 1e6
        );
    }

    for precision in [Precision::F32, Precision::F64] {
        let ctx = match GpuContext::new(&GpuOptions {
            precision,
            ..Default::default()
        }) {
            Ok(c) => c,
            Err(e) => {
                println!("{precision:?}: {e}");
                continue;
            }
        };
        for round in 0..2 {
            let mut gpu = GpuBackend::new(&ctx, &p, &x0, &ls).unwrap();
            let t = Instant::now();
            for _ in 0..SWEEPS {
                sweep(&mut gpu);
            }
            let sweep_s = t.elapsed().as_secs_f64() / SWEEPS as f64;
            let t = Instant::now();
            for _ in 0..SWEEPS {
                gpu.evaluate(Points::Current, EVAL, None).unwrap();
                gpu.flush().unwrap();
            }
            let eval = t.elapsed().as_secs_f64() / SWEEPS as f64;
            println!(
                "{} {precision:?}{}: sweep {:.2} ms ({:.2} M tets/s), objective read-back {:.2} ms",
                ctx.adapter_name(),
                if round == 0 { " (cold)" } else { "" },
                sweep_s * 1e3,
                ne / sweep_s / 1e6,
                eval * 1e3
            );
        }
    }
}

const EVAL: EvalSlots = EvalSlots {
    value: Slot(0),
    infeasible: Slot(1),
    min_det: None,
};

/// One coloured sweep and one read-back of its largest move.
fn sweep(be: &mut dyn Backend) {
    for c in 0..be.num_colors() {
        be.bcd_color(c).unwrap();
    }
    be.max_move(Slot(2)).unwrap();
    be.flush().unwrap();
}
