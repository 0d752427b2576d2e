//! Malformed files give errors naming the file and the problem; failed
//! writes leave nothing behind; no input makes a reader panic.

use std::path::{Path, PathBuf};

use meshsmooth::io::{self, CellData, Format};
use meshsmooth::mesh::{ElementKind, LowerKind, Mesh};

use crate::common;

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
    let unknown = text.replace(
        "header_type=\"UInt64\"",
        "header_type=\"UInt64\" compressor=\"vtkZstd\"",
    );
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
    for f in Format::ALL.into_iter().filter(|f| !f.is_surface_only()) {
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
    let mut rand = common::xorshift(0x2545_f491_4f6c_dd1du64);
    // an OpenFOAM case is a folder of files: its mutants are in `openfoam`
    for f in Format::ALL
        .into_iter()
        .filter(|f| !f.is_openfoam() && !f.is_surface_only())
    {
        let ext = match f {
            Format::VtkAscii | Format::VtkBinary => "vtk",
            Format::VtuAscii | Format::VtuBinary => "vtu",
            Format::Medit => "mesh",
            Format::Abaqus => "inp",
            Format::Exodus => "exo",
            Format::VtkHdf => "vtkhdf",
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

/// The hostile files of `bombs` and their mutants (cut short, bytes
/// changed) read through the CLI within a 256 MiB budget: `Ok` or an error
/// naming the file, never a signal, a panic or more than 1 GiB of RSS.
#[test]
fn bombs_and_their_mutants_stay_bounded() {
    use crate::bombs;
    let mut corpus: Vec<(String, Vec<u8>)> = bombs::declared_256m()
        .into_iter()
        .map(|(n, b, _)| (n.to_string(), b))
        .collect();
    corpus.push(("lzma_small.vtu".into(), bombs::lzma_bomb(1025, 1 << 20)));
    corpus.push((
        "lzma_huge.vtu".into(),
        bombs::lzma_bomb(1025, 1025 * bombs::CHUNK_ZEROS),
    ));
    corpus.push(("zlib_1g.vtu".into(), bombs::zlib_conn_1g()));
    corpus.extend(bombs::abaqus_bombs().into_iter().map(|(n, b, _)| (n.to_string(), b)));
    let dir = tempfile::tempdir().unwrap();
    let mut rand = common::xorshift(0x5851_f42d_4c95_7f2du64);
    let mut worst = (0, String::new());
    for (name, bytes) in &corpus {
        let p = dir.path().join(name);
        for k in 0..12 {
            let mut b = bytes.clone();
            if k % 3 == 0 {
                b.truncate(rand() as usize % b.len());
            } else {
                let i = rand() as usize % b.len();
                b[i] = rand() as u8;
            }
            std::fs::write(&p, &b).unwrap();
            let run = bombs::run_cli(
                &[
                    "quality".as_ref(),
                    p.as_os_str(),
                    "--max-memory".as_ref(),
                    "256M".as_ref(),
                ],
                std::time::Duration::from_secs(60),
            );
            let what = format!("{name} mutant {k}: {:?} {}", run.code, run.stderr.trim());
            assert_eq!(run.signal, None, "{what}");
            assert!(
                matches!(run.code, Some(0 | 1)) && !run.stderr.contains("panicked"),
                "{what}"
            );
            assert!(run.code == Some(0) || run.stderr.contains(name.as_str()), "{what}");
            assert!(run.max_rss_kib < 1 << 20, "{what}: {} KiB", run.max_rss_kib);
            assert!(run.secs < 5.0, "{what}: {:.1} s", run.secs);
            if run.max_rss_kib > worst.0 {
                worst = (run.max_rss_kib, what);
            }
        }
    }
    eprintln!("largest peak RSS: {} KiB ({})", worst.0, worst.1);
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

// ---- VTU encodings VTK writes: appended raw/base64, compressed blocks ----

use std::io::Write as _;

#[derive(Clone, Copy, Debug)]
enum Codec {
    None,
    Zlib,
    Lz4,
    Lzma,
}

/// Bytes of one array in VTK's layout: a byte-count header, or the block
/// header `[nblocks, blocksize, lastsize, csizes..]` and the blocks.
fn vtk_block(data: &[u8], codec: Codec, h64: bool, big: bool, block: usize) -> Vec<u8> {
    let word = |x: usize| -> Vec<u8> {
        match (h64, big) {
            (true, true) => (x as u64).to_be_bytes().to_vec(),
            (true, false) => (x as u64).to_le_bytes().to_vec(),
            (false, true) => (x as u32).to_be_bytes().to_vec(),
            (false, false) => (x as u32).to_le_bytes().to_vec(),
        }
    };
    let compress = |b: &[u8]| -> Vec<u8> {
        match codec {
            Codec::None => unreachable!(),
            Codec::Zlib => {
                let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
                e.write_all(b).unwrap();
                e.finish().unwrap()
            }
            Codec::Lz4 => lz4_flex::block::compress(b),
            Codec::Lzma => {
                let mut out = Vec::new();
                lzma_rs::xz_compress(&mut std::io::Cursor::new(b), &mut out).unwrap();
                out
            }
        }
    };
    if let Codec::None = codec {
        return [word(data.len()), data.to_vec()].concat();
    }
    let blocks: Vec<Vec<u8>> = data.chunks(block).map(compress).collect();
    let mut out = [word(blocks.len()), word(block), word(data.len() % block)].concat();
    for b in &blocks {
        out.extend(word(b.len()));
    }
    for b in &blocks {
        out.extend_from_slice(b);
    }
    out
}

/// `small_tets` as a VTU with appended data (raw or base64), compressed or
/// not, UInt32 or UInt64 headers, either byte order, Int32 connectivity.
fn appended_vtu(codec: Codec, raw: bool, h64: bool, big: bool) -> Vec<u8> {
    use base64::Engine;
    let m = small_tets();
    let f64s = |v: &[f64]| -> Vec<u8> {
        v.iter()
            .flat_map(|x| if big { x.to_be_bytes() } else { x.to_le_bytes() })
            .collect()
    };
    let i32s = |v: &[i64]| -> Vec<u8> {
        v.iter()
            .flat_map(|&x| {
                if big {
                    (x as i32).to_be_bytes()
                } else {
                    (x as i32).to_le_bytes()
                }
            })
            .collect()
    };
    let pts: Vec<f64> = m.points.iter().flatten().copied().collect();
    let conn: Vec<i64> = m.conn.iter().map(|&v| v as i64).collect();
    let offs: Vec<i64> = m.offsets[1..].iter().map(|&v| v as i64).collect();
    let temp = [0.5f64, 1.5, 2.5];
    let arrays: Vec<(&str, &str, &str, usize, Vec<u8>)> = vec![
        ("PointData", "Int32", "fixed", 1, i32s(&[1, 1, 1, 0, 0, 0])),
        ("Points", "Float64", "Points", 3, f64s(&pts)),
        ("Cells", "Int32", "connectivity", 1, i32s(&conn)),
        ("Cells", "Int32", "offsets", 1, i32s(&offs)),
        ("Cells", "UInt8", "types", 1, vec![10, 10, 10]),
        ("CellData", "Float64", "temperature", 1, f64s(&temp)),
    ];
    let mut payload: Vec<u8> = Vec::new();
    let mut xml = String::new();
    let mut section = "";
    for (sec, ty, name, nc, bytes) in &arrays {
        if *sec != section {
            if !section.is_empty() {
                xml.push_str(&format!("</{section}>\n"));
            }
            xml.push_str(&format!("<{sec}>\n"));
            section = sec;
        }
        xml.push_str(&format!(
            "<DataArray type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"{nc}\" format=\"appended\" offset=\"{}\">\n\
             <InformationKey name=\"L2_NORM_RANGE\" location=\"vtkDataArray\" length=\"2\"><Value index=\"0\">1</Value></InformationKey>\n\
             </DataArray>\n",
            payload.len()
        ));
        // a small block size so even these arrays span several blocks
        let block = vtk_block(bytes, codec, h64, big, 16);
        if raw {
            payload.extend(block);
        } else {
            // VTK encodes the header and the data as separate base64 runs
            let hlen = match codec {
                Codec::None => 1,
                _ => 3 + bytes.len().div_ceil(16),
            } * if h64 { 8 } else { 4 };
            let b64 = base64::engine::general_purpose::STANDARD;
            payload.extend(b64.encode(&block[..hlen]).into_bytes());
            payload.extend(b64.encode(&block[hlen..]).into_bytes());
        }
    }
    xml.push_str(&format!("</{section}>\n"));
    let compressor = match codec {
        Codec::None => "",
        Codec::Zlib => " compressor=\"vtkZLibDataCompressor\"",
        Codec::Lz4 => " compressor=\"vtkLZ4DataCompressor\"",
        Codec::Lzma => " compressor=\"vtkLZMADataCompressor\"",
    };
    let mut out = format!(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"{}\" header_type=\"{}\"{compressor}>\n\
         <UnstructuredGrid>\n<Piece NumberOfPoints=\"6\" NumberOfCells=\"3\">\n{xml}</Piece>\n</UnstructuredGrid>\n\
         <AppendedData encoding=\"{}\">\n   _",
        if big { "BigEndian" } else { "LittleEndian" },
        if h64 { "UInt64" } else { "UInt32" },
        if raw { "raw" } else { "base64" },
    )
    .into_bytes();
    out.extend(payload);
    out.extend_from_slice(b"\n  </AppendedData>\n</VTKFile>\n");
    out
}

const CODECS: [Codec; 4] = [Codec::None, Codec::Zlib, Codec::Lz4, Codec::Lzma];

#[test]
fn appended_vtu_in_every_layout_reads() {
    let want = small_tets();
    let dir = tempfile::tempdir().unwrap();
    for codec in CODECS {
        for raw in [true, false] {
            for h64 in [false, true] {
                for big in [false, true] {
                    let ctx = format!("{codec:?} raw={raw} h64={h64} big={big}");
                    let p = write_file(dir.path(), "a.vtu", &appended_vtu(codec, raw, h64, big));
                    let m = io::read(&p).unwrap_or_else(|e| panic!("{ctx}: {e}"));
                    assert_eq!(m.points, want.points, "{ctx}");
                    assert_eq!(m.conn, want.conn, "{ctx}");
                    assert_eq!(m.fixed, want.fixed, "{ctx}");
                    let t = m.data.cell_array("temperature").unwrap();
                    assert_eq!(t.values, meshsmooth::mesh::Values::Float(vec![0.5, 1.5, 2.5]), "{ctx}");
                }
            }
        }
    }
}

/// Where the binary part of a file starts (the appended payload, else the
/// first `<Cells>`), so that cuts are aimed inside the compressed blocks.
fn payload_start(bytes: &[u8]) -> usize {
    let find = |n: &[u8]| bytes.windows(n.len()).position(|w| w == n);
    let cells = find(b"<Cells>").unwrap_or(0);
    find(b" _").map_or(cells, |p| (p + 2).min(cells))
}

/// Truncated anywhere (inside a compressed block, after `<CellData>`,
/// without `</VTKFile>`): an error with the byte offset, never a panic or a
/// hang; corrupted bytes: `Ok` or `Err`, never a panic.
#[test]
fn truncated_or_corrupted_compressed_vtu_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    for codec in CODECS {
        for raw in [true, false] {
            files.push((
                format!("{codec:?}-raw{raw}.vtu"),
                appended_vtu(codec, raw, false, false),
            ));
        }
    }
    // inline compressed (meshsmooth's own vtu-zlib) and VTK's own files
    let src = dir.path().join("z.vtu");
    io::write(&src, &small_tets(), Format::VtuZlib, &[]).unwrap();
    files.push(("vtu-zlib.vtu".into(), std::fs::read(&src).unwrap()));
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/interop");
    for f in [
        "vtk_tri_x_xml_default.vtu",
        "vtk_tri_x_xml_binary_lz4_h32.vtu",
        "vtk_tet_xml_binary_lzma_h32.vtu",
    ] {
        files.push((f.into(), std::fs::read(data.join(f)).unwrap()));
    }
    let start = std::time::Instant::now();
    let mut rand = common::xorshift(0x9e37_79b9_7f4a_7c15u64);
    for (name, bytes) in &files {
        let p = dir.path().join("cut.vtu");
        let full = String::from_utf8_lossy(bytes);
        // only trailing whitespace may go (the XML before the payload is text,
        // so offsets found in `full` there are byte offsets)
        let tail = bytes.iter().rev().take_while(|b| b.is_ascii_whitespace()).count();
        let from = payload_start(bytes);
        let step = ((bytes.len() - from) / 300).max(1);
        for cut in (from..bytes.len() - tail).step_by(step).chain([bytes.len() - tail - 1]) {
            std::fs::write(&p, &bytes[..cut]).unwrap();
            let e = io::read(&p)
                .map(|_| ())
                .expect_err(&format!("{name} cut at {cut} was accepted"));
            let e = e.to_string();
            assert!(e.contains("cut.vtu") && e.contains("byte"), "{name} cut at {cut}: {e}");
        }
        if let Some(cd) = full.find("<CellData>") {
            let cut = cd + "<CellData>".len();
            std::fs::write(&p, &bytes[..cut]).unwrap();
            let e = io::read(&p).expect_err(name).to_string();
            assert!(e.contains(&format!("byte {cut}")) && e.contains("truncated"), "{e}");
        }
        for _ in 0..200 {
            let mut b = bytes.clone();
            let i = from + rand() as usize % (b.len() - from);
            b[i] = match rand() % 3 {
                0 => b'A',
                1 => 0xff,
                _ => rand() as u8,
            };
            std::fs::write(&p, &b).unwrap();
            let _ = io::read(&p);
        }
    }
    let secs = start.elapsed().as_secs_f64();
    assert!(secs < 60.0, "the fuzzing took {secs:.0} s: something is not linear");
}

/// A bad input never leaves an output file behind.
#[test]
fn smooth_on_a_truncated_file_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = appended_vtu(Codec::Zlib, true, false, false);
    let input = write_file(dir.path(), "in.vtu", &bytes[..bytes.len() - 40]);
    let out = dir.path().join("out.vtu");
    let hist = dir.path().join("h.csv");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_meshsmooth"))
        .args(["smooth".as_ref(), input.as_os_str(), "-o".as_ref(), out.as_os_str()])
        .args([
            "--history".as_ref(),
            hist.as_os_str(),
            "--device".as_ref(),
            "cpu".as_ref(),
        ])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("in.vtu"));
    assert_eq!(dir_entries(dir.path()), vec!["in.vtu".to_string()]);
}

/// Outputs: a device is written through, a symlink's target replaced, a
/// directory refused; new files get 0666 & ~umask, replaced ones keep their mode.
#[cfg(unix)]
#[test]
fn outputs_respect_what_is_already_there() {
    use std::os::unix::fs::{FileTypeExt, PermissionsExt};
    let m = small_tets();
    io::write(Path::new("/dev/null"), &m, Format::VtkAscii, &[]).unwrap();
    assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device());
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("target.vtk");
    std::fs::write(&target, "old").unwrap();
    std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o640)).unwrap();
    let link = dir.path().join("link.vtk");
    std::os::unix::fs::symlink("target.vtk", &link).unwrap();
    io::write(&link, &m, Format::VtkAscii, &[]).unwrap();
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    assert_eq!(io::read(&target).unwrap().conn, m.conn);
    assert_eq!(std::fs::metadata(&target).unwrap().permissions().mode() & 0o777, 0o640);
    let fresh = dir.path().join("fresh.vtk");
    io::write(&fresh, &m, Format::VtkAscii, &[]).unwrap();
    let mode = std::fs::metadata(&fresh).unwrap().permissions().mode() & 0o777;
    // the umask only removes bits; 0600 (tempfile's default) would mean it was not applied from 0666
    assert!(mode & 0o044 != 0 || mode == 0o600 && umask_is(0o177), "mode {mode:o}");
    let sub = dir.path().join("sub.vtk");
    std::fs::create_dir(&sub).unwrap();
    let e = io::write(&sub, &m, Format::VtkAscii, &[]).unwrap_err().to_string();
    assert!(e.contains("directory"), "{e}");
    // a FIFO is written directly (a reader drains it)
    let fifo = dir.path().join("pipe.vtk");
    crate::common::fifo(&fifo);
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(&fifo).unwrap())
    };
    io::write(&fifo, &m, Format::VtkAscii, &[]).unwrap();
    let got = reader.join().unwrap();
    assert!(got.starts_with(b"# vtk DataFile"));
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
}

/// The process umask, read from /proc (Linux); None elsewhere.
#[cfg(unix)]
fn umask_is(mask: u32) -> bool {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("Umask:"))
                .and_then(|l| u32::from_str_radix(l[6..].trim(), 8).ok())
        })
        .is_some_and(|m| m == mask)
}

#[test]
fn duplicate_elements_are_refused_with_the_file_name() {
    let text = vtk(PTS, "CELLS 2 10\n4 0 1 2 3\n4 3 2 1 0\n", "CELL_TYPES 2\n10\n10\n");
    expect_err("dup.vtk", &text, &["elements 0 and 1 are duplicates"]);
}

#[test]
fn long_tokens_are_clipped_in_messages() {
    let junk = "x".repeat(300_000);
    let text = vtk(&format!("POINTS 4 double\n{junk} 0 0\n"), "", "");
    let e = expect_err("long.vtk", &text, &["xxxx"]);
    assert!(e.len() < 400, "message of {} bytes", e.len());
}

fn meshsmooth_cmd() -> std::process::Command {
    std::process::Command::new(env!("CARGO_BIN_EXE_meshsmooth"))
}

/// `meshsmooth quality X | head -1`: no panic, no backtrace when the reader goes away.
#[test]
fn a_closed_pipe_ends_the_program_quietly() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("m.vtk");
    io::write(&p, &small_tets(), Format::VtkAscii, &[]).unwrap();
    let mut child = meshsmooth_cmd()
        .args(["quality".as_ref(), p.as_os_str()])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // the reader is gone before anything is printed
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked") && err.trim().is_empty(), "stderr: {err}");
}

/// `--history` equal to the output or the input is refused before anything runs.
#[test]
fn history_may_not_collide_with_the_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.vtk");
    io::write(&input, &small_tets(), Format::VtkAscii, &[]).unwrap();
    let before = std::fs::read(&input).unwrap();
    let out = dir.path().join("out.vtk");
    let same_as_out = dir.path().join(".").join("out.vtk");
    for (hist, what) in [(&same_as_out, "output"), (&input, "input")] {
        let o = meshsmooth_cmd()
            .args(["smooth".as_ref(), input.as_os_str(), "-o".as_ref(), out.as_os_str()])
            .args([
                "--history".as_ref(),
                hist.as_os_str(),
                "--device".as_ref(),
                "cpu".as_ref(),
            ])
            .output()
            .unwrap();
        assert!(!o.status.success(), "{what}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("--history") || err.contains("input"), "{what}: {err}");
        assert!(o.stdout.is_empty(), "{what}: ran before refusing");
        assert!(!out.exists(), "{what}: wrote the output");
        assert_eq!(std::fs::read(&input).unwrap(), before);
    }
}

#[test]
fn an_inverted_input_is_named_in_the_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_file(
        dir.path(),
        "inv.vtk",
        &vtk(PTS, "CELLS 1 5\n4 0 2 1 3\n", "CELL_TYPES 1\n10\n"),
    );
    let out = dir.path().join("o.vtk");
    let o = meshsmooth_cmd()
        .args([
            "smooth".as_ref(),
            p.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
            "--device".as_ref(),
            "cpu".as_ref(),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("inv.vtk") && err.contains("inverted"),
        "{err}"
    );
    assert!(!out.exists());
}
