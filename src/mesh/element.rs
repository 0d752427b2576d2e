//! Element kinds and their corner tables.
//!
//! Node ordering is VTK's for every kind; Gmsh and Medit use the same ordering
//! for linear elements, so files convert without permutation.

use std::fmt;

/// The element kinds meshsmooth can optimise.
///
/// Every corner of every kind has exactly `dim` incident edges inside the
/// element, which the corner-based metrics need (pyramids do not, and are
/// refused when a file is read). A polyhedron is given by its faces, stored
/// with the mesh ([`Mesh::faces`](super::Mesh)); its vertex count, corners,
/// faces and edges are per element ([`Mesh::element_corners`](super::Mesh::element_corners)),
/// so the static tables below are empty for it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
pub enum ElementKind {
    /// 3-node triangle (2D).
    Triangle,
    /// 4-node quadrilateral (2D).
    Quadrilateral,
    /// 4-node tetrahedron.
    Tetrahedron,
    /// 8-node hexahedron.
    Hexahedron,
    /// 6-node triangular prism (wedge).
    Prism,
    /// VTK_POLYHEDRON: any closed cell whose every vertex has exactly three
    /// cell edges (see [`super::polyhedron`]).
    Polyhedron,
}

impl ElementKind {
    /// Every kind.
    pub const ALL: [ElementKind; 6] = [
        ElementKind::Triangle,
        ElementKind::Quadrilateral,
        ElementKind::Tetrahedron,
        ElementKind::Hexahedron,
        ElementKind::Prism,
        ElementKind::Polyhedron,
    ];

    /// Topological (and metric) dimension.
    pub fn dim(self) -> usize {
        match self {
            ElementKind::Triangle | ElementKind::Quadrilateral => 2,
            _ => 3,
        }
    }

    /// Vertices per element; `None` for polyhedra, whose count is per element.
    pub fn num_vertices(self) -> Option<usize> {
        match self {
            ElementKind::Triangle => Some(3),
            ElementKind::Quadrilateral => Some(4),
            ElementKind::Tetrahedron => Some(4),
            ElementKind::Hexahedron => Some(8),
            ElementKind::Prism => Some(6),
            ElementKind::Polyhedron => None,
        }
    }

    /// For each corner: the corner vertex followed by its `dim` neighbours, ordered
    /// so that det[x_a - x_c, x_b - x_c, ...] > 0 for a well-oriented element.
    /// Empty for polyhedra (per element: [`Mesh::element_corners`](super::Mesh::element_corners)).
    pub fn corners(self) -> &'static [[usize; 4]] {
        match self {
            ElementKind::Triangle => &[[0, 1, 2, 0], [1, 2, 0, 0], [2, 0, 1, 0]],
            ElementKind::Quadrilateral => &[[0, 1, 3, 0], [1, 2, 0, 0], [2, 3, 1, 0], [3, 0, 2, 0]],
            ElementKind::Tetrahedron => &[[0, 1, 2, 3], [1, 2, 0, 3], [2, 0, 1, 3], [3, 0, 2, 1]],
            ElementKind::Hexahedron => &[
                [0, 1, 3, 4],
                [1, 2, 0, 5],
                [2, 3, 1, 6],
                [3, 0, 2, 7],
                [4, 7, 5, 0],
                [5, 4, 6, 1],
                [6, 5, 7, 2],
                [7, 6, 4, 3],
            ],
            ElementKind::Prism => &[
                [0, 1, 2, 3],
                [1, 2, 0, 4],
                [2, 0, 1, 5],
                [3, 5, 4, 0],
                [4, 3, 5, 1],
                [5, 4, 3, 2],
            ],
            ElementKind::Polyhedron => &[],
        }
    }

    /// Triangles and tetrahedra: their map from the reference element is
    /// affine, so every corner sees the same Jacobian.
    pub fn is_simplex(self) -> bool {
        matches!(self, ElementKind::Triangle | ElementKind::Tetrahedron)
    }

    /// The corners the objective and the metric reports evaluate: a simplex
    /// only its first (every corner of it sees the same S, see
    /// [`is_simplex`](Self::is_simplex)), every other kind all of its corners.
    /// The one place this rule is written.
    pub fn optimised_corners(self) -> &'static [[usize; 4]] {
        let all = self.corners();
        if self.is_simplex() { &all[..1] } else { all }
    }

    /// Faces (for 3D kinds) or edges (for 2D kinds) as local vertex lists; a facet
    /// used by exactly one element lies on the boundary skin.
    pub fn facets(self) -> &'static [&'static [usize]] {
        match self {
            ElementKind::Triangle => &[&[0, 1], &[1, 2], &[2, 0]],
            ElementKind::Quadrilateral => &[&[0, 1], &[1, 2], &[2, 3], &[3, 0]],
            ElementKind::Tetrahedron => &[&[0, 1, 2], &[0, 1, 3], &[1, 2, 3], &[0, 2, 3]],
            ElementKind::Hexahedron => &[
                &[0, 1, 2, 3],
                &[4, 5, 6, 7],
                &[0, 1, 5, 4],
                &[1, 2, 6, 5],
                &[2, 3, 7, 6],
                &[3, 0, 4, 7],
            ],
            ElementKind::Prism => &[&[0, 1, 2], &[3, 4, 5], &[0, 1, 4, 3], &[1, 2, 5, 4], &[2, 0, 3, 5]],
            ElementKind::Polyhedron => &[],
        }
    }

    /// Edges as local vertex pairs.
    pub fn edges(self) -> &'static [[usize; 2]] {
        match self {
            ElementKind::Triangle => &[[0, 1], [1, 2], [2, 0]],
            ElementKind::Quadrilateral => &[[0, 1], [1, 2], [2, 3], [3, 0]],
            ElementKind::Tetrahedron => &[[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]],
            ElementKind::Hexahedron => &[
                [0, 1],
                [1, 2],
                [2, 3],
                [3, 0],
                [4, 5],
                [5, 6],
                [6, 7],
                [7, 4],
                [0, 4],
                [1, 5],
                [2, 6],
                [3, 7],
            ],
            ElementKind::Prism => &[[0, 1], [1, 2], [2, 0], [3, 4], [4, 5], [5, 3], [0, 3], [1, 4], [2, 5]],
            ElementKind::Polyhedron => &[],
        }
    }

    /// VTK cell type id.
    pub fn vtk_id(self) -> u8 {
        match self {
            ElementKind::Triangle => 5,
            ElementKind::Quadrilateral => 9,
            ElementKind::Tetrahedron => 10,
            ElementKind::Hexahedron => 12,
            ElementKind::Prism => 13,
            ElementKind::Polyhedron => 42,
        }
    }

    /// The kind with this VTK cell type number, if meshsmooth handles it.
    pub fn from_vtk_id(id: u8) -> Option<Self> {
        ElementKind::ALL.into_iter().find(|k| k.vtk_id() == id)
    }

    /// Gmsh element type number; `None` for polyhedra, which Gmsh files cannot hold.
    pub fn gmsh_id(self) -> Option<u32> {
        match self {
            ElementKind::Triangle => Some(2),
            ElementKind::Quadrilateral => Some(3),
            ElementKind::Tetrahedron => Some(4),
            ElementKind::Hexahedron => Some(5),
            ElementKind::Prism => Some(6),
            ElementKind::Polyhedron => None,
        }
    }

    /// The kind with this Gmsh element type number, if meshsmooth handles it.
    pub fn from_gmsh_id(id: u32) -> Option<Self> {
        ElementKind::ALL.into_iter().find(|k| k.gmsh_id() == Some(id))
    }

    /// The kind's lower-case name (`triangle`, `tetrahedron`, ...).
    pub fn name(self) -> &'static str {
        match self {
            ElementKind::Triangle => "triangle",
            ElementKind::Quadrilateral => "quadrilateral",
            ElementKind::Tetrahedron => "tetrahedron",
            ElementKind::Hexahedron => "hexahedron",
            ElementKind::Prism => "prism",
            ElementKind::Polyhedron => "polyhedron",
        }
    }
}

impl fmt::Display for ElementKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn simplices_optimise_their_first_corner_the_others_all() {
        for kind in ElementKind::ALL {
            let Some(nv) = kind.num_vertices() else { continue };
            let used = kind.optimised_corners();
            let simplex = nv == kind.dim() + 1;
            assert_eq!(kind.is_simplex(), simplex, "{kind}");
            assert_eq!(used.len(), if simplex { 1 } else { nv }, "{kind}");
            assert_eq!(used, &kind.corners()[..used.len()], "{kind}");
        }
    }

    #[test]
    fn corner_tables_use_each_vertex_once_as_corner() {
        for kind in ElementKind::ALL {
            let Some(nv) = kind.num_vertices() else { continue };
            let corners = kind.corners();
            assert_eq!(corners.len(), nv, "{kind}");
            for (i, c) in corners.iter().enumerate() {
                assert_eq!(c[0], i, "{kind}");
                for &n in &c[1..=kind.dim()] {
                    assert!(n < nv && n != i, "{kind}");
                    let is_edge = kind
                        .edges()
                        .iter()
                        .any(|e| (e[0] == i && e[1] == n) || (e[1] == i && e[0] == n));
                    assert!(is_edge, "{kind}: corner {i} neighbour {n} is not an edge");
                }
            }
        }
    }
}
