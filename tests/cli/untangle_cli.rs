//! `meshsmooth untangle` and `smooth` on tangled inputs, end to end.

use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::io::{self, Format};
use meshsmooth::metric::inverted_elements;
use std::path::Path;

use crate::common;
use common::cli::{meshsmooth, s, text};

/// A tangled tet box written (unchecked: it is inverted) to `path`.
fn tangled_box(path: &Path) -> usize {
    let mut m = generate::tet_box(4, 4, 4, [4.0; 3]);
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: 0.6 },
        fraction: 1.0,
        seed: 11,
    };
    generate::perturb_unguarded(&mut m, &opts).unwrap();
    let bad = inverted_elements(&m, &m.points).len();
    assert!(bad > 0);
    io::write(path, &m, Format::VtkAscii, &[]).unwrap();
    bad
}

#[test]
fn smooth_untangles_a_tangled_input_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let (input, out) = (dir.path().join("t.vtk"), dir.path().join("o.vtk"));
    let bad = tangled_box(&input);
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&out), "--device", "cpu"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains(&format!("the input is tangled ({bad} inverted element(s))")),
        "{t}"
    );
    assert!(t.contains("untangled") && t.contains("inverted corner(s)"), "{t}");
    // the quality before and after: the inverted count (last column), then none
    assert_eq!(quality_row(&t, "before").last(), Some(&bad.to_string()), "{t}");
    assert_eq!(quality_row(&t, "after").last().map(String::as_str), Some("0"), "{t}");
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&out), "--device", "cpu", "-v"]);
    let t = text(&o);
    let (before, after) = t.split_once("== optimised mesh ==").expect("both reports");
    assert!(before.contains(&format!("inverted elements: {bad} ")), "{before}");
    assert!(after.contains("(inverted elements: 0)"), "{after}");
    let m = io::read(&out).unwrap();
    assert!(inverted_elements(&m, &m.points).is_empty());
}

#[test]
fn no_untangle_refuses_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (input, out) = (dir.path().join("t.vtk"), dir.path().join("o.vtk"));
    let bad = tangled_box(&input);
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&out), "--device", "cpu", "--no-untangle"]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(
        t.contains(&format!("mesh has {bad} inverted")) && t.contains("t.vtk"),
        "{t}"
    );
    assert!(!out.exists());
}

#[test]
fn untangle_command_writes_an_untangled_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let (input, out) = (dir.path().join("t.vtk"), dir.path().join("u.vtk"));
    tangled_box(&input);
    let o = meshsmooth(&["untangle", s(&input), "-o", s(&out), "--device", "cpu"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert_eq!(quality_row(&t, "after").last().map(String::as_str), Some("0"), "{t}");
    let o = meshsmooth(&["untangle", s(&input), "-o", s(&out), "--device", "cpu", "-v"]);
    assert!(text(&o).contains("== untangled mesh =="), "{}", text(&o));
    let m = io::read(&out).unwrap();
    assert!(inverted_elements(&m, &m.points).is_empty());
}

/// Two tetrahedra, all vertices on the boundary, one inverted (Mesquite's
/// `two_tets.vtk` case): the error names it and why, and nothing is written.
#[test]
fn an_unrepairable_tangle_is_refused_with_the_element_and_reason() {
    let dir = tempfile::tempdir().unwrap();
    let (input, out) = (dir.path().join("two_tets.vtk"), dir.path().join("o.vtk"));
    let mut m = meshsmooth::Mesh::new(vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.2, 0.2, 0.2],
    ]);
    m.push_element(meshsmooth::ElementKind::Tetrahedron, &[0, 1, 2, 3]);
    m.push_element(meshsmooth::ElementKind::Tetrahedron, &[0, 2, 1, 4]);
    io::write(&input, &m, Format::VtkAscii, &[]).unwrap();
    for cmd in ["smooth", "untangle"] {
        let o = meshsmooth(&[cmd, s(&input), "-o", s(&out), "--device", "cpu"]);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(1), "{t}");
        assert!(
            t.contains("untangling failed: 1 element(s) remain inverted (first ids: 1)"),
            "{t}"
        );
        assert!(t.contains("every vertex fixed") && t.contains("two_tets.vtk"), "{t}");
        assert!(!out.exists(), "{cmd} wrote an output");
    }
}

#[test]
fn generate_tangle_writes_a_tangled_mesh_that_smooth_repairs() {
    let dir = tempfile::tempdir().unwrap();
    let (input, out) = (dir.path().join("g.vtk"), dir.path().join("o.vtk"));
    let o = meshsmooth(&[
        "generate",
        "box",
        "--cells",
        "4",
        "4",
        "4",
        "--perturb",
        "random:0.6",
        "--tangle",
        "-o",
        s(&input),
    ]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let m = io::read(&input).unwrap();
    let bad = inverted_elements(&m, &m.points).len();
    assert!(
        bad > 0 && t.contains(&format!("{bad} of {} elements inverted", m.num_elements())),
        "{t}"
    );
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&out), "--device", "cpu", "-q"]);
    assert!(o.status.success(), "{}", text(&o));
    let m = io::read(&out).unwrap();
    assert!(inverted_elements(&m, &m.points).is_empty());
}

/// A triangle fan around one free vertex inside a fixed "C": no valid
/// position exists. `--save-partial` writes the last (still tangled)
/// positions as NAME.partial.EXT and nothing under the output's name.
#[test]
fn save_partial_writes_the_still_tangled_result_beside_the_output() {
    let dir = tempfile::tempdir().unwrap();
    let (input, out) = (dir.path().join("c.vtk"), dir.path().join("o.vtk"));
    let boundary = [
        [0.0, 0.0],
        [4.0, 0.0],
        [4.0, 1.0],
        [1.0, 1.0],
        [1.0, 2.0],
        [4.0, 2.0],
        [4.0, 3.0],
        [0.0, 3.0],
    ];
    let mut points: Vec<[f64; 3]> = boundary.iter().map(|p| [p[0], p[1], 0.0]).collect();
    points.push([0.5, 1.5, 0.0]);
    let mut m = meshsmooth::Mesh::new(points);
    for i in 0..8u32 {
        m.push_element(meshsmooth::ElementKind::Triangle, &[8, i, (i + 1) % 8]);
    }
    io::write(&input, &m, Format::VtkAscii, &[]).unwrap();
    let o = meshsmooth(&["untangle", s(&input), "-o", s(&out), "--device", "cpu"]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(t.contains("untangling failed") && t.contains("c.vtk"), "{t}");
    assert!(!out.exists() && !dir.path().join("o.partial.vtk").exists());
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&out), "--device", "cpu", "--save-partial"]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(!out.exists());
    let partial = io::read(dir.path().join("o.partial.vtk")).unwrap();
    assert!(!inverted_elements(&partial, &partial.points).is_empty());
    assert_ne!(partial.points[8], m.points[8]);
}

/// The cells of the terminal's quality row `name` ("before", "after").
fn quality_row(t: &str, name: &str) -> Vec<String> {
    let line = t
        .lines()
        .find(|l| l.trim_start().starts_with(&format!("{name} ")))
        .unwrap_or_else(|| panic!("no {name} row in {t}"));
    line.split_whitespace().skip(1).map(String::from).collect()
}
