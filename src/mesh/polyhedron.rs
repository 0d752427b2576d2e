//! Polyhedral elements (VTK_POLYHEDRON): cells given by their faces.
//!
//! A polyhedron's corners are its vertices, each with the three cell edges
//! it must have (trivalent, as in the reference-Jacobian rezoning paper,
//! section 3): the corner model then treats it exactly like a hexahedron
//! corner. Faces are listed counter-clockwise seen from outside (VTK's
//! convention), which orders every corner's neighbours so that a valid cell
//! has positive corner determinants.

use crate::metric::mat3::Vec3;

/// The faces of a mesh's polyhedra in compressed rows: element `e`'s faces
/// are `elem[e]..elem[e + 1]` (an empty range for the other kinds), face `f`
/// has the vertices `conn[offsets[f]..offsets[f + 1]]` (mesh vertex ids).
/// `elem` stays empty while the mesh has no polyhedron.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Faces {
    /// Per element, the offset of its first face (`elements + 1` entries), or empty.
    pub elem: Vec<usize>,
    /// Per face, the offset of its first vertex in `conn` (`faces + 1` entries).
    pub offsets: Vec<usize>,
    /// The faces' vertex ids, concatenated.
    pub conn: Vec<u32>,
}

impl Faces {
    /// The faces of element `e` (none for a kind other than a polyhedron).
    pub fn of(&self, e: usize) -> impl Iterator<Item = &[u32]> + Clone + '_ {
        let range = match (self.elem.get(e), self.elem.get(e + 1)) {
            (Some(&a), Some(&b)) => a..b,
            _ => 0..0,
        };
        range.map(move |f| &self.conn[self.offsets[f]..self.offsets[f + 1]])
    }

    /// Number of faces stored (all polyhedra).
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// True when no face is stored.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Appends element `e`'s faces; `e` must be the next element, after
    /// `e` elements already accounted for.
    pub(crate) fn push<'a>(&mut self, e: usize, faces: impl IntoIterator<Item = &'a [u32]>) {
        if self.offsets.is_empty() {
            self.offsets.push(0);
        }
        self.pad(e);
        for f in faces {
            self.conn.extend_from_slice(f);
            self.offsets.push(self.conn.len());
        }
        self.elem.push(self.len());
    }

    /// Records that element `e` (not a polyhedron) has no faces, once any
    /// polyhedron is stored.
    pub(crate) fn push_none(&mut self, e: usize) {
        if !self.elem.is_empty() {
            self.pad(e);
            self.elem.push(self.len());
        }
    }

    fn pad(&mut self, e: usize) {
        if self.elem.is_empty() {
            self.elem.push(0);
        }
        while self.elem.len() < e + 1 {
            self.elem.push(self.len());
        }
    }
}

/// The vertex list of a cell given only by faces (as legacy VTK gives it):
/// every vertex once, in order of first appearance.
pub fn vertices_of_faces<'a>(faces: impl IntoIterator<Item = &'a [u32]>) -> Vec<u32> {
    let mut out: Vec<u32> = Vec::new();
    for f in faces {
        for &v in f {
            if !out.contains(&v) {
                out.push(v);
            }
        }
    }
    out
}

/// The corners of a polyhedron with vertices `vs` and `faces` (mesh vertex
/// ids): for each vertex, its local index followed by its three neighbours
/// along cell edges, ordered so that an outward-oriented convex cell has a
/// positive determinant. The message of an error names the vertex (mesh id)
/// and the problem: a face too short or with a repeated vertex, a face vertex
/// outside the cell, a vertex in no face, an edge not shared by exactly two
/// faces in opposite directions (the cell is open or its faces inconsistently
/// oriented), or a vertex without exactly three cell edges.
pub fn corners<'a>(vs: &[u32], faces: impl IntoIterator<Item = &'a [u32]>) -> Result<Vec<[usize; 4]>, String> {
    let local = |v: u32| vs.iter().position(|&w| w == v);
    let n = vs.len();
    // next[v]: for each face at v, (predecessor -> successor) in local ids;
    // the faces around v, seen from outside, chain these into one cycle
    let mut next: Vec<Vec<(usize, usize)>> = vec![Vec::new(); n];
    let mut directed: Vec<(usize, usize)> = Vec::new();
    for (fi, f) in faces.into_iter().enumerate() {
        if f.len() < 3 {
            return Err(format!("face {fi} has {} vertices; a face needs at least 3", f.len()));
        }
        let mut ids = Vec::with_capacity(f.len());
        for (i, &v) in f.iter().enumerate() {
            let l = local(v).ok_or_else(|| format!("face {fi} uses vertex {v}, which is not a vertex of the cell"))?;
            if f[..i].contains(&v) {
                return Err(format!("face {fi} uses vertex {v} twice"));
            }
            ids.push(l);
        }
        let k = ids.len();
        for i in 0..k {
            let (p, v, s) = (ids[(i + k - 1) % k], ids[i], ids[(i + 1) % k]);
            next[v].push((p, s));
            directed.push((v, s));
        }
    }
    directed.sort_unstable();
    if let Some(w) = directed.windows(2).find(|w| w[0] == w[1]) {
        let (a, b) = w[0];
        return Err(format!(
            "the edge from vertex {} to vertex {} is used twice in the same direction: \
             the faces are not consistently oriented",
            vs[a], vs[b]
        ));
    }
    for &(a, b) in &directed {
        if directed.binary_search(&(b, a)).is_err() {
            return Err(format!(
                "the edge between vertices {} and {} belongs to one face only: the cell is not closed \
                 (or its faces are not consistently oriented)",
                vs[a], vs[b]
            ));
        }
    }
    let mut out = Vec::with_capacity(n);
    for (v, links) in next.iter().enumerate() {
        if links.is_empty() {
            return Err(format!("vertex {} is in no face of the cell", vs[v]));
        }
        if links.len() != 3 {
            return Err(format!(
                "vertex {} has {} cell edges; a polyhedron's corners need exactly 3 (trivalent vertices)",
                vs[v],
                links.len()
            ));
        }
        let step = |a: usize| links.iter().find(|l| l.0 == a).map(|l| l.1);
        let a = links[0].0;
        let b = step(a);
        let c = b.and_then(step);
        match (b, c) {
            (Some(b), Some(c)) if step(c) == Some(a) => out.push([v, a, b, c]),
            _ => {
                return Err(format!(
                    "the faces at vertex {} do not form one fan around it (the cell is pinched there)",
                    vs[v]
                ));
            }
        }
    }
    Ok(out)
}

/// Signed volume of a polyhedron with `faces` (mesh vertex ids) at `points`:
/// positive when the faces are oriented outward. Each face is split into a
/// fan of triangles about its centroid (faces need not be planar), and the
/// tetrahedra they span with the cell's centroid are summed.
pub fn volume<'a>(points: &[Vec3], faces: impl IntoIterator<Item = &'a [u32]> + Clone) -> f64 {
    let (mut o, mut count) = ([0.0; 3], 0.0);
    for f in faces.clone() {
        for &v in f {
            for (oc, pc) in o.iter_mut().zip(points[v as usize]) {
                *oc += pc;
            }
            count += 1.0;
        }
    }
    let o = o.map(|c| c / count);
    let rel = |v: u32| -> Vec3 { std::array::from_fn(|i| points[v as usize][i] - o[i]) };
    let mut six_v = 0.0;
    for f in faces {
        let mut c = [0.0; 3];
        for &v in f {
            let p = rel(v);
            for i in 0..3 {
                c[i] += p[i] / f.len() as f64;
            }
        }
        for i in 0..f.len() {
            let (a, b) = (rel(f[i]), rel(f[(i + 1) % f.len()]));
            six_v += crate::metric::mat3::det(&[[c[0], a[0], b[0]], [c[1], a[1], b[1]], [c[2], a[2], b[2]]]);
        }
    }
    six_v / 6.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit cube as a polyhedron, faces outward (VTK's hexahedron numbering).
    fn cube() -> (Vec<Vec3>, Vec<Vec<u32>>) {
        let pts = (0..8)
            .map(|i| [[0.0, 1.0, 1.0, 0.0][i % 4], [0.0, 0.0, 1.0, 1.0][i % 4], (i / 4) as f64])
            .collect();
        let faces = vec![
            vec![0, 3, 2, 1],
            vec![4, 5, 6, 7],
            vec![0, 1, 5, 4],
            vec![1, 2, 6, 5],
            vec![2, 3, 7, 6],
            vec![3, 0, 4, 7],
        ];
        (pts, faces)
    }

    fn det_at(pts: &[Vec3], c: &[usize; 4]) -> f64 {
        let e = |k: usize| -> Vec3 { std::array::from_fn(|i| pts[c[k]][i] - pts[c[0]][i]) };
        let (a, b, d) = (e(1), e(2), e(3));
        crate::metric::mat3::det(&[[a[0], b[0], d[0]], [a[1], b[1], d[1]], [a[2], b[2], d[2]]])
    }

    #[test]
    fn cube_corners_are_the_hexahedron_corners_up_to_rotation() {
        let (pts, faces) = cube();
        let vs: Vec<u32> = (0..8).collect();
        let cs = corners(&vs, faces.iter().map(|f| &f[..])).unwrap();
        let hex = crate::ElementKind::Hexahedron.corners();
        for (c, h) in cs.iter().zip(hex) {
            assert_eq!(c[0], h[0]);
            let rot = |k: usize| [h[1 + k % 3], h[1 + (k + 1) % 3], h[1 + (k + 2) % 3]];
            assert!((0..3).any(|k| rot(k) == [c[1], c[2], c[3]]), "{c:?} vs {h:?}");
            assert_eq!(det_at(&pts, c), 1.0);
        }
        assert!((volume(&pts, faces.iter().map(|f| &f[..])) - 1.0).abs() < 1e-15);
        // reversed faces: negative volume and every corner negative
        let inward: Vec<Vec<u32>> = faces.iter().map(|f| f.iter().rev().copied().collect()).collect();
        let cs = corners(&vs, inward.iter().map(|f| &f[..])).unwrap();
        assert!(cs.iter().all(|c| det_at(&pts, c) < 0.0));
        assert!((volume(&pts, inward.iter().map(|f| &f[..])) + 1.0).abs() < 1e-15);
    }

    #[test]
    fn non_trivalent_open_and_misoriented_cells_are_named() {
        // a square pyramid: the apex has four edges
        let vs: Vec<u32> = (10..15).collect();
        let pyramid = [
            vec![10, 13, 12, 11],
            vec![10, 11, 14],
            vec![11, 12, 14],
            vec![12, 13, 14],
            vec![13, 10, 14],
        ];
        let e = corners(&vs, pyramid.iter().map(|f| &f[..])).unwrap_err();
        assert!(e.contains("vertex 14 has 4 cell edges"), "{e}");
        // a cube missing its top face
        let (_, faces) = cube();
        let all: Vec<u32> = (0..8).collect();
        let e = corners(&all, faces.iter().filter(|f| f[0] != 4).map(|f| &f[..])).unwrap_err();
        assert!(e.contains("not closed"), "{e}");
        // one face flipped
        let mut flipped = faces.clone();
        flipped[1].reverse();
        let e = corners(&all, flipped.iter().map(|f| &f[..])).unwrap_err();
        assert!(e.contains("consistently oriented"), "{e}");
        // a face naming a vertex outside the cell
        let e = corners(&all[..7], faces.iter().map(|f| &f[..])).unwrap_err();
        assert!(e.contains("vertex 7"), "{e}");
    }

    #[test]
    fn faces_rows_follow_the_elements() {
        let mut f = Faces::default();
        f.push_none(0);
        assert!(f.elem.is_empty());
        f.push(1, [&[1u32, 2, 3][..], &[3, 2, 4][..]]);
        f.push_none(2);
        f.push(3, [&[5u32, 6, 7][..]]);
        assert_eq!(f.elem, vec![0, 0, 2, 2, 3]);
        assert_eq!(f.of(0).count(), 0);
        assert_eq!(f.of(1).collect::<Vec<_>>(), vec![&[1, 2, 3][..], &[3, 2, 4][..]]);
        assert_eq!(f.of(3).next(), Some(&[5, 6, 7][..]));
        assert_eq!(f.of(9).count(), 0);
        assert_eq!(vertices_of_faces(f.of(1)), vec![1, 2, 3, 4]);
    }
}
