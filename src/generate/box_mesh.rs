//! Structured tetrahedral boxes.

use crate::mesh::{ElementKind, Mesh};

/// The 6 Kuhn (Freudenthal) paths from cell corner (0,0,0) to (1,1,1), as
/// axis orders, with the sign of the permutation. Every cell uses the same
/// split, so the diagonals on shared faces agree and the mesh conforms.
const KUHN: [([usize; 3], bool); 6] = [
    ([0, 1, 2], true),
    ([0, 2, 1], false),
    ([1, 0, 2], false),
    ([1, 2, 0], true),
    ([2, 0, 1], true),
    ([2, 1, 0], false),
];

/// A box `[0, lengths[0]] x [0, lengths[1]] x [0, lengths[2]]` of `nx * ny * nz`
/// hexahedral cells, each split into 6 tetrahedra along its main diagonal
/// (Kuhn split). Vertices are numbered x fastest, then y, then z; every tet is
/// positively oriented. On cube cells the tets are congruent with inverse mean
/// ratio 1.32283, the optimum of the mean-ratio objective on this connectivity.
///
/// # Panics
/// If a cell count is zero or a length is not positive and finite.
pub fn tet_box(nx: usize, ny: usize, nz: usize, lengths: [f64; 3]) -> Mesh {
    assert!(nx > 0 && ny > 0 && nz > 0, "tet_box needs at least one cell per axis");
    assert!(
        lengths.iter().all(|l| l.is_finite() && *l > 0.0),
        "tet_box needs positive finite lengths, got {lengths:?}"
    );
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
    mesh.kinds.reserve(6 * nx * ny * nz);
    mesh.conn.reserve(24 * nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                for (order, even) in KUHN {
                    let mut c = [i, j, k];
                    let mut tet = [id(i, j, k); 4];
                    for (slot, axis) in tet[1..].iter_mut().zip(order) {
                        c[axis] += 1;
                        *slot = id(c[0], c[1], c[2]);
                    }
                    // det[e_a, e_a+e_b, e_a+e_b+e_c] has the permutation's sign
                    if !even {
                        tet.swap(1, 2);
                    }
                    mesh.push_element(ElementKind::Tetrahedron, &tet);
                }
            }
        }
    }
    mesh
}

/// The duct of the size study: a box 4 x 1 x 1 (long axis x) of
/// `4n x n x n` cube cells, `n = cells_across`, split into tets by
/// [`tet_box`]. It has `(4n+1)(n+1)^2` vertices and `24 n^3` tets.
pub fn duct(cells_across: usize) -> Mesh {
    let n = cells_across;
    tet_box(4 * n, n, n, [4.0, 1.0, 1.0])
}
