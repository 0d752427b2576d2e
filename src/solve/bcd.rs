//! Block coordinate descent (section 3.1 of the Newton paper), written once
//! over `Backend`: a sweep is one safeguarded Newton step per free vertex on
//! its 3x3 block, colour by colour (the vertices of a colour share no
//! element), or one vertex at a time in locality order where the backend has
//! such a sweep (the CPU; `Method::Bcd` on a GPU runs the colours).

use super::{Sweep, accepted_step_inverted};
use crate::backend::{Backend, EvalSlots, Points, Slot, Vector};
use crate::error::Result;
use std::time::Instant;

const F: Slot = Slot(0);
const INFEASIBLE: Slot = Slot(1);
const GG: Slot = Slot(2);
/// The slot a sweep writes its largest squared move to.
pub(crate) const MOVED: Slot = Slot(3);

pub(crate) const EVAL: EvalSlots = EvalSlots {
    value: F,
    infeasible: INFEASIBLE,
    min_det: None,
};

/// A sweep of the block coordinate descent and its evaluation.
pub struct Bcd {
    /// One vertex at a time where the backend can; colour by colour otherwise.
    pub sequential: bool,
    g: Vector,
}

impl Bcd {
    pub fn new<B: Backend + ?Sized>(be: &mut B, sequential: bool) -> Result<Bcd> {
        Ok(Bcd {
            sequential,
            g: be.vector()?,
        })
    }

    /// (F, |grad F|) at the current positions, `None` if infeasible there.
    pub fn start<B: Backend + ?Sized>(&mut self, be: &mut B) -> Result<Option<(f64, f64)>> {
        evaluate_at(be, self.g)
    }

    /// One sweep, then F and |grad F| at the new positions in the same flush.
    pub fn step<B: Backend + ?Sized>(&mut self, be: &mut B, deadline: Option<Instant>) -> Result<Sweep> {
        if !(self.sequential && be.bcd_sequential(MOVED, deadline)?) {
            for c in 0..be.num_colors() {
                if deadline.is_some_and(|d| Instant::now() >= d) {
                    break;
                }
                be.bcd_color(c)?;
            }
            be.max_move(MOVED)?;
        }
        finish(be, self.g)
    }
}

fn evaluate<B: Backend + ?Sized>(be: &mut B, g: Vector) -> Result<[f64; crate::backend::N_SLOTS]> {
    be.evaluate(Points::Current, EVAL, Some(g))?;
    be.norm_sq(g, GG)?;
    be.flush()
}

/// (F, |grad F|) at the current positions, `None` if infeasible there.
pub(crate) fn evaluate_at<B: Backend + ?Sized>(be: &mut B, g: Vector) -> Result<Option<(f64, f64)>> {
    let s = evaluate(be, g)?;
    Ok((s[INFEASIBLE.0 as usize] == 0.0).then(|| (s[F.0 as usize], s[GG.0 as usize].sqrt())))
}

/// Evaluates after a sweep that wrote its largest move to `MOVED`.
pub(crate) fn finish<B: Backend + ?Sized>(be: &mut B, g: Vector) -> Result<Sweep> {
    let s = evaluate(be, g)?;
    if s[INFEASIBLE.0 as usize] != 0.0 {
        return Err(accepted_step_inverted());
    }
    Ok(Sweep {
        objective: s[F.0 as usize],
        grad_norm: s[GG.0 as usize].sqrt(),
        max_move_sq: s[MOVED.0 as usize],
        cg_iterations: 0,
    })
}
