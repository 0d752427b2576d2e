//! `--boundary`, `--feature-angle` and the fixed-vertex rules of `smooth`.

use clap::Args;
use meshsmooth::problem::{Boundary, BoundaryMode};
use std::path::PathBuf;

#[derive(Args, Debug, Clone)]
pub struct BoundaryArgs {
    /// fixed: boundary vertices stay where they are; slide: they move within their boundary
    /// face or along their feature edge, staying on the original boundary (corners stay).
    #[arg(long, value_enum, default_value_t = BoundaryMode::Fixed)]
    pub boundary: BoundaryMode,
    /// With --boundary slide: boundary faces meeting at more than this angle form a
    /// feature edge, and an edge turning by more than it makes a corner.
    #[arg(long, value_name = "DEGREES", default_value_t = Boundary::default().feature_angle)]
    pub feature_angle: f64,
    /// Slide the boundary on this triangulated geometry (STL, OBJ, PLY, VTK or any mesh
    /// file holding a surface; typically a finer export of the CAD surface) instead of
    /// the mesh's own skin: every boundary vertex is projected onto it, smooth parts
    /// slide on its patches, vertices on its feature curves along them, and vertices
    /// at its corners stay. Implies --boundary slide; the feature angle is applied to
    /// the geometry's own facets.
    #[arg(long, value_name = "GEOMETRY")]
    pub surface: Option<PathBuf>,
    /// Fix the vertices of a group: a Gmsh physical group (name or number), an
    /// element set or a node set (Abaqus *ELSET, *NSET); repeatable.
    #[arg(long, value_name = "GROUP")]
    pub fix_group: Vec<String>,
    /// Release the vertices of a group's boundary cells (fixed by default), or of a
    /// node set; a group is a Gmsh physical group, an element set or a node set;
    /// repeatable.
    #[arg(long, value_name = "GROUP")]
    pub free_group: Vec<String>,
    /// Fix the vertices where this point-data array is non-zero; repeatable.
    #[arg(long, value_name = "NAME")]
    pub fixed_array: Vec<String>,
    /// Fix the vertices listed in this file (0-based ids, whitespace or commas, # comments);
    /// repeatable.
    #[arg(long, value_name = "FILE")]
    pub fixed_file: Vec<PathBuf>,
}
