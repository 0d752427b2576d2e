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
