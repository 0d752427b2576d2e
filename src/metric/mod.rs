//! Element quality metrics in f64: value, gradient and Hessian per element and
//! per vertex. Each file here is the CPU twin of a WGSL kernel in `shaders/metric/`.

pub mod corner;
pub mod corner_model;
pub mod det_path;
pub mod inv_cbrt;
pub mod mat3;
pub mod mean_ratio;
pub mod planar;
pub mod reference_jacobian;
// Public only for the integration tests and benches: the symbolic Hessian internals.
#[doc(hidden)]
pub mod shess;
pub mod smetric;
pub mod surface;

pub use mean_ratio::{TetShape, tet_det};

use crate::mesh::{ElementKind, Mesh};
use mat3::{Vec3, sub};

/// Smallest corner Jacobian determinant of an element (2D kinds use the xy
/// plane). An element is feasible when this is positive.
pub fn min_corner_det(kind: ElementKind, x: &[Vec3]) -> f64 {
    corners_min_det(kind.dim(), kind.corners(), x)
}

/// Smallest determinant over `corners` (local indices into `x`) in dimension `dim`.
pub fn corners_min_det(dim: usize, corners: &[[usize; 4]], x: &[Vec3]) -> f64 {
    let mut min = f64::INFINITY;
    for c in corners {
        let o = &x[c[0]];
        let d = if dim == 2 {
            let a = sub(&x[c[1]], o);
            let b = sub(&x[c[2]], o);
            a[0] * b[1] - a[1] * b[0]
        } else {
            let (a, b, e) = (sub(&x[c[1]], o), sub(&x[c[2]], o), sub(&x[c[3]], o));
            mat3::det(&[[a[0], b[0], e[0]], [a[1], b[1], e[1]], [a[2], b[2], e[2]]])
        };
        min = min.min(d);
    }
    min
}

/// Smallest corner determinant of element `e` of `mesh` at positions
/// `points`; -inf for a polyhedron without valid corners (see
/// [`Mesh::element_corners`]).
pub fn element_min_det(mesh: &Mesh, points: &[Vec3], e: usize) -> f64 {
    let kind = mesh.kinds[e];
    if kind == ElementKind::Polyhedron {
        let x: Vec<Vec3> = mesh.element(e).iter().map(|&v| points[v as usize]).collect();
        return match mesh.element_corners(e) {
            Ok(cs) => corners_min_det(3, &cs, &x),
            Err(_) => f64::NEG_INFINITY,
        };
    }
    let mut x = [[0.0; 3]; 8];
    let vs = mesh.element(e);
    for (slot, &v) in x.iter_mut().zip(vs) {
        *slot = points[v as usize];
    }
    min_corner_det(kind, &x[..vs.len()])
}

/// Whether a planar mesh is wound clockwise: the signed areas of its
/// elements in the xy plane sum to a negative number. Such meshes are fine:
/// their orientation is simply mirrored, and every check reads them mirrored.
/// The sum is the signed area the boundary encloses, which moving interior
/// vertices does not change, so a tangled mesh (even one with most elements
/// inverted) keeps the orientation of its boundary.
pub fn is_clockwise(mesh: &Mesh, points: &[Vec3]) -> bool {
    mesh.dim() == 2 && {
        let mut area = 0.0;
        for e in 0..mesh.num_elements() {
            let vs = mesh.element(e);
            for (i, &v) in vs.iter().enumerate() {
                let (p, q) = (points[v as usize], points[vs[(i + 1) % vs.len()] as usize]);
                area += p[0] * q[1] - q[0] * p[1];
            }
        }
        area < 0.0
    }
}

/// `points` as the checks and reports read them: a planar mesh in its
/// plane's 2D coordinates (`mesh::plane`), mirrored (y -> -y, exact) when it
/// lies in a plane z = constant wound clockwise, so that well-shaped elements
/// have positive corner determinants; shape metrics do not change under
/// either map.
pub fn oriented<'a>(mesh: &Mesh, points: &'a [Vec3]) -> std::borrow::Cow<'a, [Vec3]> {
    // a planar mesh outside the planes z = constant, in its plane's
    // coordinates (counterclockwise by construction); one that is not flat
    // is read as its xy projection here and refused by every solve
    if let Ok(Some(plane)) = crate::mesh::plane::Plane::fit(mesh, points) {
        return std::borrow::Cow::Owned(points.iter().map(|p| plane.to_plane(p)).collect());
    }
    if is_clockwise(mesh, points) {
        std::borrow::Cow::Owned(points.iter().map(|p| [p[0], -p[1], p[2]]).collect())
    } else {
        std::borrow::Cow::Borrowed(points)
    }
}

/// `points` scaled by a power of two (exactly, so no determinant changes
/// sign) to a unit-sized box where they span less than 1e-30 or more than
/// 1e30 (unchanged otherwise): a determinant of cubed lengths would
/// underflow or overflow there and read as degenerate.
pub fn near_unit(points: &[Vec3]) -> std::borrow::Cow<'_, [Vec3]> {
    let extent = (0..3)
        .map(|k| {
            let (lo, hi) = points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p[k]), hi.max(p[k]))
            });
            hi - lo
        })
        .fold(0.0, f64::max);
    if !(extent > 0.0 && extent.is_finite()) || (1e-30..=1e30).contains(&extent) {
        return std::borrow::Cow::Borrowed(points);
    }
    let scale = (-extent.log2().round()).exp2();
    std::borrow::Cow::Owned(points.iter().map(|p| p.map(|x| x * scale)).collect())
}

/// `Error::Inverted` when `mesh` has an inverted element at its own points.
pub fn refuse_inverted(mesh: &Mesh) -> crate::error::Result<()> {
    let bad = inverted_elements(mesh, &mesh.points);
    if bad.is_empty() {
        Ok(())
    } else {
        Err(crate::error::Error::inverted(bad))
    }
}

/// Ids of elements with a non-positive corner determinant (against the
/// mesh's own orientation for planar meshes, against each element's own
/// normal on a surface mesh).
pub fn inverted_elements(mesh: &Mesh, points: &[Vec3]) -> Vec<usize> {
    let measured = Measured::new(mesh, points);
    (0..mesh.num_elements())
        .filter(|&e| !(measured.min_det(mesh, e) > 0.0))
        .collect()
}

/// Elements as the checks and reports measure them: a planar mesh
/// [`oriented`], a surface mesh's element each in its own tangent plane
/// (axes from its Newell normal), all at a size whose determinants neither
/// underflow nor overflow ([`near_unit`]).
pub struct Measured<'a> {
    points: std::borrow::Cow<'a, [Vec3]>,
    surface: bool,
}

impl<'a> Measured<'a> {
    /// `mesh` at `points`, read for measuring.
    pub fn new(mesh: &Mesh, points: &'a [Vec3]) -> Measured<'a> {
        let surface = crate::mesh::plane::is_surface(mesh, points);
        let read = if surface {
            std::borrow::Cow::Borrowed(points)
        } else {
            oriented(mesh, points)
        };
        let scaled = match near_unit(&read) {
            std::borrow::Cow::Owned(v) => Some(v),
            std::borrow::Cow::Borrowed(_) => None,
        };
        Measured {
            points: scaled.map_or(read, std::borrow::Cow::Owned),
            surface,
        }
    }

    /// Whether the mesh is measured as a surface.
    pub fn is_surface(&self) -> bool {
        self.surface
    }

    /// The points measured (oriented and scaled).
    pub fn points(&self) -> &[Vec3] {
        &self.points
    }

    /// A surface element's vertices in its own tangent frame; `None` for a
    /// degenerate one.
    fn in_frame(&self, mesh: &Mesh, e: usize) -> Option<([Vec3; 8], usize)> {
        let vs = mesh.element(e);
        let normal = surface::element_normal(&self.points, vs)?;
        let axes = crate::mesh::plane::axes_with_normal(&normal);
        let o = self.points[vs[0] as usize];
        let mut x = [[0.0; 3]; 8];
        for (slot, &v) in x.iter_mut().zip(vs) {
            let d = sub(&self.points[v as usize], &o);
            *slot = std::array::from_fn(|i| mat3::dot(&axes[i], &d));
        }
        Some((x, vs.len()))
    }

    /// Smallest corner determinant of element `e` (positive when feasible).
    pub fn min_det(&self, mesh: &Mesh, e: usize) -> f64 {
        if !self.surface {
            return element_min_det(mesh, &self.points, e);
        }
        match self.in_frame(mesh, e) {
            Some((x, n)) => min_corner_det(mesh.kinds[e], &x[..n]),
            None => f64::NEG_INFINITY,
        }
    }

    /// Inverse mean ratio of element `e`; `None` if it is inverted.
    pub fn eta(&self, mesh: &Mesh, e: usize) -> Option<f64> {
        if !self.surface {
            return element_eta(mesh, &self.points, e);
        }
        let (x, n) = self.in_frame(mesh, e)?;
        corner::element_eta(mesh.kinds[e], &x[..n])
    }
}

/// Inverse mean ratio of element `e` at `points`, `None` if it is inverted.
pub fn element_eta(mesh: &Mesh, points: &[Vec3], e: usize) -> Option<f64> {
    let kind = mesh.kinds[e];
    if kind == ElementKind::Polyhedron {
        let x: Vec<Vec3> = mesh.element(e).iter().map(|&v| points[v as usize]).collect();
        let cs = mesh.optimised_corners(e).ok()?;
        return corner::corners_eta(kind, &cs, &x);
    }
    let mut x = [[0.0; 3]; 8];
    let vs = mesh.element(e);
    for (slot, &v) in x.iter_mut().zip(vs) {
        *slot = points[v as usize];
    }
    corner::element_eta(mesh.kinds[e], &x[..vs.len()])
}
