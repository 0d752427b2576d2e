//! Mesh files: VTK legacy, XML and HDF, Gmsh, Medit, Abaqus, Exodus II, OpenFOAM, STL, OBJ, PLY; atomic writes.
//!
//! Readers produce a `RawMesh` (every cell in file order, with its shape);
//! `RawMesh::into_mesh` then splits top-dimensional elements from lower
//! cells the same way for every format, and [`read`] validates the result.
//!
//! Conventions:
//! - vertices of lower cells are fixed; so are those flagged by VTK point data
//!   `fixed`, Medit RequiredVertices, or Gmsh point elements. `Mesh::fixed` is
//!   left empty when no vertex is fixed;
//! - VTK/VTU files store the elements, then the lower cells (`vtk_cells`);
//!   their cell arrays cover both, the lower cells' values from
//!   `MeshData::lower`, and where there are none (the `cell_data` quality
//!   arrays, which measure elements only) NaN for floats, 0 for integers
//!   and "" for strings; `.pvtu` pieces hold them too. VTK/VTU carry
//!   `fixed` as point data; Gmsh stores fixed vertices not covered by lower
//!   cells as point elements (type 15), which read back as lower `Vertex`
//!   cells; Medit stores them as RequiredVertices and groups elements by kind;
//! - the input's point, cell and field arrays live in `Mesh::data` and are
//!   written to VTK/VTU (all of them, after the `cell_data` quality arrays of
//!   [`write`] replace any input array of the same name); Gmsh keeps the
//!   `gmsh:physical`/`gmsh:geometrical` cell arrays as element tags and its
//!   `$PhysicalNames`; Medit keeps nothing but the mesh;
//! - named sets are `MeshData::node_sets` (vertex ids) and
//!   `MeshData::element_sets` (element and lower-cell ids; a cell can be in
//!   several): Abaqus `*NSET`/`*ELSET` read and write them, readers of other
//!   formats with sets (Exodus node sets) fill the same fields through
//!   `RawMesh::node_sets`/`cell_sets`. Both are groups for `--fix-group` and
//!   `--free-group` beside Gmsh's physical groups; a node set fixes nothing
//!   by itself. VTK/VTU carry them as field arrays `node_set:NAME` and
//!   `element_set:NAME`; Gmsh and Medit drop them;
//! - Abaqus keeps its node and element numbers and element types as the
//!   arrays `abaqus:node_id`, `abaqus:element_id`, `abaqus:type` and
//!   `abaqus:types`, which the `.inp` writer puts back;
//! - Exodus II (cargo feature `exodus`) keeps its blocks (element sets and
//!   the cell array `exodus:block_id`), node sets, side sets (boundary cells
//!   in element sets), number maps and last time step's variables (see `exodus`);
//! - VTKHDF (cargo feature `vtkhdf`) keeps what a `.vtu` keeps, its pieces
//!   merged on reading (see `vtkhdf`);
//! - an OpenFOAM case (a folder) keeps its faces, patches and zones in
//!   `MeshData::polymesh`, which only the OpenFOAM writer puts back; its
//!   patches are physical groups and its zones sets (see `openfoam`);
//! - the surface formats STL, OBJ and PLY hold triangles (and, but for
//!   STL, quadrilaterals) and no lower cells; STL's solids and OBJ's groups
//!   read as element sets, which their writers put back; PLY's extra vertex
//!   and face properties are point and cell arrays (see `stl`, `obj`, `ply`);
//! - VTK XML PolyData (`.vtp`) holds triangles and quadrilaterals, with
//!   vertices and lines as lower cells, and keeps what a `.vtu` keeps; its
//!   cells are in VTK's order (vertices, lines, polygons), and so are its
//!   cell arrays and the cell numbers of its element sets (see `vtu`);
//! - `cell_data` is written to VTK/VTU/VTP, PLY, Exodus and VTKHDF only
//!   (other formats check its length).

mod abaqus;
mod atomic;
mod batch;
mod codec;
#[cfg(feature = "exodus")]
mod exodus;
mod gmsh;
mod input;
mod lex;
mod limits;
mod medit;
#[cfg(feature = "exodus")]
mod netcdf_classic;
mod obj;
mod openfoam;
mod ply;
mod pvtu;
mod smoothed;
mod stl;
mod vtk;
mod vtk_cells;
#[cfg(feature = "vtkhdf")]
mod vtkhdf;
mod vtu;

pub use atomic::{Staged, is_stream, same_file, same_target, stage, write_atomic};
pub use limits::ReadLimits;
pub use openfoam::same_case;
pub use pvtu::{
    GLOBAL_CELL_IDS, GLOBAL_POINT_IDS, LocalPieces, PieceWriter, merge_pieces, merge_share, piece_error, piece_path,
    piece_paths, point_ids, write_index, write_pieces, write_pieces_with,
};
pub use smoothed::{eta_field, stage_mesh, write_mesh, write_mesh_pieces, write_mesh_pieces_with, write_mesh_to};

use std::fmt;
use std::path::Path;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::mesh::{DataArray, ElementKind, ElementSet, LowerKind, Mesh, NodeSet, PhysicalName, ValueType, Values};

/// File formats meshsmooth reads and writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Format {
    /// Legacy VTK, ASCII.
    VtkAscii,
    /// Legacy VTK, binary.
    VtkBinary,
    /// VTK XML unstructured grid, ASCII.
    VtuAscii,
    /// Inline base64, uncompressed.
    VtuBinary,
    /// Inline base64, zlib-compressed in VTK's block format (`vtkZLibDataCompressor`).
    VtuZlib,
    /// Gmsh 2.2, ASCII.
    Msh22Ascii,
    /// Gmsh 2.2, binary.
    Msh22Binary,
    /// Gmsh 4.1, ASCII.
    Msh41Ascii,
    /// Gmsh 4.1, binary.
    Msh41Binary,
    /// Medit (`.mesh`), ASCII.
    Medit,
    /// Abaqus input (`.inp`), ASCII.
    Abaqus,
    /// Exodus II (`.exo`, `.e`): netCDF, classic or netCDF-4 (cargo feature `exodus`).
    Exodus,
    /// VTKHDF (`.vtkhdf`, `.hdf`): VTK's HDF5 format, an UnstructuredGrid (cargo feature `vtkhdf`).
    VtkHdf,
    /// VTK XML PolyData (`.vtp`), inline base64, uncompressed: surfaces
    /// (triangles and quadrilaterals) with vertices and lines as lower cells.
    Vtp,
    /// VTK XML PolyData, ASCII.
    VtpAscii,
    /// VTK XML PolyData, inline base64 with zlib blocks (`vtkZLibDataCompressor`).
    VtpZlib,
    /// OpenFOAM polyMesh case (a folder), ASCII.
    OpenFoam,
    /// OpenFOAM polyMesh case, binary.
    OpenFoamBinary,
    /// STL (`.stl`), binary: triangles only.
    StlBinary,
    /// STL, ASCII.
    StlAscii,
    /// Wavefront OBJ (`.obj`), ASCII.
    Obj,
    /// PLY (`.ply`), binary little-endian.
    PlyBinary,
    /// PLY, ASCII.
    PlyAscii,
}

/// What a build without the `exodus` feature says of an Exodus II (netCDF) file.
#[cfg(not(feature = "exodus"))]
const NO_EXODUS: &str = "an Exodus II (netCDF) file, which this build of meshsmooth cannot read or write: \
     build it with `--features exodus` (needs libnetCDF, Debian's libnetcdf-dev)";

/// What a build without the `vtkhdf` feature says of a VTKHDF file.
#[cfg(not(feature = "vtkhdf"))]
const NO_VTKHDF: &str = "a VTKHDF (HDF5) file, which this build of meshsmooth cannot read or write: \
     build it with `--features vtkhdf` (needs libHDF5, Debian's libhdf5-dev)";

/// How much of a file [`Format::of_file`] reads: a VTU file's first array
/// (and its compressor attribute) sits within the header.
const HEAD_BYTES: u64 = 64 << 10;

const EXTENSIONS: &str = ".vtk (legacy VTK), .vtu (VTK XML), .pvtu (VTK XML pieces: read, or written by smooth --pieces), .vtp (VTK XML PolyData), .msh (Gmsh 2.2/4.1), .mesh (Medit), .inp (Abaqus), .exo/.e (Exodus II), .vtkhdf/.hdf (VTKHDF), .stl (STL), .obj (Wavefront OBJ), .ply (PLY), an OpenFOAM case folder or its .foam file";

impl Format {
    /// Every format.
    pub const ALL: [Format; 23] = [
        Format::VtkAscii,
        Format::VtkBinary,
        Format::VtuAscii,
        Format::VtuBinary,
        Format::VtuZlib,
        Format::Msh22Ascii,
        Format::Msh22Binary,
        Format::Msh41Ascii,
        Format::Msh41Binary,
        Format::Medit,
        Format::Abaqus,
        Format::Exodus,
        Format::VtkHdf,
        Format::OpenFoam,
        Format::OpenFoamBinary,
        Format::StlBinary,
        Format::StlAscii,
        Format::Obj,
        Format::PlyBinary,
        Format::PlyAscii,
        Format::Vtp,
        Format::VtpAscii,
        Format::VtpZlib,
    ];

    /// Default format for a file name's extension (used for writing; reading
    /// also looks at the content).
    pub fn from_path(path: &Path) -> Result<Format> {
        if openfoam::is_case_output(path) {
            return Ok(Format::OpenFoam);
        }
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        if path.is_dir() {
            return Err(Error::Unsupported(format!(
                "{} is a folder but not an OpenFOAM case (it has no constant folder): give a file name, \
                 or the format openfoam to write a case there",
                path.display()
            )));
        }
        match ext.as_deref() {
            Some("vtk") => Ok(Format::VtkAscii),
            Some("vtu") => Ok(Format::VtuAscii),
            Some("vtp") => Ok(Format::Vtp),
            Some("msh") => Ok(Format::Msh41Ascii),
            Some("mesh") => Ok(Format::Medit),
            Some("inp") => Ok(Format::Abaqus),
            Some("exo" | "e" | "ex2" | "exii" | "gen" | "g") => Ok(Format::Exodus),
            Some("vtkhdf" | "hdf" | "hdf5" | "h5") => Ok(Format::VtkHdf),
            Some("stl") => Ok(Format::StlBinary),
            Some("obj") => Ok(Format::Obj),
            Some("ply") => Ok(Format::PlyBinary),
            _ => Err(Error::Unsupported(format!(
                "{}: unknown mesh file extension; supported: {EXTENSIONS}",
                path.display()
            ))),
        }
    }

    /// The format to write `path` in when none is named, for a mesh read
    /// from `input`: the extension's family in the input's encoding (a
    /// binary or compressed input stays binary or compressed, and a Gmsh
    /// file keeps its version); the extension's default ([`Format::from_path`])
    /// where the input's encoding is unknown (a `.pvtu` index, a file that
    /// cannot be read).
    pub fn following(path: &Path, input: &Path) -> Result<Format> {
        let from = Format::of_file(input);
        // a new case folder has no extension to tell
        let foam = matches!(from, Some(Format::OpenFoam | Format::OpenFoamBinary));
        let default = match Format::from_path(path) {
            Err(_) if foam && path.extension().is_none() => Format::OpenFoam,
            other => other?,
        };
        let Some(from) = from else {
            return Ok(default);
        };
        let (binary, compressed) = (from.is_binary(), matches!(from, Format::VtuZlib | Format::VtpZlib));
        Ok(match default {
            Format::VtkAscii if binary => Format::VtkBinary,
            Format::VtuAscii if compressed => Format::VtuZlib,
            Format::VtuAscii if binary => Format::VtuBinary,
            // PolyData defaults to base64: an ASCII one stays ASCII, and a
            // compressed VTK XML input (grid or PolyData) gives compressed
            Format::Vtp if compressed => Format::VtpZlib,
            Format::Vtp if from == Format::VtpAscii => from,
            Format::Msh41Ascii if matches!(from, Format::Msh22Ascii | Format::Msh22Binary) => from,
            Format::Msh41Ascii if binary => Format::Msh41Binary,
            Format::OpenFoam if binary => Format::OpenFoamBinary,
            // the surface formats default to binary: an ASCII input stays ASCII
            Format::StlBinary if from == Format::StlAscii => from,
            Format::PlyBinary if from == Format::PlyAscii => from,
            other => other,
        })
    }

    /// Whether the format stores its numbers in binary.
    pub fn is_binary(self) -> bool {
        matches!(
            self,
            Format::VtkBinary
                | Format::VtuBinary
                | Format::VtuZlib
                | Format::Msh22Binary
                | Format::Msh41Binary
                | Format::OpenFoamBinary
                | Format::StlBinary
                | Format::PlyBinary
                | Format::Exodus
                | Format::VtkHdf
                | Format::Vtp
                | Format::VtpZlib
        )
    }

    /// Whether the format is VTK XML PolyData (`.vtp`), in any encoding.
    fn is_poly_data(self) -> bool {
        matches!(self, Format::Vtp | Format::VtpAscii | Format::VtpZlib)
    }

    /// Whether the format is an OpenFOAM case (a folder, not a file).
    pub fn is_openfoam(self) -> bool {
        matches!(self, Format::OpenFoam | Format::OpenFoamBinary)
    }

    /// The format a mesh file is in, from its first bytes (`None` for a
    /// `.pvtu` index, an unknown or unreadable file, and anything but a
    /// regular file: a pipe's first bytes are the reader's, not ours to
    /// take). A VTU file whose
    /// arrays are compressed by any compressor counts as [`Format::VtuZlib`],
    /// the compressed VTU meshsmooth writes; raw appended data as
    /// [`Format::VtuBinary`].
    pub fn of_file(path: &Path) -> Option<Format> {
        use std::io::Read;
        if let Some(f) = openfoam::format_of(path) {
            return Some(f);
        }
        if !std::fs::metadata(path).ok()?.is_file() {
            return None;
        }
        let mut head = Vec::new();
        std::fs::File::open(path)
            .ok()?
            .take(HEAD_BYTES)
            .read_to_end(&mut head)
            .ok()?;
        let text = String::from_utf8_lossy(&head);
        let mut lines = text.lines().map(str::trim).filter(|l| !l.is_empty());
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        let Some(family) = sniff(&head) else {
            // binary STL and OBJ have no magic: their extension tells
            return match ext.as_deref() {
                Some("stl") => Some(Format::StlBinary),
                Some("obj") => Some(Format::Obj),
                _ => None,
            };
        };
        match family {
            Family::Vtk => {
                let kind = lines.nth(2)?;
                Some(if kind.eq_ignore_ascii_case("binary") {
                    Format::VtkBinary
                } else {
                    Format::VtkAscii
                })
            }
            Family::Vtu => {
                if text.contains("PUnstructuredGrid") {
                    return None;
                }
                let binary = text.contains("format=\"binary\"") || text.contains("format=\"appended\"");
                let compressed = text.contains("compressor=");
                if text.contains("type=\"PolyData\"") {
                    // VTK names a compressor in its ASCII files too
                    return Some(match (binary, compressed) {
                        (false, _) => Format::VtpAscii,
                        (true, false) => Format::Vtp,
                        (true, true) => Format::VtpZlib,
                    });
                }
                Some(if compressed {
                    Format::VtuZlib
                } else if binary {
                    Format::VtuBinary
                } else {
                    Format::VtuAscii
                })
            }
            Family::Gmsh => {
                let t: Vec<&str> = lines.nth(1)?.split_whitespace().collect();
                let binary = t.get(1) == Some(&"1");
                Some(match (t.first()?.starts_with('2'), binary) {
                    (true, false) => Format::Msh22Ascii,
                    (true, true) => Format::Msh22Binary,
                    (false, false) => Format::Msh41Ascii,
                    (false, true) => Format::Msh41Binary,
                })
            }
            Family::Medit => Some(Format::Medit),
            Family::Abaqus => Some(Format::Abaqus),
            Family::Exodus => Some(Format::Exodus),
            Family::Hdf5 => Some(hdf5_format(path, &head)),
            Family::Stl => {
                let len = std::fs::metadata(path).ok()?.len();
                let n = head
                    .get(80..84)
                    .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u64);
                Some(if n.is_some_and(|n| 84 + 50 * n == len) {
                    Format::StlBinary
                } else {
                    Format::StlAscii
                })
            }
            Family::Obj => Some(Format::Obj),
            Family::Ply => Some(if text.lines().nth(1)?.contains("ascii") {
                Format::PlyAscii
            } else {
                Format::PlyBinary
            }),
        }
    }

    /// Parse a command-line format name.
    pub fn from_name(name: &str) -> Option<Format> {
        Format::ALL.into_iter().find(|f| f.name() == name)
    }

    /// The format's command-line name (`vtk`, `vtu-zlib`, `msh4`, `medit`, ...); see [`Format::from_name`].
    pub fn name(self) -> &'static str {
        match self {
            Format::VtkAscii => "vtk",
            Format::VtkBinary => "vtk-binary",
            Format::VtuAscii => "vtu",
            Format::VtuBinary => "vtu-binary",
            Format::VtuZlib => "vtu-zlib",
            Format::Msh22Ascii => "msh2",
            Format::Msh22Binary => "msh2-binary",
            Format::Msh41Ascii => "msh4",
            Format::Msh41Binary => "msh4-binary",
            Format::Medit => "medit",
            Format::Abaqus => "abaqus",
            Format::Exodus => "exodus",
            Format::VtkHdf => "vtkhdf",
            Format::Vtp => "vtp",
            Format::VtpAscii => "vtp-ascii",
            Format::VtpZlib => "vtp-zlib",
            Format::OpenFoam => "openfoam",
            Format::OpenFoamBinary => "openfoam-binary",
            Format::StlBinary => "stl",
            Format::StlAscii => "stl-ascii",
            Format::Obj => "obj",
            Format::PlyBinary => "ply",
            Format::PlyAscii => "ply-ascii",
        }
    }

    /// Whether the format stores lower-dimensional cells (boundary faces and
    /// lines, points) and their cell arrays: every format but the surface
    /// formats STL, OBJ and PLY, which hold the elements only (VTK PolyData
    /// holds lines and points, not faces).
    pub fn keeps_lower_cells(self) -> bool {
        match self {
            Format::VtkAscii | Format::VtkBinary | Format::VtuAscii | Format::VtuBinary | Format::VtuZlib => true,
            Format::Msh22Ascii | Format::Msh22Binary | Format::Msh41Ascii | Format::Msh41Binary => true,
            Format::Medit | Format::Abaqus | Format::Exodus | Format::VtkHdf => true,
            Format::OpenFoam | Format::OpenFoamBinary => true,
            Format::Vtp | Format::VtpAscii | Format::VtpZlib => true,
            Format::StlBinary | Format::StlAscii | Format::Obj | Format::PlyBinary | Format::PlyAscii => false,
        }
    }

    /// Whether the format holds surfaces only (triangles, and for OBJ, PLY
    /// and VTP quadrilaterals): STL, OBJ, PLY, VTK PolyData.
    pub fn is_surface_only(self) -> bool {
        !self.keeps_lower_cells() || self.is_poly_data()
    }

    /// Whether the format stores per-element data given to [`write`]
    /// (VTK, VTU, VTP, PLY, Exodus, VTKHDF).
    pub fn keeps_cell_data(self) -> bool {
        matches!(
            self,
            Format::VtkAscii
                | Format::VtkBinary
                | Format::VtuAscii
                | Format::VtuBinary
                | Format::VtuZlib
                | Format::PlyBinary
                | Format::PlyAscii
                | Format::Exodus
                | Format::VtkHdf
                | Format::Vtp
                | Format::VtpAscii
                | Format::VtpZlib
        )
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One value per element, written as cell data where the format supports it.
#[derive(Clone, Copy, Debug)]
pub struct CellData<'a> {
    /// The array's name.
    pub name: &'a str,
    /// One value per element.
    pub values: &'a [f64],
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Family {
    Vtk,
    Vtu,
    Gmsh,
    Medit,
    Abaqus,
    Exodus,
    /// HDF5: a netCDF-4 (Exodus) or VTKHDF file, told apart by [`hdf5_format`].
    Hdf5,
    Stl,
    Ply,
    Obj,
}

fn sniff(data: &[u8]) -> Option<Family> {
    let start = data.iter().position(|b| !b.is_ascii_whitespace())?;
    let head = &data[start..data.len().min(start + 256)];
    let starts = |p: &str| {
        head.get(..p.len())
            .is_some_and(|h| h.eq_ignore_ascii_case(p.as_bytes()))
    };
    if starts("# vtk DataFile") {
        Some(Family::Vtk)
    } else if starts("<?xml") || starts("<VTKFile") {
        Some(Family::Vtu)
    } else if starts("$MeshFormat") {
        Some(Family::Gmsh)
    } else if starts("MeshVersionFormatted") {
        Some(Family::Medit)
    } else if starts("solid") {
        // ASCII STL, or a binary one whose header starts so: `stl` tells them apart by size
        Some(Family::Stl)
    } else if starts("ply") && head.get(3).is_some_and(|b| b.is_ascii_whitespace()) {
        Some(Family::Ply)
    } else if head.starts_with(b"CDF\x01") || head.starts_with(b"CDF\x02") || head.starts_with(b"CDF\x05") {
        // netCDF classic, 64-bit offset, 64-bit data
        Some(Family::Exodus)
    } else if head.starts_with(b"\x89HDF\r\n\x1a\n") {
        Some(Family::Hdf5)
    } else if starts("*") {
        // a keyword or a `**` comment: no other format starts with one
        Some(Family::Abaqus)
    } else {
        None
    }
}

/// Read a mesh, detecting the format from the content (falling back to the
/// extension), and validate it. A `.pvtu` index is read with all its pieces,
/// merged into one mesh (see `pvtu`).
/// Reading allocates at most [`ReadLimits::default`] (half the physical
/// memory unless [`ReadLimits::set_default`] said otherwise).
pub fn read(path: impl AsRef<Path>) -> Result<Mesh> {
    read_file(path.as_ref(), true, &ReadLimits::default())
}

/// [`read`] within `limits`: a file whose declared sizes, decompressed
/// blocks or decoded arrays would take more than `limits.max_bytes` is
/// refused with an error naming the file and the array or section.
pub fn read_with_limits(path: impl AsRef<Path>, limits: &ReadLimits) -> Result<Mesh> {
    read_file(path.as_ref(), true, limits)
}

/// The `.pvtu` index at `path`, its pieces read by `read_pieces` (given
/// their paths, it returns the meshes in that order; each piece read with
/// [`read_pvtu_piece`], its errors wrapped by [`piece_error`]), merged and validated as [`read`] does: the pieces
/// can be read by other processes. Any other file is read as [`read`] reads it.
pub fn read_pvtu_with(
    path: &Path,
    read_pieces: &mut dyn FnMut(&[std::path::PathBuf]) -> Result<Vec<Mesh>>,
) -> Result<Mesh> {
    let data = input::read_file(path, &limits::Budget::new(path, &ReadLimits::default()))?;
    if !pvtu::is_index(&data) {
        return read(path);
    }
    let mesh = pvtu::read_with(path, &data, read_pieces)?;
    mesh.validate().map_err(|e| in_file(path, e))?;
    Ok(mesh)
}

/// One piece of a `.pvtu` index, unmerged: any mesh file but another
/// index (errors name the piece only: see [`piece_error`]).
pub fn read_pvtu_piece(path: &Path) -> Result<Mesh> {
    read_piece(path, &ReadLimits::default())
}

/// One piece of a `.pvtu` index: any mesh file but another index.
fn read_piece(path: &Path, limits: &ReadLimits) -> Result<Mesh> {
    read_file(path, false, limits)
}

fn read_file(path: &Path, index_allowed: bool, limits: &ReadLimits) -> Result<Mesh> {
    if let Some(dir) = openfoam::polymesh_dir(path) {
        let mesh = openfoam::read_case(path, &dir, limits)?;
        mesh.validate().map_err(|e| in_file(path, e))?;
        return Ok(mesh);
    }
    let budget = limits::Budget::new(path, limits);
    let data = input::read_file(path, &budget)?;
    if data.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(Error::parse(path, None, "file is empty"));
    }
    let family = match sniff(&data) {
        Some(f) => f,
        None => match Format::from_path(path)? {
            Format::VtkAscii | Format::VtkBinary => Family::Vtk,
            Format::VtuAscii | Format::VtuBinary | Format::VtuZlib => Family::Vtu,
            Format::Vtp | Format::VtpAscii | Format::VtpZlib => Family::Vtu,
            Format::Medit => Family::Medit,
            Format::Abaqus => Family::Abaqus,
            Format::Exodus => Family::Exodus,
            Format::VtkHdf => Family::Hdf5,
            Format::StlBinary | Format::StlAscii => Family::Stl,
            Format::Obj => Family::Obj,
            Format::PlyBinary | Format::PlyAscii => Family::Ply,
            _ => Family::Gmsh,
        },
    };
    if family == Family::Vtu && pvtu::is_index(&data) {
        if !index_allowed {
            return Err(Error::parse(path, None, "a piece of a .pvtu index is itself an index"));
        }
        let mesh = pvtu::read(path, &data, limits)?;
        mesh.validate().map_err(|e| in_file(path, e))?;
        return Ok(mesh);
    }
    let family = match family {
        Family::Hdf5 if hdf5_format(path, &data) == Format::Exodus => Family::Exodus,
        f => f,
    };
    if family == Family::Hdf5 {
        #[cfg(feature = "vtkhdf")]
        {
            let (raws, names) = vtkhdf::read(path, &data, &budget)?;
            drop(data);
            let pieces = raws
                .into_iter()
                .map(|raw| {
                    let piece = raw.into_mesh(path)?;
                    piece.validate_structure().map_err(|e| in_file(path, e))?;
                    Ok(piece)
                })
                .collect::<Result<Vec<_>>>()?;
            let mesh = match <[Mesh; 1]>::try_from(pieces) {
                Ok([one]) => one,
                Err(pieces) => pvtu::merge_pieces(path, &pieces, &names)?,
            };
            mesh.validate().map_err(|e| in_file(path, e))?;
            check_wedge_convention(path, &mesh)?;
            return Ok(mesh);
        }
        #[cfg(not(feature = "vtkhdf"))]
        return Err(Error::parse(path, None, NO_VTKHDF));
    }
    let raw = match family {
        Family::Vtk => vtk::read(path, &data, &budget)?,
        Family::Vtu => vtu::read(path, &data, &budget)?,
        Family::Gmsh => gmsh::read(path, &data, &budget)?,
        Family::Medit => medit::read(path, &data, &budget)?,
        Family::Abaqus => abaqus::read(path, &data, &budget)?,
        #[cfg(feature = "exodus")]
        Family::Exodus => exodus::read(path, &data, &budget)?,
        #[cfg(not(feature = "exodus"))]
        Family::Exodus => return Err(Error::parse(path, None, NO_EXODUS)),
        Family::Hdf5 => unreachable!("read above"),
        Family::Stl => stl::read(path, &data, &budget)?,
        Family::Obj => obj::read(path, &data, &budget)?,
        Family::Ply => ply::read(path, &data, &budget)?,
    };
    drop(data);
    let mesh = raw.into_mesh(path)?;
    if index_allowed {
        mesh.validate().map_err(|e| in_file(path, e))?;
    } else {
        // a piece may hold points only other pieces' cells use; the merged mesh is validated whole
        mesh.validate_structure().map_err(|e| in_file(path, e))?;
    }
    if matches!(family, Family::Vtk | Family::Vtu) {
        check_wedge_convention(path, &mesh)?;
    }
    Ok(mesh)
}

/// Which HDF5 file `path` is: VTKHDF by its extension or, failing that, by
/// the name of its `VTKHDF` group among `data`'s bytes; else netCDF-4 (Exodus).
fn hdf5_format(path: &Path, data: &[u8]) -> Format {
    match Format::from_path(path) {
        Ok(f @ (Format::VtkHdf | Format::Exodus)) => f,
        _ if data.windows(6).any(|w| w == b"VTKHDF") => Format::VtkHdf,
        _ => Format::Exodus,
    }
}

/// A path libraries that open files by name (libnetCDF, libHDF5) can open
/// for `path`, whose bytes are `data`: `path` itself when it is a regular
/// file, else a private copy of `data` (kept while the guard lives).
#[cfg(any(feature = "exodus", feature = "vtkhdf"))]
fn on_disk(path: &Path, data: &[u8]) -> Result<(Option<tempfile::NamedTempFile>, std::path::PathBuf)> {
    if std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return Ok((None, path.to_path_buf()));
    }
    let copy = tempfile::NamedTempFile::new().map_err(|e| Error::io(path, e))?;
    std::fs::write(copy.path(), data).map_err(|e| Error::io(path, e))?;
    let p = copy.path().to_path_buf();
    Ok((Some(copy), p))
}

/// Output through a library that writes files by name: `build` writes a
/// private temporary file, which is then copied to `w` (the staged output).
#[cfg(any(feature = "exodus", feature = "vtkhdf"))]
fn through_file(w: &mut dyn std::io::Write, build: impl FnOnce(&Path) -> WriteResult) -> WriteResult {
    let dir = tempfile::tempdir().map_err(WriteError::Io)?;
    let tmp = dir.path().join("out");
    build(&tmp)?;
    let mut f = std::fs::File::open(&tmp).map_err(WriteError::Io)?;
    std::io::copy(&mut f, w).map_err(WriteError::Io)?;
    Ok(())
}

/// Errors about a mesh read from `path` (invalid, inverted, unsupported)
/// name the file; errors that already do are returned as they are.
pub fn in_file(path: &Path, e: Error) -> Error {
    match e {
        Error::InvalidMesh(msg) => Error::parse(path, None, msg),
        e @ (Error::Inverted { .. } | Error::Untangle { .. } | Error::Unsupported(_)) => {
            Error::parse(path, None, e.to_string())
        }
        other => other,
    }
}

/// VTK's wedge, as VTK 9.7's vtkCellValidator and vtkMeshQuality (and so
/// ParaView) judge it, has its base triangle (0,1,2) ordered with its normal
/// toward the top (3,4,5) — meshsmooth's and Gmsh's order, so VTK files need
/// no permutation. Some writers reverse the base when they write VTK: Gmsh's
/// VTK export (its `MPrism::getVertexVTK` maps 0,2,1,3,5,4) and meshio 5.3
/// both do. When every wedge of a VTK file is inverted in VTK's order but
/// valid reversed, the file's wedges have their base reversed: say so, and
/// name those writers rather than guess which one it was.
fn check_wedge_convention(path: &Path, mesh: &Mesh) -> Result<()> {
    let prisms = mesh.count_kind(ElementKind::Prism);
    if prisms == 0 {
        return Ok(());
    }
    let bad = crate::metric::inverted_elements(mesh, &mesh.points);
    let bad_prisms = bad.iter().filter(|&&e| mesh.kinds[e] == ElementKind::Prism).count();
    if bad_prisms != prisms {
        return Ok(());
    }
    let mut flipped = mesh.clone();
    for e in 0..mesh.num_elements() {
        if mesh.kinds[e] == ElementKind::Prism {
            let vs = &mut flipped.conn[mesh.offsets[e]..mesh.offsets[e + 1]];
            vs.swap(1, 2);
            vs.swap(4, 5);
        }
    }
    let still = crate::metric::inverted_elements(&flipped, &flipped.points);
    if still.iter().any(|&e| mesh.kinds[e] == ElementKind::Prism) {
        return Ok(());
    }
    Err(Error::parse(
        path,
        None,
        format!(
            "all {prisms} wedges are inverted in VTK's vertex order (base triangle 0,1,2 with its normal \
             toward the top 3,4,5, as VTK 9 and ParaView judge them) but valid with the base reversed: \
             the file writes every wedge with its base triangle reversed, as Gmsh's VTK export and \
             meshio 5.3 do. Reorder each wedge as (0,2,1,3,5,4), or export the mesh in a format that \
             keeps the writer's own order (Gmsh .msh, or VTK written by VTK or ParaView)"
        ),
    ))
}

/// Write `mesh` atomically: either the complete file replaces `path`, or
/// `path` is left as it was.
pub fn write(path: &Path, mesh: &Mesh, format: Format, cell_data: &[CellData]) -> Result<()> {
    stage_write(path, mesh, format, cell_data)?.commit()
}

/// [`write`] up to the rename: the complete file waits beside `path` until
/// [`Staged::commit`] (see [`stage`]).
pub fn stage_write(path: &Path, mesh: &Mesh, format: Format, cell_data: &[CellData]) -> Result<Staged> {
    check_writable(path, mesh, format)?;
    if format.is_openfoam() {
        check_cell_data(mesh, cell_data)?;
        return openfoam::stage(path, mesh, format.is_binary());
    }
    stage(path, |w| encode(w, mesh, format, cell_data))
}

/// Writes `mesh` to `w` (standard output, say) in `format`; `name` is what
/// errors call the destination. Nothing is written if the mesh cannot be.
pub fn write_to(
    w: &mut dyn std::io::Write,
    name: &Path,
    mesh: &Mesh,
    format: Format,
    cell_data: &[CellData],
) -> Result<()> {
    check_writable(name, mesh, format)?;
    if format.is_openfoam() {
        return Err(Error::InvalidArgument(format!(
            "cannot write {} as OpenFOAM: a polyMesh is a folder of files, not one stream; give a case folder",
            name.display()
        )));
    }
    let mut buffered = std::io::BufWriter::with_capacity(1 << 20, w);
    match encode(&mut buffered, mesh, format, cell_data).and_then(|()| Ok(std::io::Write::flush(&mut buffered)?)) {
        Ok(()) => Ok(()),
        Err(WriteError::Io(e)) => Err(Error::io(name, e)),
        Err(WriteError::Other(e)) => Err(e),
    }
}

fn check_writable(path: &Path, mesh: &Mesh, format: Format) -> Result<()> {
    check_structure(mesh)?;
    check_kinds_fit(path, mesh, format)?;
    mesh.data
        .check(mesh.num_points(), mesh.num_elements(), mesh.lower.len())
        .map_err(|e| match e {
            Error::InvalidMesh(m) => Error::InvalidMesh(format!("cannot write: {m}")),
            other => other,
        })
}

fn encode(w: &mut dyn std::io::Write, mesh: &Mesh, format: Format, cell_data: &[CellData]) -> WriteResult {
    match format {
        Format::VtkAscii => vtk::write(w, mesh, cell_data, false),
        Format::VtkBinary => vtk::write(w, mesh, cell_data, true),
        Format::VtuAscii => vtu::write(w, mesh, cell_data, vtu::Encoding::Ascii),
        Format::VtuBinary => vtu::write(w, mesh, cell_data, vtu::Encoding::Base64),
        Format::VtuZlib => vtu::write(w, mesh, cell_data, vtu::Encoding::Zlib),
        Format::Vtp => vtu::write_poly(w, mesh, cell_data, vtu::Encoding::Base64),
        Format::VtpAscii => vtu::write_poly(w, mesh, cell_data, vtu::Encoding::Ascii),
        Format::VtpZlib => vtu::write_poly(w, mesh, cell_data, vtu::Encoding::Zlib),
        Format::Msh22Ascii => gmsh::write22(w, mesh, cell_data, false),
        Format::Msh22Binary => gmsh::write22(w, mesh, cell_data, true),
        Format::Msh41Ascii => gmsh::write41(w, mesh, cell_data, false),
        Format::Msh41Binary => gmsh::write41(w, mesh, cell_data, true),
        Format::Medit => medit::write(w, mesh, cell_data),
        Format::Abaqus => abaqus::write(w, mesh, cell_data),
        #[cfg(feature = "exodus")]
        Format::Exodus => exodus::write(w, mesh, cell_data),
        #[cfg(not(feature = "exodus"))]
        Format::Exodus => Err(WriteError::Other(Error::Unsupported(NO_EXODUS.into()))),
        #[cfg(feature = "vtkhdf")]
        Format::VtkHdf => vtkhdf::write(w, mesh, cell_data),
        #[cfg(not(feature = "vtkhdf"))]
        Format::VtkHdf => Err(WriteError::Other(Error::Unsupported(NO_VTKHDF.into()))),
        Format::StlBinary | Format::StlAscii => {
            check_cell_data(mesh, cell_data)?;
            stl::write(w, mesh, format == Format::StlBinary)
        }
        Format::Obj => {
            check_cell_data(mesh, cell_data)?;
            obj::write(w, mesh)
        }
        Format::PlyBinary | Format::PlyAscii => {
            check_cell_data(mesh, cell_data)?;
            ply::write(w, mesh, cell_data, format == Format::PlyBinary)
        }
        Format::OpenFoam | Format::OpenFoamBinary => Err(WriteError::Other(Error::InvalidArgument(
            "an OpenFOAM case is a folder: it is written by stage_write, not to a stream".into(),
        ))),
    }
}

/// Gmsh, Medit and Abaqus files have no polyhedral cells: refuse before writing anything.
fn check_kinds_fit(path: &Path, mesh: &Mesh, format: Format) -> Result<()> {
    let vtk = matches!(
        format,
        Format::VtkAscii | Format::VtkBinary | Format::VtuAscii | Format::VtuBinary | Format::VtuZlib
    ) || format.is_openfoam();
    if format.is_surface_only() {
        let bad = if matches!(format, Format::StlBinary | Format::StlAscii) {
            stl::non_triangle(mesh)
        } else {
            mesh.kinds
                .iter()
                .position(|&k| k.dim() != 2)
                .map(|e| (e, mesh.kinds[e]))
        };
        if let Some((e, k)) = bad {
            let holds = if matches!(format, Format::StlBinary | Format::StlAscii) {
                "triangles only (split quadrilaterals first, or write OBJ or PLY)"
            } else if format.is_poly_data() {
                "surfaces of triangles and quadrilaterals only (write a volume mesh as .vtu)"
            } else {
                "triangles and quadrilaterals only"
            };
            return Err(Error::InvalidArgument(format!(
                "cannot write {}: element {e} is a {k}, and the {format} format holds {holds}",
                path.display()
            )));
        }
        if format.is_poly_data()
            && let Some(c) = mesh
                .lower
                .iter()
                .position(|(k, _)| !matches!(k, LowerKind::Vertex | LowerKind::Line))
        {
            return Err(Error::InvalidArgument(format!(
                "cannot write {}: boundary cell {c} is a {}, and the {format} format holds vertices and lines \
                 as boundary cells only (write .vtu)",
                path.display(),
                format!("{:?}", mesh.lower[c].0).to_lowercase()
            )));
        }
        return Ok(());
    }
    match mesh.kinds.iter().position(|&k| k == ElementKind::Polyhedron) {
        Some(e) if !vtk => Err(Error::InvalidArgument(format!(
            "cannot write {}: element {e} is a polyhedron, which the {format} format cannot hold; \
             write VTK (.vtk), VTK XML (.vtu) or an OpenFOAM case",
            path.display()
        ))),
        _ => Ok(()),
    }
}

/// The writers index freely, so refuse meshes whose arrays disagree.
fn check_structure(mesh: &Mesh) -> Result<()> {
    let n = mesh.points.len();
    let ok = mesh.offsets.len() == mesh.kinds.len() + 1
        && mesh.offsets.first() == Some(&0)
        && mesh.offsets.last() == Some(&mesh.conn.len())
        && mesh.offsets.windows(2).all(|w| w[0] <= w[1])
        && mesh.conn.iter().all(|&v| (v as usize) < n)
        && mesh.lower.iter().all(|(_, vs)| vs.iter().all(|&v| (v as usize) < n))
        && (mesh.fixed.is_empty() || mesh.fixed.len() == n);
    if ok {
        Ok(())
    } else {
        Err(Error::InvalidMesh(
            "cannot write: element offsets, connectivity, vertex ids or fixed flags are inconsistent".into(),
        ))
    }
}

/// Errors inside a writer: OS errors get the path attached by [`write_atomic`].
#[derive(Debug)]
pub enum WriteError {
    /// An operating-system error (its path is attached later).
    Io(std::io::Error),
    /// Any other error.
    Other(Error),
}

impl From<std::io::Error> for WriteError {
    fn from(e: std::io::Error) -> Self {
        WriteError::Io(e)
    }
}

impl From<Error> for WriteError {
    fn from(e: Error) -> Self {
        WriteError::Other(e)
    }
}

/// What a writer returns.
pub type WriteResult = std::result::Result<(), WriteError>;

/// Field arrays that carry named sets through VTK/VTU files, which have no
/// sets: `node_set:NAME` holds a node set's vertex ids, `element_set:NAME`
/// an element set's element ids (0-based; its lower cells are not written
/// to VTK/VTU).
const NODE_SET_FIELD: &str = "node_set:";
const ELEMENT_SET_FIELD: &str = "element_set:";

/// The field arrays a VTK/VTU writer writes: the input's, then one per set.
pub(crate) fn out_field_arrays(mesh: &Mesh) -> Vec<std::borrow::Cow<'_, DataArray>> {
    out_field_arrays_from(mesh, 0)
}

/// [`out_field_arrays`] for a file whose element `e` is its cell
/// `first_element + e` (a PolyData's elements follow its vertices and lines).
pub(crate) fn out_field_arrays_from(mesh: &Mesh, first_element: usize) -> Vec<std::borrow::Cow<'_, DataArray>> {
    let ids = |prefix: &str, name: &str, ids: &[u32], first: usize| {
        std::borrow::Cow::Owned(DataArray::new(
            format!("{prefix}{name}"),
            ValueType::I64,
            1,
            Values::Int(ids.iter().map(|&i| i64::from(i) + first as i64).collect()),
        ))
    };
    let data = &mesh.data;
    let mut out: Vec<std::borrow::Cow<DataArray>> = data.field.iter().map(std::borrow::Cow::Borrowed).collect();
    out.extend(
        data.node_sets
            .iter()
            .map(|s| ids(NODE_SET_FIELD, &s.name, &s.vertices, 0)),
    );
    out.extend(
        data.element_sets
            .iter()
            .map(|s| ids(ELEMENT_SET_FIELD, &s.name, &s.elements, first_element)),
    );
    out
}

/// Checked by every writer right before it writes cell data, so a bad array
/// fails the write midway and exercises the atomic clean-up.
fn check_cell_data(mesh: &Mesh, cell_data: &[CellData]) -> Result<()> {
    for cd in cell_data {
        if cd.values.len() != mesh.num_elements() {
            return Err(Error::InvalidArgument(format!(
                "cell data '{}' has {} values but the mesh has {} elements",
                cd.name,
                cd.values.len(),
                mesh.num_elements()
            )));
        }
    }
    Ok(())
}

/// Shape of a cell as read from a file; whether a triangle is an element or a
/// boundary face depends on the other cells, so it is decided afterwards.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Shape {
    Vertex,
    Line,
    Elem(ElementKind),
}

impl Shape {
    pub fn num_vertices(self) -> usize {
        match self {
            Shape::Vertex => 1,
            Shape::Line => 2,
            // a polyhedron's count is per cell; readers check it themselves
            Shape::Elem(k) => k.num_vertices().unwrap_or(0),
        }
    }
}

/// Everything a reader found, before elements and lower cells are separated.
#[derive(Default)]
pub(crate) struct RawMesh {
    pub points: Vec<[f64; 3]>,
    pub shapes: Vec<Shape>,
    pub offsets: Vec<usize>,
    pub conn: Vec<u32>,
    /// Faces of the polyhedral cells, by cell.
    pub faces: crate::mesh::Faces,
    /// Fixed flags from the file (VTK `fixed` data, Medit RequiredVertices);
    /// empty when the file has none.
    pub fixed: Vec<bool>,
    /// Arrays with one tuple per point.
    pub point_data: Vec<DataArray>,
    /// Arrays with one tuple per cell (every cell, in file order).
    pub cell_data: Vec<DataArray>,
    /// Arrays of the whole data set.
    pub field_data: Vec<DataArray>,
    pub physical_names: Vec<PhysicalName>,
    pub gmsh_entities: Vec<crate::mesh::data::GmshEntity>,
    /// Named vertex sets (point ids).
    pub node_sets: Vec<NodeSet>,
    /// Named cell sets: every cell's index in file order, split into
    /// elements and lower cells by [`into_mesh`](Self::into_mesh).
    pub cell_sets: Vec<(String, Vec<u32>)>,
}

impl RawMesh {
    pub fn push(&mut self, shape: Shape, vertices: &[u32]) {
        self.faces.push_none(self.shapes.len());
        self.push_cell(shape, vertices);
    }

    /// `ids.len() / nv` cells of one shape with `nv` vertices each.
    pub fn push_block(&mut self, shape: Shape, nv: usize, ids: Vec<u32>) {
        let k = ids.len().checked_div(nv).unwrap_or(0);
        if !self.faces.elem.is_empty() {
            for vs in ids.chunks_exact(nv) {
                self.push(shape, vs);
            }
            return;
        }
        if self.offsets.is_empty() {
            self.offsets.push(0);
        }
        let base = self.conn.len();
        self.shapes.resize(self.shapes.len() + k, shape);
        if self.conn.is_empty() {
            // the first block is taken as it is (at 10M tets a 166 MB copy)
            self.conn = ids;
        } else {
            self.conn.extend_from_slice(&ids);
        }
        self.offsets.extend((1..=k).map(|i| base + i * nv));
    }

    /// A polyhedral cell with its vertex list and faces (vertex ids).
    pub fn push_polyhedron(&mut self, vertices: &[u32], faces: &[Vec<u32>]) {
        self.faces.push(self.shapes.len(), faces.iter().map(|f| &f[..]));
        self.push_cell(Shape::Elem(ElementKind::Polyhedron), vertices);
    }

    fn push_cell(&mut self, shape: Shape, vertices: &[u32]) {
        if self.offsets.is_empty() {
            self.offsets.push(0);
        }
        self.shapes.push(shape);
        self.conn.extend_from_slice(vertices);
        self.offsets.push(self.conn.len());
    }

    /// Mark vertex `v` fixed (ids are checked by the caller).
    pub fn fix(&mut self, v: usize) {
        if self.fixed.len() != self.points.len() {
            self.fixed.resize(self.points.len(), false);
        }
        if let Some(f) = self.fixed.get_mut(v) {
            *f = true;
        }
    }

    /// Whether every cell is an element (not a polyhedron): then the cell
    /// arrays are the mesh's as they are.
    fn lower_free(&self, has3d: bool) -> bool {
        self.shapes
            .par_iter()
            .all(|s| matches!(s, Shape::Elem(k) if *k != ElementKind::Polyhedron && (k.dim() == 3 || !has3d)))
    }

    /// [`into_mesh`](Self::into_mesh) when [`lower_free`](Self::lower_free):
    /// moves the arrays instead of copying cell by cell.
    fn into_elements(self) -> Result<Mesh> {
        let n = self.points.len();
        let mut mesh = Mesh::new(self.points);
        mesh.kinds = self
            .shapes
            .par_iter()
            .map(|s| match s {
                Shape::Elem(k) => *k,
                _ => unreachable!("checked by lower_free"),
            })
            .collect();
        mesh.offsets = if self.offsets.is_empty() { vec![0] } else { self.offsets };
        mesh.conn = self.conn;
        mesh.data.point = self.point_data;
        mesh.data.cell = self.cell_data;
        mesh.data.field = self.field_data;
        mesh.data.physical_names = self.physical_names;
        mesh.data.gmsh_entities = self.gmsh_entities;
        mesh.data.node_sets = self.node_sets;
        mesh.data.element_sets = self
            .cell_sets
            .into_iter()
            .map(|(name, elements)| ElementSet {
                name,
                elements,
                lower: Vec::new(),
            })
            .collect();
        let mut fixed = self.fixed;
        if fixed.iter().any(|&f| f) {
            fixed.resize(n, false);
            mesh.fixed = fixed;
        }
        Ok(mesh)
    }

    /// Takes the sets [`out_field_arrays`] wrote out of the field arrays.
    fn sets_from_field(&mut self, path: &Path) -> Result<()> {
        let (np, nc) = (self.points.len(), self.shapes.len());
        let mut rest = Vec::with_capacity(self.field_data.len());
        for a in std::mem::take(&mut self.field_data) {
            let node = a.name.strip_prefix(NODE_SET_FIELD);
            let cell = a.name.strip_prefix(ELEMENT_SET_FIELD);
            let (Some(name), Values::Int(v)) = (node.or(cell), &a.values) else {
                rest.push(a);
                continue;
            };
            let n = if node.is_some() { np } else { nc };
            let ids: Vec<u32> = v
                .iter()
                .map_while(|&i| u32::try_from(i).ok().filter(|&i| (i as usize) < n))
                .collect();
            if ids.len() != v.len() {
                return Err(Error::parse(
                    path,
                    None,
                    format!(
                        "field array '{}' holds an id past the {n} the file has",
                        lex::clip(&a.name)
                    ),
                ));
            }
            if node.is_some() {
                self.node_sets.push(NodeSet {
                    name: name.to_string(),
                    vertices: ids,
                });
            } else {
                self.cell_sets.push((name.to_string(), ids));
            }
        }
        self.field_data = rest;
        Ok(())
    }

    pub fn into_mesh(mut self, path: &Path) -> Result<Mesh> {
        if self.points.is_empty() {
            return Err(Error::parse(path, None, "the file has no points"));
        }
        self.sets_from_field(path)?;
        let has3d = self.shapes.iter().any(|s| matches!(s, Shape::Elem(k) if k.dim() == 3));
        let ncells = self.shapes.len();
        let np = self.points.len();
        for a in &self.point_data {
            if a.tuples() != np || a.values.len() % a.components != 0 {
                return Err(Error::parse(
                    path,
                    None,
                    format!(
                        "point data '{}' has {} tuples but the file has {np} points",
                        lex::clip(&a.name),
                        a.tuples()
                    ),
                ));
            }
        }
        for a in &self.cell_data {
            if a.tuples() != ncells || a.values.len() % a.components != 0 {
                return Err(Error::parse(
                    path,
                    None,
                    format!(
                        "cell data '{}' has {} tuples but the file has {ncells} cells",
                        lex::clip(&a.name),
                        a.tuples()
                    ),
                ));
            }
        }
        if !self.shapes.is_empty()
            && self.faces.elem.is_empty()
            && self.lower_free(has3d)
            && self.conn.par_iter().all(|&v| (v as usize) < np)
        {
            return self.into_elements();
        }
        let mut elem_ids = Vec::with_capacity(ncells);
        let mut lower_ids = Vec::new();
        let mut mesh = Mesh::new(self.points);
        let n = mesh.points.len();
        let mut fixed = self.fixed;
        fixed.resize(n, false);
        for (c, &shape) in self.shapes.iter().enumerate() {
            let vs = &self.conn[self.offsets[c]..self.offsets[c + 1]];
            if let Some(&v) = vs.iter().find(|&&v| v as usize >= n) {
                return Err(Error::parse(
                    path,
                    None,
                    format!("cell {c} refers to vertex {v}, but the file has {n} points"),
                ));
            }
            let lower = match shape {
                Shape::Elem(ElementKind::Polyhedron) => {
                    mesh.push_polyhedron(vs, self.faces.of(c));
                    elem_ids.push(c);
                    continue;
                }
                Shape::Elem(k) if k.dim() == 3 || !has3d => {
                    mesh.push_element(k, vs);
                    elem_ids.push(c);
                    continue;
                }
                Shape::Elem(ElementKind::Triangle) => LowerKind::Triangle,
                Shape::Elem(_) => LowerKind::Quadrilateral,
                Shape::Vertex => LowerKind::Vertex,
                Shape::Line => LowerKind::Line,
            };
            for &v in vs {
                fixed[v as usize] = true;
            }
            mesh.lower.push((lower, vs.to_vec()));
            lower_ids.push(c);
        }
        mesh.data.point = self.point_data;
        mesh.data.cell = self.cell_data.iter().map(|a| a.select(&elem_ids)).collect();
        if !lower_ids.is_empty() {
            mesh.data.lower = self.cell_data.iter().map(|a| a.select(&lower_ids)).collect();
        }
        mesh.data.field = self.field_data;
        mesh.data.physical_names = self.physical_names;
        mesh.data.gmsh_entities = self.gmsh_entities;
        mesh.data.node_sets = self.node_sets;
        mesh.data.element_sets = split_cell_sets(self.cell_sets, ncells, &elem_ids, &lower_ids);
        if fixed.iter().any(|&f| f) {
            mesh.fixed = fixed;
        }
        if mesh.kinds.is_empty() {
            return Err(Error::parse(
                path,
                None,
                "the file has no elements (triangles, quadrilaterals, tetrahedra, hexahedra, prisms or polyhedra)",
            ));
        }
        Ok(mesh)
    }
}

/// Sets of cells in file order as sets of elements and of lower cells,
/// given which cells became which (`elem_ids`, `lower_ids`: ascending).
fn split_cell_sets(
    sets: Vec<(String, Vec<u32>)>,
    cells: usize,
    elem_ids: &[usize],
    lower_ids: &[usize],
) -> Vec<ElementSet> {
    if sets.is_empty() {
        return Vec::new();
    }
    // cell -> element id, or lower id with the top bit set
    const LOWER: u32 = 1 << 31;
    let mut to = vec![u32::MAX; cells];
    elem_ids.iter().enumerate().for_each(|(e, &c)| to[c] = e as u32);
    lower_ids
        .iter()
        .enumerate()
        .for_each(|(l, &c)| to[c] = l as u32 | LOWER);
    sets.into_iter()
        .map(|(name, cells)| {
            let (lower, elements): (Vec<u32>, Vec<u32>) = cells
                .iter()
                .filter_map(|&c| to.get(c as usize).copied().filter(|&t| t != u32::MAX))
                .partition(|&t| t & LOWER != 0);
            ElementSet {
                name,
                elements,
                lower: lower.into_iter().map(|t| t & !LOWER).collect(),
            }
        })
        .collect()
}

/// Shortest text that parses back to exactly `x` (`{:?}` switches to
/// exponent notation for very large or small magnitudes, unlike `{}`).
pub(crate) fn fmt_f64(x: f64) -> String {
    format!("{x:?}")
}

/// Elements are 2D only when no element is 3D; used to pick 2D output.
pub(crate) fn is_planar_z0(mesh: &Mesh) -> bool {
    mesh.dim() == 2 && mesh.points.iter().all(|p| p[2].to_bits() == 0)
}

/// Vertex ids (0-based, whitespace- or comma-separated, `#` starts a
/// comment) from a text file, for `--fixed-file`; an entry that is not a
/// non-negative integer is refused with its line.
pub fn read_vertex_ids(path: &Path) -> Result<Vec<usize>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let mut ids = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let content = line.split('#').next().unwrap_or("");
        for token in content
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|t| !t.is_empty())
        {
            let id = token.parse::<usize>().map_err(|_| {
                Error::parse(
                    path,
                    Some(crate::error::Location::Line(i + 1)),
                    format!("'{}' is not a vertex id (a non-negative integer)", lex::clip(token)),
                )
            })?;
            ids.push(id);
        }
    }
    Ok(ids)
}
