use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::metric::inverted_elements;
use meshsmooth::problem::ProblemOptions;
use meshsmooth::solve::untangle::{UntangleParams, untangle_mesh};
use meshsmooth::solve::{Method, Options, Params};
fn main() {
    let meshes = vec![
        ("tri", generate::tri_grid(20, 20, [20.0, 20.0])),
        ("quad", generate::quad_grid(20, 20, [20.0, 20.0])),
        ("tet", generate::tet_box(8, 8, 8, [8.0; 3])),
        ("hex", generate::hex_box(8, 8, 8, [8.0; 3])),
        ("graded", generate::graded_tet_box(8, 1e3)),
    ];
    for (name, r) in meshes {
        for alpha in [0.6, 1.0, 2.0, 4.0] {
            for method in [Method::Newton, Method::Bcd] {
                let mut m = r.clone();
                generate::perturb_unguarded(
                    &mut m,
                    &PerturbOptions {
                        perturbation: Perturbation::Random { alpha },
                        fraction: 1.0,
                        seed: 1,
                    },
                )
                .unwrap();
                let bad = inverted_elements(&m, &m.points).len();
                let t = std::time::Instant::now();
                let res = untangle_mesh(
                    &mut m,
                    &ProblemOptions::default(),
                    &Options::cpu(method, &Params::default()),
                    &UntangleParams::default(),
                    &mut |_| true,
                );
                match res {
                    Ok(i) => println!(
                        "{name} a={alpha} {method}: {bad}/{} inverted -> {} rounds {} its {:.2}s sched {:?}",
                        m.num_elements(),
                        i.rounds,
                        i.iterations,
                        t.elapsed().as_secs_f64(),
                        i.schedule
                            .iter()
                            .map(|(e, d)| (format!("{e:.1e}"), format!("{d:.1e}")))
                            .collect::<Vec<_>>()
                    ),
                    Err(e) => println!("{name} a={alpha} {method}: {bad}/{} FAILED {e}", m.num_elements()),
                }
            }
        }
    }
}
