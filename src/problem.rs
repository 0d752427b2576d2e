//! `Problem`: what a solver needs and nothing else — free-vertex flags,
//! elements and adjacency in locality order, and the metric's reference data.
//! Built once; solvers work in its (reordered) numbering and the result is
//! mapped back to the mesh's own numbering.

use crate::error::{Error, Result};
use crate::mesh::topology::{self, Csr};
use crate::mesh::{ElementKind, Mesh, color, order};
use crate::metric::TetShape;
use crate::metric::mat3::Vec3;
use std::time::{Duration, Instant};

#[derive(Clone, Debug)]
pub struct Problem {
    /// `order[new] = old` vertex id.
    pub order: Vec<u32>,
    /// `elem_order[new] = old` element id.
    pub elem_order: Vec<u32>,
    /// Tetrahedra in the new numbering.
    pub tets: Vec<[u32; 4]>,
    /// Per vertex (new numbering): incident elements packed as `4 * element + local corner`.
    pub incidence: Csr,
    /// Per vertex: its edge neighbours (new numbering).
    pub neighbours: Csr,
    /// Per vertex: may it move?
    pub free: Vec<bool>,
    /// Free vertices in sweep order (ascending new ids).
    pub free_vertices: Vec<u32>,
    /// Colour classes of the free vertices: no two vertices of a class share an
    /// element. Each class is in sweep order.
    pub colors: Csr,
    /// Reference shape of every element (the equilateral tetrahedron).
    pub shape: TetShape,
    /// Time spent building this problem.
    pub setup_time: Duration,
}

impl Problem {
    /// Builds the problem for the inverse mean-ratio objective over a
    /// tetrahedral mesh. Other element kinds are refused here until their
    /// solvers exist.
    pub fn new(mesh: &Mesh) -> Result<Problem> {
        let start = Instant::now();
        if let Some(e) = mesh.kinds.iter().position(|&k| k != ElementKind::Tetrahedron) {
            return Err(Error::Unsupported(format!(
                "element {e} is a {}: the optimiser handles tetrahedral meshes only so far",
                mesh.kinds[e]
            )));
        }
        if mesh.num_elements() == 0 {
            return Err(Error::InvalidMesh("mesh has no elements".into()));
        }
        let fixed_old = topology::fixed_vertices(mesh);
        let nb_old = topology::vertex_neighbours(mesh);
        let order = order::reverse_bfs(&mesh.points, &nb_old, &fixed_old);
        let inv = order::invert(&order);

        // elements numbered in the order the vertex sweep first touches them
        let ve_old = topology::vertex_elements(mesh);
        let mut elem_new = vec![u32::MAX; mesh.num_elements()];
        let mut elem_order = Vec::with_capacity(mesh.num_elements());
        for &old_v in &order {
            for &e in ve_old.of(old_v as usize) {
                if elem_new[e as usize] == u32::MAX {
                    elem_new[e as usize] = elem_order.len() as u32;
                    elem_order.push(e);
                }
            }
        }
        let tets: Vec<[u32; 4]> = elem_order
            .iter()
            .map(|&e| {
                let vs = mesh.element(e as usize);
                [
                    inv[vs[0] as usize],
                    inv[vs[1] as usize],
                    inv[vs[2] as usize],
                    inv[vs[3] as usize],
                ]
            })
            .collect();
        let n = mesh.num_points();
        let incidence = Csr::from_pairs(
            n,
            tets.iter()
                .enumerate()
                .flat_map(|(e, t)| (0..4).map(move |k| (t[k], 4 * e as u32 + k as u32))),
        );
        let inv_ref = &inv;
        let mut nb_pairs: Vec<(u32, u32)> = (0..n)
            .flat_map(|new| {
                nb_old
                    .of(order[new] as usize)
                    .iter()
                    .map(move |&w| (new as u32, inv_ref[w as usize]))
            })
            .collect();
        nb_pairs.sort_unstable();
        let neighbours = Csr::from_pairs(n, nb_pairs.into_iter());
        let free: Vec<bool> = order.iter().map(|&o| !fixed_old[o as usize]).collect();
        let free_vertices: Vec<u32> = (0..n as u32).filter(|&v| free[v as usize]).collect();
        let colors = color::greedy(&free_vertices, n, |v| {
            incidence.of(v).iter().flat_map(|&packed| tets[(packed >> 2) as usize])
        });
        Ok(Problem {
            order,
            elem_order,
            tets,
            incidence,
            neighbours,
            free,
            free_vertices,
            colors,
            shape: TetShape::equilateral(),
            setup_time: start.elapsed(),
        })
    }

    /// Bytes held by the problem's arrays.
    pub fn bytes(&self) -> usize {
        let csr = |c: &Csr| 4 * (c.offsets.len() + c.items.len());
        4 * (self.order.len() + self.elem_order.len() + self.free_vertices.len())
            + 16 * self.tets.len()
            + self.free.len()
            + csr(&self.incidence)
            + csr(&self.neighbours)
            + csr(&self.colors)
    }

    pub fn num_vertices(&self) -> usize {
        self.order.len()
    }

    pub fn num_elements(&self) -> usize {
        self.tets.len()
    }

    /// Mesh positions gathered into the problem's numbering.
    pub fn gather(&self, points: &[Vec3]) -> Vec<Vec3> {
        self.order.iter().map(|&o| points[o as usize]).collect()
    }

    /// Problem positions scattered back to the mesh numbering.
    pub fn scatter(&self, x: &[Vec3]) -> Vec<Vec3> {
        let mut out = vec![[0.0; 3]; x.len()];
        for (new, &old) in self.order.iter().enumerate() {
            out[old as usize] = x[new];
        }
        out
    }

    #[inline]
    pub fn tet_points(&self, x: &[Vec3], e: usize) -> [Vec3; 4] {
        let t = &self.tets[e];
        [x[t[0] as usize], x[t[1] as usize], x[t[2] as usize], x[t[3] as usize]]
    }

    /// Mean edge length, the length scale for displacement comparisons.
    pub fn mean_edge_length(&self, x: &[Vec3]) -> f64 {
        let (mut sum, mut count) = (0.0, 0usize);
        for v in 0..self.num_vertices() {
            for &w in self.neighbours.of(v) {
                if (w as usize) > v {
                    sum += crate::metric::mat3::sub(&x[v], &x[w as usize])
                        .iter()
                        .map(|c| c * c)
                        .sum::<f64>()
                        .sqrt();
                    count += 1;
                }
            }
        }
        sum / count.max(1) as f64
    }

    /// Element ids (mesh numbering) that are inverted or degenerate at `x`.
    pub fn infeasible_elements(&self, x: &[Vec3]) -> Vec<usize> {
        let mut bad: Vec<usize> = (0..self.num_elements())
            .filter(|&e| self.shape.value(&self.tet_points(x, e)).is_none())
            .map(|e| self.elem_order[e] as usize)
            .collect();
        bad.sort_unstable();
        bad
    }

    /// Refuses a start with inverted elements: every solver needs a feasible start.
    pub fn check_feasible(&self, x: &[Vec3]) -> Result<()> {
        let bad = self.infeasible_elements(x);
        if bad.is_empty() {
            Ok(())
        } else {
            Err(Error::Inverted {
                count: bad.len(),
                first: bad.into_iter().take(5).collect(),
            })
        }
    }
}
