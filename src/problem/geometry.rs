//! Sliding on a given geometry (`--surface GEOMETRY`) instead of the mesh's
//! own skin.
//!
//! The geometry is a triangulated surface (STL, OBJ, PLY, a VTK or Gmsh
//! surface; quadrilaterals count as two triangles) or a volume mesh, whose
//! skin is then used. It is classified on its own, so that a poor starting
//! skin cannot invent features: an edge of the geometry is a *feature edge*
//! when its two faces meet at more than the feature angle (their windings
//! compared along the shared edge, so a file with inconsistently wound
//! triangles reads the same) or when it does not have exactly two faces. The
//! faces joined across other edges form *patches*, the feature edges joined
//! at vertices with two of them that turn gently form *curves*, and every
//! other vertex on a feature edge is a *corner*.
//!
//! A skin vertex of the mesh then takes its class from where it lies: on a
//! geometry corner (within [`CORNER_TOL`] of its own skin edge length h) it
//! stays; on a feature curve (within [`EDGE_TOL`] h) it slides along that
//! curve; anywhere else it slides on the patch of its nearest triangle. Its
//! candidates are the primitives of that patch or curve within [`REACH`] h
//! of its start, found in an R*-tree, so a vertex can slide that far —
//! farther than the two face rings of the mesh's own skin allow — and never
//! onto another patch. A skin vertex farther than [`FAR`] h from the
//! geometry is refused: the geometry is not this mesh's.

use super::boundary::{self, IDENTITY, SkinClasses, VertexClass};
use crate::backend::cpu::project_boundary::closest_on_triangle;
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::mesh::topology::Csr;
use crate::metric::mat3::{Vec3, dot, sub, unit};
use rstar::{AABB, PointDistance, RTree, RTreeObject};
use std::collections::HashMap;

/// A mesh vertex this close to a geometry corner (in its skin edge lengths) is a corner.
pub const CORNER_TOL: f64 = 0.05;
/// A mesh vertex this close to a feature curve (in its skin edge lengths) slides along it.
pub const EDGE_TOL: f64 = 0.05;
/// How far (in its skin edge lengths) a vertex's candidates reach from its start.
pub const REACH: f64 = 2.5;
/// A skin vertex farther than this (in its skin edge lengths) from the geometry is refused.
pub const FAR: f64 = 0.5;

/// A triangle or segment (`[a, b, b]`) of the geometry, indexed by the tree.
struct Prim {
    index: u32,
    shape: [Vec3; 3],
}

impl RTreeObject for Prim {
    type Envelope = AABB<[f64; 3]>;

    fn envelope(&self) -> Self::Envelope {
        let [a, b, c] = &self.shape;
        let lo = std::array::from_fn(|k| a[k].min(b[k]).min(c[k]));
        let hi = std::array::from_fn(|k| a[k].max(b[k]).max(c[k]));
        AABB::from_corners(lo, hi)
    }
}

impl PointDistance for Prim {
    fn distance_2(&self, p: &[f64; 3]) -> f64 {
        let d = sub(p, &closest_on_triangle(p, &self.shape));
        dot(&d, &d)
    }
}

/// A classified geometry with its search trees.
pub struct Geometry {
    /// Triangles, then segments `[a, b, b]` of the feature curves.
    primitives: Vec<[Vec3; 3]>,
    /// Patch of each triangle, curve of each segment.
    group: Vec<u32>,
    /// Unit normal of each triangle.
    normal: Vec<Vec3>,
    triangles: RTree<Prim>,
    segments: RTree<Prim>,
    corners: RTree<[f64; 3]>,
    /// Patches, curves and corners, for reports.
    pub counts: [usize; 3],
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        parent[i as usize] = parent[parent[i as usize] as usize];
        i = parent[i as usize];
    }
    i
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (a, b) = (find(parent, a), find(parent, b));
    if a != b {
        parent[a.max(b) as usize] = a.min(b);
    }
}

/// Dense ids 0.. for the roots of `parent`, in order of first appearance.
fn groups(parent: &mut [u32]) -> (Vec<u32>, usize) {
    let mut id = HashMap::new();
    let out = (0..parent.len() as u32)
        .map(|i| {
            let r = find(parent, i);
            let next = id.len() as u32;
            *id.entry(r).or_insert(next)
        })
        .collect();
    (out, id.len())
}

impl Geometry {
    /// Classifies `geometry` (a surface or a volume mesh, at `points`) with
    /// faces meeting at more than `feature_angle` degrees forming feature
    /// edges, and so do the edges in `curves` (vertex pairs: a surface mesh's
    /// own curves from its file).
    pub fn new(geometry: &Mesh, points: &[Vec3], feature_angle: f64, curves: &[(u32, u32)]) -> Result<Geometry> {
        let curves: std::collections::HashSet<(u32, u32)> = curves.iter().map(|&(a, b)| (a.min(b), a.max(b))).collect();
        // faces: a volume mesh's skin, or the surface's own elements
        let faces: Vec<Vec<u32>> = if geometry.dim() == 3 {
            boundary::skin_faces(geometry, points)
        } else {
            (0..geometry.num_elements())
                .filter(|&e| geometry.element(e).len() >= 3)
                .map(|e| geometry.element(e).to_vec())
                .collect()
        };
        if faces.is_empty() {
            return Err(Error::InvalidMesh(
                "the surface geometry has no faces: give a triangulated surface (STL, OBJ, PLY, VTK, Gmsh) or a volume mesh".into(),
            ));
        }
        let cos_feature = feature_angle.to_radians().cos();
        // a face without area has no normal: zero, so no edge of it is smooth
        let face_normal: Vec<Vec3> = faces
            .iter()
            .map(|f| crate::metric::surface::element_normal(points, f).unwrap_or([0.0; 3]))
            .collect();
        // each edge with its faces and the direction each traverses it in
        let mut edges: HashMap<(u32, u32), Vec<(u32, bool)>> = HashMap::new();
        for (fi, f) in faces.iter().enumerate() {
            for i in 0..f.len() {
                let (a, b) = (f[i], f[(i + 1) % f.len()]);
                edges.entry((a.min(b), a.max(b))).or_default().push((fi as u32, a < b));
            }
        }
        let mut parent: Vec<u32> = (0..faces.len() as u32).collect();
        let mut feature: Vec<(u32, u32)> = Vec::new();
        for (&key, fs) in &edges {
            let smooth = fs.len() == 2 && !curves.contains(&key) && {
                let (na, nb) = (&face_normal[fs[0].0 as usize], &face_normal[fs[1].0 as usize]);
                // two faces wound alike traverse their edge in opposite directions
                let s = if fs[0].1 != fs[1].1 { 1.0 } else { -1.0 };
                s * dot(na, nb) >= cos_feature
            };
            if smooth {
                union(&mut parent, fs[0].0, fs[1].0);
            } else {
                feature.push(key);
            }
        }
        feature.sort_unstable();
        let sure = |k: &(u32, u32)| edges[k].len() != 2 || curves.contains(k);
        let kept = boundary::without_dangling(feature.clone(), sure);
        if kept.len() != feature.len() {
            // a dropped edge joins its two faces' patches after all
            let kept_set: std::collections::HashSet<&(u32, u32)> = kept.iter().collect();
            for k in feature.iter().filter(|k| !kept_set.contains(k)) {
                let fs = &edges[k];
                union(&mut parent, fs[0].0, fs[1].0);
            }
            feature = kept;
        }
        let (patch, patches) = groups(&mut parent);

        // vertices on feature edges: two that turn gently join a curve, others are corners
        let mut at: HashMap<u32, Vec<u32>> = HashMap::new();
        for (i, &(a, b)) in feature.iter().enumerate() {
            at.entry(a).or_default().push(i as u32);
            at.entry(b).or_default().push(i as u32);
        }
        let mut parent: Vec<u32> = (0..feature.len() as u32).collect();
        let mut corner_ids: Vec<u32> = Vec::new();
        let mut ends: Vec<(&u32, &Vec<u32>)> = at.iter().collect();
        ends.sort_unstable();
        for (&v, es) in ends {
            let gentle = es.len() == 2 && {
                let away = |e: u32| {
                    let (a, b) = feature[e as usize];
                    let o = if a == v { b } else { a };
                    unit(sub(&points[o as usize], &points[v as usize]))
                };
                // the two edges leave v in nearly opposite directions
                -dot(&away(es[0]), &away(es[1])) >= cos_feature
            };
            if gentle {
                union(&mut parent, es[0], es[1]);
            } else {
                corner_ids.push(v);
            }
        }
        let (curve, curves) = groups(&mut parent);

        let mut primitives = Vec::new();
        let mut group = Vec::new();
        let mut normal = Vec::new();
        for (fi, f) in faces.iter().enumerate() {
            let p = |i: usize| points[f[i] as usize];
            for i in 1..f.len() - 1 {
                primitives.push([p(0), p(i), p(i + 1)]);
                group.push(patch[fi]);
                normal.push(face_normal[fi]);
            }
        }
        let first_segment = primitives.len();
        for (i, &(a, b)) in feature.iter().enumerate() {
            let (pa, pb) = (points[a as usize], points[b as usize]);
            primitives.push([pa, pb, pb]);
            group.push(curve[i]);
            normal.push([0.0; 3]);
        }
        let prims = |range: std::ops::Range<usize>| -> Vec<Prim> {
            range
                .map(|i| Prim {
                    index: i as u32,
                    shape: primitives[i],
                })
                .collect()
        };
        Ok(Geometry {
            triangles: RTree::bulk_load(prims(0..first_segment)),
            segments: RTree::bulk_load(prims(first_segment..primitives.len())),
            corners: RTree::bulk_load(corner_ids.iter().map(|&v| points[v as usize]).collect()),
            counts: [patches, curves, corner_ids.len()],
            primitives,
            group,
            normal,
        })
    }

    /// Classifies the skin of `mesh` at `points` on this geometry (same
    /// coordinates) and gives each sliding vertex its projector and
    /// candidates; an error names a skin vertex that lies far from it.
    pub fn classify(&self, mesh: &Mesh, points: &[Vec3]) -> Result<SkinClasses> {
        let n = mesh.num_points();
        // each skin vertex's longest skin edge: the length its tolerances scale with
        let mut h = vec![0.0f64; n];
        for f in boundary::sliding_faces(mesh, points) {
            for i in 0..f.len() {
                let (a, b) = (f[i] as usize, f[(i + 1) % f.len()] as usize);
                let d = sub(&points[a], &points[b]);
                let l = dot(&d, &d).sqrt();
                h[a] = h[a].max(l);
                h[b] = h[b].max(l);
            }
        }
        let mut class = vec![VertexClass::Interior; n];
        let mut projector = vec![IDENTITY; n];
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        for v in 0..n {
            if !(h[v] > 0.0) {
                continue;
            }
            let p = &points[v];
            let within = |d2: Option<f64>, tol: f64| d2.is_some_and(|d2| d2 <= (tol * h[v]).powi(2));
            let d2 = |q: &Vec3| {
                let d = sub(p, q);
                dot(&d, &d)
            };
            if within(self.corners.nearest_neighbor(p).map(d2), CORNER_TOL) {
                class[v] = VertexClass::Corner;
                continue;
            }
            let near_seg = self.segments.nearest_neighbor(p);
            let (tree, nearest) = match near_seg {
                Some(s) if within(Some(s.distance_2(p)), EDGE_TOL) => (&self.segments, s),
                _ => {
                    let t = self.triangles.nearest_neighbor(p).expect("a geometry has faces");
                    let d = t.distance_2(p).sqrt();
                    if d > FAR * h[v] {
                        return Err(Error::InvalidMesh(format!(
                            "skin vertex {v} at ({:e}, {:e}, {:e}) lies {d:e} from the surface geometry, more than \
                             {FAR} of its edge length {:e}: the geometry does not describe this mesh's boundary \
                             (other units or another part?)",
                            p[0], p[1], p[2], h[v]
                        )));
                    }
                    (&self.triangles, t)
                }
            };
            let g = self.group[nearest.index as usize];
            let is_edge = std::ptr::eq(tree, &self.segments);
            class[v] = if is_edge {
                VertexClass::Edge
            } else {
                VertexClass::Surface
            };
            // the mean direction of every primitive of the patch or curve the
            // vertex touches (a vertex of the geometry touches several), so
            // that the tangent space does not depend on which one a tree
            // query meets first
            let touch = (1e-9 * h[v]).powi(2).max(f64::MIN_POSITIVE);
            let mut dir = [0.0; 3];
            let first = if is_edge {
                let [a, b, _] = &nearest.shape;
                unit(sub(b, a))
            } else {
                self.normal[nearest.index as usize]
            };
            for c in tree.locate_within_distance(*p, touch) {
                if self.group[c.index as usize] != g {
                    continue;
                }
                let d = if is_edge {
                    let [a, b, _] = &c.shape;
                    unit(sub(b, a))
                } else {
                    self.normal[c.index as usize]
                };
                // segments point either way along their curve
                let s = if is_edge && dot(&d, &first) < 0.0 { -1.0 } else { 1.0 };
                for k in 0..3 {
                    dir[k] += s * d[k];
                }
            }
            let dir = if dot(&dir, &dir) > 0.0 { unit(dir) } else { first };
            projector[v] = if is_edge {
                boundary::line_projector(&dir)
            } else {
                boundary::plane_projector(&dir)
            };
            let reach = (REACH * h[v]).powi(2);
            let mut cs: Vec<u32> = tree
                .locate_within_distance(*p, reach)
                .filter(|c| self.group[c.index as usize] == g)
                .map(|c| c.index)
                .collect();
            cs.sort_unstable();
            pairs.extend(cs.into_iter().map(|c| (v as u32, c)));
        }
        Ok(SkinClasses {
            class,
            projector,
            candidates: Csr::from_pairs(n, pairs.into_iter()),
            primitives: self.primitives.clone(),
        })
    }
}
