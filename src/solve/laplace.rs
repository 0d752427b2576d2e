//! Smart Laplacian smoothing as the shared loop drives it: the sweep is the
//! backend's (only the CPU has one, `backend::cpu::laplace`), the evaluation
//! that of every other method.

use super::Sweep;
use super::bcd::{MOVED, evaluate_at, finish};
use crate::backend::{Backend, Vector};
use crate::error::{Error, Result};
use std::time::Instant;

/// Smart-Laplace smoothing's state on the backend (a gradient vector).
pub struct Laplace {
    g: Vector,
}

impl Laplace {
    /// Allocates the state on `be`.
    pub fn new<B: Backend + ?Sized>(be: &mut B) -> Result<Laplace> {
        Ok(Laplace { g: be.vector()? })
    }

    /// (F, |grad F|) at the current positions, `None` if infeasible there.
    pub fn start<B: Backend + ?Sized>(&mut self, be: &mut B) -> Result<Option<(f64, f64)>> {
        evaluate_at(be, self.g)
    }

    /// One smart-Laplace sweep (stopping early, valid, at `deadline`).
    pub fn step<B: Backend + ?Sized>(&mut self, be: &mut B, deadline: Option<Instant>) -> Result<Sweep> {
        if !be.laplace(MOVED, deadline)? {
            return Err(Error::InvalidArgument(format!(
                "method 'laplace' has no version on {}",
                be.describe()
            )));
        }
        finish(be, self.g)
    }
}
