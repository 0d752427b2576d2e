//! Inexact Newton (section 3.2 of the Newton paper): the global Hessian over
//! the free vertices, PCG with a block-Jacobi preconditioner for the
//! direction (a direction of negative curvature when CG meets one), and an
//! Armijo line search on the global objective with infeasible points rejected.

use super::bcd::LineSearch;
use super::bsr::HessianPattern;
use super::pcg::{BlockJacobi, NegativeCurvature, PcgInfo, PcgParams, pcg};
use crate::metric::mat3::Vec3;
use crate::objective;
use crate::problem::Problem;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Newton's own settings (termination is in `Params`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewtonParams {
    /// Most CG iterations per Newton step.
    pub cg_max_iter: usize,
    /// Forcing term: CG stops at |r| <= eta |g| with
    /// eta = min(forcing_max, sqrt(|g| / |g_0|)), which tightens as Newton converges.
    pub forcing_max: f64,
    /// On negative curvature: the CG iterate (default: on the test meshes it
    /// takes fewer Newton iterations) or the direction itself, as in the paper.
    pub negative_curvature: NegativeCurvature,
}

impl Default for NewtonParams {
    fn default() -> Self {
        NewtonParams {
            cg_max_iter: 100,
            forcing_max: 0.5,
            negative_curvature: NegativeCurvature::Iterate,
        }
    }
}

/// Buffers and pattern held across Newton iterations.
pub struct Newton {
    pub pattern: HessianPattern,
    pub params: NewtonParams,
    grad: Vec<Vec3>,
    rhs: Vec<Vec3>,
    dir: Vec<Vec3>,
    trial: Vec<Vec3>,
    g0: Option<f64>,
    /// F at the current point when `grad` and the matrix are assembled there.
    current: Option<f64>,
    /// What the last PCG solve did.
    pub last_pcg: Option<PcgInfo>,
    pub cg_iterations: usize,
    /// Time to build the sparsity pattern (reported apart from the iterations).
    pub setup_time: Duration,
}

impl Newton {
    pub fn new(p: &Problem, params: NewtonParams) -> Newton {
        let start = Instant::now();
        let pattern = HessianPattern::new(p);
        let m = pattern.free_vertex.len();
        Newton {
            pattern,
            params,
            grad: vec![[0.0; 3]; m],
            rhs: vec![[0.0; 3]; m],
            dir: vec![[0.0; 3]; m],
            trial: Vec::new(),
            g0: None,
            current: None,
            last_pcg: None,
            cg_iterations: 0,
            setup_time: start.elapsed(),
        }
    }

    /// Bytes held by the solver (pattern, matrix, preconditioner, vectors).
    pub fn bytes(&self) -> usize {
        let m = self.grad.len();
        self.pattern.matrix.bytes()
            + 4 * (self.pattern.free_index.len() + self.pattern.free_vertex.len())
            + 64 * self.pattern.slots.len()
            + 4 * self.pattern.ranges.iter().map(|r| r.elements.len() + 2).sum::<usize>()
            + 48 * m // preconditioner factors
            + 24 * (3 * m + 4 * m) // grad, rhs, dir; PCG's r, z, p, q
            + 24 * self.pattern.free_index.len() // trial positions
    }

    /// Assembles gradient and Hessian at `x` unless the last step already did.
    fn ensure_assembled(&mut self, p: &Problem, x: &[Vec3]) -> Option<f64> {
        if self.current.is_none() {
            if !self.pattern.assemble(p, x, &mut self.grad) {
                return None;
            }
            self.current = Some(objective::value(p, x)?);
        }
        self.current
    }

    /// One Newton iteration. Returns F and |grad F| at the new point (the
    /// assembly for the next iteration is done here, so nothing is evaluated
    /// twice) and the largest squared vertex displacement, 0 when the line
    /// search found no acceptable step.
    pub fn step(&mut self, p: &Problem, x: &mut [Vec3], ls: &LineSearch) -> Option<(f64, f64, f64)> {
        let f = self.ensure_assembled(p, x)?;
        let gnorm = objective::norm(&self.grad);
        let g0 = *self.g0.get_or_insert(gnorm);
        let rtol = self.params.forcing_max.min((gnorm / g0).sqrt());
        let m = &self.pattern.matrix;
        let precond = BlockJacobi::new(m.diag.par_iter().map(|&s| m.blocks[s as usize]));
        self.rhs
            .par_iter_mut()
            .zip(&self.grad)
            .for_each(|(r, g)| *r = g.map(|c| -c));
        let pcg_params = PcgParams {
            max_iter: self.params.cg_max_iter,
            rtol,
            negative_curvature: self.params.negative_curvature,
        };
        let info = pcg(m, &precond, &self.rhs, &mut self.dir, &pcg_params);
        self.cg_iterations += info.iterations;
        self.last_pcg = Some(info);
        let slope_of = |g: &[Vec3], d: &[Vec3]| -> f64 {
            g.iter()
                .zip(d)
                .map(|(g, d)| g[0] * d[0] + g[1] * d[1] + g[2] * d[2])
                .sum()
        };
        let mut slope = slope_of(&self.grad, &self.dir);
        if !(slope < 0.0) {
            // not downhill (rounding at a near-stationary point): preconditioned steepest descent
            use super::pcg::Precond;
            precond.apply(&self.rhs, &mut self.dir);
            slope = slope_of(&self.grad, &self.dir);
            if !(slope < 0.0) {
                return Some((f, gnorm, 0.0));
            }
        }
        let mut alpha = 1.0;
        for _ in 0..=ls.max_backtracks {
            self.trial.clear();
            self.trial.extend_from_slice(x);
            for (d, &v) in self.dir.iter().zip(&self.pattern.free_vertex) {
                let t = &mut self.trial[v as usize];
                for c in 0..3 {
                    t[c] += alpha * d[c];
                }
            }
            if let Some(ft) = objective::value(p, &self.trial)
                && ft <= f + ls.sigma * alpha * slope
            {
                x.copy_from_slice(&self.trial);
                let dmax = self
                    .dir
                    .iter()
                    .map(|d| d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
                    .fold(0.0, f64::max);
                // the next iteration's gradient and Hessian, and this one's |grad F|
                if !self.pattern.assemble(p, x, &mut self.grad) {
                    return None;
                }
                self.current = Some(ft);
                return Some((ft, objective::norm(&self.grad), alpha * alpha * dmax));
            }
            alpha *= ls.beta;
        }
        Some((f, gnorm, 0.0))
    }
}
