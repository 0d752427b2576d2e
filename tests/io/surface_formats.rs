//! Surface-mesh formats: STL (ASCII, binary), OBJ, PLY (ASCII, binary) and
//! VTK XML PolyData (`.vtp`) round trips with their data and groups, files
//! of meshio and VTK read back and ours read by them, mutants and prefixes
//! that read or fail naming the file, located errors, and the CLI on a
//! surface.

use std::path::{Path, PathBuf};
use std::process::Command;

use meshsmooth::ElementKind;
use meshsmooth::io::{self, Format};
use meshsmooth::mesh::{DataArray, ElementSet, LowerKind, Mesh, ValueType, Values};

use crate::common;
use crate::common::cli::{meshsmooth, s, text};

const SURFACE: [Format; 8] = [
    Format::StlBinary,
    Format::StlAscii,
    Format::Obj,
    Format::PlyBinary,
    Format::PlyAscii,
    Format::Vtp,
    Format::VtpAscii,
    Format::VtpZlib,
];

fn ext(f: Format) -> &'static str {
    match f {
        Format::StlBinary | Format::StlAscii => "stl",
        Format::Obj => "obj",
        Format::Vtp | Format::VtpAscii | Format::VtpZlib => "vtp",
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
            // everything: points, cells, arrays (names, types, values) and sets
            Format::Vtp | Format::VtpAscii | Format::VtpZlib => {
                assert_eq!(got.points, m.points, "{f}");
                assert_eq!(got.conn, m.conn, "{f}");
                assert_eq!(got.data.point, m.data.point, "{f}: point data");
                assert_eq!(got.data.cell, m.data.cell, "{f}: cell data");
                assert_eq!(got.data.element_sets, m.data.element_sets, "{f}: sets");
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
fn quadrilaterals_round_trip_through_obj_ply_and_vtp_and_stl_refuses_them() {
    let dir = tempfile::tempdir().unwrap();
    let m = quad_cube(3);
    for f in [
        Format::Obj,
        Format::PlyBinary,
        Format::PlyAscii,
        Format::Vtp,
        Format::VtpAscii,
        Format::VtpZlib,
    ] {
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
fn ply_and_vtp_keep_the_quality_cell_data_given_to_write() {
    let dir = tempfile::tempdir().unwrap();
    let m = sphere(2);
    let q: Vec<f64> = (0..m.num_elements()).map(|e| e as f64 * 0.25).collect();
    for f in [
        Format::PlyBinary,
        Format::PlyAscii,
        Format::Vtp,
        Format::VtpAscii,
        Format::VtpZlib,
    ] {
        assert!(f.keeps_cell_data(), "{f}");
        let p = dir.path().join(format!("q.{}.{}", f.name(), ext(f)));
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
    // VTK PolyData: surfaces, with vertices and lines as boundary cells;
    // base64 by default, ASCII and zlib on request
    for (name, f, binary) in [
        ("vtp", Format::Vtp, true),
        ("vtp-ascii", Format::VtpAscii, false),
        ("vtp-zlib", Format::VtpZlib, true),
    ] {
        assert_eq!(Format::from_name(name), Some(f));
        assert_eq!(f.name(), name);
        assert!(Format::ALL.contains(&f), "{f}");
        assert!(
            f.is_surface_only() && f.keeps_lower_cells() && f.keeps_cell_data(),
            "{f}"
        );
        assert_eq!(f.is_binary(), binary, "{f}");
    }
    assert_eq!(Format::from_path(Path::new("a.STL")).unwrap(), Format::StlBinary);
    assert_eq!(Format::from_path(Path::new("a.obj")).unwrap(), Format::Obj);
    assert_eq!(Format::from_path(Path::new("a.ply")).unwrap(), Format::PlyBinary);
    assert_eq!(Format::from_path(Path::new("a/b.vtp")).unwrap(), Format::Vtp);
    assert_eq!(Format::from_path(Path::new("B.VTP")).unwrap(), Format::Vtp);
    let e = Format::from_path(Path::new("b.xyz")).unwrap_err().to_string();
    assert!(e.contains(".vtp (VTK XML PolyData)"), "{e}");
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
    // a .vtp output is base64 but for an ASCII .vtp input (ASCII) and a
    // compressed VTK XML input (zlib); a .vtp input's encoding carries over
    // to the other formats as a .vtu's does
    assert_eq!(
        Format::following(&dir.path().join("out.vtp"), &ply).unwrap(),
        Format::Vtp
    );
    assert_eq!(
        Format::following(&dir.path().join("out.vtp"), &ascii).unwrap(),
        Format::Vtp
    );
    let out = |name: &str, input: &Path| Format::following(&dir.path().join(name), input).unwrap();
    for (f, vtp, vtu, vtk, ply) in [
        (
            Format::Vtp,
            Format::Vtp,
            Format::VtuBinary,
            Format::VtkBinary,
            Format::PlyBinary,
        ),
        (
            Format::VtpAscii,
            Format::VtpAscii,
            Format::VtuAscii,
            Format::VtkAscii,
            Format::PlyBinary,
        ),
        (
            Format::VtpZlib,
            Format::VtpZlib,
            Format::VtuZlib,
            Format::VtkBinary,
            Format::PlyBinary,
        ),
    ] {
        let input = dir.path().join(format!("in.{}.vtp", f.name()));
        io::write(&input, &m, f, &[]).unwrap();
        assert_eq!(Format::of_file(&input), Some(f));
        assert_eq!(io::read(&input).unwrap().points, m.points, "{f}");
        assert_eq!(out("out.vtp", &input), vtp, "{f}");
        assert_eq!(out("out.vtu", &input), vtu, "{f}");
        assert_eq!(out("out.vtk", &input), vtk, "{f}");
        assert_eq!(out("out.ply", &input), ply, "{f}");
    }
    for (f, vtp) in [
        (Format::VtuAscii, Format::Vtp),
        (Format::VtuBinary, Format::Vtp),
        (Format::VtuZlib, Format::VtpZlib),
    ] {
        let input = dir.path().join(format!("in.{}.vtu", f.name()));
        io::write(&input, &m, f, &[]).unwrap();
        assert_eq!(out("out.vtp", &input), vtp, "{f}");
    }
    // content wins over the extension, both ways
    let named_vtu = dir.path().join("really-polydata.vtu");
    io::write(&named_vtu, &m, Format::Vtp, &[]).unwrap();
    assert_eq!(Format::of_file(&named_vtu), Some(Format::Vtp));
    assert_eq!(io::read(&named_vtu).unwrap().conn, m.conn);
    let named_vtp = dir.path().join("really-grid.vtp");
    io::write(&named_vtp, &m, Format::VtuBinary, &[]).unwrap();
    assert_eq!(Format::of_file(&named_vtp), Some(Format::VtuBinary));
    assert_eq!(io::read(&named_vtp).unwrap().conn, m.conn);
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
/// or fail with an error naming the file; none panics or hangs. A `.vtp`
/// (ours in each encoding, an ASCII and an appended raw one with vertices,
/// lines and cell data) cut anywhere is refused with the byte offset.
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
    let extra = [
        ("vtk polydata", "vtk", poly.to_vec()),
        ("vtp ascii", "vtp", vtp_with_lower_cells().into_bytes()),
        ("vtp appended raw", "vtp", appended_raw_vtp()),
    ];
    for (f, ext, bytes) in files.into_iter().chain(extra) {
        let p = dir.path().join(format!("fuzz.{ext}"));
        let check = |b: &[u8], what: &str| -> Option<String> {
            std::fs::write(&p, b).unwrap();
            let r = std::panic::catch_unwind(|| io::read(&p));
            match r {
                Err(_) => panic!("{f}: {what} panicked"),
                Ok(Err(e)) => {
                    let e = e.to_string();
                    assert!(e.contains("fuzz."), "{f}: {what}: the error names no file: {e}");
                    Some(e)
                }
                Ok(Ok(_)) => None,
            }
        };
        assert!(check(&bytes, "the file itself").is_none(), "{f}");
        for cut in 0..bytes.len() {
            let e = check(&bytes[..cut], &format!("prefix {cut}"));
            // a cut of the trailing newline leaves the whole file
            if ext == "vtp" && cut > 0 && !bytes[cut..].iter().all(u8::is_ascii_whitespace) {
                let e = e.unwrap_or_else(|| panic!("{f}: prefix {cut} read"));
                assert!(e.contains("byte "), "{f}: prefix {cut}: no byte offset: {e}");
            }
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

/// A Python with `module` (meshio or vtk; see [`common::python_with`]).
fn python(module: &str) -> Option<PathBuf> {
    common::python_with(module, "the surface-format read-back tests")
}

fn run_py(python: &Path, script: &str, args: &[&Path]) -> serde_json::Value {
    let o = Command::new(python).args(["-c", script]).args(args).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&o.stdout)))
}

/// meshio reads what we write (points, triangles, the PLY arrays) and we
/// read what meshio writes, in every encoding it has. meshio 5.3 has no
/// `.vtp` reader or writer (VTK's own are tested below).
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
    for f in SURFACE.into_iter().filter(|&f| ext(f) != "vtp") {
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

/// VTK's readers (vtkSTLReader, vtkOBJReader, vtkPLYReader,
/// vtkXMLPolyDataReader) read ours with the same points and triangles, and
/// we read what VTK's writers write.
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
r = {'stl': vtk.vtkSTLReader, 'obj': vtk.vtkOBJReader, 'ply': vtk.vtkPLYReader, 'vtp': vtk.vtkXMLPolyDataReader}[p[-3:]]()
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
                        ('e.obj', vtk.vtkOBJWriter(), None), ('f.vtp', vtk.vtkXMLPolyDataWriter(), None)]:
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
    for name in ["a.stl", "b.stl", "c.ply", "d.ply", "e.obj", "f.vtp"] {
        let got = io::read(dir.path().join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(got.num_elements(), m.num_elements(), "{name}");
        assert_eq!(got.num_points(), m.num_points(), "{name}");
    }
}

/// VTK's vtkXMLPolyDataWriter builds a surface of triangles and
/// quadrilaterals with a vertex and a line, a point array and a cell array,
/// and writes it in every mode (ASCII, inline binary, appended base64 with
/// zlib, appended raw uncompressed with 64-bit headers and 32-bit ids); we
/// read each as that mesh, the cell array split between the polygons and
/// the lower cells in VTK's order.
#[test]
fn we_read_vtks_xml_polydata_in_every_mode() {
    let Some(py) = python("vtk") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let write = r#"
import sys, json, vtk
d, nx, ny = sys.argv[1], 4, 3
pts = vtk.vtkPoints()
pts.SetDataTypeToDouble()
P = [(i * 0.5, j * 0.25, (i * j % 3) * 0.125) for j in range(ny + 1) for i in range(nx + 1)]
for p in P:
    pts.InsertNextPoint(p)
at = lambda i, j: j * (nx + 1) + i
polys = []
for j in range(ny):
    for i in range(nx):
        a, b, c, e = at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)
        polys += [[a, b, c, e]] if (i + j) % 2 == 0 else [[a, b, c], [a, c, e]]
verts, lines = [[at(nx, ny)]], [[at(0, 0), at(1, 0)]]
pd = vtk.vtkPolyData()
pd.SetPoints(pts)
for cells, put in [(verts, pd.SetVerts), (lines, pd.SetLines), (polys, pd.SetPolys)]:
    ca = vtk.vtkCellArray()
    for c in cells:
        ca.InsertNextCell(len(c), c)
    put(ca)
h = vtk.vtkDoubleArray()
h.SetName('h')
for k, p in enumerate(P):
    h.InsertNextValue(p[0] + 2 * p[1] + k)
pd.GetPointData().AddArray(h)
c = vtk.vtkIntArray()
c.SetName('c')
for k in range(pd.GetNumberOfCells()):
    c.InsertNextValue(100 + k)
pd.GetCellData().AddArray(c)
for name, mode in [('ascii', 'Ascii'), ('binary', 'Binary'), ('appended', 'Appended'), ('raw', 'Appended')]:
    w = vtk.vtkXMLPolyDataWriter()
    w.SetInputData(pd)
    w.SetFileName(d + '/' + name + '.vtp')
    getattr(w, 'SetDataModeTo' + mode)()
    if name == 'raw':
        w.SetCompressorTypeToNone()
        w.EncodeAppendedDataOff()
        w.SetHeaderTypeToUInt64()
        w.SetIdTypeToInt32()
    assert w.Write() == 1
print(json.dumps({'points': P, 'verts': verts, 'lines': lines, 'polys': polys,
                  'h': [h.GetValue(k) for k in range(len(P))], 'c': [c.GetValue(k) for k in range(c.GetNumberOfTuples())]}))
"#;
    let want = run_py(&py, write, &[dir.path()]);
    let ints =
        |v: &serde_json::Value| -> Vec<i64> { v.as_array().unwrap().iter().map(|x| x.as_i64().unwrap()).collect() };
    let cells = |v: &serde_json::Value| -> Vec<Vec<u32>> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|c| ints(c).into_iter().map(|i| i as u32).collect())
            .collect()
    };
    let points: Vec<[f64; 3]> = want["points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| [0, 1, 2].map(|k| p[k].as_f64().unwrap()))
        .collect();
    let polys = cells(&want["polys"]);
    let (verts, lines) = (cells(&want["verts"]), cells(&want["lines"]));
    let h: Vec<f64> = want["h"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let c = ints(&want["c"]);
    let nl = verts.len() + lines.len();
    assert!(polys.iter().any(|p| p.len() == 3) && polys.iter().any(|p| p.len() == 4));
    // VTK compresses with zlib unless told not to
    for (name, f) in [
        ("ascii", Format::VtpAscii),
        ("binary", Format::VtpZlib),
        ("appended", Format::VtpZlib),
        ("raw", Format::Vtp),
    ] {
        let p = dir.path().join(format!("{name}.vtp"));
        assert_eq!(Format::of_file(&p), Some(f), "{name}");
        let m = io::read(&p).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(m.points, points, "{name}: points");
        assert_eq!(m.num_elements(), polys.len(), "{name}");
        let elements: Vec<Vec<u32>> = (0..m.num_elements()).map(|e| m.element(e).to_vec()).collect();
        assert_eq!(elements, polys, "{name}: polygons");
        let kinds: Vec<ElementKind> = polys
            .iter()
            .map(|p| {
                if p.len() == 3 {
                    ElementKind::Triangle
                } else {
                    ElementKind::Quadrilateral
                }
            })
            .collect();
        assert_eq!(m.kinds, kinds, "{name}");
        let lower: Vec<(LowerKind, Vec<u32>)> = verts
            .iter()
            .map(|v| (LowerKind::Vertex, v.clone()))
            .chain(lines.iter().map(|l| (LowerKind::Line, l.clone())))
            .collect();
        assert_eq!(m.lower, lower, "{name}: vertices and lines");
        let ha = m.data.point.iter().find(|a| a.name == "h").unwrap();
        assert_eq!(
            (ha.ty, &ha.values),
            (ValueType::F64, &Values::Float(h.clone())),
            "{name}: h"
        );
        let ca = m.data.cell_array("c").unwrap();
        assert_eq!(
            (ca.ty, &ca.values),
            (ValueType::I32, &Values::Int(c[nl..].to_vec())),
            "{name}: c"
        );
        assert_eq!(
            m.data.lower_array("c").unwrap().values,
            Values::Int(c[..nl].to_vec()),
            "{name}"
        );
    }
}

/// A surface of triangles and quadrilaterals with a boundary vertex and
/// line, point arrays, a cell array (with values on the lower cells) and
/// an element set.
fn decorated_mixed_surface() -> Mesh {
    let cube = quad_cube(3);
    let mut m = Mesh::new(cube.points.clone());
    for e in 0..cube.num_elements() {
        let q = cube.element(e);
        if e % 3 == 0 {
            m.push_element(ElementKind::Triangle, &[q[0], q[1], q[2]]);
            m.push_element(ElementKind::Triangle, &[q[0], q[2], q[3]]);
        } else {
            m.push_element(ElementKind::Quadrilateral, q);
        }
    }
    let (np, ne) = (m.num_points(), m.num_elements());
    // a line first: VTK's order puts the vertex before it
    let (a, b) = (m.element(1)[0], m.element(1)[1]);
    m.lower = vec![
        (LowerKind::Line, vec![a, b]),
        (LowerKind::Vertex, vec![m.element(5)[2]]),
    ];
    m.data.point.push(DataArray::new(
        "height",
        ValueType::F64,
        1,
        Values::Float(m.points.iter().map(|p| p[2] * 0.5 + p[0]).collect()),
    ));
    m.data.point.push(DataArray::new(
        "uv",
        ValueType::F32,
        2,
        // whole numbers: exact as 32-bit floats
        Values::Float(
            m.points
                .iter()
                .flat_map(|p| [(p[0] * 3.0).round(), (p[1] * 3.0).round()])
                .collect(),
        ),
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
    m.data
        .lower
        .push(DataArray::new("region", ValueType::U8, 1, Values::Int(vec![7, 8])));
    m.data.element_sets.push(ElementSet {
        name: "first".into(),
        elements: (0..ne as u32 / 3).collect(),
        lower: Vec::new(),
    });
    m
}

/// VTK's vtkXMLPolyDataReader reads our `.vtp`, in each encoding, as the
/// mesh it holds: the same points, polygons, vertices and lines, and every
/// point, cell and field array with its values (the cell arrays in VTK's
/// order: vertices, lines, polygons; VTK reads each part of them from its
/// own offset into the array).
#[test]
fn vtk_reads_our_vtp_with_its_cells_and_arrays() {
    let Some(py) = python("vtk") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let m = decorated_mixed_surface();
    let eta: Vec<f64> = (0..m.num_elements()).map(|e| 1.0 + e as f64 / 64.0).collect();
    let read = r#"
import sys, json, vtk
r = vtk.vtkXMLPolyDataReader()
r.SetFileName(sys.argv[1])
r.Update()
o = r.GetOutput()
def cells(ca):
    out, ids = [], vtk.vtkIdList()
    ca.InitTraversal()
    while ca.GetNextCell(ids):
        out.append([ids.GetId(k) for k in range(ids.GetNumberOfIds())])
    return out
def arrays(d):
    out = {}
    for k in range(d.GetNumberOfArrays()):
        a = d.GetAbstractArray(k)
        n, m = a.GetNumberOfTuples(), a.GetNumberOfComponents()
        v = [a.GetComponent(i, j) for i in range(n) for j in range(m)] if a.IsNumeric() else []
        out[a.GetName()] = {'type': a.GetDataTypeAsString(), 'components': m, 'tuples': n,
                            'values': [None if x != x else x for x in v]}
    return out
print(json.dumps({'errors': r.GetErrorCode(), 'points': [list(o.GetPoint(i)) for i in range(o.GetNumberOfPoints())],
                  'verts': cells(o.GetVerts()), 'lines': cells(o.GetLines()), 'polys': cells(o.GetPolys()),
                  'strips': o.GetNumberOfStrips(), 'cells': o.GetNumberOfCells(),
                  'point_data': arrays(o.GetPointData()), 'cell_data': arrays(o.GetCellData()),
                  'field_data': arrays(o.GetFieldData())}))
"#;
    let near = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1.0);
    let cells = |v: &serde_json::Value| -> Vec<Vec<u32>> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|c| {
                c.as_array()
                    .unwrap()
                    .iter()
                    .map(|x| x.as_u64().unwrap() as u32)
                    .collect()
            })
            .collect()
    };
    let elements: Vec<Vec<u32>> = (0..m.num_elements()).map(|e| m.element(e).to_vec()).collect();
    for f in [Format::Vtp, Format::VtpAscii, Format::VtpZlib] {
        let p = dir.path().join(format!("ours.{}.vtp", f.name()));
        io::write(
            &p,
            &m,
            f,
            &[io::CellData {
                name: "eta",
                values: &eta,
            }],
        )
        .unwrap();
        let got = run_py(&py, read, &[&p]);
        assert_eq!(got["errors"], 0, "{f}: {got}");
        let points = got["points"].as_array().unwrap();
        assert_eq!(points.len(), m.num_points(), "{f}");
        for (i, q) in points.iter().enumerate() {
            assert!(
                (0..3).all(|k| near(q[k].as_f64().unwrap(), m.points[i][k])),
                "{f}: point {i}: {q}"
            );
        }
        assert_eq!(cells(&got["polys"]), elements, "{f}");
        assert_eq!(cells(&got["verts"]), vec![m.lower[1].1.clone()], "{f}");
        assert_eq!(cells(&got["lines"]), vec![m.lower[0].1.clone()], "{f}");
        assert_eq!(
            (got["strips"].as_u64(), got["cells"].as_u64()),
            (Some(0), Some(m.num_elements() as u64 + 2)),
            "{f}"
        );
        let check = |what: &str, arrays: &serde_json::Value, name: &str, ty: &str, want: &[Option<f64>]| {
            let a = &arrays[name];
            assert_eq!(a["type"], ty, "{f}: {what} {name}: {a}");
            let values = a["values"]
                .as_array()
                .unwrap_or_else(|| panic!("{f}: no {what} array {name}: {arrays}"));
            assert_eq!(values.len(), want.len(), "{f}: {what} {name}");
            for (i, (v, w)) in values.iter().zip(want).enumerate() {
                match w {
                    Some(w) => assert!(
                        v.as_f64().is_some_and(|v| near(v, *w)),
                        "{f}: {what} {name}[{i}]: {v} for {w}"
                    ),
                    None => assert!(v.is_null(), "{f}: {what} {name}[{i}]: {v} for NaN"),
                }
            }
        };
        let pd = &got["point_data"];
        for a in &m.data.point {
            let want: Vec<Option<f64>> = (0..a.values.len()).map(|i| Some(a.get_f64(i))).collect();
            let ty = match a.ty {
                ValueType::F64 => "double",
                ValueType::F32 => "float",
                _ => "int",
            };
            check("point", pd, &a.name, ty, &want);
            assert_eq!(pd[&a.name]["components"], a.components, "{f}: {}", a.name);
        }
        // cell arrays: the vertex, the line, then the polygons
        let region = m.data.cell_array("region").unwrap();
        let want: Vec<Option<f64>> = [Some(8.0), Some(7.0)]
            .into_iter()
            .chain((0..m.num_elements()).map(|e| Some(region.get_f64(e))))
            .collect();
        check("cell", &got["cell_data"], "region", "unsigned char", &want);
        let want: Vec<Option<f64>> = [None, None].into_iter().chain(eta.iter().map(|&q| Some(q))).collect();
        check("cell", &got["cell_data"], "eta", "double", &want);
        // a set's elements by their cells' numbers in the file: after the vertex and the line
        let set: Vec<Option<f64>> = m.data.element_sets[0]
            .elements
            .iter()
            .map(|&e| Some(f64::from(e) + 2.0))
            .collect();
        check("field", &got["field_data"], "element_set:first", "long long", &set);
        // and we read it back as written, the lower cells in VTK's order
        let back = io::read(&p).unwrap();
        assert_eq!(
            (&back.points, &back.kinds, &back.conn),
            (&m.points, &m.kinds, &m.conn),
            "{f}"
        );
        let mut lower = m.lower.clone();
        lower.reverse();
        assert_eq!(back.lower, lower, "{f}");
        assert_eq!(back.data.point, m.data.point, "{f}");
        assert_eq!(back.data.cell_array("region"), m.data.cell_array("region"), "{f}");
        assert_eq!(
            back.data.lower_array("region").unwrap().values,
            Values::Int(vec![8, 7]),
            "{f}"
        );
        assert_eq!(
            back.data.cell_array("eta").unwrap().values,
            Values::Float(eta.clone()),
            "{f}"
        );
        assert_eq!(back.data.element_sets, m.data.element_sets, "{f}");
    }
}

/// `meshsmooth quality` reads an STL surface (Gmsh's sphere where Gmsh is
/// installed, else ours) as it reads the same surface in legacy VTK and
/// VTK XML PolyData; `smooth` writes a `.vtp` output, which reads back as
/// the same surface.
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
    let vtp = dir.path().join("sphere.vtp");
    io::write(&vtp, &m, Format::Vtp, &[]).unwrap();
    let (a, b, c) = (
        meshsmooth(&["quality", s(&stl), "--json"]),
        meshsmooth(&["quality", s(&vtk), "--json"]),
        meshsmooth(&["quality", s(&vtp), "--json"]),
    );
    assert_eq!(a.status.success(), b.status.success(), "{}\n{}", text(&a), text(&b));
    assert_eq!(text(&a).replace(s(&stl), "F"), text(&b).replace(s(&vtk), "F"));
    assert_eq!(text(&a).replace(s(&stl), "F"), text(&c).replace(s(&vtp), "F"));
    // smooth to .vtp (the quality array with it), and --format vtp-ascii to
    // any name; a volume mesh is refused naming the element and the format
    let out = dir.path().join("out.vtp");
    let o = meshsmooth(&["smooth", s(&vtp), "-o", s(&out), "--max-iter", "2"]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(Format::of_file(&out), Some(Format::Vtp), "{}", text(&o));
    let got = io::read(&out).unwrap();
    assert_eq!((got.num_points(), &got.conn), (m.num_points(), &m.conn));
    assert_ne!(got.points, m.points, "smoothing moved nothing");
    let q = got.data.cell_array("inverse_mean_ratio").expect("the quality array");
    assert!((0..q.tuples()).all(|e| q.get_f64(e) >= 1.0 - 1e-9), "{q:?}");
    let other = dir.path().join("out.surface");
    let o = meshsmooth(&[
        "smooth",
        s(&vtp),
        "-o",
        s(&other),
        "--format",
        "vtp-ascii",
        "--max-iter",
        "2",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(Format::of_file(&other), Some(Format::VtpAscii), "{}", text(&o));
    assert_eq!(io::read(&other).unwrap().conn, m.conn);
    let boxed = dir.path().join("box.vtk");
    io::write(&boxed, &common::perturbed_box(2, 0.1, 3), Format::VtkAscii, &[]).unwrap();
    let bad = dir.path().join("box.vtp");
    let o = meshsmooth(&["smooth", s(&boxed), "-o", s(&bad), "--max-iter", "2"]);
    assert!(!o.status.success() && !bad.exists(), "{}", text(&o));
    let want = "element 0 is a tetrahedron, and the vtp format holds surfaces of triangles and quadrilaterals only \
                (write a volume mesh as .vtu)";
    assert!(text(&o).contains(want) && text(&o).contains("box.vtp"), "{}", text(&o));
    let o = meshsmooth(&["smooth", s(&boxed), "-o", s(&bad), "--format", "vtq"]);
    assert!(!o.status.success(), "{}", text(&o));
    let t = text(&o);
    assert!(
        t.contains("unknown format 'vtq'") && t.contains("vtp, vtp-ascii, vtp-zlib"),
        "{t}"
    );
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

/// A VTK XML PolyData file in ASCII with five points: `piece` the
/// `<Piece>`'s cell counts, `body` its cell sections and data.
fn ascii_vtp(piece: &str, body: &str) -> String {
    format!(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\">\n\
         <PolyData>\n<Piece NumberOfPoints=\"5\" {piece}>\n<Points>\n\
         <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">0 0 0 1 0 0 1 1 0 0 1 0 2 0 0</DataArray>\n\
         </Points>\n{body}</Piece>\n</PolyData>\n</VTKFile>\n"
    )
}

/// A PolyData cell section (`Verts`, `Lines`, `Polys`, `Strips`) in ASCII.
fn vtp_cells(tag: &str, conn: &str, offsets: &str) -> String {
    format!(
        "<{tag}>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">{conn}</DataArray>\n\
         <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">{offsets}</DataArray>\n</{tag}>\n"
    )
}

/// One vertex, one line, a triangle and a quadrilateral, with a point array
/// `h` and a cell array `id` (10, 11 for the vertex and the line, 12, 13
/// for the polygons: VTK's cell order).
fn vtp_with_lower_cells() -> String {
    let body = [
        "<PointData>\n<DataArray type=\"Float64\" Name=\"h\" format=\"ascii\">0 1 2 3 4</DataArray>\n</PointData>\n",
        "<CellData>\n<DataArray type=\"Int32\" Name=\"id\" format=\"ascii\">10 11 12 13</DataArray>\n</CellData>\n",
        &vtp_cells("Verts", "4", "1"),
        &vtp_cells("Lines", "0 1", "2"),
        &vtp_cells("Polys", "1 4 2 0 1 2 3", "3 7"),
    ]
    .concat();
    ascii_vtp(
        "NumberOfVerts=\"1\" NumberOfLines=\"1\" NumberOfStrips=\"0\" NumberOfPolys=\"2\"",
        &body,
    )
}

/// The file of [`vtp_with_lower_cells`] with its arrays appended raw
/// (UInt32 headers, Float32 points, Int32 ids and offsets), as VTK writes
/// it uncompressed.
fn appended_raw_vtp() -> Vec<u8> {
    let f32s = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let i32s = |v: &[i32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let arrays: [(&str, &str, &str, Vec<u8>); 10] = [
        ("PointData", "Float32", "h", f32s(&[0.0, 1.0, 2.0, 3.0, 4.0])),
        ("CellData", "Int32", "id", i32s(&[10, 11, 12, 13])),
        (
            "Points",
            "Float32",
            "Points",
            f32s(&[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0., 2., 0., 0.]),
        ),
        ("Verts", "Int32", "connectivity", i32s(&[4])),
        ("Verts", "Int32", "offsets", i32s(&[1])),
        ("Lines", "Int32", "connectivity", i32s(&[0, 1])),
        ("Lines", "Int32", "offsets", i32s(&[2])),
        ("Polys", "Int32", "connectivity", i32s(&[1, 4, 2, 0, 1, 2, 3])),
        ("Polys", "Int32", "offsets", i32s(&[3, 7])),
        ("Strips", "Int32", "connectivity", Vec::new()),
    ];
    let mut xml = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\" \
         header_type=\"UInt32\">\n<PolyData>\n<Piece NumberOfPoints=\"5\" NumberOfVerts=\"1\" NumberOfLines=\"1\" \
         NumberOfStrips=\"0\" NumberOfPolys=\"2\">\n",
    );
    let mut blob = Vec::new();
    let mut open: Option<&str> = None;
    for (section, ty, name, bytes) in arrays {
        if open != Some(section) {
            if let Some(o) = open {
                xml += &format!("</{o}>\n");
            }
            xml += &format!("<{section}>\n");
            open = Some(section);
        }
        let components = if name == "Points" { 3 } else { 1 };
        xml += &format!(
            "<DataArray type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"{components}\" format=\"appended\" offset=\"{}\"/>\n",
            blob.len()
        );
        blob.extend((bytes.len() as u32).to_le_bytes());
        blob.extend(bytes);
    }
    xml += &format!(
        "</{}>\n</Piece>\n</PolyData>\n<AppendedData encoding=\"raw\">\n_",
        open.unwrap()
    );
    let mut out = xml.into_bytes();
    out.extend(blob);
    out.extend(b"\n</AppendedData>\n</VTKFile>\n");
    out
}

/// XML PolyData: polygons as elements, vertices and lines as lower cells,
/// cell arrays over all of them in VTK's order (vertices, lines,
/// polygons), ASCII and appended raw; written back the same, the lower
/// cells grouped in VTK's order with their cell data.
#[test]
fn vtp_reads_polygons_lines_and_vertices_and_writes_them_back() {
    let dir = tempfile::tempdir().unwrap();
    let (ascii, raw) = (dir.path().join("ascii.vtp"), dir.path().join("raw.vtp"));
    std::fs::write(&ascii, vtp_with_lower_cells()).unwrap();
    std::fs::write(&raw, appended_raw_vtp()).unwrap();
    for (p, f) in [(&ascii, Format::VtpAscii), (&raw, Format::Vtp)] {
        assert_eq!(Format::of_file(p), Some(f), "{}", p.display());
        let m = io::read(p).unwrap_or_else(|e| panic!("{e}"));
        let ctx = p.display().to_string();
        assert_eq!(
            m.kinds,
            vec![ElementKind::Triangle, ElementKind::Quadrilateral],
            "{ctx}"
        );
        assert_eq!(m.conn, vec![1, 4, 2, 0, 1, 2, 3], "{ctx}");
        assert_eq!(
            m.lower,
            vec![(LowerKind::Vertex, vec![4]), (LowerKind::Line, vec![0, 1])],
            "{ctx}"
        );
        assert_eq!(m.points[4], [2.0, 0.0, 0.0], "{ctx}");
        let id = m.data.cell_array("id").unwrap();
        assert_eq!(id.values, Values::Int(vec![12, 13]), "{ctx}");
        assert_eq!(
            m.data.lower_array("id").unwrap().values,
            Values::Int(vec![10, 11]),
            "{ctx}"
        );
        let h = m.data.point.iter().find(|a| a.name == "h").unwrap();
        assert_eq!(h.values, Values::Float(vec![0.0, 1.0, 2.0, 3.0, 4.0]), "{ctx}");
        // the lower cells' vertices are fixed
        assert!(m.fixed[0] && m.fixed[1] && m.fixed[4], "{ctx}: {:?}", m.fixed);
    }
    let m = io::read(&ascii).unwrap();
    let back = dir.path().join("back.vtp");
    io::write(&back, &m, Format::Vtp, &[]).unwrap();
    let got = io::read(&back).unwrap();
    assert_eq!((&got.points, &got.kinds, &got.conn), (&m.points, &m.kinds, &m.conn));
    assert_eq!((&got.lower, &got.fixed), (&m.lower, &m.fixed));
    assert_eq!(got.data.point, m.data.point);
    assert_eq!(got.data.cell, m.data.cell);
    assert_eq!(got.data.lower, m.data.lower);
    // lower cells line first: written (and read back) vertices first, their
    // cell data with them; the quality array's lower values are NaN
    let mut swapped = m.clone();
    swapped.lower.reverse();
    for a in &mut swapped.data.lower {
        *a = a.select(&[1, 0]);
    }
    let q = [0.5, 0.75];
    io::write(
        &back,
        &swapped,
        Format::Vtp,
        &[io::CellData {
            name: "eta",
            values: &q,
        }],
    )
    .unwrap();
    let got = io::read(&back).unwrap();
    assert_eq!(got.lower, m.lower);
    assert_eq!(got.data.lower_array("id"), m.data.lower_array("id"));
    assert_eq!(got.data.cell_array("eta").unwrap().values, Values::Float(q.to_vec()));
    let eta = got.data.lower_array("eta").unwrap();
    assert!((0..2).all(|i| eta.get_f64(i).is_nan()), "{eta:?}");
    // a boundary face has no place in a PolyData: refused naming it, nothing written
    let mut faced = sphere(1);
    faced.lower.push((LowerKind::Triangle, vec![0, 2, 4]));
    let out = dir.path().join("faced.vtp");
    let e = io::write(&out, &faced, Format::Vtp, &[]).unwrap_err().to_string();
    assert!(
        e.contains("faced.vtp") && e.contains("boundary cell 0 is a triangle") && e.contains("vertices and lines"),
        "{e}"
    );
    assert!(!out.exists());
    let mut sink = Vec::new();
    assert!(io::write_to(&mut sink, &out, &faced, Format::Vtp, &[]).is_err());
    assert!(sink.is_empty(), "{} bytes written", sink.len());
    // quality values that do not fit the elements: refused, nothing left behind
    let e = io::write(
        &out,
        &m,
        Format::Vtp,
        &[io::CellData {
            name: "q",
            values: &[1.0],
        }],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("1 values") && e.contains("2 elements"), "{e}");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        3,
        "only ascii, raw and back"
    );
}

/// What a PolyData may not hold is refused naming the cell (its number in
/// VTK's order and its place in its section) and the byte offset.
#[test]
fn bad_vtp_files_are_refused_naming_the_cell_and_where() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.vtp");
    let polys = |n: usize, conn: &str, offs: &str| {
        ascii_vtp(&format!("NumberOfPolys=\"{n}\""), &vtp_cells("Polys", conn, offs))
    };
    let cases: Vec<(String, Vec<&str>)> = vec![
        (
            ascii_vtp("NumberOfStrips=\"1\"", &vtp_cells("Strips", "0 1 3 2", "4")),
            vec![
                "cell 0 (Strips 0) is a triangle strip, one of 1",
                "not supported",
                "byte",
            ],
        ),
        // numbered after the vertices and polygons before them
        (
            ascii_vtp(
                "NumberOfVerts=\"1\" NumberOfPolys=\"2\" NumberOfStrips=\"2\"",
                &[
                    vtp_cells("Verts", "4", "1"),
                    vtp_cells("Polys", "0 1 2 0 2 3", "3 6"),
                    vtp_cells("Strips", "0 1 3 2 1 4 2", "4 7"),
                ]
                .concat(),
            ),
            vec![
                "cell 3 (Strips 0) is a triangle strip, one of 2 (NumberOfStrips)",
                "byte",
            ],
        ),
        (
            polys(1, "0 1 4 2 3", "5"),
            vec!["cell 0 (Polys 0) is a polygon of 5 vertices", "byte"],
        ),
        (
            ascii_vtp(
                "NumberOfVerts=\"1\" NumberOfPolys=\"2\"",
                &(vtp_cells("Verts", "4", "1") + &vtp_cells("Polys", "0 1 2 0 1 4 2 3", "3 8")),
            ),
            vec!["cell 2 (Polys 1) is a polygon of 5 vertices", "byte"],
        ),
        (
            ascii_vtp("NumberOfLines=\"1\"", &vtp_cells("Lines", "0 1 2", "3")),
            vec!["cell 0 (Lines 0) is a polyline of 3 points", "byte"],
        ),
        (
            ascii_vtp("NumberOfVerts=\"1\"", &vtp_cells("Verts", "0 1", "2")),
            vec!["cell 0 (Verts 0) is a poly-vertex of 2 points", "byte"],
        ),
        (
            polys(1, "0 1 9", "3"),
            vec!["cell 0 (Polys 0) refers to vertex 9, but the file has 5 points", "byte"],
        ),
        (
            polys(2, "0 1 2", "3 9"),
            vec!["Polys offset 1 is 9", "connectivity size 3", "byte"],
        ),
        (
            polys(2, "0 1 2 0 2 3", "3"),
            vec!["Polys offsets: expected 2 values (NumberOfPolys), found 1", "byte"],
        ),
        (
            ascii_vtp("NumberOfPolys=\"1\"", ""),
            vec!["missing Polys DataArray 'connectivity' (NumberOfPolys is 1)"],
        ),
        (
            ascii_vtp(
                "NumberOfPolys=\"1\"",
                &(vtp_cells("Polys", "0 1 2", "3")
                    + "<CellData>\n<DataArray type=\"Int32\" Name=\"c\" format=\"ascii\">1 2</DataArray>\n</CellData>\n"),
            ),
            vec!["array 'c' has 2 values", "1 cells"],
        ),
        (
            ascii_vtp(
                "NumberOfPolys=\"1\"",
                "<Polys>\n<DataArray type=\"Float64\" Name=\"connectivity\" format=\"ascii\">0 1 2.5</DataArray>\n\
                 <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">3</DataArray>\n</Polys>\n",
            ),
            vec!["'connectivity' holds 2.5, which is not a whole number", "byte"],
        ),
        (
            polys(1, "0 1 2", "3").replace("NumberOfPolys=\"1\"", "NumberOfPolys=\"many\""),
            vec!["NumberOfPolys must be a count, found 'many'", "byte"],
        ),
        // a huge declared count is refused before anything is allocated for it
        (
            polys(1, "0 1 2", "3").replace("NumberOfPolys=\"1\"", "NumberOfPolys=\"4000000000000000\""),
            vec!["5 points and 4000000000000000 cells", "memory budget", "byte"],
        ),
        (
            polys(1, "0 1 2", "3").replace("type=\"PolyData\"", "type=\"ImageData\""),
            vec!["VTKFile type 'ImageData' is not supported", "PolyData (.vtp)", "byte"],
        ),
    ];
    for (content, needles) in &cases {
        expect_err(&p, content.as_bytes(), needles);
    }
    // a PolyData's cells are its sections': a <Cells> in it is not read as cells
    let cells = "<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">0 1 2 3</DataArray>\n\
                 <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">4</DataArray>\n\
                 <DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">9</DataArray>\n</Cells>\n";
    std::fs::write(
        &p,
        polys(1, "0 1 2", "3").replace("<Points>", &format!("{cells}<Points>")),
    )
    .unwrap();
    let m = io::read(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        (m.kinds.clone(), m.conn.clone()),
        (vec![ElementKind::Triangle], vec![0, 1, 2])
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
