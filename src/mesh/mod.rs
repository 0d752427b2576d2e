//! The mesh model: coordinates and elements, nothing about metrics or devices.

pub mod color;
pub mod data;
pub mod element;
pub mod fixing;
pub mod frame;
pub mod order;
pub mod plane;
pub mod polyhedron;
pub mod polymesh;
pub mod sweep_order;
// Public only for the integration tests and benches: mesh topology internals.
#[doc(hidden)]
pub mod topology;

pub use data::{DataArray, ElementSet, MeshData, NodeSet, PhysicalName, ValueType, Values};
pub use element::ElementKind;
pub use polyhedron::Faces;

use crate::error::{Error, Result};
use std::borrow::Cow;

/// Cells of lower dimension than the mesh (Gmsh and Medit boundary lines,
/// triangles, points). They are kept for round trips and their vertices are
/// treated as fixed; they are never optimised.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum LowerKind {
    /// A point (one vertex).
    Vertex,
    /// A 2-node line.
    Line,
    /// A 3-node triangle.
    Triangle,
    /// A 4-node quadrilateral.
    Quadrilateral,
}

impl LowerKind {
    /// Vertices of a cell of this kind.
    pub fn num_vertices(self) -> usize {
        match self {
            LowerKind::Vertex => 1,
            LowerKind::Line => 2,
            LowerKind::Triangle => 3,
            LowerKind::Quadrilateral => 4,
        }
    }

    /// VTK cell type id (`VTK_VERTEX`, `VTK_LINE`, `VTK_TRIANGLE`, `VTK_QUAD`).
    pub fn vtk_id(self) -> u8 {
        match self {
            LowerKind::Vertex => 1,
            LowerKind::Line => 3,
            LowerKind::Triangle => 5,
            LowerKind::Quadrilateral => 9,
        }
    }
}

/// An unstructured mesh: points, elements of mixed kinds (in file order), optional
/// boundary cells, and user-fixed vertex flags.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Mesh {
    /// Coordinates; planar meshes keep their (constant) z so files round-trip.
    pub points: Vec<[f64; 3]>,
    /// Kind of each element.
    pub kinds: Vec<ElementKind>,
    /// CSR offsets into `conn`, `kinds.len() + 1` entries.
    pub offsets: Vec<usize>,
    /// Vertex ids of all elements, concatenated.
    pub conn: Vec<u32>,
    /// Faces of the polyhedral elements (empty when there are none).
    pub faces: Faces,
    /// Lower-dimensional cells (boundary lines/faces, points) read from a file.
    pub lower: Vec<(LowerKind, Vec<u32>)>,
    /// Vertices the user marked fixed (empty means none).
    pub fixed: Vec<bool>,
    /// The input file's point, cell and field arrays and Gmsh group names,
    /// written back where the output format can hold them.
    pub data: MeshData,
}

impl Mesh {
    /// A mesh of these points with no elements yet.
    pub fn new(points: Vec<[f64; 3]>) -> Self {
        Mesh {
            points,
            offsets: vec![0],
            ..Default::default()
        }
    }

    /// Appends an element of a kind with a fixed vertex count (a polyhedron
    /// needs its faces: [`push_polyhedron`](Self::push_polyhedron)).
    pub fn push_element(&mut self, kind: ElementKind, vertices: &[u32]) {
        debug_assert_eq!(Some(vertices.len()), kind.num_vertices());
        self.faces.push_none(self.kinds.len());
        self.push_vertices(kind, vertices);
    }

    /// Appends a polyhedron with `vertices` and `faces` (mesh vertex ids,
    /// each face counter-clockwise seen from outside).
    pub fn push_polyhedron<'a>(&mut self, vertices: &[u32], faces: impl IntoIterator<Item = &'a [u32]>) {
        self.faces.push(self.kinds.len(), faces);
        self.push_vertices(ElementKind::Polyhedron, vertices);
    }

    fn push_vertices(&mut self, kind: ElementKind, vertices: &[u32]) {
        if self.offsets.is_empty() {
            self.offsets.push(0);
        }
        self.kinds.push(kind);
        self.conn.extend_from_slice(vertices);
        self.offsets.push(self.conn.len());
    }

    /// The corners of element `e` (local vertex indices, see
    /// [`ElementKind::corners`]); a polyhedron's are computed from its faces,
    /// and the error names the vertex and the problem (see
    /// [`polyhedron::corners`]).
    pub fn element_corners(&self, e: usize) -> std::result::Result<Cow<'static, [[usize; 4]]>, String> {
        match self.kinds[e] {
            ElementKind::Polyhedron => polyhedron::corners(self.element(e), self.faces.of(e)).map(Cow::Owned),
            kind => Ok(Cow::Borrowed(kind.corners())),
        }
    }

    /// The corners of element `e` the objective and the metric reports
    /// evaluate ([`ElementKind::optimised_corners`]; a polyhedron all of them).
    pub fn optimised_corners(&self, e: usize) -> std::result::Result<Cow<'static, [[usize; 4]]>, String> {
        match self.kinds[e] {
            ElementKind::Polyhedron => self.element_corners(e),
            kind => Ok(Cow::Borrowed(kind.optimised_corners())),
        }
    }

    /// Element `e`'s edges as mesh vertex ids (each once).
    pub fn element_edges(&self, e: usize) -> Vec<[u32; 2]> {
        let vs = self.element(e);
        match self.kinds[e] {
            ElementKind::Polyhedron => {
                let mut out: Vec<[u32; 2]> = Vec::new();
                for f in self.faces.of(e) {
                    for (i, &a) in f.iter().enumerate() {
                        let b = f[(i + 1) % f.len()];
                        let edge = [a.min(b), a.max(b)];
                        if !out.contains(&edge) {
                            out.push(edge);
                        }
                    }
                }
                out
            }
            kind => kind.edges().iter().map(|&[a, b]| [vs[a], vs[b]]).collect(),
        }
    }

    /// Number of points (vertices).
    pub fn num_points(&self) -> usize {
        self.points.len()
    }

    /// Number of elements.
    pub fn num_elements(&self) -> usize {
        self.kinds.len()
    }

    /// The vertex ids of element `e`.
    pub fn element(&self, e: usize) -> &[u32] {
        &self.conn[self.offsets[e]..self.offsets[e + 1]]
    }

    /// Metric dimension: 3 if any element is a volume element, else 2.
    pub fn dim(&self) -> usize {
        if self.kinds.iter().any(|k| k.dim() == 3) { 3 } else { 2 }
    }

    /// The elements `elems` and the vertices `verts` (both ascending; `verts`
    /// must hold every vertex of `elems`) as a mesh of their own, numbered in
    /// that order, with their fixed flags; no arrays.
    pub fn cut(&self, verts: &[usize], elems: &[usize]) -> Mesh {
        let mut local = std::collections::HashMap::with_capacity(verts.len());
        for (l, &v) in verts.iter().enumerate() {
            local.insert(v as u32, l as u32);
        }
        let mut piece = Mesh::new(verts.iter().map(|&v| self.points[v]).collect());
        for &e in elems {
            let vs: Vec<u32> = self.element(e).iter().map(|v| local[v]).collect();
            if self.kinds[e] == ElementKind::Polyhedron {
                let faces: Vec<Vec<u32>> = self.faces.of(e).map(|f| f.iter().map(|v| local[v]).collect()).collect();
                piece.push_polyhedron(&vs, faces.iter().map(Vec::as_slice));
            } else {
                piece.push_element(self.kinds[e], &vs);
            }
        }
        if !self.fixed.is_empty() {
            piece.fixed = verts.iter().map(|&v| self.fixed[v]).collect();
        }
        piece
    }

    /// Per vertex, whether an element uses it.
    pub fn used_vertices(&self) -> Vec<bool> {
        let mut used = vec![false; self.points.len()];
        for &v in &self.conn {
            if let Some(u) = used.get_mut(v as usize) {
                *u = true;
            }
        }
        used
    }

    /// The vertices no element uses (ascending). They are part of the mesh
    /// (a file keeps them, with their point data) but not of any problem:
    /// smoothing and untangling leave them where they are.
    pub fn unused_vertices(&self) -> Vec<usize> {
        let used = self.used_vertices();
        (0..used.len()).filter(|&v| !used[v]).collect()
    }

    /// The vertices elements use (ascending) and the mesh restricted to
    /// them ([`Mesh::keep_vertices`]); `None` when every vertex is used.
    pub fn without_unused(&self) -> Option<(Vec<usize>, Mesh)> {
        let used = self.used_vertices();
        if used.iter().all(|&u| u) {
            return None;
        }
        let keep: Vec<usize> = (0..used.len()).filter(|&v| used[v]).collect();
        let mesh = self.keep_vertices(&keep);
        Some((keep, mesh))
    }

    /// The mesh restricted to the vertices `keep` (ascending), renumbered in
    /// that order: every element, the fixed flags, the point arrays of
    /// those vertices, the boundary cells (and their arrays) whose vertices
    /// are all kept, the cell and field arrays and group names. An element
    /// vertex not in `keep` becomes `u32::MAX` (which no check accepts).
    pub fn keep_vertices(&self, keep: &[usize]) -> Mesh {
        let mut local = vec![u32::MAX; self.points.len()];
        for (l, &v) in keep.iter().enumerate() {
            local[v] = l as u32;
        }
        let map = |v: &u32| local.get(*v as usize).copied().unwrap_or(u32::MAX);
        let lower: Vec<usize> = (0..self.lower.len())
            .filter(|&c| self.lower[c].1.iter().all(|v| map(v) != u32::MAX))
            .collect();
        let mut data = self.data.clone();
        data.point = data.point.iter().map(|a| a.select(keep)).collect();
        if lower.len() != self.lower.len() {
            data.lower = data.lower.iter().map(|a| a.select(&lower)).collect();
        }
        data.keep_in_sets(self.points.len(), keep, self.lower.len(), &lower);
        // its faces name the points as they were numbered
        data.polymesh = None;
        Mesh {
            points: keep.iter().map(|&v| self.points[v]).collect(),
            kinds: self.kinds.clone(),
            offsets: self.offsets.clone(),
            conn: self.conn.iter().map(map).collect(),
            faces: Faces {
                conn: self.faces.conn.iter().map(map).collect(),
                ..self.faces.clone()
            },
            lower: lower
                .iter()
                .map(|&c| (self.lower[c].0, self.lower[c].1.iter().map(map).collect()))
                .collect(),
            fixed: if self.fixed.is_empty() {
                Vec::new()
            } else {
                keep.iter().map(|&v| self.fixed[v]).collect()
            },
            data,
        }
    }

    /// Did the user mark vertex `v` fixed?
    pub fn is_fixed(&self, v: usize) -> bool {
        self.fixed.get(v).copied().unwrap_or(false)
    }

    /// Element ids per kind, for reports.
    pub fn count_kind(&self, kind: ElementKind) -> usize {
        self.kinds.iter().filter(|&&k| k == kind).count()
    }

    /// Structural checks every reader and generator runs: non-empty, one
    /// dimension, finite coordinates, indices in range, no repeated vertex in an
    /// element, no coincident vertices unless both are fixed (vertices no
    /// element uses are allowed and take no part in that check).
    pub fn validate(&self) -> Result<()> {
        self.validate_structure()?;
        self.validate_vertices()
    }

    /// The checks of [`validate`](Self::validate) that a piece of a
    /// partitioned file passes too: every element well formed, arrays of the
    /// right lengths; no check that each vertex is used once and by something.
    pub fn validate_structure(&self) -> Result<()> {
        if self.points.is_empty() {
            return Err(Error::InvalidMesh("mesh has no vertices".into()));
        }
        if self.kinds.is_empty() {
            return Err(Error::InvalidMesh("mesh has no elements".into()));
        }
        if self.offsets.len() != self.kinds.len() + 1 || *self.offsets.last().unwrap() != self.conn.len() {
            return Err(Error::InvalidMesh("element offsets do not match connectivity".into()));
        }
        let dim = self.dim();
        if let Some(e) = self.kinds.iter().position(|k| k.dim() != dim) {
            return Err(Error::InvalidMesh(format!(
                "element {e} is a {} ({}D) in a {dim}D mesh; mixed 2D and 3D elements are not supported",
                self.kinds[e],
                self.kinds[e].dim()
            )));
        }
        if !self.fixed.is_empty() && self.fixed.len() != self.points.len() {
            return Err(Error::InvalidMesh(format!(
                "fixed flags cover {} vertices but the mesh has {}",
                self.fixed.len(),
                self.points.len()
            )));
        }
        if let Some(v) = self.points.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
            return Err(Error::InvalidMesh(format!(
                "vertex {v} has a non-finite coordinate {:?}",
                self.points[v]
            )));
        }
        let n = self.points.len();
        let polyhedra = self.kinds.contains(&ElementKind::Polyhedron);
        if polyhedra
            && (self.faces.elem.len() != self.kinds.len() + 1
                || self.faces.offsets.last() != Some(&self.faces.conn.len()))
        {
            return Err(Error::InvalidMesh(
                "polyhedron face offsets do not match the elements".into(),
            ));
        }
        // every element checked in parallel first; the loop below then runs
        // only to name the first bad one, or for polyhedra (small meshes)
        let plain = |e: usize| {
            let vs = self.element(e);
            self.kinds[e].num_vertices() == Some(vs.len())
                && vs
                    .iter()
                    .enumerate()
                    .all(|(i, &v)| (v as usize) < n && !vs[..i].contains(&v))
        };
        let all_plain = !polyhedra && {
            use rayon::prelude::*;
            (0..self.num_elements())
                .into_par_iter()
                .with_min_len(1 << 12)
                .all(plain)
        };
        for e in (0..self.num_elements()).filter(|_| !all_plain) {
            let vs = self.element(e);
            if let Some(nv) = self.kinds[e].num_vertices().filter(|&nv| nv != vs.len()) {
                return Err(Error::InvalidMesh(format!(
                    "element {e} ({}) has {} vertices, expected {nv}",
                    self.kinds[e],
                    vs.len(),
                )));
            }
            if polyhedra && (self.kinds[e] == ElementKind::Polyhedron) != (self.faces.of(e).next().is_some()) {
                return Err(Error::InvalidMesh(format!(
                    "element {e} ({}) {} faces",
                    self.kinds[e],
                    if self.kinds[e] == ElementKind::Polyhedron {
                        "has no"
                    } else {
                        "has polyhedron"
                    }
                )));
            }
            for (i, &v) in vs.iter().enumerate() {
                if v as usize >= n {
                    return Err(Error::InvalidMesh(format!(
                        "element {e} refers to vertex {v}, but the mesh has only {n} vertices (ids 0..{})",
                        n - 1
                    )));
                }
                if vs[..i].contains(&v) {
                    return Err(Error::InvalidMesh(format!("element {e} uses vertex {v} twice: {vs:?}")));
                }
            }
            if self.kinds[e] == ElementKind::Polyhedron {
                if let Some(&v) = self.faces.of(e).flatten().find(|&&v| v as usize >= n) {
                    return Err(Error::InvalidMesh(format!(
                        "element {e} (polyhedron) has a face with vertex {v}, but the mesh has only {n} vertices"
                    )));
                }
                self.element_corners(e)
                    .map_err(|m| Error::InvalidMesh(format!("element {e} (polyhedron): {m}")))?;
            }
        }
        for (kind, vs) in &self.lower {
            if vs.len() != kind.num_vertices() || vs.iter().any(|&v| v as usize >= n) {
                return Err(Error::InvalidMesh(format!(
                    "boundary cell {kind:?} {vs:?} is malformed"
                )));
            }
        }
        self.data.check(n, self.num_elements(), self.lower.len())
    }

    /// No duplicate elements, no free vertex on top of another (vertices used
    /// by no element are allowed: they never move, see
    /// [`unused_vertices`](Self::unused_vertices)).
    fn validate_vertices(&self) -> Result<()> {
        let used = self.used_vertices();
        if let Some((a, b)) = self.duplicate_elements() {
            let mut vs = self.element(b).to_vec();
            vs.sort_unstable();
            return Err(Error::InvalidMesh(format!(
                "elements {a} and {b} are duplicates: both have the vertices {vs:?}"
            )));
        }
        let sorted: Vec<usize> = {
            use rayon::prelude::*;
            // Sorting the coordinates themselves, as integers ordered like
            // the (finite) floats, streams through memory; comparing through
            // indices missed the cache on every comparison. -0.0 becomes 0.0
            // so that points equal as floats stay neighbours.
            let key = |x: f64| {
                let b = (x + 0.0).to_bits();
                if b >> 63 == 1 { !b } else { b | 1 << 63 }
            };
            let mut keys: Vec<([u64; 3], u32)> = self
                .points
                .par_iter()
                .enumerate()
                // a vertex no element uses never moves: it may sit anywhere
                .filter(|&(i, _)| used[i])
                .map(|(i, p)| ([key(p[0]), key(p[1]), key(p[2])], i as u32))
                .collect();
            keys.par_sort_unstable();
            keys.into_par_iter().map(|(_, i)| i as usize).collect()
        };
        if let Some(w) = sorted
            .windows(2)
            // Coincident fixed vertices never move (real meshes have them on
            // seams, e.g. Mesquite's tire.vtk), so only a free duplicate is an error.
            .find(|w| self.points[w[0]] == self.points[w[1]] && !(self.is_fixed(w[0]) && self.is_fixed(w[1])))
        {
            let (a, b) = (w[0].min(w[1]), w[0].max(w[1]));
            return Err(Error::InvalidMesh(format!(
                "vertices {a} and {b} are duplicates: both at {:?}",
                self.points[a]
            )));
        }
        Ok(())
    }

    /// The first pair of elements (in file order) with the same vertex set.
    pub fn duplicate_elements(&self) -> Option<(usize, usize)> {
        use rayon::prelude::*;
        // Elements with the same vertex set share their smallest vertex:
        // bucketing by it (a counting sort) leaves small independent groups,
        // so the check is linear and parallel instead of hashing every
        // element's sorted vertex list.
        let ne = self.num_elements();
        let lowest: Vec<u32> = (0..ne)
            .into_par_iter()
            .map(|e| self.element(e).iter().copied().min().unwrap_or(u32::MAX))
            .collect();
        let nb = lowest
            .iter()
            .copied()
            .filter(|&v| v != u32::MAX)
            .max()
            .map_or(0, |m| m as usize + 1);
        let buckets = topology::Csr::from_pairs(
            nb,
            lowest
                .iter()
                .enumerate()
                .filter(|&(_, &v)| v != u32::MAX)
                .map(|(e, &v)| (v, e as u32)),
        );
        // what the sequential scan in file order finds first: the smallest
        // second occurrence of a vertex set, paired with the set's first
        (0..nb)
            .into_par_iter()
            .with_min_len(4096)
            .map_init(
                || {
                    (
                        Vec::<u32>::new(),
                        Vec::<usize>::new(),
                        Vec::<usize>::new(),
                        Vec::<u64>::new(),
                    )
                },
                |(keys, starts, idx, prints), v| {
                    let group = buckets.of(v);
                    if group.len() < 2 {
                        return None;
                    }
                    // equal vertex sets have equal fingerprints (a sum over
                    // the set), so a group whose fingerprints all differ,
                    // nearly every group, needs no sort of its vertex lists
                    prints.clear();
                    prints.extend(group.iter().map(|&e| {
                        let vs = self.element(e as usize);
                        vs.iter().fold(vs.len() as u64, |h, &v| {
                            h.wrapping_add((v as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15).rotate_left(29))
                        })
                    }));
                    prints.sort_unstable();
                    if prints.windows(2).all(|w| w[0] != w[1]) {
                        return None;
                    }
                    keys.clear();
                    starts.clear();
                    for &e in group {
                        starts.push(keys.len());
                        let from = keys.len();
                        keys.extend_from_slice(self.element(e as usize));
                        keys[from..].sort_unstable();
                    }
                    starts.push(keys.len());
                    let key = |i: usize| &keys[starts[i]..starts[i + 1]];
                    idx.clear();
                    idx.extend(0..group.len());
                    // group is ascending, so ties keep file order
                    idx.sort_by(|&a, &b| key(a).cmp(key(b)).then(a.cmp(&b)));
                    idx.windows(2)
                        .filter(|w| key(w[0]) == key(w[1]))
                        .map(|w| (group[w[0]] as usize, group[w[1]] as usize))
                        // within a run of equal sets the smallest second
                        // element is the run's second, paired with its first
                        .min_by_key(|&(_, b)| b)
                },
            )
            .flatten()
            .min_by_key(|&(_, b)| b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first pair a scan in file order finds: the smallest second
    /// occurrence of a vertex set, with that set's first element.
    fn first_duplicate(mesh: &Mesh) -> Option<(usize, usize)> {
        let mut seen = std::collections::HashMap::new();
        for e in 0..mesh.num_elements() {
            let mut vs = mesh.element(e).to_vec();
            vs.sort_unstable();
            if let Some(&a) = seen.get(&vs) {
                return Some((a, e));
            }
            seen.insert(vs, e);
        }
        None
    }

    #[test]
    fn duplicate_elements_are_the_first_a_scan_in_file_order_finds() {
        let mut x = 12345u64;
        let mut next = |m: u64| {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (x >> 33) % m
        };
        for round in 0..40 {
            // few points, so groups sharing a lowest vertex are large
            let np = 8 + next(40) as usize;
            let mut mesh = Mesh::new((0..np).map(|i| [i as f64, 0.0, 0.0]).collect());
            for _ in 0..(20 + next(200)) {
                let mut vs = Vec::new();
                while vs.len() < 4 {
                    let v = next(np as u64) as u32;
                    if !vs.contains(&v) {
                        vs.push(v);
                    }
                }
                mesh.push_element(ElementKind::Tetrahedron, &vs);
            }
            if round % 2 == 0 {
                // a copy of an earlier element, its vertices in another order
                let e = next(mesh.num_elements() as u64) as usize;
                let mut vs = mesh.element(e).to_vec();
                vs.rotate_left(1 + next(3) as usize);
                mesh.push_element(ElementKind::Tetrahedron, &vs);
            }
            assert_eq!(mesh.duplicate_elements(), first_duplicate(&mesh), "round {round}");
        }
    }
}
