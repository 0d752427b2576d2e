//! A conforming mixed mesh of tetrahedra, prisms and hexahedra. Without
//! pyramids, hexahedra may meet prisms only through quadrilateral faces and
//! prisms meet tetrahedra through triangles, so the domain is an L: Kuhn
//! tetrahedra in the lower slab x in [0, n], prisms above them (their
//! triangles split along the same x+y diagonal as the tetrahedra's top faces),
//! and hexahedra beside the prisms in x in [n, 2n].

use crate::mesh::{ElementKind, Mesh};
use crate::metric::tet_det;
use std::collections::HashMap;

/// `n` x `n` cells per slab across (x, y), each slab `layers` cells high.
pub fn mixed_block(n: usize, layers: usize) -> Mesh {
    assert!(n > 0 && layers > 0, "mixed_block needs at least one cell");
    let mut ids: HashMap<[usize; 3], u32> = HashMap::new();
    let mut points = Vec::new();
    let mut id = |p: [usize; 3], points: &mut Vec<[f64; 3]>| {
        *ids.entry(p).or_insert_with(|| {
            points.push([p[0] as f64, p[1] as f64, p[2] as f64]);
            points.len() as u32 - 1
        })
    };
    let mut cells: Vec<(ElementKind, Vec<u32>)> = Vec::new();
    for k in 0..2 * layers {
        for j in 0..n {
            for i in 0..2 * n {
                // cube corner b: bit 0 = x, bit 1 = y, bit 2 = z
                let corner = |b: usize| [i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1)];
                if i < n && k < layers {
                    // lower slab: Kuhn tetrahedra around the diagonal 0-7
                    for perm in [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]] {
                        let a = 1 << perm[0];
                        let ab = a | (1 << perm[1]);
                        let vs = [0, a, ab, 7].map(|b| id(corner(b), &mut points));
                        cells.push((ElementKind::Tetrahedron, vs.to_vec()));
                    }
                } else if i < n {
                    // upper slab: two prisms on the triangles (0,1,3) and (0,3,2)
                    for tri in [[0, 1, 3], [0, 3, 2]] {
                        let bottom = tri.map(|b| id(corner(b), &mut points));
                        let top = tri.map(|b| id(corner(b + 4), &mut points));
                        cells.push((ElementKind::Prism, [bottom, top].concat()));
                    }
                } else if k >= layers {
                    let vs = [0, 1, 3, 2, 4, 5, 7, 6].map(|b| id(corner(b), &mut points));
                    cells.push((ElementKind::Hexahedron, vs.to_vec()));
                }
            }
        }
    }
    let mut mesh = Mesh::new(points);
    for (kind, mut vs) in cells {
        if kind == ElementKind::Tetrahedron {
            let x = [0, 1, 2, 3].map(|k| mesh.points[vs[k] as usize]);
            if tet_det(&x) < 0.0 {
                vs.swap(1, 2);
            }
        }
        mesh.push_element(kind, &vs);
    }
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mixed_block_is_valid_conforming_and_positively_oriented() {
        let m = mixed_block(3, 2);
        m.validate().unwrap();
        assert_eq!(m.count_kind(ElementKind::Tetrahedron), 6 * 18);
        assert_eq!(m.count_kind(ElementKind::Prism), 2 * 18);
        assert_eq!(m.count_kind(ElementKind::Hexahedron), 18);
        assert!(crate::metric::inverted_elements(&m, &m.points).is_empty());
        // conforming: every interior face is shared by exactly two elements, so the
        // skin is the boundary of the L-shaped domain (lower slab z in [0, 2] under
        // x in [0, 3]; upper slab z in [2, 4] under x in [0, 6]) and nothing else
        let skin = crate::mesh::topology::skin_vertices(&m);
        for (p, &on_skin) in m.points.iter().zip(&skin) {
            let inside_y = p[1] > 0.0 && p[1] < 3.0;
            let lower = p[0] > 0.0 && p[0] < 3.0 && p[2] > 0.0 && p[2] <= 2.0;
            let upper = p[0] > 0.0 && p[0] < 6.0 && p[2] > 2.0 && p[2] < 4.0;
            assert_eq!(on_skin, !(inside_y && (lower || upper)), "{p:?}");
        }
        // interior vertices on each kind's interfaces exist (tet-prism at z = 2, prism-hex at x = 3)
        assert!(m.points.iter().zip(&skin).any(|(p, &s)| !s && p[2] == 2.0));
        assert!(
            m.points
                .iter()
                .zip(&skin)
                .any(|(p, &s)| !s && p[0] == 3.0 && p[2] == 3.0)
        );
    }
}
