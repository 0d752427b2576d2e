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
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NlcgParams {
    /// Stop after a step that moved no vertex farther than this many mean
    /// edge lengths (the paper's tol_x); also the resolution of the line search.
    pub tol_x: f64,
    /// The first trial of the first search (and of a restart after a failed
    /// search) moves the farthest-moving vertex this many mean edge lengths.
    pub first_move: f64,
    /// The strong-Wolfe line search's settings.
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
    /// NLCG's settings.
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
    /// Line searches run.
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
                ..Default::default()
            });
        }
        Ok(Sweep {
            objective: f,
            grad_norm: gg.sqrt(),
            max_move_sq: 0.0,
            cg_iterations: 0,
            ..Default::default()
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::function_backend::{Function, FunctionBackend};
    use crate::solve::wolfe::Wolfe;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    struct Run {
        x: Vec<f64>,
        iterations: usize,
        grad_norms: Vec<f64>,
        objectives: Vec<f64>,
        accepted: Vec<Vec<f64>>,
        nlcg: Nlcg,
    }

    /// NLCG from `x0` until |grad f| <= tol (or `max_iter`, or no step).
    fn minimise(f: &Function, x0: &[f64], params: NlcgParams, tol: f64, max_iter: usize) -> Run {
        let mut be = FunctionBackend::new(f, x0);
        let mut nlcg = Nlcg::new(&mut be, params, 1.0).unwrap();
        let (f0, g0) = nlcg.start(&mut be).unwrap().expect("a feasible start");
        let (mut objectives, mut grad_norms) = (vec![f0], vec![g0]);
        let mut iterations = 0;
        while grad_norms[iterations] > tol && iterations < max_iter {
            let s = nlcg.step(&mut be).unwrap();
            if s.max_move_sq == 0.0 {
                break;
            }
            iterations += 1;
            objectives.push(s.objective);
            grad_norms.push(s.grad_norm);
        }
        Run {
            x: be.point(),
            iterations,
            grad_norms,
            objectives,
            accepted: std::mem::take(&mut be.accepted),
            nlcg,
        }
    }

    /// f(x) = 1/2 (x - x*)^T A (x - x*) with A symmetric positive definite
    /// (written about its minimiser, so that rounding does not hide the last
    /// decreases from the line search).
    fn quadratic(a: Vec<Vec<f64>>, star: Vec<f64>) -> impl Fn(&[f64]) -> Option<(f64, Vec<f64>)> {
        move |x: &[f64]| {
            let e: Vec<f64> = x.iter().zip(&star).map(|(p, q)| p - q).collect();
            let ae = matvec(&a, &e);
            Some((0.5 * e.iter().zip(&ae).map(|(p, q)| p * q).sum::<f64>(), ae))
        }
    }

    /// A seeded SPD matrix M^T M + I/2 and a minimiser x*.
    fn spd_problem(n: usize, seed: u64) -> (Vec<Vec<f64>>, Vec<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let m: Vec<Vec<f64>> = (0..n)
            .map(|_| (0..n).map(|_| rng.random_range(-1.0..1.0)).collect())
            .collect();
        let a = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| (0..n).map(|k| m[k][i] * m[k][j]).sum::<f64>() + if i == j { 0.5 } else { 0.0 })
                    .collect()
            })
            .collect();
        let star = (0..n).map(|_| rng.random_range(-2.0..2.0)).collect();
        (a, star)
    }

    fn matvec(a: &[Vec<f64>], x: &[f64]) -> Vec<f64> {
        a.iter().map(|r| r.iter().zip(x).map(|(p, q)| p * q).sum()).collect()
    }

    fn max_diff(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max)
    }

    #[test]
    fn convex_quadratic_is_minimised_in_at_most_n_iterations_with_exact_line_searches() {
        let n = 12;
        // c2 tiny: the search ends at the cubic step, which on a quadratic is
        // its exact minimiser, so NLCG is linear CG
        let exact = NlcgParams {
            line_search: Wolfe {
                c1: 1e-10,
                c2: 1e-7,
                ..Wolfe::default()
            },
            ..NlcgParams::default()
        };
        for seed in 0..3 {
            let (a, star) = spd_problem(n, seed);
            let f = quadratic(a, star.clone());
            let x0 = vec![0.0; n];
            let run = minimise(
                &f,
                &x0,
                exact,
                1e-9 * f(&x0).unwrap().1.iter().map(|g| g * g).sum::<f64>().sqrt(),
                100,
            );
            eprintln!(
                "seed {seed}: {} iterations, {} evaluations, {}/{} wolfe, |g| {:?}",
                run.iterations, run.nlcg.evaluations, run.nlcg.wolfe_steps, run.nlcg.searches, run.grad_norms
            );
            assert!(run.iterations <= n, "seed {seed}: {} iterations", run.iterations);
            assert!(max_diff(&run.x, &star) < 1e-7, "seed {seed}: {:?} vs {star:?}", run.x);
            // exact searches make successive gradients orthogonal, which is
            // what keeps beta_PR positive: no restarts
            assert_eq!(run.nlcg.wolfe_steps, run.nlcg.searches);
        }
        // the paper's inexact search still converges, in a few more iterations
        let (a, star) = spd_problem(n, 0);
        let f = quadratic(a, star.clone());
        let run = minimise(&f, &vec![0.0; n], NlcgParams::default(), 1e-9, 20 * n);
        eprintln!("default line search: {} iterations", run.iterations);
        assert!(run.grad_norms.last().unwrap() <= &1e-9);
        assert!(max_diff(&run.x, &star) < 1e-7);
    }

    /// Extended Rosenbrock: sum over pairs of 100 (x2 - x1^2)^2 + (1 - x1)^2,
    /// minimised at all ones.
    fn rosenbrock(x: &[f64]) -> Option<(f64, Vec<f64>)> {
        let mut f = 0.0;
        let mut g = vec![0.0; x.len()];
        for i in (0..x.len()).step_by(2) {
            let (u, v) = (x[i], x[i + 1]);
            f += 100.0 * (v - u * u).powi(2) + (1.0 - u).powi(2);
            g[i] += -400.0 * u * (v - u * u) - 2.0 * (1.0 - u);
            g[i + 1] += 200.0 * (v - u * u);
        }
        Some((f, g))
    }

    #[test]
    fn rosenbrock_is_minimised() {
        let x0: Vec<f64> = (0..6).map(|i| if i % 2 == 0 { -1.2 } else { 1.0 }).collect();
        let run = minimise(&rosenbrock, &x0, NlcgParams::default(), 1e-8, 5000);
        eprintln!(
            "Rosenbrock: {} iterations, {} evaluations, {}/{} strong Wolfe",
            run.iterations, run.nlcg.evaluations, run.nlcg.wolfe_steps, run.nlcg.searches
        );
        assert!(*run.grad_norms.last().unwrap() <= 1e-8, "{:?}", run.grad_norms.last());
        assert!(max_diff(&run.x, &[1.0; 6]) < 1e-6, "{:?}", run.x);
        // every step decreased f
        assert!(run.objectives.windows(2).all(|w| w[1] < w[0]));
        // and most met the strong Wolfe conditions
        assert!(run.nlcg.wolfe_steps * 10 >= run.nlcg.searches * 9);
    }

    /// sum (x_i - 2)^2 - log(1 - x_i): infeasible for any x_i >= 1, minimised
    /// at x_i = (3 - sqrt 3) / 2 ~ 0.634 (where 2 (x - 2)(1 - x) + 1 = 0).
    fn barrier(x: &[f64]) -> Option<(f64, Vec<f64>)> {
        if x.iter().any(|&v| !(v < 1.0)) {
            return None;
        }
        let f = x.iter().map(|&v| (v - 2.0).powi(2) - (1.0 - v).ln()).sum();
        Some((f, x.iter().map(|&v| 2.0 * (v - 2.0) + 1.0 / (1.0 - v)).collect()))
    }

    #[test]
    fn iterates_stay_feasible_when_first_steps_overshoot_into_the_infeasible_region() {
        let x0 = [0.0, -0.5, 0.3, 0.9, -2.0, 0.5];
        for first_move in [0.01, 1.0, 100.0] {
            let params = NlcgParams {
                first_move,
                ..NlcgParams::default()
            };
            let run = minimise(&barrier, &x0, params, 1e-6, 500);
            assert!(*run.grad_norms.last().unwrap() <= 1e-6);
            // the Hessian is diagonal, at least 2 + 1/(1 - x)^2 > 9 near the
            // minimiser: |x - x*| <= |g| / 9
            let best = (3.0 - 3.0f64.sqrt()) / 2.0;
            assert!(max_diff(&run.x, &[best; 6]) < 2e-7, "{first_move}: {:?}", run.x);
            assert!(!run.accepted.is_empty());
            assert!(run.accepted.iter().all(|x| barrier(x).is_some()));
        }
    }

    #[test]
    fn a_stationary_start_takes_no_step() {
        let run = minimise(&rosenbrock, &[1.0; 6], NlcgParams::default(), -1.0, 10);
        assert_eq!(run.iterations, 0);
        assert!(run.accepted.is_empty());
    }

    #[test]
    fn unusable_settings_are_refused() {
        let f = rosenbrock;
        let mut be = FunctionBackend::new(&f, &[0.0; 3]);
        for params in [
            NlcgParams {
                tol_x: -1.0,
                ..NlcgParams::default()
            },
            NlcgParams {
                first_move: 0.0,
                ..NlcgParams::default()
            },
            NlcgParams {
                line_search: Wolfe {
                    c1: 0.5,
                    c2: 0.1,
                    ..Wolfe::default()
                },
                ..NlcgParams::default()
            },
        ] {
            assert!(Nlcg::new(&mut be, params, 1.0).is_err());
        }
    }
}
