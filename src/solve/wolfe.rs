//! The feasibility-aware strong-Wolfe line search of the Reference-Jacobian
//! rezoning paper (sections 5.2–5.5, algorithms 2–5), for a function whose
//! feasible set along the line need not be known in advance.
//!
//! The search is a pure function of a 1-D oracle `phi(alpha)` that returns
//! `(phi, phi')` at a feasible step and `None` at an infeasible one; the
//! solvers wrap their backend in such an oracle (one flush per trial), and the
//! tests a plain function. Every step it returns was evaluated and found
//! feasible, with sufficient decrease.
//!
//! Departures from the printed algorithms:
//! - for feasible sets that are not intervals (a corner determinant is a
//!   polynomial in alpha, so a mesh can be valid at two steps and inverted
//!   between them), a zoom trial found infeasible becomes the new upper end
//!   (as a trial with phi = +inf would), and the next trial bisects towards
//!   the lower end;
//! - the cubic step (algorithm 5) falls back to bisection where it is not a
//!   number or not inside the interval (rounding on a nearly flat phi);
//! - the bracketing increment doubles after each trial that neither brackets
//!   nor satisfies the conditions (`Wolfe::growth`; 1 is the paper's fixed
//!   increment): with the previous step as the first increment, the fixed
//!   one spent the whole evaluation budget on Rosenbrock's function when the
//!   step had to grow fiftyfold;
//! - at most `Wolfe::max_evaluations` trials per search.
//!
//! Algorithm 5 as printed divides by phi(hi) - phi(lo) + 2 d2; the cubic's
//! minimiser (Nocedal and Wright, eq. 3.59) has phi'(hi) - phi'(lo) + 2 d2,
//! which is what is used here (checked on cubics in the tests).

/// The constants of the search (the paper's values by default).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Wolfe {
    /// Sufficient decrease: phi(a) <= phi(0) + c1 a phi'(0).
    pub c1: f64,
    /// Curvature: |phi'(a)| <= -c2 phi'(0).
    pub c2: f64,
    /// Step-increment reduction after an infeasible trial (the paper's rho).
    pub rho: f64,
    /// Step-increment growth after a trial that neither brackets nor meets
    /// the conditions. The paper keeps the increment (1): the trials go
    /// delta, 2 delta, 3 delta, ... and a first increment far too short costs
    /// one evaluation per increment; 2 doubles it (trials delta, 3 delta,
    /// 7 delta, ...), as Nocedal and Wright's extrapolation does.
    pub growth: f64,
    /// A cubic step closer to the lower end than this fraction of the
    /// interval is moved to it (the paper's tol_alpha_lo).
    pub interpolation_tol: f64,
    /// Most evaluations of phi per search; then the best step so far is
    /// returned (without the curvature condition).
    pub max_evaluations: usize,
}

impl Default for Wolfe {
    fn default() -> Self {
        Wolfe {
            c1: 1e-4,
            c2: 0.1,
            rho: 0.5,
            growth: 2.0,
            interpolation_tol: 0.1,
            max_evaluations: 50,
        }
    }
}

impl Wolfe {
    /// True for usable constants: 0 < c1 < c2 < 1, 0 < rho < 1, 0 < tol < 1/2.
    pub fn is_valid(&self) -> bool {
        0.0 < self.c1
            && self.c1 < self.c2
            && self.c2 < 1.0
            && 0.0 < self.rho
            && self.rho < 1.0
            && self.growth >= 1.0
            && 0.0 < self.interpolation_tol
            && self.interpolation_tol < 0.5
            && self.max_evaluations > 0
    }
}

/// phi and phi' at a feasible step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// The step length.
    pub alpha: f64,
    /// phi(alpha): F at the step.
    pub value: f64,
    /// phi'(alpha): the directional derivative at the step.
    pub slope: f64,
}

/// What a search found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Search {
    /// The step, with sufficient decrease; `None` when no step longer than
    /// `tol_alpha` decreased phi enough (or none was feasible).
    pub step: Option<Sample>,
    /// The step also meets the curvature condition (strong Wolfe).
    pub strong_wolfe: bool,
    /// Evaluations of F and its gradient the search made.
    pub evaluations: usize,
    /// The smallest step found infeasible (infinity if none was).
    pub alpha_max: f64,
}

/// Searches along a descent direction: `start` is phi(0) and phi'(0) < 0,
/// `delta` the first step increment (grown by `Wolfe::growth` after each
/// trial until a bracket is found), `tol_alpha` the step resolution. `phi` returns
/// `(phi, phi')` or `None` where the step is infeasible; a value or slope
/// that is not finite counts as infeasible.
pub fn line_search<E>(
    phi: &mut dyn FnMut(f64) -> Result<Option<(f64, f64)>, E>,
    start: (f64, f64),
    delta: f64,
    tol_alpha: f64,
    params: &Wolfe,
) -> Result<Search, E> {
    let mut s = State {
        phi,
        params,
        phi0: start.0,
        slope0: start.1,
        tol_alpha,
        evaluations: 0,
        alpha_max: f64::INFINITY,
    };
    let origin = Sample {
        alpha: 0.0,
        value: start.0,
        slope: start.1,
    };
    if !(start.1 < 0.0 && start.0.is_finite()) {
        return Ok(s.done(origin, false));
    }
    // algorithm 2: bracketing
    let mut prev = origin;
    let mut delta = delta;
    loop {
        let Some(trial) = s.step_length(prev.alpha, &mut delta)? else {
            return Ok(s.done(prev, false));
        };
        if !s.sufficient(&trial) || (prev.alpha > 0.0 && trial.value >= prev.value) {
            return s.zoom(prev, trial);
        }
        if s.curvature(&trial) {
            return Ok(s.done(trial, true));
        }
        if trial.slope >= 0.0 {
            return s.zoom(trial, prev);
        }
        prev = trial;
        delta *= params.growth;
    }
}

struct State<'a, E> {
    phi: &'a mut dyn FnMut(f64) -> Result<Option<(f64, f64)>, E>,
    params: &'a Wolfe,
    phi0: f64,
    slope0: f64,
    tol_alpha: f64,
    evaluations: usize,
    alpha_max: f64,
}

impl<E> State<'_, E> {
    /// phi at `alpha`, or `None` (and `alpha_max` lowered) where infeasible.
    fn eval(&mut self, alpha: f64) -> Result<Option<Sample>, E> {
        self.evaluations += 1;
        match (self.phi)(alpha)? {
            Some((value, slope)) if value.is_finite() && slope.is_finite() => Ok(Some(Sample { alpha, value, slope })),
            _ => {
                self.alpha_max = self.alpha_max.min(alpha);
                Ok(None)
            }
        }
    }

    fn exhausted(&self) -> bool {
        self.evaluations >= self.params.max_evaluations
    }

    fn sufficient(&self, t: &Sample) -> bool {
        t.value <= self.phi0 + self.params.c1 * t.alpha * self.slope0
    }

    fn curvature(&self, t: &Sample) -> bool {
        t.slope.abs() <= -self.params.c2 * self.slope0
    }

    /// `best` as the answer: no step if it is the origin.
    fn done(&self, best: Sample, strong_wolfe: bool) -> Search {
        Search {
            step: (best.alpha > 0.0).then_some(best),
            strong_wolfe,
            evaluations: self.evaluations,
            alpha_max: self.alpha_max,
        }
    }

    /// Algorithm 3: the next feasible trial `alpha + delta`, `delta` reduced
    /// by rho past every known or newly found infeasible step; `None` once it
    /// falls to `tol_alpha` (or the evaluations run out).
    fn step_length(&mut self, alpha: f64, delta: &mut f64) -> Result<Option<Sample>, E> {
        let rho = self.params.rho;
        loop {
            while *delta > self.tol_alpha && alpha + *delta >= self.alpha_max {
                *delta *= rho;
            }
            if !(*delta > self.tol_alpha) || self.exhausted() {
                return Ok(None);
            }
            if let Some(t) = self.eval(alpha + *delta)? {
                return Ok(Some(t));
            }
            *delta *= rho;
        }
    }

    /// Algorithm 4, as a loop: `lo` is the best step with sufficient
    /// decrease so far, and phi'(lo) (hi - lo) < 0. `hi` may be infeasible
    /// (value +inf), after a zoom trial was.
    fn zoom(&mut self, mut lo: Sample, mut hi: Sample) -> Result<Search, E> {
        loop {
            if (hi.alpha - lo.alpha).abs() <= self.tol_alpha || self.exhausted() {
                return Ok(self.done(lo, false));
            }
            let alpha = interpolate(&lo, &hi, self.params.interpolation_tol);
            let Some(t) = self.eval(alpha)? else {
                hi = Sample {
                    alpha,
                    value: f64::INFINITY,
                    slope: f64::NAN,
                };
                continue;
            };
            if !self.sufficient(&t) || t.value >= lo.value {
                hi = t;
                continue;
            }
            if self.curvature(&t) {
                return Ok(self.done(t, true));
            }
            if t.slope * (hi.alpha - lo.alpha) >= 0.0 {
                hi = lo;
            }
            lo = t;
        }
    }
}

/// Algorithm 5: the minimiser of the cubic through phi and phi' at both ends,
/// moved away from `lo` to at least `tol` of the interval; the midpoint
/// where the cubic gives no step inside the interval (or `hi` is infeasible).
pub fn interpolate(lo: &Sample, hi: &Sample, tol: f64) -> f64 {
    let width = hi.alpha - lo.alpha;
    let d1 = lo.slope + hi.slope - 3.0 * (lo.value - hi.value) / (lo.alpha - hi.alpha);
    let d2 = (d1 * d1 - lo.slope * hi.slope).sqrt().copysign(width);
    let cubic = hi.alpha - width * (hi.slope + d2 - d1) / (hi.slope - lo.slope + 2.0 * d2);
    // fraction of the way from lo to hi; NaN (no cubic) fails the test
    let t = (cubic - lo.alpha) / width;
    if !(t > 0.0 && t < 1.0) {
        return lo.alpha + 0.5 * width;
    }
    lo.alpha + t.max(tol) * width
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::convert::Infallible;

    /// A 1-D test function: value and derivative, `None` where infeasible.
    type F = fn(f64) -> Option<(f64, f64)>;

    fn run(f: F, delta: f64, params: &Wolfe) -> (Search, Vec<f64>) {
        let mut trials = Vec::new();
        let start = f(0.0).unwrap();
        let mut phi = |a: f64| -> Result<_, Infallible> {
            trials.push(a);
            Ok(f(a))
        };
        let s = line_search(&mut phi, start, delta, 1e-12, params).unwrap();
        (s, trials)
    }

    /// The returned step meets both strong Wolfe conditions, is feasible and
    /// carries the oracle's own values.
    fn assert_wolfe(f: F, s: &Search, params: &Wolfe) {
        let (f0, g0) = f(0.0).unwrap();
        let step = s.step.expect("a step");
        let (v, g) = f(step.alpha).expect("the step is feasible");
        assert_eq!((v, g), (step.value, step.slope));
        assert!(s.strong_wolfe);
        assert!(
            v <= f0 + params.c1 * step.alpha * g0,
            "sufficient decrease at {}",
            step.alpha
        );
        assert!(g.abs() <= -params.c2 * g0, "curvature at {}: {g} vs {g0}", step.alpha);
    }

    fn quadratic(a: f64) -> Option<(f64, f64)> {
        // minimiser 3
        Some(((a - 3.0).powi(2), 2.0 * (a - 3.0)))
    }

    fn quartic(a: f64) -> Option<(f64, f64)> {
        // minimisers +-2, and phi'(0) = -1 pushes towards +2
        let q = a * a - 4.0;
        Some((q * q - a, 4.0 * a * q - 1.0))
    }

    /// A barrier with its pole at 1 + sqrt(2) ~ 2.41 (as an element's near
    /// inversion), infeasible from 2, minimised at 1 + sqrt(2) - 1/sqrt(3)
    /// ~ 1.84: long first steps land in the infeasible region.
    fn barrier(a: f64) -> Option<(f64, f64)> {
        if a >= 2.0 {
            return None;
        }
        let d = 1.0 + 2.0f64.sqrt() - a;
        Some((-3.0 * a + 1.0 / d, -3.0 + 1.0 / (d * d)))
    }

    /// Feasible on [0, 0.5] and [0.7, inf), minimised at 1: the feasible set
    /// along the line is not an interval.
    fn gap(a: f64) -> Option<(f64, f64)> {
        if a > 0.5 && a < 0.7 {
            return None;
        }
        Some(((a - 1.0).powi(2), 2.0 * (a - 1.0)))
    }

    #[test]
    fn quadratic_step_meets_strong_wolfe_from_short_and_long_first_steps() {
        let params = Wolfe::default();
        for delta in [0.1, 1.0, 2.9, 3.0, 5.0, 100.0] {
            let (s, _) = run(quadratic, delta, &params);
            assert_wolfe(quadratic, &s, &params);
            // |phi'| <= 0.1 |phi'(0)| = 0.6 puts the step within 0.3 of 3
            assert!((s.step.unwrap().alpha - 3.0).abs() <= 0.3, "{delta}: {s:?}");
        }
    }

    #[test]
    fn quadratic_minimiser_is_found_by_one_cubic_step() {
        // a cubic through a quadratic's data is the quadratic: one zoom
        // step lands on the minimiser
        let (s, trials) = run(quadratic, 5.0, &Wolfe::default());
        assert_eq!(trials.len(), 2, "{trials:?}");
        assert!((s.step.unwrap().alpha - 3.0).abs() < 1e-12);
    }

    #[test]
    fn quartic_step_meets_strong_wolfe() {
        let params = Wolfe::default();
        for delta in [0.1, 0.5, 1.0, 3.0, 10.0] {
            let (s, _) = run(quartic, delta, &params);
            assert_wolfe(quartic, &s, &params);
            assert!((s.step.unwrap().alpha - 2.0).abs() < 0.1, "{delta}: {s:?}");
        }
        // tight curvature: the search homes in on the minimiser
        let tight = Wolfe {
            c2: 1e-6,
            ..Wolfe::default()
        };
        let (s, _) = run(quartic, 3.0, &tight);
        assert_wolfe(quartic, &s, &tight);
        let exact = {
            // 4 a (a^2 - 4) = 1 near 2, by Newton
            let mut a = 2.0f64;
            for _ in 0..50 {
                a -= (4.0 * a * (a * a - 4.0) - 1.0) / (12.0 * a * a - 16.0);
            }
            a
        };
        assert!((s.step.unwrap().alpha - exact).abs() < 1e-7);
    }

    #[test]
    fn infeasible_steps_are_never_returned_and_bound_the_search() {
        let params = Wolfe::default();
        for delta in [0.05, 0.3, 1.0, 1.9, 2.0, 3.0, 50.0] {
            let (s, trials) = run(barrier, delta, &params);
            let step = s.step.expect("a step");
            assert!(step.alpha < 2.0, "{delta}: {step:?}");
            assert_wolfe(barrier, &s, &params);
            // once found infeasible, no trial goes past the smallest infeasible step
            let mut bound = f64::INFINITY;
            for &a in &trials {
                assert!(
                    a < bound,
                    "{delta}: trial {a} past known infeasible {bound}: {trials:?}"
                );
                if barrier(a).is_none() {
                    bound = bound.min(a);
                }
            }
            assert_eq!(s.alpha_max, bound);
        }
    }

    #[test]
    fn infeasible_gap_inside_the_bracket_is_never_returned() {
        let params = Wolfe::default();
        for delta in [0.3, 0.45, 0.8, 2.0, 10.0] {
            let (s, trials) = run(gap, delta, &params);
            let step = s.step.expect("a step");
            assert!(gap(step.alpha).is_some(), "{delta}: {step:?}");
            assert!(step.value < gap(0.0).unwrap().0);
            assert!(trials.iter().all(|a| a.is_finite() && *a > 0.0));
            if s.strong_wolfe {
                assert_wolfe(gap, &s, &params);
            }
        }
    }

    #[test]
    fn wholly_infeasible_line_gives_no_step() {
        let (s, trials) = run(|a| (a == 0.0).then_some((0.0, -1.0)), 1.0, &Wolfe::default());
        assert_eq!(s.step, None);
        assert!(!s.strong_wolfe);
        // rho = 1/2 from 1 down to 1e-12: about 40 halvings
        assert!(trials.len() <= 41 && trials.len() >= 39, "{}", trials.len());
        assert_eq!(s.alpha_max, *trials.last().unwrap());
    }

    #[test]
    fn uphill_direction_gives_no_step() {
        let (s, trials) = run(|a| Some((a, 1.0)), 1.0, &Wolfe::default());
        assert_eq!((s.step, trials.len()), (None, 0));
    }

    #[test]
    fn evaluation_budget_returns_the_best_step_so_far() {
        // phi keeps decreasing: linear bracketing never brackets
        // (with the paper's fixed increment, and doubling it)
        for (growth, last) in [(1.0, 3.5), (2.0, 63.5)] {
            let params = Wolfe {
                max_evaluations: 7,
                growth,
                ..Wolfe::default()
            };
            let (s, trials) = run(|a| Some((-a, -1.0)), 0.5, &params);
            assert_eq!(trials.len(), 7);
            assert_eq!(s.step.unwrap().alpha, last);
            assert!(!s.strong_wolfe);
        }
    }

    #[test]
    fn cubic_interpolation_finds_a_cubics_minimiser() {
        // phi = a^3 - 3 a: local minimiser 1, from either end of [0, 2] or [-0.5, 1.7]
        let c = |a: f64| Sample {
            alpha: a,
            value: a * a * a - 3.0 * a,
            slope: 3.0 * a * a - 3.0,
        };
        for (lo, hi) in [(0.0, 2.0), (2.0, 0.0), (-0.5, 1.7), (1.7, 0.2)] {
            let a = interpolate(&c(lo), &c(hi), 0.1);
            assert!((a - 1.0).abs() < 1e-12, "[{lo}, {hi}]: {a}");
        }
        // next to lo: moved to a tenth of the interval
        let q = |a: f64| Sample {
            alpha: a,
            value: (a - 0.01).powi(2),
            slope: 2.0 * (a - 0.01),
        };
        assert!((interpolate(&q(0.0), &q(1.0), 0.1) - 0.1).abs() < 1e-15);
        let mirrored = |a: f64| {
            let s = q(-a);
            Sample {
                alpha: a,
                slope: -s.slope,
                ..s
            }
        };
        assert!((interpolate(&mirrored(0.0), &mirrored(-1.0), 0.1) + 0.1).abs() < 1e-15);
        // an infeasible end: bisection
        let inf = Sample {
            alpha: 1.0,
            value: f64::INFINITY,
            slope: f64::NAN,
        };
        assert_eq!(interpolate(&q(0.0), &inf, 0.1), 0.5);
    }

    #[test]
    fn default_constants_are_the_papers() {
        let w = Wolfe::default();
        assert_eq!((w.c1, w.c2, w.rho, w.interpolation_tol), (1e-4, 0.1, 0.5, 0.1));
        assert!(w.is_valid());
        assert!(!Wolfe { c2: 1e-5, ..w }.is_valid());
    }
}
