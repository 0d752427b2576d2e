//! Surface meshes (triangles and quadrilaterals in 3D) for tests, examples
//! and benchmarks: the unit sphere refined from an octahedron, and the skin
//! of a cube, both wound with outward normals.

use crate::mesh::{ElementKind, Mesh};
use std::collections::HashMap;

/// The unit sphere: an octahedron with every face split into `n^2`
/// triangles, projected onto the sphere (`8 n^2` triangles, `4 n^2 + 2`
/// vertices), wound counterclockwise seen from outside.
///
/// # Panics
/// If `n` is zero.
pub fn sphere(n: usize) -> Mesh {
    assert!(n > 0, "sphere: n must be at least 1");
    let axes: [[f64; 3]; 6] = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    let faces = [
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    let mut welded = Welded::default();
    let mut tris = Vec::new();
    for [a, b, c] in faces {
        let (a, b, c) = (axes[a], axes[b], axes[c]);
        // barycentric lattice point (i, j) of the face: a + i/n (b - a) + j/n (c - a)
        let at = |i: usize, j: usize, w: &mut Welded| {
            let (s, t) = (i as f64 / n as f64, j as f64 / n as f64);
            let p: [f64; 3] = std::array::from_fn(|k| a[k] + s * (b[k] - a[k]) + t * (c[k] - a[k]));
            let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            w.id(p.map(|x| x / l))
        };
        for i in 0..n {
            for j in 0..n - i {
                let (p, q, r) = (
                    at(i, j, &mut welded),
                    at(i + 1, j, &mut welded),
                    at(i, j + 1, &mut welded),
                );
                tris.push([p, q, r]);
                if i + j + 1 < n {
                    let s = at(i + 1, j + 1, &mut welded);
                    tris.push([q, s, r]);
                }
            }
        }
    }
    let mut mesh = Mesh::new(welded.points);
    for t in tris {
        mesh.push_element(ElementKind::Triangle, &t);
    }
    mesh
}

/// The skin of the cube [0, side]^3 with `n x n` cells on every face:
/// quadrilaterals, or each split into two triangles (`triangles`), wound
/// counterclockwise seen from outside.
///
/// # Panics
/// If `n` is zero or `side` is not positive and finite.
pub fn cube_surface(n: usize, side: f64, triangles: bool) -> Mesh {
    assert!(
        n > 0 && side > 0.0 && side.is_finite(),
        "cube_surface: n >= 1 and a positive side"
    );
    let mut welded = Welded::default();
    let mut cells = Vec::new();
    // each face: a fixed axis k at 0 or side, and two in-face axes (u, v)
    // ordered so that u x v points outward
    for k in 0..3 {
        for high in [false, true] {
            let (mut u, mut v) = ((k + 1) % 3, (k + 2) % 3);
            if !high {
                std::mem::swap(&mut u, &mut v);
            }
            let at = |i: usize, j: usize, w: &mut Welded| {
                let mut p = [0.0; 3];
                p[k] = if high { side } else { 0.0 };
                // lattice coordinates exact at the ends, so shared edges weld
                p[u] = if i == n { side } else { side * i as f64 / n as f64 };
                p[v] = if j == n { side } else { side * j as f64 / n as f64 };
                w.id(p)
            };
            for i in 0..n {
                for j in 0..n {
                    let q = [
                        at(i, j, &mut welded),
                        at(i + 1, j, &mut welded),
                        at(i + 1, j + 1, &mut welded),
                        at(i, j + 1, &mut welded),
                    ];
                    cells.push(q);
                }
            }
        }
    }
    let mut mesh = Mesh::new(welded.points);
    for [a, b, c, d] in cells {
        if triangles {
            mesh.push_element(ElementKind::Triangle, &[a, b, c]);
            mesh.push_element(ElementKind::Triangle, &[a, c, d]);
        } else {
            mesh.push_element(ElementKind::Quadrilateral, &[a, b, c, d]);
        }
    }
    mesh
}

/// Points numbered once each, by their coordinates to 1e-12 (a point on an
/// edge shared by two faces is computed from each, with other roundings).
#[derive(Default)]
struct Welded {
    points: Vec<[f64; 3]>,
    ids: HashMap<[i64; 3], u32>,
}

impl Welded {
    fn id(&mut self, p: [f64; 3]) -> u32 {
        let p = p.map(|x| x + 0.0);
        let key = p.map(|x| (x * 1e12).round() as i64);
        let next = self.points.len() as u32;
        *self.ids.entry(key).or_insert_with(|| {
            self.points.push(p);
            next
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::mat3::{cross, dot, sub};

    fn outward(m: &Mesh) -> bool {
        let c = {
            let n = m.num_points() as f64;
            let mut c = [0.0; 3];
            for p in &m.points {
                for k in 0..3 {
                    c[k] += p[k] / n;
                }
            }
            c
        };
        (0..m.num_elements()).all(|e| {
            let vs = m.element(e);
            let p = |i: usize| m.points[vs[i] as usize];
            let n = cross(&sub(&p(1), &p(0)), &sub(&p(2), &p(0)));
            dot(&n, &sub(&p(0), &c)) > 0.0
        })
    }

    #[test]
    fn spheres_and_cubes_are_closed_welded_and_wound_outward() {
        for n in [1, 2, 3, 4, 5, 6, 16] {
            let s = sphere(n);
            assert_eq!(s.num_elements(), 8 * n * n);
            assert_eq!(s.num_points(), 4 * n * n + 2);
            assert!(s.points.iter().all(|p| (dot(p, p).sqrt() - 1.0).abs() < 1e-15));
            assert!(outward(&s));
            for tri in [false, true] {
                let c = cube_surface(n, 2.0, tri);
                assert_eq!(c.num_points(), 6 * n * n + 2, "Euler: V = E - F + 2");
                assert_eq!(c.num_elements(), 6 * n * n * if tri { 2 } else { 1 });
                assert!(outward(&c));
            }
        }
    }
}
