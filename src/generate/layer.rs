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
    layer_2d(nx, first, growth, layers, true)
}

/// [`boundary_layer_2d`], its layer's squares kept as quads (`quads`) or
/// split into triangles as the far field's are.
fn layer_2d(nx: usize, first: f64, growth: f64, layers: usize, quads: bool) -> Result<Mesh> {
    let z = wall_coordinates(first, growth, layers, 1.0 / nx.max(1) as f64)?;
    let ny = z.len() - 1;
    let grid = quad_grid(nx, ny, [1.0, 1.0]);
    let mut mesh = Mesh::new(grid.points.clone());
    for p in &mut mesh.points {
        p[1] = z[(p[1] * ny as f64).round() as usize];
    }
    let split = |mesh: &mut Mesh, q: &[u32]| {
        mesh.push_element(ElementKind::Triangle, &[q[0], q[1], q[2]]);
        mesh.push_element(ElementKind::Triangle, &[q[0], q[2], q[3]]);
    };
    for e in 0..layers * nx {
        if quads {
            mesh.push_element(ElementKind::Quadrilateral, grid.element(e));
        } else {
            split(&mut mesh, grid.element(e));
        }
    }
    for e in layers * nx..grid.num_elements() {
        split(&mut mesh, grid.element(e));
    }
    Ok(mesh)
}

/// The element kinds of a boundary-layer mesh: the layer's, and above it
/// the far field's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum LayerKind {
    /// 2D: quads in the layer, triangles above.
    Quad,
    /// 2D: triangles throughout (the layer's quads split in two: stretched triangles).
    Tri,
    /// 3D: hexahedra throughout.
    Hex,
    /// 3D: prisms in the layer (triangles on the wall, extruded), tetrahedra above.
    Prism,
    /// 3D: tetrahedra throughout (each prism of the extrusion split in three).
    Tet,
}

crate::error::by_name!(LayerKind { Quad = "quad", Tri = "tri", Hex = "hex", Prism = "prism", Tet = "tet" });

impl LayerKind {
    /// 2 or 3.
    pub fn dim(self) -> usize {
        match self {
            LayerKind::Quad | LayerKind::Tri => 2,
            _ => 3,
        }
    }
}

/// A boundary-layer mesh of `kind` on the wall y = 0 (2D, the unit square,
/// `layers` rows from `first` growing by `growth`, see
/// [`boundary_layer_2d`]) or z = 0 (3D, the unit cube, cells growing until
/// they reach the `1 / cells` of the columns' width, see
/// [`graded_hex_box`]; `layers` is not used).
pub fn boundary_layer(kind: LayerKind, cells: usize, first: f64, growth: f64, layers: usize) -> Result<Mesh> {
    match kind {
        LayerKind::Quad => boundary_layer_2d(cells, first, growth, layers),
        LayerKind::Tri => layer_2d(cells, first, growth, layers, false),
        LayerKind::Hex => graded_hex_box(cells, first, growth),
        LayerKind::Prism | LayerKind::Tet => extruded_layer(cells, first, growth, kind == LayerKind::Prism),
    }
}

/// Wall-normal coordinates of the 3D meshes: graded until the cells reach
/// the columns' width `1 / n`, then even.
fn graded_wall_coordinates(n: usize, first: f64, growth: f64) -> Result<(Vec<f64>, usize)> {
    let far = 1.0 / n.max(1) as f64;
    let layers = if growth > 1.0 && first < far {
        ((far / first).ln() / growth.ln()).ceil() as usize
    } else {
        0
    };
    Ok((wall_coordinates(first, growth, layers, far)?, layers))
}

/// The unit cube of `n x n` columns of hexahedra graded toward the wall
/// z = 0: cells from `first` growing by `growth` until they reach the
/// `1 / n` of the columns' width, then even cells up to z = 1.
pub fn graded_hex_box(n: usize, first: f64, growth: f64) -> Result<Mesh> {
    let (z, _) = graded_wall_coordinates(n, first, growth)?;
    Ok(graded_columns(n, &z))
}

/// `n x n` columns of hexahedra through the wall-normal coordinates `z`.
fn graded_columns(n: usize, z: &[f64]) -> Mesh {
    let nz = z.len() - 1;
    let mut mesh = hex_box(n, n, nz, [1.0, 1.0, 1.0]);
    for p in &mut mesh.points {
        p[2] = z[(p[2] * nz as f64).round() as usize];
    }
    mesh
}

/// The wall's `n x n` squares split into triangles, extruded through the
/// graded coordinates: prisms in the graded layer (where `prisms`), every
/// other prism split into three tetrahedra. The split cuts each side quad
/// along the diagonal from its bottom vertex of larger index to the top
/// vertex of the smaller, a rule that depends only on the quad's own
/// vertices, so neighbouring columns agree and the mesh is conforming.
fn extruded_layer(n: usize, first: f64, growth: f64, prisms: bool) -> Result<Mesh> {
    let (z, layers) = graded_wall_coordinates(n, first, growth)?;
    let nz = z.len() - 1;
    let hexes = graded_columns(n, &z);
    let mut mesh = Mesh::new(hexes.points.clone());
    for k in 0..nz {
        for c in 0..n * n {
            let h = hexes.element(k * n * n + c);
            // the bottom square's triangles, counter-clockwise seen from +z
            for tri in [[0, 1, 2], [0, 2, 3]] {
                if prisms && k < layers {
                    let vs = [tri[0], tri[1], tri[2], tri[0] + 4, tri[1] + 4, tri[2] + 4].map(|c| h[c]);
                    mesh.push_element(ElementKind::Prism, &vs);
                } else {
                    let mut b = tri.map(|c| h[c]);
                    b.sort_unstable();
                    let t = b.map(|v| h[(0..4).find(|&c| h[c] == v).unwrap() + 4]);
                    for mut tet in [
                        [b[0], b[1], b[2], t[0]],
                        [b[1], b[2], t[0], t[1]],
                        [b[2], t[0], t[1], t[2]],
                    ] {
                        let x = tet.map(|v| mesh.points[v as usize]);
                        if crate::metric::tet_det(&x) < 0.0 {
                            tet.swap(1, 2);
                        }
                        mesh.push_element(ElementKind::Tetrahedron, &tet);
                    }
                }
            }
        }
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

    #[test]
    fn every_layer_kind_is_conforming_and_positive() {
        use crate::error::Named;
        for kind in LayerKind::NAMES.iter().map(|&(_, k)| k) {
            let m = boundary_layer(kind, 5, 1e-3, 1.5, 6).unwrap();
            assert_eq!(m.dim(), kind.dim(), "{kind:?}");
            assert!(crate::metric::inverted_elements(&m, &m.points).is_empty(), "{kind:?}");
            // conforming: every interior face is shared by exactly two
            // elements, so the skin is exactly the box's boundary
            let skin = crate::mesh::topology::skin_vertices(&m);
            for (v, p) in m.points.iter().enumerate() {
                let on_box = p[..kind.dim()].iter().any(|&c| c == 0.0 || c == 1.0);
                assert_eq!(skin[v], on_box, "{kind:?}: vertex {v} at {p:?}");
            }
        }
        let p = boundary_layer(LayerKind::Prism, 4, 1e-3, 1.5, 0).unwrap();
        let prisms = p.kinds.iter().filter(|k| **k == ElementKind::Prism).count();
        let tets = p.kinds.iter().filter(|k| **k == ElementKind::Tetrahedron).count();
        // 2 triangles per wall square in each of the graded layers (ln 250 / ln 1.5 -> 14)
        assert_eq!(prisms, 2 * 16 * 14);
        assert!(tets > 0 && tets % 6 == 0, "{tets}");
    }
}
