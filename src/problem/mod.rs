//! `Problem`: what a solver needs and nothing else — free-vertex flags,
//! element corners and adjacency in locality order, each corner's reference
//! (B = D W^-1), the metric and the template. Built once; solvers work in its
//! (reordered) numbering and the result is mapped back to the mesh's own.
//!
//! Every element is a list of corners: simplices one (their map from the
//! reference is affine, so every corner sees the same S), quadrilaterals,
//! hexahedra and prisms all of theirs ([`ElementKind::optimised_corners`]).
//! F = sum over corners of w_c m(S_c) with w_c = 1 / (|E| corners(e)): the
//! mean over elements of the mean corner term.
//!
//! Building is a pipeline of small stages, each in its own file and usable on
//! its own: [`check`](check()) (options, planarity, reference fit) →
//! [`order`](order()) (vertex and element numbering, by [`Ordering`]) →
//! [`corners`](corners()) (corners, shapes, weights) →
//! [`adjacency`](adjacency()) (elements, incidence, neighbours, free
//! vertices) → [`colours`]. Reports stop after `corners`, in the mesh's own numbering
//! ([`Numbering::identity`]).
//!
//! [`ElementKind::optimised_corners`]: crate::mesh::ElementKind::optimised_corners

mod adjacency;
pub mod boundary;
mod check;
mod corners;
pub mod geometry;
mod numbering;
pub mod targets;

#[cfg(feature = "mpi")]
pub(crate) use adjacency::sharing_neighbours;
pub use adjacency::{Adjacency, adjacency, colours};
pub use boundary::{Boundary, BoundaryMode, Sliding};
pub use check::{check, same_connectivity};
pub use corners::{Corners, corners, element_vertices};
pub use numbering::{MeshGraph, Numbering, order};
pub use targets::{InputTargets, Target};

use crate::error::{Error, Result};
use crate::mesh::Mesh;
pub use crate::mesh::order::Ordering;
use crate::mesh::plane::{Plane, in_plane};
use crate::mesh::topology::Csr;
use crate::metric::corner_model::{CornerShape, Model, Template};
use crate::metric::mat3::{Vec3, sub};
use crate::metric::smetric::MetricKind;
use std::time::{Duration, Instant};

/// What to optimise.
#[derive(Clone, Copy, Debug, Default)]
#[non_exhaustive]
pub struct ProblemOptions<'a> {
    /// The corner metric.
    pub metric: MetricKind,
    /// How corner values combine into the objective.
    pub template: Template,
    /// A mesh with the same connectivity whose corners are the targets W
    /// (required by `tmp`; optional for the others, which default to the ideal
    /// element of each kind).
    pub reference: Option<&'a Mesh>,
    /// The vertex order the problem is built (and swept) in; a paper scheme
    /// ([`Ordering::Sweep`]) keeps the input numbering and orders the
    /// sequential sweep's list instead.
    pub ordering: Ordering,
    /// Seed of the random scheme (R, -R).
    pub order_seed: u64,
    /// Fixed boundary (the default) or sliding on it.
    pub boundary: Boundary,
    /// Constructed targets W (`reference` is the other way to give them).
    pub target: Target<'a>,
    /// The length the problem's coordinates are in, in the mesh's units (the
    /// solve's frame: `Frame::scale`); size and metric fields are divided by
    /// it. 0 means 1.
    pub length_unit: f64,
    /// A geometry the sliding skin vertices stay on instead of the mesh's
    /// own skin (a surface, or a volume mesh whose skin is used), in the
    /// mesh's coordinates; it makes the boundary slide (`geometry`).
    pub surface: Option<&'a Mesh>,
}

impl<'a> ProblemOptions<'a> {
    /// These options with the default target ([`Target::Auto`]) decided for
    /// `mesh`, and a line for the user where that decision keeps the input's
    /// stretching. Input targets (with the shape+size metric, which keeps the
    /// targets' sizes) are chosen when the metric is the default inverse
    /// mean ratio, no reference mesh is given, no element is inverted or a
    /// polyhedron, and the mesh's [`Intent`](targets::Intent) shows a
    /// boundary layer or wall grading; otherwise the ideal objective, as
    /// before. Anything but `Auto` is returned as it is.
    pub fn resolved(&self, mesh: &Mesh) -> crate::error::Result<(ProblemOptions<'a>, Option<String>)> {
        self.resolved_with(mesh, None)
    }

    /// [`ProblemOptions::resolved`] given the mesh's inverted elements
    /// (`metric::inverted_elements`) when the caller has them already.
    pub(crate) fn resolved_with(
        &self,
        mesh: &Mesh,
        inverted: Option<&[usize]>,
    ) -> crate::error::Result<(ProblemOptions<'a>, Option<String>)> {
        // only wanted once the cheaper tests have passed
        let tangled = || match inverted {
            Some(bad) => !bad.is_empty(),
            None => !crate::metric::inverted_elements(mesh, &mesh.points).is_empty(),
        };
        let ideal = ProblemOptions {
            target: Target::Ideal,
            ..*self
        };
        if self.target != Target::Auto {
            return Ok((*self, None));
        }
        if self.metric != MetricKind::InverseMeanRatio
            || self.reference.is_some()
            || crate::mesh::plane::is_surface(mesh, &mesh.points)
            || mesh.kinds.contains(&crate::mesh::ElementKind::Polyhedron)
            || tangled()
        {
            return Ok((ideal, None));
        }
        let shapes = targets::Shapes::of(mesh, &mesh.points)?;
        if shapes.raw_share(mesh.dim()) < targets::ANISOTROPIC_SHARE {
            return Ok((ideal, None));
        }
        let intent = targets::intent_of(mesh, &shapes);
        if !intent.keeps_input() {
            return Ok((ideal, None));
        }
        let input = ProblemOptions {
            target: Target::Input(InputTargets::default()),
            metric: MetricKind::ShapeSize,
            ..*self
        };
        if input.check(mesh).is_err() {
            return Ok((ideal, None));
        }
        let note = format!(
            "targets: input (the mesh's own sizes and stretching, regularised) with the shape-size metric, since {}; ask for the ideal shape with target ideal",
            intent.describe()
        );
        Ok((input, Some(note)))
    }
}

/// A mesh set up for the solvers: renumbered vertices and elements, corners, references, adjacency and colours.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
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
    /// Metric, template and regularisation of the objective.
    pub model: Model,
    /// Per vertex (new numbering): incident corners packed as `4 * corner + local slot`.
    pub incidence: Csr,
    /// Per vertex: its edge neighbours (new numbering).
    pub neighbours: Csr,
    /// Every element a simplex, and every element around each vertex here:
    /// the vertices sharing a corner with a vertex are then exactly its
    /// edge neighbours. A part restricted from a whole problem says `false`
    /// (an edge's elements may lie on another part).
    #[serde(default)]
    pub simplicial: bool,
    /// Per vertex: may it move?
    pub free: Vec<bool>,
    /// Free vertices in sweep order (ascending new ids).
    pub free_vertices: Vec<u32>,
    /// Colour classes of the free vertices: no two vertices of a class share an
    /// element. Each class is in sweep order.
    pub colors: Csr,
    /// A surface mesh: its elements are measured in their own tangent planes
    /// (`metric::surface`) and its vertices slide on the surface.
    #[serde(default)]
    pub surface_mesh: bool,
    /// The plane of a planar mesh outside the planes z = constant: positions
    /// are in its coordinates (`gather` maps into them, `scatter` back).
    pub plane: Option<Plane>,
    /// The constraints of the boundary vertices that slide (`--boundary slide`).
    pub sliding: Option<Sliding>,
    /// The paper scheme that orders the sequential sweep's list (`None`:
    /// the sweep follows the numbering).
    #[serde(skip)]
    pub sweep_order: Option<crate::mesh::sweep_order::SweepOrder>,
    /// Seed of the random schemes.
    pub order_seed: u64,
    /// Time spent building this problem.
    pub setup_time: Duration,
}

impl Problem {
    /// The inverse mean ratio, harmonic template, ideal references.
    pub fn new(mesh: &Mesh) -> Result<Problem> {
        Self::with_options(mesh, &ProblemOptions::default())
    }

    /// check → order → corners → adjacency → colours.
    pub fn with_options(mesh: &Mesh, opts: &ProblemOptions) -> Result<Problem> {
        let start = Instant::now();
        let plane = check(mesh, &mesh.points, opts)?;
        let points = in_plane(plane.as_ref(), &mesh.points);
        let mut graph = MeshGraph::of(mesh);
        let skin = boundary::skin_classes(mesh, &points, opts)?;
        // a sliding vertex is free unless the user fixed it
        let slides = |v: usize| {
            skin.as_ref()
                .is_some_and(|s| !s.candidates.of(v).is_empty() && !mesh.is_fixed(v))
        };
        // a surface mesh's vertices move only on the surface: one that does
        // not slide (a corner, a kept boundary curve) stays
        let surface_mesh = plane.is_none() && crate::mesh::plane::is_surface(mesh, &points);
        for (v, f) in graph.fixed.iter_mut().enumerate() {
            *f = if surface_mesh { !slides(v) } else { *f && !slides(v) };
        }
        let numbering = order(mesh, &graph, opts.ordering);
        let corners = corners(mesh, &points, opts, &numbering)?;
        let adj = adjacency(mesh, &graph, &numbering, &corners);
        let colors = colours(&adj);
        let sliding = skin.as_ref().map(|s| s.renumber(&numbering, slides));
        Ok(Problem {
            dim: corners.dim,
            surface_mesh: corners.surface,
            order: numbering.order,
            elem_order: numbering.elem_order,
            elements: adj.elements,
            corners: corners.corners,
            corner_element: corners.corner_element,
            corner_shape: corners.corner_shape,
            corner_weight: corners.corner_weight,
            shapes: corners.shapes,
            model: Model {
                metric: opts.metric,
                template: opts.template,
                eps: 0.0,
            },
            incidence: adj.incidence,
            neighbours: adj.neighbours,
            simplicial: adj.simplicial,
            free: adj.free,
            free_vertices: adj.free_vertices,
            colors,
            plane,
            sliding,
            sweep_order: opts.ordering.sweep(),
            order_seed: opts.order_seed,
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
            + self.sliding.as_ref().map_or(0, |s| s.bytes())
    }

    /// Only x and y move: a planar problem (the z rows of every block are
    /// the identity and its gradients' z are zero).
    #[inline]
    pub fn in_plane(&self) -> bool {
        self.dim == 2 && !self.surface_mesh
    }

    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        self.order.len()
    }

    /// Number of elements.
    pub fn num_elements(&self) -> usize {
        self.elem_order.len()
    }

    /// Number of corners.
    pub fn num_corners(&self) -> usize {
        self.corners.len()
    }

    /// Mesh positions gathered into the problem's numbering.
    pub fn gather(&self, points: &[Vec3]) -> Vec<Vec3> {
        let points = in_plane(self.plane.as_ref(), points);
        self.order.iter().map(|&o| points[o as usize]).collect()
    }

    /// Problem positions scattered back to the mesh numbering.
    pub fn scatter(&self, x: &[Vec3]) -> Vec<Vec3> {
        let mut out = vec![[0.0; 3]; x.len()];
        for (new, &old) in self.order.iter().enumerate() {
            out[old as usize] = match &self.plane {
                Some(pl) => pl.from_plane(&x[new]),
                None => x[new],
            };
        }
        out
    }

    /// The positions of corner `c`'s four vertices (corner first).
    #[inline]
    pub fn corner_points(&self, x: &[Vec3], c: usize) -> [Vec3; 4] {
        let t = &self.corners[c];
        [x[t[0] as usize], x[t[1] as usize], x[t[2] as usize], x[t[3] as usize]]
    }

    /// The reference shape of corner `c`.
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
            Err(Error::inverted(bad))
        }
    }
}
