//! Block coordinate descent on Mesquite's tetrahedral test meshes, against
//! Mesquite's own results (../shared/meshes/README.md). Prints a Markdown table:
//! time to reach Mesquite's final F, and time to |grad F| < 1e-6.
//!
//! Run: cargo bench --bench mesquite_tet

use meshsmooth::io;
use meshsmooth::solve::{self, Method, Params};
use std::path::PathBuf;

/// name, Mesquite FN final F, FN seconds, Mesquite BCD seconds, BCD sweeps
const MESQUITE: &[(&str, f64, f64, f64, usize)] = &[
    ("tire.vtk", 1.2583, 0.040, 0.45, 12),
    ("cube-clip-5.vtk", 1.2701, 0.108, 1.29, 20),
    ("flat-tet-sphere.vtk", 1.1970, 0.139, 1.98, 21),
    ("perturbed_box_tet_20.vtk", 1.32283, 0.186, 1.53, 11),
    ("cub_wedge_like.vtk", 1.1194, 0.76, 7.10, 15),
];

fn main() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes");
    if !dir.is_dir() {
        eprintln!("{} not found; nothing to compare", dir.display());
        return;
    }
    let threads = rayon::current_num_threads();
    println!(
        "| mesh | method | F start | F end | Mesquite F | sweeps | s to Mesquite F | s to converge | Mesquite BCD s (sweeps) | Mesquite FN s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for &(name, mq_f, mq_fn_s, mq_bcd_s, mq_sweeps) in MESQUITE {
        let mesh = io::read(&dir.join(name)).expect("mesh reads");
        for method in [Method::Bcd, Method::BcdColored] {
            // best of three runs, as the machine is shared
            let info = (0..3)
                .map(|_| {
                    let mut m = mesh.clone();
                    solve::smooth_mesh(&mut m, method, &Params::default(), &mut |_| true).unwrap()
                })
                .min_by(|a, b| a.seconds.total_cmp(&b.seconds))
                .unwrap();
            let reach = info
                .history
                .time_to_value(mq_f * (1.0 + 1e-4))
                .map_or("never".into(), |t| format!("{t:.3}"));
            let label = if method == Method::BcdColored {
                format!("{method} ({threads} threads)")
            } else {
                method.to_string()
            };
            println!(
                "| {name} | {label} | {:.5} | {:.5} | {mq_f} | {} | {reach} | {:.3} | {mq_bcd_s} ({mq_sweeps}) | {mq_fn_s} |",
                info.history.records[0].objective, info.objective, info.iterations, info.seconds
            );
        }
    }
}
