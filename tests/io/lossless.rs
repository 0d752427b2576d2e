//! What a round trip keeps beyond the elements: boundary cells and their
//! data in VTK/VTU files, Gmsh views (`$NodeData`, `$ElementData`), Gmsh 4.1
//! entities and the entity of each node; and the `$PhysicalNames` a reader
//! refuses.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use meshsmooth::io::{self, Format};
use meshsmooth::mesh::data::{GMSH_DIM_TAGS, GMSH_PHYSICAL};
use meshsmooth::mesh::{DataArray, ElementKind, LowerKind, Mesh, ValueType, Values};

use crate::common::cli::{meshsmooth, s, text};
use crate::interop::{gmsh_available, meshio_python, run_gmsh};

fn interop_file(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/interop")
        .join(name)
}

fn array<'a>(arrays: &'a [DataArray], name: &str) -> &'a DataArray {
    arrays
        .iter()
        .find(|a| a.name == name)
        .unwrap_or_else(|| panic!("no array '{name}'"))
}

/// Values as f64 bits (NaN compares equal to NaN).
fn bits(a: &DataArray) -> Vec<u64> {
    (0..a.values.len()).map(|i| a.get_f64(i).to_bits()).collect()
}

/// `src` smoothed by the CLI to `out` in `format`, read back: it moved
/// from `input`.
fn smooth_to(src: &Path, out: &Path, format: &str, input: &Mesh) -> Mesh {
    let o = meshsmooth(&[
        "smooth",
        s(src),
        "-o",
        s(out),
        "--format",
        format,
        "--device",
        "cpu",
        "--max-iter",
        "5",
        "-q",
    ]);
    assert!(o.status.success(), "{format}: {}", text(&o));
    let got = io::read(out).unwrap();
    assert_ne!(got.points, input.points, "{format}: smoothed");
    got
}

/// meshio's volume mesh with its boundary: smoothed to every VTK and VTU
/// encoding by the CLI, it keeps its 708 boundary triangles (after the
/// tetrahedra) with their `gmsh:physical` values, and the quality array
/// has NaN for them; meshio reads the output the same way.
#[test]
fn smooth_keeps_the_boundary_triangles_of_a_meshio_vtu_and_their_groups() {
    let src = interop_file("meshio_tetbox_vtu_zlib.vtu");
    let input = io::read(&src).unwrap();
    assert_eq!((input.num_elements(), input.lower.len()), (1577, 708));
    let want_phys = input.data.lower_array(GMSH_PHYSICAL).unwrap().values.clone();
    let dir = tempfile::tempdir().unwrap();
    let python = meshio_python();
    for (format, ext) in [
        ("vtu", "vtu"),
        ("vtu-binary", "vtu"),
        ("vtu-zlib", "vtu"),
        ("vtk", "vtk"),
        ("vtk-binary", "vtk"),
    ] {
        let out = dir.path().join(format!("out-{format}.{ext}"));
        let got = smooth_to(&src, &out, format, &input);
        assert_eq!(got.num_elements(), 1577, "{format}");
        assert_eq!(got.lower, input.lower, "{format}: boundary triangles");
        assert!(got.lower.iter().all(|(k, _)| *k == LowerKind::Triangle));
        assert_eq!(
            got.data.lower_array(GMSH_PHYSICAL).unwrap().values,
            want_phys,
            "{format}"
        );
        assert_eq!(
            got.data.cell_array(GMSH_PHYSICAL).unwrap(),
            input.data.cell_array(GMSH_PHYSICAL).unwrap(),
            "{format}"
        );
        let q = got.data.lower_array("inverse_mean_ratio").expect("quality array");
        assert!(
            (0..708).all(|i| q.get_f64(i).is_nan()),
            "{format}: quality of a lower cell"
        );
        let q = got.data.cell_array("inverse_mean_ratio").unwrap();
        assert!(
            (0..1577).all(|e| q.get_f64(e) >= 1.0 - 1e-12),
            "{format}: quality of the elements"
        );
        let Some(python) = &python else { continue };
        let script = "import sys, json, meshio, numpy as np\n\
                      m = meshio.read(sys.argv[1])\n\
                      q = np.concatenate(m.cell_data['inverse_mean_ratio'])\n\
                      print(json.dumps([[c.type, len(c.data)] for c in m.cells] + \
                      [np.concatenate(m.cell_data['gmsh:physical']).ravel().tolist(), int(np.isnan(q).sum())]))";
        let o = Command::new(python).args(["-c", script]).arg(&out).output().unwrap();
        assert!(o.status.success(), "{format}: {}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v[0], serde_json::json!(["tetra", 1577]), "{format}: meshio");
        assert_eq!(v[1], serde_json::json!(["triangle", 708]), "{format}: meshio");
        let phys: Vec<i64> = serde_json::from_value(v[2].clone()).unwrap();
        let Values::Int(tri) = &want_phys else { panic!() };
        assert_eq!(
            &phys[1577..],
            &tri[..],
            "{format}: meshio's gmsh:physical of the triangles"
        );
        assert_eq!(v[3], 708, "{format}: meshio's NaN quality values");
    }
}

/// A tetrahedron with a boundary triangle and views: `temperature` in two
/// time steps (the last is kept), a 3-component `velocity` that leaves node
/// 4 out (NaN), and `pressure` on both cells (element tags 20 and 10).
fn msh_with_views(version: &str) -> String {
    let (header, nodes, elements) = match version {
        "2.2" => (
            "2.2 0 8",
            "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n",
            "$Elements\n2\n10 2 2 7 1 1 2 3\n20 4 2 8 1 1 2 3 4\n$EndElements\n",
        ),
        _ => (
            "4.1 0 8",
            "$Entities\n0 0 1 1\n1 0 0 0 1 1 0 1 7 0\n1 0 0 0 1 1 1 1 8 1 1\n$EndEntities\n\
             $Nodes\n2 4 1 4\n2 1 0 3\n1\n2\n3\n0 0 0\n1 0 0\n0 1 0\n3 1 0 1\n4\n0 0 1\n$EndNodes\n",
            "$Elements\n2 2 10 20\n2 1 2 1\n10 1 2 3\n3 1 4 1\n20 1 2 3 4\n$EndElements\n",
        ),
    };
    format!(
        "$MeshFormat\n{header}\n$EndMeshFormat\n{nodes}{elements}\
         $NodeData\n1\n\"temperature\"\n1\n0.0\n3\n0\n1\n4\n1 9\n2 9\n3 9\n4 9\n$EndNodeData\n\
         $NodeData\n1\n\"temperature\"\n1\n1.0\n3\n1\n1\n4\n1 10.5\n2 11.5\n3 12.5\n4 -13.25\n$EndNodeData\n\
         $NodeData\n1\n\"velocity\"\n1\n1.0\n3\n1\n3\n3\n1 1 2 3\n2 4 5 6\n3 7 8 9\n$EndNodeData\n\
         $ElementData\n1\n\"pressure\"\n1\n1.0\n3\n1\n1\n2\n20 101.5\n10 7.75\n$EndElementData\n"
    )
}

fn check_views(ctx: &str, m: &Mesh) {
    let t = array(&m.data.point, "temperature");
    assert_eq!((t.ty, t.components), (ValueType::F64, 1), "{ctx}");
    assert_eq!(
        t.values,
        Values::Float(vec![10.5, 11.5, 12.5, -13.25]),
        "{ctx}: last step"
    );
    let v = array(&m.data.point, "velocity");
    assert_eq!(v.components, 3, "{ctx}");
    let mut want = (1..=9).map(f64::from).collect::<Vec<_>>();
    want.extend([f64::NAN; 3]);
    assert_eq!(
        bits(v),
        want.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
        "{ctx}: velocity"
    );
    assert_eq!(
        array(&m.data.cell, "pressure").values,
        Values::Float(vec![101.5]),
        "{ctx}"
    );
    assert_eq!(
        array(&m.data.lower, "pressure").values,
        Values::Float(vec![7.75]),
        "{ctx}"
    );
}

/// Gmsh views become point and cell arrays (2.2 and 4.1 files), and come
/// back the same from every Gmsh format (ASCII and binary) and from VTK and
/// VTU files; Gmsh reads the views meshsmooth writes with the same values.
#[test]
fn gmsh_views_survive_msh_and_vtu_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    for version in ["2.2", "4.1"] {
        let src = dir.path().join(format!("views-{version}.msh"));
        std::fs::write(&src, msh_with_views(version)).unwrap();
        let m = io::read(&src).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((m.num_elements(), m.lower.len()), (1, 1));
        check_views(&format!("{version} as read"), &m);
        for f in Format::ALL.into_iter().filter(|f| !f.is_surface_only()) {
            let ext = match f {
                Format::VtkAscii | Format::VtkBinary => "vtk",
                Format::VtuAscii | Format::VtuBinary | Format::VtuZlib => "vtu",
                Format::Exodus => "exo",
                Format::VtkHdf => "vtkhdf",
                // none holds arrays of values
                Format::Medit | Format::Abaqus | Format::OpenFoam | Format::OpenFoamBinary => continue,
                _ => "msh",
            };
            let out = dir.path().join(format!("views-{version}.{f}.{ext}"));
            io::write(&out, &m, f, &[]).unwrap();
            let got = io::read(&out).unwrap_or_else(|e| panic!("{version} as {f}: {e}"));
            check_views(&format!("{version} as {f}"), &got);
            if ext == "msh" {
                gmsh_has_the_views(&format!("{version} as {f}"), &out, &got);
            }
        }
    }
}

/// Gmsh loads `path`'s views and saves each as a `.msh` of its own, which
/// holds the values `m` has (matched by coordinates: Gmsh may renumber).
fn gmsh_has_the_views(ctx: &str, path: &Path, m: &Mesh) {
    if !gmsh_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("views.geo");
    std::fs::write(
        &script,
        format!(
            "Merge \"{}\";\nFor i In {{0:PostProcessing.NbViews-1}}\n  Save View[i] Sprintf(\"{}/view%g.msh\", i);\nEndFor\n",
            path.display(),
            dir.path().display()
        ),
    )
    .unwrap();
    run_gmsh(&format!("{ctx}: views"), &[script.as_os_str(), "-0".as_ref()]);
    let key = |p: [f64; 3]| p.map(f64::to_bits);
    let ids: HashMap<[u64; 3], usize> = m.points.iter().enumerate().map(|(i, &p)| (key(p), i)).collect();
    let mut seen = Vec::new();
    for i in 0..3 {
        let view = io::read(dir.path().join(format!("view{i}.msh"))).unwrap_or_else(|e| panic!("{ctx}: view {i}: {e}"));
        // (Gmsh saves the mesh with the view, in 4.1: the nodes' entities come along)
        for a in view.data.point.iter().filter(|a| a.name != GMSH_DIM_TAGS) {
            let want = array(&m.data.point, &a.name);
            let k = a.components;
            for (j, &p) in view.points.iter().enumerate() {
                let w = ids[&key(p)];
                for c in 0..k {
                    assert_eq!(
                        a.get_f64(j * k + c).to_bits(),
                        want.get_f64(w * k + c).to_bits(),
                        "{ctx}: Gmsh's '{}' at node {w}",
                        a.name
                    );
                }
            }
            seen.push(a.name.clone());
        }
        for a in view.data.cell.iter().filter(|a| a.name == "pressure") {
            assert_eq!(a.values, Values::Float(vec![101.5]), "{ctx}: Gmsh's pressure");
            assert_eq!(
                array(&view.data.lower, "pressure").values,
                Values::Float(vec![7.75]),
                "{ctx}"
            );
            seen.push(a.name.clone());
        }
    }
    seen.sort();
    assert_eq!(seen, ["pressure", "temperature", "velocity"], "{ctx}: Gmsh's views");
}

/// The entity of each node in `m`'s `gmsh:dim_tags`, by coordinates to
/// 1e-9 (Gmsh prints 16 significant digits).
fn node_entities(m: &Mesh) -> HashMap<[i64; 3], (i64, i64)> {
    let a = array(&m.data.point, GMSH_DIM_TAGS);
    m.points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            (
                p.map(|x| (x * 1e9).round() as i64),
                (a.get_i64(2 * i), a.get_i64(2 * i + 1)),
            )
        })
        .collect()
}

/// Gmsh's 4.1 box smoothed to 4.1 ASCII and binary keeps every entity (its
/// box, physical tags and bounding entities) and each node on its entity;
/// Gmsh, saving the output again, finds the same entities and nodes.
#[test]
fn msh41_entities_and_node_entities_survive_smooth() {
    let src = interop_file("gmsh_box_phys_msh41a.msh");
    let input = io::read(&src).unwrap();
    assert_eq!(input.data.gmsh_entities.len(), 8 + 12 + 6 + 1);
    let dim_tags = array(&input.data.point, GMSH_DIM_TAGS).clone();
    // Gmsh's blocks: the box's 8 corners, then nodes of curves, surfaces, the volume
    assert_eq!((dim_tags.get_i64(0), dim_tags.get_i64(1)), (0, 1));
    let dims: Vec<i64> = (0..input.num_points()).map(|i| dim_tags.get_i64(2 * i)).collect();
    assert!(dims.contains(&1) && dims.contains(&2) && dims.contains(&3));
    let dir = tempfile::tempdir().unwrap();
    for format in ["msh4", "msh4-binary"] {
        let out = dir.path().join(format!("{format}.msh"));
        let got = smooth_to(&src, &out, format, &input);
        assert_eq!(got.data.gmsh_entities, input.data.gmsh_entities, "{format}: entities");
        assert_eq!(
            array(&got.data.point, GMSH_DIM_TAGS),
            &dim_tags,
            "{format}: node entities"
        );
        if !gmsh_available() {
            continue;
        }
        let resaved = dir.path().join(format!("{format}.gmsh.msh"));
        run_gmsh(
            &format!("{format}: -save"),
            &[
                &out,
                Path::new("-save"),
                Path::new("-format"),
                Path::new("msh41"),
                Path::new("-o"),
                &resaved,
            ],
        );
        let back = io::read(&resaved).unwrap();
        let shape = |m: &Mesh| -> Vec<(i32, i32, Vec<i32>, Vec<i32>)> {
            let mut v: Vec<_> = m
                .data
                .gmsh_entities
                .iter()
                .map(|e| (e.dim, e.tag, e.physical.clone(), e.bounding.clone()))
                .collect();
            v.sort();
            v
        };
        assert_eq!(shape(&back), shape(&input), "{format}: entities after Gmsh");
        assert_eq!(
            node_entities(&back),
            node_entities(&got),
            "{format}: node entities after Gmsh"
        );
    }
}

/// `$PhysicalNames` entries Gmsh cannot take are refused with the file and
/// the line: a dimension outside 0..=3 (Gmsh 4.8 crashes on one), a tag that
/// is not positive, a name without quotes.
#[test]
fn bad_physical_names_are_refused_with_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    for (entry, why) in [
        ("-5 1 \"skin\"", "dimension -5"),
        ("4 1 \"skin\"", "dimension 4"),
        ("2 0 \"skin\"", "physical tag 0"),
        ("2 -3 \"skin\"", "physical tag -3"),
        ("2 1 skin", "not in double quotes"),
        ("2 1 \"skin", "not in double quotes"),
    ] {
        let path = dir.path().join("bad-names.msh");
        let text = format!(
            "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n3 2 \"solid\"\n{entry}\n$EndPhysicalNames\n\
             $Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n$Elements\n1\n1 4 2 2 1 1 2 3 4\n$EndElements\n"
        );
        std::fs::write(&path, text).unwrap();
        let e = io::read(&path).expect_err(entry).to_string();
        assert!(
            e.contains("bad-names.msh") && e.contains("line 7") && e.contains(why) && e.contains("$PhysicalNames"),
            "{entry}: {e}"
        );
    }
    // the good entries are kept as they are
    let path = dir.path().join("good-names.msh");
    let text = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n3 2 \"solid part\"\n0 9 \"\"\n$EndPhysicalNames\n\
                $Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n$Elements\n1\n1 4 2 2 1 1 2 3 4\n$EndElements\n";
    std::fs::write(&path, text).unwrap();
    let m = io::read(&path).unwrap();
    let names: Vec<(i32, i32, &str)> = m
        .data
        .physical_names
        .iter()
        .map(|p| (p.dim, p.tag, p.name.as_str()))
        .collect();
    assert_eq!(names, [(3, 2, "solid part"), (0, 9, "")]);
    assert_eq!(m.kinds, [ElementKind::Tetrahedron]);
}

/// A view naming a node or element the file does not have is refused with
/// the file, the line and the view; so is a view before its mesh.
#[test]
fn bad_views_are_refused_with_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n\
                $Elements\n1\n1 4 2 2 1 1 2 3 4\n$EndElements\n";
    for (view, line, why) in [
        (
            "$NodeData\n1\n\"t\"\n1\n0\n3\n0\n1\n2\n1 5\n9 6\n$EndNodeData\n",
            "line 25",
            "'t' has a value for node 9, which is not in $Nodes",
        ),
        (
            "$ElementData\n1\n\"p\"\n1\n0\n3\n0\n1\n1\n2 5\n$EndElementData\n",
            "line 24",
            "'p' has a value for element 2, which is not in $Elements",
        ),
        (
            "$NodeData\n1\n\"t\"\n1\n0\n2\n0\n1\n$EndNodeData\n",
            "line 22",
            "expected the integer tags 'time-step components count'",
        ),
    ] {
        let path = dir.path().join("bad-view.msh");
        std::fs::write(&path, format!("{mesh}{view}")).unwrap();
        let e = io::read(&path).expect_err(view).to_string();
        assert!(
            e.contains("bad-view.msh") && e.contains(line) && e.contains(why),
            "{view}: {e}"
        );
    }
    let path = dir.path().join("early-view.msh");
    let early = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$NodeData\n1\n\"t\"\n1\n0\n3\n0\n1\n0\n$EndNodeData\n";
    std::fs::write(&path, format!("{early}{}", &mesh[31..])).unwrap();
    let e = io::read(&path).expect_err("view first").to_string();
    assert!(
        e.contains("early-view.msh") && e.contains("line 4") && e.contains("$NodeData before $Nodes"),
        "{e}"
    );
}

/// A physical group Gmsh cannot take, set by a program rather than read,
/// is not written either: the write fails and leaves no file.
#[test]
fn bad_physical_names_are_not_written() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = Mesh::new(vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    m.push_element(ElementKind::Tetrahedron, &[0, 1, 2, 3]);
    m.data.physical_names = vec![meshsmooth::mesh::PhysicalName {
        dim: -5,
        tag: 1,
        name: "skin".into(),
    }];
    for f in [Format::Msh22Ascii, Format::Msh41Binary] {
        let path = dir.path().join(format!("{f}.msh"));
        let e = io::write(&path, &m, f, &[]).expect_err("dimension -5").to_string();
        assert!(e.contains("'skin'") && e.contains("dimension -5"), "{f}: {e}");
        assert!(!path.exists(), "{f}");
    }
}
