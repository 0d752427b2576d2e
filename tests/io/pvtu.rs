//! `.pvtu` pieces: the pieces written for any partition read back (merged)
//! as the mesh written whole, every element in exactly one piece; pieces
//! without global ids merge by coordinates; a missing piece, overlapping
//! pieces and ids that disagree with coordinates are errors naming the piece.
//! The plain CLI writes pieces (--pieces N) that read back as its whole output.

use crate::common;

use meshsmooth::generate::{PerturbOptions, Perturbation, mixed_block, perturb};
use meshsmooth::io::{self, CellData, Format, GLOBAL_CELL_IDS, GLOBAL_POINT_IDS};
use meshsmooth::mesh::{DataArray, ValueType, Values};
use meshsmooth::partition::{Partitioner, mesh_owners};
use meshsmooth::{Error, Mesh};
use std::path::Path;
use std::process::Command;

/// A mixed tet/prism/hex mesh carrying a point array, a cell array and fixed flags.
fn mixed_with_data() -> Mesh {
    let mut m = mixed_block(4, 2);
    perturb(
        &mut m,
        &PerturbOptions {
            perturbation: Perturbation::Random { alpha: 0.2 },
            seed: 7,
            ..Default::default()
        },
    )
    .unwrap();
    let n = m.num_points();
    let ne = m.num_elements();
    m.data.point.push(DataArray::new(
        "temperature",
        ValueType::F64,
        1,
        Values::Float((0..n).map(|i| (i as f64).sqrt() / 3.0).collect()),
    ));
    m.data.cell.push(DataArray::new(
        "material",
        ValueType::I32,
        1,
        Values::Int((0..ne as i64).map(|e| e % 5).collect()),
    ));
    m.fixed = (0..n).map(|v| v % 7 == 0).collect();
    m
}

fn quality_of(m: &Mesh) -> Vec<f64> {
    (0..m.num_elements()).map(|e| e as f64 * 0.25).collect()
}

/// The mesh written whole as .vtu and read back: what the pieces must give.
fn whole(dir: &Path, m: &Mesh, q: &[f64]) -> Mesh {
    let path = dir.join("whole.vtu");
    io::write(&path, m, Format::VtuAscii, &[CellData { name: "q", values: q }]).unwrap();
    io::read(&path).unwrap()
}

fn write_pieces(
    dir: &Path,
    m: &Mesh,
    q: &[f64],
    parts: usize,
    partitioner: Partitioner,
    format: Format,
) -> std::path::PathBuf {
    let owner = mesh_owners(m, parts, partitioner).unwrap();
    let index = dir.join(format!("p{parts}.pvtu"));
    let written = io::write_pieces(&index, m, &owner, parts, format, &[CellData { name: "q", values: q }]).unwrap();
    // a part owning vertices but no element (each belongs to its first vertex's owner) gets no piece
    assert!(!written.is_empty() && written.len() <= parts);
    index
}

fn partitioners() -> Vec<Partitioner> {
    if cfg!(feature = "metis") {
        vec![Partitioner::Rcb, Partitioner::Metis]
    } else {
        vec![Partitioner::Rcb]
    }
}

#[test]
fn pieces_merge_back_into_the_whole_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let polyhedra = common::truncated_octahedra(3, 1.0, 5);
    for (name, m) in [("mixed", mixed_with_data()), ("polyhedra", polyhedra)] {
        let q = quality_of(&m);
        let want = whole(dir.path(), &m, &q);
        for partitioner in partitioners() {
            for parts in 1..=4 {
                for format in [Format::VtuAscii, Format::VtuZlib] {
                    let index = write_pieces(dir.path(), &m, &q, parts, partitioner, format);
                    let got = io::read(&index).unwrap();
                    assert_eq!(got, want, "{name}, {parts} pieces by {partitioner:?}, {format}");
                }
            }
        }
    }
}

#[test]
fn every_element_is_in_exactly_one_piece() {
    let dir = tempfile::tempdir().unwrap();
    let m = mixed_with_data();
    let q = quality_of(&m);
    let index = write_pieces(dir.path(), &m, &q, 3, Partitioner::Rcb, Format::VtuBinary);
    let data = std::fs::read(&index).unwrap();
    let pieces: Vec<Mesh> = io::piece_paths(&index, &data)
        .unwrap()
        .iter()
        .map(|p| io::read(p).unwrap())
        .collect();
    assert_eq!(pieces.len(), 3, "every part of a tet-rich mesh owns elements");
    let mut cells: Vec<i64> = Vec::new();
    let mut points = 0;
    for piece in &pieces {
        let ids = piece.data.cell_array(GLOBAL_CELL_IDS).unwrap();
        cells.extend((0..piece.num_elements()).map(|e| ids.get_i64(e)));
        points += piece.num_points();
        // each piece's points are those of the whole mesh with the same id
        let pid = piece.data.point.iter().find(|a| a.name == GLOBAL_POINT_IDS).unwrap();
        for (l, p) in piece.points.iter().enumerate() {
            assert_eq!(*p, m.points[pid.get_i64(l) as usize]);
        }
    }
    cells.sort_unstable();
    assert_eq!(cells, (0..m.num_elements() as i64).collect::<Vec<_>>());
    // interface vertices are in more than one piece
    assert!(points > m.num_points());
}

/// Rewrites every piece of `index` with `edit` applied.
fn edit_pieces(index: &Path, edit: impl Fn(usize, &mut Mesh)) {
    let data = std::fs::read(index).unwrap();
    for (i, p) in io::piece_paths(index, &data).unwrap().iter().enumerate() {
        let mut piece = io::read(p).unwrap();
        edit(i, &mut piece);
        io::write(p, &piece, Format::VtuAscii, &[]).unwrap();
    }
}

#[test]
fn pieces_without_ids_merge_by_coordinates() {
    let dir = tempfile::tempdir().unwrap();
    let m = mixed_with_data();
    let q = quality_of(&m);
    let index = write_pieces(dir.path(), &m, &q, 3, Partitioner::Rcb, Format::VtuAscii);
    edit_pieces(&index, |_, piece| {
        piece.data.point.retain(|a| a.name != GLOBAL_POINT_IDS);
        piece.data.cell.retain(|a| a.name != GLOBAL_CELL_IDS);
    });
    let got = io::read(&index).unwrap();
    assert_eq!(got.num_points(), m.num_points());
    assert_eq!(got.num_elements(), m.num_elements());
    // each merged point is the whole mesh's point with its coordinates
    let whole_id = |p: &[f64; 3]| m.points.iter().position(|w| w == p).expect("a point of the whole mesh");
    let map: Vec<usize> = got.points.iter().map(whole_id).collect();
    let mut map_sorted = map.clone();
    map_sorted.sort_unstable();
    map_sorted.dedup();
    assert_eq!(map_sorted.len(), m.num_points(), "points merged twice or lost");
    let elements = |mesh: &Mesh, ids: &dyn Fn(u32) -> usize| {
        let mut es: Vec<(String, Vec<usize>)> = (0..mesh.num_elements())
            .map(|e| {
                (
                    format!("{:?}", mesh.kinds[e]),
                    mesh.element(e).iter().map(|&v| ids(v)).collect(),
                )
            })
            .collect();
        es.sort();
        es
    };
    assert_eq!(elements(&got, &|v| map[v as usize]), elements(&m, &|v| v as usize));
    for v in 0..got.num_points() {
        assert_eq!(got.fixed[v], m.fixed[map[v]]);
    }
}

#[test]
fn paraview_global_node_ids_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let m = mixed_with_data();
    let q = quality_of(&m);
    let want = whole(dir.path(), &m, &q);
    let index = write_pieces(dir.path(), &m, &q, 4, Partitioner::Rcb, Format::VtuAscii);
    edit_pieces(&index, |_, piece| {
        for a in &mut piece.data.point {
            if a.name == GLOBAL_POINT_IDS {
                a.name = "GlobalNodeIds".into();
            }
        }
    });
    assert_eq!(io::read(&index).unwrap(), want);
}

fn message(e: Error) -> String {
    e.to_string()
}

#[test]
fn a_missing_piece_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let m = mixed_with_data();
    let q = quality_of(&m);
    let index = write_pieces(dir.path(), &m, &q, 3, Partitioner::Rcb, Format::VtuAscii);
    std::fs::remove_file(dir.path().join("p3_1.vtu")).unwrap();
    let msg = message(io::read(&index).unwrap_err());
    assert!(msg.contains("p3.pvtu"), "{msg}");
    assert!(msg.contains("piece 1") && msg.contains("p3_1.vtu"), "{msg}");
}

#[test]
fn ids_that_disagree_with_coordinates_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let m = mixed_with_data();
    let q = quality_of(&m);
    let index = write_pieces(dir.path(), &m, &q, 2, Partitioner::Rcb, Format::VtuAscii);
    // every point of piece 1 on the interface now sits elsewhere in piece 1 than in piece 0
    edit_pieces(&index, |i, piece| {
        if i == 1 {
            for p in &mut piece.points {
                p[0] += 1e-3;
            }
        }
    });
    let msg = message(io::read(&index).unwrap_err());
    assert!(msg.contains("piece 1") && msg.contains("global id"), "{msg}");
}

#[test]
fn overlapping_pieces_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let m = mixed_with_data();
    let q = quality_of(&m);
    let index = write_pieces(dir.path(), &m, &q, 2, Partitioner::Rcb, Format::VtuAscii);
    // piece 1 replaced by the whole mesh: piece 0's cells are then in both
    let owner = vec![0u32; m.num_points()];
    let all = dir.path().join("all.pvtu");
    io::write_pieces(
        &all,
        &m,
        &owner,
        1,
        Format::VtuAscii,
        &[CellData { name: "q", values: &q }],
    )
    .unwrap();
    std::fs::copy(dir.path().join("all_0.vtu"), dir.path().join("p2_1.vtu")).unwrap();
    let msg = message(io::read(&index).unwrap_err());
    assert!(msg.contains("overlap") && msg.contains("p2_1.vtu"), "{msg}");
}

const BIN: &str = env!("CARGO_BIN_EXE_meshsmooth");

#[test]
fn the_cli_writes_pieces_that_read_back_as_its_whole_output() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.vtu");
    io::write(&input, &mixed_with_data(), Format::VtuAscii, &[]).unwrap();
    let run = |out: &str, extra: &[&str]| {
        let o = Command::new(BIN)
            .arg("smooth")
            .arg(&input)
            .arg("-o")
            .arg(dir.path().join(out))
            .args(["--device", "cpu", "--partitioner", "rcb"])
            .args(extra)
            .env_remove("OMPI_COMM_WORLD_SIZE")
            .output()
            .unwrap();
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr),
        )
    };
    let (ok, log) = run("whole.vtu", &[]);
    assert!(ok, "{log}");
    let (ok, log) = run("parts.pvtu", &["--pieces", "3"]);
    assert!(ok, "{log}");
    assert!(log.contains("wrote 3 pieces"), "{log}");
    let whole = io::read(dir.path().join("whole.vtu")).unwrap();
    assert_eq!(io::read(dir.path().join("parts.pvtu")).unwrap(), whole);
    // one piece by default without MPI
    let (ok, log) = run("one.pvtu", &[]);
    assert!(ok, "{log}");
    assert!(dir.path().join("one_0.vtu").exists() && !dir.path().join("one_1.vtu").exists());
    // a piece would replace the input: refused before anything is written
    std::fs::copy(&input, dir.path().join("clash_1.vtu")).unwrap();
    let o = Command::new(BIN)
        .arg("smooth")
        .arg(dir.path().join("clash_1.vtu"))
        .arg("-o")
        .arg(dir.path().join("clash.pvtu"))
        .args(["--pieces", "2", "--device", "cpu"])
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && log.contains("clash_1.vtu") && log.contains("input"),
        "{log}"
    );
    assert!(!dir.path().join("clash_0.vtu").exists() && !dir.path().join("clash.pvtu").exists());
    assert_eq!(
        io::read(dir.path().join("clash_1.vtu")).unwrap(),
        io::read(&input).unwrap()
    );
    // --pieces needs a .pvtu index to name them
    let (ok, log) = run("bad.vtu", &["--pieces", "2"]);
    assert!(!ok && log.contains(".pvtu"), "{log}");
    assert!(!dir.path().join("bad.vtu").exists() && !dir.path().join("bad_0.vtu").exists());
}

/// Pieces VTK 9.7.2 wrote (tests/data/interop/pvtu/make_pvtu.py): no global ids,
/// single-precision points, points no cell of the piece uses, and with one ghost
/// level duplicate cells flagged in vtkGhostType. Each reads as the whole mesh
/// (its coordinates rounded to f32, as VTK wrote them), every element once.
#[test]
fn pieces_written_by_vtk_merge_into_the_whole_mesh() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/interop/pvtu");
    let whole = io::read(dir.join("whole.vtu")).unwrap();
    let f32_of = |p: &[f64; 3]| p.map(|c| c as f32);
    for index in ["vtk_ghost0.pvtu", "vtk_ghost1.pvtu"] {
        let got = io::read(dir.join(index)).unwrap_or_else(|e| panic!("{index}: {e}"));
        assert_eq!(got.num_points(), whole.num_points(), "{index}");
        assert_eq!(got.num_elements(), whole.num_elements(), "{index}");
        let map: Vec<usize> = got
            .points
            .iter()
            .map(|p| {
                whole
                    .points
                    .iter()
                    .position(|w| f32_of(w) == f32_of(p))
                    .unwrap_or_else(|| panic!("{index}: {p:?} is no point of the whole mesh"))
            })
            .collect();
        let mut cells_got: Vec<Vec<usize>> = (0..got.num_elements())
            .map(|e| got.element(e).iter().map(|&v| map[v as usize]).collect())
            .collect();
        let mut cells_whole: Vec<Vec<usize>> = (0..whole.num_elements())
            .map(|e| whole.element(e).iter().map(|&v| v as usize).collect())
            .collect();
        cells_got.sort();
        cells_whole.sort();
        assert_eq!(cells_got, cells_whole, "{index}: the elements differ");
        assert!(
            got.data
                .point
                .iter()
                .chain(&got.data.cell)
                .all(|a| a.name != "vtkGhostType"),
            "{index}: ghost flags are the pieces' business, not the mesh's"
        );
    }
}

#[test]
fn lower_cells_and_their_arrays_travel_through_the_pieces() {
    // meshio's tet box: 1577 tets and 708 boundary triangles with gmsh:physical
    let dir = tempfile::tempdir().unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/interop/meshio_tetbox_vtu_zlib.vtu");
    let m = io::read(&src).unwrap();
    assert_eq!((m.num_elements(), m.lower.len()), (1577, 708));
    let path = dir.path().join("whole.vtu");
    io::write(&path, &m, Format::VtuBinary, &[]).unwrap();
    let want = io::read(&path).unwrap();
    assert_eq!(want.lower, m.lower);
    for partitioner in partitioners() {
        for parts in 1..=4 {
            let owner = mesh_owners(&m, parts, partitioner).unwrap();
            let index = dir.path().join(format!("lower{parts}.pvtu"));
            io::write_pieces(&index, &m, &owner, parts, Format::VtuZlib, &[]).unwrap();
            let got = io::read(&index).unwrap();
            let ctx = format!("{parts} pieces by {partitioner:?}");
            assert_eq!(got.lower, m.lower, "{ctx}");
            assert_eq!(got.data.lower, want.data.lower, "{ctx}");
            assert_eq!(got, want, "{ctx}");
            // each triangle in exactly one piece, with the physical tag it had
            let mut seen = 0;
            for r in 0..parts {
                let piece = io::piece_path(&index, r);
                if let Ok(p) = io::read_pvtu_piece(&piece) {
                    seen += p.lower.len();
                    let ids = p.data.lower_array(GLOBAL_CELL_IDS).unwrap();
                    let tags = p.data.lower_array("gmsh:physical").unwrap();
                    let whole_tags = m.data.lower_array("gmsh:physical").unwrap();
                    for c in 0..p.lower.len() {
                        let global = ids.get_i64(c) as usize - m.num_elements();
                        assert_eq!(tags.get_i64(c), whole_tags.get_i64(global), "{ctx}");
                    }
                }
            }
            assert_eq!(seen, 708, "{ctx}");
        }
    }
}
