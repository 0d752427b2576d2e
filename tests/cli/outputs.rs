//! The command line's outputs: checked before any work, written all or
//! nothing, and the mesh on standard output with `-o -` or `-o /dev/stdout`.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common;
use common::cli::{generate_box, meshsmooth, s, text};

fn input(dir: &Path) -> std::path::PathBuf {
    let path = dir.join("in.vtk");
    generate_box(&path, [4, 4, 4], "random:0.3", 1);
    path
}

/// The names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn directory_output_is_refused_before_solving() {
    let dir = tempfile::tempdir().unwrap();
    let input = input(dir.path());
    let out_dir = dir.path().join("out");
    std::fs::create_dir(&out_dir).unwrap();
    let history = dir.path().join("h.csv");
    let before = listing(dir.path());
    let t = Instant::now();
    let o = meshsmooth(&[
        "smooth",
        s(&input),
        "-o",
        s(&out_dir),
        "--history",
        s(&history),
        "--max-iter",
        "100000",
    ]);
    let (elapsed, all) = (t.elapsed(), text(&o));
    assert_eq!(o.status.code(), Some(1), "{all}");
    assert!(
        all.contains(&format!("-o {} is a directory", out_dir.display())),
        "{all}"
    );
    // nothing was solved, nothing written
    assert!(!all.contains("initial mesh") && !all.contains("converged"), "{all}");
    assert!(elapsed < Duration::from_secs(10), "{elapsed:?}");
    assert_eq!(listing(dir.path()), before);
    assert!(listing(&out_dir).is_empty());

    // the same for compare's --csv, with its --plot given a good name
    let plot = dir.path().join("p.svg");
    let o = meshsmooth(&["compare", s(&input), "--csv", s(&out_dir), "--plot", s(&plot)]);
    let all = text(&o);
    assert_eq!(o.status.code(), Some(1), "{all}");
    assert!(
        all.contains(&format!("--csv {} is a directory", out_dir.display())),
        "{all}"
    );
    assert!(!plot.exists());
    assert_eq!(listing(dir.path()), before);
}

#[test]
fn history_in_a_missing_directory_leaves_no_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let input = input(dir.path());
    let output = dir.path().join("out.vtu");
    let history = dir.path().join("missing").join("h.csv");
    let before = listing(dir.path());
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&output), "--history", s(&history)]);
    let all = text(&o);
    assert_eq!(o.status.code(), Some(1), "{all}");
    assert!(all.contains("--history") && all.contains(s(&history)), "{all}");
    assert!(all.contains("does not exist"), "{all}");
    assert!(!output.exists());
    assert_eq!(listing(dir.path()), before);
}

#[test]
fn history_equal_to_the_input_is_refused_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let input = input(dir.path());
    let original = std::fs::read(&input).unwrap();
    let output = dir.path().join("out.vtk");
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&output), "--history", s(&input)]);
    let all = text(&o);
    assert_eq!(o.status.code(), Some(1), "{all}");
    assert!(
        all.contains(&format!("--history {} is the input mesh", input.display())),
        "{all}"
    );
    assert!(!all.contains("output "), "{all}");
    assert_eq!(std::fs::read(&input).unwrap(), original);
    assert!(!output.exists());

    // and two outputs on one file
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&output), "--history", s(&output)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("is also the file of -o"), "{}", text(&o));
    assert!(!output.exists());
}

/// Runs the binary with its standard output a pipe, returning what came
/// through the pipe and what went to standard error.
fn piped(args: &[&str]) -> (bool, Vec<u8>, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_meshsmooth"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .output()
        .expect("runs");
    (
        o.status.success(),
        o.stdout,
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn mesh_to_stdout_with_dash() {
    let dir = tempfile::tempdir().unwrap();
    let input = input(dir.path());
    let points = meshsmooth::io::read(&input).unwrap().num_points();
    let (ok, mesh, err) = piped(&["smooth", s(&input), "-o", "-", "--format", "vtu"]);
    assert!(ok, "{err}");
    // the mesh alone on stdout, the reports on stderr
    assert!(
        mesh.starts_with(b"<?xml"),
        "{}",
        String::from_utf8_lossy(&mesh[..mesh.len().min(200)])
    );
    assert!(
        err.contains("  before ") && err.contains("wrote the mesh to standard output"),
        "{err}"
    );
    let back = dir.path().join("back.vtu");
    std::fs::write(&back, &mesh).unwrap();
    let read = meshsmooth::io::read(&back).unwrap();
    assert_eq!(read.num_points(), points);
    let o = meshsmooth(&["quality", s(&back)]);
    assert!(o.status.success(), "{}", text(&o));
    // only the input and the copy read back: nothing named "-"
    assert_eq!(listing(dir.path()), ["back.vtu", "in.vtk"]);

    // without --format, standard output has no extension to go by
    let (ok, mesh, err) = piped(&["smooth", s(&input), "-o", "-"]);
    assert!(!ok && mesh.is_empty());
    assert!(err.contains("--format"), "{err}");
}

#[test]
fn mesh_to_dev_stdout_into_a_pipe() {
    let dir = tempfile::tempdir().unwrap();
    let input = input(dir.path());
    let points = meshsmooth::io::read(&input).unwrap().num_points();
    let history = dir.path().join("h.csv");
    let (ok, mesh, err) = piped(&[
        "smooth",
        s(&input),
        "-o",
        "/dev/stdout",
        "--format",
        "vtk",
        "--history",
        s(&history),
    ]);
    assert!(ok, "{err}");
    assert!(mesh.starts_with(b"# vtk DataFile"), "{err}");
    assert!(err.contains("  after "), "{err}");
    let back = dir.path().join("back.vtk");
    std::fs::write(&back, &mesh).unwrap();
    assert_eq!(meshsmooth::io::read(&back).unwrap().num_points(), points);
    assert!(std::fs::read_to_string(&history).unwrap().starts_with("iteration,"));

    // generate too
    let (ok, mesh, err) = piped(&[
        "generate",
        "box",
        "--cells",
        "2",
        "2",
        "2",
        "-o",
        "/dev/stdout",
        "--format",
        "msh4",
    ]);
    assert!(ok, "{err}");
    assert!(mesh.starts_with(b"$MeshFormat"), "{err}");
    assert!(err.contains("wrote the mesh to standard output"), "{err}");
}

#[test]
fn an_output_keeps_the_encoding_of_its_input() {
    use meshsmooth::io::{self, Format};
    let dir = tempfile::tempdir().unwrap();
    let mesh = io::read(input(dir.path())).unwrap();
    // every format is recognised in the file it was written as
    // the surface formats hold no volumes: `surface_formats` covers them
    for f in Format::ALL.into_iter().filter(|f| !f.is_surface_only()) {
        let ext = match f {
            Format::VtkAscii | Format::VtkBinary => "vtk",
            Format::VtuAscii | Format::VtuBinary | Format::VtuZlib => "vtu",
            Format::Medit => "mesh",
            Format::Abaqus => "inp",
            Format::Exodus => "exo",
            Format::VtkHdf => "vtkhdf",
            // a case folder
            Format::OpenFoam | Format::OpenFoamBinary => "",
            _ => "msh",
        };
        let path = dir.path().join(format!("as-{}.{ext}", f.name()).trim_end_matches('.'));
        io::write(&path, &mesh, f, &[]).unwrap();
        assert_eq!(Format::of_file(&path), Some(f), "{}", f.name());
    }
    // smooth without --format: the output's family from its name, the
    // encoding (and Gmsh version) from the input
    let cases = [
        (Format::VtuBinary, "vtu", Format::VtuBinary),
        (Format::VtuZlib, "vtu", Format::VtuZlib),
        (Format::VtuAscii, "vtu", Format::VtuAscii),
        (Format::VtkBinary, "vtu", Format::VtuBinary),
        (Format::VtuZlib, "vtk", Format::VtkBinary),
        (Format::VtkAscii, "vtk", Format::VtkAscii),
        (Format::Msh22Binary, "msh", Format::Msh22Binary),
        (Format::Msh22Ascii, "msh", Format::Msh22Ascii),
        (Format::Msh41Binary, "msh", Format::Msh41Binary),
        (Format::VtuBinary, "msh", Format::Msh41Binary),
        (Format::VtuAscii, "msh", Format::Msh41Ascii),
        (Format::Msh41Binary, "mesh", Format::Medit),
    ];
    for (k, (from, ext, expected)) in cases.into_iter().enumerate() {
        let inp = dir.path().join(format!(
            "in{k}.{}",
            if from.name().starts_with("msh") {
                "msh"
            } else if from.name().starts_with("vtu") {
                "vtu"
            } else {
                "vtk"
            }
        ));
        io::write(&inp, &mesh, from, &[]).unwrap();
        let out = dir.path().join(format!("out{k}.{ext}"));
        let o = meshsmooth(&["smooth", s(&inp), "-o", s(&out), "--max-iter", "2"]);
        assert!(o.status.success(), "{}", text(&o));
        assert_eq!(Format::of_file(&out), Some(expected), "{} -> .{ext}", from.name());
    }
    // --format still decides
    let inp = dir.path().join("in-binary.vtu");
    io::write(&inp, &mesh, Format::VtuBinary, &[]).unwrap();
    let out = dir.path().join("asked.vtu");
    let o = meshsmooth(&["smooth", s(&inp), "-o", s(&out), "--max-iter", "2", "--format", "vtu"]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(Format::of_file(&out), Some(Format::VtuAscii));
}

#[cfg(unix)]
#[test]
fn a_mesh_read_from_a_pipe_is_read_once() {
    use meshsmooth::io::{self, Format};
    // the output's encoding is not looked for in a pipe: its bytes are the
    // reader's, and a second open would wait for a writer that is gone
    let dir = tempfile::tempdir().unwrap();
    let mesh = io::read(input(dir.path())).unwrap();
    let file = dir.path().join("binary.vtu");
    io::write(&file, &mesh, Format::VtuBinary, &[]).unwrap();
    let bytes = std::fs::read(&file).unwrap();
    let fifo = dir.path().join("pipe.vtu");
    common::fifo(&fifo);
    let writer = {
        let fifo = fifo.clone();
        std::thread::spawn(move || {
            use std::io::Write;
            let mut f = std::fs::OpenOptions::new().write(true).open(&fifo).unwrap();
            let _ = f.write_all(&bytes);
        })
    };
    let out = dir.path().join("out.vtu");
    let mut child = Command::new(env!("CARGO_BIN_EXE_meshsmooth"))
        .args(["smooth", s(&fifo), "-o", s(&out), "--max-iter", "2"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > Duration::from_secs(30) {
            child.kill().unwrap();
            panic!("smooth of a pipe did not finish");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    writer.join().unwrap();
    assert!(status.success());
    assert_eq!(io::read(&out).unwrap().num_points(), mesh.num_points());
    // its encoding unknown, the output takes the extension's default
    assert_eq!(Format::of_file(&out), Some(Format::VtuAscii));
    assert_eq!(Format::of_file(&fifo), None);
}
