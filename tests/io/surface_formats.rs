//! Surface-mesh formats: STL (ASCII, binary), OBJ and PLY (ASCII, binary)
//! round trips with their data and groups, files of meshio and VTK read
//! back and ours read by them, mutants and prefixes that read or fail
//! naming the file, located errors, and the CLI on a surface.

use std::path::{Path, PathBuf};
use std::process::Command;

use meshsmooth::ElementKind;
use meshsmooth::io::{self, Format};
use meshsmooth::mesh::{DataArray, ElementSet, Mesh, ValueType, Values};

use crate::common;
use crate::common::cli::{meshsmooth, s, text};

const SURFACE: [Format; 5] = [
    Format::StlBinary,
    Format::StlAscii,
    Format::Obj,
    Format::PlyBinary,
    Format::PlyAscii,
];

fn ext(f: Format) -> &'static str {
    match f {
        Format::StlBinary | Format::StlAscii => "stl",
        Format::Obj => "obj",
        _ => "ply",
    }
}

/// A triangulated unit sphere: an octahedron with each face split `n`
/// times per edge, projected onto the sphere.
fn sphere(n: usize) -> Mesh {
    meshsmooth::generate::sphere(n)
}

/// A unit cube's surface of quadrilaterals, `n` by `n` on each side.
fn quad_cube(n: usize) -> Mesh {
    let mut points: Vec<[f64; 3]> = Vec::new();
    let mut ids = std::collections::HashMap::new();
    let mut quads = Vec::new();
    for axis in 0..3 {
        for side in [0.0, 1.0] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for i in 0..n {
                for j in 0..n {
                    let mut corner = |di: usize, dj: usize, points: &mut Vec<[f64; 3]>| {
                        let mut p = [0.0; 3];
                        p[axis] = side;
                        p[u] = (i + di) as f64 / n as f64;
                        p[v] = (j + dj) as f64 / n as f64;
                        let key = p.map(|x| (x * 1e6).round() as i64);
                        *ids.entry(key).or_insert_with(|| {
                            points.push(p);
                            points.len() - 1
                        }) as u32
                    };
                    let q = [(0, 0), (1, 0), (1, 1), (0, 1)].map(|(a, b)| corner(a, b, &mut points));
                    quads.push(if side == 0.0 { [q[0], q[3], q[2], q[1]] } else { q });
                }
            }
        }
    }
    let mut m = Mesh::new(points);
    for q in quads {
        m.push_element(ElementKind::Quadrilateral, &q);
    }
    m
}

/// The sphere with point and cell arrays and two element sets (its first
/// and second halves, so every format keeps the element order).
fn decorated_sphere() -> Mesh {
    let mut m = sphere(4);
    let (np, ne) = (m.num_points(), m.num_elements());
    m.data.point.push(DataArray::new(
        "height",
        ValueType::F64,
        1,
        Values::Float(m.points.iter().map(|p| p[2] * 0.5).collect()),
    ));
    m.data.point.push(DataArray::new(
        "label",
        ValueType::I32,
        1,
        Values::Int((0..np as i64).map(|i| i % 7 - 3).collect()),
    ));
    m.data.cell.push(DataArray::new(
        "region",
        ValueType::U8,
        1,
        Values::Int((0..ne as i64).map(|e| e % 5).collect()),
    ));
    let half = (ne / 2) as u32;
    m.data.element_sets = vec![
        ElementSet {
            name: "north".into(),
            elements: (0..half).collect(),
            lower: Vec::new(),
        },
        ElementSet {
            name: "south".into(),
            elements: (half..ne as u32).collect(),
            lower: Vec::new(),
        },
    ];
    m
}

/// Each element's corner coordinates, in order: what must survive the
/// vertex renumbering of STL's merge.
fn corner_coords(m: &Mesh) -> Vec<Vec<[u64; 3]>> {
    (0..m.num_elements())
        .map(|e| {
            m.element(e)
                .iter()
                .map(|&v| common::bits(&m.points[v as usize]))
                .collect()
        })
        .collect()
}

fn f32_points(m: &Mesh) -> Mesh {
    let mut r = m.clone();
    for p in &mut r.points {
        *p = p.map(|x| f64::from(x as f32));
    }
    r
}

fn set(m: &Mesh, name: &str) -> Vec<u32> {
    m.data
        .element_sets
        .iter()
        .find(|s| s.name == name)
        .unwrap_or_else(|| panic!("no set {name}: {:?}", m.data.element_sets))
        .elements
        .clone()
}

#[test]
fn every_surface_format_round_trips_points_cells_data_and_groups() {
    let dir = tempfile::tempdir().unwrap();
    let m = decorated_sphere();
    for f in SURFACE {
        let p = dir.path().join(format!("sphere.{}.{}", f.name(), ext(f)));
        io::write(&p, &m, f, &[]).unwrap_or_else(|e| panic!("{f}: {e}"));
        assert_eq!(Format::of_file(&p), Some(f), "{f}");
        let got = io::read(&p).unwrap_or_else(|e| panic!("{f}: {e}"));
        assert_eq!(got.num_elements(), m.num_elements(), "{f}");
        assert!(got.kinds.iter().all(|&k| k == ElementKind::Triangle), "{f}");
        assert!(got.lower.is_empty(), "{f}");
        // binary STL holds 32-bit floats; every other one the exact doubles
        let want = if f == Format::StlBinary {
            f32_points(&m)
        } else {
            m.clone()
        };
        assert_eq!(corner_coords(&got), corner_coords(&want), "{f}: corners");
        assert_eq!(
            got.num_points(),
            m.num_points(),
            "{f}: STL's merge finds every shared vertex"
        );
        match f {
            Format::StlAscii | Format::Obj => {
                assert_eq!(set(&got, "north"), set(&m, "north"), "{f}");
                assert_eq!(set(&got, "south"), set(&m, "south"), "{f}");
            }
            Format::PlyBinary | Format::PlyAscii => {
                assert_eq!(got.points, m.points, "{f}");
                assert_eq!(got.conn, m.conn, "{f}");
                assert_eq!(got.data.point, m.data.point, "{f}: point data");
                assert_eq!(got.data.cell, m.data.cell, "{f}: cell data");
            }
            _ => {}
        }
        if f == Format::Obj {
            assert_eq!(got.points, m.points, "{f}");
            assert_eq!(got.conn, m.conn, "{f}");
        }
    }
}

#[test]
fn quadrilaterals_round_trip_through_obj_and_ply_and_stl_refuses_them() {
    let dir = tempfile::tempdir().unwrap();
    let m = quad_cube(3);
    for f in [Format::Obj, Format::PlyBinary, Format::PlyAscii] {
        let p = dir.path().join(format!("cube.{}.{}", f.name(), ext(f)));
        io::write(&p, &m, f, &[]).unwrap();
        let got = io::read(&p).unwrap_or_else(|e| panic!("{f}: {e}"));
        assert_eq!(
            (got.points.clone(), got.conn.clone(), got.kinds.clone()),
            (m.points.clone(), m.conn.clone(), m.kinds.clone()),
            "{f}"
        );
    }
    for f in [Format::StlBinary, Format::StlAscii] {
        let p = dir.path().join(format!("cube.{}.stl", f.name()));
        let e = io::write(&p, &m, f, &[]).unwrap_err().to_string();
        assert!(
            e.contains("element 0 is a quadrilateral") && e.contains("triangles only"),
            "{e}"
        );
        assert!(!p.exists(), "{f}: nothing written");
    }
    // volumes fit none of them
    let tets = common::perturbed_box(2, 0.0, 1);
    for f in SURFACE {
        let p = dir.path().join(format!("box.{}", ext(f)));
        let e = io::write(&p, &tets, f, &[]).unwrap_err().to_string();
        assert!(
            e.contains("element 0 is a") && e.contains(&format!("the {f} format")),
            "{e}"
        );
    }
}

#[test]
fn ply_keeps_the_quality_cell_data_given_to_write() {
    let dir = tempfile::tempdir().unwrap();
    let m = sphere(2);
    let q: Vec<f64> = (0..m.num_elements()).map(|e| e as f64 * 0.25).collect();
    for f in [Format::PlyBinary, Format::PlyAscii] {
        let p = dir.path().join(format!("q.{}.ply", f.name()));
        io::write(
            &p,
            &m,
            f,
            &[io::CellData {
                name: "eta",
                values: &q,
            }],
        )
        .unwrap();
        let got = io::read(&p).unwrap();
        let a = got.data.cell.iter().find(|a| a.name == "eta").expect("eta");
        assert_eq!(a.values, Values::Float(q.clone()), "{f}");
    }
}

#[test]
fn names_extensions_and_encodings_of_the_surface_formats() {
    for (name, f) in [
        ("stl", Format::StlBinary),
        ("stl-ascii", Format::StlAscii),
        ("obj", Format::Obj),
        ("ply", Format::PlyBinary),
        ("ply-ascii", Format::PlyAscii),
    ] {
        assert_eq!(Format::from_name(name), Some(f));
        assert_eq!(f.name(), name);
        assert!(!f.keeps_lower_cells() && f.is_surface_only(), "{f}");
    }
    assert_eq!(Format::from_path(Path::new("a.STL")).unwrap(), Format::StlBinary);
    assert_eq!(Format::from_path(Path::new("a.obj")).unwrap(), Format::Obj);
    assert_eq!(Format::from_path(Path::new("a.ply")).unwrap(), Format::PlyBinary);
    let dir = tempfile::tempdir().unwrap();
    let m = sphere(1);
    let ascii = dir.path().join("in.stl");
    io::write(&ascii, &m, Format::StlAscii, &[]).unwrap();
    assert_eq!(
        Format::following(&dir.path().join("out.stl"), &ascii).unwrap(),
        Format::StlAscii
    );
    let ply = dir.path().join("in.ply");
    io::write(&ply, &m, Format::PlyAscii, &[]).unwrap();
    assert_eq!(
        Format::following(&dir.path().join("out.ply"), &ply).unwrap(),
        Format::PlyAscii
    );
    assert_eq!(
        Format::following(&dir.path().join("out.stl"), &ply).unwrap(),
        Format::StlBinary
    );
}

#[test]
fn stl_merges_equal_corners_and_keeps_its_solids() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("two.stl");
    std::fs::write(
        &p,
        "solid left part\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0 1 0\n  endloop\n endfacet\nendsolid left part\n\
         solid right\n facet normal 0 0 1\n  outer loop\n   vertex 1 0 0\n   vertex 1 1 0\n   vertex -0.0 1 0\n  endloop\n endfacet\nendsolid right\n",
    )
    .unwrap();
    let m = io::read(&p).unwrap();
    assert_eq!(m.num_points(), 4, "{:?}", m.points);
    assert_eq!(m.conn, vec![0, 1, 2, 1, 3, 2]);
    assert_eq!(set(&m, "left part"), vec![0]);
    assert_eq!(set(&m, "right"), vec![1]);
    let out = dir.path().join("back.stl");
    io::write(&out, &m, Format::StlAscii, &[]).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.starts_with("solid left part\n") && text.contains("endsolid right"),
        "{text}"
    );
}

fn expect_err(path: &Path, content: &[u8], needles: &[&str]) {
    std::fs::write(path, content).unwrap();
    let e = io::read(path).unwrap_err().to_string();
    assert!(e.contains(&path.display().to_string()), "{e}");
    for n in needles {
        assert!(e.contains(n), "wanted '{n}' in: {e}");
    }
}

#[test]
fn bad_surface_files_are_refused_naming_the_file_and_where() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("bad.obj");
    expect_err(
        &obj,
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\n# a comment\nf 1 2 3\nf 1 2 9\n",
        &["line 6", "vertex 9", "3 vertices"],
    );
    expect_err(
        &obj,
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1 2//2 -4\n",
        &["line 4", "vertex -4"],
    );
    expect_err(
        &obj,
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 2 2 0\nf 1 2 3 4 5\n",
        &["line 6", "more than 4"],
    );
    expect_err(&obj, b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", &["line 4", "2 vertices"]);
    expect_err(&obj, b"v 0 0 zero\n", &["line 1", "zero"]);
    expect_err(&obj, b"v 0 0 0\ncurv 1 2\n", &["line 2", "curv"]);
    let ply = dir.path().join("bad.ply");
    expect_err(
        &ply,
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
          element face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 7\n",
        &["face 1", "vertex 7", "3 vertices", "line 14"],
    );
    // the same in binary: the face is named with its byte offset
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
          element face 1\nproperty list uchar int vertex_indices\nend_header\n"
        .to_vec();
    for x in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
        b.extend_from_slice(&x.to_le_bytes());
    }
    b.push(3);
    for v in [0i32, 1, 5] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    expect_err(&ply, &b, &["face 0", "vertex 5", "byte"]);
    // a huge declared count is refused before anything is allocated for it
    expect_err(
        &ply,
        b"ply\nformat binary_big_endian 1.0\nelement vertex 4000000000000\nproperty double x\nproperty double y\nend_header\n\0\0",
        &["element vertex declares 4000000000000", "line 3"],
    );
    // an element without properties takes no bytes: a huge count of them
    // must be passed over at once, not counted through
    let started = std::time::Instant::now();
    std::fs::write(
        &ply,
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
          element junk 18000000000000000000\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
          0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    )
    .unwrap();
    let m = io::read(&ply).unwrap();
    assert_eq!((m.points.len(), m.num_elements()), (3, 1));
    assert!(started.elapsed().as_secs() < 5, "took {:?}", started.elapsed());
    let stl = dir.path().join("bad.stl");
    // neither text nor a binary of the right size: both reasons are given
    let mut b = vec![b'x'; 84];
    b[80..84].copy_from_slice(&2u32.to_le_bytes());
    b.extend_from_slice(&[0xff; 60]);
    expect_err(
        &stl,
        &b,
        &[
            "neither an ASCII STL",
            "binary facet count 2 needs 184 bytes but the file has 144",
            "byte 84",
        ],
    );
    expect_err(
        &stl,
        b"solid a\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n  endloop\n",
        &["line 6", "exactly 3"],
    );
    expect_err(
        &stl,
        b"solid a\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 nan\n",
        &["line 4", "non-finite"],
    );
}

/// Every prefix and a few hundred mutants of a small file per format read
/// or fail with an error naming the file; none panics or hangs.
#[test]
fn prefixes_and_mutants_of_surface_files_read_or_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = sphere(1);
    m.data.point.push(DataArray::new(
        "w",
        ValueType::F32,
        1,
        Values::Float(vec![0.5; m.num_points()]),
    ));
    m.data.element_sets.push(ElementSet {
        name: "g".into(),
        elements: vec![0, 1],
        lower: Vec::new(),
    });
    let mut rand = common::xorshift(0x9e37_79b9_7f4a_7c15);
    let poly = b"# vtk DataFile Version 4.2\np\nASCII\nDATASET POLYDATA\nPOINTS 4 float\n0 0 0 1 0 0 1 1 0 0 1 0\n\
                 LINES 1 3\n2 0 1\nPOLYGONS 2 8\n3 0 1 2\n3 0 2 3\nCELL_DATA 3\nSCALARS c int 1\nLOOKUP_TABLE default\n1 2 3\n";
    let files = SURFACE.map(|f| {
        let src = dir.path().join(format!("src.{}", ext(f)));
        io::write(&src, &m, f, &[]).unwrap();
        (f.name(), ext(f), std::fs::read(&src).unwrap())
    });
    for (f, ext, bytes) in files.into_iter().chain([("vtk polydata", "vtk", poly.to_vec())]) {
        let p = dir.path().join(format!("fuzz.{ext}"));
        let check = |b: &[u8], what: &str| {
            std::fs::write(&p, b).unwrap();
            let r = std::panic::catch_unwind(|| io::read(&p));
            match r {
                Err(_) => panic!("{f}: {what} panicked"),
                Ok(Err(e)) => {
                    let e = e.to_string();
                    assert!(e.contains("fuzz."), "{f}: {what}: the error names no file: {e}");
                }
                Ok(Ok(_)) => {}
            }
        };
        for cut in 0..bytes.len() {
            check(&bytes[..cut], &format!("prefix {cut}"));
        }
        for k in 0..300 {
            let mut b = bytes.clone();
            let i = rand() as usize % b.len();
            b[i] = match rand() % 4 {
                0 => b'9',
                1 => b[i] ^ (1 << (rand() % 8)),
                2 => b' ',
                _ => rand() as u8,
            };
            check(&b, &format!("mutant {k} (byte {i})"));
        }
    }
}

/// A Python with meshio and vtk (`MESHSMOOTH_PYTHON`, else `.venv`).
fn python(module: &str) -> Option<PathBuf> {
    let p = std::env::var_os("MESHSMOOTH_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv/bin/python"));
    let ok = Command::new(&p)
        .args(["-c", &format!("import {module}")])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            std::env::var_os("CI").is_none(),
            "no Python with {module} at {}, and CI must run the surface-format read-back tests",
            p.display()
        );
        common::skipped(&format!("no Python with {module} (set MESHSMOOTH_PYTHON)"));
    }
    ok.then_some(p)
}

fn run_py(python: &Path, script: &str, args: &[&Path]) -> serde_json::Value {
    let o = Command::new(python).args(["-c", script]).args(args).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&o.stdout)))
}

/// meshio reads what we write (points, triangles, the PLY arrays) and we
/// read what meshio writes, in every encoding it has.
#[test]
fn meshio_reads_our_surfaces_and_we_read_meshios() {
    let Some(py) = python("meshio") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    // meshio 5.3 cannot read a binary PLY face list followed by face
    // properties (its list reader takes the whole block as lists): no cell arrays
    let mut m = decorated_sphere();
    m.data.cell.clear();
    let read = r#"
import sys, json, meshio
m = meshio.read(sys.argv[1])
cells = sum(len(c.data) for c in m.cells)
print(json.dumps({'points': len(m.points), 'cells': cells, 'point_data': sorted(m.point_data)}))
"#;
    for f in SURFACE {
        let p = dir.path().join(format!("ours.{}.{}", f.name(), ext(f)));
        io::write(&p, &m, f, &[]).unwrap();
        let got = run_py(&py, read, &[&p]);
        assert_eq!(got["cells"], m.num_elements(), "{f}: {got}");
        // meshio's STL reader merges nothing: 3 points a facet
        if !matches!(f, Format::StlBinary | Format::StlAscii) {
            assert_eq!(got["points"], m.num_points(), "{f}: {got}");
        }
        if ext(f) == "ply" {
            let names = got["point_data"].to_string();
            assert!(names.contains("height") && names.contains("label"), "{f}: {got}");
        }
    }
    let write = r#"
import sys, meshio, numpy as np
src = meshio.read(sys.argv[1], file_format='ply')
tri = src.cells_dict['triangle']
m = meshio.Mesh(src.points, [('triangle', tri)], point_data={'h': src.points[:, 2].copy()})
meshio.write(sys.argv[2] + '/a.stl', m, binary=False)
meshio.write(sys.argv[2] + '/b.stl', m, binary=True)
meshio.write(sys.argv[2] + '/c.obj', meshio.Mesh(src.points, [('triangle', tri)]))
meshio.write(sys.argv[2] + '/d.ply', m, binary=False)
meshio.write(sys.argv[2] + '/e.ply', m, binary=True)
print('{}')
"#;
    let src = dir.path().join("src.ply");
    io::write(&src, &m, Format::PlyBinary, &[]).unwrap();
    run_py(&py, write, &[&src, dir.path()]);
    for name in ["a.stl", "b.stl", "c.obj", "d.ply", "e.ply"] {
        let got = io::read(dir.path().join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(got.num_elements(), m.num_elements(), "{name}");
        assert_eq!(got.num_points(), m.num_points(), "{name}");
        let want = if name == "b.stl" { f32_points(&m) } else { m.clone() };
        let close = corner_coords(&got).iter().zip(corner_coords(&want)).all(|(a, b)| {
            a.iter().zip(&b).all(|(x, y)| {
                x.iter()
                    .zip(y)
                    .all(|(p, q)| (f64::from_bits(*p) - f64::from_bits(*q)).abs() < 1e-6)
            })
        });
        assert!(close, "{name}: corners differ");
        if name.ends_with("ply") {
            assert!(got.data.point.iter().any(|a| a.name == "h"), "{name}");
        }
    }
}

/// VTK's readers (vtkSTLReader, vtkOBJReader, vtkPLYReader) read ours with
/// the same points and triangles, and we read what VTK's writers write.
#[test]
fn vtk_reads_our_surfaces_and_we_read_vtks() {
    let Some(py) = python("vtk") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let m = sphere(3);
    let read = r#"
import sys, json, vtk
p = sys.argv[1]
r = vtk.vtkSTLReader() if p.endswith('.stl') else vtk.vtkOBJReader() if p.endswith('.obj') else vtk.vtkPLYReader()
r.SetFileName(p)
r.Update()
o = r.GetOutput()
print(json.dumps({'points': o.GetNumberOfPoints(), 'cells': o.GetNumberOfCells(), 'polys': o.GetNumberOfPolys()}))
"#;
    for f in SURFACE {
        let p = dir.path().join(format!("ours.{}.{}", f.name(), ext(f)));
        io::write(&p, &m, f, &[]).unwrap();
        let got = run_py(&py, read, &[&p]);
        assert_eq!(got["polys"], m.num_elements(), "{f}: {got}");
        assert_eq!(got["points"], m.num_points(), "{f}: {got}");
    }
    let write = r#"
import sys, vtk
r = vtk.vtkPLYReader()
r.SetFileName(sys.argv[1])
r.Update()
d = sys.argv[2]
for name, w, binary in [('a.stl', vtk.vtkSTLWriter(), False), ('b.stl', vtk.vtkSTLWriter(), True),
                        ('c.ply', vtk.vtkPLYWriter(), False), ('d.ply', vtk.vtkPLYWriter(), True),
                        ('e.obj', vtk.vtkOBJWriter(), None)]:
    w.SetInputData(r.GetOutput())
    w.SetFileName(d + '/' + name)
    if binary is not None:
        w.SetFileTypeToBinary() if binary else w.SetFileTypeToASCII()
    w.Write()
print('{}')
"#;
    let src = dir.path().join("src.ply");
    io::write(&src, &m, Format::PlyBinary, &[]).unwrap();
    run_py(&py, write, &[&src, dir.path()]);
    for name in ["a.stl", "b.stl", "c.ply", "d.ply", "e.obj"] {
        let got = io::read(dir.path().join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(got.num_elements(), m.num_elements(), "{name}");
        assert_eq!(got.num_points(), m.num_points(), "{name}");
    }
}

/// `meshsmooth quality` reads an STL surface (Gmsh's sphere where Gmsh is
/// installed, else ours) as it reads the same surface in legacy VTK.
#[test]
fn the_cli_reports_the_quality_of_an_stl_surface() {
    let dir = tempfile::tempdir().unwrap();
    let stl = dir.path().join("sphere.stl");
    let geo = dir.path().join("sphere.geo");
    std::fs::write(
        &geo,
        "SetFactory(\"OpenCASCADE\");\nSphere(1) = {0, 0, 0, 1};\nMesh.MeshSizeMax = 0.3;\n",
    )
    .unwrap();
    let gmsh = Command::new("gmsh")
        .args([s(&geo), "-2", "-format", "stl", "-o", s(&stl)])
        .output()
        .is_ok_and(|o| o.status.success());
    if !gmsh {
        common::skipped("no gmsh: the CLI reads a sphere of the tests' own");
        io::write(&stl, &sphere(6), Format::StlBinary, &[]).unwrap();
    }
    // the same surface as legacy VTK: whatever quality makes of it (the
    // solver may refuse a curved surface), it must make the same of both
    let m = io::read(&stl).unwrap();
    assert!(m.num_elements() > 50, "{}", m.num_elements());
    let vtk = dir.path().join("sphere.vtk");
    io::write(&vtk, &m, Format::VtkAscii, &[]).unwrap();
    let (a, b) = (
        meshsmooth(&["quality", s(&stl), "--json"]),
        meshsmooth(&["quality", s(&vtk), "--json"]),
    );
    assert_eq!(a.status.success(), b.status.success(), "{}\n{}", text(&a), text(&b));
    assert_eq!(text(&a).replace(s(&stl), "F"), text(&b).replace(s(&vtk), "F"));
}

/// Legacy `DATASET POLYDATA`: polygons as elements, vertices and lines as
/// lower cells, cell data over all of them in VTK's order.
#[test]
fn legacy_vtk_polydata_reads_polygons_lines_and_vertices() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("poly.vtk");
    std::fs::write(
        &p,
        "# vtk DataFile Version 4.2\npolydata\nASCII\nDATASET POLYDATA\nPOINTS 5 float\n\
         0 0 0 1 0 0 1 1 0 0 1 0 2 0 0\nVERTICES 1 2\n1 4\nLINES 1 3\n2 0 1\n\
         POLYGONS 2 9\n3 1 4 2\n4 0 1 2 3\nPOINT_DATA 5\nSCALARS h double 1\nLOOKUP_TABLE default\n0 1 2 3 4\n\
         CELL_DATA 4\nSCALARS id int 1\nLOOKUP_TABLE default\n10 11 12 13\n",
    )
    .unwrap();
    let m = io::read(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(m.kinds, vec![ElementKind::Triangle, ElementKind::Quadrilateral]);
    assert_eq!(m.conn, vec![1, 4, 2, 0, 1, 2, 3]);
    assert_eq!(m.lower.len(), 2);
    let id = m.data.cell.iter().find(|a| a.name == "id").unwrap();
    assert_eq!(id.values, Values::Int(vec![12, 13]));
    assert_eq!(m.data.point.len(), 1);
    // the 5.1 layout too
    std::fs::write(
        &p,
        "# vtk DataFile Version 5.1\npolydata\nASCII\nDATASET POLYDATA\nPOINTS 4 float\n\
         0 0 0 1 0 0 1 1 0 0 1 0\nPOLYGONS 3 6\nOFFSETS vtktypeint64\n0 3 6\nCONNECTIVITY vtktypeint64\n0 1 2 0 2 3\n",
    )
    .unwrap();
    assert_eq!(io::read(&p).unwrap().conn, vec![0, 1, 2, 0, 2, 3]);
    let head = "# vtk DataFile Version 4.2\np\nASCII\nDATASET POLYDATA\nPOINTS 4 float\n0 0 0 1 0 0 1 1 0 0 1 0\n";
    expect_err(
        &p,
        format!("{head}TRIANGLE_STRIPS 1 5\n4 0 1 3 2\n").as_bytes(),
        &["TRIANGLE_STRIPS", "line 7"],
    );
    expect_err(
        &p,
        format!("{head}POLYGONS 1 6\n5 0 1 2 3 0\n").as_bytes(),
        &["POLYGONS cell 0 has 5 vertices"],
    );
    expect_err(
        &p,
        format!("{head}POLYGONS 1 4\n3 0 1 9\n").as_bytes(),
        &["vertex 9", "line 8"],
    );
    expect_err(
        &p,
        format!("{head}POLYGONS 1 4\n3 0 1 2\nCELL_DATA 2\n").as_bytes(),
        &["CELL_DATA 2", "1 cells"],
    );
}

/// VTK's vtkPolyDataWriter (ASCII and binary) writes what we read as the
/// same triangle surface.
#[test]
fn we_read_vtks_legacy_polydata() {
    let Some(py) = python("vtk") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let m = sphere(3);
    let src = dir.path().join("src.ply");
    io::write(&src, &m, Format::PlyBinary, &[]).unwrap();
    let write = r#"
import sys, vtk
r = vtk.vtkPLYReader()
r.SetFileName(sys.argv[1])
r.Update()
o = r.GetOutput()
h = vtk.vtkDoubleArray()
h.SetName('h')
for i in range(o.GetNumberOfPoints()):
    h.InsertNextValue(o.GetPoint(i)[2])
o.GetPointData().AddArray(h)
for name, binary in [('a.vtk', False), ('b.vtk', True)]:
    w = vtk.vtkPolyDataWriter()
    w.SetInputData(o)
    w.SetFileName(sys.argv[2] + '/' + name)
    w.SetFileTypeToBinary() if binary else w.SetFileTypeToASCII()
    w.Write()
print('{}')
"#;
    run_py(&py, write, &[&src, dir.path()]);
    for name in ["a.vtk", "b.vtk"] {
        let got = io::read(dir.path().join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(got.num_elements(), m.num_elements(), "{name}");
        assert_eq!(got.conn, m.conn, "{name}");
        // VTK writes 6 significant digits in ASCII, 32-bit floats in binary
        let near = got
            .points
            .iter()
            .zip(&m.points)
            .all(|(a, b)| (0..3).all(|k| (a[k] - b[k]).abs() < 1e-5));
        assert!(near, "{name}: points differ");
        assert!(got.data.point.iter().any(|a| a.name == "h"), "{name}");
    }
}
