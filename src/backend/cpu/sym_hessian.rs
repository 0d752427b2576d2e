//! The CPU Newton's Hessian in the Newton paper's storage (section 3.2):
//! diagonal blocks plus the strictly upper off-diagonal blocks in 3x3-block
//! compressed sparse rows, 64|V| + 18|E| + 19N words rather than twice the
//! off-diagonal blocks. CPU only: the GPU keeps both triangles
//! (`hessian_assemble`, `hessian_gather`, `bsr_spmv`), whose CPU twins stay
//! the reference of the kernel tests; the upper blocks here are bit for bit
//! the twins' upper blocks (same corners, same order).
//!
//! The product and the preconditioners work on fixed row ranges (their
//! count follows the problem size, never the thread count), so every sum is
//! taken in one order and results repeat bit for bit on any number of threads.
//! The assembly's ranges may follow the thread count: a row's sum order does
//! not depend on them.

use super::block_jacobi_factor::BlockJacobi;
use super::bsr_spmv::BlockCsr;
use super::project_boundary::mul3;
use crate::metric::mat3::{Mat3, Vec3, transpose};
use crate::problem::Problem;
use rayon::prelude::*;

/// Rows per product range: larger, since a block whose column leaves its
/// row's range costs a second visit in the transposed pass.
const PRODUCT_ROWS: usize = 4096;

/// Symmetric block matrix: `diag[i]` and, for j > i, the block (i, j) at
/// `blocks[row_offsets[i]..row_offsets[i+1]]` with columns `cols[..]` (sorted).
#[derive(Clone, Debug, Default)]
pub struct SymBlockCsr {
    pub diag: Vec<Mat3>,
    pub row_offsets: Vec<u32>,
    pub cols: Vec<u32>,
    pub blocks: Vec<Mat3>,
    /// Product ranges: rows `bounds[k]..bounds[k+1]`.
    bounds: Vec<u32>,
    /// For each row j, the blocks (block index, row) above it whose row lies
    /// in an earlier product range: the transposed pass adds their B^T x_row.
    cross_offsets: Vec<u32>,
    cross: Vec<[u32; 2]>,
    /// A planar problem: z couples to nothing (the corner model puts only a
    /// z-z entry on the diagonal blocks), so products skip the zero entries.
    pub planar: bool,
}

impl SymBlockCsr {
    /// From the upper pattern (`row_offsets`, `cols` sorted, every column > its row), zero blocks.
    pub fn from_pattern(row_offsets: Vec<u32>, cols: Vec<u32>) -> SymBlockCsr {
        let rows = row_offsets.len() - 1;
        let nranges = rows.div_ceil(PRODUCT_ROWS).max(1);
        let bounds: Vec<u32> = (0..=nranges).map(|r| (r * rows / nranges) as u32).collect();
        // blocks leaving their range, counted then placed by column (ascending rows within a column)
        let mut count = vec![0u32; rows + 1];
        for k in 0..nranges {
            let end = bounds[k + 1];
            for i in bounds[k]..end {
                for &j in &cols[row_offsets[i as usize] as usize..row_offsets[i as usize + 1] as usize] {
                    if j >= end {
                        count[j as usize + 1] += 1;
                    }
                }
            }
        }
        for j in 0..rows {
            count[j + 1] += count[j];
        }
        let mut cross = vec![[0u32; 2]; count[rows] as usize];
        let mut next = count.clone();
        for k in 0..nranges {
            let end = bounds[k + 1];
            for i in bounds[k]..end {
                for s in row_offsets[i as usize]..row_offsets[i as usize + 1] {
                    let j = cols[s as usize];
                    if j >= end {
                        cross[next[j as usize] as usize] = [s, i];
                        next[j as usize] += 1;
                    }
                }
            }
        }
        let n = cols.len();
        SymBlockCsr {
            diag: vec![[[0.0; 3]; 3]; rows],
            row_offsets,
            cols,
            blocks: vec![[[0.0; 3]; 3]; n],
            bounds,
            cross_offsets: count,
            cross,
            planar: false,
        }
    }

    /// The diagonal and upper blocks of a full symmetric block matrix.
    pub fn from_full(m: &BlockCsr) -> SymBlockCsr {
        let rows = m.rows();
        let mut row_offsets = vec![0u32];
        let mut cols = Vec::new();
        let mut blocks = Vec::new();
        for i in 0..rows {
            for s in m.row_offsets[i] as usize..m.row_offsets[i + 1] as usize {
                if m.cols[s] as usize > i {
                    cols.push(m.cols[s]);
                    blocks.push(m.blocks[s]);
                }
            }
            row_offsets.push(cols.len() as u32);
        }
        let mut sym = SymBlockCsr::from_pattern(row_offsets, cols);
        sym.blocks = blocks;
        sym.diag = m.diag.iter().map(|&s| m.blocks[s as usize]).collect();
        sym
    }

    /// Both triangles, columns sorted per row (the layout of `BlockCsr` and the GPU).
    pub fn to_full(&self) -> BlockCsr {
        let rows = self.rows();
        let mut entries: Vec<Vec<(u32, Mat3)>> = (0..rows).map(|i| vec![(i as u32, self.diag[i])]).collect();
        for i in 0..rows {
            for s in self.row_offsets[i] as usize..self.row_offsets[i + 1] as usize {
                let (j, b) = (self.cols[s], self.blocks[s]);
                entries[i].push((j, b));
                entries[j as usize].push((i as u32, transpose(&b)));
            }
        }
        let mut m = BlockCsr::default();
        m.row_offsets.push(0);
        for (i, mut row) in entries.into_iter().enumerate() {
            row.sort_by_key(|e| e.0);
            for (j, b) in row {
                if j as usize == i {
                    m.diag.push(m.cols.len() as u32);
                }
                m.cols.push(j);
                m.blocks.push(b);
            }
            m.row_offsets.push(m.cols.len() as u32);
        }
        m
    }

    pub fn rows(&self) -> usize {
        self.diag.len()
    }

    /// Off-diagonal blocks stored (the paper's N).
    pub fn off_diagonal_blocks(&self) -> usize {
        self.blocks.len()
    }

    /// Bytes held (structure and values).
    pub fn bytes(&self) -> usize {
        let m = std::mem::size_of::<Mat3>();
        m * (self.diag.len() + self.blocks.len())
            + 4 * (self.row_offsets.len() + self.cols.len() + self.bounds.len() + self.cross_offsets.len())
            + 8 * self.cross.len()
    }

    /// Index of block (i, j), i < j, both in the pattern.
    #[inline]
    fn slot(&self, i: u32, j: u32) -> usize {
        let (a, b) = (
            self.row_offsets[i as usize] as usize,
            self.row_offsets[i as usize + 1] as usize,
        );
        a + self.cols[a..b]
            .binary_search(&j)
            .expect("pattern holds every element pair")
    }

    /// y = A x: each product range in parallel takes its rows' products with
    /// the upper blocks and scatters their transposes into its own later rows;
    /// then a transposed pass adds the transposes that cross into later ranges.
    pub fn mul(&self, x: &[Vec3], y: &mut [Vec3]) {
        if self.planar {
            self.mul_dim::<2>(x, y)
        } else {
            self.mul_dim::<3>(x, y)
        }
    }

    /// `mul` reading the leading D x D part of the off-diagonal blocks: in a
    /// planar problem their z rows and columns are exactly zero.
    fn mul_dim<const D: usize>(&self, x: &[Vec3], y: &mut [Vec3]) {
        let parts = split_rows(&self.bounds, y);
        parts.into_par_iter().for_each(|(start, ys)| {
            let end = start + ys.len();
            ys.iter_mut().for_each(|v| *v = [0.0; 3]);
            for i in start..end {
                let xi = x[i];
                let d = &self.diag[i];
                let mut acc = if D == 2 {
                    [
                        d[0][0] * xi[0] + d[0][1] * xi[1],
                        d[1][0] * xi[0] + d[1][1] * xi[1],
                        d[2][2] * xi[2],
                    ]
                } else {
                    mv(d, &xi)
                };
                let (a, b) = (self.row_offsets[i] as usize, self.row_offsets[i + 1] as usize);
                for (blk, &j) in self.blocks[a..b].iter().zip(&self.cols[a..b]) {
                    let j = j as usize;
                    let xj = x[j];
                    for r in 0..D {
                        for c in 0..D {
                            acc[r] += blk[r][c] * xj[c];
                        }
                    }
                    if j < end {
                        let mut t = [0.0; 3];
                        for c in 0..D {
                            for r in 0..D {
                                t[c] += blk[r][c] * xi[r];
                            }
                        }
                        let yj = &mut ys[j - start];
                        for c in 0..D {
                            yj[c] += t[c];
                        }
                    }
                }
                let yi = &mut ys[i - start];
                for r in 0..3 {
                    yi[r] += acc[r];
                }
            }
        });
        if self.cross.is_empty() {
            return;
        }
        y.par_iter_mut().with_min_len(512).enumerate().for_each(|(j, yj)| {
            for e in &self.cross[self.cross_offsets[j] as usize..self.cross_offsets[j + 1] as usize] {
                let (blk, xi) = (&self.blocks[e[0] as usize], &x[e[1] as usize]);
                for c in 0..D {
                    for r in 0..D {
                        yj[c] += blk[r][c] * xi[r];
                    }
                }
            }
        });
    }

    /// H <- P H P + (I - P) on the diagonal: the Hessian restricted to the
    /// directions the vertices may move in (as `constrain_blocks` does to the full matrix).
    pub fn constrain(&mut self, projector: &[Mat3], free_vertices: &[u32]) {
        let p = |i: usize| &projector[free_vertices[i] as usize];
        self.diag.par_iter_mut().enumerate().for_each(|(i, d)| {
            let pi = p(i);
            let mut c = mul3(pi, &mul3(d, pi));
            for r in 0..3 {
                for q in 0..3 {
                    c[r][q] += if r == q { 1.0 } else { 0.0 } - pi[r][q];
                }
            }
            *d = c;
        });
        let (offsets, cols) = (&self.row_offsets, &self.cols);
        let parts = split_rows_blocks(offsets, &mut self.blocks);
        parts.into_par_iter().for_each(|(i, blocks)| {
            let pi = p(i);
            for (b, &j) in blocks.iter_mut().zip(&cols[offsets[i] as usize..]) {
                *b = mul3(pi, &mul3(b, p(j as usize)));
            }
        });
    }

    /// y = M^-1 x for symmetric block Gauss-Seidel on each product range
    /// (couplings between ranges dropped, which keeps it parallel and
    /// symmetric positive definite): M = (D + L) D^-1 (D + U), with D^-1
    /// applied through the block-Jacobi factors.
    pub fn sgs(&self, jacobi: &BlockJacobi, x: &[Vec3], y: &mut [Vec3]) {
        if self.planar {
            self.sgs_dim::<2>(jacobi, x, y)
        } else {
            self.sgs_dim::<3>(jacobi, x, y)
        }
    }

    /// `sgs` reading the leading D x D part of the off-diagonal blocks (as
    /// `mul_dim`): in a planar problem the rest is exactly zero.
    fn sgs_dim<const D: usize>(&self, jacobi: &BlockJacobi, x: &[Vec3], y: &mut [Vec3]) {
        let f = jacobi.factors();
        let parts = split_rows(&self.bounds, y);
        parts.into_par_iter().for_each(|(start, ys)| {
            let end = start + ys.len();
            ys.copy_from_slice(&x[start..end]);
            // forward: (D + L) w = x, the L column of row i being row i of U transposed
            for i in start..end {
                let w = ldlt_solve(&f[i], &ys[i - start]);
                ys[i - start] = w;
                for s in self.row_offsets[i] as usize..self.row_offsets[i + 1] as usize {
                    let j = self.cols[s] as usize;
                    if j >= end {
                        break;
                    }
                    let (b, yj) = (&self.blocks[s], &mut ys[j - start]);
                    for c in 0..D {
                        let mut t = 0.0;
                        for r in 0..D {
                            t += b[r][c] * w[r];
                        }
                        yj[c] -= t;
                    }
                }
            }
            // backward: (D + U) y = D w
            for i in (start..end).rev() {
                let mut acc = [0.0; 3];
                for s in self.row_offsets[i] as usize..self.row_offsets[i + 1] as usize {
                    let j = self.cols[s] as usize;
                    if j >= end {
                        break;
                    }
                    let (b, yj) = (&self.blocks[s], &ys[j - start]);
                    for r in 0..D {
                        let mut t = 0.0;
                        for c in 0..D {
                            t += b[r][c] * yj[c];
                        }
                        acc[r] += t;
                    }
                }
                let t = ldlt_solve(&f[i], &acc);
                let yi = &mut ys[i - start];
                for r in 0..3 {
                    yi[r] -= t[r];
                }
            }
        });
    }
}

#[inline]
fn mv(b: &Mat3, x: &Vec3) -> Vec3 {
    [0, 1, 2].map(|r| b[r][0] * x[0] + b[r][1] * x[1] + b[r][2] * x[2])
}

/// L^-T D^-1 L^-1 x with one block's factors (as `block_jacobi` applies them).
#[inline]
fn ldlt_solve(f: &[f64; 6], x: &Vec3) -> Vec3 {
    let [l10, l20, l21, i0, i1, i2] = *f;
    let z0 = x[0];
    let z1 = x[1] - l10 * z0;
    let z2 = x[2] - l20 * z0 - l21 * z1;
    let (w0, w1, w2) = (z0 * i0, z1 * i1, z2 * i2);
    let y2 = w2;
    let y1 = w1 - l21 * y2;
    let y0 = w0 - l10 * y1 - l20 * y2;
    [y0, y1, y2]
}

/// `y` cut at `bounds`: (first row, rows).
fn split_rows<'a>(bounds: &[u32], mut y: &'a mut [Vec3]) -> Vec<(usize, &'a mut [Vec3])> {
    let mut parts = Vec::with_capacity(bounds.len());
    for w in bounds.windows(2) {
        let (a, rest) = y.split_at_mut((w[1] - w[0]) as usize);
        parts.push((w[0] as usize, a));
        y = rest;
    }
    parts
}

/// Each row's upper blocks: (row, blocks).
fn split_rows_blocks<'a>(offsets: &[u32], mut blocks: &'a mut [Mat3]) -> Vec<(usize, &'a mut [Mat3])> {
    let mut parts = Vec::with_capacity(offsets.len());
    for (i, w) in offsets.windows(2).enumerate() {
        let (a, rest) = blocks.split_at_mut((w[1] - w[0]) as usize);
        parts.push((i, a));
        blocks = rest;
    }
    parts
}

/// Newton's CPU Hessian for a problem: the upper pattern, the free
/// numbering and the assembly ranges. Element pairs find their block by a
/// search in a short row instead of a stored per-corner map, which the
/// paper's memory budget has no room for.
#[derive(Clone, Debug)]
pub struct SymHessian {
    /// Free index of each vertex (problem numbering), `u32::MAX` if fixed.
    pub free_index: Vec<u32>,
    /// Assembly ranges: rows `start..end` and the corners with a vertex among them, ascending.
    ranges: Vec<(u32, u32, Vec<u32>)>,
    pub matrix: SymBlockCsr,
}

impl SymHessian {
    pub fn new(p: &Problem) -> SymHessian {
        use crate::backend::hessian_pattern::{free_index, pattern_rows, range_corners};
        let free_index = free_index(p);
        // the rows' columns after the diagonal, as the full pattern has them
        let pattern = pattern_rows(p, &free_index, true);
        let (row_offsets, cols) = (pattern.offsets, pattern.items);
        let ranges = range_corners(p, &free_index, p.free_vertices.len());
        SymHessian {
            free_index,
            ranges,
            matrix: SymBlockCsr {
                planar: p.in_plane(),
                ..SymBlockCsr::from_pattern(row_offsets, cols)
            },
        }
    }

    /// Bytes held: the free numbering, the assembly ranges and the matrix.
    pub fn bytes(&self) -> usize {
        self.matrix.bytes() + 4 * self.free_index.len() + 4 * self.ranges.iter().map(|r| r.2.len() + 2).sum::<usize>()
    }

    /// Assembles the free gradient (by free index) and the Hessian of F at
    /// `x`, each block summed over its corners in ascending order by the one
    /// range that owns its row. `false` if an element is infeasible.
    pub fn assemble(&mut self, p: &Problem, x: &[Vec3], grad: &mut [Vec3]) -> bool {
        let nslots = p.dim + 1;
        let m = &mut self.matrix;
        let offsets = &m.row_offsets;
        let cols = &m.cols;
        let mut parts = Vec::with_capacity(self.ranges.len());
        let (mut blocks, mut diags, mut grads) = (&mut m.blocks[..], &mut m.diag[..], &mut grad[..]);
        for r in &self.ranges {
            let nb = (offsets[r.1 as usize] - offsets[r.0 as usize]) as usize;
            let nr = (r.1 - r.0) as usize;
            let (b, rest_b) = blocks.split_at_mut(nb);
            let (d, rest_d) = diags.split_at_mut(nr);
            let (g, rest_g) = grads.split_at_mut(nr);
            parts.push((r, b, d, g));
            (blocks, diags, grads) = (rest_b, rest_d, rest_g);
        }
        let free_index = &self.free_index;
        parts.into_par_iter().all(|(r, blocks, diags, grads)| {
            let (start, end) = (r.0, r.1);
            blocks.iter_mut().for_each(|b| *b = [[0.0; 3]; 3]);
            diags.iter_mut().for_each(|b| *b = [[0.0; 3]; 3]);
            grads.iter_mut().for_each(|g| *g = [0.0; 3]);
            let mut h = [[[[0.0; 3]; 3]; 4]; 4];
            let rows = Rows {
                start,
                end,
                offsets,
                cols,
                base: offsets[start as usize] as usize,
            };
            for &e in &r.2 {
                let e = e as usize;
                let (shape, xe) = (p.shape(e), p.corner_points(x, e));
                let t = &p.corners[e];
                let fi: [u32; 4] = std::array::from_fn(|a| {
                    if a < nslots {
                        free_index[t[a] as usize]
                    } else {
                        u32::MAX
                    }
                });
                let scale = p.corner_weight[e];
                // the tetrahedral mean ratio builds only the blocks this
                // range stores, in the same arithmetic as `upper_blocks`
                if p.model.fast(shape.n) {
                    let Some(f) = shape.tet.block_factors(&xe) else {
                        return false;
                    };
                    rows.scatter(
                        &fi,
                        nslots,
                        scale,
                        &f.grad,
                        |a, b| f.block(&shape.tet, a, b),
                        blocks,
                        diags,
                        grads,
                    );
                } else {
                    let Some((_, g)) = p.model.upper_blocks(shape, &xe, &mut h) else {
                        return false;
                    };
                    rows.scatter(&fi, nslots, scale, &g, |a, b| h[a][b], blocks, diags, grads);
                }
            }
            true
        })
    }

    /// Block (i, j), i < j, of the matrix (for tests).
    pub fn block(&self, i: u32, j: u32) -> Mat3 {
        self.matrix.blocks[self.matrix.slot(i, j)]
    }
}

/// One assembly range's rows of the matrix.
struct Rows<'a> {
    start: u32,
    end: u32,
    offsets: &'a [u32],
    cols: &'a [u32],
    /// Index of the range's first block.
    base: usize,
}

impl Rows<'_> {
    /// Adds `scale` times one element's gradient and Hessian blocks to the
    /// rows of this range; `block(a, b)` gives the element's block (a, b)
    /// for a <= b only.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn scatter(
        &self,
        fi: &[u32; 4],
        nslots: usize,
        scale: f64,
        g: &[Vec3; 4],
        block: impl Fn(usize, usize) -> Mat3,
        blocks: &mut [Mat3],
        diags: &mut [Mat3],
        grads: &mut [Vec3],
    ) {
        for a in 0..nslots {
            let i = fi[a];
            if i < self.start || i >= self.end {
                continue;
            }
            let li = (i - self.start) as usize;
            for c in 0..3 {
                grads[li][c] += g[a][c] * scale;
            }
            add(&mut diags[li], &block(a, a), scale);
            let (ra, rb) = (self.offsets[i as usize] as usize, self.offsets[i as usize + 1] as usize);
            for b in 0..nslots {
                let j = fi[b];
                if j == u32::MAX || j <= i {
                    continue;
                }
                // rows hold a handful of columns: a scan beats a bisection
                let s = ra
                    + self.cols[ra..rb]
                        .iter()
                        .position(|&c| c == j)
                        .expect("pattern holds every element pair");
                let dest = &mut blocks[s - self.base];
                if a < b {
                    add(dest, &block(a, b), scale);
                } else {
                    add(dest, &transpose(&block(b, a)), scale);
                }
            }
        }
    }
}

#[inline(always)]
fn add(blk: &mut Mat3, h: &Mat3, scale: f64) {
    for c in 0..3 {
        for q in 0..3 {
            blk[c][q] += h[c][q] * scale;
        }
    }
}
