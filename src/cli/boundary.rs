//! `--boundary`, `--feature-angle` and the fixed-vertex rules of `smooth`.

use clap::Args;
use meshsmooth::io;
use meshsmooth::mesh::fixing::FixRules;
use meshsmooth::problem::{Boundary, BoundaryMode};
use meshsmooth::{Error, Result};
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
    /// Fix the vertices of a Gmsh physical group (name or number); repeatable.
    #[arg(long, value_name = "GROUP")]
    pub fix_group: Vec<String>,
    /// Release the vertices of a Gmsh physical group's boundary cells (fixed by default);
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

impl BoundaryArgs {
    pub fn boundary(&self) -> Result<Boundary> {
        let a = self.feature_angle;
        if !(a > 0.0 && a < 180.0) {
            return Err(Error::InvalidArgument(format!(
                "--feature-angle must be between 0 and 180 degrees, got {a}"
            )));
        }
        Ok(Boundary {
            mode: self.boundary,
            feature_angle: a,
        })
    }

    pub fn rules(&self) -> Result<FixRules> {
        let fixed_ids = self
            .fixed_file
            .iter()
            .map(|p| Ok((p.display().to_string(), io::read_vertex_ids(p)?)))
            .collect::<Result<_>>()?;
        Ok(FixRules {
            fix_groups: self.fix_group.clone(),
            free_groups: self.free_group.clone(),
            fixed_arrays: self.fixed_array.clone(),
            fixed_ids,
            release_facets: self.boundary == BoundaryMode::Slide,
        })
    }
}
