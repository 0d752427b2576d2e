//! Sliding boundary (`--boundary slide`): the skin is classified once and
//! each boundary vertex gets a constraint the solvers respect.
//!
//! - **Classification.** Skin facets (faces in 3D, edges in 2D) get outward
//!   normals; a skin edge is a *feature edge* when its two faces meet at more
//!   than the feature angle, and so do its two sides (each face's normal
//!   summed with its neighbours' across its other edges, so that one skewed
//!   facet on a smooth surface makes no feature), or when it does not have
//!   exactly two skin faces.
//!   In 2D every boundary edge is a feature edge. A vertex with no feature
//!   edge is a *surface* vertex (it moves in its tangent plane, normal = the
//!   area-weighted mean of its faces' normals); with exactly two, whose
//!   directions turn by at most the feature angle, an *edge* vertex (it moves
//!   along the edge); anything else (one or three or more feature edges, a
//!   sharp turn) is a *corner* and stays fixed.
//! - **Constraint.** Each sliding vertex carries the orthogonal projector P
//!   onto its tangent space (I - n n^T or t t^T), from the original mesh, and
//!   a list of candidate primitives of the original boundary: the triangles of
//!   its own patch within two face rings (a quadrilateral face counts as two
//!   triangles), or the segments of its own feature curve within two vertices
//!   along it (not past a corner). After every step it is put back at the
//!   closest point of its candidates (`backend::cpu::project_boundary`), so it
//!   stays on the original triangulation exactly (to rounding), and never on a
//!   neighbouring patch or on the far side of a thin wall. The candidate lists
//!   limit how far a vertex can slide: the rim of its list can be as close
//!   as 0.4–0.5 mean edge lengths (measured on Gmsh spheres and cylinders,
//!   README "Sliding boundary"), while a solve there moved boundary vertices
//!   at most 0.37; a vertex at the end of its list stays on the list's rim.
//! - P is the start's only until the first gradient: the solvers use the
//!   projector of the constraint active where the gradient mapping leads the
//!   vertex (`backend::cpu::project_boundary::active_projector`): its face,
//!   the crease it sits on, or none where it is stationary on a crease. The
//!   boundary is faceted and the minimiser sits on its creases, where no
//!   tangent plane makes the projected gradient vanish.

use super::numbering::Numbering;
use crate::mesh::topology::Csr;
use crate::mesh::{ElementKind, Mesh};
use crate::metric::mat3::cross;
use crate::metric::mat3::{Mat3, Vec3, dot, sub, unit};
use std::collections::{HashMap, VecDeque};

/// Whether boundary vertices stay where they are or slide on the boundary.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum BoundaryMode {
    /// Every skin vertex stays where it is.
    #[default]
    Fixed,
    /// Skin vertices slide in their boundary patch or along their feature
    /// edge; corners stay.
    Slide,
}

crate::error::by_name!(BoundaryMode: "boundary" { Fixed = "fixed", Slide = "slide" });

/// How the boundary is treated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Boundary {
    /// Fixed or sliding skin vertices.
    pub mode: BoundaryMode,
    /// Faces meeting at more than this angle (degrees) form a feature edge; an
    /// edge turning by more than it makes a corner.
    pub feature_angle: f64,
}

impl Default for Boundary {
    fn default() -> Self {
        Boundary {
            mode: BoundaryMode::Fixed,
            feature_angle: 30.0,
        }
    }
}

/// What a skin vertex may do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VertexClass {
    /// Not on the skin.
    Interior,
    /// On one smooth patch: moves in its tangent plane.
    Surface,
    /// On a feature edge (or a 2D boundary): moves along it.
    Edge,
    /// Fixed.
    Corner,
}

/// The sliding constraints in the problem's numbering.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Sliding {
    /// Per vertex: the projector onto the directions it may move in at the
    /// start (the identity off the boundary); the solvers take the active
    /// constraint's (`project_boundary::active_projector`), smart Laplace and
    /// the sweep orderings this one.
    pub projector: Vec<Mat3>,
    /// Per vertex: indices into `primitives` it is projected onto; empty for
    /// a vertex that does not slide.
    pub candidates: Csr,
    /// Triangles of the original boundary, and segments `[a, b, b]` of its
    /// feature curves.
    pub primitives: Vec<[Vec3; 3]>,
    /// Vertices of each class: surface, edge, corner.
    pub counts: [usize; 3],
}

impl Sliding {
    /// Does vertex `v` (problem numbering) slide?
    #[inline]
    pub fn slides(&self, v: usize) -> bool {
        self.candidates.offsets[v] != self.candidates.offsets[v + 1]
    }

    /// The constraints of the vertices `global` (ascending), numbered by
    /// their place in it, with only the primitives they are projected onto
    /// (a part of a partitioned run carries its own, not the whole skin's).
    pub fn restrict(&self, global: &[u32]) -> Sliding {
        let mut kept = vec![u32::MAX; self.primitives.len()];
        let mut primitives = Vec::new();
        let mut pairs = Vec::new();
        for (l, &g) in global.iter().enumerate() {
            for &c in self.candidates.of(g as usize) {
                if kept[c as usize] == u32::MAX {
                    kept[c as usize] = primitives.len() as u32;
                    primitives.push(self.primitives[c as usize]);
                }
                pairs.push((l as u32, kept[c as usize]));
            }
        }
        Sliding {
            projector: global.iter().map(|&g| self.projector[g as usize]).collect(),
            candidates: Csr::from_pairs(global.len(), pairs.into_iter()),
            primitives,
            counts: self.counts,
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        72 * self.projector.len()
            + 4 * (self.candidates.offsets.len() + self.candidates.items.len())
            + 72 * self.primitives.len()
    }
}

/// The classification in the mesh's numbering, before renumbering.
#[derive(Clone, Debug)]
pub struct SkinClasses {
    /// Per vertex: surface, edge, corner or interior.
    pub class: Vec<VertexClass>,
    /// Per vertex: the projector onto the directions it may slide in.
    pub projector: Vec<Mat3>,
    /// Per vertex: indices into `primitives` it is projected onto.
    pub candidates: Csr,
    /// Triangles of the boundary, and segments `[a, b, b]` of its feature curves.
    pub primitives: Vec<[Vec3; 3]>,
}

fn norm(a: &Vec3) -> f64 {
    dot(a, a).sqrt()
}

pub(crate) const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// I - n n^T
pub(crate) fn plane_projector(n: &Vec3) -> Mat3 {
    let mut p = IDENTITY;
    for i in 0..3 {
        for j in 0..3 {
            p[i][j] -= n[i] * n[j];
        }
    }
    p
}

/// t t^T
pub(crate) fn line_projector(t: &Vec3) -> Mat3 {
    let mut p = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            p[i][j] = t[i] * t[j];
        }
    }
    p
}

/// A skin facet: its vertices (mesh numbering) and outward normal scaled by its area.
struct Facet {
    vertices: Vec<u32>,
    normal: Vec3,
}

/// Facets used by one element, with normals pointing away from that element.
fn skin_facets(mesh: &Mesh, points: &[Vec3]) -> Vec<Facet> {
    // a polyhedron's facets are its stored faces, the other kinds' their tables
    let facets_of = |e: usize| -> Vec<Vec<u32>> {
        let vs = mesh.element(e);
        match mesh.kinds[e] {
            ElementKind::Polyhedron => mesh.faces.of(e).map(|f| f.to_vec()).collect(),
            kind => kind
                .facets()
                .iter()
                .map(|local| local.iter().map(|&l| vs[l]).collect())
                .collect(),
        }
    };
    let mut seen: HashMap<Vec<u32>, (u32, usize, usize)> = HashMap::new();
    for e in 0..mesh.num_elements() {
        for (f, vertices) in facets_of(e).into_iter().enumerate() {
            let mut key = vertices;
            key.sort_unstable();
            seen.entry(key).or_insert((0, e, f)).0 += 1;
        }
    }
    let mut once: Vec<(usize, usize)> = seen.values().filter(|s| s.0 == 1).map(|s| (s.1, s.2)).collect();
    once.sort_unstable();
    once.into_iter()
        .map(|(e, f)| {
            let vs = mesh.element(e);
            let vertices: Vec<u32> = facets_of(e).swap_remove(f);
            let centre = centroid(points, vs);
            let fc = centroid(points, &vertices);
            let mut normal = if vertices.len() == 2 {
                // 2D: the in-plane normal of the edge
                let t = sub(&points[vertices[1] as usize], &points[vertices[0] as usize]);
                [t[1], -t[0], 0.0]
            } else {
                // Newell's normal: twice the area, for any planar polygon
                let mut n = [0.0; 3];
                for i in 0..vertices.len() {
                    let a = &points[vertices[i] as usize];
                    let b = &points[vertices[(i + 1) % vertices.len()] as usize];
                    let c = cross(&sub(a, &fc), &sub(b, &fc));
                    for k in 0..3 {
                        n[k] += 0.5 * c[k];
                    }
                }
                n
            };
            if dot(&normal, &sub(&fc, &centre)) < 0.0 {
                normal = normal.map(|c| -c);
            }
            Facet { vertices, normal }
        })
        .collect()
}

/// The vertices of each skin facet of `mesh` (faces in 3D, edges in 2D).
pub(crate) fn skin_faces(mesh: &Mesh, points: &[Vec3]) -> Vec<Vec<u32>> {
    skin_facets(mesh, points).into_iter().map(|f| f.vertices).collect()
}

fn centroid(points: &[Vec3], vs: &[u32]) -> Vec3 {
    let mut c = [0.0; 3];
    for &v in vs {
        for k in 0..3 {
            c[k] += points[v as usize][k] / vs.len() as f64;
        }
    }
    c
}

fn edge_key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// Feature edges found by their dihedral angle alone, less every chain that
/// ends nowhere: an edge with an end on no other feature edge is dropped,
/// again and again, unless `sure` keeps it (a rim, a curve of the file). The
/// features a user built form closed curves or meet at corners; a poor skin
/// of a smooth surface (vertices slid along it, its facets now skewed) has
/// edges sharper than the feature angle too, but they stand alone or in
/// short open chains and would fix or pin the vertices on them.
pub(crate) fn without_dangling(mut edges: Vec<(u32, u32)>, sure: impl Fn(&(u32, u32)) -> bool) -> Vec<(u32, u32)> {
    loop {
        let mut degree: HashMap<u32, usize> = HashMap::new();
        for &(a, b) in &edges {
            *degree.entry(a).or_default() += 1;
            *degree.entry(b).or_default() += 1;
        }
        let before = edges.len();
        edges.retain(|e| sure(e) || (degree[&e.0] > 1 && degree[&e.1] > 1));
        if edges.len() == before {
            return edges;
        }
    }
}

/// The edges of a mesh's line cells (its file's curves: Gmsh's curve
/// elements, VTK lines): on a surface mesh they are feature curves.
fn file_curves(mesh: &Mesh) -> Vec<(u32, u32)> {
    mesh.lower
        .iter()
        .filter(|(k, _)| *k == crate::mesh::LowerKind::Line)
        .flat_map(|(_, vs)| vs.windows(2).map(|w| (w[0], w[1])))
        .collect()
}

/// The skin's classes where the boundary slides (`None` where it is fixed):
/// on the geometry `opts.surface` when one is given (which makes it slide),
/// else on the mesh's own skin.
pub fn skin_classes(
    mesh: &Mesh,
    points: &[Vec3],
    opts: &super::ProblemOptions,
) -> crate::error::Result<Option<SkinClasses>> {
    let surface_mesh = crate::mesh::plane::is_surface(mesh, points);
    if surface_mesh {
        crate::mesh::topology::check_surface(mesh).map_err(crate::error::Error::InvalidMesh)?;
    }
    let angle = opts.boundary.feature_angle;
    let classes = match opts.surface {
        Some(g) => {
            if mesh.dim() != 3 && !surface_mesh {
                return Err(crate::error::Error::Unsupported(
                    "a surface geometry needs a volume or surface mesh: a planar mesh's boundary slides along its own sides"
                        .into(),
                ));
            }
            super::geometry::Geometry::new(g, &g.points, angle, &[])?.classify(mesh, points)?
        }
        // a surface mesh slides on itself: its faces are the geometry
        None if surface_mesh => {
            super::geometry::Geometry::new(mesh, points, angle, &file_curves(mesh))?.classify(mesh, points)?
        }
        None if opts.boundary.mode == BoundaryMode::Slide => classify(mesh, points, angle),
        None => return Ok(None),
    };
    Ok(Some(if surface_mesh && opts.boundary.mode == BoundaryMode::Fixed {
        // its skin: the open rim, on edges of one element only
        classes.keeping(&crate::mesh::topology::skin_vertices(mesh))
    } else {
        classes
    }))
}

/// The faces the sliding vertices of `mesh` lie on: a surface mesh's own
/// elements, a volume or planar mesh's skin facets.
pub(crate) fn sliding_faces(mesh: &Mesh, points: &[Vec3]) -> Vec<Vec<u32>> {
    if crate::mesh::plane::is_surface(mesh, points) {
        (0..mesh.num_elements()).map(|e| mesh.element(e).to_vec()).collect()
    } else {
        skin_faces(mesh, points)
    }
}

/// Classifies the skin of `mesh` at `points` (the coordinates the problem is
/// built in) and builds every sliding vertex's projector and candidates.
pub fn classify(mesh: &Mesh, points: &[Vec3], feature_angle: f64) -> SkinClasses {
    let n = mesh.num_points();
    let planar = mesh.dim() == 2;
    let facets = skin_facets(mesh, points);
    let cos_feature = feature_angle.to_radians().cos();
    // skin edges and the facets on each
    let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    if planar {
        for (f, fc) in facets.iter().enumerate() {
            edges
                .entry(edge_key(fc.vertices[0], fc.vertices[1]))
                .or_default()
                .push(f as u32);
        }
    } else {
        for (f, fc) in facets.iter().enumerate() {
            let k = fc.vertices.len();
            for i in 0..k {
                edges
                    .entry(edge_key(fc.vertices[i], fc.vertices[(i + 1) % k]))
                    .or_default()
                    .push(f as u32);
            }
        }
    }
    let apart = |a: &Vec3, b: &Vec3| dot(a, b) < cos_feature * norm(a) * norm(b);
    // a facet's normal with those of its neighbours across its other edges:
    // a crease whose two sides, so widened, meet within the feature angle is
    // one skewed facet on a smooth surface (a skin slid along a sphere), not
    // an edge a user built, whose sides stay apart
    let side = |f: u32, skip: (u32, u32)| -> Vec3 {
        let vs = &facets[f as usize].vertices;
        let mut s = facets[f as usize].normal;
        for i in 0..vs.len() {
            let key = edge_key(vs[i], vs[(i + 1) % vs.len()]);
            if key == skip {
                continue;
            }
            if let [g, h] = edges[&key][..] {
                let o = if g == f { h } else { g };
                for k in 0..3 {
                    s[k] += facets[o as usize].normal[k];
                }
            }
        }
        s
    };
    let is_feature = |key: &(u32, u32), fs: &Vec<u32>| -> bool {
        match fs[..] {
            [f, g] if !planar => {
                apart(&facets[f as usize].normal, &facets[g as usize].normal) && apart(&side(f, *key), &side(g, *key))
            }
            _ => true,
        }
    };
    let mut feature_edges: Vec<(u32, u32)> = edges
        .iter()
        .filter(|(k, fs)| is_feature(k, fs))
        .map(|(k, _)| *k)
        .collect();
    feature_edges.sort_unstable();
    if !planar {
        let sure = |k: &(u32, u32)| edges[k].len() != 2;
        feature_edges = without_dangling(feature_edges, sure);
    }
    let feature_set: std::collections::HashSet<(u32, u32)> = feature_edges.iter().copied().collect();
    let feature_at = Csr::from_pairs(
        n,
        feature_edges
            .iter()
            .enumerate()
            .flat_map(|(i, &(a, b))| [(a, i as u32), (b, i as u32)])
            .collect::<Vec<_>>()
            .into_iter(),
    );
    let facets_at = Csr::from_pairs(
        n,
        facets
            .iter()
            .enumerate()
            .flat_map(|(f, fc)| fc.vertices.iter().map(move |&v| (v, f as u32)))
            .collect::<Vec<_>>()
            .into_iter(),
    );

    // classes and projectors
    let mut class = vec![VertexClass::Interior; n];
    let mut projector = vec![IDENTITY; n];
    for v in 0..n {
        if facets_at.of(v).is_empty() {
            continue;
        }
        let fe = feature_at.of(v);
        class[v] = match fe.len() {
            0 if !planar => {
                let mut nv = [0.0; 3];
                for &f in facets_at.of(v) {
                    for k in 0..3 {
                        nv[k] += facets[f as usize].normal[k];
                    }
                }
                projector[v] = plane_projector(&unit(nv));
                VertexClass::Surface
            }
            2 => {
                let other = |i: u32| {
                    let (a, b) = feature_edges[i as usize];
                    if a as usize == v { b } else { a }
                };
                let xv = &points[v];
                let e1 = unit(sub(&points[other(fe[0]) as usize], xv));
                let e2 = unit(sub(xv, &points[other(fe[1]) as usize]));
                // on a straight curve e1 and e2 are the same direction
                if dot(&e1, &e2) >= cos_feature {
                    projector[v] = line_projector(&unit([e1[0] + e2[0], e1[1] + e2[1], e1[2] + e2[2]]));
                    VertexClass::Edge
                } else {
                    VertexClass::Corner
                }
            }
            _ => VertexClass::Corner,
        };
        if class[v] == VertexClass::Corner {
            projector[v] = IDENTITY;
        }
    }

    // primitives: every skin facet's triangles, then every feature segment
    let mut primitives: Vec<[Vec3; 3]> = Vec::new();
    let mut facet_prims: Vec<(u32, u32)> = Vec::with_capacity(facets.len());
    if !planar {
        for fc in &facets {
            let first = primitives.len() as u32;
            let p = |i: usize| points[fc.vertices[i] as usize];
            for i in 1..fc.vertices.len() - 1 {
                primitives.push([p(0), p(i), p(i + 1)]);
            }
            facet_prims.push((first, primitives.len() as u32));
        }
    }
    let seg0 = primitives.len() as u32;
    for &(a, b) in &feature_edges {
        let (pa, pb) = (points[a as usize], points[b as usize]);
        primitives.push([pa, pb, pb]);
    }

    // candidates: breadth-first, two rings, within the patch or along the curve
    const RINGS: usize = 2;
    let mut pairs: Vec<(u32, u32)> = Vec::new();
    let mut facet_seen = vec![usize::MAX; facets.len()];
    let mut edge_seen = vec![usize::MAX; feature_edges.len()];
    for v in 0..n {
        match class[v] {
            VertexClass::Surface => {
                let mut queue: VecDeque<(u32, usize)> = facets_at.of(v).iter().map(|&f| (f, 0)).collect();
                for &f in facets_at.of(v) {
                    facet_seen[f as usize] = v;
                }
                while let Some((f, depth)) = queue.pop_front() {
                    let (a, b) = facet_prims[f as usize];
                    pairs.extend((a..b).map(|p| (v as u32, p)));
                    if depth == RINGS {
                        continue;
                    }
                    let vs = &facets[f as usize].vertices;
                    for i in 0..vs.len() {
                        let key = edge_key(vs[i], vs[(i + 1) % vs.len()]);
                        if feature_set.contains(&key) {
                            continue;
                        }
                        for &g in &edges[&key] {
                            if facet_seen[g as usize] != v {
                                facet_seen[g as usize] = v;
                                queue.push_back((g, depth + 1));
                            }
                        }
                    }
                }
            }
            VertexClass::Edge => {
                let mut queue: VecDeque<(u32, usize)> = VecDeque::from([(v as u32, 0)]);
                let mut visited = vec![v as u32];
                while let Some((w, depth)) = queue.pop_front() {
                    for &e in feature_at.of(w as usize) {
                        if edge_seen[e as usize] != v {
                            edge_seen[e as usize] = v;
                            pairs.push((v as u32, seg0 + e));
                        }
                        let (a, b) = feature_edges[e as usize];
                        let u = if a == w { b } else { a };
                        if depth < RINGS && class[u as usize] == VertexClass::Edge && !visited.contains(&u) {
                            visited.push(u);
                            queue.push_back((u, depth + 1));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    pairs.sort_unstable();
    let candidates = Csr::from_pairs(n, pairs.into_iter());
    SkinClasses {
        class,
        projector,
        candidates,
        primitives,
    }
}

impl SkinClasses {
    /// These classes with the vertices `kept` made corners: they stay.
    fn keeping(mut self, kept: &[bool]) -> SkinClasses {
        let mut pairs = Vec::new();
        for (v, &k) in kept.iter().enumerate() {
            if k {
                if self.class[v] != VertexClass::Interior {
                    self.class[v] = VertexClass::Corner;
                }
                self.projector[v] = IDENTITY;
            } else {
                pairs.extend(self.candidates.of(v).iter().map(|&c| (v as u32, c)));
            }
        }
        self.candidates = Csr::from_pairs(kept.len(), pairs.into_iter());
        self
    }

    /// The constraints of the vertices that slide (`moves[v]`: not fixed by
    /// the user), in the problem's numbering.
    pub fn renumber(&self, numbering: &Numbering, moves: impl Fn(usize) -> bool) -> Sliding {
        let order = &numbering.order;
        let mut counts = [0usize; 3];
        for c in &self.class {
            match c {
                VertexClass::Surface => counts[0] += 1,
                VertexClass::Edge => counts[1] += 1,
                VertexClass::Corner => counts[2] += 1,
                VertexClass::Interior => {}
            }
        }
        let projector = order
            .iter()
            .map(|&o| {
                if moves(o as usize) {
                    self.projector[o as usize]
                } else {
                    IDENTITY
                }
            })
            .collect();
        let pairs: Vec<(u32, u32)> = order
            .iter()
            .enumerate()
            .filter(|&(_, &o)| moves(o as usize))
            .flat_map(|(new, &o)| self.candidates.of(o as usize).iter().map(move |&p| (new as u32, p)))
            .collect();
        Sliding {
            projector,
            candidates: Csr::from_pairs(order.len(), pairs.into_iter()),
            primitives: self.primitives.clone(),
            counts,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::without_dangling;

    /// A closed loop and a junction of three loops stay; a chain that ends
    /// nowhere goes, unless `sure` keeps it.
    #[test]
    fn dangling_feature_chains_are_dropped() {
        let loop3 = vec![(0, 1), (1, 2), (0, 2)];
        assert_eq!(without_dangling(loop3.clone(), |_| false), loop3);
        let mut with_tail = loop3.clone();
        with_tail.extend([(2, 3), (3, 4)]);
        assert_eq!(without_dangling(with_tail.clone(), |_| false), loop3);
        assert_eq!(without_dangling(with_tail.clone(), |&(a, _)| a == 3), with_tail);
        assert!(without_dangling(vec![(5, 6), (6, 7)], |_| false).is_empty());
    }
}
