//! Vertex orderings for locality of reference, and the element numbering that
//! follows a vertex order.

use super::Mesh;
use super::sweep_order::SweepOrder;
use super::topology::Csr;
use rayon::prelude::*;

/// The vertex order a problem is built in, and its sweep order. Three are
/// numberings of the graph (`rbfs`, `cuthill-mckee`, `red-black`): the
/// problem is built in them and every method sweeps or numbers its rows in
/// them. The reordering paper's 20 schemes ([`SweepOrder`]: `n`, `wqp`,
/// `reverse-d-grvm`, ...) leave the problem in the input numbering and
/// reorder the list the sequential sweep (`--method bcd` on the CPU) visits,
/// once or every k-th sweep; `n` (alias `input`) is the input numbering
/// itself for every method.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Ordering {
    /// Reverse breadth-first from the farthest boundary vertex ([`reverse_bfs`]).
    #[default]
    ReverseBfs,
    /// Cuthill–McKee: breadth-first from a vertex of least degree, neighbours
    /// visited by increasing degree ([`cuthill_mckee`]).
    CuthillMcKee,
    /// Checkerboard: the vertices of one class of a 2-colouring, then the
    /// other ([`red_black`]; the paper's section 6.8).
    RedBlack,
    /// One of the paper's schemes, applied to the sweep list.
    Sweep(SweepOrder),
}

impl Ordering {
    /// The input numbering (the paper's N).
    pub const INPUT: Ordering = Ordering::Sweep(SweepOrder::N);

    /// Every ordering: the three graph numberings, then the paper's 20.
    pub fn all() -> Vec<Ordering> {
        let mut v = vec![Ordering::ReverseBfs, Ordering::CuthillMcKee, Ordering::RedBlack];
        v.extend(SweepOrder::all().map(Ordering::Sweep));
        v
    }

    /// The paper scheme that reorders the sweep list, if this is one (N included).
    pub fn sweep(self) -> Option<SweepOrder> {
        match self {
            Ordering::Sweep(s) => Some(s),
            _ => None,
        }
    }

    /// `order[new] = old` for a mesh with vertex `points`, edge `neighbours`
    /// and `boundary` (fixed) flags, all in the mesh's numbering. The paper's
    /// schemes keep the input numbering: they act on the sweep list.
    pub fn order(self, points: &[[f64; 3]], neighbours: &Csr, boundary: &[bool]) -> Vec<u32> {
        match self {
            Ordering::ReverseBfs => reverse_bfs(points, neighbours, boundary),
            Ordering::CuthillMcKee => cuthill_mckee(neighbours),
            Ordering::RedBlack => red_black(neighbours),
            Ordering::Sweep(_) => (0..points.len() as u32).collect(),
        }
    }
}

impl std::fmt::Display for Ordering {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Ordering::ReverseBfs => f.write_str("rbfs"),
            Ordering::CuthillMcKee => f.write_str("cuthill-mckee"),
            Ordering::RedBlack => f.write_str("red-black"),
            Ordering::Sweep(s) => f.write_str(&s.name()),
        }
    }
}

impl std::str::FromStr for Ordering {
    type Err = crate::Error;
    fn from_str(s: &str) -> crate::Result<Self> {
        let lower = s.trim().to_ascii_lowercase();
        match lower.as_str() {
            "rbfs" => return Ok(Ordering::ReverseBfs),
            "cuthill-mckee" => return Ok(Ordering::CuthillMcKee),
            "red-black" => return Ok(Ordering::RedBlack),
            _ => {}
        }
        SweepOrder::parse(&lower).map(Ordering::Sweep).ok_or_else(|| {
            let names: Vec<String> = Ordering::all()
                .iter()
                .filter(|o| o.sweep().is_none_or(|s| !s.reverse))
                .map(|o| o.to_string())
                .collect();
            crate::Error::InvalidArgument(format!(
                "unknown ordering '{s}' (expected {}, input, or a paper scheme reversed as reverse-NAME or -NAME)",
                names.join(", ")
            ))
        })
    }
}

/// Red-black (checkerboard) order: each connected part is 2-coloured by the
/// parity of the breadth-first distance from its lowest-numbered vertex;
/// the even vertices come first, then the odd, each in input order. On a
/// structured quadrilateral or hexahedral mesh (a bipartite edge graph) this
/// is the checkerboard of the paper's section 6.8: no two neighbours share a
/// colour. On other meshes (triangles, tetrahedra: odd cycles) it is the same
/// parity split, in which some neighbours share a colour. Returns `order[new] = old`.
pub fn red_black(neighbours: &Csr) -> Vec<u32> {
    let n = neighbours.len();
    let mut parity = vec![u8::MAX; n];
    let mut queue = Vec::with_capacity(n);
    for root in 0..n {
        if parity[root] != u8::MAX {
            continue;
        }
        parity[root] = 0;
        queue.clear();
        queue.push(root as u32);
        let mut head = 0;
        while head < queue.len() {
            let v = queue[head] as usize;
            head += 1;
            for &w in neighbours.of(v) {
                if parity[w as usize] == u8::MAX {
                    parity[w as usize] = 1 - parity[v];
                    queue.push(w);
                }
            }
        }
    }
    let mut order: Vec<u32> = (0..n as u32).filter(|&v| parity[v as usize] == 0).collect();
    order.extend((0..n as u32).filter(|&v| parity[v as usize] == 1));
    order
}

/// Reverse breadth-first order (section 3.3 of the Newton paper): BFS from the
/// boundary vertex farthest from the origin, then reversed. Disconnected parts
/// are started in turn from their own farthest vertex. Returns `order[new] = old`.
pub fn reverse_bfs(points: &[[f64; 3]], neighbours: &Csr, boundary: &[bool]) -> Vec<u32> {
    let n = points.len();
    // distances from the bounding-box centre, so that the order does not
    // depend on where the mesh sits
    let center = crate::mesh::frame::Frame::of(points).center;
    let dist2: Vec<f64> = points
        .par_iter()
        .map(|p| (0..3).map(|k| (p[k] - center[k]).powi(2)).sum::<f64>())
        .collect();
    // candidates for BFS roots: boundary vertices first, farthest first; a
    // strict total order (ids break ties), so any sort gives the same list
    let before = |a: &u32, b: &u32| {
        let (a, b) = (*a as usize, *b as usize);
        boundary[b]
            .cmp(&boundary[a])
            .then(dist2[b].total_cmp(&dist2[a]))
            .then(a.cmp(&b))
    };
    let mut seen = vec![false; n];
    let mut order = Vec::with_capacity(n);
    // breadth-first from `root` if unseen; returns how many are seen
    let mut search_from = |root: u32| {
        if std::mem::replace(&mut seen[root as usize], true) {
            return order.len();
        }
        let mut head = order.len();
        order.push(root);
        while head < order.len() {
            let v = order[head] as usize;
            head += 1;
            for &w in neighbours.of(v) {
                if !seen[w as usize] {
                    seen[w as usize] = true;
                    order.push(w);
                }
            }
        }
        order.len()
    };
    // a connected mesh needs only the first root (a linear search): the
    // whole list is sorted only for a mesh in several parts
    let first = (0..n as u32).into_par_iter().min_by(before);
    if first.is_some_and(|r| search_from(r) < n) {
        let mut roots: Vec<u32> = (0..n as u32).collect();
        roots.par_sort_unstable_by(before);
        for r in roots {
            search_from(r);
        }
    }
    order.reverse();
    order
}

/// Cuthill–McKee order: each connected part is swept breadth-first from its
/// vertex of least degree (lowest id on ties), the unseen neighbours of a
/// vertex taken by increasing degree (then id). Returns `order[new] = old`.
pub fn cuthill_mckee(neighbours: &Csr) -> Vec<u32> {
    let n = neighbours.len();
    let degree = |v: u32| neighbours.of(v as usize).len();
    let mut roots: Vec<u32> = (0..n as u32).collect();
    roots.sort_by_key(|&v| (degree(v), v));
    let mut seen = vec![false; n];
    let mut order = Vec::with_capacity(n);
    let mut next: Vec<u32> = Vec::new();
    for &root in &roots {
        if seen[root as usize] {
            continue;
        }
        seen[root as usize] = true;
        let mut head = order.len();
        order.push(root);
        while head < order.len() {
            let v = order[head] as usize;
            head += 1;
            next.clear();
            next.extend(neighbours.of(v).iter().copied().filter(|&w| !seen[w as usize]));
            next.sort_by_key(|&w| (degree(w), w));
            for &w in &next {
                seen[w as usize] = true;
                order.push(w);
            }
        }
    }
    order
}

/// Elements numbered in the order a sweep over the vertices first touches
/// them: `elem_order[new] = old`, for the vertex numbering `inv[old] = new`.
///
/// A vertex touches its elements in ascending id, and an element is first
/// touched by its earliest vertex: so the numbering is the elements sorted by
/// (earliest vertex, id). The keys are found in parallel and sorted by one
/// counting sort, linear, with no sequential walk of every vertex's elements.
pub fn elements_by_first_touch(inv: &[u32], mesh: &Mesh) -> Vec<u32> {
    let first: Vec<u32> = (0..mesh.num_elements())
        .into_par_iter()
        .with_min_len(1 << 12)
        .map(|e| {
            let vs = mesh.element(e).iter();
            vs.map(|&v| inv[v as usize]).min().expect("an element has vertices")
        })
        .collect();
    Csr::from_pairs(inv.len(), first.iter().enumerate().map(|(e, &k)| (k, e as u32))).items
}

/// Inverse of a permutation: `inv[perm[i]] = i`.
pub fn invert(perm: &[u32]) -> Vec<u32> {
    let mut inv = vec![0u32; perm.len()];
    for (i, &p) in perm.iter().enumerate() {
        inv[p as usize] = i as u32;
    }
    inv
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reverse_bfs_visits_every_vertex_once_and_ends_at_the_farthest_boundary_vertex() {
        // a path 0-1-2-3 plus an isolated component 4-5
        let pairs = [(0, 1), (1, 0), (1, 2), (2, 1), (2, 3), (3, 2), (4, 5), (5, 4)];
        let nb = Csr::from_pairs(6, pairs.iter().copied());
        let pts: Vec<[f64; 3]> = (0..6).map(|i| [i as f64, 0.0, 0.0]).collect();
        let boundary = [true, false, false, true, true, true];
        let order = reverse_bfs(&pts, &nb, &boundary);
        let mut sorted = order.clone();
        sorted.sort();
        assert_eq!(sorted, vec![0, 1, 2, 3, 4, 5]);
        // distances from the centre x = 2.5: 0 and 5 tie (lower id first), so
        // the BFS is 0,1,2,3 then 5,4; reversed
        assert_eq!(order, vec![4, 5, 3, 2, 1, 0]);
        // the same order wherever the mesh sits and whatever its units
        let moved: Vec<[f64; 3]> = pts.iter().map(|p| [p[0] * 1e6 - 3e7, 5.0, -1.0]).collect();
        assert_eq!(reverse_bfs(&moved, &nb, &boundary), order);
        assert_eq!(invert(&[2, 0, 1]), vec![1, 2, 0]);
    }

    fn is_permutation(order: &[u32], n: usize) -> bool {
        let mut sorted = order.to_vec();
        sorted.sort_unstable();
        sorted == (0..n as u32).collect::<Vec<_>>()
    }

    #[test]
    fn cuthill_mckee_starts_at_least_degree_and_takes_neighbours_by_degree() {
        // a star 0-{1,2,3} whose leaf 3 continues to 4; degrees 3,1,1,2,1
        let edges = [(0, 1), (0, 2), (0, 3), (3, 4)];
        let mut pairs: Vec<(u32, u32)> = edges.iter().flat_map(|&(a, b)| [(a, b), (b, a)]).collect();
        pairs.sort_unstable();
        let nb = Csr::from_pairs(5, pairs.into_iter());
        let order = cuthill_mckee(&nb);
        assert!(is_permutation(&order, 5));
        // root 1 (degree 1, lowest id), then 0, then 0's unseen neighbours by
        // degree: 2 (degree 1) before 3 (degree 2), then 4
        assert_eq!(order, vec![1, 0, 2, 3, 4]);
    }

    #[test]
    fn orderings_are_permutations_and_input_is_the_identity() {
        let pairs = [(0, 1), (1, 0), (1, 2), (2, 1), (2, 3), (3, 2)];
        let nb = Csr::from_pairs(4, pairs.iter().copied());
        let pts: Vec<[f64; 3]> = (0..4).map(|i| [i as f64, 0.0, 0.0]).collect();
        let boundary = [true, false, false, true];
        for o in Ordering::all() {
            assert!(is_permutation(&o.order(&pts, &nb, &boundary), 4), "{o}");
        }
        assert_eq!(Ordering::RedBlack.order(&pts, &nb, &boundary), vec![0, 2, 1, 3]);
        assert_eq!(Ordering::INPUT.order(&pts, &nb, &boundary), vec![0, 1, 2, 3]);
        assert_eq!(Ordering::ReverseBfs.order(&pts, &nb, &boundary), vec![3, 2, 1, 0]);
        assert_eq!(Ordering::CuthillMcKee.order(&pts, &nb, &boundary), vec![0, 1, 2, 3]);
    }

    #[test]
    fn ordering_names_round_trip() {
        assert_eq!(Ordering::default(), Ordering::ReverseBfs);
        assert_eq!(Ordering::all().len(), 23);
        for o in Ordering::all() {
            assert_eq!(o.to_string().parse::<Ordering>().unwrap(), o);
        }
        assert_eq!(Ordering::ReverseBfs.to_string(), "rbfs");
        assert_eq!(Ordering::CuthillMcKee.to_string(), "cuthill-mckee");
        assert_eq!("N".parse::<Ordering>().unwrap(), Ordering::INPUT);
        assert_eq!("input".parse::<Ordering>().unwrap(), Ordering::INPUT);
        assert_eq!("Red-Black".parse::<Ordering>().unwrap(), Ordering::RedBlack);
        let err = "bfs".parse::<Ordering>().unwrap_err().to_string();
        assert!(err.contains("rbfs, cuthill-mckee, red-black, n, r, wqp, gavm"), "{err}");
        assert!(err.contains("d-lng"), "{err}");
    }

    /// Reverse BFS as first written: every vertex sorted as a root.
    fn reverse_bfs_sorting_every_root(points: &[[f64; 3]], neighbours: &Csr, boundary: &[bool]) -> Vec<u32> {
        let center = crate::mesh::frame::Frame::of(points).center;
        let dist2 = |v: usize| (0..3).map(|k| (points[v][k] - center[k]).powi(2)).sum::<f64>();
        let mut roots: Vec<u32> = (0..points.len() as u32).collect();
        roots.sort_by(|&a, &b| {
            let (a, b) = (a as usize, b as usize);
            boundary[b]
                .cmp(&boundary[a])
                .then(dist2(b).total_cmp(&dist2(a)))
                .then(a.cmp(&b))
        });
        let mut seen = vec![false; points.len()];
        let mut order = Vec::new();
        for root in roots {
            if std::mem::replace(&mut seen[root as usize], true) {
                continue;
            }
            let mut head = order.len();
            order.push(root);
            while head < order.len() {
                let v = order[head] as usize;
                head += 1;
                for &w in neighbours.of(v) {
                    if !std::mem::replace(&mut seen[w as usize], true) {
                        order.push(w);
                    }
                }
            }
        }
        order.reverse();
        order
    }

    #[test]
    fn reverse_bfs_is_the_one_that_sorted_every_root_on_any_thread_count() {
        // connected, and in two parts (a box beside a shifted copy)
        let one = crate::generate::tet_box(6, 5, 4, [6.0, 5.0, 4.0]);
        let mut two = one.clone();
        let n = one.num_points() as u32;
        two.points.extend(one.points.iter().map(|p| [p[0] + 9.0, p[1], p[2]]));
        for e in 0..one.num_elements() {
            let vs: Vec<u32> = one.element(e).iter().map(|&v| v + n).collect();
            two.push_element(one.kinds[e], &vs);
        }
        for m in [one, two, crate::generate::mixed_block(3, 2)] {
            let nb = super::super::topology::vertex_neighbours(&m);
            let fixed = super::super::topology::fixed_vertices(&m);
            let want = reverse_bfs_sorting_every_root(&m.points, &nb, &fixed);
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                assert_eq!(
                    pool.install(|| reverse_bfs(&m.points, &nb, &fixed)),
                    want,
                    "{threads} threads"
                );
            }
        }
    }

    /// The numbering as first written: a sweep over the vertices in order,
    /// each taking its untouched elements in ascending id.
    fn first_touch_by_sweep(order: &[u32], mesh: &Mesh) -> Vec<u32> {
        let ve = super::super::topology::vertex_elements(mesh);
        let mut touched = vec![false; mesh.num_elements()];
        let mut elem_order = Vec::new();
        for &v in order {
            for &e in ve.of(v as usize) {
                if !std::mem::replace(&mut touched[e as usize], true) {
                    elem_order.push(e);
                }
            }
        }
        elem_order
    }

    #[test]
    fn elements_follow_the_first_vertex_that_touches_them() {
        // triangles 0 = {0, 1, 2}, 1 = {1, 2, 3}, 2 = {2, 3, 4}
        let mut m = Mesh::new((0..5).map(|i| [i as f64, (i % 2) as f64, 0.0]).collect());
        for t in [[0, 1, 2], [1, 2, 3], [2, 3, 4]] {
            m.push_element(super::super::ElementKind::Triangle, &t);
        }
        // sweep 4, 3, 2, 1, 0: vertex 4 touches 2, vertex 3 touches 1
        assert_eq!(elements_by_first_touch(&invert(&[4, 3, 2, 1, 0]), &m), vec![2, 1, 0]);
        // sweep 2, 0, ...: vertex 2 touches all three, ascending
        assert_eq!(elements_by_first_touch(&invert(&[2, 0, 1, 3, 4]), &m), vec![0, 1, 2]);
    }

    #[test]
    fn first_touch_is_the_sequential_sweep_for_every_ordering_and_thread_count() {
        let meshes = [
            crate::generate::tet_box(6, 5, 4, [6.0, 5.0, 4.0]),
            crate::generate::mixed_block(3, 2),
            crate::generate::tri_grid(7, 6, [1.0, 1.0]),
        ];
        for m in &meshes {
            let nb = super::super::topology::vertex_neighbours(m);
            let fixed = super::super::topology::fixed_vertices(m);
            for o in [
                Ordering::ReverseBfs,
                Ordering::CuthillMcKee,
                Ordering::RedBlack,
                Ordering::INPUT,
            ] {
                let order = o.order(&m.points, &nb, &fixed);
                let want = first_touch_by_sweep(&order, m);
                for threads in [1, 2, 3] {
                    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                    let got = pool.install(|| elements_by_first_touch(&invert(&order), m));
                    assert_eq!(got, want, "{o} on {threads} threads");
                }
            }
        }
    }
}
