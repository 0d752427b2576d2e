//! Partitioned smoothing under `mpirun` gives the single-process answer: the
//! built binary is run on 1 to 4 ranks and compared with a plain run on a
//! generated tet box, a Gmsh mesh, a mixed tet/prism/hex mesh and a planar
//! triangle grid.
//!
//! Newton matches to 1e-10 (relative) in F and in the iterate with the same
//! iteration count: per-vertex work gives the same bits on every partition,
//! and only the ranks' partial sums are added in another order. Coloured BCD
//! follows the same iterates exactly (its per-vertex steps see the same data,
//! its only reduction that steers it is a maximum). With `--device gpu` each
//! rank runs its part on its own GPU context (lavapipe here, shared by the
//! ranks): Newton, coloured BCD, NLCG, a sliding boundary and a planar mesh
//! against one GPU process in f64, and an f32 case. Needs `mpirun` (Open MPI).

use crate::common;

use meshsmooth::Mesh;
use meshsmooth::backend::gpu::Precision;
use meshsmooth::metric::inverted_elements;
use meshsmooth::problem::Problem;
use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_meshsmooth");

struct Run {
    /// F per iteration (the history CSV), the last the answer.
    objective: Vec<f64>,
    points: Vec<[f64; 3]>,
    stdout: String,
}

fn smooth(ranks: Option<usize>, input: &Path, dir: &Path, method: &str) -> Run {
    smooth_by(ranks, input, dir, method, "metis")
}

fn smooth_by(ranks: Option<usize>, input: &Path, dir: &Path, method: &str, partitioner: &str) -> Run {
    smooth_with(ranks, input, dir, method, partitioner, &[])
}

/// `smooth_by` with more options (`extra`), which name its files too.
fn smooth_with(ranks: Option<usize>, input: &Path, dir: &Path, method: &str, partitioner: &str, extra: &[&str]) -> Run {
    let stem = input.file_stem().unwrap().to_string_lossy();
    let tag = ranks.map_or("plain".to_string(), |n| format!("np{n}-{partitioner}"));
    let tag = format!("{stem}-{tag}{}", extra.join("").replace(['-', '.', '/'], "_"));
    let out = dir.join(format!("{tag}-{method}.vtu"));
    let history = dir.join(format!("{tag}-{method}.csv"));
    let mut cmd = match ranks {
        Some(n) => {
            let mut c = Command::new("mpirun");
            c.args(["--allow-run-as-root", "--oversubscribe", "-np", &n.to_string(), BIN]);
            c
        }
        None => Command::new(BIN),
    };
    cmd.arg("smooth")
        .arg(input)
        .arg("-o")
        .arg(&out)
        .args(["--method", method, "--partitioner", partitioner, "--history"])
        .arg(&history)
        .args(extra)
        .env_remove("OMPI_COMM_WORLD_SIZE");
    if !extra.contains(&"--device") {
        cmd.args(["--device", "cpu"]);
    }
    // partitioned runs precondition with block Jacobi (auto's Gauss-Seidel on
    // a planar mesh is one process's): the single run here must do the same
    if method == "newton" && !extra.contains(&"--preconditioner") {
        cmd.args(["--preconditioner", "jacobi"]);
    }
    if extra.contains(&"gpu") {
        // a waiting rank yields its core to the others' (software) GPU instead of spinning
        cmd.env("OMPI_MCA_mpi_yield_when_idle", "1");
    }
    let o = cmd.output().expect("mpirun runs (apt-get install openmpi-bin)");
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "{tag} {method} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let csv = std::fs::read_to_string(&history).unwrap();
    let objective = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(2).unwrap().parse().unwrap())
        .collect();
    Run {
        objective,
        points: meshsmooth::io::read(&out).unwrap().points,
        stdout,
    }
}

fn max_rel(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let scale = a.iter().flatten().fold(0.0f64, |m, c| m.max(c.abs())).max(1e-300);
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
        / scale
}

fn meshes(dir: &Path) -> Vec<PathBuf> {
    let generate = |args: &[&str], name: &str| {
        let path = dir.join(name);
        let o = Command::new(BIN)
            .arg("generate")
            .args(args)
            .arg("-o")
            .arg(&path)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        path
    };
    let gmsh = dir.join("gmsh_box.msh");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/interop/gmsh_box_phys_msh41a.msh"),
        &gmsh,
    )
    .unwrap();
    vec![
        generate(
            &["box", "--cells", "5", "4", "4", "--perturb", "random:0.3"],
            "tet_box.vtu",
        ),
        gmsh,
        generate(
            &["mixed", "--cells", "4", "--layers", "2", "--perturb", "random:0.25"],
            "mixed.vtu",
        ),
        // planar: the parts carry the plane's frame
        generate(
            &["grid", "--cells", "10", "8", "--type", "tri", "--perturb", "random:0.3"],
            "tri.vtu",
        ),
    ]
}

/// Vertices the problem fixes (the boundary and user-fixed ones) keep their bits.
fn assert_fixed_unmoved(input: &Mesh, out: &[[f64; 3]], what: &str) {
    let p = Problem::new(input).unwrap();
    for (new, &old) in p.order.iter().enumerate() {
        if !p.free[new] {
            assert_eq!(
                input.points[old as usize], out[old as usize],
                "{what}: fixed vertex {old} moved"
            );
        }
    }
}

fn compare(method: &str, partitioner: &str, ranks: std::ops::RangeInclusive<usize>, f_tol: f64, x_tol: f64) {
    let dir = tempfile::tempdir().unwrap();
    for input in meshes(dir.path()) {
        let mesh = meshsmooth::io::read(&input).unwrap();
        let one = smooth(None, &input, dir.path(), method);
        assert!(
            one.objective.len() > 2,
            "{}: the plain run did nothing",
            input.display()
        );
        for ranks in ranks.clone() {
            let what = format!("{} {method} on {ranks} ranks ({partitioner})", input.display());
            let many = smooth_by(Some(ranks), &input, dir.path(), method, partitioner);
            assert!(
                many.stdout.contains(&format!("mpi ({ranks} ranks)")),
                "{what}: not partitioned:\n{}",
                many.stdout
            );
            assert!(many.stdout.contains("edge cut"), "{what}: no partition report");
            assert!(
                many.stdout.contains(&format!("partitioner {partitioner}")),
                "{what}: the report does not name the partitioner:\n{}",
                many.stdout
            );
            assert_same_run(&one, &many, &what, f_tol, x_tol);
            assert!(inverted_elements(&mesh, &many.points).is_empty(), "{what}: infeasible");
            assert_fixed_unmoved(&mesh, &many.points, &what);
        }
    }
}

#[test]
fn newton_on_ranks_matches_one_process() {
    compare("newton", "metis", 1..=4, 1e-10, 1e-10);
}

#[test]
fn colored_bcd_on_ranks_matches_one_process() {
    compare("bcd-colored", "metis", 1..=4, 1e-8, 1e-8);
}

/// The geometric fallback partitions as well as METIS for the solve's answer.
#[test]
fn newton_on_a_bisection_partition_matches_one_process() {
    compare("newton", "rcb", 2..=4, 1e-10, 1e-10);
}

/// Runs the binary under mpirun on `ranks` ranks; its stdout.
fn mpirun(ranks: usize, args: &[&std::ffi::OsStr]) -> String {
    let o = Command::new("mpirun")
        .args(["--allow-run-as-root", "--oversubscribe", "-np", &ranks.to_string(), BIN])
        .args(args)
        .output()
        .expect("mpirun runs");
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "{args:?} on {ranks} ranks failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    stdout
}

/// A 3-rank run writes its parts as .pvtu pieces; they read back, with and
/// without MPI, as the mesh the same run writes gathered into one file.
#[test]
fn pieces_of_a_three_rank_run_read_back_as_the_gathered_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let all = meshes(dir.path());
    for input in [&all[0], &all[2]] {
        let name = input.file_stem().unwrap().to_string_lossy().into_owned();
        let path = |f: &str| dir.path().join(format!("{name}-{f}"));
        let smooth = |ranks: usize, from: &Path, to: &Path| {
            mpirun(
                ranks,
                &[
                    "smooth".as_ref(),
                    from.as_os_str(),
                    "-o".as_ref(),
                    to.as_os_str(),
                    "--device".as_ref(),
                    "cpu".as_ref(),
                ],
            )
        };
        smooth(3, input, &path("gathered.vtu"));
        let log = smooth(3, input, &path("pieces.pvtu"));
        assert!(log.contains("wrote 3 pieces"), "{name}: {log}");
        assert!(
            log.contains("pieces written by ranks 0, 1, 2; the index by rank 0"),
            "{name}: {log}"
        );
        for r in 0..3 {
            assert!(path(&format!("pieces_{r}.vtu")).exists(), "{name}: piece {r} missing");
        }
        let gathered = meshsmooth::io::read(path("gathered.vtu")).unwrap();
        // without MPI: the library reads all pieces and merges them
        assert_eq!(meshsmooth::io::read(path("pieces.pvtu")).unwrap(), gathered, "{name}");
        // under MPI, with as many ranks as pieces and with fewer: the same mesh, so the same run
        for (ranks, readers) in [(3, "0, 1, 2"), (2, "0, 0, 1")] {
            let log = smooth(ranks, &path("pieces.pvtu"), &path(&format!("again-pieces-{ranks}.vtu")));
            assert!(
                log.contains(&format!("were read by ranks {readers} (in piece order)")),
                "{name}: {log}"
            );
            smooth(
                ranks,
                &path("gathered.vtu"),
                &path(&format!("again-gathered-{ranks}.vtu")),
            );
            let a = meshsmooth::io::read(path(&format!("again-pieces-{ranks}.vtu"))).unwrap();
            let b = meshsmooth::io::read(path(&format!("again-gathered-{ranks}.vtu"))).unwrap();
            assert_eq!(a, b, "{name} on {ranks} ranks");
        }
    }
}

#[test]
fn refusals_are_clean() {
    let dir = tempfile::tempdir().unwrap();
    let input = &meshes(dir.path())[0];
    let o = Command::new("mpirun")
        .args(["--allow-run-as-root", "--oversubscribe", "-np", "2", BIN, "smooth"])
        .arg(input)
        .arg("-o")
        .arg(dir.path().join("out.vtu"))
        .args(["--method", "laplace"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("under MPI"));
}

/// Ranks reading the pieces of an earlier run themselves (one piece each on
/// 3 ranks; two and one on 2) solve the mesh one process solves from the
/// same pieces: F to 1e-8 at every iteration.
#[test]
fn ranks_reading_their_own_pieces_give_the_single_process_objective() {
    let dir = tempfile::tempdir().unwrap();
    let input = &meshes(dir.path())[0];
    let pieces = dir.path().join("earlier.pvtu");
    mpirun(
        3,
        &[
            "smooth".as_ref(),
            input.as_os_str(),
            "-o".as_ref(),
            pieces.as_os_str(),
            "--device".as_ref(),
            "cpu".as_ref(),
            "--max-iter".as_ref(),
            "2".as_ref(),
        ],
    );
    let one = smooth(None, &pieces, dir.path(), "newton");
    assert!(one.objective.len() > 2, "the plain run did nothing");
    for ranks in [2, 3] {
        let many = smooth(Some(ranks), &pieces, dir.path(), "newton");
        assert!(
            many.stdout.contains("were read by ranks"),
            "{ranks} ranks: {}",
            many.stdout
        );
        assert_eq!(
            many.objective.len(),
            one.objective.len(),
            "{ranks} ranks: iteration count"
        );
        for (k, (a, b)) in one.objective.iter().zip(&many.objective).enumerate() {
            assert!(
                (a - b).abs() <= 1e-8 * a.abs(),
                "{ranks} ranks: F at iteration {k}: {a} vs {b}"
            );
        }
        assert!(
            max_rel(&one.points, &many.points) <= 1e-8,
            "{ranks} ranks: iterates differ"
        );
    }
    // more pieces than ranks: written round the ranks, read in runs of consecutive pieces
    let five = dir.path().join("five.pvtu");
    let gathered = dir.path().join("five-gathered.vtu");
    let run = |from: &Path, output: &Path, extra: &[&str]| {
        let mut args: Vec<&std::ffi::OsStr> = vec![
            "smooth".as_ref(),
            from.as_os_str(),
            "-o".as_ref(),
            output.as_os_str(),
            "--device".as_ref(),
            "cpu".as_ref(),
        ];
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        mpirun(2, &args)
    };
    let log = run(&pieces, &five, &["--pieces", "5"]);
    assert!(log.contains("were read by ranks 0, 0, 1 (in piece order)"), "{log}");
    assert!(
        log.contains("pieces written by ranks 0, 1, 0, 1, 0; the index by rank 0"),
        "{log}"
    );
    run(&pieces, &gathered, &[]);
    let whole = meshsmooth::io::read(&gathered).unwrap();
    assert_eq!(meshsmooth::io::read(&five).unwrap(), whole);
    let log = run(&five, &dir.path().join("five-again.vtu"), &["--max-iter", "0"]);
    assert!(
        log.contains("were read by ranks 0, 0, 0, 1, 1 (in piece order)"),
        "{log}"
    );
}

/// NLCG is written once over the backend contract, so it runs over the
/// distributed backend unchanged.
#[test]
fn nlcg_on_ranks_matches_one_process() {
    compare("nlcg", "metis", 1..=3, 1e-8, 1e-8);
}

/// Sliding vertices carry their constraints (projector, candidate boundary
/// primitives) into the parts: 2 ranks give the single-process answer.
#[test]
fn sliding_boundary_on_two_ranks_matches_one_process() {
    let dir = tempfile::tempdir().unwrap();
    let all = meshes(dir.path());
    let slide = ["--boundary", "slide"];
    for input in [&all[0], &all[2], &all[3]] {
        let mesh = meshsmooth::io::read(input).unwrap();
        for method in ["newton", "bcd-colored", "nlcg"] {
            let what = format!("{} {method}", input.display());
            let one = smooth_with(None, input, dir.path(), method, "metis", &slide);
            let two = smooth_with(Some(2), input, dir.path(), method, "metis", &slide);
            assert!(two.stdout.contains("mpi (2 ranks)"), "{what}: not partitioned");
            assert!(two.stdout.contains("slide on boundary faces"), "{what}: {}", two.stdout);
            // the boundary slid: the fixed-boundary problem's fixed vertices moved
            let p = Problem::new(&mesh).unwrap();
            let slid = p
                .order
                .iter()
                .enumerate()
                .filter(|&(new, &old)| !p.free[new] && two.points[old as usize] != mesh.points[old as usize])
                .count();
            assert!(slid > 0, "{what}: no boundary vertex moved");
            // each step's face, crease or hold is decided at relative
            // thresholds from the gradient, whose sums the ranks add in another
            // order: late in a solve that can change a step, so the runs agree
            // in F and closely in position, not iteration for iteration
            let (a, b) = (one.objective.last().unwrap(), two.objective.last().unwrap());
            assert!((a - b).abs() <= 1e-6 * a.abs(), "{what}: F {a} vs {b}");
            let dx = max_rel(&one.points, &two.points);
            assert!(dx <= 1e-2, "{what}: results differ by {dx:e}");
            assert!(inverted_elements(&mesh, &two.points).is_empty(), "{what}: infeasible");
        }
    }
}

/// A time limit is read from rank 0's clock and shared, so every rank stops
/// at the same iteration (rank 0 checks the ranks' counts and fails the run
/// if they differ) and the output is the last accepted, valid state.
#[test]
fn a_time_limit_stops_every_rank_at_the_same_iteration() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("big.vtu");
    let o = Command::new(BIN)
        .args([
            "generate",
            "box",
            "--cells",
            // large enough that no method stops before the limit on a quiet
            // machine (Newton took 1.0 s on 16^3 and 5.3 s here to stall)
            "24",
            "24",
            "24",
            "--perturb",
            "random:0.3",
            "-o",
        ])
        .arg(&input)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mesh = meshsmooth::io::read(&input).unwrap();
    let limit = ["--time-limit", "1", "--tol", "0", "--max-iter", "1000000"];
    for method in ["bcd-colored", "newton", "nlcg"] {
        let run = smooth_with(Some(2), &input, dir.path(), method, "metis", &limit);
        assert!(run.stdout.contains("time limit reached"), "{method}: {}", run.stdout);
        assert!(run.objective.len() >= 2, "{method}: no iteration before the limit");
        assert!(
            run.objective.last().unwrap() < &run.objective[0],
            "{method}: F did not decrease"
        );
        assert!(
            inverted_elements(&mesh, &run.points).is_empty(),
            "{method}: inverted output"
        );
        assert_fixed_unmoved(&mesh, &run.points, method);
    }
}

/// A GPU per rank for the tests below: every rank opens its own context on
/// the adapter this finds (lavapipe on CI, all ranks sharing it). `false`,
/// with the reason printed, where there is none — except under `CI`, where
/// that fails the test.
fn gpu_ranks_possible(precision: Precision) -> bool {
    common::context(precision).is_some()
}

/// `method` on one process and on `ranks` ranks, both on the GPU in
/// `precision`, from `input`: (one, many), checked to be partitioned over
/// GPU ranks, feasible and (unless the boundary slides) with the fixed
/// vertices unmoved.
fn gpu_pair(dir: &Path, input: &Path, method: &str, precision: &str, ranks: usize, extra: &[&str]) -> (Run, Run) {
    let gpu: Vec<&str> = ["--device", "gpu", "--precision", precision]
        .into_iter()
        .chain(extra.iter().copied())
        .collect();
    let one = smooth_with(None, input, dir, method, "metis", &gpu);
    let two = smooth_with(Some(ranks), input, dir, method, "metis", &gpu);
    let what = format!("{} {method} {precision} {extra:?} on {ranks} ranks", input.display());
    assert!(one.objective.len() > 2, "{what}: the plain run did nothing");
    assert!(
        two.stdout.contains(&format!("on mpi ({ranks} ranks) x gpu")) && two.stdout.contains(&format!("({precision})")),
        "{what}: not on a GPU per rank:\n{}",
        two.stdout
    );
    let mesh = meshsmooth::io::read(input).unwrap();
    assert!(inverted_elements(&mesh, &two.points).is_empty(), "{what}: infeasible");
    if !extra.contains(&"slide") {
        assert_fixed_unmoved(&mesh, &two.points, &what);
    }
    (one, two)
}

/// Newton with a GPU per rank (2 and 3 ranks) in f64 follows the single-process GPU run:
/// the same iteration count, F to 1e-10 at every iteration and the iterate
/// to 1e-9 (the per-vertex work is the same; the ranks' partial sums — F
/// over owned corners, dots over owned entries — add in another order),
/// and it reaches the CPU's F to 1e-10.
#[test]
fn newton_with_a_gpu_per_rank_matches_one_gpu_process() {
    if !gpu_ranks_possible(Precision::F64) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let all = meshes(dir.path());
    for (input, ranks) in [(&all[0], 2), (&all[0], 3), (&all[2], 2)] {
        let (one, two) = gpu_pair(dir.path(), input, "newton", "f64", ranks, &[]);
        let what = format!("{} on {ranks} ranks", input.display());
        assert_same_run(&one, &two, &what, 1e-10, 1e-9);
        let cpu = smooth(None, input, dir.path(), "newton");
        let (a, b) = (cpu.objective.last().unwrap(), two.objective.last().unwrap());
        assert!(
            (a - b).abs() <= 1e-10 * a.abs(),
            "{what}: F {b} on GPU ranks, {a} on the CPU"
        );
    }
}

/// Coloured BCD with a GPU per rank in f64: each colour's steps see the
/// single-process data (its ghosts exchanged after every colour), so it
/// reaches the single-process GPU optimum, F and iterate to 1e-8, in the
/// same number of sweeps.
#[test]
fn colored_bcd_with_a_gpu_per_rank_matches_one_gpu_process() {
    if !gpu_ranks_possible(Precision::F64) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let input = &meshes(dir.path())[0];
    let (one, two) = gpu_pair(dir.path(), input, "bcd-colored", "f64", 2, &[]);
    assert_eq!(two.objective.len(), one.objective.len(), "sweep count");
    let (a, b) = (one.objective.last().unwrap(), two.objective.last().unwrap());
    assert!((a - b).abs() <= 1e-8 * a.abs(), "F {a} vs {b}");
    let dx = max_rel(&one.points, &two.points);
    assert!(dx <= 1e-8, "iterates differ by {dx:e}");
}

/// In f32 the ranks' sums round differently from one process's, and the
/// stopping test sits near f32's resolution, so only the answer is
/// compared: F to 1e-5 (relative) of the single-process f32 run and of the
/// CPU's f64 optimum, feasible.
#[test]
fn newton_with_a_gpu_per_rank_in_f32_reaches_the_optimum() {
    if !gpu_ranks_possible(Precision::F32) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let input = &meshes(dir.path())[0];
    let (one, two) = gpu_pair(dir.path(), input, "newton", "f32", 2, &[]);
    let cpu = smooth(None, input, dir.path(), "newton");
    let b = two.objective.last().unwrap();
    for (a, what) in [
        (one.objective.last().unwrap(), "one f32 process"),
        (cpu.objective.last().unwrap(), "the CPU"),
    ] {
        assert!((a - b).abs() <= 1e-5 * a.abs(), "F {b} on f32 GPU ranks, {a} on {what}");
    }
}

/// NLCG, a sliding boundary and a planar mesh on 2 GPU ranks in f64, each
/// against one GPU process: same iteration count, F at every iteration and
/// the iterate to 1e-9.
#[test]
fn nlcg_sliding_and_planar_with_a_gpu_per_rank_match_one_gpu_process() {
    if !gpu_ranks_possible(Precision::F64) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let all = meshes(dir.path());
    for (input, method, extra) in [
        (&all[2], "nlcg", &[][..]),
        (&all[0], "newton", &["--boundary", "slide"][..]),
        (&all[3], "newton", &[][..]),
    ] {
        let (one, two) = gpu_pair(dir.path(), input, method, "f64", 2, extra);
        let what = format!("{} {method} {extra:?}", input.display());
        assert_same_run(&one, &two, &what, 1e-9, 1e-9);
    }
}

/// Two runs with the same iteration count, F at every iteration within
/// `f_tol` (relative) and final iterates within `x_tol`.
fn assert_same_run(one: &Run, two: &Run, what: &str, f_tol: f64, x_tol: f64) {
    assert_eq!(two.objective.len(), one.objective.len(), "{what}: iteration count");
    for (k, (a, b)) in one.objective.iter().zip(&two.objective).enumerate() {
        assert!(
            (a - b).abs() <= f_tol * a.abs(),
            "{what}: F at iteration {k}: {a} vs {b}"
        );
    }
    let dx = max_rel(&one.points, &two.points);
    assert!(dx <= x_tol, "{what}: iterates differ by {dx:e}");
}

/// `input` written as `parts` .pvtu pieces (RCB, one process, no iteration):
/// the pieces carry `GlobalPointIds`; with `ids` false they are rewritten
/// without any id array, so the ranks must match points by coordinates.
fn pieces_of(input: &Path, parts: usize, ids: bool) -> PathBuf {
    let stem = input.file_stem().unwrap().to_string_lossy();
    let index = input.with_file_name(format!("{stem}-{parts}{}.pvtu", if ids { "" } else { "-noids" }));
    let o = Command::new(BIN)
        .arg("smooth")
        .arg(input)
        .arg("-o")
        .arg(&index)
        .args([
            "--pieces",
            &parts.to_string(),
            "--partitioner",
            "rcb",
            "--max-iter",
            "0",
            "--quiet",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    if !ids {
        for r in 0..parts {
            let path = meshsmooth::io::piece_path(&index, r);
            let mut piece = meshsmooth::io::read(&path).unwrap();
            piece.data.point.retain(|a| a.name != meshsmooth::io::GLOBAL_POINT_IDS);
            piece.data.cell.retain(|a| a.name != meshsmooth::io::GLOBAL_CELL_IDS);
            meshsmooth::io::write(&path, &piece, meshsmooth::io::Format::VtuAscii, &[]).unwrap();
        }
    }
    index
}

/// The largest part's vertex count and the mesh's, from the report's memory line.
fn part_and_whole(stdout: &str) -> (usize, usize) {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("mpi memory: largest part "))
        .unwrap_or_else(|| panic!("no memory line:\n{stdout}"));
    let numbers: Vec<usize> = line
        .split(|c: char| !c.is_ascii_digit())
        .filter_map(|w| w.parse().ok())
        .collect();
    (numbers[0], numbers[2])
}

/// `--partitioner pieces`: each rank sets up its part from the pieces it
/// read (3 pieces on 3 ranks, and on 2 ranks, rank 0 reading two), with its
/// own colouring and vertex order, and no rank holds the whole mesh. Newton
/// gives the single-process F at every iteration to 1e-10 with the same
/// iteration count; coloured BCD, whose colours differ from one process's,
/// the same optimum to 1e-8; both feasible, with the fixed vertices unmoved.
/// A tet box, a tet/prism/hex mesh and a triangle grid (z = 0), with global
/// ids in the pieces and without them (points matched by their coordinates).
#[test]
fn ranks_setting_up_their_own_parts_from_pieces_match_one_process() {
    let dir = tempfile::tempdir().unwrap();
    let all = meshes(dir.path());
    for input in [&all[0], &all[2], &all[3]] {
        for ids in [true, false] {
            let pvtu = pieces_of(input, 3, ids);
            let mesh = meshsmooth::io::read(&pvtu).unwrap();
            // BCD's colours take another path to the optimum: both runs stop
            // near enough to it for 1e-8 at 1e-9 (at the default 1e-6 the tet
            // box's stop 5e-7 apart; at 1e-8 the triangle grid's 1.8e-8)
            for (method, extra) in [("newton", &[][..]), ("bcd-colored", &["--tol", "1e-9"][..])] {
                let one = smooth_with(None, &pvtu, dir.path(), method, "metis", extra);
                assert!(one.objective.len() > 2, "{}: the plain run did nothing", pvtu.display());
                for ranks in [2, 3] {
                    let what = format!("{} {method} on {ranks} ranks", pvtu.display());
                    let many = smooth_with(Some(ranks), &pvtu, dir.path(), method, "pieces", extra);
                    assert!(
                        many.stdout.contains("no rank held the whole mesh"),
                        "{what}:\n{}",
                        many.stdout
                    );
                    let (largest, whole) = part_and_whole(&many.stdout);
                    assert_eq!(whole, mesh.num_points(), "{what}: the mesh's vertex count");
                    assert!(largest < whole, "{what}: a part of {largest} of {whole} vertices");
                    let (a, b) = (one.objective.last().unwrap(), many.objective.last().unwrap());
                    if method == "newton" {
                        assert_eq!(many.objective.len(), one.objective.len(), "{what}: iteration count");
                        for (k, (a, b)) in one.objective.iter().zip(&many.objective).enumerate() {
                            assert!(
                                (a - b).abs() <= 1e-10 * a.abs(),
                                "{what}: F at iteration {k}: {a} vs {b}"
                            );
                        }
                    } else {
                        assert!((a - b).abs() <= 1e-8 * a.abs(), "{what}: F {a} vs {b}");
                    }
                    let dx = max_rel(&one.points, &many.points);
                    assert!(dx <= 1e-8, "{what}: iterates differ by {dx:e}");
                    assert!(inverted_elements(&mesh, &many.points).is_empty(), "{what}: infeasible");
                    assert_fixed_unmoved(&mesh, &many.points, &what);
                }
            }
        }
    }
}

/// Parts set up on the ranks from pieces run on a GPU per rank too: Newton
/// in f64 on 2 ranks gives one GPU process's F at every iteration to 1e-10
/// with the same iteration count, feasible, fixed vertices unmoved.
#[test]
fn parts_set_up_on_the_ranks_run_on_a_gpu_per_rank() {
    if !gpu_ranks_possible(Precision::F64) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let input = &meshes(dir.path())[0];
    let pvtu = pieces_of(input, 2, true);
    let gpu = ["--device", "gpu", "--precision", "f64"];
    let one = smooth_with(None, &pvtu, dir.path(), "newton", "metis", &gpu);
    let two = smooth_with(Some(2), &pvtu, dir.path(), "newton", "pieces", &gpu);
    let what = format!("{} on 2 GPU ranks from pieces", pvtu.display());
    assert!(one.objective.len() > 2, "{what}: the plain run did nothing");
    assert!(
        two.stdout.contains("on mpi (2 ranks) x gpu") && two.stdout.contains("no rank held the whole mesh"),
        "{what}: not parts set up on GPU ranks:\n{}",
        two.stdout
    );
    assert_same_run(&one, &two, &what, 1e-10, 1e-8);
    let mesh = meshsmooth::io::read(&pvtu).unwrap();
    assert!(inverted_elements(&mesh, &two.points).is_empty(), "{what}: infeasible");
    assert_fixed_unmoved(&mesh, &two.points, &what);
}

/// The ranks write back the pieces they read (piece r by its reader) and
/// they read back as the mesh the same run gathers into one file; pieces VTK
/// wrote (no global ids, single-precision points, ghost cells) smooth to the
/// single-process F too. What cannot come from pieces is refused.
#[test]
fn pieces_set_up_on_the_ranks_are_written_back_by_them() {
    let dir = tempfile::tempdir().unwrap();
    let input = &meshes(dir.path())[0];
    let pvtu = pieces_of(input, 3, true);
    let run = |ranks: usize, from: &Path, to: &Path, extra: &[&str]| {
        let mut args: Vec<&std::ffi::OsStr> = vec![
            "smooth".as_ref(),
            from.as_os_str(),
            "-o".as_ref(),
            to.as_os_str(),
            "--device".as_ref(),
            "cpu".as_ref(),
            "--partitioner".as_ref(),
            "pieces".as_ref(),
        ];
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        mpirun(ranks, &args)
    };
    let out = dir.path().join("back.pvtu");
    let log = run(2, &pvtu, &out, &[]);
    assert!(log.contains("wrote 3 pieces"), "{log}");
    assert!(
        log.contains("pieces written by ranks 0, 0, 1; the index by rank 0"),
        "{log}"
    );
    let gathered = dir.path().join("back.vtu");
    run(2, &pvtu, &gathered, &[]);
    let back = meshsmooth::io::read(&out).unwrap();
    assert_eq!(back, meshsmooth::io::read(&gathered).unwrap());
    assert_ne!(
        back.points,
        meshsmooth::io::read(&pvtu).unwrap().points,
        "nothing moved"
    );

    let vtk = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/interop/pvtu/vtk_ghost1.pvtu");
    let one = smooth(None, &vtk, dir.path(), "newton");
    let many = smooth_by(Some(3), &vtk, dir.path(), "newton", "pieces");
    assert_eq!(many.objective.len(), one.objective.len(), "VTK pieces: iteration count");
    for (a, b) in one.objective.iter().zip(&many.objective) {
        assert!((a - b).abs() <= 1e-10 * a.abs(), "VTK pieces: F {a} vs {b}");
    }

    let refused = |ranks: usize, from: &Path, extra: &[&str], says: &str| {
        let o = Command::new("mpirun")
            .args([
                "--allow-run-as-root",
                "--oversubscribe",
                "-np",
                &ranks.to_string(),
                BIN,
                "smooth",
            ])
            .arg(from)
            .arg("-o")
            .arg(dir.path().join("refused.vtu"))
            .args(["--partitioner", "pieces"])
            .args(extra)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(says), "{extra:?}: {err}");
    };
    refused(2, input, &[], "give a .pvtu input");
    refused(2, &pvtu, &["--boundary", "slide"], "only the fixed boundary");
    refused(4, &pvtu, &[], "3 pieces for 4 ranks");
    // targets the parts cannot be given are refused, not smoothed away: a
    // boundary layer (the default would keep it) and input targets asked for
    let layer = dir.path().join("layer.vtu");
    let o = Command::new(BIN)
        .args([
            "generate",
            "boundary-layer",
            "--cells",
            "12",
            "--perturb",
            "random-shortest:0.2",
            "-o",
        ])
        .arg(&layer)
        .output()
        .unwrap();
    assert!(o.status.success());
    let layer_pieces = pieces_of(&layer, 2, true);
    refused(
        2,
        &layer_pieces,
        &[],
        "--partitioner pieces smooths toward the ideal targets only, and rank 0's part has stretched elements",
    );
    refused(2, &pvtu, &["--target", "input"], "and --target input was asked for");
    // the ideal target, asked for, runs
    let o = mpirun(
        2,
        &[
            "smooth".as_ref(),
            layer_pieces.as_os_str(),
            "-o".as_ref(),
            dir.path().join("ideal.vtu").as_os_str(),
            "--partitioner".as_ref(),
            "pieces".as_ref(),
            "--target".as_ref(),
            "ideal".as_ref(),
            "--device".as_ref(),
            "cpu".as_ref(),
        ],
    );
    assert!(o.contains("wrote"), "{o}");
}

/// A boundary layer gets the default's input targets on every rank, built
/// from the whole mesh: two ranks give the single-process answer (NLCG, whose
/// path on the layer is chaotic, the same optimum).
#[test]
fn input_targets_on_two_ranks_match_one_process() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("layer.vtu");
    let o = Command::new(BIN)
        .args([
            "generate",
            "boundary-layer",
            "--cells",
            "20",
            "--layers",
            "10",
            "--perturb",
            "random-shortest:0.3",
            "-o",
        ])
        .arg(&input)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mesh = meshsmooth::io::read(&input).unwrap();
    let mut optimum = f64::NAN;
    for method in ["newton", "bcd-colored"] {
        let one = smooth(None, &input, dir.path(), method);
        if method == "newton" {
            optimum = *one.objective.last().unwrap();
        }
        let two = smooth(Some(2), &input, dir.path(), method);
        for run in [&one, &two] {
            assert!(run.stdout.contains("targets: input"), "{method}: {}", run.stdout);
        }
        assert!(two.stdout.contains("mpi (2 ranks)"), "{method}: not partitioned");
        assert_eq!(two.objective.len(), one.objective.len(), "{method}: iteration count");
        let (a, b) = (one.objective.last().unwrap(), two.objective.last().unwrap());
        assert!((a - b).abs() <= 1e-8 * a.abs(), "{method}: F {a} vs {b}");
        let dx = max_rel(&one.points, &two.points);
        assert!(dx <= 1e-8, "{method}: iterates differ by {dx:e}");
        assert!(inverted_elements(&mesh, &two.points).is_empty());
    }
    // NLCG on this stretched layer is slow and its path is chaotic: the
    // ranks' sums in another order leave the single-process path after some
    // iterations (about 100 here) and both wander to the same optimum. So
    // the paths agree at first, and at the end the two differ by less than
    // their own distance from the optimum (Newton's F)
    let one = smooth(None, &input, dir.path(), "nlcg");
    let two = smooth(Some(2), &input, dir.path(), "nlcg");
    assert_eq!(two.objective.len(), one.objective.len(), "nlcg: iteration count");
    for (k, (a, b)) in one.objective.iter().zip(&two.objective).take(40).enumerate() {
        assert!((a - b).abs() <= 1e-9 * a.abs(), "nlcg iteration {k}: F {a} vs {b}");
    }
    let (a, b) = (*one.objective.last().unwrap(), *two.objective.last().unwrap());
    let gap = a.max(b) - optimum;
    eprintln!("nlcg: F {a} (one) and {b} (two ranks), Newton's optimum {optimum}");
    assert!(
        a >= optimum - 1e-10 && b >= optimum - 1e-10,
        "below the optimum: {a}, {b} vs {optimum}"
    );
    assert!((a - b).abs() <= gap, "nlcg: F {a} vs {b}, {gap:e} from the optimum");
    assert!(inverted_elements(&mesh, &two.points).is_empty());
}
