//! Preconditioned conjugate gradients on H d = -g with a block-Jacobi
//! preconditioner, stopping on negative curvature (section 3.2 of the Newton
//! paper). Written over an operator and a preconditioner so that the same
//! loop runs a CPU or a GPU matrix.

use crate::metric::mat3::{Mat3, Vec3};
use rayon::prelude::*;

/// y = A x
pub trait LinOp {
    fn apply(&self, x: &[Vec3], y: &mut [Vec3]);
}

/// y = M^-1 x
pub trait Precond {
    fn apply(&self, x: &[Vec3], y: &mut [Vec3]);
}

impl LinOp for super::bsr::BlockCsr {
    fn apply(&self, x: &[Vec3], y: &mut [Vec3]) {
        self.mul(x, y)
    }
}

/// LDL^T of each 3x3 diagonal block, D^-1 stored so that applying it is
/// multiplications only: y = L^-T (D^-1 (L^-1 x)).
#[derive(Clone, Debug, Default)]
pub struct BlockJacobi {
    /// Per block: l10, l20, l21 and 1/d0, 1/d1, 1/d2.
    factors: Vec<[f64; 6]>,
}

impl BlockJacobi {
    /// Factors the diagonal blocks; a block that is not positive definite
    /// (cannot happen for the mean ratio, but rounding is rounding) is
    /// replaced by the identity scaled to its diagonal.
    pub fn new(diag_blocks: impl IndexedParallelIterator<Item = Mat3>) -> BlockJacobi {
        BlockJacobi {
            factors: diag_blocks.map(|h| ldlt(&h)).collect(),
        }
    }

    pub fn bytes(&self) -> usize {
        self.factors.len() * std::mem::size_of::<[f64; 6]>()
    }
}

fn ldlt(h: &Mat3) -> [f64; 6] {
    let d0 = h[0][0];
    let l10 = h[1][0] / d0;
    let l20 = h[2][0] / d0;
    let d1 = h[1][1] - l10 * l10 * d0;
    let l21 = (h[2][1] - l20 * l10 * d0) / d1;
    let d2 = h[2][2] - l20 * l20 * d0 - l21 * l21 * d1;
    if d0 > 0.0 && d1 > 0.0 && d2 > 0.0 && l21.is_finite() {
        [l10, l20, l21, 1.0 / d0, 1.0 / d1, 1.0 / d2]
    } else {
        let s = (h[0][0].abs() + h[1][1].abs() + h[2][2].abs()) / 3.0;
        let inv = if s > 0.0 { 1.0 / s } else { 1.0 };
        [0.0, 0.0, 0.0, inv, inv, inv]
    }
}

impl Precond for BlockJacobi {
    fn apply(&self, x: &[Vec3], y: &mut [Vec3]) {
        y.par_iter_mut()
            .with_min_len(1024)
            .zip(x)
            .zip(&self.factors)
            .for_each(|((yi, xi), f)| {
                let [l10, l20, l21, i0, i1, i2] = *f;
                // L^-1
                let z0 = xi[0];
                let z1 = xi[1] - l10 * z0;
                let z2 = xi[2] - l20 * z0 - l21 * z1;
                // D^-1
                let (w0, w1, w2) = (z0 * i0, z1 * i1, z2 * i2);
                // L^-T
                let y2 = w2;
                let y1 = w1 - l21 * y2;
                let y0 = w0 - l10 * y1 - l20 * y2;
                *yi = [y0, y1, y2];
            });
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PcgParams {
    pub max_iter: usize,
    /// Stop when |r| <= rtol |b|.
    pub rtol: f64,
    /// What to return when p^T A p <= 0 after the first iteration.
    pub negative_curvature: NegativeCurvature,
}

impl Default for PcgParams {
    fn default() -> Self {
        PcgParams {
            max_iter: 100,
            rtol: 1e-2,
            negative_curvature: NegativeCurvature::Direction,
        }
    }
}

/// The answer on negative curvature met after the first iteration (at the
/// first, both are the preconditioned right-hand side).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NegativeCurvature {
    /// The direction p of negative curvature, oriented so that p^T b > 0
    /// (section 3.2 of the Newton paper).
    Direction,
    /// The CG iterate so far, a descent direction from the positive definite
    /// part of the Krylov space (truncated Newton); often allows longer steps.
    Iterate,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PcgStop {
    Converged,
    MaxIterations,
    /// p^T A p <= 0 was met; the returned direction is that p, oriented downhill.
    NegativeCurvature,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PcgInfo {
    pub iterations: usize,
    pub stop: PcgStop,
    pub relative_residual: f64,
}

fn dot(a: &[Vec3], b: &[Vec3]) -> f64 {
    // fixed chunking: deterministic
    a.par_chunks(4096)
        .zip(b.par_chunks(4096))
        .map(|(x, y)| {
            x.iter()
                .zip(y)
                .map(|(u, v)| u[0] * v[0] + u[1] * v[1] + u[2] * v[2])
                .sum::<f64>()
        })
        .collect::<Vec<f64>>()
        .iter()
        .sum()
}

fn axpy(alpha: f64, x: &[Vec3], y: &mut [Vec3]) {
    y.par_iter_mut().with_min_len(4096).zip(x).for_each(|(yi, xi)| {
        for r in 0..3 {
            yi[r] += alpha * xi[r];
        }
    });
}

/// Solves A d = b approximately from d = 0. On negative curvature at the
/// first iteration the result is the preconditioned right-hand side M^-1 b
/// (for b = -g: preconditioned steepest descent); later, the direction of
/// negative curvature itself, with its sign chosen so that d^T b > 0.
pub fn pcg(a: &dyn LinOp, m: &dyn Precond, b: &[Vec3], d: &mut [Vec3], params: &PcgParams) -> PcgInfo {
    let n = b.len();
    d.iter_mut().for_each(|v| *v = [0.0; 3]);
    let mut r = b.to_vec();
    let mut z = vec![[0.0; 3]; n];
    let mut q = vec![[0.0; 3]; n];
    let bnorm = dot(b, b).sqrt();
    if bnorm == 0.0 {
        return PcgInfo {
            iterations: 0,
            stop: PcgStop::Converged,
            relative_residual: 0.0,
        };
    }
    m.apply(&r, &mut z);
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let mut rel = 1.0;
    for k in 0..params.max_iter {
        a.apply(&p, &mut q);
        let curvature = dot(&p, &q);
        if !(curvature > 0.0) {
            if k > 0 && params.negative_curvature == NegativeCurvature::Iterate {
                // d already holds the iterate
            } else if k > 0 {
                let sign = if dot(&p, b) >= 0.0 { 1.0 } else { -1.0 };
                d.par_iter_mut().zip(&p).for_each(|(di, pi)| *di = pi.map(|c| sign * c));
            } else {
                d.copy_from_slice(&p);
            }
            return PcgInfo {
                iterations: k,
                stop: PcgStop::NegativeCurvature,
                relative_residual: rel,
            };
        }
        let alpha = rz / curvature;
        axpy(alpha, &p, d);
        axpy(-alpha, &q, &mut r);
        rel = dot(&r, &r).sqrt() / bnorm;
        if rel <= params.rtol {
            return PcgInfo {
                iterations: k + 1,
                stop: PcgStop::Converged,
                relative_residual: rel,
            };
        }
        m.apply(&r, &mut z);
        let rz_new = dot(&r, &z);
        let beta = rz_new / rz;
        rz = rz_new;
        p.par_iter_mut().with_min_len(4096).zip(&z).for_each(|(pi, zi)| {
            for c in 0..3 {
                pi[c] = zi[c] + beta * pi[c];
            }
        });
    }
    PcgInfo {
        iterations: params.max_iter,
        stop: PcgStop::MaxIterations,
        relative_residual: rel,
    }
}
