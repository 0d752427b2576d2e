//! The plane a planar mesh lies in. Planar meshes are optimised in the 2D
//! coordinates of their plane: a mesh in the plane z = constant as it is
//! (mirrored when wound clockwise, `metric::oriented`), any other plane —
//! the xz plane, a tilted one — through right-handed axes (e1, e2, n) with
//! the normal n oriented along the elements' own, so that they wind
//! counterclockwise in (e1, e2). Points map back onto the plane; a plane
//! through two axes maps back exactly (its constant coordinate keeps its bits).

use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::mesh::frame::{bounding_box, box_center};
use crate::metric::mat3::cross;
use crate::metric::mat3::{Vec3, dot, sub};
use std::borrow::Cow;

/// Largest distance from the fitted plane, relative to the mesh's extent,
/// that still counts as planar (six significant digits in a file, as VTK's
/// ASCII float output has, stay well within it).
pub const PLANARITY_TOLERANCE: f64 = 1e-5;

/// The plane a planar mesh lies in, with an orthonormal frame.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Plane {
    /// A point of the plane.
    pub origin: Vec3,
    /// e1, e2 (in the plane) and the unit normal n = e1 x e2.
    pub axes: [Vec3; 3],
}

fn unit(a: Vec3) -> Vec3 {
    let n = dot(&a, &a).sqrt();
    a.map(|c| c / n)
}

impl Plane {
    /// The plane of a planar mesh at `points`: `None` for a volume mesh and
    /// for one in a plane z = constant (used as it is); an error naming the
    /// farthest vertex for a planar mesh that is not flat.
    pub fn fit(mesh: &Mesh, points: &[Vec3]) -> Result<Option<Plane>> {
        let Some(fit) = Self::best(mesh, points)? else {
            return Ok(None);
        };
        let (plane, far, dist, extent) = (fit.plane, fit.farthest, fit.distance, fit.extent);
        if dist > PLANARITY_TOLERANCE * extent {
            return Err(Error::Unsupported(format!(
                "planar mesh is not flat: vertex {far} lies {dist:e} off the best-fitting plane \
                 (normal ({:.6}, {:.6}, {:.6})), more than {PLANARITY_TOLERANCE:e} of the mesh's extent {extent:e}",
                plane.axes[2][0], plane.axes[2][1], plane.axes[2][2]
            )));
        }
        Ok(Some(plane))
    }

    /// The best-fitting plane of a mesh of 2D elements and its farthest
    /// vertex; `None` for a volume mesh and one in a plane z = constant.
    fn best(mesh: &Mesh, points: &[Vec3]) -> Result<Option<Fit>> {
        if mesh.dim() != 2 || points.is_empty() {
            return Ok(None);
        }
        let z = points[0][2];
        if points.iter().all(|p| p[2] == z) {
            return Ok(None);
        }
        // Newell's normal of every element, summed: the elements' own orientation
        let mut n = [0.0; 3];
        for e in 0..mesh.num_elements() {
            let vs = mesh.element(e);
            for (i, &a) in vs.iter().enumerate() {
                let (p, q) = (points[a as usize], points[vs[(i + 1) % vs.len()] as usize]);
                n[0] += (p[1] - q[1]) * (p[2] + q[2]);
                n[1] += (p[2] - q[2]) * (p[0] + q[0]);
                n[2] += (p[0] - q[0]) * (p[1] + q[1]);
            }
        }
        if !(dot(&n, &n) > 0.0) {
            return Err(Error::InvalidMesh(
                "planar mesh has no area: its elements do not span a plane".into(),
            ));
        }
        let (lo, hi) = bounding_box(points);
        let origin = box_center(&lo, &hi);
        let n = unit(n);
        let axes = match (0..3).find(|&k| n[k].abs() > 1.0 - 1e-12) {
            // a plane through two axes: exact axes, so its constant coordinate survives
            Some(k) => {
                let s = n[k].signum();
                let mut e = [[0.0; 3]; 3];
                e[0][(k + 1) % 3] = 1.0;
                e[1][(k + 2) % 3] = s;
                e[2][k] = s;
                e
            }
            None => axes_with_normal(&n),
        };
        let plane = Plane { origin, axes };
        let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        let (far, dist) = points
            .iter()
            .map(|p| dot(&sub(p, &origin), &plane.axes[2]).abs())
            .enumerate()
            .fold((0, 0.0f64), |m, (v, d)| if d > m.1 { (v, d) } else { m });
        Ok(Some(Fit {
            plane,
            farthest: far,
            distance: dist,
            extent,
        }))
    }

    /// In-plane coordinates (u, v, 0).
    pub fn to_plane(&self, p: &Vec3) -> Vec3 {
        let d = sub(p, &self.origin);
        [dot(&d, &self.axes[0]), dot(&d, &self.axes[1]), 0.0]
    }

    /// The point of the plane at in-plane coordinates (u, v).
    pub fn from_plane(&self, q: &Vec3) -> Vec3 {
        let [e1, e2, _] = &self.axes;
        std::array::from_fn(|k| self.origin[k] + q[0] * e1[k] + q[1] * e2[k])
    }
}

/// Right-handed orthonormal axes (e1, e2, n) for the unit normal `n`: e1
/// along the coordinate axis least aligned with n, projected into the plane.
pub fn axes_with_normal(n: &Vec3) -> [Vec3; 3] {
    let k = (0..3).min_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs())).unwrap();
    let mut a = [0.0; 3];
    a[k] = 1.0;
    let e1 = unit(sub(&a, &n.map(|c| c * n[k])));
    [e1, cross(n, &e1), *n]
}

/// A fitted plane and how far the mesh is from it.
struct Fit {
    plane: Plane,
    farthest: usize,
    distance: f64,
    extent: f64,
}

/// Whether `mesh` is a surface mesh at `points`: its elements are triangles
/// and quadrilaterals that do not lie in one plane (beyond
/// [`PLANARITY_TOLERANCE`]). Such a mesh is optimised in 3D, each element in
/// its own tangent plane, every vertex sliding on the surface.
pub fn is_surface(mesh: &Mesh, points: &[Vec3]) -> bool {
    match Plane::best(mesh, points) {
        Ok(Some(f)) => f.distance > PLANARITY_TOLERANCE * f.extent,
        Ok(None) => false,
        Err(_) => mesh.dim() == 2 && spans_space(points),
    }
}

/// Points that do not all lie on one plane through the first three (a
/// closed surface has a Newell normal of zero, so it fits no plane at all).
fn spans_space(points: &[Vec3]) -> bool {
    let (lo, hi) = bounding_box(points);
    (0..3).filter(|&k| hi[k] > lo[k]).count() == 3
}

/// `points` in the plane's coordinates when a plane was fitted, else as they are.
pub fn in_plane<'a>(plane: Option<&Plane>, points: &'a [Vec3]) -> Cow<'a, [Vec3]> {
    match plane {
        Some(pl) => Cow::Owned(points.iter().map(|p| pl.to_plane(p)).collect()),
        None => Cow::Borrowed(points),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate;

    fn rotated(m: &Mesh, f: impl Fn(&Vec3) -> Vec3) -> Mesh {
        Mesh {
            points: m.points.iter().map(f).collect(),
            ..m.clone()
        }
    }

    #[test]
    fn planes_are_fitted_oriented_and_mapped_back() {
        let grid = generate::tri_grid(4, 3, [4.0, 3.0]);
        assert_eq!(Plane::fit(&grid, &grid.points).unwrap(), None);
        // the xz plane, both windings: exact axes, y keeps its bits
        for (name, m) in [
            ("xz", rotated(&grid, |p| [p[0], 0.1, p[1]])),
            ("xz mirrored", rotated(&grid, |p| [p[1], 0.1, p[0]])),
        ] {
            let pl = Plane::fit(&m, &m.points).unwrap().expect(name);
            assert_eq!(pl.axes[2].iter().filter(|c| c.abs() == 1.0).count(), 1, "{name}");
            let flat = in_plane(Some(&pl), &m.points);
            assert!(
                crate::metric::inverted_elements(&grid, &flat).is_empty(),
                "{name}: counterclockwise"
            );
            for (p, q) in m.points.iter().zip(flat.iter()) {
                let back = pl.from_plane(q);
                assert_eq!(back[1], 0.1, "{name}");
                assert!((0..3).all(|k| (back[k] - p[k]).abs() < 1e-15), "{name}");
            }
        }
        // a tilted plane: mapped back onto itself, with the same shape
        let (c, s) = (0.6f64, 0.8f64);
        let tilted = rotated(&grid, |p| [p[0], c * p[1], s * p[1] + 7.0]);
        let pl = Plane::fit(&tilted, &tilted.points).unwrap().unwrap();
        assert!(
            (pl.axes[2][0]).abs() < 1e-15 && (pl.axes[2][1] + s).abs() < 1e-15 && (pl.axes[2][2] - c).abs() < 1e-15
        );
        let flat = in_plane(Some(&pl), &tilted.points);
        for e in 0..grid.num_elements() {
            let a = crate::metric::element_eta(&grid, &grid.points, e).unwrap();
            let b = crate::metric::element_eta(&grid, &flat, e).unwrap();
            assert!((a - b).abs() < 1e-12 * a, "element {e}: {a} vs {b}");
        }
        // not flat: refused with the farthest vertex
        let mut bent = tilted.clone();
        bent.points[5][0] += 0.1;
        bent.points[5][2] += 0.3;
        let e = Plane::fit(&bent, &bent.points).unwrap_err().to_string();
        assert!(e.contains("not flat") && e.contains("vertex"), "{e}");
    }
}
