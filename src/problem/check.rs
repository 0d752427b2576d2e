//! Stage 1, check: the mesh has elements, a planar mesh is flat, and the
//! options fit each other and the mesh.

use super::ProblemOptions;
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::mesh::plane::Plane;
use crate::metric::corner_model::Template;
use crate::metric::mat3::Vec3;
use crate::metric::smetric::MetricKind;

/// Refuses what no later stage can build from; `points` are the positions
/// the problem is built at (the mesh's own, or a report's). Returns the plane
/// of a planar mesh outside the planes z = constant, which the later stages
/// work in.
pub fn check(mesh: &Mesh, points: &[Vec3], opts: &ProblemOptions) -> Result<Option<Plane>> {
    if mesh.num_elements() == 0 {
        return Err(Error::InvalidMesh("mesh has no elements".into()));
    }
    // a planar mesh must be flat (in any plane); one that is not is a surface
    if crate::mesh::plane::is_surface(mesh, points) {
        opts.check(mesh)?;
        opts.check_surface()?;
        return Ok(None);
    }
    let plane = Plane::fit(mesh, points)?;
    opts.check(mesh)?;
    Ok(plane)
}

impl ProblemOptions<'_> {
    /// What a surface mesh can be smoothed with: each element is measured in
    /// its own tangent plane against the ideal element of its kind, by a
    /// metric of its size-free shape.
    pub fn check_surface(&self) -> Result<()> {
        if !crate::metric::surface::supports(self.metric) {
            return Err(Error::Unsupported(format!(
                "a surface mesh is measured with the inverse mean ratio (imr) or the condition number (cn), not {}",
                self.metric
            )));
        }
        if self.reference.is_some() || self.target.is_constructed() {
            return Err(Error::Unsupported(
                "a surface mesh is smoothed toward ideal elements: reference meshes and constructed targets are for planar and volume meshes"
                    .into(),
            ));
        }
        Ok(())
    }

    /// The options' own consistency and the reference's fit to `mesh`, without
    /// building anything: callers can refuse bad input before any work.
    pub fn check(&self, mesh: &Mesh) -> Result<()> {
        if self.metric == MetricKind::TargetShapeSize && self.reference.is_none() && !self.target.is_constructed() {
            return Err(Error::InvalidArgument(
                "the target-matrix metric (tmp) needs a reference mesh for its targets W".into(),
            ));
        }
        if self.metric == MetricKind::TargetShapeSize && self.template == Template::Average {
            return Err(Error::InvalidArgument(
                "the average template needs a quality in (0, 1] (imr, cn); use the harmonic template with tmp".into(),
            ));
        }
        if self.target.is_constructed() && self.reference.is_some() {
            return Err(Error::InvalidArgument(format!(
                "targets come either from a reference mesh or from '{}', not both",
                self.target.name()
            )));
        }
        if self.target.is_constructed() && self.metric.every_corner() {
            return Err(Error::InvalidArgument(format!(
                "the {} metric measures every corner against the octant corner and takes no targets",
                self.metric
            )));
        }
        if self.metric == MetricKind::ShapeSize && !self.target.is_constructed() && self.reference.is_none() {
            return Err(Error::InvalidArgument(
                "the shape+size metric needs targets with a size: input, size:FIELD, metric:FIELD or a reference mesh"
                    .into(),
            ));
        }
        match self.reference {
            Some(r) => check_same_connectivity(mesh, r),
            None => Ok(()),
        }
    }
}

/// A reference mesh must match the mesh vertex for vertex and element for element.
fn check_same_connectivity(mesh: &Mesh, r: &Mesh) -> Result<()> {
    same_connectivity(mesh, r, "reference mesh", "the reference")
}

/// Whether `other` (named `what` in a sentence, `short` after "in") matches
/// `mesh` vertex for vertex and element for element; the error names the
/// first difference.
pub fn same_connectivity(mesh: &Mesh, other: &Mesh, what: &str, short: &str) -> Result<()> {
    if other.num_points() != mesh.num_points() {
        return Err(Error::InvalidArgument(format!(
            "{what} has {} vertices, the mesh {}",
            other.num_points(),
            mesh.num_points()
        )));
    }
    if other.num_elements() != mesh.num_elements() {
        return Err(Error::InvalidArgument(format!(
            "{what} has {} elements, the mesh {}",
            other.num_elements(),
            mesh.num_elements()
        )));
    }
    for e in 0..mesh.num_elements() {
        if other.kinds[e] != mesh.kinds[e]
            || other.element(e) != mesh.element(e)
            || !other.faces.of(e).eq(mesh.faces.of(e))
        {
            return Err(Error::InvalidArgument(format!(
                "{what} differs at element {e}: {} {:?} in the mesh, {} {:?} in {short}",
                mesh.kinds[e],
                mesh.element(e),
                other.kinds[e],
                other.element(e)
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate;

    #[test]
    fn check_takes_a_bent_planar_mesh_as_a_surface_and_refuses_a_mismatched_reference() {
        let mut m = generate::quad_grid(2, 2, [1.0, 1.0]);
        let opts = ProblemOptions::default();
        assert!(check(&m, &m.points, &opts).is_ok());
        let mut tilted = m.points.clone();
        tilted[4][2] = 0.5;
        // a bent one is a surface: no plane, and only what a surface takes
        assert_eq!(check(&m, &tilted, &opts).unwrap(), None);
        let tmp = ProblemOptions {
            metric: MetricKind::ShapeSize,
            target: crate::problem::Target::Input(Default::default()),
            ..Default::default()
        };
        let err = check(&m, &tilted, &tmp).unwrap_err().to_string();
        assert!(err.contains("surface mesh"), "{err}");
        let other = generate::quad_grid(3, 2, [1.0, 1.0]);
        let with_ref = ProblemOptions {
            reference: Some(&other),
            ..Default::default()
        };
        assert!(check(&m, &m.points, &with_ref).is_err());
        m.kinds.clear();
        m.offsets = vec![0];
        m.conn.clear();
        assert!(check(&m, &m.points, &opts).is_err());
    }
}
