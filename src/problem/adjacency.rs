//! Stage 4, adjacency (elements, corner incidence, vertex neighbours and the
//! free vertices in the problem's numbering), and stage 5, colours.

use super::corners::{Corners, push_element_vertices, reverse_winding};
use super::numbering::{MeshGraph, Numbering};
use crate::mesh::topology::{self, Csr};
use crate::mesh::{ElementKind, Mesh, color};
use rayon::prelude::*;

/// What a solver needs to find its way around the problem, all in the
/// problem's numbering.
#[derive(Clone, Debug)]
pub struct Adjacency {
    /// Vertices of each element, in the order the corners read them.
    pub elements: Csr,
    /// Per vertex: incident corners packed as `4 * corner + local slot`.
    pub incidence: Csr,
    /// Per vertex: its edge neighbours, sorted.
    pub neighbours: Csr,
    /// Per vertex: may it move?
    pub free: Vec<bool>,
    /// Free vertices in sweep order (ascending ids).
    pub free_vertices: Vec<u32>,
    /// Every element a simplex: the vertices sharing an element with a
    /// vertex are then its edge neighbours.
    pub simplicial: bool,
}

/// Which vertices move and their sweep order, from the mesh graph, the numbering and the corners.
pub fn adjacency(mesh: &Mesh, graph: &MeshGraph, numbering: &Numbering, corners: &Corners) -> Adjacency {
    let (order, inv) = (&numbering.order, &numbering.inv);
    let n = order.len();
    let dim = corners.dim;
    let elements = renumbered_elements(mesh, numbering, corners.flip);
    // a sequential counting sort: linear, and faster on two shared cores
    // than a parallel one with atomics (see `topology::vertex_elements`)
    let incidence = Csr::from_pairs(
        n,
        corners
            .corners
            .iter()
            .enumerate()
            .flat_map(|(c, t)| (0..=dim).map(move |k| (t[k], 4 * c as u32 + k as u32))),
    );
    // each vertex's list renumbered and sorted on its own, in parallel, not
    // one sort of every (vertex, neighbour) pair
    let neighbours = topology::build_par(n, |new, out| {
        let from = out.len();
        out.extend(
            graph
                .neighbours
                .of(order[new] as usize)
                .iter()
                .map(|&w| inv[w as usize]),
        );
        out[from..].sort_unstable();
    });
    let simplicial = mesh
        .kinds
        .par_iter()
        .all(|k| matches!(k, ElementKind::Triangle | ElementKind::Tetrahedron));
    let free: Vec<bool> = order.iter().map(|&o| !graph.fixed[o as usize]).collect();
    let free_vertices: Vec<u32> = (0..n as u32).filter(|&v| free[v as usize]).collect();
    Adjacency {
        elements,
        incidence,
        neighbours,
        free,
        free_vertices,
        simplicial,
    }
}

/// The elements' vertices in the problem's numbering, elements in its order.
fn renumbered_elements(mesh: &Mesh, numbering: &Numbering, flip: bool) -> Csr {
    let (elem_order, inv) = (&numbering.elem_order, &numbering.inv);
    let ne = elem_order.len();
    let k = if ne > 0 { mesh.element(0).len() } else { 0 };
    if k == 0 || !(0..ne).into_par_iter().all(|e| mesh.element(e).len() == k) {
        return topology::build_par(ne, |new_e, out| {
            let from = out.len();
            push_element_vertices(mesh, elem_order[new_e] as usize, flip, out);
            for v in &mut out[from..] {
                *v = inv[*v as usize];
            }
        });
    }
    // elements of one size (the usual mesh) are written in place: no
    // per-task lists to grow and then copy together
    let mut items = vec![0u32; k * ne];
    items
        .par_chunks_mut(k)
        .zip(elem_order.par_iter())
        .with_min_len(1 << 12)
        .for_each(|(out, &old)| {
            let old = old as usize;
            out.copy_from_slice(mesh.element(old));
            if flip {
                reverse_winding(mesh.kinds[old], out);
            }
            for v in out {
                *v = inv[*v as usize];
            }
        });
    Csr {
        offsets: (0..=ne).map(|e| (k * e) as u32).collect(),
        items,
    }
}

/// Colour classes of the free vertices (greedy, in sweep order): no two
/// vertices of a class share an element.
///
/// The greedy pass stays sequential, so the classes (and every coloured
/// solve) are the same as ever on any thread count; it is made cheap
/// instead: each vertex reads its deduplicated list of element-sharing
/// vertices (built in parallel), not every vertex of every element around
/// it. In a simplex every two vertices share an edge, so there the list is
/// the edge neighbours, already built.
pub fn colours(adj: &Adjacency) -> Csr {
    let n = adj.free.len();
    let shared;
    let around = if adj.simplicial {
        &adj.neighbours
    } else {
        shared = sharing_neighbours(&adj.elements, n);
        &shared
    };
    color::greedy(&adj.free_vertices, n, |v| around.of(v).iter().copied())
}

/// Per vertex: the other vertices of its elements, sorted, each once.
pub(crate) fn sharing_neighbours(elements: &Csr, n: usize) -> Csr {
    let vertex_elements = Csr::from_pairs(
        n,
        (0..elements.len()).flat_map(|e| elements.of(e).iter().map(move |&v| (v, e as u32))),
    );
    topology::build_par(n, |v, out| {
        let from = out.len();
        for &e in vertex_elements.of(v) {
            out.extend(elements.of(e as usize).iter().filter(|&&w| w as usize != v));
        }
        crate::mesh::topology::sort_dedup_tail(out, from);
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate;
    use crate::mesh::order::Ordering;
    use crate::problem::{ProblemOptions, corners, element_vertices, order};

    fn stages(mesh: &Mesh) -> (Numbering, Corners, Adjacency) {
        let g = MeshGraph::of(mesh);
        let num = order(mesh, &g, Ordering::ReverseBfs);
        let cs = corners(mesh, &mesh.points, &ProblemOptions::default(), &num).unwrap();
        let adj = adjacency(mesh, &g, &num, &cs);
        (num, cs, adj)
    }

    #[test]
    fn incidence_lists_every_corner_slot_once_under_its_vertex() {
        let m = generate::mixed_block(2, 2);
        let (_, cs, adj) = stages(&m);
        let dim = cs.dim;
        let mut seen = vec![0u8; 4 * cs.len()];
        for v in 0..adj.incidence.len() {
            for &packed in adj.incidence.of(v) {
                let (c, k) = (packed as usize / 4, packed as usize % 4);
                assert!(k <= dim);
                assert_eq!(cs.corners[c][k] as usize, v, "slot {k} of corner {c}");
                seen[packed as usize] += 1;
            }
        }
        for c in 0..cs.len() {
            for k in 0..4 {
                assert_eq!(seen[4 * c + k], u8::from(k <= dim), "corner {c} slot {k}");
            }
        }
    }

    /// Both ways of renumbering elements (in place for one size, by lists
    /// for several) give each element's vertices as the corners read them,
    /// clockwise planar meshes reversed.
    #[test]
    fn elements_are_read_as_the_corners_read_them_in_the_new_numbering() {
        let mut clockwise = generate::quad_grid(5, 4, [5.0, 4.0]);
        for p in &mut clockwise.points {
            p[1] = -p[1];
        }
        let mut mixed_planar = generate::tri_grid(4, 3, [4.0, 3.0]);
        mixed_planar.push_element(ElementKind::Quadrilateral, &[0, 1, 6, 5]);
        let meshes = [
            ("mixed", generate::mixed_block(2, 2)),
            ("tets", generate::tet_box(5, 4, 3, [5.0, 4.0, 3.0])),
            ("clockwise quads", clockwise),
            ("triangles and a quad", mixed_planar),
        ];
        for (name, m) in meshes {
            let (num, cs, adj) = stages(&m);
            assert_eq!(adj.elements.len(), m.num_elements(), "{name}");
            for (new_e, &old_e) in num.elem_order.iter().enumerate() {
                let want: Vec<u32> = element_vertices(&m, old_e as usize, cs.flip)
                    .iter()
                    .map(|&v| num.inv[v as usize])
                    .collect();
                assert_eq!(adj.elements.of(new_e), want, "{name}: element {new_e}");
            }
            if name == "clockwise quads" {
                assert!(cs.flip, "{name}");
            }
        }
    }

    #[test]
    fn elements_and_neighbours_are_the_mesh_renumbered() {
        let m = generate::mixed_block(2, 2);
        let (num, _, adj) = stages(&m);
        for (new_e, &old_e) in num.elem_order.iter().enumerate() {
            let mut a: Vec<u32> = adj.elements.of(new_e).iter().map(|&v| num.order[v as usize]).collect();
            let mut b = m.element(old_e as usize).to_vec();
            a.sort_unstable();
            b.sort_unstable();
            assert_eq!(a, b, "element {new_e}");
        }
        let g = MeshGraph::of(&m);
        for v in 0..adj.neighbours.len() {
            let nb = adj.neighbours.of(v);
            assert!(nb.windows(2).all(|w| w[0] < w[1]));
            let mut old: Vec<u32> = nb.iter().map(|&w| num.order[w as usize]).collect();
            old.sort_unstable();
            assert_eq!(old, g.neighbours.of(num.order[v] as usize));
            assert_eq!(adj.free[v], !g.fixed[num.order[v] as usize]);
        }
        assert!(adj.free_vertices.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(adj.free_vertices.len(), adj.free.iter().filter(|&&f| f).count());
    }

    #[test]
    fn setup_is_the_same_on_one_thread_and_on_two() {
        let m = generate::tet_box(9, 8, 7, [9.0, 8.0, 7.0]);
        let build = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| crate::problem::Problem::new(&m).unwrap())
        };
        let (a, b) = (build(1), build(2));
        assert_eq!(a.order, b.order);
        assert_eq!(a.elem_order, b.elem_order);
        assert_eq!(a.elements, b.elements);
        assert_eq!(a.corners, b.corners);
        assert_eq!(a.incidence, b.incidence);
        assert_eq!(a.neighbours, b.neighbours);
        assert_eq!(a.free, b.free);
        assert_eq!(a.colors, b.colors);
    }

    /// The colouring as it was first written: greedy over every vertex of
    /// every element around each vertex.
    fn colours_over_whole_elements(adj: &Adjacency) -> Csr {
        let n = adj.free.len();
        let elements = &adj.elements;
        let pairs: Vec<(u32, u32)> = (0..elements.len())
            .flat_map(|e| elements.of(e).iter().map(move |&v| (v, e as u32)))
            .collect();
        let vertex_elements = Csr::from_pairs(n, pairs.into_iter());
        color::greedy(&adj.free_vertices, n, |v| {
            vertex_elements
                .of(v)
                .iter()
                .flat_map(|&e| elements.of(e as usize).iter().copied())
        })
    }

    #[test]
    fn colours_are_those_of_the_greedy_over_whole_elements_on_any_thread_count() {
        let hexes = generate::hex_box(5, 4, 4, [5.0, 4.0, 4.0]);
        let tets = generate::tet_box(12, 12, 12, [1.0, 1.0, 1.0]);
        for (name, m) in [("mixed", generate::mixed_block(4, 3)), ("hexes", hexes), ("tets", tets)] {
            let (_, _, adj) = stages(&m);
            let want = colours_over_whole_elements(&adj);
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                assert_eq!(pool.install(|| colours(&adj)), want, "{name} on {threads} threads");
            }
        }
    }

    #[test]
    fn no_two_vertices_of_a_colour_share_an_element() {
        let m = generate::tet_box(4, 3, 3, [4.0, 3.0, 3.0]);
        let (_, _, adj) = stages(&m);
        let colors = colours(&adj);
        let mut colour_of = vec![u32::MAX; adj.free.len()];
        for k in 0..colors.len() {
            for &v in colors.of(k) {
                assert_eq!(colour_of[v as usize], u32::MAX, "vertex {v} coloured twice");
                colour_of[v as usize] = k as u32;
            }
        }
        for v in 0..adj.free.len() {
            assert_eq!(adj.free[v], colour_of[v] != u32::MAX, "vertex {v}");
        }
        for e in 0..adj.elements.len() {
            let cs: Vec<u32> = adj
                .elements
                .of(e)
                .iter()
                .map(|&v| colour_of[v as usize])
                .filter(|&c| c != u32::MAX)
                .collect();
            for (i, a) in cs.iter().enumerate() {
                assert!(!cs[i + 1..].contains(a), "element {e} has two vertices of colour {a}");
            }
        }
        assert!(colors.len() >= 2);
    }
}
