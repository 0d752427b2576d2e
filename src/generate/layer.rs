//! Meshes graded toward a wall, as boundary-layer meshers build them: the
//! cases the input targets keep (see [`crate::problem::targets`]).

use super::grid::{hex_box, quad_grid};
use crate::error::{Error, Result};
use crate::mesh::{ElementKind, Mesh};

/// Wall-normal coordinates from 0: `layers` cells from `first` growing by
/// `growth`, then cells as close to `far` as fit evenly up to 1.
fn wall_coordinates(first: f64, growth: f64, layers: usize, far: f64) -> Result<Vec<f64>> {
    if !(first > 0.0 && first < 1.0 && (1.0..=4.0).contains(&growth) && far > 0.0 && far.is_finite()) {
        return Err(Error::InvalidArgument(format!(
            "a boundary layer needs 0 < first height < 1, growth between 1 and 4 and a positive far-field size (got {first}, {growth}, {far})"
        )));
    }
    let mut z = vec![0.0];
    let mut h = first;
    for _ in 0..layers {
        z.push(z.last().unwrap() + h);
        h *= growth;
    }
    let top = *z.last().unwrap();
    if top >= 1.0 {
        return Err(Error::InvalidArgument(format!(
            "a boundary layer of {layers} cells from {first} growing by {growth} is {top:.3} thick, more than the unit height"
        )));
    }
    let rest = ((1.0 - top) / far).round().max(1.0) as usize;
    z.extend((1..=rest).map(|k| top + (1.0 - top) * k as f64 / rest as f64));
    // exactly the unit height, whatever the rounding of the sum
    *z.last_mut().unwrap() = 1.0;
    Ok(z)
}

/// The unit square with a quad boundary layer on the wall y = 0 (`layers`
/// rows from `first` growing by `growth`) under triangles (each square of
/// an `nx`-wide grid split in two) up to y = 1. Cell `e`'s data is not set;
/// the layer's quads come first.
pub fn boundary_layer_2d(nx: usize, first: f64, growth: f64, layers: usize) -> Result<Mesh> {
    let z = wall_coordinates(first, growth, layers, 1.0 / nx.max(1) as f64)?;
    let ny = z.len() - 1;
    let grid = quad_grid(nx, ny, [1.0, 1.0]);
    let mut mesh = Mesh::new(grid.points.clone());
    for p in &mut mesh.points {
        p[1] = z[(p[1] * ny as f64).round() as usize];
    }
    for e in 0..grid.num_elements() {
        let q = grid.element(e);
        if e / nx < layers {
            mesh.push_element(ElementKind::Quadrilateral, q);
        }
    }
    for e in 0..grid.num_elements() {
        let q = grid.element(e);
        if e / nx >= layers {
            mesh.push_element(ElementKind::Triangle, &[q[0], q[1], q[2]]);
            mesh.push_element(ElementKind::Triangle, &[q[0], q[2], q[3]]);
        }
    }
    Ok(mesh)
}

/// The unit cube of `n x n` columns of hexahedra graded toward the wall
/// z = 0: cells from `first` growing by `growth` until they reach the
/// `1 / n` of the columns' width, then even cells up to z = 1.
pub fn graded_hex_box(n: usize, first: f64, growth: f64) -> Result<Mesh> {
    let far = 1.0 / n.max(1) as f64;
    let layers = if growth > 1.0 && first < far {
        ((far / first).ln() / growth.ln()).ceil() as usize
    } else {
        0
    };
    let z = wall_coordinates(first, growth, layers, far)?;
    let nz = z.len() - 1;
    let mut mesh = hex_box(n, n, nz, [1.0, 1.0, 1.0]);
    for p in &mut mesh.points {
        p[2] = z[(p[2] * nz as f64).round() as usize];
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layers_grow_from_the_wall_and_fill_the_unit_height() {
        let m = boundary_layer_2d(20, 1e-3, 1.2, 12).unwrap();
        let mut ys: Vec<f64> = m.points.iter().map(|p| p[1]).collect();
        ys.sort_by(f64::total_cmp);
        ys.dedup();
        assert!((ys[1] - 1e-3).abs() < 1e-15 && ((ys[2] - ys[1]) / ys[1] - 1.2).abs() < 1e-9);
        assert_eq!(*ys.last().unwrap(), 1.0);
        assert_eq!(
            m.kinds.iter().filter(|k| **k == ElementKind::Quadrilateral).count(),
            20 * 12
        );
        assert!(crate::metric::inverted_elements(&m, &m.points).is_empty());
        let h = graded_hex_box(6, 1e-3, 1.5).unwrap();
        let mut zs: Vec<f64> = h.points.iter().map(|p| p[2]).collect();
        zs.sort_by(f64::total_cmp);
        zs.dedup();
        assert!((zs[1] - 1e-3).abs() < 1e-15 && ((zs[2] - zs[1]) / zs[1] - 1.5).abs() < 1e-9);
        assert!(crate::metric::inverted_elements(&h, &h.points).is_empty());
        assert!(boundary_layer_2d(10, 0.1, 2.0, 10).is_err());
    }
}
