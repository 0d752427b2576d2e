//! Every format writes and reads back every element kind exactly, and the
//! real meshes in `../shared/meshes` (when present) read with the documented counts.

use std::path::Path;

use meshsmooth::io::{self, CellData, Format};
use meshsmooth::mesh::{ElementKind, LowerKind, Mesh};

/// Structured grid points with coordinates that have no short decimal form,
/// so the text writers must print them with full precision.
fn grid_points(nx: usize, ny: usize, nz: usize, scale: f64, z0: f64) -> Vec<[f64; 3]> {
    let mut pts = Vec::new();
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                let (x, y, z) = (i as f64, j as f64, k as f64);
                pts.push([
                    scale * (x / 3.0 + 0.01 * (y * 1.7).sin()),
                    scale * (y / 7.0 + 1e-9 * x.sqrt()),
                    if nz == 0 { z0 } else { scale * (z / 11.0 + z0) },
                ]);
            }
        }
    }
    pts
}

/// The 8 corners of grid cell (i,j,k) in VTK hexahedron order.
fn cube(nx: usize, ny: usize, i: usize, j: usize, k: usize) -> [u32; 8] {
    let id = |i: usize, j: usize, k: usize| ((k * (ny + 1) + j) * (nx + 1) + i) as u32;
    [
        id(i, j, k),
        id(i + 1, j, k),
        id(i + 1, j + 1, k),
        id(i, j + 1, k),
        id(i, j, k + 1),
        id(i + 1, j, k + 1),
        id(i + 1, j + 1, k + 1),
        id(i, j + 1, k + 1),
    ]
}

fn push_split(m: &mut Mesh, kind: ElementKind, c: [u32; 8]) {
    match kind {
        ElementKind::Hexahedron => m.push_element(kind, &c),
        ElementKind::Prism => {
            m.push_element(kind, &[c[0], c[1], c[2], c[4], c[5], c[6]]);
            m.push_element(kind, &[c[0], c[2], c[3], c[4], c[6], c[7]]);
        }
        ElementKind::Tetrahedron => {
            for t in [
                [0, 1, 2, 6],
                [0, 2, 3, 6],
                [0, 3, 7, 6],
                [0, 7, 4, 6],
                [0, 4, 5, 6],
                [0, 5, 1, 6],
            ] {
                m.push_element(kind, &t.map(|i| c[i]));
            }
        }
        _ => unreachable!(),
    }
}

/// 3D grid mesh; `pick(cell index)` chooses how each grid cell is split.
fn mesh3d(n: usize, scale: f64, pick: impl Fn(usize) -> ElementKind) -> Mesh {
    let mut m = Mesh::new(grid_points(n, n, n, scale, 0.5));
    let mut cell = 0;
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                push_split(&mut m, pick(cell), cube(n, n, i, j, k));
                cell += 1;
            }
        }
    }
    m
}

fn mesh2d(n: usize, z: f64, pick: impl Fn(usize) -> ElementKind) -> Mesh {
    let mut m = Mesh::new(grid_points(n, n, 0, 1.0, z));
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    for j in 0..n {
        for i in 0..n {
            let q = [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)];
            match pick(j * n + i) {
                ElementKind::Quadrilateral => m.push_element(ElementKind::Quadrilateral, &q),
                _ => {
                    m.push_element(ElementKind::Triangle, &[q[0], q[1], q[2]]);
                    m.push_element(ElementKind::Triangle, &[q[0], q[2], q[3]]);
                }
            }
        }
    }
    m
}

/// Add boundary cells (grouped by kind, as Medit stores them) and fix their vertices.
fn with_lower(mut m: Mesh, lower: Vec<(LowerKind, Vec<u32>)>) -> Mesh {
    m.fixed = vec![false; m.num_points()];
    for (_, vs) in &lower {
        for &v in vs {
            m.fixed[v as usize] = true;
        }
    }
    m.lower = lower;
    m
}

fn test_meshes() -> Vec<(&'static str, Mesh)> {
    use ElementKind::*;
    let n = 3;
    let bottom = |m: &Mesh| -> Vec<(LowerKind, Vec<u32>)> {
        let _ = m;
        vec![
            (LowerKind::Triangle, vec![0, 1, 5]),
            (LowerKind::Triangle, vec![0, 5, 4]),
            (LowerKind::Quadrilateral, vec![1, 2, 6, 5]),
            (LowerKind::Line, vec![2, 3]),
            (LowerKind::Vertex, vec![63]),
        ]
    };
    let tet = mesh3d(n, 1.0, |_| Tetrahedron);
    let tet = with_lower(tet.clone(), bottom(&tet));
    let hex = mesh3d(n, 1e-7, |_| Hexahedron);
    let mut prism = mesh3d(n, 1234.5, |_| Prism);
    prism.fixed = (0..prism.num_points()).map(|v| v % 5 == 0).collect();
    let mixed = mesh3d(n, 1.0, |c| [Hexahedron, Prism, Tetrahedron][c % 3]);
    let mixed = with_lower(mixed.clone(), bottom(&mixed));
    let grouped = mesh3d(n, 1.0, |c| [Hexahedron, Prism, Tetrahedron][c * 3 / 27]);
    let tri = mesh2d(4, 0.0, |_| Triangle);
    let tri = with_lower(
        tri,
        vec![
            (LowerKind::Line, vec![0, 1]),
            (LowerKind::Line, vec![1, 2]),
            (LowerKind::Vertex, vec![24]),
        ],
    );
    let tri_z5 = mesh2d(4, 5.0, |_| Triangle);
    let quad = mesh2d(4, 0.0, |_| Quadrilateral);
    let mixed2d = mesh2d(4, 0.0, |c| if c % 2 == 0 { Quadrilateral } else { Triangle });
    let mut grouped2d = mesh2d(4, 0.0, |c| if c < 8 { Quadrilateral } else { Triangle });
    grouped2d.fixed = (0..grouped2d.num_points()).map(|v| v < 5).collect();
    let meshes = vec![
        ("tet", tet),
        ("hex", hex),
        ("prism", prism),
        ("mixed-hex-prism-tet", mixed),
        ("grouped-hex-prism-tet", grouped),
        ("tri", tri),
        ("tri-z5", tri_z5),
        ("quad", quad),
        ("mixed-tri-quad", mixed2d),
        ("grouped-quad-tri", grouped2d),
    ];
    for (name, m) in &meshes {
        m.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    meshes
}

fn ext(f: Format) -> &'static str {
    match f {
        Format::VtkAscii | Format::VtkBinary => "vtk",
        Format::VtuAscii | Format::VtuBinary | Format::VtuZlib => "vtu",
        Format::Medit => "mesh",
        Format::Exodus => "exo",
        Format::VtkHdf => "vtkhdf",
        _ => "msh",
    }
}

fn bits(m: &Mesh) -> Vec<[u64; 3]> {
    m.points.iter().map(|p| p.map(f64::to_bits)).collect()
}

fn fixed(m: &Mesh) -> Vec<bool> {
    (0..m.num_points()).map(|v| m.is_fixed(v)).collect()
}

/// Medit stores elements grouped by kind; interleaved meshes cannot round-trip there.
fn is_grouped(m: &Mesh) -> bool {
    let mut seen = Vec::new();
    m.kinds.iter().all(|k| {
        if seen.last() != Some(k) {
            if seen.contains(k) {
                return false;
            }
            seen.push(*k);
        }
        true
    })
}

#[test]
fn every_format_round_trips_every_mesh() {
    let dir = tempfile::tempdir().unwrap();
    for (name, m) in test_meshes() {
        // the surface formats hold no volumes nor lower cells: `surface_formats` covers them
        for f in Format::ALL.into_iter().filter(|f| !f.is_surface_only()) {
            // Medit, Abaqus and Exodus write one block per kind: interleaved kinds come back grouped
            if matches!(f, Format::Medit | Format::Abaqus | Format::Exodus) && !is_grouped(&m) {
                continue;
            }
            // OpenFOAM rebuilds each cell from its faces, in an order of its
            // own, and holds volume meshes only (its own tests in `openfoam`)
            if f.is_openfoam() {
                continue;
            }
            let path = dir.path().join(format!("{name}-{f}.{}", ext(f)));
            io::write(&path, &m, f, &[]).unwrap_or_else(|e| panic!("{name} {f}: {e}"));
            let got = io::read(&path).unwrap_or_else(|e| panic!("{name} {f}: {e}"));
            let ctx = format!("{name} as {f}");
            assert_eq!(bits(&got), bits(&m), "{ctx}: points");
            assert_eq!(got.kinds, m.kinds, "{ctx}: kinds");
            assert_eq!(got.offsets, m.offsets, "{ctx}: offsets");
            assert_eq!(got.conn, m.conn, "{ctx}: conn");
            assert_eq!(fixed(&got), fixed(&m), "{ctx}: fixed");
            assert!(f.keeps_lower_cells(), "{ctx}");
            match f {
                // VTK's lower cells follow the elements; Medit's kinds (and
                // Exodus's blocks, one per kind here) come in order
                Format::VtkAscii
                | Format::VtkBinary
                | Format::VtuAscii
                | Format::VtuBinary
                | Format::VtuZlib
                | Format::VtkHdf
                | Format::Medit
                | Format::Exodus => assert_eq!(got.lower, m.lower, "{ctx}: lower"),
                // Abaqus has no point element: the fixed flags of points travel as a node set
                Format::Abaqus => {
                    let cells: Vec<_> = m
                        .lower
                        .iter()
                        .filter(|(k, _)| *k != LowerKind::Vertex)
                        .cloned()
                        .collect();
                    assert_eq!(got.lower, cells, "{ctx}: lower");
                }
                _ => {
                    // Gmsh keeps lower cells and adds point cells for other fixed vertices.
                    assert_eq!(got.lower[..m.lower.len()], m.lower[..], "{ctx}: lower");
                    assert!(
                        got.lower[m.lower.len()..].iter().all(|(k, _)| *k == LowerKind::Vertex),
                        "{ctx}: extra lower cells"
                    );
                }
            }
            // Writing what was read gives the same file content.
            let again = dir.path().join(format!("again-{name}-{f}.{}", ext(f)));
            io::write(&again, &got, f, &[]).unwrap();
            let got2 = io::read(&again).unwrap();
            assert_eq!(got2, got, "{ctx}: second round trip");
        }
    }
}

/// The binary writers encode large arrays in parallel chunks (16384 records):
/// meshes of several chunks, with long runs of one type and with the types
/// interleaved, and Gmsh tags on their cells, read back as written.
#[test]
fn parallel_binary_writers_round_trip_meshes_of_several_chunks() {
    use ElementKind::*;
    let dir = tempfile::tempdir().unwrap();
    let grouped = mesh3d(26, 1.0, |c| [Hexahedron, Prism, Tetrahedron][c * 3 / (26 * 26 * 26)]);
    let mut mixed = mesh3d(26, 0.5, |c| [Hexahedron, Prism, Tetrahedron][c % 3]);
    mixed.fixed = (0..mixed.num_points()).map(|v| v % 7 == 0).collect();
    for (name, mut m) in [("grouped", grouped), ("mixed", mixed)] {
        assert!(m.num_points() > 16384 && m.num_elements() > 16384, "{name}");
        let ne = m.num_elements();
        // Gmsh 4.1 keeps physical tags per entity: one per elementary tag here
        for (array, base) in [("gmsh:physical", 11i64), ("gmsh:geometrical", 1)] {
            m.data.cell.push(meshsmooth::mesh::DataArray::new(
                array,
                meshsmooth::mesh::ValueType::I32,
                1,
                meshsmooth::mesh::Values::Int((0..ne).map(|e| base + (e / 5000 % 5) as i64).collect()),
            ));
        }
        for f in [
            Format::VtuBinary,
            Format::VtuZlib,
            Format::Msh41Binary,
            Format::Msh22Binary,
            Format::Msh41Ascii,
        ] {
            let path = dir.path().join(format!("{name}-{f}.{}", ext(f)));
            io::write(&path, &m, f, &[]).unwrap_or_else(|e| panic!("{name} {f}: {e}"));
            let got = io::read(&path).unwrap_or_else(|e| panic!("{name} {f}: {e}"));
            let ctx = format!("{name} as {f}");
            assert_eq!(bits(&got), bits(&m), "{ctx}: points");
            assert_eq!(got.kinds, m.kinds, "{ctx}: kinds");
            assert_eq!(got.offsets, m.offsets, "{ctx}: offsets");
            assert_eq!(got.conn, m.conn, "{ctx}: conn");
            assert_eq!(fixed(&got), fixed(&m), "{ctx}: fixed");
            for array in ["gmsh:physical", "gmsh:geometrical"] {
                let want = m.data.cell_array(array).unwrap();
                let have = got
                    .data
                    .cell_array(array)
                    .unwrap_or_else(|| panic!("{ctx}: no {array}"));
                let bad = (0..ne).find(|&e| have.get_i64(e) != want.get_i64(e));
                assert!(bad.is_none(), "{ctx}: {array} differs first at cell {bad:?}");
            }
        }
        // binary and text Gmsh 4.1 files of one mesh read back equal
        let (a, b) = (
            dir.path().join(format!("{name}-a.msh")),
            dir.path().join(format!("{name}-b.msh")),
        );
        io::write(&a, &m, Format::Msh41Binary, &[]).unwrap();
        io::write(&b, &m, Format::Msh41Ascii, &[]).unwrap();
        assert_eq!(io::read(&a).unwrap(), io::read(&b).unwrap(), "{name}");
    }
}

/// The batched binary writers put each large array in the file exactly as
/// one encoding of the whole array would: VTU's points and connectivity as
/// one base64 run after their byte count, MSH 4.1's nodes and element
/// records as one block each (several batches of pieces here).
#[test]
fn batched_binary_writers_write_whole_array_encodings() {
    use base64::Engine;
    use base64::engine::general_purpose::STANDARD as B64;
    let m = meshsmooth::generate::tet_box(40, 40, 40, [1.0, 1.3, 0.7]);
    let dir = tempfile::tempdir().unwrap();
    let holds = |file: &[u8], want: &[u8], what: &str| {
        assert!(
            memchr::memmem::find(file, want).is_some(),
            "{what} is not in the file whole"
        );
    };
    let points: Vec<u8> = m.points.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    let conn: Vec<u8> = m.conn.iter().flat_map(|&v| (v as i64).to_le_bytes()).collect();
    let path = dir.path().join("box.vtu");
    io::write(&path, &m, Format::VtuBinary, &[]).unwrap();
    let file = std::fs::read(&path).unwrap();
    for (what, bytes) in [("points", &points), ("connectivity", &conn)] {
        let line = B64.encode((bytes.len() as u64).to_le_bytes()) + &B64.encode(bytes) + "\n";
        holds(&file, line.as_bytes(), what);
    }
    let records: Vec<u8> = (0..m.num_elements())
        .flat_map(|e| {
            let vs = m.element(e).iter().map(|&v| v as u64 + 1);
            std::iter::once(e as u64 + 1).chain(vs).flat_map(u64::to_le_bytes)
        })
        .collect();
    let tags: Vec<u8> = (1..=m.num_points() as u64).flat_map(u64::to_le_bytes).collect();
    let path = dir.path().join("box.msh");
    io::write(&path, &m, Format::Msh41Binary, &[]).unwrap();
    let file = std::fs::read(&path).unwrap();
    holds(&file, &[tags, points].concat(), "node tags and coordinates");
    holds(&file, &records, "element records");
}

#[test]
fn medit_writes_2d_only_for_planar_z0_meshes() {
    let dir = tempfile::tempdir().unwrap();
    for (name, dim) in [
        ("quad", "Dimension 2"),
        ("tri-z5", "Dimension 3"),
        ("tet", "Dimension 3"),
    ] {
        let m = test_meshes().into_iter().find(|(n, _)| *n == name).unwrap().1;
        let p = dir.path().join(format!("{name}.mesh"));
        io::write(&p, &m, Format::Medit, &[]).unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.contains(dim), "{name}: {text}");
    }
}

#[test]
fn cell_data_is_written_to_vtk_and_vtu() {
    let dir = tempfile::tempdir().unwrap();
    let m = mesh3d(2, 1.0, |_| ElementKind::Hexahedron);
    let q: Vec<f64> = (0..m.num_elements()).map(|e| 1.0 + e as f64 / 3.0).collect();
    let cd = [CellData {
        name: "quality",
        values: &q,
    }];
    for f in [
        Format::VtkAscii,
        Format::VtkBinary,
        Format::VtuAscii,
        Format::VtuBinary,
        Format::VtuZlib,
    ] {
        let p = dir.path().join(format!("cd-{f}.{}", ext(f)));
        io::write(&p, &m, f, &cd).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        let text = String::from_utf8_lossy(&bytes);
        assert!(text.contains("quality"), "{f}");
        if matches!(f, Format::VtkAscii | Format::VtuAscii) {
            assert!(text.contains(&format!("{:?}", q[1])), "{f}: {}", q[1]);
        }
        // The file stays readable, and the array reads back with its values.
        let got = io::read(&p).unwrap();
        assert_eq!(got.conn, m.conn, "{f}");
        let a = got
            .data
            .cell_array("quality")
            .unwrap_or_else(|| panic!("{f}: no quality array"));
        assert_eq!(a.values, meshsmooth::mesh::Values::Float(q.clone()), "{f}");
    }
}

#[test]
fn format_names_and_extensions() {
    for f in Format::ALL {
        assert_eq!(Format::from_name(f.name()), Some(f));
    }
    assert_eq!(Format::from_name("stl-binary"), None);
    assert_eq!(Format::from_path(Path::new("a/b.VTK")).unwrap(), Format::VtkAscii);
    assert_eq!(Format::from_path(Path::new("b.vtu")).unwrap(), Format::VtuAscii);
    assert_eq!(Format::from_path(Path::new("b.msh")).unwrap(), Format::Msh41Ascii);
    assert_eq!(Format::from_path(Path::new("b.mesh")).unwrap(), Format::Medit);
    let e = Format::from_path(Path::new("b.xyz")).unwrap_err().to_string();
    assert!(e.contains("b.xyz") && e.contains(".vtk") && e.contains(".mesh"), "{e}");
}

#[test]
fn content_wins_over_extension() {
    let dir = tempfile::tempdir().unwrap();
    let m = mesh2d(2, 0.0, |_| ElementKind::Quadrilateral);
    let p = dir.path().join("really-gmsh.vtk");
    io::write(&p, &m, Format::Msh22Binary, &[]).unwrap();
    assert_eq!(io::read(&p).unwrap().conn, m.conn);
}

#[test]
fn same_file_sees_through_relative_paths() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.vtk");
    std::fs::write(&a, "x").unwrap();
    let b = dir.path().join(".").join("a.vtk");
    assert!(io::same_file(&a, &b));
    assert!(!io::same_file(&a, &dir.path().join("missing.vtk")));
}

/// `(file, vertices, elements, fixed)` rows of the README's table.
fn readme_rows(readme: &str) -> Vec<(String, usize, usize, Option<usize>)> {
    readme
        .lines()
        .filter_map(|l| {
            let cols: Vec<&str> = l.split('|').map(str::trim).collect();
            let file = cols.get(1)?;
            if !file.ends_with(".vtk") {
                return None;
            }
            let (v, e) = cols.get(2)?.split_once('/')?;
            let fixed = cols.get(4)?.parse().ok();
            Some((file.to_string(), v.trim().parse().ok()?, e.trim().parse().ok()?, fixed))
        })
        .collect()
}

#[test]
fn real_meshes_read_with_documented_counts() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes");
    let Ok(readme) = std::fs::read_to_string(dir.join("README.md")) else {
        println!("note: {} not found; skipping the real-mesh test", dir.display());
        return;
    };
    let rows = readme_rows(&readme);
    assert!(rows.len() >= 10, "README table not understood");
    let tmp = tempfile::tempdir().unwrap();
    for (file, nv, ne, nfixed) in rows {
        let path = dir.join(&file);
        if file == "mixed-hex-pyr-tet.vtk" {
            let e = io::read(&path).unwrap_err().to_string();
            assert!(e.contains("pyramid") && e.contains(&file), "{e}");
            continue;
        }
        let m = io::read(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((m.num_points(), m.num_elements()), (nv, ne), "{file}");
        if let Some(nf) = nfixed {
            assert_eq!(fixed(&m).iter().filter(|&&f| f).count(), nf, "{file}: fixed");
        }
        // And they survive a binary round trip.
        let out = tmp.path().join("rt.vtu");
        io::write(&out, &m, Format::VtuBinary, &[]).unwrap();
        assert_eq!(io::read(&out).unwrap(), m, "{file}");
    }
}

#[test]
fn vtk_wedges_follow_vtk_orientation() {
    // VTK 9's validator and vtkMeshQuality (ParaView) take a wedge's base
    // triangle (0,1,2) with its normal toward (3,4,5), as meshsmooth and Gmsh
    // do: VTK files are written in meshsmooth's own order.
    let mesh = meshsmooth::generate::prism_mesh(false, 1);
    let dir = tempfile::tempdir().unwrap();
    for (name, format) in [("p.vtk", Format::VtkAscii), ("p.vtu", Format::VtuAscii)] {
        let path = dir.path().join(name);
        meshsmooth::io::write(&path, &mesh, format, &[]).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        // the first cell's vertex ids as written
        let ids: Vec<usize> = if name.ends_with(".vtk") {
            let line = text.lines().skip_while(|l| !l.starts_with("CELLS")).nth(1).unwrap();
            line.split_whitespace().skip(1).map(|t| t.parse().unwrap()).collect()
        } else {
            let start = text.find("Name=\"connectivity\"").unwrap();
            let body = &text[text[start..].find('>').unwrap() + start + 1..];
            body.split_whitespace().take(6).map(|t| t.parse().unwrap()).collect()
        };
        let p = |i: usize| mesh.points[ids[i]];
        let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let (u, v, w) = (sub(p(1), p(0)), sub(p(2), p(0)), sub(p(3), p(0)));
        let normal = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let toward_top = normal[0] * w[0] + normal[1] * w[1] + normal[2] * w[2];
        assert!(
            toward_top > 0.0,
            "{name}: base normal points away from the top triangle"
        );
        assert_eq!(
            meshsmooth::io::read(&path).unwrap().conn,
            mesh.conn,
            "{name}: round trip"
        );
    }
}
