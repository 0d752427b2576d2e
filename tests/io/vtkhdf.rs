//! VTKHDF (feature `vtkhdf`): our files read back by us with their boundary
//! cells, sets and arrays; a file of two pieces read as one mesh; files
//! VTK's vtkHDFWriter writes smoothed and read back by vtkHDFReader; bad
//! files refused naming the file and the problem.

use crate::common;

use common::cli::{meshsmooth, s, text};
use hdf5_metno as hdf5;
use meshsmooth::generate;
use meshsmooth::io::{self, Format};
use meshsmooth::mesh::{DataArray, ElementSet, LowerKind, Mesh, NodeSet, ValueType, Values};
use std::path::{Path, PathBuf};

/// A 3^3 tet box with its z = 0 faces as boundary triangles, a node set, an
/// element set, a fixed vertex, point, cell (and boundary-cell) and field
/// arrays of several types.
fn case() -> Mesh {
    let mut m = generate::tet_box(3, 3, 3, [2.0, 1.0, 0.5]);
    let (n, ne) = (m.num_points(), m.num_elements());
    for e in 0..ne {
        for f in m.kinds[e].facets() {
            let vs: Vec<u32> = f.iter().map(|&l| m.element(e)[l]).collect();
            if vs.iter().all(|&v| m.points[v as usize][2] == 0.0) {
                m.lower.push((LowerKind::Triangle, vs));
            }
        }
    }
    let nl = m.lower.len();
    m.data.point.push(DataArray::new(
        "velocity",
        ValueType::F64,
        3,
        Values::Float((0..3 * n).map(|i| i as f64 * 0.5 - 7.0).collect()),
    ));
    m.data.point.push(DataArray::new(
        "weight",
        ValueType::F32,
        1,
        Values::Float((0..n).map(|i| (i % 5) as f64 * 0.25).collect()),
    ));
    m.data.cell.push(DataArray::new(
        "material",
        ValueType::I32,
        1,
        Values::Int((0..ne as i64).map(|e| e % 3 - 1).collect()),
    ));
    m.data.lower.push(DataArray::new(
        "material",
        ValueType::I32,
        1,
        Values::Int((0..nl as i64).map(|c| 100 + c).collect()),
    ));
    m.data.field.push(DataArray::new(
        "author",
        ValueType::Str,
        1,
        Values::Str(vec!["meshsmooth test".into()]),
    ));
    m.data.node_sets.push(NodeSet {
        name: "inlet".into(),
        vertices: (0..n as u32).filter(|&v| m.points[v as usize][0] == 0.0).collect(),
    });
    m.data.element_sets.push(ElementSet {
        name: "core".into(),
        elements: (0..ne as u32).step_by(4).collect(),
        lower: Vec::new(),
    });
    m.fixed = vec![false; n];
    m.fixed[n / 2] = true;
    m
}

fn array<'a>(arrays: &'a [DataArray], name: &str) -> &'a DataArray {
    arrays.iter().find(|a| a.name == name).unwrap_or_else(|| {
        panic!(
            "no array {name}: {:?}",
            arrays.iter().map(|a| &a.name).collect::<Vec<_>>()
        )
    })
}

#[test]
fn vtkhdf_round_trip_keeps_cells_boundary_sets_and_arrays() {
    let dir = tempfile::tempdir().unwrap();
    let m = case();
    let path = dir.path().join("box.vtkhdf");
    io::write(&path, &m, Format::VtkHdf, &[]).unwrap();
    assert_eq!(Format::of_file(&path), Some(Format::VtkHdf));
    let back = io::read(&path).unwrap();
    assert_eq!(back.points, m.points);
    assert_eq!(
        (&back.kinds, &back.offsets, &back.conn),
        (&m.kinds, &m.offsets, &m.conn)
    );
    assert_eq!(back.lower, m.lower);
    for name in ["velocity", "weight"] {
        let (a, b) = (array(&back.data.point, name), array(&m.data.point, name));
        assert_eq!(
            (a.ty, a.components, &a.values),
            (b.ty, b.components, &b.values),
            "{name}"
        );
    }
    assert_eq!(array(&back.data.cell, "material"), array(&m.data.cell, "material"));
    assert_eq!(array(&back.data.lower, "material"), array(&m.data.lower, "material"));
    assert_eq!(array(&back.data.field, "author"), array(&m.data.field, "author"));
    assert_eq!(back.data.node_sets, m.data.node_sets);
    assert_eq!(back.data.element_sets, m.data.element_sets);
    assert!(back.is_fixed(m.num_points() / 2));
    // written again, the same mesh
    let again = dir.path().join("again.hdf");
    io::write(&again, &back, Format::VtkHdf, &[]).unwrap();
    assert_eq!(io::read(&again).unwrap(), back);
}

/// The box written by hand as two pieces (elements split in two, each piece
/// with its own copy of the points it uses, ids local to the piece), as a
/// parallel VTK writer lays them out.
fn write_two_pieces(path: &Path, m: &Mesh) {
    let ne = m.num_elements();
    let halves = [0..ne / 2, ne / 2..ne];
    let file = hdf5::File::create(path).unwrap();
    let root = file.create_group("VTKHDF").unwrap();
    root.new_attr::<i64>()
        .shape([2])
        .create("Version")
        .unwrap()
        .write_raw(&[2i64, 2])
        .unwrap();
    let ty = hdf5::types::FixedAscii::<16>::from_ascii("UnstructuredGrid").unwrap();
    root.new_attr::<hdf5::types::FixedAscii<16>>()
        .create("Type")
        .unwrap()
        .write_scalar(&ty)
        .unwrap();
    let (mut np, mut nc, mut nk) = (vec![], vec![], vec![]);
    let (mut pts, mut offs, mut conn, mut types, mut tag) = (vec![], vec![], vec![], vec![], vec![]);
    for h in halves {
        let mut local = std::collections::BTreeMap::new();
        for e in h.clone() {
            for &v in m.element(e) {
                let next = local.len() as i64;
                local.entry(v).or_insert(next);
            }
        }
        let mut order: Vec<(u32, i64)> = local.iter().map(|(&v, &l)| (v, l)).collect();
        order.sort_by_key(|x| x.1);
        for (v, _) in &order {
            pts.extend(m.points[*v as usize]);
            tag.push(*v as f64);
        }
        offs.push(0i64);
        let mut k = 0;
        for e in h.clone() {
            conn.extend(m.element(e).iter().map(|v| local[v]));
            k += m.element(e).len() as i64;
            offs.push(k);
            types.push(10u8);
        }
        np.push(order.len() as i64);
        nc.push(h.len() as i64);
        nk.push(k);
    }
    let put = |name: &str, shape: &[usize], f: &dyn Fn(&hdf5::Dataset)| {
        let ds = root.new_dataset::<f64>().shape(shape).create(name);
        f(&ds.unwrap());
    };
    let ints = |name: &str, v: &[i64]| {
        root.new_dataset::<i64>()
            .shape([v.len()])
            .create(name)
            .unwrap()
            .write_raw(v)
            .unwrap();
    };
    ints("NumberOfPoints", &np);
    ints("NumberOfCells", &nc);
    ints("NumberOfConnectivityIds", &nk);
    ints("Offsets", &offs);
    ints("Connectivity", &conn);
    put("Points", &[pts.len() / 3, 3], &|d| d.write_raw(&pts).unwrap());
    root.new_dataset::<u8>()
        .shape([types.len()])
        .create("Types")
        .unwrap()
        .write_raw(&types)
        .unwrap();
    let pd = root.create_group("PointData").unwrap();
    pd.new_dataset::<f64>()
        .shape([tag.len()])
        .create("original_id")
        .unwrap()
        .write_raw(&tag)
        .unwrap();
}

fn sorted_elements(m: &Mesh) -> Vec<Vec<[u64; 3]>> {
    let mut out: Vec<Vec<[u64; 3]>> = (0..m.num_elements())
        .map(|e| {
            let mut v: Vec<[u64; 3]> = m
                .element(e)
                .iter()
                .map(|&v| m.points[v as usize].map(f64::to_bits))
                .collect();
            v.sort();
            v
        })
        .collect();
    out.sort();
    out
}

#[test]
fn a_file_of_two_pieces_reads_as_the_whole_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let m = generate::tet_box(3, 2, 2, [1.0; 3]);
    let path = dir.path().join("two.vtkhdf");
    write_two_pieces(&path, &m);
    let back = io::read(&path).unwrap();
    // the points both pieces hold are merged
    assert_eq!(back.num_points(), m.num_points());
    assert_eq!(back.num_elements(), m.num_elements());
    assert_eq!(sorted_elements(&back), sorted_elements(&m));
    // each point's data came with it
    let ids = array(&back.data.point, "original_id");
    for v in 0..back.num_points() {
        assert_eq!(back.points[v], m.points[ids.get_f64(v) as usize], "point {v}");
    }
    let Some(python) = python() else { return };
    let got = py(
        &python,
        "import sys, json, vtk\nr = vtk.vtkHDFReader()\nr.SetFileName(sys.argv[1])\nr.Update()\no = r.GetOutput()\nprint(json.dumps([o.GetNumberOfCells(), o.GetNumberOfPoints()]))",
        &[&path],
    );
    // VTK keeps each piece's copy of the points: the layout is as VTK reads it
    assert_eq!(got[0], m.num_elements(), "{got}");
    assert!(got[1].as_u64().unwrap() > m.num_points() as u64, "{got}");
}

/// A Python with vtk (see [`common::python_with`]).
fn python() -> Option<PathBuf> {
    common::python_with("vtk", "the VTKHDF interop tests")
}

use common::py_json as py;

/// VTK's vtkHDFWriter writes a perturbed tet box (float32 points, a point
/// vector); meshsmooth smooths it to VTKHDF; vtkHDFReader reads the output
/// with the same points and cells, the vector kept and the quality array
/// added, and the quality improved.
#[test]
fn vtk_hdf_files_are_smoothed_and_read_back_by_vtk() {
    let Some(python) = python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.vtu");
    common::cli::generate_box(&src, [5, 4, 4], "random:0.3", 3);
    let input = dir.path().join("in.vtkhdf");
    let write = r#"
import sys, json, vtk
r = vtk.vtkXMLUnstructuredGridReader()
r.SetFileName(sys.argv[1])
r.Update()
g = r.GetOutput()
v = vtk.vtkDoubleArray(); v.SetName("flow"); v.SetNumberOfComponents(3)
for i in range(g.GetNumberOfPoints()): v.InsertNextTuple3(i, -i, 0.5 * i)
g.GetPointData().AddArray(v)
w = vtk.vtkHDFWriter(); w.SetInputData(g); w.SetFileName(sys.argv[2]); w.Write()
print(json.dumps([g.GetNumberOfPoints(), g.GetNumberOfCells()]))
"#;
    let made = py(&python, write, &[&src, &input]);
    let start = io::read(&input).unwrap();
    assert_eq!(made, serde_json::json!([start.num_points(), start.num_elements()]));
    let flow = array(&start.data.point, "flow");
    assert_eq!((flow.components, flow.get_f64(3 * 7 + 1)), (3, -7.0));

    let output = dir.path().join("out.vtkhdf");
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&output)]);
    assert!(o.status.success(), "{}", text(&o));
    let out = io::read(&output).unwrap();
    let q = |m: &Mesh| meshsmooth::report::quality_report(m, &m.points).objective.unwrap();
    assert!(q(&out) < q(&start) - 1e-3, "{} vs {}", q(&out), q(&start));
    let read = r#"
import sys, json, vtk
r = vtk.vtkHDFReader()
r.SetFileName(sys.argv[1])
r.Update()
o = r.GetOutput()
f = o.GetPointData().GetArray("flow")
q = o.GetCellData().GetArray("inverse_mean_ratio")
print(json.dumps({"points": o.GetNumberOfPoints(), "cells": o.GetNumberOfCells(),
  "flow": [f.GetNumberOfComponents(), f.GetComponent(7, 1)], "q": q.GetRange() if q else None,
  "p5": list(o.GetPoint(5))}))
"#;
    let got = py(&python, read, &[&output]);
    assert_eq!(got["points"], out.num_points(), "{got}");
    assert_eq!(got["cells"], out.num_elements(), "{got}");
    assert_eq!(got["flow"], serde_json::json!([3, -7.0]), "{got}");
    assert!(got["q"][0].as_f64().unwrap() >= 1.0 - 1e-9, "{got}");
    let p5: Vec<f64> = serde_json::from_value(got["p5"].clone()).unwrap();
    assert_eq!(p5, out.points[5].to_vec());
}

/// Files that are not VTKHDF meshes, or that lie about their cells, are
/// refused naming the file and what is wrong; cut files too.
#[test]
fn bad_vtkhdf_files_are_refused_naming_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let m = case();
    let good = dir.path().join("good.vtkhdf");
    io::write(&good, &m, Format::VtkHdf, &[]).unwrap();
    let refused = |name: &str, edit: &dyn Fn(&hdf5::Group), want: &str| {
        let p = dir.path().join(name);
        std::fs::copy(&good, &p).unwrap();
        {
            let f = hdf5::File::open_rw(&p).unwrap();
            edit(&f.group("VTKHDF").unwrap());
        }
        let e = io::read(&p).expect_err(name).to_string();
        assert!(e.contains(name) && e.contains(want), "{name}: {e}");
    };
    refused(
        "polydata.vtkhdf",
        &|g| {
            g.delete_attr("Type").unwrap();
            let t = hdf5::types::FixedAscii::<8>::from_ascii("PolyData").unwrap();
            g.new_attr::<hdf5::types::FixedAscii<8>>()
                .create("Type")
                .unwrap()
                .write_scalar(&t)
                .unwrap();
        },
        "the file holds PolyData",
    );
    refused(
        "far_id.vtkhdf",
        &|g| {
            let ds = g.dataset("Connectivity").unwrap();
            let mut c = ds.read_raw::<i64>().unwrap();
            c[5] = 1_000_000;
            ds.write_raw(&c).unwrap();
        },
        "cell 1 refers to point 1000000",
    );
    refused(
        "offsets.vtkhdf",
        &|g| {
            let ds = g.dataset("Offsets").unwrap();
            let mut o = ds.read_raw::<i64>().unwrap();
            o[3] = o[2] - 1;
            ds.write_raw(&o).unwrap();
        },
        "cell 2: offsets",
    );
    refused(
        "counts.vtkhdf",
        &|g| {
            g.dataset("NumberOfCells").unwrap().write_raw(&[3i64]).unwrap();
        },
        "Types has",
    );
    refused(
        "steps.vtkhdf",
        &|g| {
            g.create_group("Steps").unwrap();
        },
        "temporal",
    );
    // an HDF5 file that is no VTKHDF file
    let other = dir.path().join("other.h5");
    hdf5::File::create(&other).unwrap().create_group("data").unwrap();
    let e = io::read(&other).unwrap_err().to_string();
    assert!(e.contains("other.h5") && e.contains("without a VTKHDF group"), "{e}");
    // cut short anywhere: refused, never read
    let bytes = std::fs::read(&good).unwrap();
    let cut = dir.path().join("cut.vtkhdf");
    for at in [8, 200, bytes.len() / 3, bytes.len() / 2, bytes.len() - 50] {
        std::fs::write(&cut, &bytes[..at]).unwrap();
        let e = io::read(&cut).expect_err("a cut file").to_string();
        assert!(e.contains("cut.vtkhdf"), "cut at {at}: {e}");
    }
    // the CLI says so and exits non-zero, writing nothing
    let out = dir.path().join("out.vtkhdf");
    let o = meshsmooth(&["smooth", s(&cut), "-o", s(&out)]);
    assert!(!o.status.success() && text(&o).contains("cut.vtkhdf"), "{}", text(&o));
    assert!(!out.exists());
}

fn vtk_file(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/interop/vtkhdf")
        .join(name)
}

/// The files VTK 9.7.2's vtkHDFWriter wrote of `whole.vtu` (see
/// `make_vtkhdf.py`): one piece with its arrays, and two gzip-compressed
/// pieces that share points, read as the whole mesh; the one piece smoothed
/// keeps its arrays.
#[test]
fn vtk_written_files_read_as_the_mesh_they_hold() {
    let whole = io::read(vtk_file("whole.vtu")).unwrap();
    let one = io::read(vtk_file("one_piece.vtkhdf")).unwrap();
    assert_eq!(one.points, whole.points);
    assert_eq!((&one.kinds, &one.conn), (&whole.kinds, &whole.conn));
    let flow = array(&one.data.point, "flow");
    assert_eq!((flow.ty, flow.components), (ValueType::F64, 3));
    for i in 0..one.num_points() {
        let want = [i as f64, -(i as f64), 0.5 * i as f64];
        assert_eq!((0..3).map(|c| flow.get_f64(3 * i + c)).collect::<Vec<_>>(), want);
    }
    let zone = array(&one.data.cell, "zone");
    assert_eq!(zone.ty, ValueType::I32);
    assert!((0..one.num_elements()).all(|e| zone.get_f64(e) == (e % 3) as f64));
    assert_eq!(
        array(&one.data.field, "origin").values,
        Values::Str(vec!["VTK 9.7.2 vtkHDFWriter".into()])
    );

    let two = io::read(vtk_file("two_pieces.vtkhdf")).unwrap();
    assert_eq!(two.num_points(), whole.num_points());
    assert_eq!(sorted_elements(&two), sorted_elements(&whole));
    let flow = array(&two.data.point, "flow");
    for v in 0..two.num_points() {
        let i = whole.points.iter().position(|p| *p == two.points[v]).unwrap();
        assert_eq!(flow.get_f64(3 * v + 1), -(i as f64), "point {v}");
    }

    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("smoothed.vtkhdf");
    let o = meshsmooth(&["smooth", s(&vtk_file("one_piece.vtkhdf")), "-o", s(&out)]);
    assert!(o.status.success(), "{}", text(&o));
    let got = io::read(&out).unwrap();
    let q = |m: &Mesh| meshsmooth::report::quality_report(m, &m.points).objective.unwrap();
    assert!(q(&got) < q(&one) - 1e-3, "{} vs {}", q(&got), q(&one));
    assert_eq!(array(&got.data.point, "flow"), array(&one.data.point, "flow"));
    assert_eq!(array(&got.data.cell, "zone"), array(&one.data.cell, "zone"));
    assert_eq!(array(&got.data.field, "origin"), array(&one.data.field, "origin"));
    assert!(got.data.cell.iter().any(|a| a.name == "inverse_mean_ratio"));
}
