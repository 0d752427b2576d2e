//! Block coordinate descent (section 3.1 of the Newton paper), written once
//! over `Backend`: a sweep is one safeguarded Newton step per free vertex on
//! its 3x3 block, colour by colour (the vertices of a colour share no
//! element), or one vertex at a time in locality order where the backend has
//! such a sweep (the CPU; `Method::Bcd` on a GPU runs the colours).

use super::reorder::{Reorder, Strategy};
use super::{BcdParams, Sweep, accepted_step_inverted};
use crate::backend::{Backend, EvalSlots, Points, Slot, Vector, Visit};
use crate::error::Result;
use crate::problem::Problem;
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
pub struct Bcd<'p> {
    /// One vertex at a time where the backend can; colour by colour otherwise.
    pub sequential: bool,
    g: Vector,
    /// The sequential sweep's list under a paper scheme, with its strategy
    /// (`None` without a scheme, or on a backend without a sequential sweep).
    pub reorder: Option<Reorder>,
    /// Per free vertex: its displacement at the last visit (dynamic movement schemes).
    moves: Option<Vector>,
    inner_iterations: usize,
    p: &'p Problem,
    ls: crate::solve::line_search::LineSearch,
    sweeps: usize,
}

impl<'p> Bcd<'p> {
    /// The sweep over `p` on `be`: sequential (one vertex at a time) if asked and the backend can, else by colours.
    pub fn new<B: Backend + ?Sized>(
        be: &mut B,
        p: &'p Problem,
        sequential: bool,
        params: &BcdParams,
    ) -> Result<Bcd<'p>> {
        let reorder = p
            .sweep_order
            .filter(|_| sequential && be.has_sequential_sweep())
            .map(|s| Reorder::new(p, s, Strategy::every(params.reorder_every), p.order_seed));
        let moves = match &reorder {
            Some(r) if r.needs_moves() => Some(be.vector()?),
            _ => None,
        };
        Ok(Bcd {
            sequential,
            g: be.vector()?,
            reorder,
            moves,
            inner_iterations: params.inner_iterations.max(1),
            p,
            ls: params.line_search,
            sweeps: 0,
        })
    }

    /// (F, |grad F|) at the current positions, `None` if infeasible there;
    /// the static order (or a dynamic run's first) is made here, inside the
    /// timed run, as the paper counts it.
    pub fn start<B: Backend + ?Sized>(&mut self, be: &mut B) -> Result<Option<(f64, f64)>> {
        if let Some(r) = &mut self.reorder {
            let (t, before) = (Instant::now(), r.seconds);
            let x = be.download()?;
            r.initial(self.p, &x, &self.ls, self.inner_iterations);
            // the download is part of what reordering costs here
            r.seconds = before + t.elapsed().as_secs_f64();
        }
        evaluate_at(be, self.g)
    }

    /// One sweep (timed: the paper's OTI), the reordering when it is due
    /// (timed apart: RT), then F and |grad F| at the new positions in the
    /// same flush.
    pub fn step<B: Backend + ?Sized>(&mut self, be: &mut B, deadline: Option<Instant>) -> Result<Sweep> {
        let t2 = Instant::now();
        let visit = Visit {
            order: self.reorder.as_ref().map(|r| r.order.as_slice()),
            inner_iterations: self.inner_iterations,
            moves: self.moves,
        };
        let sequential = self.sequential && be.bcd_sequential(&visit, MOVED, deadline)?;
        if !sequential {
            for c in 0..be.num_colors() {
                if deadline.is_some_and(|d| be.past(d)) {
                    break;
                }
                be.bcd_color(c)?;
            }
            be.max_move(MOVED)?;
        }
        // a sequential sweep (CPU) has run when the call returns; coloured
        // sweeps may only be recorded (GPU) until the evaluation's flush, so
        // their optimisation time is left to the caller: the whole step
        let t3 = Instant::now();
        self.sweeps += 1;
        let (mut reorder_seconds, mut reorderings) = (0.0, 0);
        if let Some(r) = &mut self.reorder
            && r.due(self.sweeps)
        {
            let before = r.seconds;
            let x = be.download()?;
            let moves = self.moves.map(|m| be.read_vector(m)).transpose()?;
            r.after_sweep(self.p, &x, moves.as_deref());
            // the downloads count as reordering work
            r.seconds = before + t3.elapsed().as_secs_f64();
            reorder_seconds = r.seconds - before;
            reorderings = 1;
        }
        let sweep = finish(be, self.g)?;
        Ok(Sweep {
            optimise_seconds: sequential.then(|| (t3 - t2).as_secs_f64()),
            reorder_seconds,
            reorderings,
            ..sweep
        })
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
        ..Default::default()
    })
}
