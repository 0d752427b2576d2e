//! Table 2 of the Newton paper on generated ducts: iterations, T100 and T50
//! for inexact Newton and block coordinate descent as the problem grows.
//! Ducts are 4x1x1 boxes of Kuhn-split cubes with interior vertices perturbed
//! randomly by 0.2 of the local edge length.
//!
//! Run: cargo bench --bench newton_vs_bcd            (ducts up to ~13k vertices)
//!      cargo bench --bench newton_vs_bcd -- --full  (adds the ~180k-vertex duct)

use meshsmooth::compare;
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::solve::{Method, Options};

fn main() {
    let full = std::env::args().any(|a| a == "--full");
    let mut sizes = vec![6usize, 7, 9, 11, 14];
    if full {
        sizes.push(35);
    }
    let threads = rayon::current_num_threads();
    println!(
        "Ducts, {threads} threads, tol |grad F| < 1e-6; T in seconds, each method's setup included (the paper's way)\n"
    );
    println!(
        "| vertices | elements | F0 | Newton I | Newton T100 | Newton T50 | BCD I | BCD T100 | BCD T50 | crossover (s, % optimal) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for n in sizes {
        let mut mesh = generate::duct(n);
        let opts = PerturbOptions {
            perturbation: Perturbation::Random { alpha: 0.2 },
            fraction: 1.0,
            seed: 1,
        };
        generate::perturb(&mut mesh, &opts).expect("perturbation");
        let (cmp, _) = compare::compare(
            &mesh,
            &Default::default(),
            &[Method::Newton, Method::Bcd],
            &Options::default(),
        )
        .expect("solves");
        let (nw, bcd) = (&cmp.runs[0], &cmp.runs[1]);
        let t = |v: Option<f64>| v.map_or("-".into(), |s| format!("{s:.3}"));
        let cross = cmp
            .crossovers
            .iter()
            .find(|c| c.second == "newton")
            .map_or("-".into(), |c| {
                format!("{:.3}, {:.2}%", c.seconds, c.optimality_percent)
            });
        println!(
            "| {} | {} | {:.4} | {} | {} | {} | {} | {} | {} | {cross} |",
            cmp.vertices,
            cmp.elements,
            cmp.initial_objective,
            nw.iterations,
            t(nw.t100_with_setup),
            t(nw.t50_with_setup),
            bcd.iterations,
            t(bcd.t100_with_setup),
            t(bcd.t50_with_setup)
        );
    }
}
