//! Sweep throughput (elements per second) of the CPU solvers on the
//! perturbed 20x20x20 box (48,000 tetrahedra).

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use meshsmooth::backend::cpu::{bcd, laplace};
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::objective;
use meshsmooth::problem::Problem;
use std::hint::black_box;

fn perturbed_box(n: usize) -> meshsmooth::Mesh {
    let mut m = generate::tet_box(n, n, n, [n as f64; 3]);
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: 0.3 },
        fraction: 1.0,
        seed: 1,
    };
    generate::perturb(&mut m, &opts).unwrap();
    m
}

fn sweeps(c: &mut Criterion) {
    let mesh = perturbed_box(20);
    let p = Problem::new(&mesh).unwrap();
    let x0 = p.gather(&mesh.points);
    let mut group = c.benchmark_group("box20_48000_tets");
    group.throughput(Throughput::Elements(p.num_elements() as u64));
    group.sample_size(30);
    group.bench_function("bcd_sweep_first", |b| {
        b.iter_batched(
            || x0.clone(),
            |mut x| bcd::sweep(&p, &mut x, &Default::default(), &Default::default(), None, None),
            BatchSize::LargeInput,
        )
    });
    // a sweep near the optimum, where most full Newton steps are accepted
    let mut near = x0.clone();
    for _ in 0..10 {
        bcd::sweep(&p, &mut near, &Default::default(), &Default::default(), None, None);
    }
    group.bench_function("bcd_sweep_near_optimum", |b| {
        b.iter_batched(
            || near.clone(),
            |mut x| bcd::sweep(&p, &mut x, &Default::default(), &Default::default(), None, None),
            BatchSize::LargeInput,
        )
    });
    group.bench_function("laplace_sweep", |b| {
        b.iter_batched(
            || x0.clone(),
            |mut x| laplace::sweep(&p, &mut x, None),
            BatchSize::LargeInput,
        )
    });
    group.bench_function("objective_gradient", |b| {
        b.iter(|| black_box(objective::gradient(&p, &x0)))
    });
    group.finish();
}

criterion_group!(benches, sweeps);
criterion_main!(benches);
