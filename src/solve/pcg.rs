//! Preconditioned conjugate gradients on H d = b with the block-Jacobi
//! preconditioner, stopping on negative curvature (section 3.2 of the Newton
//! paper). Written once over `Backend`: alpha, beta and the curvature guard
//! are slot expressions evaluated where the vectors live, so an iteration
//! needs one flush (one read-back on a GPU).

/// Newton's preconditioner is a backend setting (`backend::settings`).
pub use crate::backend::settings::Preconditioner;
use crate::backend::{Backend, Coef, Slot, Vector};
use crate::error::Result;

/// Settings of one PCG solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PcgParams {
    /// Most CG iterations.
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
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum NegativeCurvature {
    /// The direction p of negative curvature, oriented so that p^T b > 0
    /// (section 3.2 of the Newton paper).
    Direction,
    /// The CG iterate so far, a descent direction from the positive definite
    /// part of the Krylov space (truncated Newton); often allows longer steps.
    #[default]
    Iterate,
}

crate::error::by_name!(NegativeCurvature: "negative_curvature" { Direction = "direction", Iterate = "iterate" });

/// Why PCG stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PcgStop {
    /// |r| <= rtol |b| was reached.
    Converged,
    /// `PcgParams::max_iter` iterations were run.
    MaxIterations,
    /// p^T A p <= 0 was met; the returned direction is that p, oriented downhill.
    NegativeCurvature,
}

/// What one PCG solve did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PcgInfo {
    /// CG iterations run.
    pub iterations: usize,
    /// Why it stopped.
    pub stop: PcgStop,
    /// |r| / |b| at the end.
    pub relative_residual: f64,
}

// PCG's scalar slots
const BB: Slot = Slot(0);
const RZ: Slot = Slot(1);
const CURVATURE: Slot = Slot(2);
const RR: Slot = Slot(3);
const RZ_NEW: Slot = Slot(4);
const PB: Slot = Slot(5);
/// Slots below this are PCG's; callers use the others.
pub const FIRST_FREE_SLOT: u32 = 6;

/// PCG's work vectors, allocated once on the backend.
#[derive(Clone, Copy, Debug)]
pub struct PcgWork {
    r: Vector,
    z: Vector,
    p: Vector,
    q: Vector,
}

impl PcgWork {
    /// Allocates the four work vectors on `be`.
    pub fn new<B: Backend + ?Sized>(be: &mut B) -> Result<PcgWork> {
        Ok(PcgWork {
            r: be.vector()?,
            z: be.vector()?,
            p: be.vector()?,
            q: be.vector()?,
        })
    }
}

/// Solves H d = b approximately from d = 0 with the backend's assembled
/// Hessian and factored preconditioner. On negative curvature at the first
/// iteration the result is M^-1 b (for b = -g: preconditioned steepest
/// descent); later, the iterate or the direction of negative curvature with
/// its sign chosen so that d^T b > 0, as `params` says.
pub fn pcg<B: Backend + ?Sized>(be: &mut B, w: &PcgWork, b: Vector, d: Vector, params: &PcgParams) -> Result<PcgInfo> {
    let (r, z, p, q) = (w.r, w.z, w.p, w.q);
    let one = Coef::value(1.0);
    let zero = Coef::value(0.0);
    be.axpby(zero, b, zero, d, None)?;
    be.copy(b, r)?;
    be.norm_sq(b, BB)?;
    be.precond(r, z)?;
    be.dot(r, z, RZ, None)?;
    be.copy(z, p)?;
    let s = be.flush()?;
    let bnorm = s[BB.0 as usize].sqrt();
    if bnorm == 0.0 {
        return Ok(PcgInfo {
            iterations: 0,
            stop: PcgStop::Converged,
            relative_residual: 0.0,
        });
    }
    let mut rel = 1.0;
    for k in 0..params.max_iter {
        // every update is skipped once p^T H p <= 0, which leaves d and p as
        // the negative-curvature exits below need them
        let positive = Some(CURVATURE);
        be.hess_mul(p, q)?;
        be.dot(p, q, CURVATURE, None)?;
        be.axpby(Coef::ratio(1.0, RZ, CURVATURE), p, one, d, positive)?;
        be.axpby(Coef::ratio(-1.0, RZ, CURVATURE), q, one, r, positive)?;
        be.norm_sq(r, RR)?;
        be.precond(r, z)?;
        be.dot(r, z, RZ_NEW, None)?;
        be.axpby(one, z, Coef::ratio(1.0, RZ_NEW, RZ), p, positive)?;
        be.set_slot(RZ, Coef::slot(RZ_NEW), positive)?;
        let s = be.flush()?;
        let curvature = s[CURVATURE.0 as usize];
        if !(curvature > 0.0) {
            if k > 0 && params.negative_curvature == NegativeCurvature::Iterate {
                // d already holds the iterate
            } else if k > 0 {
                be.dot(p, b, PB, None)?;
                let sign = if be.flush()?[PB.0 as usize] >= 0.0 { 1.0 } else { -1.0 };
                be.axpby(Coef::value(sign), p, zero, d, None)?;
            } else {
                be.copy(p, d)?;
            }
            return Ok(PcgInfo {
                iterations: k,
                stop: PcgStop::NegativeCurvature,
                relative_residual: rel,
            });
        }
        rel = s[RR.0 as usize].sqrt() / bnorm;
        if rel <= params.rtol {
            return Ok(PcgInfo {
                iterations: k + 1,
                stop: PcgStop::Converged,
                relative_residual: rel,
            });
        }
    }
    Ok(PcgInfo {
        iterations: params.max_iter,
        stop: PcgStop::MaxIterations,
        relative_residual: rel,
    })
}
