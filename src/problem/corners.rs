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
use rayon::prelude::*;

/// The corners of every element, in a [`Numbering`].
#[derive(Clone, Debug)]
pub struct Corners {
    /// Metric dimension: 2 or 3.
    pub dim: usize,
    /// Planar mesh wound clockwise: elements are read in mirrored order.
    pub flip: bool,
    /// A surface mesh (`mesh::plane::is_surface`): every corner measured in
    /// its own tangent plane, facing its element's normal at `points`.
    pub surface: bool,
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
    let mut out = Vec::new();
    element_vertices_into(mesh, e, flip, &mut out);
    out
}

/// [`element_vertices`] into a buffer the caller reuses (no allocation per element).
fn element_vertices_into(mesh: &Mesh, e: usize, flip: bool, out: &mut Vec<u32>) {
    out.clear();
    push_element_vertices(mesh, e, flip, out);
}

/// [`element_vertices`] appended to `out`.
pub(crate) fn push_element_vertices(mesh: &Mesh, e: usize, flip: bool, out: &mut Vec<u32>) {
    let from = out.len();
    out.extend_from_slice(mesh.element(e));
    if flip {
        reverse_winding(mesh.kinds[e], &mut out[from..]);
    }
}

/// A planar element's vertices read the other way round from the first
/// ([v0, v2, v1] for a triangle); other kinds as they are.
pub(crate) fn reverse_winding(kind: ElementKind, vs: &mut [u32]) {
    if matches!(kind, ElementKind::Triangle | ElementKind::Quadrilateral) {
        vs[1..].reverse();
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

/// Elements per parallel task: a fixed size, so tasks (and the first error
/// found) do not depend on the thread count.
const CHUNK: usize = 1 << 12;

/// A shape's bits, the key under which equal shapes share one id.
fn shape_key(shape: &CornerShape) -> [u64; 15] {
    std::array::from_fn(|i| {
        if i < 12 {
            shape.tet.b(i / 3)[i % 3].to_bits()
        } else {
            shape.normal[i - 12].to_bits()
        }
    })
}

/// `s` cut into consecutive pieces of the given lengths.
fn split_by<'a, T>(mut s: &'a mut [T], lens: &[usize]) -> Vec<&'a mut [T]> {
    let mut out = Vec::with_capacity(lens.len());
    for &len in lens {
        let (a, b) = s.split_at_mut(len);
        out.push(a);
        s = b;
    }
    out
}

/// The corners of `mesh` with its vertices at `points` (which decide the
/// orientation of a planar mesh), elements and vertices in `numbering`.
/// Fails on a reference element that is inverted or degenerate.
///
/// Elements are filled in parallel, in fixed chunks whose output ranges come
/// from a prefix sum of their corner counts; shape ids are numbered in order
/// of first appearance, as a sequential pass would number them, so the
/// result does not depend on the thread count.
pub fn corners(mesh: &Mesh, points: &[Vec3], opts: &ProblemOptions, numbering: &Numbering) -> Result<Corners> {
    let dim = mesh.dim();
    let surface = crate::mesh::plane::is_surface(mesh, points);
    // planar meshes wound clockwise are optimised in mirrored order
    let flip = !surface && crate::metric::is_clockwise(mesh, points);
    let elem_order = &numbering.elem_order;
    let ne = elem_order.len();
    let inv = &numbering.inv;
    // a planar reference in its own plane's coordinates, as the mesh is in its
    let reference = match opts.reference {
        Some(r) => Some((r, in_plane(Plane::fit(r, &r.points)?.as_ref(), &r.points))),
        None => None,
    };
    // the rezoning paper's metrics: every corner against the octant corner,
    // each weighted 1 / (corners in the mesh)
    let every = opts.metric.every_corner();
    // constructed targets (input, size or metric field), per used corner
    let targets = super::targets::build(mesh, points, flip, opts.target, opts.length_unit)?;
    let own = reference.is_some() || targets.is_some() || surface;
    let used_by = |e: usize| {
        if every {
            mesh.element_corners(e)
        } else {
            mesh.optimised_corners(e)
        }
    };
    let nchunks = ne.div_ceil(CHUNK);
    let chunk = |c: usize| c * CHUNK..((c + 1) * CHUNK).min(ne);
    // (an element whose corners are refused counts none here and is
    // reported by the fill below)
    let chunk_len: Vec<usize> = (0..nchunks)
        .into_par_iter()
        .map(|c| {
            elem_order[chunk(c)]
                .iter()
                .map(|&e| used_by(e as usize).map_or(0, |c| c.len()))
                .sum()
        })
        .collect();
    let total: usize = chunk_len.iter().sum();
    const OCTANT: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    // Without a reference a corner's shape depends on its element's kind
    // only: one shape per kind, numbered in the order the kinds first appear.
    // `None`: the kind's ideal corner is refused (reported by the fill).
    let kind_index = |k: ElementKind| ElementKind::ALL.iter().position(|&a| a == k).unwrap();
    let mut shapes: Vec<CornerShape> = Vec::new();
    let mut kind_shape: [Option<u32>; ElementKind::ALL.len()] = [None; ElementKind::ALL.len()];
    if !own {
        const NK: usize = ElementKind::ALL.len();
        let first: [usize; NK] = elem_order
            .par_iter()
            .enumerate()
            .fold(
                || [usize::MAX; NK],
                |mut first, (new_e, &e)| {
                    let k = kind_index(mesh.kinds[e as usize]);
                    first[k] = first[k].min(new_e);
                    first
                },
            )
            .reduce(|| [usize::MAX; NK], |a, b| std::array::from_fn(|k| a[k].min(b[k])));
        let mut kinds: Vec<(usize, usize)> = (0..NK)
            .map(|k| (first[k], k))
            .filter(|&(at, _)| at != usize::MAX)
            .collect();
        kinds.sort_unstable();
        for (_, k) in kinds {
            let w = if every {
                OCTANT
            } else {
                ideal_corner(ElementKind::ALL[k])
            };
            if let Some(shape) = CornerShape::from_w(&w, dim) {
                let key = shape_key(&shape);
                let id = match shapes.iter().position(|s| shape_key(s) == key) {
                    Some(id) => id,
                    None => {
                        shapes.push(shape);
                        shapes.len() - 1
                    }
                };
                kind_shape[k] = Some(id as u32);
            }
        }
    }
    let mut out = Corners {
        dim,
        flip,
        surface,
        corners: vec![[0; 4]; total],
        corner_element: vec![0; total],
        corner_shape: vec![0; total],
        corner_weight: vec![0.0; total],
        shapes,
    };
    // with a reference, every corner's own shape, deduplicated afterwards
    let mut own_shapes: Vec<CornerShape> = Vec::new();
    if own {
        own_shapes = vec![CornerShape::from_w(&OCTANT, dim).expect("the octant corner is valid"); total];
    }
    let own_lens: Vec<usize> = if own { chunk_len.clone() } else { vec![0; nchunks] };
    let parts: Vec<_> = split_by(&mut out.corners, &chunk_len)
        .into_iter()
        .zip(split_by(&mut out.corner_element, &chunk_len))
        .zip(split_by(&mut out.corner_shape, &chunk_len))
        .zip(split_by(&mut out.corner_weight, &chunk_len))
        .zip(split_by(&mut own_shapes, &own_lens))
        .enumerate()
        .collect();
    let filled: Vec<Result<()>> = parts
        .into_par_iter()
        .map(|(ci, ((((cv_out, ce_out), cs_out), cw_out), own_out))| {
            let (mut vs, mut rvs) = (Vec::new(), Vec::new());
            let mut at = 0;
            for new_e in chunk(ci) {
                let old_e = elem_order[new_e] as usize;
                let kind = mesh.kinds[old_e];
                element_vertices_into(mesh, old_e, flip, &mut vs);
                let used = used_by(old_e).map_err(|m| Error::InvalidMesh(format!("element {old_e} ({kind}): {m}")))?;
                let refused = |c: &[usize; 4]| {
                    Error::InvalidMesh(format!(
                        "reference element {old_e} ({kind}) is inverted or degenerate at its corner at vertex {}",
                        vs[c[0]]
                    ))
                };
                if let Some((r, rp)) = &reference {
                    element_vertices_into(r, old_e, flip, &mut rvs);
                    for (j, c) in used.iter().enumerate() {
                        let w = corner_matrix(rp, &rvs, c, dim);
                        own_out[at + j] = CornerShape::from_w(&w, dim).ok_or_else(|| refused(c))?;
                    }
                } else if let Some(t) = &targets {
                    for (j, w) in t.of(old_e).iter().enumerate() {
                        own_out[at + j] = CornerShape::from_w(w, dim).ok_or_else(|| {
                            Error::InvalidMesh(format!(
                                "the target of element {old_e} ({kind}) at its corner at vertex {} is degenerate",
                                vs[used[j][0]]
                            ))
                        })?;
                    }
                } else if surface {
                    // the kind's ideal corner, facing the element's own normal
                    let normal = crate::metric::surface::element_normal(points, &vs)
                        .ok_or_else(|| Error::InvalidMesh(format!("surface element {old_e} ({kind}) has no area")))?;
                    let ideal = CornerShape::from_w(&ideal_corner(kind), dim).ok_or_else(|| refused(&used[0]))?;
                    for j in 0..used.len() {
                        own_out[at + j] = ideal.on_surface(normal);
                    }
                } else if let (None, Some(c)) = (kind_shape[kind_index(kind)], used.first()) {
                    return Err(refused(c));
                }
                let shape = kind_shape[kind_index(kind)].unwrap_or(0);
                let weight = if every {
                    1.0 / total as f64
                } else {
                    1.0 / (ne as f64 * used.len() as f64)
                };
                for c in used.iter() {
                    let mut cv = [0u32; 4];
                    for (slot, l) in cv.iter_mut().zip(c.iter()).take(dim + 1) {
                        *slot = inv[vs[*l] as usize];
                    }
                    if dim == 2 {
                        cv[3] = cv[0];
                    }
                    cv_out[at] = cv;
                    ce_out[at] = new_e as u32;
                    cs_out[at] = shape;
                    cw_out[at] = weight;
                    at += 1;
                }
            }
            Ok(())
        })
        .collect();
    filled.into_iter().collect::<Result<Vec<()>>>()?;
    if own {
        number_shapes(&own_shapes, &mut out.corner_shape, &mut out.shapes);
    }
    Ok(out)
}

/// Numbers distinct shapes (by their bits) in order of first appearance:
/// `ids[c]` becomes corner `c`'s shape id and `shapes` the distinct shapes.
/// A parallel sort of the corners by key, not a hash map.
fn number_shapes(own: &[CornerShape], ids: &mut [u32], shapes: &mut Vec<CornerShape>) {
    let keys: Vec<[u64; 15]> = own.par_iter().map(shape_key).collect();
    let mut by_key: Vec<u32> = (0..own.len() as u32).collect();
    by_key.par_sort_unstable_by(|&a, &b| keys[a as usize].cmp(&keys[b as usize]).then(a.cmp(&b)));
    // each corner's first equal corner, then those first corners numbered in order
    let mut first = vec![0u32; own.len()];
    let mut reps = Vec::new();
    for (i, &c) in by_key.iter().enumerate() {
        if i == 0 || keys[c as usize] != keys[by_key[i - 1] as usize] {
            reps.push(c);
        }
        first[c as usize] = *reps.last().unwrap();
    }
    reps.sort_unstable();
    let mut id_of = vec![0u32; own.len()];
    for (id, &r) in reps.iter().enumerate() {
        id_of[r as usize] = id as u32;
        shapes.push(own[r as usize]);
    }
    ids.par_iter_mut()
        .zip(first.par_iter())
        .for_each(|(id, &f)| *id = id_of[f as usize]);
}

impl Corners {
    /// Number of corners.
    pub fn len(&self) -> usize {
        self.corners.len()
    }

    /// True when there are no corners.
    pub fn is_empty(&self) -> bool {
        self.corners.is_empty()
    }

    /// The positions of corner `c`'s four vertices (corner first).
    #[inline]
    pub fn points(&self, x: &[Vec3], c: usize) -> [Vec3; 4] {
        let t = &self.corners[c];
        [x[t[0] as usize], x[t[1] as usize], x[t[2] as usize], x[t[3] as usize]]
    }

    /// The reference shape of corner `c`.
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

    /// The corners as a plain sequential loop builds them, shapes numbered
    /// through a map in order of first appearance.
    fn sequential(m: &Mesh, opts: &ProblemOptions, num: &Numbering) -> Corners {
        let dim = m.dim();
        let every = opts.metric.every_corner();
        let used_by = |e: usize| {
            if every {
                m.element_corners(e).unwrap()
            } else {
                m.optimised_corners(e).unwrap()
            }
        };
        let total: usize = (0..m.num_elements()).map(|e| used_by(e).len()).sum();
        let mut out = Corners {
            dim,
            flip: false,
            surface: false,
            corners: vec![],
            corner_element: vec![],
            corner_shape: vec![],
            corner_weight: vec![],
            shapes: vec![],
        };
        let mut ids = std::collections::HashMap::new();
        for (new_e, &old_e) in num.elem_order.iter().enumerate() {
            let (old_e, vs) = (old_e as usize, m.element(old_e as usize));
            let used = used_by(old_e);
            for c in used.iter() {
                let w = match opts.reference {
                    Some(r) => corner_matrix(&r.points, r.element(old_e), c, dim),
                    None if every => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                    None => ideal_corner(m.kinds[old_e]),
                };
                let shape = CornerShape::from_w(&w, dim).unwrap();
                let id = *ids.entry(shape_key(&shape)).or_insert_with(|| {
                    out.shapes.push(shape);
                    out.shapes.len() as u32 - 1
                });
                let mut cv = [0u32; 4];
                for k in 0..=dim {
                    cv[k] = num.inv[vs[c[k]] as usize];
                }
                out.corners.push(cv);
                out.corner_element.push(new_e as u32);
                out.corner_shape.push(id);
                out.corner_weight.push(if every {
                    1.0 / total as f64
                } else {
                    1.0 / (m.num_elements() as f64 * used.len() as f64)
                });
            }
        }
        out
    }

    #[test]
    fn parallel_corners_equal_the_sequential_ones_on_any_thread_count() {
        use crate::mesh::order::Ordering;
        use crate::metric::smetric::MetricKind;
        use crate::problem::{MeshGraph, order};
        // a mixed mesh of several chunks, and a reference whose corners all
        // differ (the shape numbering without a per-kind table)
        let m = generate::mixed_block(12, 10);
        assert!(m.num_elements() > 2 * CHUNK, "{}", m.num_elements());
        let mut r = m.clone();
        for (v, p) in r.points.iter_mut().enumerate() {
            p[0] += 0.01 * ((v * 7919) % 13) as f64 / 13.0;
        }
        let num = order(&m, &MeshGraph::of(&m), Ordering::ReverseBfs);
        let with_reference = ProblemOptions {
            reference: Some(&r),
            ..Default::default()
        };
        let every = ProblemOptions {
            metric: MetricKind::ConditionNumberPaper,
            ..Default::default()
        };
        for (name, opts) in [
            ("ideal", ProblemOptions::default()),
            ("reference", with_reference),
            ("every corner", every),
        ] {
            let want = sequential(&m, &opts, &num);
            assert!(name != "reference" || want.shapes.len() > 100, "{}", want.shapes.len());
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let got = pool.install(|| corners(&m, &m.points, &opts, &num).unwrap());
                let ctx = format!("{name} on {threads} threads");
                assert_eq!(got.corners, want.corners, "{ctx}");
                assert_eq!(got.corner_element, want.corner_element, "{ctx}");
                assert_eq!(got.corner_shape, want.corner_shape, "{ctx}");
                assert_eq!(got.corner_weight, want.corner_weight, "{ctx}");
                assert_eq!(got.shapes, want.shapes, "{ctx}");
            }
        }
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
