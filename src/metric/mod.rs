//! Element quality metrics in f64: value, gradient and Hessian per element and
//! per vertex. Each file here is the CPU twin of a WGSL kernel in `shaders/metric/`.

pub mod corner;
pub mod corner_model;
pub mod mat3;
pub mod mean_ratio;
pub mod reference_jacobian;
pub mod smetric;

pub use mean_ratio::{TetShape, tet_det};

use crate::mesh::{ElementKind, Mesh};
use mat3::{Vec3, sub};

/// Smallest corner Jacobian determinant of an element (2D kinds use the xy
/// plane). An element is feasible when this is positive.
pub fn min_corner_det(kind: ElementKind, x: &[Vec3]) -> f64 {
    let mut min = f64::INFINITY;
    for c in kind.corners() {
        let o = &x[c[0]];
        let d = if kind.dim() == 2 {
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

/// Smallest corner determinant of element `e` of `mesh` at positions `points`.
pub fn element_min_det(mesh: &Mesh, points: &[Vec3], e: usize) -> f64 {
    let mut x = [[0.0; 3]; 8];
    let vs = mesh.element(e);
    for (slot, &v) in x.iter_mut().zip(vs) {
        *slot = points[v as usize];
    }
    min_corner_det(mesh.kinds[e], &x[..vs.len()])
}

/// Whether a planar mesh is wound clockwise (most of its elements have
/// negative corner determinants in the xy plane). Such meshes are fine: their
/// orientation is simply mirrored, and every check reads them mirrored.
pub fn is_clockwise(mesh: &Mesh, points: &[Vec3]) -> bool {
    mesh.dim() == 2 && {
        let negative = (0..mesh.num_elements())
            .filter(|&e| element_min_det(mesh, points, e) < 0.0)
            .count();
        2 * negative > mesh.num_elements()
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

/// Ids of elements with a non-positive corner determinant (against the
/// mesh's own orientation for planar meshes).
pub fn inverted_elements(mesh: &Mesh, points: &[Vec3]) -> Vec<usize> {
    let points = oriented(mesh, points);
    (0..mesh.num_elements())
        .filter(|&e| !(element_min_det(mesh, &points, e) > 0.0))
        .collect()
}

/// Inverse mean ratio of element `e` at `points`, `None` if it is inverted.
pub fn element_eta(mesh: &Mesh, points: &[Vec3], e: usize) -> Option<f64> {
    let mut x = [[0.0; 3]; 8];
    let vs = mesh.element(e);
    for (slot, &v) in x.iter_mut().zip(vs) {
        *slot = points[v as usize];
    }
    corner::element_eta(mesh.kinds[e], &x[..vs.len()])
}
