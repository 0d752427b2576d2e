//! Our solvers on Mesquite's test meshes (the VTK files of Mesquite's
//! `testSuite/meshFiles`), against the times Mesquite's FeasibleNewton and
//! block coordinate descent took on them on one core of the same machine
//! class. Prints a Markdown table: time to reach Mesquite's final F (within
//! 1e-4 relative) with our setup counted (Mesquite's time includes its own),
//! and time to |grad F| < 1e-6, on one thread and on all cores. BCD runs on
//! the tetrahedral meshes (on the others it needs thousands of sweeps, as
//! Mesquite's own capped BCD runs show).
//!
//! Run: MESHSMOOTH_MESQUITE_MESHES=DIR cargo bench --bench mesquite
//! (DIR defaults to ../shared/meshes next to this repository).

use meshsmooth::io;
use meshsmooth::solve::{self, Info, Method, Params};
use std::path::PathBuf;

/// name, Mesquite FN final F, FN seconds, Mesquite BCD seconds, BCD sweeps
const MESQUITE: &[(&str, f64, f64, f64, usize)] = &[
    ("tire.vtk", 1.2583, 0.040, 0.45, 12),
    ("cube-clip-5.vtk", 1.2701, 0.108, 1.29, 20),
    ("flat-tet-sphere.vtk", 1.1970, 0.139, 1.98, 21),
    ("perturbed_box_tet_20.vtk", 1.32283, 0.186, 1.53, 11),
    ("cub_wedge_like.vtk", 1.1194, 0.76, 7.10, 15),
    ("shashkov.vtk", 3.105, 0.51, 0.95, 50),
    ("tri_20258.vtk", 1.03359, 0.087, 3.38, 50),
    ("shashkov_quad.vtk", 3.471, 0.51, 1.83, 50),
    ("overt_hyb_1.vtk", 1.0264, 0.052, 2.05, 50),
    ("1000hex-block-internal-bias.vtk", 1.0000, 0.020, 0.82, 23),
    ("cub_fru.vtk", 2.5350, 2.92, 21.7, 50),
];

fn main() {
    let dir = std::env::var_os("MESHSMOOTH_MESQUITE_MESHES")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes"));
    if !dir.is_dir() {
        eprintln!(
            "{} not found: set MESHSMOOTH_MESQUITE_MESHES to a folder holding Mesquite's test meshes",
            dir.display()
        );
        return;
    }
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let all = rayon::current_num_threads();
    println!(
        "| mesh | method | threads | F end | Mesquite F | iterations | s to Mesquite F (with setup) | s to converge (with setup) | vs Mesquite FN (s) | vs Mesquite BCD (s, sweeps) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for &(name, mq_f, mq_fn_s, mq_bcd_s, mq_sweeps) in MESQUITE {
        let mesh = io::read(&dir.join(name)).expect("mesh reads");
        let tets = mesh.kinds.iter().all(|&k| k == meshsmooth::ElementKind::Tetrahedron);
        let runs: &[(Method, usize)] = if tets {
            &[
                (Method::Bcd, 1),
                (Method::Newton, 1),
                (Method::BcdColored, all),
                (Method::Newton, all),
            ]
        } else {
            &[(Method::Newton, 1), (Method::Newton, all)]
        };
        for &(method, threads) in runs {
            let run = || -> Info {
                // best of three: the machine may be shared
                (0..3)
                    .map(|_| {
                        let mut m = mesh.clone();
                        solve::smooth_mesh(
                            &mut m,
                            &Default::default(),
                            &solve::Options::cpu(method, &Params::default()),
                            &mut |_| true,
                        )
                        .unwrap()
                    })
                    .min_by(|a, b| a.seconds.total_cmp(&b.seconds))
                    .unwrap()
            };
            let info = if threads == 1 { one.install(run) } else { run() };
            // setup counted on our side too: Mesquite's times include its own
            let reach = info
                .history
                .time_to_value(mq_f * (1.0 + 1e-4))
                .map(|t| t + info.setup_seconds);
            let speedup = |mq: f64| reach.map_or("-".into(), |t| ratio(mq / t.max(1e-6)));
            println!(
                "| {name} | {method} | {threads} | {:.5} | {mq_f} | {} | {} | {:.3} | {} ({mq_fn_s}) | {} ({mq_bcd_s}, {mq_sweeps}) |",
                info.objective,
                info.iterations,
                reach.map_or("never".into(), |t| format!("{t:.3}")),
                info.seconds + info.setup_seconds,
                speedup(mq_fn_s),
                speedup(mq_bcd_s),
            );
        }
    }
}

/// Their time over ours, worded so that a slower result reads as slower.
fn ratio(r: f64) -> String {
    if r >= 1.0 {
        format!("{r:.1}× faster")
    } else {
        format!("{r:.1}× (slower)")
    }
}
