//! Inexact Newton (section 3.2 of the Newton paper): the global Hessian over
//! the free vertices, PCG with a block-Jacobi preconditioner for the
//! direction (a direction of negative curvature when CG meets one), and an
//! Armijo line search on the global objective with infeasible points
//! rejected. Written once over `Backend`.

use super::line_search::LineSearch;
use super::pcg::{FIRST_FREE_SLOT, NegativeCurvature, PcgInfo, PcgParams, PcgStop, PcgWork, Preconditioner, pcg};
use super::{Sweep, accepted_step_inverted};
use crate::backend::{Backend, Coef, EvalSlots, Points, Slot, Vector};
use crate::error::Result;
use std::time::{Duration, Instant};

/// Newton's own settings (termination is in `solve::Params`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NewtonParams {
    /// Most CG iterations per Newton step.
    pub cg_max_iter: usize,
    /// Forcing term: CG stops at |r| <= eta |g| with
    /// eta = min(forcing_max, sqrt(|g| / |g_0|)), which tightens as Newton converges.
    pub forcing_max: f64,
    /// The cap on eta instead of `forcing_max` at the first step and after
    /// a step whose CG met no negative curvature: where the Hessian looks convex, a more exact
    /// solve saves whole Newton iterations (an assembly each; on Mesquite's
    /// cub_wedge_like 2 instead of 4 to its final F), while on the
    /// nonconvex meshes CG stops at negative curvature anyway.
    #[serde(default = "default_forcing_convex")]
    pub forcing_convex: f64,
    /// On negative curvature: the CG iterate (default: on the test meshes it
    /// takes fewer Newton iterations) or the direction itself, as in the paper.
    pub negative_curvature: NegativeCurvature,
    /// The global Armijo line search.
    pub line_search: LineSearch,
    /// CG's preconditioner.
    pub preconditioner: Preconditioner,
    /// After a trial step that inverts an element, the next trial goes to
    /// this fraction of the distance at which the first corner inverts
    /// (found from the corners' determinant polynomials), whether that is
    /// longer or shorter than half the step; 0 halves blindly, as the
    /// paper's Armijo search does. On the hard planar meshes most trials were
    /// halvings until nothing inverted.
    #[serde(default = "default_inversion_fraction")]
    pub inversion_fraction: f64,
    /// At most this many coloured BCD sweeps before the first Newton step,
    /// ended early once a sweep decreases F by more than
    /// [`START_SLOWDOWN`] of the sweep before it (BCD has stopped gaining
    /// fast); 0 (the default) starts with Newton, as the paper does. Far
    /// from the optimum the objective is not convex and Newton's steps meet
    /// negative curvature, where a sweep costs less and gains more: on a
    /// randomly perturbed 30^3 box (162k tets, worst element 2283, CPU,
    /// 2 threads) 6 sweeps cut Newton from 19 iterations (14 on negative
    /// curvature) to 3 and the solve from 0.76-1.15 s to 0.62-0.68 s, to the
    /// same F. On Mesquite's milder test meshes, where Newton needs 4-9
    /// iterations, the sweeps cost more than they save (tire 0.070 s against
    /// 0.051 s, cub_wedge_like 0.54 against 0.37 on one thread), so they are
    /// not the default.
    #[serde(default = "default_start_sweeps")]
    pub start_sweeps: usize,
}

/// The start's BCD sweeps end once a sweep's decrease of F exceeds this
/// fraction of the previous sweep's: BCD's linear rate has slowed (it was
/// 0.18-0.19 for five sweeps on the perturbed boxes, then rose).
pub const START_SLOWDOWN: f64 = 0.25;

impl NewtonParams {
    /// Settings outside their ranges as an error naming the setting (the
    /// command line's and the Python API's names are the same).
    pub fn check(&self) -> crate::Result<()> {
        let bad =
            |what: &str, v: f64, range: &str| Err(crate::Error::InvalidArgument(format!("{what} {v} must be {range}")));
        if !(0.0..1.0).contains(&self.inversion_fraction) {
            return bad("inversion fraction", self.inversion_fraction, "at least 0 and below 1");
        }
        if !(self.forcing_max > 0.0 && self.forcing_max < 1.0) {
            return bad("forcing term", self.forcing_max, "above 0 and below 1");
        }
        if self.cg_max_iter == 0 {
            return bad("CG iteration limit", 0.0, "at least 1");
        }
        Ok(())
    }
}

impl NewtonParams {
    /// Newton as section 3.2 of the Newton paper describes it: block-Jacobi
    /// PCG, the direction of negative curvature itself when CG meets one,
    /// and an Armijo search that halves a step until nothing inverts, from
    /// the first iteration (no BCD sweeps first). The
    /// paper gives no forcing term, so CG keeps one cap throughout (no
    /// tighter solve where the Hessian looks convex, which is this
    /// library's addition). `NewtonParams::default()` is the faster variant.
    pub fn paper() -> NewtonParams {
        let d = NewtonParams::default();
        NewtonParams {
            forcing_convex: d.forcing_max,
            negative_curvature: NegativeCurvature::Direction,
            preconditioner: Preconditioner::Jacobi,
            inversion_fraction: 0.0,
            ..d
        }
    }
}

fn default_forcing_convex() -> f64 {
    NewtonParams::default().forcing_convex
}

fn default_start_sweeps() -> usize {
    NewtonParams::default().start_sweeps
}

fn default_inversion_fraction() -> f64 {
    NewtonParams::default().inversion_fraction
}

impl Default for NewtonParams {
    fn default() -> Self {
        NewtonParams {
            cg_max_iter: 100,
            forcing_max: 0.5,
            forcing_convex: 0.1,
            negative_curvature: NegativeCurvature::Iterate,
            line_search: LineSearch::default(),
            preconditioner: Preconditioner::Jacobi,
            inversion_fraction: 0.7,
            start_sweeps: 0,
        }
    }
}

// Newton's scalar slots, after PCG's
const F: Slot = Slot(FIRST_FREE_SLOT);
const INFEASIBLE: Slot = Slot(FIRST_FREE_SLOT + 1);
const GG: Slot = Slot(FIRST_FREE_SLOT + 2);
const SLOPE: Slot = Slot(FIRST_FREE_SLOT + 3);
const DD: Slot = Slot(FIRST_FREE_SLOT + 4);
const DMAX: Slot = Slot(FIRST_FREE_SLOT + 5);
const INVERSION: Slot = Slot(FIRST_FREE_SLOT + 6);

const EVAL: EvalSlots = EvalSlots {
    value: F,
    infeasible: INFEASIBLE,
    min_det: None,
};

/// Newton's vectors on the backend and what it carries between iterations.
pub struct Newton {
    /// Newton's settings.
    pub params: NewtonParams,
    g: Vector,
    rhs: Vector,
    d: Vector,
    work: PcgWork,
    g0: Option<f64>,
    /// (F, |grad F|) at the current point, where gradient and Hessian are assembled.
    current: (f64, f64),
    /// What the last PCG solve did.
    pub last_pcg: Option<PcgInfo>,
    /// CG iterations over all Newton steps so far.
    pub cg_iterations: usize,
    /// Time to build the Hessian pattern and the vectors (reported apart from the iterations).
    pub setup_time: Duration,
    /// Bytes of the pattern, the matrix and the preconditioner.
    pub hessian_bytes: usize,
}

impl Newton {
    /// Builds the Hessian pattern and Newton's vectors on `be`, then
    /// assembles at the current positions. Fails if they are infeasible.
    pub fn new<B: Backend + ?Sized>(be: &mut B, params: NewtonParams) -> Result<Newton> {
        let start = Instant::now();
        be.set_preconditioner(params.preconditioner)?;
        let hessian_bytes = be.prepare_hessian()?;
        let (g, rhs, d) = (be.vector()?, be.vector()?, be.vector()?);
        let work = PcgWork::new(be)?;
        let setup_time = start.elapsed();
        Ok(Newton {
            params,
            g,
            rhs,
            d,
            work,
            g0: None,
            current: (f64::NAN, f64::NAN),
            last_pcg: None,
            cg_iterations: 0,
            setup_time,
            hessian_bytes,
        })
    }

    /// Assembles at the current positions: (F, |grad F|), or `None` when
    /// they are infeasible on this backend.
    pub fn start<B: Backend + ?Sized>(&mut self, be: &mut B) -> Result<Option<(f64, f64)>> {
        be.evaluate(Points::Current, EVAL, None)?;
        let s = be.flush()?;
        if s[INFEASIBLE.0 as usize] != 0.0 {
            return Ok(None);
        }
        be.assemble(self.g)?;
        be.norm_sq(self.g, GG)?;
        let s = be.flush()?;
        self.current = (s[F.0 as usize], s[GG.0 as usize].sqrt());
        Ok(Some(self.current))
    }

    /// The gradient and last direction vectors, for tests.
    pub fn vectors(&self) -> (Vector, Vector) {
        (self.g, self.d)
    }

    /// The step after a rejected trial at `alpha`: halved, or, when the
    /// trial inverted a corner, `inversion_fraction` of the way to where
    /// the first corner inverts (longer or shorter than half).
    fn next_trial<B: Backend + ?Sized>(&self, be: &mut B, alpha: f64, inverted: bool) -> Result<f64> {
        let halved = alpha * self.params.line_search.beta;
        let theta = self.params.inversion_fraction;
        if !inverted || !(theta > 0.0) {
            return Ok(halved);
        }
        be.inversion_fraction(INVERSION)?;
        let t = be.flush()?[INVERSION.0 as usize];
        // NaN: the backend does not know; +inf or >= 1: something else was infeasible
        Ok(if t > 0.0 && t < 1.0 { theta * t * alpha } else { halved })
    }

    /// One Newton iteration from an assembled point (`start` first): F and
    /// |grad F| at the new point (assembled there for the next iteration)
    /// and the largest squared vertex move, 0 when the line search found no
    /// acceptable step.
    pub fn step<B: Backend + ?Sized>(&mut self, be: &mut B) -> Result<Sweep> {
        let (f, gnorm) = self.current;
        let stay = Sweep {
            objective: f,
            grad_norm: gnorm,
            max_move_sq: 0.0,
            cg_iterations: 0,
            ..Default::default()
        };
        let g0 = *self.g0.get_or_insert(gnorm);
        // the first step too: nothing has shown negative curvature yet
        let convex = !self.last_pcg.is_some_and(|i| i.stop == PcgStop::NegativeCurvature);
        let cap = if convex {
            self.params.forcing_convex
        } else {
            self.params.forcing_max
        };
        let rtol = cap.min((gnorm / g0).sqrt());
        be.factor_precond()?;
        be.axpby(Coef::value(-1.0), self.g, Coef::value(0.0), self.rhs, None)?;
        let pcg_params = PcgParams {
            max_iter: self.params.cg_max_iter,
            rtol,
            negative_curvature: self.params.negative_curvature,
        };
        let info = pcg(be, &self.work, self.rhs, self.d, &pcg_params)?;
        self.cg_iterations += info.iterations;
        self.last_pcg = Some(info);
        let negative_curvature = info.stop == PcgStop::NegativeCurvature;
        let mut stay = Sweep {
            cg_iterations: info.iterations,
            negative_curvature,
            ..stay
        };
        be.dot(self.g, self.d, SLOPE, None)?;
        let mut slope = be.flush()?[SLOPE.0 as usize];
        if !(slope < 0.0) {
            // not downhill (rounding at a near-stationary point): preconditioned steepest descent
            be.precond(self.rhs, self.d)?;
            be.dot(self.g, self.d, SLOPE, None)?;
            slope = be.flush()?[SLOPE.0 as usize];
            if !(slope < 0.0) {
                return Ok(stay);
            }
        }
        let ls = &self.params.line_search;
        let mut alpha = 1.0;
        for trial in 1..=ls.max_backtracks + 1 {
            stay.line_search_trials = trial;
            be.trial(Coef::value(alpha), self.d)?;
            be.evaluate(Points::Trial, EVAL, None)?;
            let s = be.flush()?;
            let ft = s[F.0 as usize];
            if s[INFEASIBLE.0 as usize] == 0.0 && ft <= f + ls.sigma * alpha * slope {
                be.accept_trial()?;
                // the next iteration's gradient and Hessian, and this one's |grad F|
                be.assemble(self.g)?;
                be.norm_sq(self.g, GG)?;
                be.dot(self.d, self.d, DD, Some(DMAX))?;
                let s = be.flush()?;
                if !s[GG.0 as usize].is_finite() {
                    return Err(accepted_step_inverted());
                }
                self.current = (ft, s[GG.0 as usize].sqrt());
                return Ok(Sweep {
                    objective: ft,
                    grad_norm: self.current.1,
                    max_move_sq: alpha * alpha * s[DMAX.0 as usize],
                    cg_iterations: info.iterations,
                    negative_curvature,
                    line_search_trials: trial,
                    ..Default::default()
                });
            }
            alpha = self.next_trial(be, alpha, s[INFEASIBLE.0 as usize] != 0.0)?;
        }
        Ok(stay)
    }
}
