//! Reference-Jacobian rezoning (sections 2–4 of the rezoning paper).
//!
//! 1. **Reference positions** (equation 1): every free vertex, on its own and
//!    with all other vertices at their Lagrangian (input) positions, finds the
//!    position minimising the paper's condition-number measure of the corners
//!    it moves (`cn-paper`). No vertex moves, so this is one parallel pass:
//!    `Backend::reference_positions`, a kernel on a GPU. Fixed (boundary)
//!    vertices are their own reference, as in the paper's examples, where the
//!    boundary stays put.
//! 2. **Reference Jacobians** (equation 4): at every corner of every element,
//!    Jr = the edges from the corner vertex's *reference* position to its
//!    neighbours' *Lagrangian* positions; F_RJ, the mean over all corners of
//!    det(Jr) |J - Jr|^2 / (det(J) |Jr|^2), is then minimised from the
//!    Lagrangian positions with any `solve::Method` (by default NLCG, the
//!    paper's optimiser).
//!
//! Each corner's Jr is its target W, so the corner's S = J Jr^-1 and the
//! term is the `rj` metric of S (`metric::reference_jacobian`); the problem
//! is an ordinary `Problem` with one shape per corner, and every backend runs
//! it. Both steps run in the mesh's `Frame`, so the result does not depend on
//! units or position.

use super::{Device, Info, Method, Options, Params, Record, solve};
use crate::Mesh;
use crate::error::{Error, Result};
use crate::mesh::frame::Frame;
use crate::metric::corner_model::{CornerShape, Template};
use crate::metric::mat3::{Mat3, Vec3, sub};
use crate::metric::smetric::MetricKind;
use crate::problem::{Problem, ProblemOptions};
use std::time::Instant;

/// Rezoning settings.
#[derive(Clone, Default)]
pub struct RezoneOptions<'a> {
    /// Step 2's optimiser, its settings and where both steps run.
    pub solve: Options<'a>,
    /// Most Newton steps per vertex in step 1 (0: the default, 20).
    pub reference_iters: usize,
}

/// Default Newton steps per vertex of step 1: the local problem is convex
/// and three-dimensional, so Newton is done in a handful; the rest is margin.
pub const REFERENCE_ITERS: usize = 20;

/// What a rezoning did.
#[derive(Clone, Debug)]
pub struct RezoneInfo {
    /// Step 1's wall time (problem build included).
    pub reference_seconds: f64,
    /// Step 2's solve.
    pub info: Info,
}

/// The problem of step 1 and of the paper's CN optimisation: the paper's
/// condition-number measure at every corner.
pub fn cn_paper_options() -> ProblemOptions<'static> {
    ProblemOptions {
        metric: MetricKind::ConditionNumberPaper,
        template: Template::Harmonic,
        ..Default::default()
    }
}

/// Step 1 on `device` from positions `x` (problem numbering of `p`, a
/// `cn-paper` problem): every vertex's reference position.
pub fn reference_positions(p: &Problem, x: &[Vec3], device: Device, iters: usize) -> Result<Vec<Vec3>> {
    if p.model.metric != MetricKind::ConditionNumberPaper {
        return Err(Error::InvalidArgument(format!(
            "reference positions are defined for the cn-paper measure, not {}",
            p.model.metric
        )));
    }
    p.check_feasible(x)?;
    let ls = Default::default();
    let device = match device {
        // rank 0 holds the whole problem, and step 1 moves no vertex: no
        // exchange would help it (step 2 runs on the ranks)
        #[cfg(feature = "mpi")]
        Device::Mpi(_) => Device::Cpu,
        device => device,
    };
    device.backend(p, x, &ls)?.reference_positions(iters)
}

/// The F_RJ problem of `mesh` (its positions are the Lagrangian ones) with
/// reference positions `reference` (mesh numbering): every corner's target
/// is its reference Jacobian. Fails when a reference Jacobian is singular or
/// inverted (a reference position outside its feasible region).
pub fn rj_problem(mesh: &Mesh, reference: &[Vec3]) -> Result<Problem> {
    check_volume(mesh)?;
    if reference.len() != mesh.num_points() {
        return Err(Error::InvalidArgument(format!(
            "{} reference positions for a mesh of {} vertices",
            reference.len(),
            mesh.num_points()
        )));
    }
    let opts = ProblemOptions {
        metric: MetricKind::ReferenceJacobian,
        ..cn_paper_options()
    };
    let mut p = Problem::with_options(mesh, &opts)?;
    let xl = p.gather(&mesh.points);
    let xr = p.gather(reference);
    let mut shapes = Vec::with_capacity(p.num_corners());
    for (c, vs) in p.corners.iter().enumerate() {
        let o = xr[vs[0] as usize];
        let mut jr: Mat3 = [[0.0; 3]; 3];
        for col in 0..3 {
            let e = sub(&xl[vs[col + 1] as usize], &o);
            for row in 0..3 {
                jr[row][col] = e[row];
            }
        }
        let shape = CornerShape::from_w(&jr, 3).ok_or_else(|| {
            let e = p.elem_order[p.corner_element[c] as usize];
            Error::InvalidMesh(format!(
                "the reference Jacobian of element {e} at vertex {} is inverted or degenerate",
                p.order[vs[0] as usize]
            ))
        })?;
        shapes.push(shape);
    }
    p.corner_shape = (0..p.num_corners() as u32).collect();
    p.shapes = shapes;
    Ok(p)
}

fn check_volume(mesh: &Mesh) -> Result<()> {
    if mesh.dim() != 3 {
        return Err(Error::Unsupported(
            "reference-Jacobian rezoning is three-dimensional; this mesh is planar".into(),
        ));
    }
    Ok(())
}

/// Rezones `mesh` in place: step 1 and step 2 of the module doc, in the
/// mesh's frame; fixed vertices keep their bits. `progress` sees step 2's
/// history.
pub fn rezone_mesh(
    mesh: &mut Mesh,
    opts: &RezoneOptions,
    progress: &mut dyn FnMut(&Record) -> bool,
) -> Result<RezoneInfo> {
    let iters = if opts.reference_iters == 0 {
        REFERENCE_ITERS
    } else {
        opts.reference_iters
    };
    check_volume(mesh)?;
    let frame = Frame::of(&mesh.points);
    let mut local = mesh.clone();
    local.points = mesh.points.iter().map(|q| frame.to_local(q)).collect();

    let start = Instant::now();
    let p1 = Problem::with_options(&local, &cn_paper_options())?;
    let x1 = p1.gather(&local.points);
    let reference = p1.scatter(&reference_positions(&p1, &x1, opts.solve.device, iters)?);
    let reference_seconds = start.elapsed().as_secs_f64();

    let p2 = rj_problem(&local, &reference)?;
    let x0 = p2.gather(&local.points);
    let mut x = x0.clone();
    let result = solve(&p2, &mut x, &opts.solve, progress);
    let moved = p2.scatter(&x);
    for (new, &old) in p2.order.iter().enumerate() {
        if p2.free[new] && x[new] != x0[new] {
            mesh.points[old as usize] = frame.to_global(&moved[old as usize]);
        }
    }
    Ok(RezoneInfo {
        reference_seconds,
        info: result?,
    })
}

/// The paper's CN optimisation (its equation 3, section 6's comparison): the
/// `cn-paper` measure minimised in place with `opts`.
pub fn cn_optimise_mesh(mesh: &mut Mesh, opts: &Options, progress: &mut dyn FnMut(&Record) -> bool) -> Result<Info> {
    super::smooth_mesh(mesh, &cn_paper_options(), opts, progress)
}

/// Step 2's default optimiser: the paper's, nonlinear CG with its
/// feasibility-aware strong-Wolfe line search (Newton reaches the same
/// minimiser in fewer, dearer iterations).
pub const DEFAULT_METHOD: Method = Method::Nlcg;

/// Default settings for both steps on `device`.
pub fn default_options(device: Device) -> RezoneOptions {
    RezoneOptions {
        solve: Options {
            method: DEFAULT_METHOD,
            params: Params::default(),
            device,
            ..Default::default()
        },
        reference_iters: REFERENCE_ITERS,
    }
}
