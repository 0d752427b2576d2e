//! Nonlinear conjugate gradients (section 5.1 of the Reference-Jacobian
//! rezoning paper, algorithm 1): Polak–Ribière directions with
//! beta = max(beta_PR, 0), the feasibility-aware strong-Wolfe line search of
//! `wolfe`, the first step increment of each search the previous step.
//! Written once over `Backend`: the vectors, F and its gradient stay on the
//! device, and each line-search trial reads back three scalars in one flush.
//!
//! Stopping (in `solve::iterate`): the unit-free gradient norm below
//! `Params::tol` (the paper's tol_g), or a step that moved no vertex farther
//! than `NlcgParams::tol_x` mean edge lengths. The paper bounds the 2-norm of
//! the whole move; the largest vertex move is used instead so that the
//! tolerance means the same on a mesh of any size.

use super::wolfe::{Wolfe, line_search};
use super::{Sweep, accepted_step_inverted};
use crate::backend::{Backend, Coef, EvalSlots, Points, Slot, Vector};
use crate::error::Result;

/// NLCG's own settings (the gradient tolerance is `Params::tol`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NlcgParams {
    /// Stop after a step that moved no vertex farther than this many mean
    /// edge lengths (the paper's tol_x); also the resolution of the line search.
    pub tol_x: f64,
    /// The first trial of the first search (and of a restart after a failed
    /// search) moves the farthest-moving vertex this many mean edge lengths.
    pub first_move: f64,
    pub line_search: Wolfe,
}

impl Default for NlcgParams {
    fn default() -> Self {
        NlcgParams {
            tol_x: 1e-9,
            first_move: 0.1,
            line_search: Wolfe::default(),
        }
    }
}

const F: Slot = Slot(0);
const INFEASIBLE: Slot = Slot(1);
const SLOPE: Slot = Slot(2);
const GG: Slot = Slot(3);
const G_OLD: Slot = Slot(4);
const PP: Slot = Slot(5);
const PMAX: Slot = Slot(6);

const EVAL: EvalSlots = EvalSlots {
    value: F,
    infeasible: INFEASIBLE,
    min_det: None,
};

/// NLCG's vectors on the backend and what it carries between iterations.
pub struct Nlcg {
    pub params: NlcgParams,
    /// Gradient at the current point.
    g: Vector,
    /// Gradient at the last trial point.
    gt: Vector,
    /// Search direction.
    p: Vector,
    /// Length unit of `tol_x` and `first_move` (the mean edge length).
    edge: f64,
    /// F and |g|^2 at the current point.
    current: (f64, f64),
    /// The previous step length, the next search's first increment.
    alpha: Option<f64>,
    /// The direction is -g (the first, or beta was 0).
    steepest: bool,
    /// Line-search trials so far (each one evaluation of F and its gradient).
    pub evaluations: usize,
    /// Searches that met the strong Wolfe conditions, and all searches.
    pub wolfe_steps: usize,
    pub searches: usize,
}

impl Nlcg {
    /// NLCG's vectors on `be`; `edge` is the length unit of the settings.
    pub fn new<B: Backend + ?Sized>(be: &mut B, params: NlcgParams, edge: f64) -> Result<Nlcg> {
        if !(params.tol_x >= 0.0 && params.first_move > 0.0 && params.line_search.is_valid()) {
            return Err(crate::Error::InvalidArgument(format!(
                "NLCG needs tol_x >= 0, first_move > 0 and 0 < c1 < c2 < 1, got {params:?}"
            )));
        }
        Ok(Nlcg {
            params,
            g: be.vector()?,
            gt: be.vector()?,
            p: be.vector()?,
            edge,
            current: (f64::NAN, f64::NAN),
            alpha: None,
            steepest: true,
            evaluations: 0,
            wolfe_steps: 0,
            searches: 0,
        })
    }

    /// (F, |grad F|) at the current positions, `None` if infeasible there;
    /// the first direction is -grad F.
    pub fn start<B: Backend + ?Sized>(&mut self, be: &mut B) -> Result<Option<(f64, f64)>> {
        be.evaluate(Points::Current, EVAL, Some(self.g))?;
        be.norm_sq(self.g, GG)?;
        let s = be.flush()?;
        if s[INFEASIBLE.0 as usize] != 0.0 {
            return Ok(None);
        }
        be.axpby(Coef::value(-1.0), self.g, Coef::value(0.0), self.p, None)?;
        self.steepest = true;
        self.current = (s[F.0 as usize], s[GG.0 as usize]);
        Ok(Some((self.current.0, self.current.1.sqrt())))
    }

    /// One iteration: a line search along the direction (along -grad F if
    /// that fails), the step, and the next direction. Reports a zero move
    /// when no step decreased F.
    pub fn step<B: Backend + ?Sized>(&mut self, be: &mut B) -> Result<Sweep> {
        let (f, gg) = self.current;
        for attempt in 0..2 {
            if attempt == 1 {
                if self.steepest && self.alpha.is_none() {
                    break;
                }
                // the search failed along p, or from the previous step's
                // increment: restart from steepest descent and a fresh increment
                be.axpby(Coef::value(-1.0), self.g, Coef::value(0.0), self.p, None)?;
                self.steepest = true;
                self.alpha = None;
            }
            be.dot(self.g, self.p, SLOPE, None)?;
            be.dot(self.p, self.p, PP, Some(PMAX))?;
            let s = be.flush()?;
            let (slope, pmax) = (s[SLOPE.0 as usize], s[PMAX.0 as usize].sqrt());
            if !(slope < 0.0 && pmax > 0.0) {
                continue;
            }
            let delta = self.alpha.unwrap_or(self.params.first_move * self.edge / pmax);
            let tol_alpha = self.params.tol_x * self.edge / pmax;
            let (p, gt) = (self.p, self.gt);
            let mut last = f64::NAN;
            let mut phi = |a: f64| -> Result<Option<(f64, f64)>> {
                last = a;
                probe(be, a, p, gt)
            };
            let search = line_search(&mut phi, (f, slope), delta, tol_alpha, &self.params.line_search)?;
            self.evaluations += search.evaluations;
            self.searches += 1;
            self.wolfe_steps += search.strong_wolfe as usize;
            let Some(step) = search.step else {
                continue;
            };
            if step.alpha != last {
                // the gradient in `gt` is that of a later trial
                self.evaluations += 1;
                probe(be, step.alpha, p, gt)?;
            }
            be.accept_trial()?;
            std::mem::swap(&mut self.g, &mut self.gt);
            be.norm_sq(self.g, GG)?;
            be.dot(self.g, self.gt, G_OLD, None)?;
            let s = be.flush()?;
            let gg_new = s[GG.0 as usize];
            if !gg_new.is_finite() {
                return Err(accepted_step_inverted());
            }
            // Polak–Ribière, restarted (beta = 0) when negative
            let beta = ((gg_new - s[G_OLD.0 as usize]) / gg).max(0.0);
            be.axpby(Coef::value(-1.0), self.g, Coef::value(beta), self.p, None)?;
            self.steepest = beta == 0.0;
            self.alpha = Some(step.alpha);
            self.current = (step.value, gg_new);
            return Ok(Sweep {
                objective: step.value,
                grad_norm: gg_new.sqrt(),
                max_move_sq: (step.alpha * pmax).powi(2),
                cg_iterations: 0,
            });
        }
        Ok(Sweep {
            objective: f,
            grad_norm: gg.sqrt(),
            max_move_sq: 0.0,
            cg_iterations: 0,
        })
    }
}

/// F and its slope along `p` at Current + `alpha` p (gradient into `gt`),
/// `None` where infeasible: one flush.
fn probe<B: Backend + ?Sized>(be: &mut B, alpha: f64, p: Vector, gt: Vector) -> Result<Option<(f64, f64)>> {
    be.trial(Coef::value(alpha), p)?;
    be.evaluate(Points::Trial, EVAL, Some(gt))?;
    be.dot(gt, p, SLOPE, None)?;
    let s = be.flush()?;
    Ok((s[INFEASIBLE.0 as usize] == 0.0).then(|| (s[F.0 as usize], s[SLOPE.0 as usize])))
}
