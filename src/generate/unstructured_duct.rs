//! The Newton paper's ducts: unstructured tetrahedral meshes of a 4 x 1 x 1
//! box, made by Gmsh's Delaunay mesher (the paper used CUBIT's). Unlike the
//! Kuhn-split [`duct`](super::duct), whose tetrahedra are all alike (and
//! already optimal), these have a spread of shapes like the paper's: an
//! average inverse mean ratio near 1.2, sigma_n above 0.1, worst near 2.5
//! (Table 1 has 1.21, 0.11 and 2.2).
//!
//! Gmsh is run as a program (`gmsh` on the PATH, or the one `MESHSMOOTH_GMSH`
//! names) with one thread, so the same Gmsh version gives the same mesh.

use std::path::PathBuf;
use std::process::Command;

use crate::error::{Error, Result};
use crate::mesh::Mesh;

/// Gmsh's mesh size for a duct of about `vertices` vertices: Gmsh 4.8's
/// counts on this geometry follow `2.77 / size^3 + 15.6 / size^2` (volume
/// and surface vertices) within 3 % from 1,300 to 13,000 vertices.
pub fn duct_size_for(vertices: usize) -> f64 {
    let n = vertices.max(8) as f64;
    let count = |s: f64| 2.77 / s.powi(3) + 15.6 / s.powi(2);
    // the count falls as the size grows: bisect on [1e-3, 4]
    let (mut lo, mut hi) = (1e-3, 4.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if count(mid) > n {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The program that runs Gmsh.
fn gmsh_program() -> PathBuf {
    std::env::var_os("MESHSMOOTH_GMSH").map_or_else(|| PathBuf::from("gmsh"), PathBuf::from)
}

/// An unstructured tetrahedral duct (4 x 1 x 1, long axis x) meshed by Gmsh
/// with element size `size` (0.1 gives about 4,200 vertices and 19,000
/// tetrahedra, the paper's Duct12). The boundary triangles come with it as
/// lower cells, which fixes the skin.
pub fn unstructured_duct(size: f64) -> Result<Mesh> {
    if !(size.is_finite() && size > 0.0 && size <= 4.0) {
        return Err(Error::InvalidArgument(format!(
            "duct element size must be above 0 and at most 4, got {size}"
        )));
    }
    let dir = tempfile::tempdir().map_err(|e| Error::io(std::env::temp_dir(), e))?;
    let geo = dir.path().join("duct.geo");
    let msh = dir.path().join("duct.msh");
    // an extruded rectangle: built-in kernel, no OpenCASCADE needed
    std::fs::write(
        &geo,
        "Point(1) = {0, 0, 0}; Point(2) = {4, 0, 0}; Point(3) = {4, 1, 0}; Point(4) = {0, 1, 0};\n\
         Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};\n\
         Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};\n\
         Extrude {0, 0, 1} { Surface{1}; }\n",
    )
    .map_err(|e| Error::io(&geo, e))?;
    let program = gmsh_program();
    let size_text = format!("{size}");
    let out = Command::new(&program)
        .arg(&geo)
        .args(["-3", "-nt", "1", "-clmin", &size_text, "-clmax", &size_text])
        .args(["-format", "msh41", "-v", "1", "-o"])
        .arg(&msh)
        .output()
        .map_err(|e| {
            Error::InvalidArgument(format!(
                "the unstructured duct needs Gmsh: running '{}' failed ({e}); install gmsh \
                 (e.g. apt install gmsh), set MESHSMOOTH_GMSH to its path, or ask for the \
                 Kuhn-split duct instead",
                program.display()
            ))
        })?;
    if !out.status.success() || !msh.exists() {
        return Err(Error::InvalidArgument(format!(
            "Gmsh ('{}') failed to mesh the duct ({}): {}",
            program.display(),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    crate::io::read(&msh)
}
