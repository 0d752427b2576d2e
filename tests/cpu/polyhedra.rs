//! Polyhedral meshes: trivalent corners from faces, the Voronoi generator,
//! reading and writing VTK polyhedra, the objective's derivatives and the
//! solvers on polyhedra.

use crate::common;
use common::{options, voronoi_box};

use meshsmooth::generate::{self, VoronoiOptions};
use meshsmooth::io::{self, Format};
use meshsmooth::metric::corner_model::Template;
use meshsmooth::metric::smetric::MetricKind;
use meshsmooth::metric::{element_eta, element_min_det, inverted_elements};
use meshsmooth::report::mesh_element_volume;
use meshsmooth::solve::{self, Device, Method, Params};
use meshsmooth::{ElementKind, Mesh, objective};
use std::collections::HashMap;
use std::path::Path;

type Vec3 = [f64; 3];

/// A hexahedron's faces, outward, in its local numbering.
const HEX_FACES: [[usize; 4]; 6] = [
    [0, 3, 2, 1],
    [4, 5, 6, 7],
    [0, 1, 5, 4],
    [1, 2, 6, 5],
    [2, 3, 7, 6],
    [3, 0, 4, 7],
];

/// `mesh` with the hexahedra for which `pick(e)` holds given as polyhedra.
fn hexes_as_polyhedra(mesh: &Mesh, pick: impl Fn(usize) -> bool) -> Mesh {
    let mut out = Mesh::new(mesh.points.clone());
    for e in 0..mesh.num_elements() {
        let vs = mesh.element(e);
        if mesh.kinds[e] == ElementKind::Hexahedron && pick(e) {
            let faces: Vec<Vec<u32>> = HEX_FACES.iter().map(|f| f.iter().map(|&l| vs[l]).collect()).collect();
            out.push_polyhedron(vs, faces.iter().map(|f| &f[..]));
        } else {
            out.push_element(mesh.kinds[e], vs);
        }
    }
    out
}

/// Faces with their cells: every face twice in opposite directions, or once on the skin.
fn check_conforming(m: &Mesh, on_boundary: impl Fn(&Vec3) -> bool) {
    let mut seen: HashMap<Vec<u32>, Vec<(usize, Vec<u32>)>> = HashMap::new();
    for e in 0..m.num_elements() {
        for f in m.faces.of(e) {
            let mut key = f.to_vec();
            key.sort_unstable();
            seen.entry(key).or_default().push((e, f.to_vec()));
        }
    }
    for uses in seen.values() {
        match &uses[..] {
            [(_, f)] => assert!(
                f.iter().all(|&v| on_boundary(&m.points[v as usize])),
                "face {f:?} is used once but is not on the boundary"
            ),
            [(a, f), (b, g)] => {
                assert_ne!(a, b);
                let k = f.len();
                let s = g.iter().position(|&v| v == f[0]).unwrap();
                assert!(
                    (0..k).all(|i| f[i] == g[(s + k - i) % k]),
                    "cells {a} and {b}: {f:?} vs {g:?}"
                );
            }
            _ => panic!("a face used {} times", uses.len()),
        }
    }
}

fn on_unit_box(p: &Vec3) -> bool {
    p.iter().any(|&c| c == 0.0 || c == 1.0)
}

#[test]
fn voronoi_mesh_is_trivalent_positive_conforming_and_tiles_the_box() {
    let m = generate::voronoi_mesh(&VoronoiOptions::default()).unwrap();
    // the paper's mesh has 663 cells and 3566 nodes
    assert_eq!(m.num_elements(), 648);
    assert!((3000..4500).contains(&m.num_points()), "{} nodes", m.num_points());
    let mut volume = 0.0;
    for e in 0..m.num_elements() {
        assert_eq!(m.kinds[e], ElementKind::Polyhedron);
        let vs = m.element(e);
        let corners = m.element_corners(e).unwrap();
        // every vertex is a corner with three distinct cell-edge neighbours
        assert_eq!(corners.len(), vs.len(), "cell {e}");
        let edges = m.element_edges(e);
        for (i, c) in corners.iter().enumerate() {
            assert_eq!(c[0], i);
            for &n in &c[1..] {
                let edge = [vs[i].min(vs[n]), vs[i].max(vs[n])];
                assert!(edges.contains(&edge), "cell {e}: corner {i} neighbour {n} is no edge");
            }
            assert!(c[1] != c[2] && c[2] != c[3] && c[1] != c[3]);
        }
        assert_eq!(edges.len(), 3 * vs.len() / 2, "cell {e}: trivalent means 3V/2 edges");
        assert!(element_min_det(&m, &m.points, e) > 0.0, "cell {e}");
        let v = mesh_element_volume(&m, &m.points, e);
        assert!(v > 0.0);
        volume += v;
    }
    assert!((volume - 1.0).abs() < 1e-12, "volumes sum to {volume}");
    check_conforming(&m, on_unit_box);
    assert_eq!(
        m,
        generate::voronoi_mesh(&VoronoiOptions::default()).unwrap(),
        "not deterministic"
    );
}

/// The default undistorted mesh is the paper's "smooth quasi-uniform" start:
/// better than the paper's distorted Original column (77 % of cells between
/// 1.5 and 3, 2.5 % above 5), which the jittered lattice as drawn is not.
#[test]
fn default_voronoi_mesh_is_smooth_and_the_raw_lattice_is_not() {
    use meshsmooth::metric::smetric::MetricKind;
    use meshsmooth::metric_report::metric_summary;
    let summary = |opts: &VoronoiOptions| {
        let m = generate::voronoi_mesh(opts).unwrap();
        metric_summary(&m, &m.points, MetricKind::ConditionNumberPaper, None).unwrap()
    };
    let above = |s: &meshsmooth::metric_report::MetricSummary, x: f64| -> f64 {
        s.bands.iter().filter(|b| b.0 >= x).map(|b| b.2).sum()
    };
    let smooth = summary(&VoronoiOptions::default());
    assert!(smooth.avg < 2.0 && above(&smooth, 5.0) < 1.0, "{smooth:?}");
    let raw = summary(&VoronoiOptions {
        lloyd: 0,
        smooth: 0,
        ..Default::default()
    });
    assert!(raw.avg > 5.0 && above(&raw, 5.0) > 10.0, "{raw:?}");
}

#[test]
fn distorted_voronoi_moves_interior_nodes_only_and_inverts_nothing() {
    let plain = generate::voronoi_mesh(&VoronoiOptions::default()).unwrap();
    let opts = VoronoiOptions {
        distorted: true,
        ..Default::default()
    };
    let m = generate::voronoi_mesh(&opts).unwrap();
    assert_eq!(
        (m.kinds.clone(), m.conn.clone(), m.faces.clone()),
        (plain.kinds.clone(), plain.conn.clone(), plain.faces.clone())
    );
    let skin = meshsmooth::mesh::topology::skin_vertices(&m);
    let mut moved = 0;
    for v in 0..m.num_points() {
        if skin[v] {
            assert_eq!(m.points[v], plain.points[v], "skin vertex {v} moved");
            assert!(on_unit_box(&m.points[v]));
        } else {
            moved += usize::from(m.points[v] != plain.points[v]);
        }
    }
    let interior = skin.iter().filter(|&&s| !s).count();
    assert!(moved > interior * 9 / 10, "{moved} of {interior} interior nodes moved");
    assert!(inverted_elements(&m, &m.points).is_empty());
    let volume: f64 = (0..m.num_elements())
        .map(|e| mesh_element_volume(&m, &m.points, e))
        .sum();
    assert!((volume - 1.0).abs() < 1e-9, "{volume}");
    let mean = |m: &Mesh| {
        (0..m.num_elements())
            .map(|e| element_eta(m, &m.points, e).unwrap())
            .sum::<f64>()
    };
    assert!(mean(&m) > mean(&plain), "the distortion did not worsen the mesh");
}

#[test]
fn a_hexahedron_given_by_its_faces_is_the_same_element() {
    let (hexes, hex_reference) = common::meshes(ElementKind::Hexahedron, 3);
    let poly = hexes_as_polyhedra(&hexes, |_| true);
    let poly_reference = hexes_as_polyhedra(&hex_reference, |_| true);
    for (metric, template) in common::models() {
        let ph = common::problem(&hexes, &hex_reference, metric, template);
        let pp = common::problem(&poly, &poly_reference, metric, template);
        let (fh, gh) = objective::gradient(&ph, &ph.gather(&hexes.points)).unwrap();
        let (fp, gp) = objective::gradient(&pp, &pp.gather(&poly.points)).unwrap();
        assert!(
            (fh - fp).abs() <= 1e-14 * fh.abs(),
            "{metric} {template:?}: {fh} vs {fp}"
        );
        let (sh, sp) = (ph.scatter(&gh), pp.scatter(&gp));
        let scale = objective::norm(&gh);
        for (u, v) in sh.iter().zip(&sp) {
            for c in 0..3 {
                assert!((u[c] - v[c]).abs() <= 1e-13 * scale, "{metric} {template:?}");
            }
        }
    }
}

fn shortest_edge(m: &Mesh) -> f64 {
    let len = |[a, b]: [u32; 2]| {
        let (p, q) = (m.points[a as usize], m.points[b as usize]);
        (0..3).map(|i| (p[i] - q[i]).powi(2)).sum::<f64>().sqrt()
    };
    (0..m.num_elements())
        .flat_map(|e| m.element_edges(e))
        .map(len)
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn objective_gradient_matches_finite_differences_on_polyhedra() {
    // whole truncated octahedra: the box's slivers would need steps so short
    // that rounding swamps the differences
    let reference = common::truncated_octahedra(5, 5.0, 8);
    let mut mesh = reference.clone();
    let noise = generate::PerturbOptions {
        perturbation: generate::Perturbation::Random { alpha: 0.1 },
        fraction: 1.0,
        seed: 8,
    };
    generate::perturb(&mut mesh, &noise).unwrap();
    for (metric, template) in common::models() {
        let p = common::problem(&mesh, &reference, metric, template);
        let x = p.gather(&mesh.points);
        let (f, g) = objective::gradient(&p, &x).unwrap();
        assert!((objective::value(&p, &x).unwrap() - f).abs() <= 1e-14 * f);
        let scale = objective::norm(&g);
        assert!(scale > 0.0);
        let h = 1e-6 * shortest_edge(&mesh);
        let mut checked = 0;
        for v in (0..x.len()).filter(|&v| p.free[v]).step_by(3) {
            for c in 0..3 {
                let mut y = x.clone();
                y[v][c] = x[v][c] + h;
                let fp = objective::value(&p, &y).unwrap();
                y[v][c] = x[v][c] - h;
                let fm = objective::value(&p, &y).unwrap();
                let fd = (fp - fm) / (2.0 * h);
                assert!(
                    (fd - g[v][c]).abs() <= 1e-6 * scale,
                    "{metric} {template:?}: vertex {v}.{c}: analytic {} vs fd {fd}",
                    g[v][c]
                );
                checked += 1;
            }
        }
        assert!(checked >= 30, "{checked}");
    }
}

fn round_trip(m: &Mesh, format: Format, name: &str) -> Mesh {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    io::write(&path, m, format, &[]).unwrap();
    io::read(&path).unwrap()
}

#[test]
fn polyhedra_round_trip_through_every_vtk_encoding() {
    let opts = VoronoiOptions {
        cells: [3, 3, 2],
        distorted: true,
        seed: 3,
        ..Default::default()
    };
    let voronoi = generate::voronoi_mesh(&opts).unwrap();
    // polyhedra mixed with hexahedra and tetrahedra
    let mut mixed = hexes_as_polyhedra(&generate::hex_box(3, 2, 2, [3.0, 2.0, 2.0]), |e| e % 2 == 0);
    mixed.points.push([0.3, 0.3, -1.0]);
    let apex = mixed.points.len() as u32 - 1;
    mixed.push_element(ElementKind::Tetrahedron, &[0, 1, 4, apex]);
    if element_min_det(&mixed, &mixed.points, mixed.num_elements() - 1) < 0.0 {
        let n = mixed.conn.len();
        mixed.conn.swap(n - 3, n - 2);
    }
    for (label, m) in [("voronoi", &voronoi), ("mixed", &mixed)] {
        m.validate().unwrap();
        for (format, ext) in [
            (Format::VtkAscii, "vtk"),
            (Format::VtkBinary, "vtk"),
            (Format::VtuAscii, "vtu"),
            (Format::VtuBinary, "vtu"),
            (Format::VtuZlib, "vtu"),
        ] {
            let got = round_trip(m, format, &format!("m.{ext}"));
            let ctx = format!("{label} {format}");
            assert_eq!(got.points, m.points, "{ctx}");
            assert_eq!(got.kinds, m.kinds, "{ctx}");
            assert_eq!(got.faces, m.faces, "{ctx}");
            for e in 0..m.num_elements() {
                let (mut a, mut b) = (got.element(e).to_vec(), m.element(e).to_vec());
                if format.name().starts_with("vtk") {
                    // legacy files hold a polyhedron's faces only
                    a.sort_unstable();
                    b.sort_unstable();
                }
                assert_eq!(a, b, "{ctx}: element {e}");
            }
        }
    }
}

#[test]
fn gmsh_and_medit_refuse_polyhedra_and_write_nothing() {
    let m = voronoi_box(2, 1.0, 1);
    let dir = tempfile::tempdir().unwrap();
    for (format, name) in [
        (Format::Msh41Ascii, "m.msh"),
        (Format::Msh22Binary, "m2.msh"),
        (Format::Medit, "m.mesh"),
    ] {
        let path = dir.path().join(name);
        let e = io::write(&path, &m, format, &[]).unwrap_err().to_string();
        assert!(e.contains(name) && e.contains("element 0 is a polyhedron"), "{e}");
        assert!(!path.exists(), "{name} was written");
    }
}

/// VTK's polyhedron example (a cube of side 2 centred on the origin, faces
/// as in VTKExamples' Polyhedron.cxx), in the layouts VTK writes.
const CUBE_POINTS: &str = "-1 -1 -1 1 -1 -1 1 1 -1 -1 1 -1 -1 -1 1 1 -1 1 1 1 1 -1 1 1";
const CUBE_STREAM: &str = "6 4 0 3 2 1 4 0 4 7 3 4 4 5 6 7 4 5 1 2 6 4 0 1 5 4 4 2 3 7 6";

fn vtu(cells_extra: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">
  <UnstructuredGrid>
    <Piece NumberOfPoints="8" NumberOfCells="1">
      <Points>
        <DataArray type="Float32" Name="Points" NumberOfComponents="3" format="ascii">{CUBE_POINTS}</DataArray>
      </Points>
      <Cells>
        <DataArray type="Int64" Name="connectivity" format="ascii">0 1 2 3 4 5 6 7</DataArray>
        <DataArray type="Int64" Name="offsets" format="ascii">8</DataArray>
        <DataArray type="UInt8" Name="types" format="ascii">42</DataArray>
{cells_extra}
      </Cells>
    </Piece>
  </UnstructuredGrid>
</VTKFile>
"#
    )
}

fn read_str(name: &str, text: &str) -> meshsmooth::Result<Mesh> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    io::read(&path)
}

fn check_cube(m: &Mesh, what: &str) {
    assert_eq!(m.kinds, vec![ElementKind::Polyhedron], "{what}");
    assert_eq!(m.faces.len(), 6, "{what}");
    assert!((mesh_element_volume(m, &m.points, 0) - 8.0).abs() < 1e-12, "{what}");
    // every corner of the cube is the ideal octant corner
    assert!((element_eta(m, &m.points, 0).unwrap() - 1.0).abs() < 1e-12, "{what}");
}

#[test]
fn vtk_polyhedron_example_reads_in_every_layout() {
    let old = vtu(&format!(
        "        <DataArray type=\"Int64\" Name=\"faces\" format=\"ascii\">{CUBE_STREAM}</DataArray>\n        \
         <DataArray type=\"Int64\" Name=\"faceoffsets\" format=\"ascii\">31</DataArray>"
    ));
    check_cube(&read_str("old.vtu", &old).unwrap(), "faces/faceoffsets");
    let new = vtu(
        "        <DataArray type=\"Int64\" Name=\"face_connectivity\" format=\"ascii\">0 3 2 1 0 4 7 3 4 5 6 7 5 1 2 6 0 1 5 4 2 3 7 6</DataArray>\n\
         <DataArray type=\"Int64\" Name=\"face_offsets\" format=\"ascii\">4 8 12 16 20 24</DataArray>\n\
         <DataArray type=\"Int64\" Name=\"polyhedron_to_faces\" format=\"ascii\">0 1 2 3 4 5</DataArray>\n\
         <DataArray type=\"Int64\" Name=\"polyhedron_offsets\" format=\"ascii\">6</DataArray>",
    );
    check_cube(&read_str("new.vtu", &new).unwrap(), "polyhedron_* arrays");
    let head =
        format!("# vtk DataFile Version 5.1\ncube\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 8 float\n{CUBE_POINTS}\n");
    let v51 = format!(
        "{head}CELLS 2 31\nOFFSETS vtktypeint64\n0 31\nCONNECTIVITY vtktypeint64\n{CUBE_STREAM}\nCELL_TYPES 1\n42\n"
    );
    check_cube(&read_str("v51.vtk", &v51).unwrap(), "legacy 5.1");
    let v42 = format!(
        "{}CELLS 1 32\n31 {CUBE_STREAM}\nCELL_TYPES 1\n42\n",
        head.replace("5.1", "4.2")
    );
    check_cube(&read_str("v42.vtk", &v42).unwrap(), "legacy 4.2");
    // a polyhedron without faces is refused with the cell named
    let e = read_str("bare.vtu", &vtu("")).unwrap_err().to_string();
    assert!(
        e.contains("bare.vtu") && e.contains("element 0 is a polyhedron") && e.contains("faces"),
        "{e}"
    );
}

#[test]
fn non_trivalent_open_and_inward_polyhedra_are_refused_with_cell_and_vertex() {
    let head = "# vtk DataFile Version 4.2\nbad\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 5 float\n0 0 0 1 0 0 1 1 0 0 1 0 0.5 0.5 1\n";
    // a square pyramid as a polyhedron: its apex (vertex 4) has four edges
    let pyramid = format!("{head}CELLS 1 23\n22 5 4 0 3 2 1 3 0 1 4 3 1 2 4 3 2 3 4 3 3 0 4\nCELL_TYPES 1\n42\n");
    let e = read_str("pyr.vtk", &pyramid).unwrap_err().to_string();
    for needle in ["pyr.vtk", "element 0", "vertex 4 has 4 cell edges", "trivalent"] {
        assert!(e.contains(needle), "lacks '{needle}': {e}");
    }
    // the same without its base: open
    let open = format!("{head}CELLS 1 18\n17 4 3 0 1 4 3 1 2 4 3 2 3 4 3 3 0 4\nCELL_TYPES 1\n42\n");
    let e = read_str("open.vtk", &open).unwrap_err().to_string();
    assert!(
        e.contains("open.vtk") && e.contains("element 0") && e.contains("not closed"),
        "{e}"
    );
    // a face vertex outside the points
    let far = format!("{head}CELLS 1 6\n5 1 3 0 1 9\nCELL_TYPES 1\n42\n");
    let e = read_str("far.vtk", &far).unwrap_err().to_string();
    assert!(
        e.contains("far.vtk") && e.contains("element 0") && e.contains("vertex 9"),
        "{e}"
    );
    // the example cube with every face reversed is inverted at every corner
    let head8 =
        format!("# vtk DataFile Version 4.2\ncube\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 8 float\n{CUBE_POINTS}\n");
    let reversed: Vec<String> = CUBE_STREAM[2..]
        .split_whitespace()
        .collect::<Vec<_>>()
        .chunks(5)
        .map(|f| format!("4 {} {} {} {}", f[4], f[3], f[2], f[1]))
        .collect();
    let inward = format!("{head8}CELLS 1 32\n31 6 {}\nCELL_TYPES 1\n42\n", reversed.join(" "));
    let e = read_str("inward.vtk", &inward);
    match e {
        Ok(m) => assert_eq!(inverted_elements(&m, &m.points), vec![0]),
        Err(e) => assert!(e.to_string().contains("inward.vtk"), "{e}"),
    }
}

#[test]
fn newton_and_bcd_improve_polyhedral_meshes_for_every_metric() {
    let reference = voronoi_box(3, 3.0, 5);
    let mut start = reference.clone();
    let noise = generate::PerturbOptions {
        perturbation: generate::Perturbation::Random { alpha: 0.4 },
        fraction: 1.0,
        seed: 5,
    };
    generate::perturb(&mut start, &noise).unwrap();
    for (metric, template) in common::models() {
        let p = common::problem(&start, &reference, metric, template);
        let f0 = objective::value(&p, &p.gather(&start.points)).unwrap();
        let mut finals = Vec::new();
        for method in [Method::Newton, Method::Bcd] {
            let mut params = Params::default();
            params.tol = 1e-6;
            params.max_iter = 400;
            let mut x = p.gather(&start.points);
            let info = solve::solve(&p, &mut x, &options(method, &params, Device::Cpu), &mut |_| true).unwrap();
            let f = objective::value(&p, &x).unwrap();
            let case = format!("{metric} {template:?} {method:?}");
            assert!(f < f0, "{case}: {f0} -> {f}");
            assert!(objective::infeasible_corners(&p, &x) == 0, "{case}");
            eprintln!(
                "{case}: {f0:.6} -> {f:.6} in {} iterations ({:?})",
                info.iterations, info.stop
            );
            if method == Method::Newton {
                // (the flat average-template condition number can stall in
                // the line search at its optimum; BCD below checks the value)
                assert!(
                    matches!(info.stop, solve::StopReason::Converged | solve::StopReason::Stalled),
                    "{case}: {:?}",
                    info.stop
                );
            }
            finals.push(f);
        }
        let (newton, bcd) = (finals[0], finals[1]);
        if (metric, template) == (MetricKind::ConditionNumber, Template::Average) {
            // both may stall here (the line search finds no decrease): the
            // average template of the condition number is non-convex and has
            // no barrier at degenerate corners. On the 4^3 body-centred mesh
            // Newton stalled at F = 0.531 against BCD's 0.368: an open problem
            continue;
        }
        // BCD creeps toward Newton's optimum on these cells: below it never,
        // 99.5% of Newton's decrease after 400 sweeps
        assert!(bcd >= newton - 1e-12 * f0, "{metric} {template:?}: {finals:?}");
        assert!(f0 - bcd >= 0.995 * (f0 - newton), "{metric} {template:?}: {finals:?}");
        if metric == MetricKind::TargetShapeSize {
            // the reference is the optimum, F = 0
            assert!(newton < 1e-10 * f0, "tmp: Newton ends at {newton}");
        }
    }
}

#[test]
fn smoothing_a_polyhedral_mesh_does_not_depend_on_units() {
    let mut a = voronoi_box(3, 1.0, 6);
    let noise = generate::PerturbOptions {
        perturbation: generate::Perturbation::Random { alpha: 0.4 },
        fraction: 1.0,
        seed: 6,
    };
    generate::perturb(&mut a, &noise).unwrap();
    let mut b = a.clone();
    // a power of two is exact: the scaled mesh is the same mesh
    for p in &mut b.points {
        *p = p.map(|c| c * 1024.0);
    }
    let mut params = Params::default();
    params.tol = 1e-8;
    let ia = solve::smooth_mesh(
        &mut a,
        &Default::default(),
        &options(Method::Newton, &params, Device::Cpu),
        &mut |_| true,
    )
    .unwrap();
    let ib = solve::smooth_mesh(
        &mut b,
        &Default::default(),
        &options(Method::Newton, &params, Device::Cpu),
        &mut |_| true,
    )
    .unwrap();
    assert_eq!(ia.iterations, ib.iterations);
    for (p, q) in a.points.iter().zip(&b.points) {
        for c in 0..3 {
            assert!((p[c] * 1024.0 - q[c]).abs() <= 1e-9 * 1024.0, "{p:?} vs {q:?}");
        }
    }
}

/// A cell as a sorted list of faces, each rotated to start at its smallest
/// vertex (orientation kept).
fn canonical_cell(m: &Mesh, e: usize) -> Vec<Vec<u32>> {
    let mut faces: Vec<Vec<u32>> = m
        .faces
        .of(e)
        .map(|f| {
            let s = f.iter().enumerate().min_by_key(|(_, v)| **v).unwrap().0;
            (0..f.len()).map(|i| f[(s + i) % f.len()]).collect()
        })
        .collect();
    faces.sort();
    faces
}

#[test]
fn vtk_and_meshio_polyhedron_files_read_as_the_mesh_they_were_made_from() {
    // tests/data/polyhedra/make.py: this mesh written by meshsmooth, read by
    // VTK 9.7.2 (whose vtkCellValidator finds every cell valid) and written
    // by VTK's legacy and XML writers and by meshio 5.3.5
    let opts = VoronoiOptions {
        cells: [2, 2, 2],
        bcc: true,
        jitter: 0.1,
        lloyd: 0,
        smooth: 0,
        seed: 1,
        ..Default::default()
    };
    let ours = generate::voronoi_mesh(&opts).unwrap();
    let mut want: Vec<_> = (0..ours.num_elements()).map(|e| canonical_cell(&ours, e)).collect();
    want.sort();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/polyhedra");
    for name in [
        "ours.vtk",
        "vtk_leg51_ascii.vtk",
        "vtk_leg51_binary.vtk",
        "vtk_xml_ascii.vtu",
        "vtk_xml_binary_zlib.vtu",
        "vtk_xml_appended_raw.vtu",
        "meshio_poly.vtu",
        "meshio_poly_zlib.vtu",
    ] {
        let m = io::read(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(m.num_points(), ours.num_points(), "{name}");
        // ASCII files carry 11 significant digits
        for (p, q) in m.points.iter().zip(&ours.points) {
            assert!((0..3).all(|i| (p[i] - q[i]).abs() < 1e-10), "{name}: {p:?} vs {q:?}");
        }
        assert!(m.kinds.iter().all(|&k| k == ElementKind::Polyhedron), "{name}");
        let mut got: Vec<_> = (0..m.num_elements()).map(|e| canonical_cell(&m, e)).collect();
        got.sort();
        assert_eq!(got, want, "{name}: cells");
        for e in 0..m.num_elements() {
            let mut a = m.element(e).to_vec();
            let mut b = meshsmooth::mesh::polyhedron::vertices_of_faces(m.faces.of(e));
            a.sort_unstable();
            b.sort_unstable();
            assert_eq!(a, b, "{name}: element {e}'s vertices are its faces'");
        }
        assert!(inverted_elements(&m, &m.points).is_empty(), "{name}");
    }
}
