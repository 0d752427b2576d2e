//! The command-line tool end to end: exit codes, outputs, and that bad input
//! leaves nothing behind.

use std::path::Path;

use crate::common;
use common::cli::{generate_box, meshsmooth, s, text};

/// The rows of a `--history` CSV.
fn history_rows(path: &Path) -> Vec<Vec<f64>> {
    let csv = std::fs::read_to_string(path).unwrap();
    assert_eq!(csv.lines().next().unwrap(), "iteration,seconds,objective,grad_norm");
    csv.lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

#[test]
fn demo_runs_without_arguments() {
    let o = meshsmooth(&["demo", "--cells", "6"]);
    assert!(o.status.success(), "{}", text(&o));
    let out = text(&o);
    assert!(out.contains("  before ") && out.contains("  after "), "{out}");
    assert!(out.contains("converged"), "{out}");
    let o = meshsmooth(&["demo", "--cells", "6", "-v"]);
    let out = text(&o);
    assert!(out.contains("initial mesh") && out.contains("optimised mesh"), "{out}");
}

#[test]
fn generate_smooth_and_quality_work_together() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("box.vtk");
    let output = dir.path().join("box-smooth.vtu");
    let history = dir.path().join("history.csv");
    generate_box(&input, [6, 5, 4], "random:0.3", 3);
    let original = std::fs::read(&input).unwrap();

    let o = meshsmooth(&[
        "smooth",
        s(&input),
        "-o",
        s(&output),
        "--history",
        s(&history),
        "--max-iter",
        "500",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(std::fs::read(&input).unwrap(), original, "input modified");
    let rows = history_rows(&history);
    assert!(rows.len() > 2);
    for w in rows.windows(2) {
        assert_eq!(w[1][0], w[0][0] + 1.0);
        assert!(w[1][2] <= w[0][2], "objective rose");
    }
    assert!(rows.last().unwrap()[3] < 1e-6, "did not converge: {:?}", rows.last());

    let o = meshsmooth(&["quality", s(&output), "--json"]);
    assert!(o.status.success(), "{}", text(&o));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let f = json["objective"].as_f64().unwrap();
    assert!(
        (f - rows.last().unwrap()[2]).abs() < 1e-9 * f,
        "report {f} vs history {:?}",
        rows.last()
    );
    assert_eq!(json["inverted"].as_u64(), Some(0));
    assert_eq!(json["elements"].as_u64(), Some(6 * 5 * 4 * 6));
}

#[test]
fn laplace_colored_and_nlcg_methods_run() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("box.msh");
    generate_box(&input, [4, 4, 4], "random:0.3", 1);
    for method in ["laplace", "bcd-colored", "nlcg"] {
        let out = dir.path().join(format!("{method}.mesh"));
        let o = meshsmooth(&["smooth", s(&input), "-o", s(&out), "--method", method, "--quiet"]);
        assert!(o.status.success(), "{method}: {}", text(&o));
        assert!(text(&o).contains(method));
        assert!(out.exists());
    }
}

#[test]
fn nlcg_stops_on_tol_x_and_refuses_a_negative_one() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("box.vtk");
    generate_box(&input, [4, 4, 4], "random:0.3", 2);
    let out = dir.path().join("out.vtk");
    let run = |tol_x: &str| {
        let tol_x = format!("--tol-x={tol_x}");
        meshsmooth(&[
            "smooth",
            s(&input),
            "-o",
            s(&out),
            "--method",
            "nlcg",
            "--tol",
            "1e-12",
            &tol_x,
            "--quiet",
        ])
    };
    let o = run("1e-3");
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("step below tolerance"), "{}", text(&o));
    std::fs::remove_file(&out).unwrap();
    let o = run("-1");
    assert!(!o.status.success());
    assert!(text(&o).contains("--tol-x"), "{}", text(&o));
    assert!(!out.exists());
}

#[test]
fn refuses_to_overwrite_its_input() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("box.vtk");
    generate_box(&input, [3, 3, 3], "random:0.2", 1);
    let original = std::fs::read(&input).unwrap();
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&input)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("never overwrites its input"), "{}", text(&o));
    assert_eq!(std::fs::read(&input).unwrap(), original);
}

#[test]
fn bad_inputs_fail_cleanly_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.vtk");
    let missing = dir.path().join("missing.vtk");
    let o = meshsmooth(&["smooth", s(&missing), "-o", s(&out)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("missing.vtk"), "{}", text(&o));
    assert!(!out.exists());

    // a tangled mesh: one vertex pulled through the opposite face
    let tangled = dir.path().join("tangled.vtk");
    std::fs::write(
        &tangled,
        "# vtk DataFile Version 3.0\ntangled\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 5 double\n\
         0 0 0\n1 0 0\n0 1 0\n0 0 1\n-1 -1 -1\nCELLS 2 10\n4 0 1 2 3\n4 0 1 2 4\nCELL_TYPES 2\n10\n10\n",
    )
    .unwrap();
    let o = meshsmooth(&["smooth", s(&tangled), "-o", s(&out)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("inverted"), "{}", text(&o));
    assert!(!out.exists());

    let o = meshsmooth(&[
        "generate",
        "box",
        "--cells",
        "2",
        "2",
        "2",
        "--perturb",
        "wobble:1",
        "-o",
        s(&out),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(!out.exists());

    let o = meshsmooth(&["smooth", s(&tangled), "-o", s(&dir.path().join("out.xyz"))]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("xyz"), "{}", text(&o));

    let o = meshsmooth(&["smooth", "--max-iter", "x"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        std::fs::read_dir(dir.path()).unwrap().count() == 1,
        "only the tangled input remains"
    );
}

#[test]
fn devices_lists_adapters_and_gpu_smoothing_names_the_device() {
    let o = meshsmooth(&["devices"]);
    assert!(o.status.success(), "{}", text(&o));
    let listing = text(&o);
    if listing.contains("no GPU adapters") {
        assert!(std::env::var_os("CI").is_none(), "CI must provide lavapipe: {listing}");
        common::skipped("no GPU adapter (set CI to make this fail)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("box.vtk");
    let out = dir.path().join("out.vtk");
    generate_box(&input, [4, 4, 4], "random:0.3", 1);
    let o = meshsmooth(&[
        "smooth",
        s(&input),
        "-o",
        s(&out),
        "--device",
        "gpu",
        "--precision",
        "f64",
        "-q",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("on gpu") && text(&o).contains("(f64)"),
        "{}",
        text(&o)
    );
    assert!(text(&o).contains("converged"), "{}", text(&o));

    let gpu = |extra: &[&str]| {
        let mut args = vec!["smooth", s(&input), "-o", s(&out), "--device", "gpu"];
        args.extend_from_slice(extra);
        meshsmooth(&args)
    };
    let o = gpu(&["--method", "newton", "-q"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("newton on gpu"), "{}", text(&o));
    let o = gpu(&["--method", "laplace"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("CPU only"), "{}", text(&o));
    let o = gpu(&["--metric", "cn", "--method", "newton", "-q"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("newton on gpu") && text(&o).contains("converged"),
        "{}",
        text(&o)
    );
    let o = meshsmooth(&[
        "smooth",
        s(&input),
        "-o",
        s(&out),
        "--device",
        "gpu",
        "--adapter",
        "no-such-gpu",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("no-such-gpu"), "{}", text(&o));
}

#[test]
fn compare_reports_both_methods_and_writes_csv_and_svg() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("box.vtk");
    generate_box(&input, [6, 6, 6], "random:0.3", 1);
    let (csv, svg) = (dir.path().join("h.csv"), dir.path().join("h.svg"));
    let o = meshsmooth(&["compare", s(&input), "--csv", s(&csv), "--plot", s(&svg)]);
    assert!(o.status.success(), "{}", text(&o));
    let out = text(&o);
    for needle in ["T50", "T100", "bcd ", "newton ", "paper est."] {
        assert!(out.contains(needle), "missing {needle}: {out}");
    }
    let rows = std::fs::read_to_string(&csv).unwrap();
    assert!(rows.lines().any(|l| l.starts_with("bcd,")) && rows.lines().any(|l| l.starts_with("newton,")));
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<polyline"));
    let o = meshsmooth(&["compare", s(&input), "--json", "--methods", "newton,bcd-colored"]);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["runs"].as_array().unwrap().len(), 2);
    // an unknown method is a usage error, named
    let o = meshsmooth(&["compare", s(&input), "--methods", "bcd,nonsense"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("nonsense"), "{}", text(&o));
}

#[test]
fn smooth_converges_on_the_perturbed_20_box_keeping_the_boundary() {
    // interior vertices moved by 0.3 of the cell size: random:ALPHA is in units of the
    // mean edge length at a vertex, 1.282 cells in a Kuhn box, so ALPHA = 0.3 / 1.282
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("box.vtk");
    let output = dir.path().join("out.vtk");
    let history = dir.path().join("h.csv");
    generate_box(&input, [20, 20, 20], "random:0.234", 5);
    let o = meshsmooth(&[
        "smooth",
        s(&input),
        "-o",
        s(&output),
        "--history",
        s(&history),
        "-q",
        "--device",
        "cpu",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let rows = history_rows(&history);
    assert!(rows.last().unwrap()[3] < 1e-6, "{:?}", rows.last());
    for w in rows.windows(2) {
        assert!(w[1][2] <= w[0][2], "objective rose: {:?} -> {:?}", w[0], w[1]);
    }
    let before = meshsmooth::io::read(&input).unwrap();
    let after = meshsmooth::io::read(&output).unwrap();
    assert_eq!(after.num_elements(), 48_000);
    assert!(meshsmooth::metric::inverted_elements(&after, &after.points).is_empty());
    let skin = meshsmooth::mesh::topology::skin_vertices(&before);
    let mut moved = 0;
    for v in 0..before.num_points() {
        if skin[v] {
            assert_eq!(before.points[v], after.points[v], "boundary vertex {v} moved");
        } else if before.points[v] != after.points[v] {
            moved += 1;
        }
    }
    assert!(moved > 6000, "only {moved} interior vertices moved");
}

/// The library quotes the partitioner by its settings key; the command line
/// names the flag.
#[cfg(not(feature = "mpi"))]
#[test]
fn partitioner_refusals_name_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("box.vtk");
    let out = dir.path().join("out.pvtu");
    generate_box(&input, [3, 3, 3], "random:0.1", 1);
    let smooth = |partitioner: &str| {
        meshsmooth(&[
            "smooth",
            s(&input),
            "-o",
            s(&out),
            "--device",
            "cpu",
            "--partitioner",
            partitioner,
            "-q",
        ])
    };
    let o = smooth("pieces");
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("error: unsupported: --partitioner pieces takes the parts from a .pvtu input's pieces"),
        "{}",
        text(&o)
    );
    if !cfg!(feature = "metis") {
        let o = smooth("metis");
        assert_eq!(o.status.code(), Some(1), "{}", text(&o));
        assert!(
            text(&o).contains("error: unsupported: --partitioner metis: this build has no METIS"),
            "{}",
            text(&o)
        );
    }
}

/// `quality --before` measures the smoothed mesh against the targets built
/// from the mesh before smoothing: its shape+size average is the objective
/// smoothing reached, and the first-layer change is the one `smooth` printed.
#[test]
fn quality_measures_a_smoothed_layer_against_the_targets_it_was_smoothed_toward() {
    let dir = tempfile::tempdir().unwrap();
    let (input, output, history) = (
        dir.path().join("layer.vtk"),
        dir.path().join("smooth.vtk"),
        dir.path().join("h.csv"),
    );
    let o = meshsmooth(&[
        "generate",
        "boundary-layer",
        "--perturb",
        "random-shortest:0.3",
        "-o",
        s(&input),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&output), "--history", s(&history)]);
    assert!(o.status.success(), "{}", text(&o));
    let smoothed = text(&o);
    let layer_line = smoothed
        .lines()
        .find(|l| l.starts_with("first-layer height"))
        .expect("smooth reports the first layer")
        .to_string();
    let f = history_rows(&history).last().unwrap()[2];

    let o = meshsmooth(&["quality", s(&output), "--before", s(&input), "--json"]);
    assert!(o.status.success(), "{}", text(&o));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let t = &json["targets"];
    assert_eq!(t["target"], "input");
    let avg = t["shape_size"]["avg"].as_f64().unwrap();
    assert!((avg - f).abs() < 1e-9 * f, "quality {avg} vs the smoothing's F {f}");
    assert!(t["shape"]["avg"].as_f64().unwrap() >= 1.0);
    // the before mesh is farther from its targets than the smoothed one
    let o = meshsmooth(&["quality", s(&input), "--json"]);
    let own: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(own["targets"]["shape_size"]["avg"].as_f64().unwrap() > avg + 0.1);
    assert!(own["targets"]["first_layer"].is_null());
    let o = meshsmooth(&["quality", s(&output), "--before", s(&input)]);
    assert!(text(&o).contains(&layer_line), "{}\nvs {layer_line}", text(&o));
    // the ideal target has nothing to add to the plain report
    let o = meshsmooth(&["quality", s(&output), "--target", "ideal", "--json"]);
    let plain: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(plain.get("targets").is_none());
    // a before mesh of other connectivity is refused by name
    let other = dir.path().join("box.vtk");
    generate_box(&other, [2, 2, 2], "random:0.1", 1);
    let o = meshsmooth(&["quality", s(&output), "--before", s(&other)]);
    assert!(!o.status.success());
    assert!(text(&o).contains("does not have the connectivity"), "{}", text(&o));
}

#[test]
fn smooth_says_where_its_time_went() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.vtu");
    generate_box(&input, [5, 5, 5], "random:0.3", 1);
    let out = dir.path().join("out.vtu");
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&out)]);
    assert!(o.status.success(), "{}", text(&o));
    let all = text(&o);
    let line = all
        .lines()
        .find(|l| l.starts_with("time: "))
        .unwrap_or_else(|| panic!("{all}"));
    // "time: read R s, setup S s, solve T s, write W s, other O s; A s in all"
    let numbers: Vec<f64> = line
        .split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .filter(|t| !t.is_empty() && t.contains('.'))
        .map(|t| t.parse().unwrap())
        .collect();
    assert_eq!(numbers.len(), 6, "{line}");
    let (parts, total) = (&numbers[..5], numbers[5]);
    assert!(parts.iter().all(|&x| x >= 0.0), "{line}");
    // the parts are disjoint pieces that make up the whole (to the printed rounding)
    assert!((parts.iter().sum::<f64>() - total).abs() <= 0.005, "{line}");
    assert!(numbers[2] > 0.0 && total > 0.0, "{line}");
    // and the solve's own line reports the same solve time
    let solve = all.lines().find(|l| l.contains(" s (setup ")).unwrap();
    assert!(
        solve.contains(&format!("in {:.3} s (setup {:.3} s)", numbers[2], numbers[1])),
        "{solve}\n{line}"
    );
}

#[test]
fn a_sheet_that_is_not_flat_is_smoothed_as_a_surface() {
    // a triangle grid bent out of its plane is a surface: each triangle is
    // measured in its own plane (none reads as inverted, as a projection's
    // would), its vertices slide on it and its rim stays
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bent.vtk");
    let mut mesh = meshsmooth::generate::tri_grid(6, 6, [1.0, 1.0]);
    for (i, p) in mesh.points.iter_mut().enumerate() {
        if p[0] > 0.0 && p[0] < 1.0 && p[1] > 0.0 && p[1] < 1.0 {
            p[0] += 0.04 * ((i * 7 % 5) as f64 - 2.0);
        }
    }
    for p in &mut mesh.points {
        p[2] = 0.3 * (3.0 * p[0]).sin() * p[1];
    }
    meshsmooth::io::write(&path, &mesh, meshsmooth::io::Format::VtkAscii, &[]).unwrap();
    let out = dir.path().join("out.vtk");
    let o = meshsmooth(&["quality", s(&path)]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("surface mesh"), "{}", text(&o));
    let o = meshsmooth(&["smooth", s(&path), "-o", s(&out)]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("surface mesh") && !t.contains("tangled"), "{t}");
    let before: Vec<&str> = t.lines().filter(|l| l.trim_start().starts_with("before")).collect();
    let after: Vec<&str> = t.lines().filter(|l| l.trim_start().starts_with("after")).collect();
    let cols = |l: &str| -> Vec<f64> { l.split_whitespace().skip(1).map(|w| w.parse().unwrap()).collect() };
    let (b, a) = (cols(before[0]), cols(after[0]));
    assert!(a[0] < b[0] && b[3] == 0.0 && a[3] == 0.0, "{t}");
    let smoothed = meshsmooth::io::read(&out).unwrap();
    let rim = meshsmooth::mesh::topology::skin_vertices(&mesh);
    for v in 0..mesh.num_points() {
        if rim[v] {
            assert_eq!(smoothed.points[v], mesh.points[v], "rim vertex {v} moved");
        }
    }
    // nothing to untangle on a surface whose triangles all face their own way
    let o = meshsmooth(&["untangle", s(&path), "-o", s(&dir.path().join("u.vtk"))]);
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn a_default_run_names_no_device_nobody_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.vtk");
    generate_box(&input, [3, 3, 3], "random:0.3", 2);
    let out = dir.path().join("out.vtk");
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&out)]);
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    // the device is in the summary line; a CPU run says nothing more of GPUs
    if t.contains(" on cpu") {
        assert!(!t.contains("GPU") && !t.contains("adapter"), "{t}");
        // asking for f32 that the CPU does not give is worth a line
        let o = meshsmooth(&["smooth", s(&input), "-o", s(&out), "--precision", "f32"]);
        assert!(o.status.success(), "{}", text(&o));
        assert!(text(&o).contains("f64, not the f32 asked for"), "{}", text(&o));
    }
}

#[test]
fn a_default_smooth_fits_a_screen_explains_its_numbers_and_why_vertices_are_fixed() {
    use meshsmooth::mesh::{DataArray, ValueType, Values};
    // 10,368 tetrahedra; 5 inner vertices fixed by the file, 3 by a --fixed-array
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.vtu");
    let mut mesh = meshsmooth::generate::tet_box(12, 12, 12, [12.0; 3]);
    let opts = meshsmooth::generate::PerturbOptions {
        perturbation: meshsmooth::generate::Perturbation::Random { alpha: 0.3 },
        fraction: 1.0,
        seed: 5,
    };
    meshsmooth::generate::perturb(&mut mesh, &opts).unwrap();
    let skin = meshsmooth::mesh::topology::skin_vertices(&mesh);
    let inner: Vec<usize> = (0..mesh.num_points()).filter(|&v| !skin[v]).collect();
    let skin_count = skin.iter().filter(|&&b| b).count();
    mesh.fixed = vec![false; mesh.num_points()];
    for &v in &inner[..5] {
        mesh.fixed[v] = true;
    }
    let mut pin = vec![0.0; mesh.num_points()];
    for &v in &inner[100..103] {
        pin[v] = 1.0;
    }
    mesh.data
        .point
        .push(DataArray::new("pin", ValueType::F64, 1, Values::Float(pin)));
    meshsmooth::io::write(&input, &mesh, meshsmooth::io::Format::VtuBinary, &[]).unwrap();
    let out = dir.path().join("out.vtu");
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&out), "--fixed-array", "pin"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.lines().count() <= 20, "{} lines:\n{t}", t.lines().count());
    let why = format!(
        "fixed {} of {} vertices: {skin_count} on the boundary",
        skin_count + 8,
        mesh.num_points()
    );
    assert!(t.contains(&why), "{why}\n{t}");
    assert!(t.contains("5 inside, marked fixed in the file"), "{t}");
    assert!(
        t.contains("3 inside, by the options below") && t.contains("pin: 3 vertices"),
        "{t}"
    );
    assert!(t.contains("1 for the ideal shape, higher is worse"), "{t}");
    // the rows: mean, median, worst, inverted; smoothing lowered the mean and the worst
    let row = |name: &str| -> Vec<f64> {
        let line = t.lines().find(|l| l.trim_start().starts_with(name)).unwrap();
        line.split_whitespace().skip(1).map(|v| v.parse().unwrap()).collect()
    };
    let (before, after) = (row("before "), row("after "));
    assert!(after[0] < before[0] && after[2] < before[2], "{t}");
    assert_eq!((before[3], after[3]), (0.0, 0.0), "{t}");
    let smoothed = meshsmooth::io::read(&out).unwrap();
    let report = meshsmooth::report::quality_report(&smoothed, &smoothed.points);
    assert!((report.eta.avg - after[0]).abs() < 1e-4, "{t}");

    let o = meshsmooth(&["smooth", s(&input), "-o", s(&out), "--fixed-array", "pin", "-v"]);
    let full = text(&o);
    assert!(
        full.contains("eta histogram") && full.contains("CG iterations"),
        "{full}"
    );
    assert!(full.lines().count() > 40, "{full}");
}
