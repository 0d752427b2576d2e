//! Stage 2, order: the vertex order (a parameter, [`Ordering`]) and the
//! element order that follows it.

use crate::mesh::Mesh;
use crate::mesh::order::{self, Ordering};
use crate::mesh::topology::{self, Csr};

/// The mesh's adjacency in its own numbering, computed once and read by the
/// order and adjacency stages.
#[derive(Clone, Debug)]
pub struct MeshGraph {
    /// Per vertex: on the skin or fixed by the user.
    pub fixed: Vec<bool>,
    /// Per vertex: its edge neighbours, sorted.
    pub neighbours: Csr,
    /// Per vertex: its elements, ascending.
    pub vertex_elements: Csr,
}

impl MeshGraph {
    /// The vertex graph of `mesh`: fixed flags, edge neighbours and vertex elements.
    pub fn of(mesh: &Mesh) -> MeshGraph {
        let (fixed, neighbours, vertex_elements) = topology::vertex_graph(mesh);
        MeshGraph {
            fixed,
            neighbours,
            vertex_elements,
        }
    }
}

/// A problem's numbering of vertices and elements.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Numbering {
    /// `order[new] = old` vertex id.
    pub order: Vec<u32>,
    /// `inv[old] = new` vertex id.
    pub inv: Vec<u32>,
    /// `elem_order[new] = old` element id.
    pub elem_order: Vec<u32>,
}

impl Numbering {
    /// The mesh's own numbering of vertices and elements (what reports use:
    /// no graph is needed).
    pub fn identity(mesh: &Mesh) -> Numbering {
        let order: Vec<u32> = (0..mesh.num_points() as u32).collect();
        Numbering {
            inv: order.clone(),
            order,
            elem_order: (0..mesh.num_elements() as u32).collect(),
        }
    }
}

/// Vertices in `ordering`; elements numbered in the order the vertex sweep
/// first touches them.
pub fn order(mesh: &Mesh, graph: &MeshGraph, ordering: Ordering) -> Numbering {
    let order = ordering.order(&mesh.points, &graph.neighbours, &graph.fixed);
    let inv = order::invert(&order);
    let elem_order = order::elements_by_first_touch(&inv, mesh);
    Numbering { inv, order, elem_order }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate;

    #[test]
    fn order_is_a_permutation_with_its_inverse_for_every_ordering() {
        let m = generate::tet_box(3, 2, 2, [3.0, 2.0, 2.0]);
        let g = MeshGraph::of(&m);
        for o in Ordering::all() {
            let n = order(&m, &g, o);
            assert_eq!(n.order.len(), m.num_points(), "{o}");
            for (new, &old) in n.order.iter().enumerate() {
                assert_eq!(n.inv[old as usize] as usize, new, "{o}");
            }
            let mut elems = n.elem_order.clone();
            elems.sort_unstable();
            assert_eq!(elems, (0..m.num_elements() as u32).collect::<Vec<_>>(), "{o}");
            // the first element is one of the first vertex's
            assert!(
                g.vertex_elements.of(n.order[0] as usize).contains(&n.elem_order[0]),
                "{o}"
            );
        }
        let input = order(&m, &g, Ordering::INPUT);
        assert_eq!(input.order, Numbering::identity(&m).order);
        assert_ne!(order(&m, &g, Ordering::ReverseBfs).order, input.order);
    }
}
