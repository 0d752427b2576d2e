//! OpenFOAM polyMesh cases: `constant/polyMesh/{points,faces,owner,
//! neighbour,boundary}` and the optional `cellZones`, `faceZones` and
//! `pointZones`, ASCII or binary (`arch` labels of 32 or 64 bits, scalars
//! of 32 or 64), each file possibly gzip-compressed (`points.gz`); `faces`
//! as a `faceList` or a `faceCompactList`.
//!
//! A case is named by its folder, its `constant/polyMesh` folder or the
//! `.foam` marker file ParaView opens. Reading, each cell becomes an
//! element in cell order: a tetrahedron, hexahedron or prism (in VTK's
//! vertex order) where its faces have that shape, else a polyhedron, its
//! faces turned outward (a face's normal points out of its owner); a
//! pyramid is refused, as in every format. The boundary faces become
//! lower cells (a polygon split into triangles) tagged by patch in the
//! `gmsh:physical` arrays with the patch names as physical names, so a
//! patch is a group for `--fix-group` and `--free-group`; their vertices
//! are fixed like any file's boundary faces, and under a sliding boundary
//! those of `wall` patches stay fixed. `cellZones` become element sets,
//! `pointZones` node sets, `faceZones` node sets of their faces' points.
//! Only `constant/polyMesh` is read (not the meshes of time folders).
//!
//! Writing a mesh read from a polyMesh keeps its faces, owners,
//! neighbours, `boundary` and zone files (byte for byte), its
//! compression, label and scalar sizes, and the other files of its
//! polyMesh folder (`sets/`, `cellLevel`); only the points change, and
//! the format (ASCII or binary) is the one asked for. Any other mesh has
//! its faces built from its elements (internal faces ordered by owner,
//! then neighbour), its boundary faces grouped into one patch per group of
//! the lower cells on them (`defaultFaces` where there is none), its
//! element sets written as `cellZones` and node sets as `pointZones`. The
//! polyMesh folder is written whole beside its place and renamed into it;
//! the case it was read from is never written.

mod build;
mod cells;
mod foamfile;
mod read;
mod write;

use std::path::{Path, PathBuf};

use super::limits::{Budget, ReadLimits};
use super::{Format, Staged};
use crate::error::{Error, Result};
use crate::mesh::Mesh;

/// Whether `path` is a `.foam` marker file's name (it need not exist).
fn is_marker(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("foam"))
}

/// The polyMesh folder a path to read names: a case folder (with
/// `constant/polyMesh`), a polyMesh folder (with `faces`), or a `.foam`
/// marker; `None` for anything else.
pub(crate) fn polymesh_dir(path: &Path) -> Option<PathBuf> {
    if is_marker(path) && !path.is_dir() {
        return Some(write::Target::of(path).polymesh());
    }
    if !path.is_dir() {
        return None;
    }
    let inner = path.join("constant").join("polyMesh");
    if inner.is_dir() {
        return Some(inner);
    }
    (read::find(path, "faces").is_some() || read::find(path, "owner").is_some()).then(|| path.to_path_buf())
}

/// Whether writing to `path` writes an OpenFOAM case: a folder with a
/// `constant` folder, a `.foam` marker, or a path ending in
/// `constant/polyMesh` (any other folder needs the format named).
pub(crate) fn is_case_output(path: &Path) -> bool {
    is_marker(path) || path.ends_with("constant/polyMesh") || path.join("constant").is_dir()
}

/// The OpenFOAM format of the case at `path` (binary when its `points`
/// says so), if it is one.
pub(crate) fn format_of(path: &Path) -> Option<Format> {
    let dir = polymesh_dir(path)?;
    let (points, gz) = read::find(&dir, "points")?;
    let head: Vec<u8> = if gz {
        use std::io::Read;
        let f = std::fs::File::open(&points).ok()?;
        let mut out = Vec::new();
        flate2::read::MultiGzDecoder::new(f)
            .take(4096)
            .read_to_end(&mut out)
            .ok()?;
        out
    } else {
        use std::io::Read;
        let mut out = Vec::new();
        std::fs::File::open(&points)
            .ok()?
            .take(4096)
            .read_to_end(&mut out)
            .ok()?;
        out
    };
    let text = String::from_utf8_lossy(&head);
    let binary = text
        .lines()
        .map(str::trim)
        .any(|l| l.starts_with("format") && l.contains("binary"));
    Some(if binary {
        Format::OpenFoamBinary
    } else {
        Format::OpenFoam
    })
}

/// Whether two folders are one (links and `..` resolved; a path that does
/// not exist yet by its nearest existing ancestor).
fn same_dir(a: &Path, b: &Path) -> bool {
    fn norm(p: &Path) -> Option<PathBuf> {
        if let Ok(c) = p.canonicalize() {
            return Some(c);
        }
        let name = p.file_name()?;
        let parent = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        Some(norm(parent)?.join(name))
    }
    match (norm(a), norm(b)) {
        (Some(x), Some(y)) => x == y,
        _ => false,
    }
}

/// Whether writing an OpenFOAM case to `output` would write into the case
/// `input` names.
pub fn same_case(output: &Path, input: &Path) -> bool {
    match polymesh_dir(input) {
        Some(src) => same_dir(&write::Target::of(output).polymesh(), &src),
        None => false,
    }
}

/// The case at `path` (its polyMesh folder `dir`), read within `limits`.
pub(crate) fn read_case(path: &Path, dir: &Path, limits: &ReadLimits) -> Result<Mesh> {
    if !dir.is_dir() {
        return Err(Error::parse(
            path,
            None,
            format!("not an OpenFOAM case: {} is not a folder", dir.display()),
        ));
    }
    let budget = Budget::new(path, limits);
    read::read(dir, &budget)
}

/// Stages `mesh` as the case `path` names (binary where `binary`).
pub(crate) fn stage(path: &Path, mesh: &Mesh, binary: bool) -> Result<Staged> {
    write::stage(path, mesh, binary)
}
