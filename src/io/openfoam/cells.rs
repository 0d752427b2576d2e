//! Cells from faces: each cell's faces turned outward (a face's normal
//! points out of its owner, so a neighbour sees it reversed), checked to
//! close, and recognised as a tetrahedron, hexahedron or prism in VTK's
//! vertex order where their shape is one; anything else is a polyhedron.

use std::path::Path;

use crate::error::{Error, Result};
use crate::mesh::polymesh::PolyMesh;
use crate::mesh::{ElementKind, Mesh};

/// What one cell becomes.
enum Cell {
    Plain(ElementKind, Vec<u32>),
    Polyhedron,
    Pyramid,
}

/// Appends the cells of `poly` to `mesh` as elements, in cell order.
/// `dir` names the polyMesh in errors.
pub(super) fn push_cells(dir: &Path, poly: &PolyMesh, mesh: &mut Mesh) -> Result<()> {
    let cells = poly.num_cells();
    let bad = |msg: String| Error::parse(dir, None, msg);
    // the faces of each cell, as (face, seen from the neighbour)
    let mut start = vec![0usize; cells + 1];
    for &c in poly.owner.iter().chain(&poly.neighbour) {
        start[c as usize + 1] += 1;
    }
    for c in 0..cells {
        start[c + 1] += start[c];
    }
    let mut fill = start.clone();
    let mut of = vec![(0u32, false); start[cells]];
    for (f, &c) in poly.owner.iter().enumerate() {
        of[fill[c as usize]] = (f as u32, false);
        fill[c as usize] += 1;
    }
    for (f, &c) in poly.neighbour.iter().enumerate() {
        of[fill[c as usize]] = (f as u32, true);
        fill[c as usize] += 1;
    }
    let mut faces: Vec<Vec<u32>> = Vec::new();
    let mut edges: Vec<(u32, u32)> = Vec::new();
    for c in 0..cells {
        let mine = &of[start[c]..start[c + 1]];
        if mine.len() < 4 {
            return Err(bad(format!(
                "cell {c} has {} faces; a cell needs at least 4 (is a cell number skipped in owner or neighbour?)",
                mine.len()
            )));
        }
        faces.resize_with(mine.len(), Vec::new);
        for (out, &(f, flip)) in faces.iter_mut().zip(mine) {
            out.clear();
            out.extend_from_slice(poly.face(f as usize));
            if flip {
                out.reverse();
            }
        }
        closed(c, &faces, &mut edges).map_err(bad)?;
        match classify(&faces) {
            Cell::Plain(kind, vs) => mesh.push_element(kind, &vs),
            Cell::Polyhedron => {
                let vs = crate::mesh::polyhedron::vertices_of_faces(faces.iter().map(Vec::as_slice));
                mesh.push_polyhedron(&vs, faces.iter().map(Vec::as_slice));
            }
            Cell::Pyramid => {
                return Err(bad(format!(
                    "cell {c} is a pyramid; pyramids are not supported: the corner-based metrics need \
                     exactly 3 edges at every corner"
                )));
            }
        }
    }
    Ok(())
}

/// Every edge of the outward faces must be met once each way: else the
/// cell is open, or owner and neighbour turn its faces inconsistently.
fn closed(c: usize, faces: &[Vec<u32>], edges: &mut Vec<(u32, u32)>) -> std::result::Result<(), String> {
    edges.clear();
    for f in faces {
        for i in 0..f.len() {
            edges.push((f[i], f[(i + 1) % f.len()]));
        }
    }
    edges.sort_unstable();
    if let Some(w) = edges.windows(2).find(|w| w[0] == w[1]) {
        let (a, b) = w[0];
        return Err(format!(
            "cell {c}: two of its faces run the edge from point {a} to point {b} the same way: \
             owner and neighbour do not agree with the faces' orientation"
        ));
    }
    for &(a, b) in edges.iter() {
        if edges.binary_search(&(b, a)).is_err() {
            return Err(format!(
                "cell {c} is not closed: the edge between points {a} and {b} is in one of its faces only"
            ));
        }
    }
    Ok(())
}

fn sorted(vs: &[u32]) -> Vec<u32> {
    let mut s = vs.to_vec();
    s.sort_unstable();
    s
}

/// Whether one of `faces` has exactly the points `vs`.
fn has_face(faces: &[Vec<u32>], vs: &[u32]) -> bool {
    let want = sorted(vs);
    faces.iter().any(|f| f.len() == vs.len() && sorted(f) == want)
}

/// The point across the edge from `v` that is not in `base`: a hexahedron's
/// or prism's vertex above `v`; `None` unless there is exactly one.
fn above(faces: &[Vec<u32>], base: &[u32], v: u32) -> Option<u32> {
    let mut found = None;
    for f in faces {
        let k = f.len();
        for i in 0..k {
            if f[i] != v {
                continue;
            }
            for w in [f[(i + 1) % k], f[(i + k - 1) % k]] {
                if !base.contains(&w) {
                    match found {
                        None => found = Some(w),
                        Some(x) if x == w => {}
                        Some(_) => return None,
                    }
                }
            }
        }
    }
    found
}

/// `base` (a face turned inward, so its normal points to the rest of
/// the cell) and the points above it: VTK's hexahedron or wedge, if the
/// cell's faces are exactly that shape's.
fn extruded(faces: &[Vec<u32>], base: Vec<u32>) -> Option<Vec<u32>> {
    let n = base.len();
    let top: Vec<u32> = base.iter().map(|&v| above(faces, &base, v)).collect::<Option<_>>()?;
    let mut all = base.clone();
    all.extend_from_slice(&top);
    if sorted(&all).windows(2).any(|w| w[0] == w[1]) || !has_face(faces, &top) {
        return None;
    }
    for i in 0..n {
        let j = (i + 1) % n;
        if !has_face(faces, &[base[i], base[j], top[j], top[i]]) {
            return None;
        }
    }
    Some(all)
}

fn classify(faces: &[Vec<u32>]) -> Cell {
    let tris = faces.iter().filter(|f| f.len() == 3).count();
    let quads = faces.iter().filter(|f| f.len() == 4).count();
    let inward = |f: &Vec<u32>| -> Vec<u32> {
        let mut r = f.clone();
        r.reverse();
        r
    };
    match (faces.len(), tris, quads) {
        (4, 4, 0) => {
            let f = &faces[0];
            match faces[1].iter().find(|v| !f.contains(v)) {
                // the outward face (a, b, c) seen from d turns clockwise
                Some(&d) => Cell::Plain(ElementKind::Tetrahedron, vec![f[0], f[2], f[1], d]),
                None => Cell::Polyhedron,
            }
        }
        (6, 0, 6) => match extruded(faces, inward(&faces[0])) {
            Some(vs) => Cell::Plain(ElementKind::Hexahedron, vs),
            None => Cell::Polyhedron,
        },
        (5, 2, 3) => {
            let base = faces.iter().find(|f| f.len() == 3).map(inward).unwrap_or_default();
            match extruded(faces, base) {
                Some(vs) => Cell::Plain(ElementKind::Prism, vs),
                None => Cell::Polyhedron,
            }
        }
        (5, 4, 1) => {
            let mut all: Vec<u32> = faces.iter().flatten().copied().collect();
            all.sort_unstable();
            all.dedup();
            if all.len() == 5 {
                Cell::Pyramid
            } else {
                Cell::Polyhedron
            }
        }
        _ => Cell::Polyhedron,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit cube's faces, outward (VTK's hexahedron numbering).
    fn cube() -> Vec<Vec<u32>> {
        vec![
            vec![0, 3, 2, 1],
            vec![4, 5, 6, 7],
            vec![0, 1, 5, 4],
            vec![1, 2, 6, 5],
            vec![2, 3, 7, 6],
            vec![3, 0, 4, 7],
        ]
    }

    #[test]
    fn shapes_come_out_in_vtk_order() {
        // the cube's faces from any starting face give a hexahedron whose
        // base turns toward its top
        let faces = cube();
        for first in 0..6 {
            let mut f = faces.clone();
            f.rotate_left(first);
            let Cell::Plain(ElementKind::Hexahedron, vs) = classify(&f) else {
                panic!("not a hexahedron")
            };
            let want: Vec<Vec<u32>> = ElementKind::Hexahedron
                .facets()
                .iter()
                .map(|l| sorted(&l.iter().map(|&i| vs[i]).collect::<Vec<_>>()))
                .collect();
            for face in &faces {
                assert!(want.contains(&sorted(face)), "{vs:?}");
            }
            // the base (0 1 2 3) is an inward face: its reverse is outward
            let base: Vec<u32> = vs[..4].iter().rev().copied().collect();
            let outward = f
                .iter()
                .any(|g| g.len() == 4 && (0..4).any(|r| (0..4).all(|i| g[(i + r) % 4] == base[i])));
            assert!(outward, "{vs:?}");
        }
        let tet = vec![vec![0, 2, 1], vec![0, 1, 3], vec![1, 2, 3], vec![0, 3, 2]];
        let Cell::Plain(ElementKind::Tetrahedron, vs) = classify(&tet) else {
            panic!()
        };
        assert_eq!(vs, vec![0, 1, 2, 3]);
        let prism = vec![
            vec![0, 2, 1],
            vec![3, 4, 5],
            vec![0, 1, 4, 3],
            vec![1, 2, 5, 4],
            vec![2, 0, 3, 5],
        ];
        let Cell::Plain(ElementKind::Prism, vs) = classify(&prism) else {
            panic!()
        };
        // the same wedge, its base maybe rotated
        let rotations = [[0, 1, 2, 3, 4, 5], [1, 2, 0, 4, 5, 3], [2, 0, 1, 5, 3, 4]];
        assert!(rotations.iter().any(|r| vs == r), "{vs:?}");
        let pyramid = vec![
            vec![0, 3, 2, 1],
            vec![0, 1, 4],
            vec![1, 2, 4],
            vec![2, 3, 4],
            vec![3, 0, 4],
        ];
        assert!(matches!(classify(&pyramid), Cell::Pyramid));
    }

    #[test]
    fn open_and_misturned_cells_are_named() {
        let mut edges = Vec::new();
        let faces = cube();
        assert!(closed(3, &faces, &mut edges).is_ok());
        let e = closed(3, &faces[1..], &mut edges).unwrap_err();
        assert!(e.contains("cell 3 is not closed"), "{e}");
        let mut flipped = faces.clone();
        flipped[2].reverse();
        let e = closed(3, &flipped, &mut edges).unwrap_err();
        assert!(e.contains("the same way"), "{e}");
    }
}
