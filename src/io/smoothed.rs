//! Writing a smoothed mesh: the guard that no output ever holds an inverted
//! element, and the per-element quality as cell data for ParaView. The CLI
//! and Rust callers share it.

use super::{CellData, Format, LocalPieces, PieceWriter, Staged, stage_write, write_pieces_with, write_to};
use crate::error::Result;
use crate::{Mesh, metric};
use std::path::Path;

/// Per-element inverse mean ratio (infinite where inverted).
pub fn eta_field(mesh: &Mesh) -> Vec<f64> {
    let measured = metric::Measured::new(mesh, &mesh.points);
    (0..mesh.num_elements())
        .map(|e| measured.eta(mesh, e).unwrap_or(f64::INFINITY))
        .collect()
}

/// Writes `mesh` with its `inverse_mean_ratio` cell data, refusing (and
/// writing nothing) if any element is inverted.
pub fn write_mesh(path: &Path, mesh: &Mesh, format: Format) -> Result<()> {
    stage_mesh(path, mesh, format)?.commit()
}

/// [`write_mesh`] up to the rename (see [`super::stage`]).
pub fn stage_mesh(path: &Path, mesh: &Mesh, format: Format) -> Result<Staged> {
    metric::refuse_inverted(mesh)?;
    let eta = eta_field(mesh);
    stage_write(path, mesh, format, &[quality(&eta)])
}

/// [`write_mesh`] to a stream (standard output, say); `name` is what errors
/// call it.
pub fn write_mesh_to(w: &mut dyn std::io::Write, name: &Path, mesh: &Mesh, format: Format) -> Result<()> {
    metric::refuse_inverted(mesh)?;
    let eta = eta_field(mesh);
    write_to(w, name, mesh, format, &[quality(&eta)])
}

fn quality(eta: &[f64]) -> CellData<'_> {
    CellData {
        name: "inverse_mean_ratio",
        values: eta,
    }
}

/// [`write_mesh`] as a `.pvtu` index at `path` and `parts` pieces, split by
/// `owner` (the owning part of each vertex); returns the pieces' paths.
pub fn write_mesh_pieces(
    path: &Path,
    mesh: &Mesh,
    owner: &[u32],
    parts: usize,
    format: Format,
) -> Result<Vec<std::path::PathBuf>> {
    write_mesh_pieces_with(path, mesh, owner, parts, format, &mut LocalPieces)
}

/// [`write_mesh_pieces`], each piece written by `writer` (the ranks of an MPI job).
pub fn write_mesh_pieces_with(
    path: &Path,
    mesh: &Mesh,
    owner: &[u32],
    parts: usize,
    format: Format,
    writer: &mut dyn PieceWriter,
) -> Result<Vec<std::path::PathBuf>> {
    metric::refuse_inverted(mesh)?;
    let eta = eta_field(mesh);
    write_pieces_with(
        path,
        mesh,
        owner,
        parts,
        format,
        &[CellData {
            name: "inverse_mean_ratio",
            values: &eta,
        }],
        writer,
    )
}
