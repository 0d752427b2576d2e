//! Per-iteration history, recorded the same way by every solver so that
//! time-to-x% figures are computed once, here.

use serde::Serialize;
use std::fmt;

/// One iteration's point of a solver's history.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Record {
    /// 0 is the starting point.
    pub iteration: usize,
    /// Seconds since the solver started (setup excluded).
    pub seconds: f64,
    /// The objective F.
    pub objective: f64,
    /// 2-norm of the free gradient of F with lengths in mean edge lengths
    /// (unit-free; the quantity `Params::tol` bounds).
    pub grad_norm: f64,
}

/// A solver's records, one per iteration, the start first.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct History {
    /// The records in iteration order.
    pub records: Vec<Record>,
}

impl History {
    /// Appends a record.
    pub fn push(&mut self, r: Record) {
        self.records.push(r);
    }

    /// The starting point's record.
    pub fn first(&self) -> Option<&Record> {
        self.records.first()
    }

    /// The last iteration's record.
    pub fn last(&self) -> Option<&Record> {
        self.records.last()
    }

    /// Time at which the objective first achieved `fraction` of the decrease
    /// from the start to `best` (T50 for 0.5; `best` is the lowest objective
    /// any compared method reached, so fractions mean the same for all).
    pub fn time_to_fraction(&self, fraction: f64, best: f64) -> Option<f64> {
        let f0 = self.first()?.objective;
        self.time_to_value(f0 - fraction * (f0 - best))
    }

    /// Time at which the objective first reached `value` or better.
    pub fn time_to_value(&self, value: f64) -> Option<f64> {
        self.records.iter().find(|r| r.objective <= value).map(|r| r.seconds)
    }

    /// CSV with header `iteration,seconds,objective,grad_norm`.
    pub fn to_csv(&self) -> String {
        let mut s = String::from("iteration,seconds,objective,grad_norm\n");
        for r in &self.records {
            s.push_str(&format!(
                "{},{:.6},{:.17e},{:.6e}\n",
                r.iteration, r.seconds, r.objective, r.grad_norm
            ));
        }
        s
    }
}

/// Why a solver stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum StopReason {
    /// |grad F| fell below the tolerance.
    Converged,
    /// No vertex moved measurably in a sweep (Laplace), or no step decreased F.
    Stalled,
    /// The iteration limit `Params::max_iter` was reached.
    MaxIterations,
    /// The time limit `Params::time_limit` was reached.
    TimeLimit,
    /// The progress callback asked to stop.
    Cancelled,
    /// F reached `Params::target_objective`.
    TargetReached,
    /// A step moved no vertex farther than `NlcgParams::tol_x` (NLCG).
    SmallStep,
}

impl fmt::Display for StopReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            StopReason::Converged => "converged (gradient norm below tolerance)",
            StopReason::Stalled => "stalled (no further improvement)",
            StopReason::MaxIterations => "iteration limit reached",
            StopReason::TimeLimit => "time limit reached",
            StopReason::Cancelled => "cancelled",
            StopReason::TargetReached => "target objective reached",
            StopReason::SmallStep => "converged (step below tolerance)",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_to_fraction_finds_first_crossing() {
        let mut h = History::default();
        for (i, f) in [10.0, 6.0, 4.0, 2.5, 2.0].into_iter().enumerate() {
            h.push(Record {
                iteration: i,
                seconds: i as f64,
                objective: f,
                grad_norm: 0.0,
            });
        }
        // total decrease 8: 50% is F <= 6 (t = 1), 90% is F <= 2.8 (t = 3)
        assert_eq!(h.time_to_fraction(0.5, 2.0), Some(1.0));
        assert_eq!(h.time_to_fraction(0.9, 2.0), Some(3.0));
        assert_eq!(h.time_to_fraction(1.0, 2.0), Some(4.0));
        // against a better optimum found elsewhere, 100% is never reached here
        assert_eq!(h.time_to_fraction(1.0, 1.0), None);
        assert_eq!(h.time_to_value(3.0), Some(3.0));
        assert_eq!(h.time_to_value(1.0), None);
        assert!(h.to_csv().lines().count() == 6);
    }
}
