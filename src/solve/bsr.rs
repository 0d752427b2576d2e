//! The global Hessian over the free vertices in 3x3-block compressed sparse
//! rows. Both triangles are stored so that a row-parallel product needs no
//! write conflicts (on the GPU there are no float atomics either).

use crate::metric::mat3::{Mat3, Vec3};
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

    /// y = A x
    pub fn mul(&self, x: &[Vec3], y: &mut [Vec3]) {
        y.par_iter_mut()
            .with_min_len(512)
            .enumerate()
            .for_each(|(i, yi)| {
                let mut acc = [0.0; 3];
                for s in self.row_offsets[i] as usize..self.row_offsets[i + 1] as usize {
                    let (b, xj) = (&self.blocks[s], &x[self.cols[s] as usize]);
                    for r in 0..3 {
                        acc[r] += b[r][0] * xj[0] + b[r][1] * xj[1] + b[r][2] * xj[2];
                    }
                }
                *yi = acc;
            });
    }

    /// Bytes held (structure and values).
    pub fn bytes(&self) -> usize {
        4 * (self.row_offsets.len() + self.cols.len() + self.diag.len())
            + std::mem::size_of::<Mat3>() * self.blocks.len()
    }
}

/// The Hessian's sparsity pattern for a problem, with the map from every
/// element's 4x4 vertex blocks to matrix slots and an element colouring for
/// conflict-free parallel assembly. Built once; its cost is reported apart.
#[derive(Clone, Debug)]
pub struct HessianPattern {
    /// Free index of each vertex (problem numbering), `u32::MAX` if fixed.
    pub free_index: Vec<u32>,
    /// Vertex of each free index.
    pub free_vertex: Vec<u32>,
    /// Per element, 16 block slots for local pairs (a, b) as `4a + b`; `u32::MAX` if either vertex is fixed.
    pub slots: Vec<[u32; 16]>,
    /// Element colour classes: no two elements of a class share a vertex.
    pub element_colors: crate::mesh::topology::Csr,
    pub matrix: BlockCsr,
}

impl HessianPattern {
    pub fn new(p: &Problem) -> HessianPattern {
        let n = p.num_vertices();
        let mut free_index = vec![u32::MAX; n];
        let free_vertex: Vec<u32> = p.free_vertices.clone();
        for (i, &v) in free_vertex.iter().enumerate() {
            free_index[v as usize] = i as u32;
        }
        let rows = free_vertex.len();
        // row pattern: free neighbours (tets: every vertex pair is an edge) and the diagonal
        let mut row_offsets = Vec::with_capacity(rows + 1);
        let mut cols = Vec::new();
        let mut diag = Vec::with_capacity(rows);
        row_offsets.push(0u32);
        for &v in &free_vertex {
            let i = free_index[v as usize];
            let mut row: Vec<u32> = p
                .neighbours
                .of(v as usize)
                .iter()
                .map(|&w| free_index[w as usize])
                .filter(|&j| j != u32::MAX)
                .chain(std::iter::once(i))
                .collect();
            row.sort_unstable();
            row.dedup();
            diag.push(cols.len() as u32 + row.iter().position(|&j| j == i).unwrap() as u32);
            cols.extend_from_slice(&row);
            row_offsets.push(cols.len() as u32);
        }
        let slot = |i: u32, j: u32| -> u32 {
            let (a, b) = (
                row_offsets[i as usize] as usize,
                row_offsets[i as usize + 1] as usize,
            );
            a as u32
                + cols[a..b]
                    .binary_search(&j)
                    .expect("pattern holds every element pair") as u32
        };
        let slots: Vec<[u32; 16]> = p
            .tets
            .iter()
            .map(|t| {
                let mut s = [u32::MAX; 16];
                for a in 0..4 {
                    for b in 0..4 {
                        let (i, j) = (free_index[t[a] as usize], free_index[t[b] as usize]);
                        if i != u32::MAX && j != u32::MAX {
                            s[4 * a + b] = slot(i, j);
                        }
                    }
                }
                s
            })
            .collect();
        let order: Vec<u32> = (0..p.num_elements() as u32).collect();
        let element_colors = crate::mesh::color::greedy(&order, p.num_elements(), |e| {
            p.tets[e]
                .iter()
                .flat_map(|&v| p.incidence.of(v as usize).iter().map(|&packed| packed >> 2))
        });
        let nblocks = cols.len();
        HessianPattern {
            free_index,
            free_vertex,
            slots,
            element_colors,
            matrix: BlockCsr {
                row_offsets,
                cols,
                blocks: vec![[[0.0; 3]; 3]; nblocks],
                diag,
            },
        }
    }

    /// Assembles value, free gradient and Hessian at `x` into `self.matrix` and
    /// `grad` (indexed by free index). `None` if an element is infeasible.
    pub fn assemble(&mut self, p: &Problem, x: &[Vec3], grad: &mut [Vec3]) -> Option<f64> {
        let scale = 1.0 / p.num_elements() as f64;
        self.matrix
            .blocks
            .par_iter_mut()
            .for_each(|b| *b = [[0.0; 3]; 3]);
        grad.par_iter_mut().for_each(|g| *g = [0.0; 3]);
        let blocks = SharedMut(self.matrix.blocks.as_mut_ptr());
        let grads = SharedMut(grad.as_mut_ptr());
        let mut total = 0.0;
        for c in 0..self.element_colors.len() {
            let class = self.element_colors.of(c);
            let etas: Option<Vec<f64>> = class
                .par_iter()
                .with_min_len(256)
                .map(|&e| {
                    let e = e as usize;
                    let (eta, g, h) = p.shape.hessian_blocks(&p.tet_points(x, e))?;
                    let t = &p.tets[e];
                    let slots = &self.slots[e];
                    for a in 0..4 {
                        let i = self.free_index[t[a] as usize];
                        if i == u32::MAX {
                            continue;
                        }
                        // SAFETY: elements of one colour share no vertex, and every
                        // slot written here lies in row i, owned by vertex t[a]; so
                        // no two threads touch the same gradient entry or block.
                        unsafe {
                            let gi = &mut *grads.at(i as usize);
                            for r in 0..3 {
                                gi[r] += g[a][r] * scale;
                            }
                            for b in 0..4 {
                                let s = slots[4 * a + b];
                                if s != u32::MAX {
                                    let blk = &mut *blocks.at(s as usize);
                                    for r in 0..3 {
                                        for q in 0..3 {
                                            blk[r][q] += h[a][b][r][q] * scale;
                                        }
                                    }
                                }
                            }
                        }
                    }
                    Some(eta)
                })
                .collect();
            // summed in a fixed order so the value repeats bit for bit
            total += etas?.iter().sum::<f64>();
        }
        Some(total * scale)
    }
}

/// A raw pointer the assembly shares across threads; see the SAFETY note there.
#[derive(Clone, Copy)]
struct SharedMut<T>(*mut T);
unsafe impl<T> Send for SharedMut<T> {}
unsafe impl<T> Sync for SharedMut<T> {}

impl<T> SharedMut<T> {
    /// # Safety
    /// `i` is in bounds and no other thread accesses element `i` meanwhile.
    unsafe fn at(&self, i: usize) -> *mut T {
        unsafe { self.0.add(i) }
    }
}
