//! A part set up on its own rank, from the mesh pieces that rank read, with
//! no rank ever holding the whole mesh: the partition is the piece layout.
//!
//! The data model is [`split`](super::split)'s: every vertex has one owner
//! and a global id; every element is present on each rank owning one of its
//! vertices; the other vertices of those elements are the rank's ghosts. Here
//! it is reached by messages between the ranks ([`Network`]) instead of by
//! cutting a whole problem:
//!
//! 1. **Owners and ids.** Each point is keyed by its global id when every
//!    piece carries one (`GlobalPointIds`/`GlobalNodeIds`), else by its
//!    coordinates' bits. A key's *home* rank (a hash of it) hears from every
//!    rank holding it and answers with its owner — the lowest such rank — and
//!    its global id: the file's, else a number the homes give out in turn.
//! 2. **Ghost layer.** Each rank sends every element it read to the owners of
//!    its vertices, with those vertices; it keeps the elements touching a
//!    vertex it owns.
//! 3. **Problem.** The rank builds an ordinary `Problem` on the local mesh
//!    (its own vertex order). A face through an owned vertex has all its
//!    elements here, so the boundary — what is fixed — is right for the owned
//!    vertices; a ghost's flag comes from its owner, asked by global id, and
//!    the same questions give the halo lists (both sides in ascending global
//!    id, as `split` lists them).
//! 4. **Colours.** Jones–Plassmann: in each round an uncoloured free owned
//!    vertex whose priority (a hash of its global id) beats every uncoloured
//!    free vertex sharing an element with it takes the least colour none of
//!    them has; the colours then cross the halo. No two vertices sharing an
//!    element get one colour, on any rank, so a coloured sweep moves
//!    independent vertices only.
//!
//! The colouring, the vertex order and the rank order of the partial sums are
//! not those of one process, so a solve agrees with one process to rounding
//! (Newton) or to its tolerance (coloured BCD takes another path), not bit
//! for bit. The fixed boundary only: sliding constraints need a skin of the
//! whole mesh.

use super::{Exchange, Part, Quality};
use crate::error::{Error, Result};
use crate::mesh::topology::Csr;
use crate::mesh::{ElementKind, Mesh};
use crate::metric::mat3::{Vec3, sub};
use crate::problem::{BoundaryMode, Problem, ProblemOptions, sharing_neighbours};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::collections::HashMap;
use std::time::Instant;

/// What the rank-local setup needs from the ranks' communicator.
pub trait Network {
    /// This rank's index.
    fn rank(&self) -> usize;
    /// Number of ranks.
    fn size(&self) -> usize;
    /// Sends `out[s]` to rank s (every rank calls it); what each rank sent
    /// here, by rank.
    fn all_to_all(&self, out: Vec<Vec<u8>>) -> Vec<Vec<u8>>;
    /// Every rank's `local`, rank after rank, on every rank.
    fn all_gather(&self, local: &[f64]) -> Vec<f64>;
    /// Overwrites the ghost entries of `data` (free-vector indices) with the owners'.
    fn exchange(&self, halo: &[Exchange], data: &mut [Vec3]);
}

/// `out[s]` to rank s, each list serialised; what every rank sent here.
pub fn swap<T: Serialize + DeserializeOwned>(net: &dyn Network, out: &[Vec<T>]) -> Result<Vec<Vec<T>>> {
    let bytes = out
        .iter()
        .map(|v| {
            let mut buf = Vec::new();
            ciborium::into_writer(v, &mut buf).expect("a list serialises to memory");
            buf
        })
        .collect();
    net.all_to_all(bytes)
        .iter()
        .map(|b| {
            ciborium::from_reader(&b[..]).map_err(|e| Error::InvalidArgument(format!("a malformed MPI message: {e}")))
        })
        .collect()
}

/// `local` on every rank, or the first failure: a rank that fails alone
/// would leave the others waiting for its messages.
pub fn agree<T>(net: &dyn Network, local: Result<T>) -> Result<T> {
    let failed = net.all_gather(&[f64::from(u8::from(local.is_err()))]);
    match (local, failed.iter().position(|&f| f != 0.0)) {
        (Err(e), _) => Err(e),
        (Ok(_), Some(r)) => Err(Error::InvalidArgument(format!("rank {r} failed (see its error)"))),
        (Ok(v), None) => Ok(v),
    }
}

/// A rank's part and where the points of its own mesh went.
#[derive(Debug)]
pub struct Local {
    /// This rank's part.
    pub part: Part,
    /// Global id of each point of the mesh the rank read.
    pub gid: Vec<u32>,
    /// Owner of each point of the mesh the rank read.
    pub owner: Vec<u32>,
    /// Vertices of the whole mesh (counted, never held).
    pub total_vertices: usize,
    /// Quality of the partition.
    pub quality: Quality,
}

/// An element sent to the owner of one of its vertices: a mesh of the
/// elements for one rank, with its points' global ids and owners.
#[derive(serde::Serialize, serde::Deserialize)]
struct Layer {
    mesh: Mesh,
    gid: Vec<u32>,
    owner: Vec<u32>,
}

/// SplitMix64's finaliser: priorities and homes that look random but are the
/// same on every rank and run.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// This rank's part of the mesh whose pieces the ranks read: `mesh` the
/// rank's share (its pieces merged), `ids` its points' global ids if the
/// pieces carry them. Every rank calls it; errors are every rank's.
pub fn build(net: &dyn Network, mesh: &Mesh, ids: Option<&[i64]>, opts: &ProblemOptions) -> Result<Local> {
    let start = Instant::now();
    let (me, size) = (net.rank(), net.size());
    agree(
        net,
        if opts.boundary.mode == BoundaryMode::Fixed && opts.reference.is_none() {
            Ok(())
        } else {
            Err(Error::Unsupported(
                "`partitioner pieces`: only the fixed boundary and the ideal targets (no `boundary slide`, no `reference`)"
                    .into(),
            ))
        },
    )?;
    let (gid, owner, total_vertices) = owners_and_ids(net, mesh, ids)?;
    let (local, lgid, lowner) = ghost_layer(net, mesh, &gid, &owner)?;
    let me32 = me as u32;
    let built = Problem::with_options(&local, opts).and_then(|p| match p.plane {
        Some(_) => Err(Error::Unsupported(
            "`partitioner pieces`: a planar mesh outside the planes z = constant".into(),
        )),
        None => Ok(p),
    });
    let mut p = agree(net, built)?;
    let n = p.num_vertices();
    let mut inv = vec![0u32; n];
    for (new, &old) in p.order.iter().enumerate() {
        inv[old as usize] = new as u32;
    }
    // mesh index of a global id here (the local mesh is in ascending global id)
    let at = |g: u32| lgid.binary_search(&g).ok();
    // ghosts ask their owners whether they are free; the questions, in
    // ascending global id, are the halo's order
    let mut asked: Vec<Vec<u32>> = vec![Vec::new(); size];
    for (m, &g) in lgid.iter().enumerate() {
        if lowner[m] != me32 {
            asked[lowner[m] as usize].push(g);
        }
    }
    let heard = swap(net, &asked)?;
    let answers: Vec<Vec<bool>> = heard
        .iter()
        .map(|gs| {
            gs.iter()
                .map(|&g| at(g).is_some_and(|m| p.free[inv[m] as usize]))
                .collect()
        })
        .collect();
    let told = swap(net, &answers)?;
    for (o, gs) in asked.iter().enumerate() {
        for (&g, &free) in gs.iter().zip(&told[o]) {
            let m = at(g).expect("asked about a vertex held here");
            p.free[inv[m] as usize] = free;
        }
    }
    p.free_vertices = (0..n as u32).filter(|&v| p.free[v as usize]).collect();
    let free_index = |m: usize| p.free_vertices.binary_search(&inv[m]).ok().map(|i| i as u32);
    let mut halo: Vec<Exchange> = Vec::new();
    for r in 0..size {
        let send: Vec<u32> = heard[r].iter().filter_map(|&g| at(g).and_then(free_index)).collect();
        let recv: Vec<u32> = asked[r].iter().filter_map(|&g| at(g).and_then(free_index)).collect();
        if !send.is_empty() || !recv.is_empty() {
            halo.push(Exchange {
                rank: r as u32,
                send,
                recv,
            });
        }
    }
    let global: Vec<u32> = p.order.iter().map(|&m| lgid[m as usize]).collect();
    let owned: Vec<bool> = p.order.iter().map(|&m| lowner[m as usize] == me32).collect();
    let (colors, free_colour) = colour(net, &p, &global, &owned, &halo);
    p.colors = colors;
    let owned_free = (0..p.free_vertices.len() as u32)
        .filter(|&i| owned[p.free_vertices[i as usize] as usize])
        .collect();
    // an element is counted by the owner of its first vertex (as in `split`)
    let owned_corners: Vec<u32> = (0..p.num_corners() as u32)
        .filter(|&c| {
            let e = p.elem_order[p.corner_element[c as usize] as usize] as usize;
            lowner[local.element(e)[0] as usize] == me32
        })
        .collect();
    reweigh(net, &mut p, &owned_corners, opts.metric.every_corner());
    let x = p.gather(&local.points);
    // each edge once, by the owner of its lower-id end (whose edges are all here)
    let (mut length, mut edges, mut cut) = (0.0, 0usize, 0usize);
    for v in (0..n).filter(|&v| owned[v]) {
        for &w in p.neighbours.of(v) {
            let w = w as usize;
            if global[w] > global[v] {
                length += sub(&x[v], &x[w]).iter().map(|c| c * c).sum::<f64>().sqrt();
                edges += 1;
                cut += usize::from(!owned[w]);
            }
        }
    }
    let mut part = Part {
        rank: me32,
        size: size as u32,
        x,
        global,
        owned,
        owned_free,
        owned_corners,
        halo,
        free_colour,
        problem: p,
        edge: 0.0,
        setup: start.elapsed(),
    };
    let counts = [
        length,
        edges as f64,
        cut as f64,
        part.ghosts() as f64,
        (part.owned.len() - part.ghosts()) as f64,
        part.owned_corners.len() as f64,
        part.halo_in() as f64,
    ];
    let k = counts.len();
    let all = net.all_gather(&counts);
    let total = |j: usize| (0..size).map(|r| all[r * k + j]).sum::<f64>();
    let max_mean = |j: usize| {
        let max = (0..size).map(|r| all[r * k + j]).fold(0.0, f64::max);
        max / (total(j) / size as f64).max(1e-300)
    };
    part.edge = total(0) / total(1).max(1.0);
    let quality = Quality {
        parts: size,
        edge_cut: total(2) as usize,
        edges: total(1) as usize,
        ghost_fraction: total(3) / (total_vertices.max(1) as f64),
        vertex_imbalance: max_mean(4),
        corner_imbalance: max_mean(5),
        halo_values: total(6) as usize,
    };
    part.setup = start.elapsed();
    Ok(Local {
        part,
        gid,
        owner,
        total_vertices,
        quality,
    })
}

/// The corner weights of the whole mesh: `corners` built them from the
/// local mesh's counts (F is a mean over the elements, or over all corners
/// for the metrics that use every corner); the global counts are the owned ones summed.
fn reweigh(net: &dyn Network, p: &mut Problem, owned_corners: &[u32], every: bool) {
    let mut per_element = vec![0u32; p.num_elements()];
    for &e in &p.corner_element {
        per_element[e as usize] += 1;
    }
    let mut owned_elements = vec![false; p.num_elements()];
    for &c in owned_corners {
        owned_elements[p.corner_element[c as usize] as usize] = true;
    }
    let local = [
        owned_elements.iter().filter(|&&o| o).count() as f64,
        owned_corners.len() as f64,
    ];
    let all = net.all_gather(&local);
    let elements: f64 = all.iter().step_by(2).sum();
    let corners: f64 = all.iter().skip(1).step_by(2).sum();
    for (w, &e) in p.corner_weight.iter_mut().zip(&p.corner_element) {
        // the expressions of `corners`, so the bits of one process
        *w = if every {
            1.0 / corners
        } else {
            1.0 / (elements * f64::from(per_element[e as usize]))
        };
    }
}

/// Step 1: the global id and the owner of each point of `mesh`, and the
/// number of vertices in all.
fn owners_and_ids(net: &dyn Network, mesh: &Mesh, ids: Option<&[i64]>) -> Result<(Vec<u32>, Vec<u32>, usize)> {
    let size = net.size();
    let with_ids = net
        .all_gather(&[f64::from(u8::from(ids.is_some()))])
        .iter()
        .all(|&f| f == 1.0);
    let key = |l: usize| -> [u64; 3] {
        match ids.filter(|_| with_ids) {
            Some(ids) => [ids[l] as u64, 0, 0],
            None => mesh.points[l].map(f64::to_bits),
        }
    };
    let home = |k: &[u64; 3]| (mix(k[0] ^ mix(k[1] ^ mix(k[2]))) % size as u64) as usize;
    let mut out: Vec<Vec<[u64; 3]>> = vec![Vec::new(); size];
    let mut slot = Vec::with_capacity(mesh.num_points());
    for l in 0..mesh.num_points() {
        let k = key(l);
        let h = home(&k);
        slot.push((h, out[h].len()));
        out[h].push(k);
    }
    let got = swap(net, &out)?;
    // as a home: ranks are heard in ascending order, so the first holder is the owner
    let mut first: HashMap<[u64; 3], u32> = HashMap::new();
    for (s, keys) in got.iter().enumerate() {
        for k in keys {
            first.entry(*k).or_insert(s as u32);
        }
    }
    let mut distinct: Vec<[u64; 3]> = first.keys().copied().collect();
    distinct.sort_unstable();
    let counts = net.all_gather(&[distinct.len() as f64]);
    let total = counts.iter().sum::<f64>() as usize;
    let offset = counts[..net.rank()].iter().sum::<f64>() as u64;
    let numbered: Result<HashMap<[u64; 3], u32>> = distinct
        .iter()
        .enumerate()
        .map(|(i, k)| {
            let g = if with_ids { k[0] } else { offset + i as u64 };
            u32::try_from(g)
                .ok()
                .filter(|&g| g != u32::MAX)
                .map(|g| (*k, g))
                .ok_or_else(|| Error::Unsupported(format!("global point id {} does not fit 32 bits", k[0] as i64)))
        })
        .collect();
    let numbered = agree(net, numbered)?;
    let replies: Vec<Vec<(u32, u32)>> = got
        .iter()
        .map(|keys| keys.iter().map(|k| (first[k], numbered[k])).collect())
        .collect();
    let back = swap(net, &replies)?;
    let (owner, gid) = slot.iter().map(|&(h, i)| back[h][i]).unzip();
    Ok((gid, owner, total))
}

/// Step 2: the local mesh — the elements of `mesh` touching an owned vertex
/// and those the other ranks send — in ascending global id, with each
/// point's global id and owner.
fn ghost_layer(net: &dyn Network, mesh: &Mesh, gid: &[u32], owner: &[u32]) -> Result<(Mesh, Vec<u32>, Vec<u32>)> {
    let (me, size) = (net.rank() as u32, net.size());
    let mut keep = Vec::new();
    let mut to: Vec<Vec<usize>> = vec![Vec::new(); size];
    let mut ranks = Vec::with_capacity(8);
    for e in 0..mesh.num_elements() {
        ranks.clear();
        ranks.extend(mesh.element(e).iter().map(|&v| owner[v as usize]));
        ranks.sort_unstable();
        ranks.dedup();
        for &r in &ranks {
            if r == me {
                keep.push(e);
            } else {
                to[r as usize].push(e);
            }
        }
    }
    let layer = |elems: &[usize]| {
        let verts = vertices_of(mesh, elems);
        Layer {
            mesh: mesh.cut(&verts, elems),
            gid: verts.iter().map(|&v| gid[v]).collect(),
            owner: verts.iter().map(|&v| owner[v]).collect(),
        }
    };
    let out: Vec<Vec<Layer>> = to
        .iter()
        .map(|elems| {
            if elems.is_empty() {
                Vec::new()
            } else {
                vec![layer(elems)]
            }
        })
        .collect();
    let mut layers = vec![layer(&keep)];
    layers.extend(swap(net, &out)?.into_iter().flatten());
    let mut points: HashMap<u32, (Vec3, u32, bool)> = HashMap::new();
    for l in &layers {
        for (v, (&g, &o)) in l.gid.iter().zip(&l.owner).enumerate() {
            points.entry(g).or_insert((l.mesh.points[v], o, l.mesh.is_fixed(v)));
        }
    }
    let mut lgid: Vec<u32> = points.keys().copied().collect();
    lgid.sort_unstable();
    let index: HashMap<u32, u32> = lgid.iter().enumerate().map(|(m, &g)| (g, m as u32)).collect();
    let mut local = Mesh::new(lgid.iter().map(|g| points[g].0).collect());
    let lowner = lgid.iter().map(|g| points[g].1).collect();
    if lgid.iter().any(|g| points[g].2) {
        local.fixed = lgid.iter().map(|g| points[g].2).collect();
    }
    for l in &layers {
        let to_local = |v: &u32| index[&l.gid[*v as usize]];
        for e in 0..l.mesh.num_elements() {
            let vs: Vec<u32> = l.mesh.element(e).iter().map(to_local).collect();
            if l.mesh.kinds[e] == ElementKind::Polyhedron {
                let faces: Vec<Vec<u32>> = l.mesh.faces.of(e).map(|f| f.iter().map(to_local).collect()).collect();
                local.push_polyhedron(&vs, faces.iter().map(Vec::as_slice));
            } else {
                local.push_element(l.mesh.kinds[e], &vs);
            }
        }
    }
    Ok((local, lgid, lowner))
}

/// Step 4: colour classes of the owned free vertices and the colour of every
/// free vertex (ghosts too), by Jones–Plassmann rounds over the ranks.
fn colour(net: &dyn Network, p: &Problem, global: &[u32], owned: &[bool], halo: &[Exchange]) -> (Csr, Vec<u32>) {
    const NONE: u32 = u32::MAX;
    let n = p.num_vertices();
    let shared;
    // in a simplex every two vertices share an edge
    let around = if p.simplicial {
        &p.neighbours
    } else {
        shared = sharing_neighbours(&p.elements, n);
        &shared
    };
    let priority = |v: usize| (mix(u64::from(global[v])), global[v]);
    let mut colour = vec![NONE; n];
    let mut left: Vec<u32> = p.free_vertices.iter().copied().filter(|&v| owned[v as usize]).collect();
    let mut data = vec![[0.0; 3]; p.free_vertices.len()];
    loop {
        let ready: Vec<u32> = left
            .iter()
            .copied()
            .filter(|&v| {
                around.of(v as usize).iter().all(|&w| {
                    let w = w as usize;
                    !p.free[w] || colour[w] != NONE || priority(w) < priority(v as usize)
                })
            })
            .collect();
        // no two ready vertices share an element: each beats the other
        for &v in &ready {
            let taken: Vec<u32> = around.of(v as usize).iter().map(|&w| colour[w as usize]).collect();
            colour[v as usize] = (0..).find(|c| !taken.contains(c)).expect("a free colour");
        }
        left.retain(|&v| colour[v as usize] == NONE);
        for (i, &v) in p.free_vertices.iter().enumerate() {
            data[i][0] = if colour[v as usize] == NONE {
                -1.0
            } else {
                f64::from(colour[v as usize])
            };
        }
        net.exchange(halo, &mut data);
        for (i, &v) in p.free_vertices.iter().enumerate() {
            if !owned[v as usize] && data[i][0] >= 0.0 {
                colour[v as usize] = data[i][0] as u32;
            }
        }
        let remaining = net.all_gather(&[left.len() as f64]).iter().sum::<f64>();
        if remaining == 0.0 {
            break;
        }
    }
    let own_max = (0..n)
        .filter(|&v| owned[v] && colour[v] != NONE)
        .map(|v| f64::from(colour[v]) + 1.0)
        .fold(0.0, f64::max);
    let count = net.all_gather(&[own_max]).into_iter().fold(0.0, f64::max) as usize;
    let classes = Csr::from_pairs(
        count,
        (0..n as u32)
            .filter(|&v| owned[v as usize] && p.free[v as usize])
            .map(|v| (colour[v as usize], v)),
    );
    let free_colour = p.free_vertices.iter().map(|&v| colour[v as usize]).collect();
    (classes, free_colour)
}

/// The vertices of `elems`, ascending, each once.
fn vertices_of(mesh: &Mesh, elems: &[usize]) -> Vec<usize> {
    let mut verts: Vec<usize> = elems
        .iter()
        .flat_map(|&e| mesh.element(e).iter().map(|&v| v as usize))
        .collect();
    verts.sort_unstable();
    verts.dedup();
    verts
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::{mixed_block, tet_box};
    use std::sync::{Barrier, Mutex};

    /// Ranks as threads of this process: a mailbox per (from, to) pair and
    /// a barrier between posting and collecting.
    struct Threads<'a> {
        rank: usize,
        size: usize,
        barrier: &'a Barrier,
        mail: &'a Mutex<Vec<Vec<Vec<u8>>>>,
    }

    impl Network for Threads<'_> {
        fn rank(&self) -> usize {
            self.rank
        }

        fn size(&self) -> usize {
            self.size
        }

        fn all_to_all(&self, out: Vec<Vec<u8>>) -> Vec<Vec<u8>> {
            self.mail.lock().unwrap()[self.rank] = out;
            self.barrier.wait();
            let got = (0..self.size)
                .map(|s| self.mail.lock().unwrap()[s][self.rank].clone())
                .collect();
            self.barrier.wait();
            got
        }

        fn all_gather(&self, local: &[f64]) -> Vec<f64> {
            let bytes: Vec<u8> = local.iter().flat_map(|v| v.to_le_bytes()).collect();
            self.all_to_all(vec![bytes; self.size])
                .concat()
                .chunks(8)
                .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
                .collect()
        }

        fn exchange(&self, halo: &[Exchange], data: &mut [Vec3]) {
            let mut out = vec![Vec::new(); self.size];
            for h in halo {
                out[h.rank as usize] = h.send.iter().map(|&i| data[i as usize]).collect();
            }
            let got: Vec<Vec<Vec3>> = swap(self, &out).unwrap();
            for h in halo {
                for (&i, &v) in h.recv.iter().zip(&got[h.rank as usize]) {
                    data[i as usize] = v;
                }
            }
        }
    }

    /// `mesh` cut into `size` pieces by coordinate bisection (an element to
    /// the owner of its first vertex, as the pieces are written), each set
    /// up on its own thread, with or without the pieces' global ids.
    fn set_up(mesh: &Mesh, size: usize, ids: bool) -> Vec<Local> {
        let owner = super::super::rcb(&mesh.points, size);
        let barrier = Barrier::new(size);
        let mail = Mutex::new(vec![Vec::new(); size]);
        std::thread::scope(|s| {
            let handles: Vec<_> = (0..size)
                .map(|rank| {
                    let (barrier, mail, owner) = (&barrier, &mail, &owner);
                    s.spawn(move || {
                        let elems: Vec<usize> = (0..mesh.num_elements())
                            .filter(|&e| owner[mesh.element(e)[0] as usize] as usize == rank)
                            .collect();
                        let verts = super::vertices_of(mesh, &elems);
                        let piece = mesh.cut(&verts, &elems);
                        let gid: Vec<i64> = verts.iter().map(|&v| v as i64).collect();
                        let net = Threads {
                            rank,
                            size,
                            barrier,
                            mail,
                        };
                        build(&net, &piece, ids.then_some(&gid[..]), &ProblemOptions::default()).unwrap()
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        })
    }

    /// The parts together are the whole problem's data model: each vertex
    /// owned once; free exactly where one process frees it (a vertex on a
    /// piece's cut is no boundary vertex); the corners' weights summing to
    /// one; each vertex one colour wherever it is, and no element holding
    /// two free vertices of one colour; the halos pairing up.
    #[test]
    fn parts_set_up_on_their_ranks_make_the_whole_problem() {
        for (name, mesh) in [
            ("tets", tet_box(5, 4, 3, [1.0, 1.0, 1.0])),
            ("mixed", mixed_block(4, 2)),
        ] {
            let whole = Problem::new(&mesh).unwrap();
            let mut free = vec![false; mesh.num_points()];
            for (new, &old) in whole.order.iter().enumerate() {
                free[old as usize] = whole.free[new];
            }
            for size in [2, 3] {
                for ids in [true, false] {
                    let what = format!("{name} on {size} ranks, ids {ids}");
                    let parts = set_up(&mesh, size, ids);
                    let n = parts[0].total_vertices;
                    assert_eq!(n, mesh.num_points(), "{what}");
                    // global ids are the mesh's with ids, else a numbering of the points
                    let mut point_of = vec![usize::MAX; n];
                    let mut owners = vec![0; n];
                    let mut colour = vec![u32::MAX; n];
                    let mut weight = 0.0;
                    for q in &parts {
                        let part = &q.part;
                        let p = &part.problem;
                        for (l, &g) in part.global.iter().enumerate() {
                            let at = mesh
                                .points
                                .iter()
                                .position(|x| *x == part.x[l])
                                .expect("a point of the mesh");
                            assert!(
                                point_of[g as usize] == usize::MAX || point_of[g as usize] == at,
                                "{what}"
                            );
                            point_of[g as usize] = at;
                            if ids {
                                assert_eq!(g as usize, at, "{what}");
                            }
                            assert_eq!(p.free[l], free[at], "{what}: vertex {at} free on rank {}", part.rank);
                            owners[g as usize] += usize::from(part.owned[l]);
                        }
                        for (i, &v) in p.free_vertices.iter().enumerate() {
                            let g = part.global[v as usize] as usize;
                            let c = part.free_colour[i];
                            assert_ne!(c, u32::MAX, "{what}: vertex {g} uncoloured");
                            assert!(
                                colour[g] == u32::MAX || colour[g] == c,
                                "{what}: vertex {g} two colours"
                            );
                            colour[g] = c;
                        }
                        let coloured: usize = (0..p.colors.len()).map(|c| p.colors.of(c).len()).sum();
                        assert_eq!(coloured, part.owned_free.len(), "{what}");
                        weight += part
                            .owned_corners
                            .iter()
                            .map(|&c| p.corner_weight[c as usize])
                            .sum::<f64>();
                        for h in &part.halo {
                            let other = &parts[h.rank as usize].part;
                            let back = other.halo.iter().find(|o| o.rank == part.rank).unwrap();
                            let g = |q: &Part, i: u32| q.global[q.problem.free_vertices[i as usize] as usize];
                            let here: Vec<u32> = h.recv.iter().map(|&i| g(part, i)).collect();
                            let there: Vec<u32> = back.send.iter().map(|&i| g(other, i)).collect();
                            assert_eq!(here, there, "{what}");
                        }
                    }
                    assert!(owners.iter().all(|&k| k == 1), "{what}: owners {owners:?}");
                    assert!((weight - 1.0).abs() < 1e-12, "{what}: weights sum to {weight}");
                    for q in &parts {
                        let p = &q.part.problem;
                        for e in 0..p.num_elements() {
                            let mut cs: Vec<u32> = p
                                .elements
                                .of(e)
                                .iter()
                                .filter(|&&v| p.free[v as usize])
                                .map(|&v| colour[q.part.global[v as usize] as usize])
                                .collect();
                            let k = cs.len();
                            cs.sort_unstable();
                            cs.dedup();
                            assert_eq!(cs.len(), k, "{what}: an element with two free vertices of one colour");
                        }
                    }
                }
            }
        }
    }
}
