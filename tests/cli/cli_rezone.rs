//! `meshsmooth rezone` end to end: outputs, section 6's table, bad input.

use meshsmooth::io;
use meshsmooth::metric::inverted_elements;
use std::path::Path;

use crate::common;
use common::cli::{meshsmooth, s, text};

fn hex_box(dir: &Path) -> std::path::PathBuf {
    let input = dir.join("box.vtk");
    let o = meshsmooth(&[
        "generate",
        "box",
        "--type",
        "hex",
        "--cells",
        "5",
        "5",
        "5",
        "--perturb",
        "random:0.35",
        "-o",
        s(&input),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    input
}

#[test]
fn rezone_writes_both_meshes_and_prints_original_rj_and_cn_columns() {
    let dir = tempfile::tempdir().unwrap();
    let input = hex_box(dir.path());
    let (rj, cn) = (dir.path().join("rj.vtu"), dir.path().join("cn.vtk"));
    let o = meshsmooth(&[
        "rezone",
        s(&input),
        "-o",
        s(&rj),
        "--compare-cn",
        s(&cn),
        "--device",
        "cpu",
        "-q",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let out = text(&o);
    for want in [
        "original",
        "RJ",
        "CN",
        "1.00 - 1.25",
        "17.00 - inf",
        "node displacement",
    ] {
        assert!(out.contains(want), "missing {want:?} in\n{out}");
    }
    let before = io::read(&input).unwrap();
    for path in [&rj, &cn] {
        let m = io::read(path).unwrap();
        assert_eq!(m.num_elements(), before.num_elements());
        assert!(inverted_elements(&m, &m.points).is_empty(), "{}", path.display());
        assert_ne!(m.points, before.points, "{} did not move", path.display());
    }
}

#[test]
fn rezone_refuses_bad_input_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let input = hex_box(dir.path());
    let out = dir.path().join("out.vtk");
    // the input is never overwritten
    let o = meshsmooth(&["rezone", s(&input), "-o", s(&input), "--device", "cpu"]);
    assert!(!o.status.success());
    assert!(text(&o).contains("never overwrites its input"), "{}", text(&o));
    // the CN mesh needs its own file
    let o = meshsmooth(&[
        "rezone",
        s(&input),
        "-o",
        s(&out),
        "--compare-cn",
        s(&out),
        "--device",
        "cpu",
    ]);
    assert!(!o.status.success());
    assert!(text(&o).contains("--compare-cn"), "{}", text(&o));
    assert!(!out.exists());
    // planar meshes are refused with the file named
    let quad = dir.path().join("quad.vtk");
    let o = meshsmooth(&[
        "generate",
        "grid",
        "--type",
        "quad",
        "--cells",
        "4",
        "4",
        "-o",
        s(&quad),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let o = meshsmooth(&["rezone", s(&quad), "-o", s(&out), "--device", "cpu"]);
    assert!(!o.status.success());
    let msg = text(&o);
    assert!(msg.contains("quad.vtk") && msg.contains("planar"), "{msg}");
    assert!(!out.exists());
    // an inverted element is named (the writer refuses them: the file by hand)
    let bad = dir.path().join("bad.vtk");
    std::fs::write(
        &bad,
        "# vtk DataFile Version 3.0\ninverted\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n\
         0 0 0\n1 0 0\n0 1 0\n0 0 -1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n",
    )
    .unwrap();
    let o = meshsmooth(&["rezone", s(&bad), "-o", s(&out), "--device", "cpu"]);
    assert!(!o.status.success());
    let msg = text(&o);
    assert!(msg.contains("bad.vtk") && msg.contains("invert"), "{msg}");
    assert!(!out.exists());
}
