//! `Problem`: what a solver needs and nothing else — free-vertex flags,
//! element corners and adjacency in locality order, each corner's reference
//! (B = D W^-1), the metric and the template. Built once; solvers work in its
//! (reordered) numbering and the result is mapped back to the mesh's own.
//!
//! Every element is a list of corners: simplices one (their map from the
//! reference is affine, so every corner sees the same S), quadrilaterals,
//! hexahedra and prisms all of theirs. F = sum over corners of w_c m(S_c) with
//! w_c = 1 / (|E| corners(e)): the mean over elements of the mean corner term.

use crate::error::{Error, Result};
use crate::mesh::topology::{self, Csr};
use crate::mesh::{ElementKind, Mesh, color, order};
use crate::metric::corner::ideal_corner;
use crate::metric::corner_model::{CornerShape, Model, Template};
use crate::metric::mat3::{Mat3, Vec3, sub};
use crate::metric::smetric::MetricKind;
use std::collections::HashMap;
use std::time::{Duration, Instant};

/// What to optimise.
#[derive(Clone, Copy, Debug, Default)]
pub struct ProblemOptions<'a> {
    pub metric: MetricKind,
    pub template: Template,
    /// A mesh with the same connectivity whose corners are the targets W
    /// (required by `tmp`; optional for the others, which default to the ideal
    /// element of each kind).
    pub reference: Option<&'a Mesh>,
}

impl ProblemOptions<'_> {
    /// The options' own consistency and the reference's fit to `mesh`, without
    /// building anything: callers can refuse bad input before any work.
    pub fn check(&self, mesh: &Mesh) -> Result<()> {
        if self.metric == MetricKind::TargetShapeSize && self.reference.is_none() {
            return Err(Error::InvalidArgument(
                "the target-matrix metric (tmp) needs a reference mesh (--reference) for its targets W".into(),
            ));
        }
        if self.metric == MetricKind::TargetShapeSize && self.template == Template::Average {
            return Err(Error::InvalidArgument(
                "the average template needs a quality in (0, 1] (imr, cn); use the harmonic template with tmp".into(),
            ));
        }
        match self.reference {
            Some(r) => check_same_connectivity(mesh, r),
            None => Ok(()),
        }
    }
}

#[derive(Clone, Debug)]
pub struct Problem {
    /// Metric dimension: 2 (x and y move) or 3.
    pub dim: usize,
    /// `order[new] = old` vertex id.
    pub order: Vec<u32>,
    /// `elem_order[new] = old` element id.
    pub elem_order: Vec<u32>,
    /// Vertices of each element (new numbering), for colouring and reports.
    pub elements: Csr,
    /// Corners: the corner vertex, then its `dim` neighbours (a 2D corner repeats
    /// its vertex in the unused fourth slot, whose B row is zero).
    pub corners: Vec<[u32; 4]>,
    /// Element of each corner (new numbering).
    pub corner_element: Vec<u32>,
    /// Index into `shapes` for each corner.
    pub corner_shape: Vec<u32>,
    /// Weight of each corner in F.
    pub corner_weight: Vec<f64>,
    /// Distinct corner references.
    pub shapes: Vec<CornerShape>,
    pub model: Model,
    /// Per vertex (new numbering): incident corners packed as `4 * corner + local slot`.
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
    /// Time spent building this problem.
    pub setup_time: Duration,
}

/// Local vertex order of an element reversed, for planar meshes wound clockwise.
fn reversed(kind: ElementKind, vs: &[u32]) -> Vec<u32> {
    match kind {
        ElementKind::Triangle => vec![vs[0], vs[2], vs[1]],
        ElementKind::Quadrilateral => vec![vs[0], vs[3], vs[2], vs[1]],
        _ => vs.to_vec(),
    }
}

/// The corner matrix (columns = edges from the corner vertex) of `c` at `pts`.
fn corner_matrix(pts: &[Vec3], vs: &[u32], c: &[usize; 4], n: usize) -> Mat3 {
    let o = pts[vs[c[0]] as usize];
    let mut a = [[0.0; 3]; 3];
    for col in 0..n {
        let e = sub(&pts[vs[c[col + 1]] as usize], &o);
        for row in 0..n {
            a[row][col] = e[row];
        }
    }
    a
}

impl Problem {
    /// The inverse mean ratio, harmonic template, ideal references.
    pub fn new(mesh: &Mesh) -> Result<Problem> {
        Self::with_options(mesh, &ProblemOptions::default())
    }

    pub fn with_options(mesh: &Mesh, opts: &ProblemOptions) -> Result<Problem> {
        let start = Instant::now();
        if mesh.num_elements() == 0 {
            return Err(Error::InvalidMesh("mesh has no elements".into()));
        }
        let dim = mesh.dim();
        if dim == 2 {
            let z = mesh.points[0][2];
            if let Some(v) = mesh.points.iter().position(|p| p[2] != z) {
                return Err(Error::Unsupported(format!(
                    "planar mesh not parallel to the xy plane (vertex 0 has z = {z}, vertex {v} has z = {}); \
                     rotate it into a plane z = constant first",
                    mesh.points[v][2]
                )));
            }
        }
        opts.check(mesh)?;
        // planar meshes wound clockwise are optimised in mirrored order
        let flip = crate::metric::is_clockwise(mesh, &mesh.points);

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
        let ne = elem_order.len();
        let mut shapes: Vec<CornerShape> = Vec::new();
        let mut shape_ids: HashMap<[u64; 12], u32> = HashMap::new();
        let mut corners = Vec::new();
        let mut corner_element = Vec::new();
        let mut corner_shape = Vec::new();
        let mut corner_weight = Vec::new();
        let mut elem_pairs = Vec::new();
        for (new_e, &old_e) in elem_order.iter().enumerate() {
            let kind = mesh.kinds[old_e as usize];
            let raw = mesh.element(old_e as usize);
            let vs = if flip { reversed(kind, raw) } else { raw.to_vec() };
            let all = kind.corners();
            let used = if matches!(kind, ElementKind::Triangle | ElementKind::Tetrahedron) {
                &all[..1]
            } else {
                all
            };
            for c in used {
                let w = match opts.reference {
                    Some(r) => {
                        let rvs = if flip {
                            reversed(kind, r.element(old_e as usize))
                        } else {
                            r.element(old_e as usize).to_vec()
                        };
                        corner_matrix(&r.points, &rvs, c, dim)
                    }
                    None => ideal_corner(kind),
                };
                let shape = CornerShape::from_w(&w, dim).ok_or_else(|| {
                    Error::InvalidMesh(format!(
                        "reference element {old_e} ({kind}) is inverted or degenerate at its corner at vertex {}",
                        vs[c[0]]
                    ))
                })?;
                let key: [u64; 12] = std::array::from_fn(|i| shape.tet.b(i / 3)[i % 3].to_bits());
                let id = *shape_ids.entry(key).or_insert_with(|| {
                    shapes.push(shape);
                    shapes.len() as u32 - 1
                });
                let mut cv = [0u32; 4];
                for (slot, l) in cv.iter_mut().zip(c.iter()).take(dim + 1) {
                    *slot = inv[vs[*l] as usize];
                }
                if dim == 2 {
                    cv[3] = cv[0];
                }
                corners.push(cv);
                corner_element.push(new_e as u32);
                corner_shape.push(id);
                corner_weight.push(1.0 / (ne as f64 * used.len() as f64));
            }
            elem_pairs.extend(vs.iter().map(|&v| (new_e as u32, inv[v as usize])));
        }
        let elements = Csr::from_pairs(ne, elem_pairs.into_iter());
        let n = mesh.num_points();
        let incidence = Csr::from_pairs(
            n,
            corners
                .iter()
                .enumerate()
                .flat_map(|(c, t)| (0..=dim).map(move |k| (t[k], 4 * c as u32 + k as u32))),
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
        let vertex_elements = Csr::from_pairs(
            n,
            (0..ne)
                .flat_map(|e| elements.of(e).iter().map(move |&v| (v, e as u32)))
                .collect::<Vec<_>>()
                .into_iter(),
        );
        let colors = color::greedy(&free_vertices, n, |v| {
            vertex_elements
                .of(v)
                .iter()
                .flat_map(|&e| elements.of(e as usize).iter().copied())
        });
        Ok(Problem {
            dim,
            order,
            elem_order,
            elements,
            corners,
            corner_element,
            corner_shape,
            corner_weight,
            shapes,
            model: Model {
                metric: opts.metric,
                template: opts.template,
            },
            incidence,
            neighbours,
            free,
            free_vertices,
            colors,
            setup_time: start.elapsed(),
        })
    }

    /// Bytes held by the problem's arrays.
    pub fn bytes(&self) -> usize {
        let csr = |c: &Csr| 4 * (c.offsets.len() + c.items.len());
        4 * (self.order.len() + self.elem_order.len() + self.free_vertices.len())
            + (16 + 4 + 4 + 8) * self.corners.len()
            + std::mem::size_of::<CornerShape>() * self.shapes.len()
            + self.free.len()
            + csr(&self.elements)
            + csr(&self.incidence)
            + csr(&self.neighbours)
            + csr(&self.colors)
    }

    pub fn num_vertices(&self) -> usize {
        self.order.len()
    }

    pub fn num_elements(&self) -> usize {
        self.elem_order.len()
    }

    pub fn num_corners(&self) -> usize {
        self.corners.len()
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
    pub fn corner_points(&self, x: &[Vec3], c: usize) -> [Vec3; 4] {
        let t = &self.corners[c];
        [x[t[0] as usize], x[t[1] as usize], x[t[2] as usize], x[t[3] as usize]]
    }

    #[inline]
    pub fn shape(&self, c: usize) -> &CornerShape {
        &self.shapes[self.corner_shape[c] as usize]
    }

    /// Weighted objective term of corner `c` at `x`; `None` if inverted.
    #[inline]
    pub fn corner_term(&self, x: &[Vec3], c: usize) -> Option<f64> {
        Some(self.corner_weight[c] * self.model.value(self.shape(c), &self.corner_points(x, c))?)
    }

    /// Mean edge length, the length scale for displacement comparisons.
    pub fn mean_edge_length(&self, x: &[Vec3]) -> f64 {
        let (mut sum, mut count) = (0.0, 0usize);
        for v in 0..self.num_vertices() {
            for &w in self.neighbours.of(v) {
                if (w as usize) > v {
                    sum += sub(&x[v], &x[w as usize]).iter().map(|c| c * c).sum::<f64>().sqrt();
                    count += 1;
                }
            }
        }
        sum / count.max(1) as f64
    }

    /// Element ids (mesh numbering) with an inverted or degenerate corner at `x`.
    pub fn infeasible_elements(&self, x: &[Vec3]) -> Vec<usize> {
        let mut bad: Vec<usize> = (0..self.num_corners())
            .filter(|&c| self.corner_term(x, c).is_none())
            .map(|c| self.elem_order[self.corner_element[c] as usize] as usize)
            .collect();
        bad.sort_unstable();
        bad.dedup();
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

/// A reference mesh must match the mesh vertex for vertex and element for element.
fn check_same_connectivity(mesh: &Mesh, r: &Mesh) -> Result<()> {
    if r.num_points() != mesh.num_points() {
        return Err(Error::InvalidArgument(format!(
            "reference mesh has {} vertices, the mesh {}",
            r.num_points(),
            mesh.num_points()
        )));
    }
    if r.num_elements() != mesh.num_elements() {
        return Err(Error::InvalidArgument(format!(
            "reference mesh has {} elements, the mesh {}",
            r.num_elements(),
            mesh.num_elements()
        )));
    }
    for e in 0..mesh.num_elements() {
        if r.kinds[e] != mesh.kinds[e] || r.element(e) != mesh.element(e) {
            return Err(Error::InvalidArgument(format!(
                "reference mesh differs at element {e}: {} {:?} in the mesh, {} {:?} in the reference",
                mesh.kinds[e],
                mesh.element(e),
                r.kinds[e],
                r.element(e)
            )));
        }
    }
    Ok(())
}
