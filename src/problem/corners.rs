//! Stage 3, corners: each element's optimised corners (see
//! [`ElementKind::optimised_corners`]) with their vertices, their reference
//! shapes B = D W^-1 and their weights in F. This stage alone is enough to
//! evaluate a metric per element, which is how the reports use it.

use super::ProblemOptions;
use super::numbering::Numbering;
use crate::error::{Error, Result};
use crate::mesh::plane::{Plane, in_plane};
use crate::mesh::{ElementKind, Mesh};
use crate::metric::corner::ideal_corner;
use crate::metric::corner_model::{CornerShape, Model};
use crate::metric::mat3::{Mat3, Vec3, sub};
use std::collections::HashMap;

/// The corners of every element, in a [`Numbering`].
#[derive(Clone, Debug)]
pub struct Corners {
    /// Metric dimension: 2 or 3.
    pub dim: usize,
    /// Planar mesh wound clockwise: elements are read in mirrored order.
    pub flip: bool,
    /// The corner vertex, then its `dim` neighbours (a 2D corner repeats its
    /// vertex in the unused fourth slot, whose B row is zero).
    pub corners: Vec<[u32; 4]>,
    /// Element of each corner.
    pub corner_element: Vec<u32>,
    /// Index into `shapes` for each corner.
    pub corner_shape: Vec<u32>,
    /// Weight of each corner in F: 1 / (elements x the element's corners).
    pub corner_weight: Vec<f64>,
    /// Distinct corner references.
    pub shapes: Vec<CornerShape>,
}

/// Element `e`'s vertices as the problem reads them: reversed for planar
/// meshes wound clockwise.
pub fn element_vertices(mesh: &Mesh, e: usize, flip: bool) -> Vec<u32> {
    let vs = mesh.element(e);
    match (flip, mesh.kinds[e]) {
        (true, ElementKind::Triangle) => vec![vs[0], vs[2], vs[1]],
        (true, ElementKind::Quadrilateral) => vec![vs[0], vs[3], vs[2], vs[1]],
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

/// The corners of `mesh` with its vertices at `points` (which decide the
/// orientation of a planar mesh), elements and vertices in `numbering`.
/// Fails on a reference element that is inverted or degenerate.
pub fn corners(mesh: &Mesh, points: &[Vec3], opts: &ProblemOptions, numbering: &Numbering) -> Result<Corners> {
    let dim = mesh.dim();
    // planar meshes wound clockwise are optimised in mirrored order
    let flip = crate::metric::is_clockwise(mesh, points);
    let ne = numbering.elem_order.len();
    let inv = &numbering.inv;
    let mut out = Corners {
        dim,
        flip,
        corners: Vec::new(),
        corner_element: Vec::new(),
        corner_shape: Vec::new(),
        corner_weight: Vec::new(),
        shapes: Vec::new(),
    };
    let mut shape_ids: HashMap<[u64; 12], u32> = HashMap::new();
    // a planar reference in its own plane's coordinates, as the mesh is in its
    let reference = match opts.reference {
        Some(r) => Some((r, in_plane(Plane::fit(r, &r.points)?.as_ref(), &r.points))),
        None => None,
    };
    // the rezoning paper's metrics: every corner against the octant corner,
    // each weighted 1 / (corners in the mesh)
    let every = opts.metric.every_corner();
    let used_by = |e: usize| {
        if every {
            mesh.element_corners(e)
        } else {
            mesh.optimised_corners(e)
        }
    };
    // (an element whose corners are refused is reported in the loop below)
    let total: usize = (0..mesh.num_elements())
        .map(|e| used_by(e).map_or(0, |c| c.len()))
        .sum();
    const OCTANT: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for (new_e, &old_e) in numbering.elem_order.iter().enumerate() {
        let old_e = old_e as usize;
        let kind = mesh.kinds[old_e];
        let vs = element_vertices(mesh, old_e, flip);
        let rvs = opts.reference.map(|r| element_vertices(r, old_e, flip));
        let used = used_by(old_e).map_err(|m| Error::InvalidMesh(format!("element {old_e} ({kind}): {m}")))?;
        for c in used.iter() {
            let w = match (&reference, &rvs) {
                (Some((_, rp)), Some(rvs)) => corner_matrix(rp, rvs, c, dim),
                _ if every => OCTANT,
                _ => ideal_corner(kind),
            };
            let shape = CornerShape::from_w(&w, dim).ok_or_else(|| {
                Error::InvalidMesh(format!(
                    "reference element {old_e} ({kind}) is inverted or degenerate at its corner at vertex {}",
                    vs[c[0]]
                ))
            })?;
            let key: [u64; 12] = std::array::from_fn(|i| shape.tet.b(i / 3)[i % 3].to_bits());
            let id = *shape_ids.entry(key).or_insert_with(|| {
                out.shapes.push(shape);
                out.shapes.len() as u32 - 1
            });
            let mut cv = [0u32; 4];
            for (slot, l) in cv.iter_mut().zip(c.iter()).take(dim + 1) {
                *slot = inv[vs[*l] as usize];
            }
            if dim == 2 {
                cv[3] = cv[0];
            }
            out.corners.push(cv);
            out.corner_element.push(new_e as u32);
            out.corner_shape.push(id);
            out.corner_weight.push(if every {
                1.0 / total as f64
            } else {
                1.0 / (ne as f64 * used.len() as f64)
            });
        }
    }
    Ok(out)
}

impl Corners {
    pub fn len(&self) -> usize {
        self.corners.len()
    }

    pub fn is_empty(&self) -> bool {
        self.corners.is_empty()
    }

    #[inline]
    pub fn points(&self, x: &[Vec3], c: usize) -> [Vec3; 4] {
        let t = &self.corners[c];
        [x[t[0] as usize], x[t[1] as usize], x[t[2] as usize], x[t[3] as usize]]
    }

    #[inline]
    pub fn shape(&self, c: usize) -> &CornerShape {
        &self.shapes[self.corner_shape[c] as usize]
    }

    /// Per element (this numbering): the mean over its corners of `model`'s
    /// value at `x` (positions in this numbering); `None` when a corner is
    /// inverted or degenerate. `num_elements` elements, corners summed in
    /// corner-table order.
    pub fn element_values(&self, model: &Model, x: &[Vec3], num_elements: usize) -> Vec<Option<f64>> {
        let mut sums = vec![Some(0.0); num_elements];
        let mut counts = vec![0usize; num_elements];
        for c in 0..self.len() {
            let e = self.corner_element[c] as usize;
            let v = model.value(self.shape(c), &self.points(x, c));
            sums[e] = match (sums[e], v) {
                (Some(s), Some(v)) => Some(s + v),
                _ => None,
            };
            counts[e] += 1;
        }
        sums.into_iter()
            .zip(counts)
            .map(|(s, n)| s.map(|s| s / n.max(1) as f64))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate;

    #[test]
    fn corners_cover_each_element_by_its_optimised_corners_with_weights_summing_to_one() {
        let m = generate::mixed_block(2, 2);
        let num = Numbering::identity(&m);
        let cs = corners(&m, &m.points, &ProblemOptions::default(), &num).unwrap();
        let mut per_element = vec![0usize; m.num_elements()];
        for c in 0..cs.len() {
            per_element[cs.corner_element[c] as usize] += 1;
            // the corner vertex and its neighbours are the element's
            let e = cs.corner_element[c] as usize;
            assert!(cs.corners[c].iter().all(|v| m.element(e).contains(v)));
        }
        for e in 0..m.num_elements() {
            assert_eq!(per_element[e], m.optimised_corners(e).unwrap().len(), "element {e}");
        }
        let total: f64 = cs.corner_weight.iter().sum();
        assert!((total - 1.0).abs() < 1e-12, "{total}");
        // one ideal shape per kind present, shared by all its corners
        let kinds: std::collections::BTreeSet<_> = m.kinds.iter().collect();
        assert!(cs.shapes.len() <= kinds.len() && !cs.shapes.is_empty());
    }

    #[test]
    fn clockwise_planar_elements_are_read_reversed() {
        let mut m = generate::quad_grid(2, 1, [2.0, 1.0]);
        for p in &mut m.points {
            p[1] = -p[1];
        }
        let cs = corners(&m, &m.points, &ProblemOptions::default(), &Numbering::identity(&m)).unwrap();
        assert!(cs.flip);
        let vs = m.element(0);
        assert_eq!(element_vertices(&m, 0, true), vec![vs[0], vs[3], vs[2], vs[1]]);
        // every corner is positively oriented once read reversed
        let model = Model::default();
        let values = cs.element_values(&model, &m.points, m.num_elements());
        assert!(
            values.iter().all(|v| v.is_some_and(|v| (v - 1.0).abs() < 1e-12)),
            "{values:?}"
        );
    }
}
