//! Structured hexahedral boxes and planar quad/triangle grids.

use crate::mesh::{ElementKind, Mesh};

fn check(counts: &[usize], lengths: &[f64], what: &str) {
    assert!(counts.iter().all(|&n| n > 0), "{what} needs at least one cell per axis");
    assert!(
        lengths.iter().all(|l| l.is_finite() && *l > 0.0),
        "{what} needs positive finite lengths, got {lengths:?}"
    );
}

/// A box `[0, lengths[0]] x [0, lengths[1]] x [0, lengths[2]]` of
/// `nx * ny * nz` hexahedra. Vertices are numbered x fastest, then y, then z
/// (as in [`tet_box`](super::tet_box)); each hex lists its bottom face
/// counter-clockwise seen from +z, then the top face, so every corner
/// determinant is the (positive) cell volume.
///
/// # Panics
/// If a cell count is zero or a length is not positive and finite.
pub fn hex_box(nx: usize, ny: usize, nz: usize, lengths: [f64; 3]) -> Mesh {
    check(&[nx, ny, nz], &lengths, "hex_box");
    let n = [nx, ny, nz];
    let (sx, sy) = (nx + 1, ny + 1);
    let id = |i: usize, j: usize, k: usize| (i + sx * (j + sy * k)) as u32;
    let mut points = Vec::with_capacity(sx * sy * (nz + 1));
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                let c = [i, j, k];
                points.push(std::array::from_fn(|a| lengths[a] * c[a] as f64 / n[a] as f64));
            }
        }
    }
    let mut mesh = Mesh::new(points);
    mesh.kinds.reserve(nx * ny * nz);
    mesh.conn.reserve(8 * nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let hex = [
                    id(i, j, k),
                    id(i + 1, j, k),
                    id(i + 1, j + 1, k),
                    id(i, j + 1, k),
                    id(i, j, k + 1),
                    id(i + 1, j, k + 1),
                    id(i + 1, j + 1, k + 1),
                    id(i, j + 1, k + 1),
                ];
                mesh.push_element(ElementKind::Hexahedron, &hex);
            }
        }
    }
    mesh
}

fn planar_points(nx: usize, ny: usize, lengths: [f64; 2]) -> Vec<[f64; 3]> {
    let mut points = Vec::with_capacity((nx + 1) * (ny + 1));
    for j in 0..=ny {
        for i in 0..=nx {
            points.push([
                lengths[0] * i as f64 / nx as f64,
                lengths[1] * j as f64 / ny as f64,
                0.0,
            ]);
        }
    }
    points
}

/// The four corners of planar cell `(i, j)`, counter-clockwise from its
/// lower-left corner, for a grid with `nx` cells per row.
pub(crate) fn cell_corners(nx: usize, i: usize, j: usize) -> [u32; 4] {
    let id = |i: usize, j: usize| (i + (nx + 1) * j) as u32;
    [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]
}

/// A rectangle `[0, lengths[0]] x [0, lengths[1]]` (z = 0) of `nx * ny`
/// quadrilaterals, vertices numbered x fastest, every quad counter-clockwise.
///
/// # Panics
/// If a cell count is zero or a length is not positive and finite.
pub fn quad_grid(nx: usize, ny: usize, lengths: [f64; 2]) -> Mesh {
    check(&[nx, ny], &lengths, "quad_grid");
    let mut mesh = Mesh::new(planar_points(nx, ny, lengths));
    for j in 0..ny {
        for i in 0..nx {
            mesh.push_element(ElementKind::Quadrilateral, &cell_corners(nx, i, j));
        }
    }
    mesh
}

/// The rectangle of [`quad_grid`] with every cell split into two
/// counter-clockwise triangles along the same (lower-left to upper-right)
/// diagonal, so the mesh has `2 nx ny` triangles.
///
/// # Panics
/// If a cell count is zero or a length is not positive and finite.
pub fn tri_grid(nx: usize, ny: usize, lengths: [f64; 2]) -> Mesh {
    check(&[nx, ny], &lengths, "tri_grid");
    let mut mesh = Mesh::new(planar_points(nx, ny, lengths));
    for j in 0..ny {
        for i in 0..nx {
            let [a, b, c, d] = cell_corners(nx, i, j);
            mesh.push_element(ElementKind::Triangle, &[a, b, c]);
            mesh.push_element(ElementKind::Triangle, &[a, c, d]);
        }
    }
    mesh
}
