//! Vertex-to-element adjacency, vertex neighbours and the boundary skin.

use super::{ElementKind, Mesh};
use rayon::prelude::*;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// A multiply-rotate hash (rustc's Fx) for the facet keys: small integers from
/// one mesh, no adversary, and SipHash was a sizeable share of problem setup.
#[derive(Clone, Copy, Default)]
struct FxHasher(u64);

impl FxHasher {
    #[inline]
    fn add(&mut self, w: u64) {
        self.0 = (self.0.rotate_left(5) ^ w).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
}

impl Hasher for FxHasher {
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut w = [0u8; 8];
            w[..chunk.len()].copy_from_slice(chunk);
            self.add(u64::from_le_bytes(w));
        }
    }

    #[inline]
    fn write_u32(&mut self, i: u32) {
        self.add(i as u64);
    }

    #[inline]
    fn write_u64(&mut self, i: u64) {
        self.add(i);
    }

    #[inline]
    fn write_usize(&mut self, i: usize) {
        self.add(i as u64);
    }

    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }
}

type FxMap<K, V> = HashMap<K, V, BuildHasherDefault<FxHasher>>;

/// Compressed lists: `items[offsets[i]..offsets[i + 1]]` belong to entry `i`.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Csr {
    pub offsets: Vec<u32>,
    pub items: Vec<u32>,
}

impl Csr {
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    #[inline]
    pub fn of(&self, i: usize) -> &[u32] {
        &self.items[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// Builds lists from (entry, item) pairs by counting sort, keeping pair order per entry.
    pub fn from_pairs(n: usize, pairs: impl Iterator<Item = (u32, u32)> + Clone) -> Csr {
        let mut offsets = vec![0u32; n + 1];
        for (i, _) in pairs.clone() {
            offsets[i as usize + 1] += 1;
        }
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut items = vec![0u32; offsets[n] as usize];
        for (i, item) in pairs {
            items[fill[i as usize] as usize] = item;
            fill[i as usize] += 1;
        }
        Csr { offsets, items }
    }
}

/// Elements incident to each vertex, in increasing element order.
///
/// A sequential counting sort: a parallel one (atomic counts and cursors,
/// then each list sorted) took 0.13 s against this one's 0.07 s on the
/// 1.3M-tet box on the shared 2-core machine.
pub fn vertex_elements(mesh: &Mesh) -> Csr {
    let pairs = (0..mesh.num_elements()).flat_map(|e| mesh.element(e).iter().map(move |&v| (v, e as u32)));
    Csr::from_pairs(mesh.num_points(), pairs)
}

/// Sorts `out[from..]` (one entry being built by [`build_par`], after the
/// chunk's earlier entries) and drops its repeated items.
pub fn sort_dedup_tail(out: &mut Vec<u32>, from: usize) {
    out[from..].sort_unstable();
    let mut keep = from;
    for i in from..out.len() {
        if keep == from || out[i] != out[keep - 1] {
            out[keep] = out[i];
            keep += 1;
        }
    }
    out.truncate(keep);
}

/// Lists built in parallel, one entry at a time: `fill(i, out)` appends
/// entry `i`'s items to `out`. Chunks of entries are built independently and
/// concatenated, so no global sort of (entry, item) pairs is needed.
pub fn build_par(n: usize, fill: impl Fn(usize, &mut Vec<u32>) + Sync) -> Csr {
    build_par_with(n, || (), |_, i, out| fill(i, out))
}

/// [`build_par`] with a scratch value per task (`init` makes one), which
/// `fill` may use but must not let change what it appends.
pub fn build_par_with<S>(
    n: usize,
    init: impl Fn() -> S + Sync + Send,
    fill: impl Fn(&mut S, usize, &mut Vec<u32>) + Sync,
) -> Csr {
    const CHUNK: usize = 1 << 14;
    let parts: Vec<(Vec<u32>, Vec<u32>)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map_init(init, |scratch, c| {
            let (mut ends, mut items) = (Vec::new(), Vec::new());
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                fill(scratch, i, &mut items);
                ends.push(items.len() as u32);
            }
            (ends, items)
        })
        .collect();
    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0u32);
    let mut items = Vec::with_capacity(parts.iter().map(|p| p.1.len()).sum());
    for (ends, part) in parts {
        let base = items.len() as u32;
        offsets.extend(ends.iter().map(|&e| base + e));
        items.extend_from_slice(&part);
    }
    Csr { offsets, items }
}

/// Vertices sharing an element edge with each vertex, sorted.
pub fn vertex_neighbours(mesh: &Mesh) -> Csr {
    if mesh.conn.iter().any(|&v| v as usize >= mesh.num_points()) {
        return vertex_neighbours_by_pairs(mesh);
    }
    vertex_neighbours_with(mesh, &vertex_elements(mesh))
}

/// [`vertex_neighbours`] from the mesh's [`vertex_elements`], when the caller
/// has them already (ids must be in range).
pub fn vertex_neighbours_with(mesh: &Mesh, ve: &Csr) -> Csr {
    // each vertex gathers its own edges from its elements: linear, and no
    // sort of all (vertex, neighbour) pairs (1 GB for 10M tetrahedra). A
    // task's marks (`mark[w] == v + 1`: w is listed for v) drop the repeats
    // as they come, so only the distinct neighbours (14 on a tet box, of 72
    // edge ends) are sorted
    let n = mesh.num_points();
    build_par_with(
        n,
        || vec![0u32; n],
        |mark, v, out| {
            let from = out.len();
            let v32 = v as u32;
            let mut add = |w: u32| {
                if mark[w as usize] != v32 + 1 {
                    mark[w as usize] = v32 + 1;
                    out.push(w);
                }
            };
            for &e in ve.of(v) {
                let e = e as usize;
                let vs = mesh.element(e);
                if mesh.kinds[e] == ElementKind::Polyhedron {
                    for [a, b] in mesh.element_edges(e) {
                        if a == v32 {
                            add(b);
                        }
                        if b == v32 {
                            add(a);
                        }
                    }
                }
                for [a, b] in mesh.kinds[e].edges() {
                    if vs[*a] == v32 {
                        add(vs[*b]);
                    }
                    if vs[*b] == v32 {
                        add(vs[*a]);
                    }
                }
            }
            out[from..].sort_unstable();
        },
    )
}

/// The pair-sorting construction, for meshes whose ids are out of range.
fn vertex_neighbours_by_pairs(mesh: &Mesh) -> Csr {
    let mut pairs = Vec::new();
    for e in 0..mesh.num_elements() {
        let vs = mesh.element(e);
        if mesh.kinds[e] == ElementKind::Polyhedron {
            for [a, b] in mesh.element_edges(e) {
                pairs.push((a, b));
                pairs.push((b, a));
            }
        }
        for [a, b] in mesh.kinds[e].edges() {
            pairs.push((vs[*a], vs[*b]));
            pairs.push((vs[*b], vs[*a]));
        }
    }
    // bucketed by vertex, then each short list sorted: one global sort of
    // every pair was most of a problem's setup on mid-size meshes
    let n = mesh.num_points();
    let raw = Csr::from_pairs(n, pairs.iter().copied());
    drop(pairs);
    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0u32);
    let mut items = Vec::with_capacity(raw.items.len() / 2);
    let mut row = Vec::new();
    for v in 0..n {
        row.clear();
        row.extend_from_slice(raw.of(v));
        row.sort_unstable();
        row.dedup();
        items.extend_from_slice(&row);
        offsets.push(items.len() as u32);
    }
    Csr { offsets, items }
}

/// Vertices on a facet (face in 3D, edge in 2D) used by exactly one element.
pub fn skin_vertices(mesh: &Mesh) -> Vec<bool> {
    let n = mesh.num_points();
    if !mesh.faces.is_empty() || mesh.conn.iter().any(|&v| v as usize >= n) {
        return skin_vertices_hashed(mesh);
    }
    skin_vertices_with(mesh, &vertex_elements(mesh))
}

/// [`skin_vertices`] from the mesh's [`vertex_elements`], when the caller has
/// them already (ids must be in range).
pub fn skin_vertices_with(mesh: &Mesh, ve: &Csr) -> Vec<bool> {
    let n = mesh.num_points();
    if !mesh.faces.is_empty() {
        return skin_vertices_hashed(mesh);
    }
    // Copies of a facet share their lowest vertex: each vertex counts the
    // facets it is lowest on, among its own elements' facets. Linear,
    // parallel, and no hash map of every facet of the mesh. In v's list a
    // facet is keyed by its other (up to three) vertices, ascending, packed
    // in a u128 (a missing fourth is u32::MAX): one compare, not four.
    let on_skin: Vec<u32> = (0..n)
        .into_par_iter()
        .with_min_len(1 << 12)
        .fold(
            || (Vec::<u128>::new(), Vec::<u32>::new()),
            |(mut keys, mut skin), v| {
                keys.clear();
                let v32 = v as u32;
                for &e in ve.of(v) {
                    let vs = mesh.element(e as usize);
                    for f in mesh.kinds[e as usize].facets() {
                        // only the facets v is lowest on: tested before the
                        // key is made, which most facets never need
                        if f.iter().all(|&l| vs[l] >= v32) && f.iter().any(|&l| vs[l] == v32) {
                            keys.push(facet_key(vs, f, v32));
                        }
                    }
                }
                keys.sort_unstable();
                let mut i = 0;
                while i < keys.len() {
                    let j = (i..keys.len()).find(|&j| keys[j] != keys[i]).unwrap_or(keys.len());
                    if j - i == 1 {
                        skin.push(v32);
                        let k = keys[i];
                        skin.extend(
                            [(k >> 64) as u32, (k >> 32) as u32, k as u32]
                                .into_iter()
                                .filter(|&w| w != u32::MAX),
                        );
                    }
                    i = j;
                }
                (keys, skin)
            },
        )
        .map(|(_, skin)| skin)
        .flatten()
        .collect();
    let mut skin = vec![false; n];
    for v in on_skin {
        skin[v as usize] = true;
    }
    skin
}

/// A facet of `vs` (local ids `local`, two to four) on which `v` is the
/// lowest vertex, by its other vertices ascending, u32::MAX-padded to three.
#[inline]
fn facet_key(vs: &[u32], local: &[usize], v: u32) -> u128 {
    let (mut k, mut m, mut dropped) = ([u32::MAX; 3], 0, false);
    for &l in local {
        // one copy of v is dropped: a (degenerate) facet naming it twice
        // keeps the other, as the sorted list of all its vertices would
        if vs[l] == v && !dropped {
            dropped = true;
        } else {
            k[m] = vs[l];
            m += 1;
        }
    }
    k.sort_unstable();
    (u128::from(k[0]) << 64) | (u128::from(k[1]) << 32) | u128::from(k[2])
}

/// The hash-map construction: polyhedra (whose faces of more than four
/// vertices need keys of any length) and meshes with out-of-range ids.
fn skin_vertices_hashed(mesh: &Mesh) -> Vec<bool> {
    let mut count: FxMap<[u32; 4], u32> = FxMap::with_capacity_and_hasher(mesh.num_elements() * 3, Default::default());
    // polyhedron faces with more than four vertices (a face of four or
    // fewer may be shared with a hexahedron or prism, so it keys as theirs)
    let mut long: FxMap<Vec<u32>, u32> = FxMap::default();
    let key = |vs: &[u32], local: &[usize]| {
        let mut k = [u32::MAX; 4];
        for (slot, &l) in k.iter_mut().zip(local) {
            *slot = vs[l];
        }
        k.sort_unstable();
        k
    };
    for e in 0..mesh.num_elements() {
        let vs = mesh.element(e);
        for f in mesh.kinds[e].facets() {
            *count.entry(key(vs, f)).or_default() += 1;
        }
        for f in mesh.faces.of(e) {
            if f.len() <= 4 {
                let local: Vec<usize> = (0..f.len()).collect();
                *count.entry(key(f, &local)).or_default() += 1;
            } else {
                let mut k = f.to_vec();
                k.sort_unstable();
                *long.entry(k).or_default() += 1;
            }
        }
    }
    let mut skin = vec![false; mesh.num_points()];
    for (k, c) in long {
        if c == 1 {
            for v in k {
                skin[v as usize] = true;
            }
        }
    }
    for (k, c) in count {
        if c == 1 {
            for &v in k.iter().filter(|&&v| v != u32::MAX) {
                skin[v as usize] = true;
            }
        }
    }
    skin
}

/// Vertices that must not move: the skin plus everything the user fixed
/// (and any vertex no element uses).
pub fn fixed_vertices(mesh: &Mesh) -> Vec<bool> {
    with_user_fixed(mesh, skin_vertices(mesh))
}

/// The vertex adjacency a problem starts from, with the mesh's
/// [`vertex_elements`] built once for all three (ids in range, else as the
/// separate functions do): (fixed vertices, edge neighbours, vertex elements).
pub fn vertex_graph(mesh: &Mesh) -> (Vec<bool>, Csr, Csr) {
    let n = mesh.num_points();
    if mesh.conn.par_iter().any(|&v| v as usize >= n) {
        return (fixed_vertices(mesh), vertex_neighbours(mesh), vertex_elements(mesh));
    }
    let ve = vertex_elements(mesh);
    let (skin, nb) = rayon::join(|| skin_vertices_with(mesh, &ve), || vertex_neighbours_with(mesh, &ve));
    (with_user_fixed(mesh, skin), nb, ve)
}

/// `fixed` plus the vertices the user fixed and those no element uses
/// (nothing could move them).
pub(crate) fn with_user_fixed(mesh: &Mesh, mut fixed: Vec<bool>) -> Vec<bool> {
    for (f, &u) in fixed.iter_mut().zip(&mesh.fixed) {
        *f |= u;
    }
    for (f, used) in fixed.iter_mut().zip(mesh.used_vertices()) {
        *f |= !used;
    }
    fixed
}

/// A surface mesh's faces must make a manifold, orientable surface: every
/// edge in at most two faces, and a choice of side for each face such that
/// two faces sharing an edge run along it in opposite directions (the faces
/// need not be wound that way already: each keeps its own side). The error
/// names the first edge (0-based vertex ids) and faces that break it.
pub fn check_surface(mesh: &Mesh) -> Result<(), String> {
    let faces: Vec<usize> = (0..mesh.num_elements())
        .filter(|&e| mesh.element(e).len() >= 3)
        .collect();
    // edge -> (face, runs from the lower id to the higher)
    let mut edges: HashMap<(u32, u32), Vec<(usize, bool)>> = HashMap::new();
    for &e in &faces {
        let vs = mesh.element(e);
        for i in 0..vs.len() {
            let (a, b) = (vs[i], vs[(i + 1) % vs.len()]);
            edges.entry((a.min(b), a.max(b))).or_default().push((e, a < b));
        }
    }
    let mut keys: Vec<&(u32, u32)> = edges.keys().collect();
    keys.sort_unstable();
    for k in &keys {
        let on = &edges[*k];
        if on.len() > 2 {
            let list: Vec<String> = on.iter().map(|(e, _)| e.to_string()).collect();
            return Err(format!(
                "the surface is not manifold: the edge between vertices {} and {} (0-based) is shared by {} faces \
                 (elements {}); a surface mesh has at most two faces on an edge",
                k.0,
                k.1,
                on.len(),
                list.join(", ")
            ));
        }
    }
    // a side for each face, spread face to face across shared edges
    let mut flip: Vec<Option<bool>> = vec![None; mesh.num_elements()];
    let mut queue = std::collections::VecDeque::new();
    for &start in &faces {
        if flip[start].is_some() {
            continue;
        }
        flip[start] = Some(false);
        queue.push_back(start);
        while let Some(e) = queue.pop_front() {
            let vs = mesh.element(e);
            for i in 0..vs.len() {
                let (a, b) = (vs[i], vs[(i + 1) % vs.len()]);
                let on = &edges[&(a.min(b), a.max(b))];
                let Some(&(f, f_up)) = on.iter().find(|(f, _)| *f != e) else {
                    continue;
                };
                // e's direction along the edge once flipped as chosen; f must run against it
                let e_up = (a < b) != flip[e].unwrap();
                let want = f_up == e_up;
                match flip[f] {
                    None => {
                        flip[f] = Some(want);
                        queue.push_back(f);
                    }
                    Some(has) if has != want => {
                        return Err(format!(
                            "the surface is not orientable: across the edge between vertices {} and {} (0-based) \
                             (elements {e} and {f}) the faces' sides cannot be chosen consistently \
                             (a Moebius strip or the like); a surface mesh needs a consistent normal",
                            a.min(b),
                            a.max(b)
                        ));
                    }
                    Some(_) => {}
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two tets sharing face (1,2,3): every vertex is on the skin.
    fn two_tets() -> Mesh {
        let mut m = Mesh::new(vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
        ]);
        m.push_element(ElementKind::Tetrahedron, &[0, 1, 2, 3]);
        m.push_element(ElementKind::Tetrahedron, &[1, 4, 2, 3]);
        m
    }

    #[test]
    fn adjacency_lists_every_incidence() {
        let m = two_tets();
        let ve = vertex_elements(&m);
        assert_eq!(ve.of(0), &[0]);
        assert_eq!(ve.of(1), &[0, 1]);
        assert_eq!(ve.of(4), &[1]);
        let nb = vertex_neighbours(&m);
        assert_eq!(nb.of(0), &[1, 2, 3]);
        assert_eq!(nb.of(1), &[0, 2, 3, 4]);
    }

    #[test]
    fn parallel_skin_and_neighbours_match_the_hashed_and_sorted_ones() {
        let meshes = [
            crate::generate::tet_box(7, 5, 6, [7.0, 5.0, 6.0]),
            crate::generate::mixed_block(3, 2),
            crate::generate::hex_box(4, 3, 5, [1.0, 1.0, 1.0]),
            crate::generate::tri_grid(9, 7, [1.0, 1.0]),
            two_tets(),
        ];
        for m in &meshes {
            assert_eq!(skin_vertices(m), skin_vertices_hashed(m));
            assert_eq!(vertex_neighbours(m), vertex_neighbours_by_pairs(m));
            // the same on one thread as on several
            let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
            assert_eq!(one.install(|| skin_vertices(m)), skin_vertices(m));
            assert_eq!(one.install(|| vertex_neighbours(m)), vertex_neighbours(m));
        }
    }

    #[test]
    fn quad_patch_skin_leaves_centre_free() {
        // 3x3 vertices, 2x2 quads: only the centre is interior
        let pts = (0..9).map(|i| [(i % 3) as f64, (i / 3) as f64, 0.0]).collect();
        let mut m = Mesh::new(pts);
        for (a, b) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let v = a + 3 * b;
            m.push_element(ElementKind::Quadrilateral, &[v, v + 1, v + 4, v + 3]);
        }
        let skin = skin_vertices(&m);
        assert_eq!(skin.iter().filter(|&&s| !s).count(), 1);
        assert!(!skin[4]);
        m.fixed = vec![false; 9];
        m.fixed[4] = true;
        assert!(fixed_vertices(&m).iter().all(|&f| f));
    }

    fn triangles(n_points: usize, tris: &[[u32; 3]]) -> Mesh {
        let mut m = Mesh::new(vec![[0.0; 3]; n_points]);
        for t in tris {
            m.push_element(ElementKind::Triangle, t);
        }
        m
    }

    /// An octahedron's faces, one wound the other way: orientable all the
    /// same (each face keeps its own side).
    #[test]
    fn a_closed_surface_with_a_reversed_face_passes() {
        let mut tris = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        assert_eq!(check_surface(&triangles(6, &tris)), Ok(()));
        tris[3] = [0, 3, 4];
        assert_eq!(check_surface(&triangles(6, &tris)), Ok(()));
    }

    #[test]
    fn a_fin_on_an_edge_is_not_manifold() {
        let m = triangles(5, &[[0, 1, 2], [1, 0, 3], [0, 1, 4]]);
        let e = check_surface(&m).unwrap_err();
        assert!(
            e.contains("not manifold") && e.contains("vertices 0 and 1") && e.contains("elements 0, 1, 2"),
            "{e}"
        );
    }

    /// A strip of 6 quads' triangles closed with a half twist.
    #[test]
    fn a_moebius_strip_is_not_orientable() {
        let n = 6u32;
        let (a, b) = (|i: u32| 2 * (i % n), |i: u32| 2 * (i % n) + 1);
        let mut tris = Vec::new();
        for i in 0..n - 1 {
            tris.push([a(i), b(i), b(i + 1)]);
            tris.push([a(i), b(i + 1), a(i + 1)]);
        }
        // the twist: rails swap
        tris.push([a(n - 1), b(n - 1), a(0)]);
        tris.push([a(n - 1), a(0), b(0)]);
        let e = check_surface(&triangles(2 * n as usize, &tris)).unwrap_err();
        assert!(e.contains("not orientable"), "{e}");
        // the same strip closed without the twist is a band: orientable
        let mut band = tris[..tris.len() - 2].to_vec();
        band.push([a(n - 1), b(n - 1), b(0)]);
        band.push([a(n - 1), b(0), a(0)]);
        assert_eq!(check_surface(&triangles(2 * n as usize, &band)), Ok(()));
    }
}
