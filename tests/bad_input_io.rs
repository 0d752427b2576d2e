//! Malformed files give errors naming the file and the problem; failed
//! writes leave nothing behind; no input makes a reader panic.

use std::path::{Path, PathBuf};

use meshsmooth::io::{self, CellData, Format};
use meshsmooth::mesh::{ElementKind, LowerKind, Mesh};

fn small_tets() -> Mesh {
    let mut m = Mesh::new(vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [2.0, 0.5, 0.25],
    ]);
    m.push_element(ElementKind::Tetrahedron, &[0, 1, 2, 3]);
    m.push_element(ElementKind::Tetrahedron, &[1, 2, 3, 4]);
    m.push_element(ElementKind::Tetrahedron, &[1, 4, 2, 5]);
    m.lower.push((LowerKind::Triangle, vec![0, 1, 2]));
    m.fixed = vec![true, true, true, false, false, false];
    m
}

fn write_file(dir: &Path, name: &str, content: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, content).unwrap();
    p
}

/// Read `content` as file `name`; the error must name the file and contain every `needle`.
fn expect_err(name: &str, content: &[u8], needles: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let p = write_file(dir.path(), name, content);
    let e = io::read(&p).expect_err(name).to_string();
    assert!(e.contains(name), "error does not name the file: {e}");
    for n in needles {
        assert!(e.contains(n), "error lacks '{n}': {e}");
    }
    e
}

const VTK_HEAD: &str = "# vtk DataFile Version 3.0\ntest\nASCII\nDATASET UNSTRUCTURED_GRID\n";

fn vtk(points: &str, cells: &str, types: &str) -> Vec<u8> {
    format!("{VTK_HEAD}{points}{cells}{types}").into_bytes()
}

const PTS: &str = "POINTS 4 double\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
const TET: &str = "CELLS 1 5\n4 0 1 2 3\n";

#[test]
fn good_hand_written_vtk_reads() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_file(dir.path(), "ok.vtk", &vtk(PTS, TET, "CELL_TYPES 1\n10\n"));
    let m = io::read(&p).unwrap();
    assert_eq!(m.conn, vec![0, 1, 2, 3]);
}

#[test]
fn vtk_51_layout_and_field_data_read() {
    let text = format!(
        "# vtk DataFile Version 5.1\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nFIELD FieldData 1\nTIME 1 1 double\n0.5\n\
         {PTS}CELLS 2 4\nOFFSETS vtktypeint64\n0 4\nCONNECTIVITY vtktypeint64\n0 1 2 3\nCELL_TYPES 1\n10\n\
         POINT_DATA 4\nFIELD FieldData 2\nfoo 2 4 float\n1 2 3 4 5 6 7 8\nfixed 1 4 int\n1 0 0 1\n\
         CELL_DATA 1\nVECTORS v double\n1 2 3\n"
    );
    let dir = tempfile::tempdir().unwrap();
    let p = write_file(dir.path(), "v51.vtk", text.as_bytes());
    let m = io::read(&p).unwrap();
    assert_eq!(m.conn, vec![0, 1, 2, 3]);
    assert_eq!(m.fixed, vec![true, false, false, true]);
}

#[test]
fn truncated_vtk_ascii() {
    let text = vtk("POINTS 100 double\n0 0 0\n1 0 0\n", "", "");
    expect_err(
        "trunc.vtk",
        &text,
        &[
            "unexpected end of file while reading POINTS",
            "expected 300 values, found 6",
        ],
    );
}

#[test]
fn truncated_vtk_binary() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("full.vtk");
    io::write(&p, &small_tets(), Format::VtkBinary, &[]).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    let cut = bytes.windows(5).position(|w| w == b"CELLS").unwrap() - 30;
    expect_err(
        "truncb.vtk",
        &bytes[..cut],
        &[
            "byte",
            "unexpected end of file while reading POINTS",
            "expected 18 values",
        ],
    );
}

#[test]
fn non_numeric_token() {
    let pts = "POINTS 4 double\n0 0 0\n1 abc 0\n0 1 0\n0 0 1\n";
    expect_err(
        "abc.vtk",
        &vtk(pts, TET, "CELL_TYPES 1\n10\n"),
        &["line 7", "'abc'", "expected a number"],
    );
}

#[test]
fn vertex_index_out_of_range() {
    let cells = "CELLS 1 5\n4 0 1 2 812\n";
    expect_err(
        "range.vtk",
        &vtk(PTS, cells, "CELL_TYPES 1\n10\n"),
        &["line 11", "element 0 refers to vertex 812, but the file has 4 points"],
    );
}

#[test]
fn nan_coordinate() {
    let pts = "POINTS 4 double\n0 0 0\n1 0 0\n0 nan 0\n0 0 1\n";
    expect_err(
        "nan.vtk",
        &vtk(pts, TET, "CELL_TYPES 1\n10\n"),
        &["line 8", "point 2 has a non-finite coordinate"],
    );
}

#[test]
fn unknown_cell_type() {
    expect_err(
        "t99.vtk",
        &vtk(PTS, TET, "CELL_TYPES 1\n99\n"),
        &["line 13", "element 0", "VTK type 99"],
    );
    expect_err(
        "poly.vtk",
        &vtk(PTS, TET, "CELL_TYPES 1\n7\n"),
        &["polygon", "VTK type 7"],
    );
}

#[test]
fn pyramid_is_refused() {
    let pts = "POINTS 5 double\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 0.5 1\n";
    let cells = "CELLS 1 6\n5 0 1 2 3 4\n";
    expect_err(
        "pyr.vtk",
        &vtk(pts, cells, "CELL_TYPES 1\n14\n"),
        &["element 0 is a pyramid", "VTK type 14", "line 14"],
    );
}

#[test]
fn cell_count_mismatch() {
    expect_err(
        "count.vtk",
        &vtk(PTS, TET, "CELL_TYPES 2\n10\n10\n"),
        &["CELL_TYPES 2", "1 cells"],
    );
    expect_err("missing.vtk", &vtk(PTS, TET, ""), &["missing CELL_TYPES"]);
}

#[test]
fn truncated_msh41() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("full.msh");
    io::write(&p, &small_tets(), Format::Msh41Ascii, &[]).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    let cut = text.find("$EndNodes").unwrap() - 20;
    expect_err("trunc41.msh", &text.as_bytes()[..cut], &["unexpected end of file"]);
    let cut = text.find("$EndElements").unwrap() - 3;
    expect_err("trunc41e.msh", &text.as_bytes()[..cut], &["unexpected end of file"]);
}

#[test]
fn msh_binary_bad_endianness_marker() {
    for f in [Format::Msh22Binary, Format::Msh41Binary] {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("full.msh");
        io::write(&p, &small_tets(), f, &[]).unwrap();
        let mut bytes = std::fs::read(&p).unwrap();
        let at = bytes.windows(2).position(|w| w == b"8\n").unwrap() + 2;
        bytes[at..at + 4].copy_from_slice(&[0, 0, 0, 1]);
        expect_err("endian.msh", &bytes, &["endianness", "byte"]);
    }
}

#[test]
fn msh_unknown_and_pyramid_elements() {
    let head =
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n5\n1 0 0 0\n2 1 0 0\n3 1 1 0\n4 0 1 0\n5 0.5 0.5 1\n$EndNodes\n";
    let pyr = format!("{head}$Elements\n1\n17 7 2 0 1 1 2 3 4 5\n$EndElements\n");
    expect_err("pyr.msh", pyr.as_bytes(), &["element 17 is a pyramid", "line 14"]);
    let tet10 = format!("{head}$Elements\n1\n9 11 2 0 1 1 2 3 4 5 1 2 3 4 5\n$EndElements\n");
    expect_err(
        "tet10.msh",
        tet10.as_bytes(),
        &["element 9", "Gmsh type 11", "10-node tetrahedron"],
    );
    let bad = format!("{head}$Elements\n1\n9 4 2 0 1 1 2 3 99\n$EndElements\n");
    expect_err("node.msh", bad.as_bytes(), &["element 9 refers to node 99"]);
}

#[test]
fn msh41_sparse_node_tags_are_renumbered() {
    let text = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 0 1\n1 0 0 0 1 1 1 0 0\n$EndEntities\n\
                $Nodes\n1 4 10 40\n3 1 0 4\n40\n10\n30\n20\n0 0 1\n0 0 0\n0 1 0\n1 0 0\n$EndNodes\n\
                $Elements\n1 1 5 5\n3 1 4 1\n5 10 20 30 40\n$EndElements\n";
    let dir = tempfile::tempdir().unwrap();
    let p = write_file(dir.path(), "sparse.msh", text.as_bytes());
    let m = io::read(&p).unwrap();
    assert_eq!(m.conn, vec![1, 3, 2, 0]);
    assert_eq!(m.points[0], [0.0, 0.0, 1.0]);
}

#[test]
fn medit_missing_vertices() {
    let text = "MeshVersionFormatted 2\nDimension 3\nTetrahedra\n1\n1 2 3 4 0\nEnd\n";
    expect_err("novert.mesh", text.as_bytes(), &["missing Vertices", "line 3"]);
    let text = "MeshVersionFormatted 2\nDimension 3\nEnd\n";
    expect_err("novert2.mesh", text.as_bytes(), &["missing Vertices"]);
}

#[test]
fn medit_case_insensitive_with_unknown_sections() {
    let text = "# comment\nMESHVERSIONFORMATTED 1\nDimension\n2\nvertices\n4\n0 0 1\n1 0 1\n1 1 1\n0 1 2\n\
                Ridges\n1\n1\nQUADRILATERALS\n1\n1 2 3 4 7\nRequiredVertices 1 4\nEND\n";
    let dir = tempfile::tempdir().unwrap();
    let p = write_file(dir.path(), "ok.mesh", text.as_bytes());
    let m = io::read(&p).unwrap();
    assert_eq!(m.kinds, vec![ElementKind::Quadrilateral]);
    assert_eq!(m.fixed, vec![false, false, false, true]);
}

#[test]
fn empty_file() {
    for name in ["empty.vtk", "empty.vtu", "empty.msh", "empty.mesh"] {
        expect_err(name, b"", &["empty"]);
    }
}

#[test]
fn elements_but_zero_points() {
    expect_err(
        "nopts.vtk",
        &vtk("POINTS 0 double\n", TET, "CELL_TYPES 1\n10\n"),
        &["0 points"],
    );
    let msh =
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n0\n$EndNodes\n$Elements\n1\n1 4 2 0 1 1 2 3 4\n$EndElements\n";
    expect_err("nopts.msh", msh.as_bytes(), &["refers to node 1"]);
}

#[test]
fn vtu_errors() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("full.vtu");
    io::write(&p, &small_tets(), Format::VtuAscii, &[]).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    // VTK writes a compressor attribute on ascii files too: it only matters for binary data
    let comp = text.replace(
        "header_type=\"UInt64\"",
        "header_type=\"UInt64\" compressor=\"vtkZLibDataCompressor\"",
    );
    let dir2 = tempfile::tempdir().unwrap();
    let zp = write_file(dir2.path(), "z.vtu", comp.as_bytes());
    assert_eq!(io::read(&zp).unwrap().conn, small_tets().conn);
    let unknown = text.replace("header_type=\"UInt64\"", "header_type=\"UInt64\" compressor=\"vtkZstd\"");
    expect_err("zs.vtu", unknown.as_bytes(), &["compressor 'vtkZstd'", "byte"]);
    let bad = text.replace("0.0 0.0 1.0", "0.0 zz 1.0");
    let at = bad.find("zz").unwrap();
    expect_err("zz.vtu", bad.as_bytes(), &["'zz'", &format!("byte {at}")]);
    let range = text.replacen("1 2 3 4", "1 2 3 44", 1);
    expect_err("r.vtu", range.as_bytes(), &["refers to vertex 44", "6 points"]);
    let cut = &text[..text.len() / 2];
    expect_err("cut.vtu", cut.as_bytes(), &["cut.vtu", "truncated"]);
    let app = text.replacen("format=\"ascii\"", "format=\"appended\" offset=\"0\"", 1);
    expect_err("app.vtu", app.as_bytes(), &["appended", "no <AppendedData>"]);
}

#[test]
fn write_into_missing_directory_fails_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("nope").join("out.vtk");
    let e = io::write(&p, &small_tets(), Format::VtkAscii, &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("nope") && e.contains("does not exist"), "{e}");
    assert!(!dir.path().join("nope").exists());
}

fn dir_entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn failed_write_leaves_no_partial_file() {
    let m = small_tets();
    let short = [1.0, 2.0];
    for f in Format::ALL {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.file");
        let e = io::write(
            &p,
            &m,
            f,
            &[CellData {
                name: "q",
                values: &short,
            }],
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("2 values") && e.to_string().contains("3 elements"),
            "{f}: {e}"
        );
        assert!(
            dir_entries(dir.path()).is_empty(),
            "{f}: left {:?}",
            dir_entries(dir.path())
        );
    }
}

#[test]
fn failed_write_keeps_previous_content() {
    let m = small_tets();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("keep.vtk");
    io::write(&p, &m, Format::VtkAscii, &[]).unwrap();
    let before = std::fs::read(&p).unwrap();
    let short = [1.0];
    assert!(
        io::write(
            &p,
            &m,
            Format::VtkBinary,
            &[CellData {
                name: "q",
                values: &short
            }]
        )
        .is_err()
    );
    assert_eq!(std::fs::read(&p).unwrap(), before);
    assert_eq!(dir_entries(dir.path()), vec!["keep.vtk".to_string()]);
}

/// Every prefix and many single-byte corruptions of valid files in every
/// format must produce `Ok` or `Err`, never a panic or a huge allocation.
#[test]
fn no_panics_on_truncated_or_corrupted_files() {
    let m = small_tets();
    let dir = tempfile::tempdir().unwrap();
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut rand = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    for f in Format::ALL {
        let ext = match f {
            Format::VtkAscii | Format::VtkBinary => "vtk",
            Format::VtuAscii | Format::VtuBinary => "vtu",
            Format::Medit => "mesh",
            _ => "msh",
        };
        let src = dir.path().join(format!("src.{ext}"));
        io::write(&src, &m, f, &[]).unwrap();
        let bytes = std::fs::read(&src).unwrap();
        let p = dir.path().join(format!("fuzz.{ext}"));
        // Every prefix near the start (headers), then a sample of the rest.
        for cut in (0..bytes.len()).filter(|&c| c < 120 || c % 17 == 0) {
            std::fs::write(&p, &bytes[..cut]).unwrap();
            let _ = io::read(&p);
        }
        for _ in 0..150 {
            let mut b = bytes.clone();
            let i = rand() as usize % b.len();
            b[i] = match rand() % 4 {
                0 => b'9',
                1 => 0xff,
                2 => b' ',
                _ => rand() as u8,
            };
            std::fs::write(&p, &b).unwrap();
            let _ = io::read(&p);
        }
    }
}

#[test]
fn vtk_binary_51_layout_reads() {
    let mut b = b"# vtk DataFile Version 5.1\nt\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n".to_vec();
    for x in [0f32, 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1.] {
        b.extend_from_slice(&x.to_be_bytes());
    }
    b.extend_from_slice(b"\nCELLS 2 4\nOFFSETS vtktypeint64\n");
    for x in [0i64, 4] {
        b.extend_from_slice(&x.to_be_bytes());
    }
    b.extend_from_slice(b"\nCONNECTIVITY vtktypeint64\n");
    for x in [0i64, 1, 2, 3] {
        b.extend_from_slice(&x.to_be_bytes());
    }
    b.extend_from_slice(b"\nCELL_TYPES 1\n");
    b.extend_from_slice(&10i32.to_be_bytes());
    b.extend_from_slice(b"\nPOINT_DATA 4\nSCALARS fixed unsigned_char\nLOOKUP_TABLE default\n\x01\x00\x00\x01\n");
    let dir = tempfile::tempdir().unwrap();
    let p = write_file(dir.path(), "b51.vtk", &b);
    let m = io::read(&p).unwrap();
    assert_eq!(m.conn, vec![0, 1, 2, 3]);
    assert_eq!(m.points[3], [0.0, 0.0, 1.0]);
    assert_eq!(m.fixed, vec![true, false, false, true]);
}
