//! ParaView's partitioned unstructured grid (`.pvtu`): an XML index naming
//! `.vtu` pieces, one per part of a partitioned run.
//!
//! Written pieces hold the elements one part owns (an element belongs to the
//! owner of its first vertex, as in a partitioned solve), the lower cells it
//! owns by the same rule, and the vertices those use, so the pieces together
//! hold every cell once; vertices on the interfaces appear in each piece
//! that uses them, as ParaView writes them.
//! Each piece carries `GlobalPointIds` and `GlobalCellIds` (VTK's names for
//! global ids): the numbers of its points and cells in the whole mesh.
//!
//! Reading merges the pieces back into one mesh. Points are the same point
//! when they have the same global id — a `GlobalPointIds` or `GlobalNodeIds`
//! point array present in every piece, the merged points then in ascending
//! id — else when their coordinates are bitwise equal, the merged points in
//! order of first appearance. Cells ParaView marks as duplicates (bit 1 of
//! `vtkGhostType`) are dropped; the others are ordered by `GlobalCellIds`
//! when every piece has it, else piece after piece. Points no remaining cell
//! uses are dropped (VTK's piece extraction leaves such points in a piece).
//! Id arrays that merely count 0..n are implied by that order and dropped.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use quick_xml::events::Event;
use quick_xml::reader::Reader;
use rayon::prelude::*;

use super::{CellData, Format, vtu, write, write_atomic};
use crate::error::{Error, Result};
use crate::mesh::{DataArray, ElementKind, Mesh, ValueType, Values};

/// The point array holding each piece vertex's global id.
pub const GLOBAL_POINT_IDS: &str = "GlobalPointIds";
/// The cell array holding each piece element's global id.
pub const GLOBAL_CELL_IDS: &str = "GlobalCellIds";
/// Point id arrays read, in order of preference (VTK's, then ParaView's D3 filter's).
const POINT_ID_NAMES: [&str; 2] = [GLOBAL_POINT_IDS, "GlobalNodeIds"];
const GHOST: &str = "vtkGhostType";
/// vtkDataSetAttributes::DUPLICATECELL: the cell belongs to another piece.
const DUPLICATE_CELL: i64 = 1;

/// Whether `data` (an XML VTK file) is a `.pvtu` index.
pub(crate) fn is_index(data: &[u8]) -> bool {
    let head = &data[..data.len().min(1024)];
    head.windows(17).any(|w| w == b"PUnstructuredGrid")
}

/// The piece files an index lists, in order, resolved beside the index.
pub fn piece_paths(path: &Path, data: &[u8]) -> Result<Vec<PathBuf>> {
    let text = std::str::from_utf8(data).map_err(|_| Error::parse(path, None, "a .pvtu index must be UTF-8 text"))?;
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut reader = Reader::from_str(text);
    let mut pieces = Vec::new();
    loop {
        let ev = reader
            .read_event()
            .map_err(|e| Error::parse(path, None, format!("malformed XML: {e}")))?;
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => match e.local_name().as_ref() {
                "VTKFile" => match vtu::attr(e, "type").as_deref() {
                    Some("PUnstructuredGrid") => {}
                    t => {
                        return Err(Error::parse(
                            path,
                            None,
                            format!(
                                "VTKFile type '{}' is not a partitioned unstructured grid (PUnstructuredGrid)",
                                t.unwrap_or("")
                            ),
                        ));
                    }
                },
                "Piece" => match vtu::attr(e, "Source") {
                    Some(s) if !s.trim().is_empty() => pieces.push(dir.join(s.trim())),
                    _ => {
                        return Err(Error::parse(
                            path,
                            None,
                            format!("piece {} has no Source attribute naming its .vtu file", pieces.len()),
                        ));
                    }
                },
                _ => {}
            },
            Event::Eof => break,
            _ => {}
        }
    }
    if pieces.is_empty() {
        return Err(Error::parse(path, None, "the index lists no Piece"));
    }
    Ok(pieces)
}

/// Reads every piece of the index at `path` (holding `data`) and merges them.
pub(crate) fn read(path: &Path, data: &[u8], limits: &super::ReadLimits) -> Result<Mesh> {
    read_with(path, data, &mut |sources| {
        sources
            .par_iter()
            .enumerate()
            .map(|(i, s)| read_piece(path, i, s, limits))
            .collect()
    })
}

/// [`read`] with the pieces read by `read_pieces` (given the pieces' paths,
/// it returns them in that order), so that other processes may read them.
pub(crate) fn read_with(
    path: &Path,
    data: &[u8],
    read_pieces: &mut dyn FnMut(&[PathBuf]) -> Result<Vec<Mesh>>,
) -> Result<Mesh> {
    let sources = piece_paths(path, data)?;
    let pieces = read_pieces(&sources)?;
    if pieces.len() != sources.len() {
        return Err(Error::parse(
            path,
            None,
            format!("{} pieces read of {}", pieces.len(), sources.len()),
        ));
    }
    merge(path, &pieces, &sources, false)
}

/// An index's pieces (`names` their files) merged into the whole mesh, as [`read`] merges them.
pub fn merge_pieces(index: &Path, pieces: &[Mesh], names: &[PathBuf]) -> Result<Mesh> {
    merge(index, pieces, names, false)
}

/// Writes the index `path` over pieces shaped like `piece` (the same
/// arrays, plus `cell_data`), named `sources` beside it: for pieces written
/// elsewhere, e.g. by the ranks that hold them.
pub fn write_index(path: &Path, piece: &Mesh, cell_data: &[CellData], sources: &[String]) -> Result<()> {
    write_atomic(path, |w| vtu::write_index(w, piece, cell_data, sources))
}

/// Some of an index's pieces (`names` their files) merged as [`read`] merges
/// all of them, with the global id of each merged point when every piece
/// carries `GlobalPointIds` or `GlobalNodeIds`: a rank's share of a
/// partitioned input, which the other ranks' shares meet at those ids (or,
/// without them, at bitwise-equal coordinates).
pub fn merge_share(index: &Path, pieces: &[Mesh], names: &[PathBuf]) -> Result<(Mesh, Option<Vec<i64>>)> {
    let mut mesh = merge(index, pieces, names, true)?;
    let ids = POINT_ID_NAMES
        .iter()
        .find_map(|&n| mesh.data.point.iter().find(|a| a.name == n))
        .filter(|_| pieces.iter().all(|p| point_ids(p).is_some()))
        .map(|a| (0..mesh.num_points()).map(|l| a.get_i64(l)).collect());
    // the rank's own numbering of its cells is no global id
    if pieces.iter().any(|p| cell_ids(p).is_none()) {
        mesh.data.cell.retain(|a| a.name != GLOBAL_CELL_IDS);
    }
    Ok((mesh, ids))
}

/// Piece `i` (file `piece`) of the index `index`, unmerged; errors name both.
fn read_piece(index: &Path, i: usize, piece: &Path, limits: &super::ReadLimits) -> Result<Mesh> {
    super::read_piece(piece, limits).map_err(|e| piece_error(index, i, piece, e))
}

/// An error reading piece `i` (file `piece`) of `index`, naming both.
pub fn piece_error(index: &Path, i: usize, piece: &Path, e: impl std::fmt::Display) -> Error {
    Error::parse(index, None, format!("piece {i} ({}): {e}", piece.display()))
}

#[derive(Clone, Copy, PartialEq, Eq, Hash)]
enum Key {
    Id(i64),
    Bits([u64; 3]),
}

/// A piece's global point ids, if it carries them.
pub fn point_ids(piece: &Mesh) -> Option<&DataArray> {
    POINT_ID_NAMES.iter().find_map(|&n| {
        piece
            .data
            .point
            .iter()
            .find(|a| a.name == n && a.components == 1 && matches!(a.values, Values::Int(_)))
    })
}

fn cell_ids(piece: &Mesh) -> Option<&DataArray> {
    piece
        .data
        .cell
        .iter()
        .find(|a| a.name == GLOBAL_CELL_IDS && a.components == 1 && matches!(a.values, Values::Int(_)))
}

/// The pieces as one mesh (see the module documentation).
/// `keep_ids`: keep id arrays that merely count (on a share of the pieces they are still ids).
fn merge(path: &Path, pieces: &[Mesh], names: &[PathBuf], keep_ids: bool) -> Result<Mesh> {
    let err = |i: usize, msg: String| Error::parse(path, None, format!("piece {i} ({}): {msg}", names[i].display()));
    let ids: Option<Vec<&DataArray>> = pieces.iter().map(point_ids).collect();
    // the first (piece, point) of each merged point
    let mut first: Vec<(usize, usize)> = Vec::new();
    let mut key_of: HashMap<Key, u32> = HashMap::new();
    let mut local: Vec<Vec<u32>> = Vec::with_capacity(pieces.len());
    for (i, piece) in pieces.iter().enumerate() {
        let mut map = Vec::with_capacity(piece.num_points());
        for (l, p) in piece.points.iter().enumerate() {
            let key = match &ids {
                Some(ids) => Key::Id(ids[i].get_i64(l)),
                None => Key::Bits(p.map(f64::to_bits)),
            };
            let m = *key_of.entry(key).or_insert_with(|| {
                first.push((i, l));
                (first.len() - 1) as u32
            });
            let (fi, fl) = first[m as usize];
            if pieces[fi].points[fl].map(f64::to_bits) != p.map(f64::to_bits) {
                let Key::Id(id) = key else { unreachable!() };
                return Err(err(
                    i,
                    format!(
                        "point {l} has global id {id} at {p:?}, but piece {fi} ({}) has that id at {:?}",
                        names[fi].display(),
                        pieces[fi].points[fl]
                    ),
                ));
            }
            map.push(m);
        }
        local.push(map);
    }
    // with global ids the merged points come in ascending id
    if let Some(ids) = &ids {
        let mut order: Vec<u32> = (0..first.len() as u32).collect();
        order.sort_by_key(|&m| {
            let (i, l) = first[m as usize];
            ids[i].get_i64(l)
        });
        let mut rank = vec![0u32; first.len()];
        for (r, &m) in order.iter().enumerate() {
            rank[m as usize] = r as u32;
        }
        first = order.iter().map(|&m| first[m as usize]).collect();
        for map in &mut local {
            for m in map.iter_mut() {
                *m = rank[*m as usize];
            }
        }
    }
    // offset of each piece's points and cells in the concatenation of all
    let starts = |count: &dyn Fn(&Mesh) -> usize| {
        let mut s = vec![0usize];
        for piece in pieces {
            s.push(s.last().unwrap() + count(piece));
        }
        s
    };
    let point_start = starts(&|m| m.num_points());
    let cell_start = starts(&|m| m.num_elements());

    let mut cells: Vec<(usize, usize)> = Vec::new();
    for (i, piece) in pieces.iter().enumerate() {
        let ghost = piece.data.cell_array(GHOST);
        cells.extend(
            (0..piece.num_elements())
                .filter(|&e| ghost.is_none_or(|g| g.get_i64(e) & DUPLICATE_CELL == 0))
                .map(|e| (i, e)),
        );
    }
    let cell_id_arrays: Option<Vec<&DataArray>> = pieces.iter().map(cell_ids).collect();
    if let Some(cids) = &cell_id_arrays {
        cells.sort_by_key(|&(i, e)| cids[i].get_i64(e));
        if let Some(w) = cells
            .windows(2)
            .find(|w| cids[w[0].0].get_i64(w[0].1) == cids[w[1].0].get_i64(w[1].1))
        {
            let ((a, ea), (b, eb)) = (w[0], w[1]);
            return Err(err(
                b,
                format!(
                    "cell {eb} has global cell id {}, as has cell {ea} of piece {a} ({}): the pieces overlap",
                    cids[b].get_i64(eb),
                    names[a].display()
                ),
            ));
        }
    }
    let cell_rows: Vec<usize> = cells.iter().map(|&(i, e)| cell_start[i] + e).collect();
    // lower cells likewise: by their global cell ids where every piece with some has them
    let mut lower: Vec<(usize, usize)> = Vec::new();
    for (i, piece) in pieces.iter().enumerate() {
        let ghost = piece.data.lower_array(GHOST);
        lower.extend(
            (0..piece.lower.len())
                .filter(|&c| ghost.is_none_or(|g| g.get_i64(c) & DUPLICATE_CELL == 0))
                .map(|c| (i, c)),
        );
    }
    let lower_ids = |i: usize| {
        pieces[i]
            .data
            .lower_array(GLOBAL_CELL_IDS)
            .filter(|a| a.components == 1 && matches!(a.values, Values::Int(_)))
    };
    if lower.iter().all(|&(i, _)| lower_ids(i).is_some()) {
        lower.sort_by_key(|&(i, c)| lower_ids(i).map(|a| a.get_i64(c)));
    }
    // points no kept cell uses are artefacts of the split (VTK's piece
    // extraction keeps them, and the ghost cells dropped used some): dropped
    let mut used = vec![false; first.len()];
    for &(i, e) in &cells {
        for &v in pieces[i].element(e) {
            used[local[i][v as usize] as usize] = true;
        }
    }
    for &(i, c) in &lower {
        for &v in &pieces[i].lower[c].1 {
            used[local[i][v as usize] as usize] = true;
        }
    }
    if used.iter().any(|&u| !u) {
        let mut renumber = vec![u32::MAX; first.len()];
        let mut kept = Vec::new();
        for (m, &u) in used.iter().enumerate() {
            if u {
                renumber[m] = kept.len() as u32;
                kept.push(first[m]);
            }
        }
        first = kept;
        for map in &mut local {
            for m in map.iter_mut() {
                *m = renumber[*m as usize];
            }
        }
    }

    let point_rows: Vec<usize> = first.iter().map(|&(i, l)| point_start[i] + l).collect();
    let mut mesh = Mesh::new(first.iter().map(|&(i, l)| pieces[i].points[l]).collect());
    for &(i, e) in &cells {
        let piece = &pieces[i];
        let verts: Vec<u32> = piece.element(e).iter().map(|&v| local[i][v as usize]).collect();
        if piece.kinds[e] == ElementKind::Polyhedron {
            let faces: Vec<Vec<u32>> = piece
                .faces
                .of(e)
                .map(|f| f.iter().map(|&v| local[i][v as usize]).collect())
                .collect();
            mesh.push_polyhedron(&verts, faces.iter().map(Vec::as_slice));
        } else {
            mesh.push_element(piece.kinds[e], &verts);
        }
    }
    mesh.lower = lower
        .iter()
        .map(|&(i, c)| {
            let (kind, vs) = &pieces[i].lower[c];
            (*kind, vs.iter().map(|&v| local[i][v as usize]).collect())
        })
        .collect();
    if pieces.iter().any(|p| !p.fixed.is_empty()) {
        mesh.fixed = first
            .iter()
            .map(|&(i, l)| pieces[i].fixed.get(l).copied().unwrap_or(false))
            .collect();
    }
    let same_arrays = |of: &dyn Fn(&Mesh) -> Vec<&DataArray>, what: &str| -> Result<Vec<Vec<DataArray>>> {
        let shape = |m: &Mesh| -> Vec<(String, ValueType, usize)> {
            of(m).iter().map(|a| (a.name.clone(), a.ty, a.components)).collect()
        };
        let want = shape(&pieces[0]);
        for (i, piece) in pieces.iter().enumerate().skip(1) {
            if shape(piece) != want {
                let list =
                    |s: Vec<(String, ValueType, usize)>| s.into_iter().map(|(n, ..)| n).collect::<Vec<_>>().join(", ");
                return Err(err(
                    i,
                    format!(
                        "its {what} arrays ({}) differ from piece 0's ({}) in names, types or components",
                        list(shape(piece)),
                        list(want)
                    ),
                ));
            }
        }
        Ok(pieces.iter().map(|m| of(m).into_iter().cloned().collect()).collect())
    };
    let point_arrays = same_arrays(
        &|m| {
            m.data
                .point
                .iter()
                .filter(|a| a.name != "fixed" && a.name != GHOST)
                .collect()
        },
        "point",
    )?;
    let cell_arrays = same_arrays(&|m| m.data.cell.iter().filter(|a| a.name != GHOST).collect(), "cell")?;
    mesh.data.point = concat_select(&point_arrays, &point_rows);
    mesh.data.cell = concat_select(&cell_arrays, &cell_rows);
    mesh.data.field = pieces[0].data.field.clone();
    if !lower.is_empty() {
        // the arrays of the pieces that have lower cells, end to end
        let with: Vec<usize> = (0..pieces.len()).filter(|&i| !pieces[i].lower.is_empty()).collect();
        let mut start = vec![0usize; pieces.len()];
        let mut at = 0;
        for &i in &with {
            start[i] = at;
            at += pieces[i].lower.len();
        }
        let of = |m: &Mesh| -> Vec<DataArray> { m.data.lower.iter().filter(|a| a.name != GHOST).cloned().collect() };
        let per_piece: Vec<Vec<DataArray>> = with.iter().map(|&i| of(&pieces[i])).collect();
        let shape = |a: &[DataArray]| -> Vec<(String, ValueType, usize)> {
            a.iter().map(|a| (a.name.clone(), a.ty, a.components)).collect()
        };
        if let Some(k) = per_piece.iter().position(|a| shape(a) != shape(&per_piece[0])) {
            return Err(err(
                with[k],
                "its lower-cell arrays differ from those of the other pieces".into(),
            ));
        }
        let rows: Vec<usize> = lower.iter().map(|&(i, c)| start[i] + c).collect();
        mesh.data.lower = concat_select(&per_piece, &rows);
    }
    if !keep_ids {
        drop_counting_ids(&mut mesh.data.point, &POINT_ID_NAMES);
        drop_counting_ids(&mut mesh.data.cell, &[GLOBAL_CELL_IDS]);
        // the lower cells' ids counted on from the elements': gone with theirs
        if mesh.data.cell_array(GLOBAL_CELL_IDS).is_none() {
            mesh.data.lower.retain(|a| a.name != GLOBAL_CELL_IDS);
        }
    }
    Ok(mesh)
}

/// Array k of every piece, end to end, restricted to `rows`.
fn concat_select(per_piece: &[Vec<DataArray>], rows: &[usize]) -> Vec<DataArray> {
    (0..per_piece[0].len())
        .map(|k| {
            let first = &per_piece[0][k];
            // every piece's array k has the first piece's type (checked on reading)
            fn join<T: Clone>(
                per_piece: &[Vec<DataArray>],
                k: usize,
                pick: impl Fn(&Values) -> Option<&Vec<T>>,
            ) -> Vec<T> {
                per_piece
                    .iter()
                    .flat_map(|a| pick(&a[k].values).cloned().unwrap_or_default())
                    .collect()
            }
            let values = match &first.values {
                Values::Int(_) => Values::Int(join(per_piece, k, |v| match v {
                    Values::Int(x) => Some(x),
                    _ => None,
                })),
                Values::Float(_) => Values::Float(join(per_piece, k, |v| match v {
                    Values::Float(x) => Some(x),
                    _ => None,
                })),
                Values::Str(_) => Values::Str(join(per_piece, k, |v| match v {
                    Values::Str(x) => Some(x),
                    _ => None,
                })),
            };
            DataArray::new(first.name.clone(), first.ty, first.components, values).select(rows)
        })
        .collect()
}

/// Removes the id arrays called `names` whose values are 0, 1, ..., n-1.
fn drop_counting_ids(arrays: &mut Vec<DataArray>, names: &[&str]) {
    arrays.retain(|a| {
        !(names.contains(&a.name.as_str())
            && a.components == 1
            && matches!(&a.values, Values::Int(v) if v.iter().enumerate().all(|(i, &x)| x == i as i64)))
    });
}

/// `path` with `_r.vtu` in place of its extension: piece r's file.
pub fn piece_path(path: &Path, r: usize) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!("{stem}_{r}.vtu"))
}

/// Writes `mesh` as the index `path` and `parts` pieces beside it (see
/// [`piece_path`]): piece r holds the elements whose first vertex `owner`
/// gives to r, the vertices they use and the vertices r owns that no element
/// uses; a part with none of these gets no piece. Each piece is written
/// atomically, the index last, so an index never names a piece that was not
/// written. Returns the pieces' paths.
pub fn write_pieces(
    path: &Path,
    mesh: &Mesh,
    owner: &[u32],
    parts: usize,
    format: Format,
    cell_data: &[CellData],
) -> Result<Vec<PathBuf>> {
    write_pieces_with(path, mesh, owner, parts, format, cell_data, &mut LocalPieces)
}

/// Who writes the pieces of [`write_pieces_with`]: this process, or the
/// ranks of an MPI job, each its own.
pub trait PieceWriter {
    /// Writes piece `r` to `path` atomically, or hands it to the process that
    /// will (which may still be writing when this returns).
    fn put(&mut self, r: usize, path: &Path, piece: &Mesh, format: Format, cell_data: &[CellData]) -> Result<()>;
    /// Returns when every piece handed out is written (the first error if
    /// one was not); the index is written after it, so it never names a
    /// piece that is not there.
    fn done(&mut self) -> Result<()> {
        Ok(())
    }
}

/// Every piece written here, in turn.
pub struct LocalPieces;

impl PieceWriter for LocalPieces {
    fn put(&mut self, _r: usize, path: &Path, piece: &Mesh, format: Format, cell_data: &[CellData]) -> Result<()> {
        write(path, piece, format, cell_data)
    }
}

/// [`write_pieces`], each piece written by `writer`.
pub fn write_pieces_with(
    path: &Path,
    mesh: &Mesh,
    owner: &[u32],
    parts: usize,
    format: Format,
    cell_data: &[CellData],
    writer: &mut dyn PieceWriter,
) -> Result<Vec<PathBuf>> {
    if !matches!(format, Format::VtuAscii | Format::VtuBinary | Format::VtuZlib) {
        return Err(Error::InvalidArgument(format!(
            "{}: pieces are VTK XML files: the format must be vtu, vtu-binary or vtu-zlib, not {format}",
            path.display()
        )));
    }
    if owner.len() != mesh.num_points() || owner.iter().any(|&r| r as usize >= parts) {
        return Err(Error::InvalidArgument(format!(
            "{}: the partition does not fit the mesh ({} owners for {} points, {parts} parts)",
            path.display(),
            owner.len(),
            mesh.num_points()
        )));
    }
    // a piece's cell arrays under the mesh's names
    fn with_names<'a>(cell_data: &[CellData<'a>], data: &'a [Vec<f64>]) -> Vec<CellData<'a>> {
        cell_data
            .iter()
            .zip(data)
            .map(|(c, v)| CellData {
                name: c.name,
                values: v,
            })
            .collect()
    }
    let mut elems: Vec<Vec<usize>> = vec![Vec::new(); parts];
    for e in 0..mesh.num_elements() {
        elems[owner[mesh.element(e)[0] as usize] as usize].push(e);
    }
    // lower cells go with their first vertex too
    let mut lowers: Vec<Vec<usize>> = vec![Vec::new(); parts];
    for (c, (_, vs)) in mesh.lower.iter().enumerate() {
        lowers[owner[vs[0] as usize] as usize].push(c);
    }
    let mut used = vec![false; mesh.num_points()];
    for &v in &mesh.conn {
        used[v as usize] = true;
    }
    let mut sources = Vec::with_capacity(parts);
    let mut paths = Vec::with_capacity(parts);
    let mut first_piece = None;
    let mut failed = None;
    for (r, (elems, lower)) in elems.iter().zip(&lowers).enumerate() {
        let mut verts: Vec<usize> = elems
            .iter()
            .flat_map(|&e| mesh.element(e).iter().map(|&v| v as usize))
            .chain(lower.iter().flat_map(|&c| mesh.lower[c].1.iter().map(|&v| v as usize)))
            .chain((0..mesh.num_points()).filter(|&v| !used[v] && owner[v] as usize == r))
            .collect();
        verts.sort_unstable();
        verts.dedup();
        // a part owning no element and no lone vertex has nothing to write
        if verts.is_empty() {
            continue;
        }
        let piece = piece_mesh(mesh, &verts, elems, lower);
        let data: Vec<Vec<f64>> = cell_data
            .iter()
            .map(|c| elems.iter().map(|&e| c.values[e]).collect())
            .collect();
        let p = piece_path(path, r);
        // pieces handed out before a failure are still waited for (`done`)
        if let Err(e) = writer.put(r, &p, &piece, format, &with_names(cell_data, &data)) {
            failed = Some(e);
            break;
        }
        sources.push(
            p.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
        );
        paths.push(p);
        if first_piece.is_none() {
            first_piece = Some((piece, data));
        }
    }
    let written = writer.done();
    if let Some(e) = failed {
        return Err(e);
    }
    written?;
    let Some((piece, data)) = first_piece else {
        return Err(Error::InvalidArgument(format!(
            "{}: the mesh has no points to write",
            path.display()
        )));
    };
    write_index(path, &piece, &with_names(cell_data, &data), &sources)?;
    Ok(paths)
}

/// The part of `mesh` on vertices `verts`, elements `elems` and lower
/// cells `lower` (all ascending), with their global ids (a lower cell's
/// global cell id counts on after the elements', as in a whole file).
fn piece_mesh(mesh: &Mesh, verts: &[usize], elems: &[usize], lower: &[usize]) -> Mesh {
    let mut piece = mesh.cut(verts, elems);
    if !lower.is_empty() {
        let local: HashMap<u32, u32> = verts.iter().enumerate().map(|(l, &v)| (v as u32, l as u32)).collect();
        piece.lower = lower
            .iter()
            .map(|&c| (mesh.lower[c].0, mesh.lower[c].1.iter().map(|v| local[v]).collect()))
            .collect();
    }
    let ids = |name: &str, rows: &[usize]| {
        DataArray::new(
            name,
            ValueType::I64,
            1,
            Values::Int(rows.iter().map(|&i| i as i64).collect()),
        )
    };
    // the arrays at `rows` (but any id arrays), then the global ids `ids_of`
    let select = |arrays: &[DataArray], drop: &[&str], rows: &[usize], id: &str, ids_of: &[usize]| -> Vec<DataArray> {
        arrays
            .iter()
            .filter(|a| !drop.contains(&a.name.as_str()))
            .map(|a| a.select(rows))
            .chain([ids(id, ids_of)])
            .collect()
    };
    piece.data.point = select(&mesh.data.point, &POINT_ID_NAMES, verts, GLOBAL_POINT_IDS, verts);
    piece.data.cell = select(&mesh.data.cell, &[GLOBAL_CELL_IDS], elems, GLOBAL_CELL_IDS, elems);
    if !lower.is_empty() {
        let ne = mesh.num_elements();
        let rows: Vec<usize> = lower.iter().map(|&c| ne + c).collect();
        piece.data.lower = select(&mesh.data.lower, &[GLOBAL_CELL_IDS], lower, GLOBAL_CELL_IDS, &rows);
    }
    piece.data.field = mesh.data.field.clone();
    piece
}
