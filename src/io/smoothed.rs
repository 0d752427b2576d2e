//! Writing a smoothed mesh: the guard that no output ever holds an inverted
//! element, and the per-element quality as cell data for ParaView. The CLI
//! and Rust callers share it.

use super::{CellData, Format, write};
use crate::error::{Error, Result};
use crate::{Mesh, metric};
use std::path::Path;

/// Per-element inverse mean ratio (infinite where inverted).
pub fn eta_field(mesh: &Mesh) -> Vec<f64> {
    let points = metric::oriented(mesh, &mesh.points);
    (0..mesh.num_elements())
        .map(|e| metric::element_eta(mesh, &points, e).unwrap_or(f64::INFINITY))
        .collect()
}

/// Writes `mesh` with its `inverse_mean_ratio` cell data, refusing (and
/// writing nothing) if any element is inverted.
pub fn write_mesh(path: &Path, mesh: &Mesh, format: Format) -> Result<()> {
    let bad = metric::inverted_elements(mesh, &mesh.points);
    if !bad.is_empty() {
        return Err(Error::Inverted {
            count: bad.len(),
            first: bad.into_iter().take(5).collect(),
        });
    }
    let eta = eta_field(mesh);
    write(
        path,
        mesh,
        format,
        &[CellData {
            name: "inverse_mean_ratio",
            values: &eta,
        }],
    )
}
