//! Splitting a `Problem` into parts for a partitioned (MPI) run, in
//! Mesquite's data model: every vertex has one owning part and a global id
//! (its number in the whole problem); every element is present on each part
//! owning one of its vertices; the vertices of those elements that a part does
//! not own are its ghosts (one layer).
//!
//! A part is itself a `Problem`, the whole one restricted: vertices, elements
//! and corners keep the whole problem's relative order and weights, and each
//! owned vertex keeps its incident corners in the same order, so a per-vertex
//! computation (a BCD step, a gradient or Hessian row) on a part gives the bits
//! the whole problem gives. Its colour classes hold only owned vertices, taken
//! from the whole problem's colouring, so a coloured sweep visits exactly what
//! one process visits. Nothing here needs MPI: the split runs on one process
//! (rank 0) and the parts are shipped. `local` builds the same kind of part
//! on each rank from the mesh pieces it read, without the whole problem,
//! talking to the other ranks through its `Network`.
//!
//! Who owns which vertex comes from a [`Partitioner`]: METIS on the vertex
//! graph where built in (feature `metis`, which `mpi` enables), else the
//! built-in recursive coordinate bisection.

// its messages are serialised with ciborium, which comes with `mpi`
#[cfg(feature = "mpi")]
pub mod local;
#[cfg(feature = "metis")]
mod metis;
mod quality;
mod rcb;

#[cfg(feature = "metis")]
pub use metis::metis;
pub use quality::Quality;
pub use rcb::rcb;

use crate::error::Result;

use crate::mesh::topology::Csr;
use crate::metric::mat3::Vec3;
use crate::problem::Problem;
use std::time::Duration;

/// How the vertices are shared out among the parts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Partitioner {
    /// METIS 5's multilevel k-way partitioning of the vertex graph (fewest cut edges).
    Metis,
    /// Recursive coordinate bisection of the vertex positions (no library needed).
    Rcb,
    /// The input's .pvtu pieces as they are (under mpirun): each rank sets up
    /// its own part from the pieces it reads; no rank holds the whole mesh.
    Pieces,
}

crate::error::by_name!(Partitioner: "partitioner" { Metis = "metis", Rcb = "rcb", Pieces = "pieces" });

impl Default for Partitioner {
    fn default() -> Self {
        if cfg!(feature = "metis") {
            Partitioner::Metis
        } else {
            Partitioner::Rcb
        }
    }
}

impl Partitioner {
    /// The partitioner's name, as the command line spells it.
    pub fn name(self) -> &'static str {
        crate::error::Named::name(&self)
    }

    /// The owning part of each vertex of `p` at positions `x` (problem
    /// numbering), `parts` parts.
    // without METIS only the positions matter
    #[cfg_attr(not(feature = "metis"), allow(unused_variables))]
    pub fn owners(self, p: &Problem, x: &[Vec3], parts: usize) -> Result<Vec<u32>> {
        match self {
            #[cfg(feature = "metis")]
            Partitioner::Metis => metis(p, parts),
            #[cfg(not(feature = "metis"))]
            Partitioner::Metis => Err(crate::error::Error::Unsupported(
                "`partitioner metis`: this build has no METIS (build with --features metis or mpi); use rcb".into(),
            )),
            Partitioner::Rcb => Ok(rcb(x, parts)),
            Partitioner::Pieces => Err(crate::error::Error::Unsupported(
                "`partitioner pieces` takes the parts from a .pvtu input's pieces under mpirun; it cannot split a whole mesh (use metis or rcb)".into(),
            )),
        }
    }
}

/// The owning part of each vertex of `mesh` (its own numbering), `parts`
/// parts, as a partitioned solve of the mesh would share them out.
pub fn mesh_owners(mesh: &crate::Mesh, parts: usize, partitioner: Partitioner) -> Result<Vec<u32>> {
    let p = Problem::new(mesh)?;
    let x = p.gather(&mesh.points);
    let owner = partitioner.owners(&p, &x, parts)?;
    let mut out = vec![0; mesh.num_points()];
    for (&old, &r) in p.order.iter().zip(&owner) {
        out[old as usize] = r;
    }
    Ok(out)
}

/// Edges of `p`'s vertex graph whose ends have different owners.
pub fn edge_cut(p: &Problem, owner: &[u32]) -> usize {
    (0..p.num_vertices())
        .map(|v| {
            p.neighbours
                .of(v)
                .iter()
                .filter(|&&w| (w as usize) > v && owner[v] != owner[w as usize])
                .count()
        })
        .sum()
}

/// The positions a part exchanges with one other part, as indices into the
/// part's free-vertex vectors (so one list serves positions and vectors:
/// only free vertices ever change). Both sides list the shared vertices in
/// ascending global id, so the i-th sent value is the i-th received one.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Exchange {
    /// The other part's rank.
    pub rank: u32,
    /// Owned free vertices the other part holds as ghosts.
    pub send: Vec<u32>,
    /// Ghost free vertices the other part owns.
    pub recv: Vec<u32>,
}

/// One part: its problem, its place in the whole and its halo.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Part {
    /// This part's rank.
    pub rank: u32,
    /// Number of parts.
    pub size: u32,
    /// The part's problem (part numbering, ghosts included).
    pub problem: Problem,
    /// Positions of the part's vertices (part numbering).
    pub x: Vec<Vec3>,
    /// Global id of each vertex: the whole problem's numbering, ascending, in
    /// a [`split`] part; in a `local` one, in the part's own vertex order.
    pub global: Vec<u32>,
    /// Per vertex: does this part own it?
    pub owned: Vec<bool>,
    /// Free-vector indices of the owned free vertices: what reductions sum.
    pub owned_free: Vec<u32>,
    /// Corners of the elements this part owns (an element belongs to the owner
    /// of its first vertex): what F sums, each corner on exactly one part.
    pub owned_corners: Vec<u32>,
    /// Neighbour parts in ascending rank.
    pub halo: Vec<Exchange>,
    /// Colour (in the whole problem's colouring) of each free vertex, ghosts
    /// included: after a colour of a sweep only that colour's ghosts change.
    pub free_colour: Vec<u32>,
    /// Mean edge length of the whole start, the scale of the stopping test.
    pub edge: f64,
    /// Setup time of the whole problem plus the split (of the part, for a `local` one).
    pub setup: Duration,
}

impl Part {
    /// The halo restricted to the free vertices of colour `c`.
    pub fn colour_halo(&self, c: u32) -> Vec<Exchange> {
        let keep = |list: &[u32]| {
            list.iter()
                .copied()
                .filter(|&i| self.free_colour[i as usize] == c)
                .collect()
        };
        self.halo
            .iter()
            .map(|h| Exchange {
                rank: h.rank,
                send: keep(&h.send),
                recv: keep(&h.recv),
            })
            .filter(|h| !(h.send.is_empty() && h.recv.is_empty()))
            .collect()
    }

    /// Ghost vertices (present, not owned).
    pub fn ghosts(&self) -> usize {
        self.owned.iter().filter(|&&o| !o).count()
    }

    /// Free ghost vertices received from neighbours per exchange.
    pub fn halo_in(&self) -> usize {
        self.halo.iter().map(|h| h.recv.len()).sum()
    }

    /// Free owned vertices sent to neighbours per exchange.
    pub fn halo_out(&self) -> usize {
        self.halo.iter().map(|h| h.send.len()).sum()
    }
}

/// Splits `p` at positions `x` (problem numbering) by `owner` (a part per
/// vertex, below `size`).
pub fn split(p: &Problem, x: &[Vec3], owner: &[u32], size: usize) -> Vec<Part> {
    let start = std::time::Instant::now();
    let n = p.num_vertices();
    let first_owner = |e: usize| owner[p.elements.of(e)[0] as usize];
    // elements of each part, ascending: those touching a vertex it owns
    let mut elems: Vec<Vec<u32>> = vec![Vec::new(); size];
    let mut ranks = Vec::with_capacity(8);
    for e in 0..p.num_elements() {
        ranks.clear();
        ranks.extend(p.elements.of(e).iter().map(|&v| owner[v as usize]));
        ranks.sort_unstable();
        ranks.dedup();
        for &r in &ranks {
            elems[r as usize].push(e as u32);
        }
    }
    let mut parts: Vec<Part> = Vec::with_capacity(size);
    let mut local = vec![u32::MAX; n];
    let mut local_elem = vec![u32::MAX; p.num_elements()];
    let edge = p.mean_edge_length(x);
    let mut colour = vec![u32::MAX; n];
    for c in 0..p.colors.len() {
        for &v in p.colors.of(c) {
            colour[v as usize] = c as u32;
        }
    }
    for (r, elems) in elems.iter().enumerate() {
        let mut global: Vec<u32> = elems
            .iter()
            .flat_map(|&e| p.elements.of(e as usize).iter().copied())
            .chain((0..n as u32).filter(|&v| owner[v as usize] == r as u32 && p.neighbours.of(v as usize).is_empty()))
            .collect();
        global.sort_unstable();
        global.dedup();
        for (l, &g) in global.iter().enumerate() {
            local[g as usize] = l as u32;
        }
        for (l, &e) in elems.iter().enumerate() {
            local_elem[e as usize] = l as u32;
        }
        let q = restrict(p, &global, elems, &local, &local_elem, |v| owner[v] == r as u32);
        let owned: Vec<bool> = global.iter().map(|&g| owner[g as usize] == r as u32).collect();
        let owned_free = q
            .free_vertices
            .iter()
            .enumerate()
            .filter(|(_, v)| owned[**v as usize])
            .map(|(i, _)| i as u32)
            .collect();
        let owned_corners = (0..q.num_corners() as u32)
            .filter(|&c| first_owner(elems[q.corner_element[c as usize] as usize] as usize) == r as u32)
            .collect();
        parts.push(Part {
            rank: r as u32,
            size: size as u32,
            x: global.iter().map(|&g| x[g as usize]).collect(),
            global: global.clone(),
            owned,
            owned_free,
            owned_corners,
            halo: Vec::new(),
            free_colour: q
                .free_vertices
                .iter()
                .map(|&v| colour[global[v as usize] as usize])
                .collect(),
            problem: q,
            edge,
            setup: Duration::ZERO,
        });
        for &g in &global {
            local[g as usize] = u32::MAX;
        }
        for &e in elems {
            local_elem[e as usize] = u32::MAX;
        }
    }
    link_halos(&mut parts, owner);
    let setup = p.setup_time + start.elapsed();
    for part in &mut parts {
        part.setup = setup;
    }
    parts
}

/// The whole problem restricted to the vertices `global` and elements
/// `elems` (both ascending; `local` and `local_elem` map into them).
fn restrict(
    p: &Problem,
    global: &[u32],
    elems: &[u32],
    local: &[u32],
    local_elem: &[u32],
    owns: impl Fn(usize) -> bool,
) -> Problem {
    let mut local_corner = vec![u32::MAX; p.num_corners()];
    let mut corners = Vec::new();
    let (mut corner_element, mut corner_shape, mut corner_weight) = (Vec::new(), Vec::new(), Vec::new());
    for c in 0..p.num_corners() {
        let e = local_elem[p.corner_element[c] as usize];
        if e == u32::MAX {
            continue;
        }
        local_corner[c] = corners.len() as u32;
        corners.push(p.corners[c].map(|v| local[v as usize]));
        corner_element.push(e);
        corner_shape.push(p.corner_shape[c]);
        corner_weight.push(p.corner_weight[c]);
    }
    let lists = |of: &dyn Fn(usize) -> Vec<u32>| {
        let mut csr = Csr {
            offsets: vec![0],
            items: Vec::new(),
        };
        for i in 0..global.len() {
            csr.items.extend(of(i));
            csr.offsets.push(csr.items.len() as u32);
        }
        csr
    };
    let incidence = lists(&|l| {
        p.incidence
            .of(global[l] as usize)
            .iter()
            .filter(|&&k| local_corner[(k >> 2) as usize] != u32::MAX)
            .map(|&k| (4 * local_corner[(k >> 2) as usize]) | (k & 3))
            .collect()
    });
    let neighbours = lists(&|l| {
        p.neighbours
            .of(global[l] as usize)
            .iter()
            .filter(|&&w| local[w as usize] != u32::MAX)
            .map(|&w| local[w as usize])
            .collect()
    });
    let mut elements = Csr {
        offsets: vec![0],
        items: Vec::new(),
    };
    for &e in elems {
        elements
            .items
            .extend(p.elements.of(e as usize).iter().map(|&v| local[v as usize]));
        elements.offsets.push(elements.items.len() as u32);
    }
    let free: Vec<bool> = global.iter().map(|&g| p.free[g as usize]).collect();
    let free_vertices = (0..global.len() as u32).filter(|&v| free[v as usize]).collect();
    let mut colors = Csr {
        offsets: vec![0],
        items: Vec::new(),
    };
    for c in 0..p.colors.len() {
        colors.items.extend(
            p.colors
                .of(c)
                .iter()
                .filter(|&&v| local[v as usize] != u32::MAX && owns(v as usize))
                .map(|&v| local[v as usize]),
        );
        colors.offsets.push(colors.items.len() as u32);
    }
    Problem {
        dim: p.dim,
        surface_mesh: p.surface_mesh,
        order: global.to_vec(),
        elem_order: elems.to_vec(),
        elements,
        corners,
        corner_element,
        corner_shape,
        corner_weight,
        shapes: p.shapes.clone(),
        model: p.model,
        incidence,
        neighbours,
        // a border edge's elements may be on another part
        simplicial: false,
        free,
        free_vertices,
        colors,
        plane: p.plane,
        sliding: p.sliding.as_ref().map(|s| s.restrict(global)),
        // the sequential sweep it orders does not run on a part
        sweep_order: None,
        order_seed: p.order_seed,
        setup_time: Duration::ZERO,
    }
}

/// Fills each part's send and receive lists from the ghosts of every part.
fn link_halos(parts: &mut [Part], owner: &[u32]) {
    let free_index = |part: &Part, g: u32| -> u32 {
        let l = part.global.binary_search(&g).expect("a shared vertex is on both parts") as u32;
        part.problem
            .free_vertices
            .binary_search(&l)
            .expect("a free vertex is free on both parts") as u32
    };
    let size = parts.len();
    // (receiver, sender) -> global ids, ascending
    let mut shared: Vec<Vec<Vec<u32>>> = vec![vec![Vec::new(); size]; size];
    for q in parts.iter() {
        for (l, &g) in q.global.iter().enumerate() {
            if !q.owned[l] && q.problem.free[l] {
                shared[q.rank as usize][owner[g as usize] as usize].push(g);
            }
        }
    }
    for q in 0..size {
        for r in 0..size {
            if shared[q][r].is_empty() {
                continue;
            }
            let recv = shared[q][r].iter().map(|&g| free_index(&parts[q], g)).collect();
            let send = shared[q][r].iter().map(|&g| free_index(&parts[r], g)).collect();
            push_exchange(&mut parts[q], r as u32, Vec::new(), recv);
            push_exchange(&mut parts[r], q as u32, send, Vec::new());
        }
    }
    for part in parts.iter_mut() {
        part.halo.sort_by_key(|h| h.rank);
    }
}

fn push_exchange(part: &mut Part, rank: u32, send: Vec<u32>, recv: Vec<u32>) {
    match part.halo.iter_mut().find(|h| h.rank == rank) {
        Some(h) => {
            h.send.extend(send);
            h.recv.extend(recv);
        }
        None => part.halo.push(Exchange { rank, send, recv }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::{mixed_block, tet_box};

    fn parts_of(mesh: &crate::Mesh, size: usize) -> (Problem, Vec<u32>, Vec<Part>) {
        let p = Problem::new(mesh).unwrap();
        let x = p.gather(&mesh.points);
        let owner = rcb(&x, size);
        let parts = split(&p, &x, &owner, size);
        (p, owner, parts)
    }

    #[test]
    fn every_corner_and_free_vertex_is_counted_once() {
        for size in 1..=4 {
            let (p, _, parts) = parts_of(&mixed_block(4, 2), size);
            let corners: usize = parts.iter().map(|q| q.owned_corners.len()).sum();
            assert_eq!(corners, p.num_corners());
            let free: usize = parts.iter().map(|q| q.owned_free.len()).sum();
            assert_eq!(free, p.free_vertices.len());
            let coloured: usize = parts.iter().map(|q| q.problem.colors.items.len()).sum();
            assert_eq!(coloured, p.free_vertices.len());
        }
    }

    #[test]
    fn owned_vertices_keep_their_corners_in_order() {
        let (p, _, parts) = parts_of(&tet_box(4, 3, 3, [1.0, 1.0, 1.0]), 3);
        for q in &parts {
            for (l, &g) in q.global.iter().enumerate().filter(|(l, _)| q.owned[*l]) {
                let whole: Vec<u32> = p.incidence.of(g as usize).iter().map(|&k| k & 3).collect();
                let here: Vec<u32> = q.problem.incidence.of(l).iter().map(|&k| k & 3).collect();
                assert_eq!(whole, here);
                for (&a, &b) in p.incidence.of(g as usize).iter().zip(q.problem.incidence.of(l)) {
                    let (ca, cb) = ((a >> 2) as usize, (b >> 2) as usize);
                    assert_eq!(p.corner_weight[ca].to_bits(), q.problem.corner_weight[cb].to_bits());
                    let back = q.problem.corners[cb].map(|v| q.global[v as usize]);
                    assert_eq!(back, p.corners[ca]);
                }
            }
        }
    }

    #[test]
    fn halos_pair_up() {
        let (_, owner, parts) = parts_of(&tet_box(5, 4, 3, [1.0, 1.0, 1.0]), 4);
        for q in &parts {
            for h in &q.halo {
                let other = &parts[h.rank as usize];
                let back = other.halo.iter().find(|o| o.rank == q.rank).unwrap();
                assert_eq!(h.recv.len(), back.send.len());
                for (&i, &j) in h.recv.iter().zip(&back.send) {
                    let gq = q.global[q.problem.free_vertices[i as usize] as usize];
                    let go = other.global[other.problem.free_vertices[j as usize] as usize];
                    assert_eq!(gq, go);
                    assert_eq!(owner[gq as usize], other.rank);
                    assert_eq!(q.free_colour[i as usize], other.free_colour[j as usize]);
                }
            }
        }
    }

    /// Each part's sliding vertices project onto the same primitives, in the
    /// same order, with the same projector, as in the whole problem.
    #[test]
    fn sliding_constraints_follow_their_vertices() {
        use crate::problem::{Boundary, BoundaryMode, ProblemOptions};
        let mesh = tet_box(5, 4, 3, [1.0, 1.0, 1.0]);
        let opts = ProblemOptions {
            boundary: Boundary {
                mode: BoundaryMode::Slide,
                ..Boundary::default()
            },
            ..ProblemOptions::default()
        };
        let p = Problem::with_options(&mesh, &opts).unwrap();
        let whole = p.sliding.as_ref().unwrap();
        let x = p.gather(&mesh.points);
        let parts = split(&p, &x, &rcb(&x, 3), 3);
        let mut slid = 0;
        for q in &parts {
            let s = q.problem.sliding.as_ref().unwrap();
            assert!(s.primitives.len() < whole.primitives.len());
            for (l, &g) in q.global.iter().enumerate() {
                assert_eq!(s.projector[l], whole.projector[g as usize]);
                let here: Vec<_> = s.candidates.of(l).iter().map(|&c| s.primitives[c as usize]).collect();
                let there: Vec<_> = whole
                    .candidates
                    .of(g as usize)
                    .iter()
                    .map(|&c| whole.primitives[c as usize])
                    .collect();
                assert_eq!(here, there);
                slid += s.slides(l) as usize;
            }
        }
        assert!(slid > 0);
    }

    #[test]
    fn one_part_is_the_whole() {
        let (p, _, parts) = parts_of(&mixed_block(3, 2), 1);
        let q = &parts[0].problem;
        assert_eq!(q.corners, p.corners);
        assert_eq!(q.incidence, p.incidence);
        assert_eq!(q.colors, p.colors);
        assert!(parts[0].halo.is_empty());
        let quality = Quality::of(&p, &vec![0; p.num_vertices()], &parts);
        assert_eq!((quality.edge_cut, quality.ghost_fraction), (0, 0.0));
    }
}
