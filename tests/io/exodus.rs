//! Exodus II (feature `exodus`): our files read back by us with blocks,
//! node sets, side sets, maps and variables; files meshio writes (with a
//! node set) smoothed and written back, then read by VTK's
//! vtkExodusIIReader and by meshio; broken files refused naming the file.

use crate::common;

use common::cli::{meshsmooth, s, text};
use meshsmooth::generate;
use meshsmooth::io::{self, Format};
use meshsmooth::mesh::{DataArray, ElementSet, LowerKind, Mesh, NodeSet, ValueType, Values};
use std::path::{Path, PathBuf};

/// A 3^3 tet box with a node set, two blocks (by x), a side set of its
/// z = 0 faces, a nodal vector and an element scalar.
fn case() -> Mesh {
    let mut m = generate::tet_box(3, 3, 3, [1.0; 3]);
    let ne = m.num_elements();
    let centre_x = |m: &Mesh, e: usize| m.element(e).iter().map(|&v| m.points[v as usize][0]).sum::<f64>() / 4.0;
    let block: Vec<i64> = (0..ne).map(|e| if centre_x(&m, e) < 0.5 { 10 } else { 20 }).collect();
    // the mesh's own order puts the blocks' elements apart: the writer groups them
    m.data.cell.push(DataArray::new(
        "exodus:block_id",
        ValueType::I32,
        1,
        Values::Int(block.clone()),
    ));
    m.data.element_sets.push(ElementSet {
        name: "left".into(),
        elements: (0..ne as u32).filter(|&e| block[e as usize] == 10).collect(),
        lower: Vec::new(),
    });
    m.data.cell.push(DataArray::new(
        "pressure",
        ValueType::F64,
        1,
        Values::Float((0..ne).map(|e| e as f64 * 0.5).collect()),
    ));
    m.data.point.push(DataArray::new(
        "velocity",
        ValueType::F64,
        3,
        Values::Float((0..3 * m.num_points()).map(|i| i as f64).collect()),
    ));
    m.data.node_sets.push(NodeSet {
        name: "inlet".into(),
        vertices: (0..m.num_points() as u32)
            .filter(|&v| m.points[v as usize][0] == 0.0)
            .collect(),
    });
    // the z = 0 faces of the box, as boundary triangles in a set
    // (outward: the tet's own facet order)
    let mut bottom = Vec::new();
    for e in 0..ne {
        for f in m.kinds[e].facets() {
            let vs: Vec<u32> = f.iter().map(|&l| m.element(e)[l]).collect();
            if vs.iter().all(|&v| m.points[v as usize][2] == 0.0) {
                bottom.push(vs);
            }
        }
    }
    m.lower.extend(bottom.into_iter().map(|f| (LowerKind::Triangle, f)));
    let nl = m.lower.len();
    m.data.element_sets.push(ElementSet {
        name: "bottom".into(),
        elements: Vec::new(),
        lower: (0..nl as u32).collect(),
    });
    m.data.lower = m
        .data
        .cell
        .iter()
        .map(|a| match a.values {
            Values::Int(_) => DataArray::new(&a.name, a.ty, 1, Values::Int(vec![0; nl])),
            _ => DataArray::new(&a.name, a.ty, 1, Values::Float(vec![f64::NAN; nl])),
        })
        .collect();
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

fn floats(a: &DataArray) -> Vec<f64> {
    match &a.values {
        Values::Float(v) => v.clone(),
        Values::Int(v) => v.iter().map(|&x| x as f64).collect(),
        Values::Str(_) => panic!("strings"),
    }
}

/// Sorted vertex triples of an element list, for order-free comparison.
fn elements(m: &Mesh) -> Vec<Vec<u32>> {
    let mut out: Vec<Vec<u32>> = (0..m.num_elements())
        .map(|e| {
            let mut v = m.element(e).to_vec();
            v.sort_unstable();
            v
        })
        .collect();
    out.sort();
    out
}

#[test]
fn exodus_round_trip_keeps_blocks_sets_and_variables() {
    let dir = tempfile::tempdir().unwrap();
    let m = case();
    let path = dir.path().join("box.exo");
    io::write(&path, &m, Format::Exodus, &[]).unwrap();
    assert_eq!(Format::of_file(&path), Some(Format::Exodus));
    let back = io::read(&path).unwrap();
    assert_eq!(back.points, m.points);
    assert_eq!(elements(&back), elements(&m));
    // blocks: ids per element (the file groups them), the named one and the other
    let ids = floats(array(&back.data.cell, "exodus:block_id"));
    let left = back
        .data
        .element_sets
        .iter()
        .find(|s| s.name == "left")
        .expect("block left");
    assert_eq!(left.elements.len(), ids.iter().filter(|&&b| b == 10.0).count());
    assert!(left.elements.iter().all(|&e| ids[e as usize] == 10.0));
    assert!(back.data.element_sets.iter().any(|s| s.name == "block_20"));
    // the element variable follows its element
    let p = floats(array(&back.data.cell, "pressure"));
    let old_p = floats(array(&m.data.cell, "pressure"));
    for e in 0..back.num_elements() {
        let key = elements_of(&back, e);
        let old = (0..m.num_elements()).find(|&o| elements_of(&m, o) == key).unwrap();
        assert_eq!(p[e], old_p[old], "element {e}");
    }
    // the nodal vector is written as velocityX, Y, Z and read back as one array
    let v = array(&back.data.point, "velocity");
    assert_eq!(v.components, 3);
    assert_eq!(floats(v), floats(array(&m.data.point, "velocity")));
    assert!(
        back.data
            .point
            .iter()
            .all(|a| !a.name.starts_with("velocity") || a.name == "velocity")
    );
    let inlet = back
        .data
        .node_sets
        .iter()
        .find(|s| s.name == "inlet")
        .expect("node set");
    assert_eq!(inlet.vertices, m.data.node_sets[0].vertices);
    // the side set: the same faces, as element sides
    let bottom = back
        .data
        .element_sets
        .iter()
        .find(|s| s.name == "bottom")
        .expect("side set");
    let face_keys = |mesh: &Mesh, ids: &[u32]| {
        let mut k: Vec<Vec<u32>> = ids
            .iter()
            .map(|&c| {
                let mut v = mesh.lower[c as usize].1.clone();
                v.sort_unstable();
                v
            })
            .collect();
        k.sort();
        k
    };
    assert_eq!(
        face_keys(&back, &bottom.lower),
        face_keys(&m, &m.data.element_sets[1].lower)
    );
    assert_eq!(bottom.lower.len(), 18);
    // and the groups work as the other formats' do
    let mut fixed = back.clone();
    let rules = meshsmooth::mesh::fixing::FixRules {
        fix_groups: vec!["inlet".into()],
        ..Default::default()
    };
    rules.apply(&mut fixed).unwrap();
    assert!(inlet.vertices.iter().all(|&v| fixed.is_fixed(v as usize)));
}

fn elements_of(m: &Mesh, e: usize) -> Vec<u32> {
    let mut v = m.element(e).to_vec();
    v.sort_unstable();
    v
}

/// A Python with meshio, netCDF4 and vtk (see [`common::python_with`]).
fn python() -> Option<PathBuf> {
    common::python_with("meshio, netCDF4, vtk", "the Exodus interop tests")
}

use common::py_json as py;

/// meshio writes a perturbed tet box with a node set; meshsmooth smooths it
/// to Exodus; VTK's vtkExodusIIReader and meshio read the output with the
/// same points and cells, the node set is kept, and quality improved.
#[test]
fn meshio_exodus_is_smoothed_and_read_back_by_vtk_and_meshio() {
    let Some(python) = python() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.vtu");
    common::cli::generate_box(&src, [5, 4, 4], "random:0.3", 2);
    let input = dir.path().join("in.exo");
    let write = r#"
import sys, json, meshio, numpy as np
m = meshio.read(sys.argv[1])
pts = m.points
wall = np.flatnonzero(pts[:, 0] == pts[:, 0].min())
m = meshio.Mesh(pts, [("tetra", m.cells_dict["tetra"])], point_sets={"wall": wall})
meshio.write(sys.argv[2], m, file_format="exodus")
print(json.dumps({"points": len(pts), "wall": len(wall)}))
"#;
    let made = py(&python, write, &[&src, &input]);
    let start = io::read(&input).unwrap();
    assert_eq!(made["points"], start.num_points());
    let wall = start
        .data
        .node_sets
        .iter()
        .find(|s| s.name == "wall")
        .expect("meshio's node set");
    assert_eq!(made["wall"], wall.vertices.len());

    let output = dir.path().join("out.exo");
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&output), "--fix-group", "wall"]);
    assert!(o.status.success(), "{}", text(&o));
    let out = io::read(&output).unwrap();
    assert_eq!(out.num_points(), start.num_points());
    let q = |m: &Mesh| meshsmooth::report::quality_report(m, &m.points).objective.unwrap();
    assert!(q(&out) < q(&start) - 1e-3, "{} vs {}", q(&out), q(&start));
    for &v in &wall.vertices {
        assert_eq!(
            out.points[v as usize], start.points[v as usize],
            "wall vertex {v} moved"
        );
    }

    let read = r#"
import sys, json, meshio, vtk
r = vtk.vtkExodusIIReader()
r.SetFileName(sys.argv[1])
r.UpdateInformation()
for i in range(r.GetNumberOfObjects(vtk.vtkExodusIIReader.NODE_SET)):
    r.SetObjectStatus(vtk.vtkExodusIIReader.NODE_SET, i, 1)
r.SetAllArrayStatus(vtk.vtkExodusIIReader.ELEM_BLOCK, 1)
r.Update()
it = r.GetOutput().NewIterator()
it.InitTraversal()
blocks = []
while not it.IsDoneWithTraversal():
    blocks.append((it.GetCurrentDataObject().GetNumberOfPoints(), it.GetCurrentDataObject().GetNumberOfCells()))
    it.GoToNextItem()
names = [r.GetObjectName(vtk.vtkExodusIIReader.NODE_SET, i) for i in range(r.GetNumberOfObjects(vtk.vtkExodusIIReader.NODE_SET))]
fields = [r.GetObjectArrayName(vtk.vtkExodusIIReader.ELEM_BLOCK, i) for i in range(r.GetNumberOfObjectArrays(vtk.vtkExodusIIReader.ELEM_BLOCK))]
m = meshio.read(sys.argv[1])
print(json.dumps({"vtk_blocks": blocks, "vtk_node_sets": names, "vtk_fields": fields,
  "meshio_points": len(m.points), "meshio_tetra": len(m.cells_dict.get("tetra", [])),
  "meshio_sets": {k: len(v) for k, v in m.point_sets.items()}}))
"#;
    let got = py(&python, read, &[&output]);
    let blocks = got["vtk_blocks"].as_array().unwrap();
    // the element block, then the node set
    assert_eq!(blocks[0][0], out.num_points(), "{got}");
    assert_eq!(blocks[0][1], out.num_elements(), "{got}");
    assert!(got["vtk_node_sets"].to_string().contains("wall"), "{got}");
    assert!(got["vtk_fields"].to_string().contains("inverse_mean_ratio"), "{got}");
    assert_eq!(got["meshio_points"], out.num_points(), "{got}");
    assert_eq!(got["meshio_tetra"], out.num_elements(), "{got}");
    assert_eq!(got["meshio_sets"]["wall"], wall.vertices.len(), "{got}");
}

/// Truncated and corrupted files, and files that lie about their nodes,
/// are refused naming the file; nothing panics.
#[test]
fn broken_exodus_files_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.exo");
    io::write(&good, &case(), Format::Exodus, &[]).unwrap();
    let bytes = std::fs::read(&good).unwrap();
    assert_eq!(&bytes[..4], b"CDF\x02", "written as classic 64-bit-offset netCDF");
    let bad = dir.path().join("bad.exo");
    for cut in [8, 100, 600, bytes.len() / 3, bytes.len() / 2, bytes.len() - 100] {
        std::fs::write(&bad, &bytes[..cut]).unwrap();
        match io::read(&bad) {
            Ok(m) => panic!(
                "a file cut at {cut} of {} read as {} points",
                bytes.len(),
                m.num_points()
            ),
            Err(e) => assert!(e.to_string().contains("bad.exo"), "cut {cut}: {e}"),
        }
    }
    // bytes flipped all over the (classic netCDF) file: read or refused, never
    // a panic or a hang
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for k in 0..150 {
        let mut b = bytes.clone();
        for _ in 0..1 + k % 4 {
            let i = (next() % b.len() as u64) as usize;
            b[i] ^= 1 << (next() % 8);
        }
        std::fs::write(&bad, &b).unwrap();
        if let Err(e) = io::read(&bad) {
            assert!(e.to_string().contains("bad.exo"), "mutant {k}: {e}");
        }
    }
    // a file that is not an Exodus mesh
    let o = meshsmooth(&["smooth", s(&bad), "-o", s(&dir.path().join("out.vtu"))]);
    assert!(!o.status.success());
    assert!(!dir.path().join("out.vtu").exists());
}

/// A Gmsh mesh with physical groups (a volume and its skin) smoothed to
/// Exodus: each group is a block of its name, the skin a block of
/// triangles, read so by meshsmooth, by vtkExodusIIReader and by meshio;
/// fixed vertices come back fixed, and a nodal vector is one 3-component
/// array for VTK as for us.
#[test]
fn gmsh_groups_become_named_blocks_that_vtk_and_meshio_read() {
    let dir = tempfile::tempdir().unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/interop/gmsh_box_phys_msh41a.msh");
    let input = io::read(&src).unwrap();
    let (ne, nl) = (input.num_elements(), input.lower.len());
    assert!(nl > 0 && input.lower.iter().all(|(k, _)| *k == LowerKind::Triangle));
    let output = dir.path().join("box.exo");
    let o = meshsmooth(&["smooth", s(&src), "-o", s(&output), "--max-iter", "5", "-q"]);
    assert!(o.status.success(), "{}", text(&o));
    let out = io::read(&output).unwrap();
    assert_ne!(out.points, input.points, "smoothed");
    let set = |m: &Mesh, name: &str| -> (usize, usize) {
        let s = m.data.element_sets.iter().find(|s| s.name == name);
        let s = s.unwrap_or_else(|| panic!("no set {name}"));
        (s.elements.len(), s.lower.len())
    };
    assert_eq!(set(&out, "solid"), (ne, 0));
    assert_eq!(set(&out, "skin"), (0, nl));
    assert!(out.data.element_sets.iter().all(|s| !s.name.starts_with("sideset")));
    // the skin's vertices were fixed (they are a boundary): they stay so
    let skin: std::collections::BTreeSet<u32> = input.lower.iter().flat_map(|c| c.1.clone()).collect();
    assert!(skin.iter().all(|&v| out.is_fixed(v as usize)));

    let mut m = out.clone();
    m.data.point.push(DataArray::new(
        "velocity",
        ValueType::F64,
        3,
        Values::Float((0..3 * m.num_points()).map(|i| i as f64 * 0.25).collect()),
    ));
    let again = dir.path().join("again.exo");
    io::write(&again, &m, Format::Exodus, &[]).unwrap();
    let back = io::read(&again).unwrap();
    assert_eq!(back.lower.len(), nl);
    assert_eq!(
        floats(array(&back.data.point, "velocity")),
        floats(array(&m.data.point, "velocity"))
    );

    let Some(python) = python() else {
        return;
    };
    let read = r#"
import sys, json, meshio, vtk
r = vtk.vtkExodusIIReader()
r.SetFileName(sys.argv[1])
r.UpdateInformation()
r.SetAllArrayStatus(vtk.vtkExodusIIReader.NODAL, 1)
r.Update()
blocks = {}
out = r.GetOutput().GetBlock(0)
for i in range(out.GetNumberOfBlocks()):
    name = out.GetMetaData(i).Get(vtk.vtkCompositeDataSet.NAME())
    blocks[name] = out.GetBlock(i).GetNumberOfCells()
vel = out.GetBlock(0).GetPointData().GetArray("velocity")
m = meshio.read(sys.argv[1])
print(json.dumps({"vtk_blocks": blocks, "vtk_velocity": vel.GetNumberOfComponents() if vel else 0,
  "meshio": {c.type: len(c.data) for c in m.cells}}))
"#;
    let got = py(&python, read, &[&again]);
    assert_eq!(got["vtk_blocks"]["solid"], ne, "{got}");
    assert_eq!(got["vtk_blocks"]["skin"], nl, "{got}");
    assert_eq!(got["vtk_velocity"], 3, "{got}");
    assert_eq!(got["meshio"]["tetra"], ne, "{got}");
    assert_eq!(got["meshio"]["triangle"], nl, "{got}");
}
