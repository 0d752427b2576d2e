//! The Newton Hessian's block pattern over the free vertices, shared by both
//! backends: 3x3-block compressed sparse rows ([`BlockCsr`]), each corner's
//! slots in them, and the row ranges the CPU assembles in parallel
//! (`cpu::hessian_assemble` fills the blocks; the GPU uploads the pattern
//! and fills them with `shaders/hessian_assemble.wgsl` and
//! `shaders/hessian_gather.wgsl`).

use crate::mesh::topology::{Csr, build_par};
use crate::metric::mat3::Mat3;
use crate::problem::Problem;
use rayon::prelude::*;

/// Symmetric block matrix: row `i` holds blocks `blocks[row_offsets[i]..row_offsets[i+1]]`
/// at block columns `cols[..]` (sorted; the diagonal included).
#[derive(Clone, Debug, Default)]
pub struct BlockCsr {
    pub row_offsets: Vec<u32>,
    pub cols: Vec<u32>,
    pub blocks: Vec<Mat3>,
    /// Index of each row's diagonal block.
    pub diag: Vec<u32>,
}

impl BlockCsr {
    pub fn rows(&self) -> usize {
        self.diag.len()
    }

    /// Bytes held (structure and values).
    pub fn bytes(&self) -> usize {
        4 * (self.row_offsets.len() + self.cols.len() + self.diag.len())
            + std::mem::size_of::<Mat3>() * self.blocks.len()
    }
}

/// The Hessian's sparsity pattern for a problem, with the map from every
/// element's 4x4 vertex blocks to matrix slots, and the rows cut into
/// contiguous ranges for parallel assembly. Built once; its cost is reported
/// apart from the iterations.
#[derive(Clone, Debug)]
pub struct HessianPattern {
    /// Free index of each vertex (problem numbering), `u32::MAX` if fixed.
    pub free_index: Vec<u32>,
    /// Vertex of each free index.
    pub free_vertex: Vec<u32>,
    /// Per element, 16 block slots for local pairs (a, b) as `4a + b`; `u32::MAX` if either vertex is fixed.
    pub slots: Vec<[u32; 16]>,
    /// Row ranges, each with the elements that touch it (in locality order).
    pub ranges: Vec<RowRange>,
    pub matrix: BlockCsr,
}

/// Rows `start..end` and the corners with a vertex among them. Each range
/// is assembled by one thread that writes only its own rows, so no two
/// threads write one block; an element on a range border is evaluated once
/// per range it touches. Ranges follow the problem size, not the thread
/// count, so the sums repeat bit for bit on any machine.
#[derive(Clone, Debug)]
pub struct RowRange {
    pub start: u32,
    pub end: u32,
    pub elements: Vec<u32>,
}

/// Rows per assembly range: large enough that border elements are few.
const ROWS_PER_RANGE: usize = 2048;

/// How many assembly ranges `rows` rows are cut into: one per 2048 rows,
/// but no more than two per thread (one on one thread), since every element
/// on a range border is evaluated once per range it touches (a third more
/// evaluations on a 20^3 box cut in four). The thread count may decide this
/// without changing a bit: each row sums its corners in ascending order
/// whichever range holds it.
pub(crate) fn assembly_ranges(rows: usize) -> usize {
    let threads = rayon::current_num_threads();
    let cap = if threads == 1 { 1 } else { 2 * threads };
    rows.div_ceil(ROWS_PER_RANGE).min(cap).max(1)
}

/// The free index of each vertex (`u32::MAX` if fixed).
pub(crate) fn free_index(p: &Problem) -> Vec<u32> {
    let mut free_index = vec![u32::MAX; p.num_vertices()];
    for (i, &v) in p.free_vertices.iter().enumerate() {
        free_index[v as usize] = i as u32;
    }
    free_index
}

/// The Hessian's row pattern over the free vertices: each row's columns
/// ascending, the whole row (diagonal included) or, with `upper`, only the
/// columns after the diagonal (the symmetric store's, `SymHessian`).
pub(crate) fn pattern_rows(p: &Problem, free_index: &[u32], upper: bool) -> Csr {
    if p.simplicial {
        simplex_rows(p, &p.free_vertices, free_index, upper)
    } else {
        corner_rows(p, &p.free_vertices, free_index, upper)
    }
}

/// Row pattern: per free vertex, the free vertices sharing a corner with it
/// (for hexahedra that includes face diagonals) and itself (with `upper`,
/// those after it only), ascending, each once. Rows in parallel, each from
/// the corners around its vertex: short sorts, not one big one.
pub(crate) fn corner_rows(p: &Problem, free_vertex: &[u32], free_index: &[u32], upper: bool) -> Csr {
    let nslots = p.dim + 1;
    build_par(free_vertex.len(), |i, row| {
        let from = row.len();
        let v = free_vertex[i] as usize;
        for &packed in p.incidence.of(v) {
            let t = &p.corners[(packed >> 2) as usize];
            row.extend(
                t[..nslots]
                    .iter()
                    .map(|&w| free_index[w as usize])
                    .filter(|&j| j != u32::MAX && (!upper || j > i as u32)),
            );
        }
        if !upper {
            row.push(i as u32);
        }
        crate::mesh::topology::sort_dedup_tail(row, from);
    })
}

/// [`corner_rows`] of a simplicial problem, whose corner-sharing vertices
/// are the edge neighbours setup has already sorted: free indices ascend
/// with vertex ids, so each row is its neighbours' free indices with the
/// diagonal merged in (with `upper`, those after the diagonal), and there is
/// nothing to sort (about 96 entries a row on a tet box).
pub(crate) fn simplex_rows(p: &Problem, free_vertex: &[u32], free_index: &[u32], upper: bool) -> Csr {
    build_par(free_vertex.len(), |i, row| {
        let i = i as u32;
        // the upper rows have no diagonal to merge in
        let mut diagonal = !upper;
        for &w in p.neighbours.of(free_vertex[i as usize] as usize) {
            let j = free_index[w as usize];
            if j == u32::MAX || (upper && j <= i) {
                continue;
            }
            if diagonal && j >= i {
                diagonal = false;
                if j > i {
                    row.push(i);
                }
            }
            row.push(j);
        }
        if diagonal {
            row.push(i);
        }
    })
}

/// The `rows` rows cut into `assembly_ranges(rows)` ranges: each range's
/// first and end row and the corners with a free vertex among its rows,
/// ascending. Each corner's ranges are found in parallel (fixed chunks),
/// then handed to the ranges in corner order: a linear pass.
pub(crate) fn range_corners(p: &Problem, free_index: &[u32], rows: usize) -> Vec<(u32, u32, Vec<u32>)> {
    const CHUNK: usize = 1 << 16;
    let n = assembly_ranges(rows);
    let ends: Vec<u32> = (1..=n).map(|r| (r * rows / n) as u32).collect();
    let nslots = p.dim + 1;
    let range_of = |i: u32| ends.partition_point(|&end| end <= i);
    let touched: Vec<Vec<(u32, u32)>> = p
        .corners
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(ci, cs)| {
            let mut touched = Vec::with_capacity(cs.len() + cs.len() / 8);
            for (j, t) in cs.iter().enumerate() {
                let mut seen = [usize::MAX; 4];
                for (k, &v) in t.iter().enumerate().take(nslots) {
                    let i = free_index[v as usize];
                    if i != u32::MAX {
                        let r = range_of(i);
                        if !seen.contains(&r) {
                            seen[k] = r;
                            touched.push((r as u32, (ci * CHUNK + j) as u32));
                        }
                    }
                }
            }
            touched
        })
        .collect();
    let mut ranges: Vec<(u32, u32, Vec<u32>)> = (0..n).map(|r| ((r * rows / n) as u32, ends[r], Vec::new())).collect();
    for (r, e) in touched.into_iter().flatten() {
        ranges[r as usize].2.push(e);
    }
    ranges
}

impl HessianPattern {
    pub fn new(p: &Problem) -> HessianPattern {
        let free_index = free_index(p);
        let free_vertex: Vec<u32> = p.free_vertices.clone();
        let rows = free_vertex.len();
        let pattern = pattern_rows(p, &free_index, false);
        let (row_offsets, cols) = (pattern.offsets, pattern.items);
        let nslots = p.dim + 1;
        let diag: Vec<u32> = (0..rows)
            .into_par_iter()
            .map(|i| {
                let (a, b) = (row_offsets[i] as usize, row_offsets[i + 1] as usize);
                a as u32 + cols[a..b].binary_search(&(i as u32)).expect("diagonal present") as u32
            })
            .collect();
        // each corner's free indices and rows read once, not once per pair
        let slots: Vec<[u32; 16]> = p
            .corners
            .par_iter()
            .map(|t| {
                let f: [u32; 4] = std::array::from_fn(|k| free_index[t[k] as usize]);
                let mut s = [u32::MAX; 16];
                for a in (0..nslots).filter(|&a| f[a] != u32::MAX) {
                    let from = row_offsets[f[a] as usize];
                    let row = &cols[from as usize..row_offsets[f[a] as usize + 1] as usize];
                    s[4 * a + a] = diag[f[a] as usize];
                    for b in (0..nslots).filter(|&b| b != a && f[b] != u32::MAX) {
                        let at = row.binary_search(&f[b]).expect("pattern holds every element pair");
                        s[4 * a + b] = from + at as u32;
                    }
                }
                s
            })
            .collect();
        let ranges: Vec<RowRange> = range_corners(p, &free_index, rows)
            .into_iter()
            .map(|(start, end, elements)| RowRange { start, end, elements })
            .collect();
        let nblocks = cols.len();
        HessianPattern {
            free_index,
            free_vertex,
            slots,
            ranges,
            matrix: BlockCsr {
                row_offsets,
                cols,
                blocks: vec![[[0.0; 3]; 3]; nblocks],
                diag,
            },
        }
    }

    /// Bytes held: the pattern, its element slots and row ranges, the matrix.
    pub fn bytes(&self) -> usize {
        self.matrix.bytes()
            + 4 * (self.free_index.len() + self.free_vertex.len())
            + 64 * self.slots.len()
            + 4 * self.ranges.iter().map(|r| r.elements.len() + 2).sum::<usize>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate;
    use crate::mesh::Mesh;
    use crate::problem::{Boundary, BoundaryMode, ProblemOptions};

    fn free_maps(p: &Problem) -> (Vec<u32>, Vec<u32>) {
        (p.free_vertices.clone(), free_index(p))
    }

    /// `rows` with each row's columns up to its own index dropped.
    fn upper_of(rows: &Csr) -> Csr {
        build_par(rows.offsets.len() - 1, |i, row| {
            row.extend(rows.of(i).iter().filter(|&&j| j > i as u32))
        })
    }

    fn problems(m: &Mesh) -> Vec<Problem> {
        let slide = ProblemOptions {
            boundary: Boundary {
                mode: BoundaryMode::Slide,
                ..Default::default()
            },
            ..Default::default()
        };
        // fixed skin; sliding skin (free boundary rows); user-fixed interior vertices
        let mut fixed = m.clone();
        fixed.fixed = (0..m.num_points()).map(|v| v % 7 == 3).collect();
        vec![
            Problem::new(m).unwrap(),
            Problem::with_options(m, &slide).unwrap(),
            Problem::new(&fixed).unwrap(),
        ]
    }

    /// The simplex rows (edge neighbours, no sort) are the corner rows (every
    /// corner's vertices, sorted and deduplicated), bit for bit, on 1, 2 and
    /// 3 threads, whole or upper; only simplicial problems take them.
    #[test]
    fn simplex_rows_are_the_corner_rows_and_other_meshes_take_the_corner_rows() {
        let tets = generate::tet_box(7, 6, 5, [7.0, 6.0, 5.0]);
        let tris = generate::tri_grid(9, 8, [9.0, 8.0]);
        for (name, m) in [("tets", tets), ("triangles", tris)] {
            for (k, p) in problems(&m).iter().enumerate() {
                assert!(p.simplicial, "{name} {k}");
                let (fv, fi) = free_maps(p);
                let want = corner_rows(p, &fv, &fi, false);
                assert!(
                    want.items.len() > fv.len(),
                    "{name} {k}: rows hold more than the diagonal"
                );
                for threads in [1, 2, 3] {
                    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                    let got = pool.install(|| simplex_rows(p, &fv, &fi, false));
                    assert_eq!(got, want, "{name} {k} on {threads} threads");
                    let h = pool.install(|| HessianPattern::new(p));
                    assert_eq!((&h.matrix.row_offsets, &h.matrix.cols), (&want.offsets, &want.items));
                    // the symmetric store's rows: both paths, the columns after the diagonal
                    let upper = upper_of(&want);
                    assert!(upper.items.len() < want.items.len(), "{name} {k}");
                    assert_eq!(pool.install(|| simplex_rows(p, &fv, &fi, true)), upper, "{name} {k}");
                    assert_eq!(pool.install(|| corner_rows(p, &fv, &fi, true)), upper, "{name} {k}");
                }
            }
        }
        // a hexahedron's corners reach its face diagonals, which are no edges
        let hexes = generate::hex_box(4, 3, 3, [4.0, 3.0, 3.0]);
        for (name, m) in [("mixed", generate::mixed_block(3, 2)), ("hexes", hexes)] {
            let p = Problem::new(&m).unwrap();
            assert!(!p.simplicial, "{name}");
            let (fv, fi) = free_maps(&p);
            let h = HessianPattern::new(&p);
            let want = corner_rows(&p, &fv, &fi, false);
            assert_eq!(
                (&h.matrix.row_offsets, &h.matrix.cols),
                (&want.offsets, &want.items),
                "{name}"
            );
            assert_ne!(
                simplex_rows(&p, &fv, &fi, false),
                want,
                "{name}: edges alone would miss pairs"
            );
            assert_eq!(pattern_rows(&p, &fi, true), upper_of(&want), "{name}");
        }
    }
}
