//! The reordering strategies of the vertex-reordering paper (sections 2 and
//! 4) for the sequential BCD sweep: static (the list is ordered once, before
//! the first sweep) or dynamic (reordered after every k-th sweep), and the
//! per-vertex keys the schemes sort by, all evaluated on the host in f64 over
//! the problem (the metric and template in use) at the current positions.
//!
//! Keys, per free vertex v:
//! - patch quality (WQP): the objective restricted to v's patch, the
//!   weighted mean of the corner terms of the elements around v (the
//!   template's average over the patch; larger is worse);
//! - gradient norm (LNG): |dF/dv|, tangential for a sliding vertex;
//! - absolute movement (GAVM): the distance v moved at its last visit;
//! - relative movement (GRVM): that distance over the distance v moved at
//!   its first visit (0/0 counts as 0, d/0 as infinite).
//!
//! Before any sweep has run (the static order, and the first order of a
//! dynamic run) no vertex has moved yet: the movement is then the one a
//! visit would make from the start positions, each vertex's visit computed
//! with the others at the start (a Jacobi trial; nothing moves). That trial
//! is also the "first movement" GRVM divides by. GRVM's own static key needs
//! a second movement to divide: the trial movement from the trial positions
//! (every vertex where its first trial put it, all at once), over the first
//! trial's. A vertex whose patch those positions invert makes no second move
//! (key 0). Without that second trial every static GRVM key would be 1 and
//! GRVM would be N.

use crate::backend::cpu::bcd::{Patch, visit};
use crate::backend::cpu::project_boundary::constrain_block;
use crate::mesh::sweep_order::{Key, SweepOrder};
use crate::mesh::topology::Csr;
use crate::metric::mat3::Vec3;
use crate::problem::Problem;
use crate::solve::line_search::LineSearch;
use std::time::Instant;

/// When the list is reordered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Strategy {
    /// Once, before the first sweep.
    #[default]
    Static,
    /// Before the first sweep and after every k-th sweep (k >= 1).
    Dynamic(usize),
}

impl Strategy {
    /// From `--reorder-every K`: 0 or none is static.
    pub fn every(k: Option<usize>) -> Strategy {
        match k {
            None | Some(0) => Strategy::Static,
            Some(k) => Strategy::Dynamic(k),
        }
    }
}

/// A sweep list and the state its scheme keeps between reorderings.
pub struct Reorder {
    /// The ordering scheme.
    pub scheme: SweepOrder,
    /// When to reorder: once, or every so many sweeps.
    pub strategy: Strategy,
    seed: u64,
    /// Free-vertex indices in the input order: the tie rule's list.
    base: Vec<u32>,
    /// The current visiting order (free-vertex indices).
    pub order: Vec<u32>,
    /// Per free vertex: distance moved at its first visit (GRVM's divisor).
    first_move: Vec<f64>,
    /// Per free vertex: distance moved at its last visit.
    last_move: Vec<f64>,
    /// Per free vertex: every corner of the elements around it (WQP).
    patch_corners: Option<Csr>,
    draws: u64,
    /// Reorderings done, the first included.
    pub count: usize,
    /// Time spent reordering (the paper's RT).
    pub seconds: f64,
}

impl Reorder {
    /// The first sweep list of `scheme` over `p`'s free vertices; `seed` drives the random tie-breaks.
    pub fn new(p: &Problem, scheme: SweepOrder, strategy: Strategy, seed: u64) -> Reorder {
        let base: Vec<u32> = (0..p.free_vertices.len() as u32).collect();
        Reorder {
            scheme,
            strategy,
            seed,
            order: base.clone(),
            base,
            first_move: Vec::new(),
            last_move: Vec::new(),
            patch_corners: None,
            draws: 0,
            count: 0,
            seconds: 0.0,
        }
    }

    /// The current visiting order as mesh vertex ids.
    pub fn vertices(&self, p: &Problem) -> Vec<u32> {
        self.order
            .iter()
            .map(|&f| p.order[p.free_vertices[f as usize] as usize])
            .collect()
    }

    /// Whether the sweep must record each vertex's displacement for the next
    /// reordering.
    pub fn needs_moves(&self) -> bool {
        matches!(self.strategy, Strategy::Dynamic(_))
            && matches!(self.scheme.scheme.key(), Key::AbsoluteMove | Key::RelativeMove)
    }

    /// Whether the list is reordered after sweep number `sweep` (from 1).
    pub fn due(&self, sweep: usize) -> bool {
        matches!(self.strategy, Strategy::Dynamic(k) if sweep.is_multiple_of(k.max(1)))
    }

    /// The first order, at the start positions `x` (problem numbering);
    /// `ls` and `inner` are the sweep's, for the trial movement.
    pub fn initial(&mut self, p: &Problem, x: &[Vec3], ls: &LineSearch, inner: usize) {
        let t = Instant::now();
        match self.scheme.scheme.key() {
            Key::AbsoluteMove => {
                self.first_move = trial_moves(p, x, ls, inner);
                self.last_move = self.first_move.clone();
            }
            Key::RelativeMove => {
                let y = trial_positions(p, x, ls, inner);
                self.first_move = moves_between(p, x, &y);
                self.last_move = trial_moves(p, &y, ls, inner);
            }
            _ => {}
        }
        self.reorder(p, x);
        self.seconds += t.elapsed().as_secs_f64();
    }

    /// Reorders after a sweep that left positions `x` and wrote each visited
    /// vertex's displacement to `moves` (indexed like `free_vertices`; read
    /// only by the movement schemes).
    pub fn after_sweep(&mut self, p: &Problem, x: &[Vec3], moves: Option<&[Vec3]>) {
        let t = Instant::now();
        if let Some(m) = moves {
            for (d, m) in self.last_move.iter_mut().zip(m) {
                *d = norm(m);
            }
        }
        self.reorder(p, x);
        self.seconds += t.elapsed().as_secs_f64();
    }

    fn reorder(&mut self, p: &Problem, x: &[Vec3]) {
        let keys = match self.scheme.scheme.key() {
            Key::None => Vec::new(),
            Key::PatchQuality => {
                let pc = self.patch_corners.get_or_insert_with(|| patch_corners(p));
                patch_quality(p, x, pc)
            }
            Key::GradientNorm => gradient_norms(p, x),
            Key::AbsoluteMove => self.last_move.clone(),
            Key::RelativeMove => self
                .last_move
                .iter()
                .zip(&self.first_move)
                .map(|(&d, &d0)| if d == 0.0 { 0.0 } else { d / d0 })
                .collect(),
        };
        let points: Vec<[f64; 3]> = if self.scheme.scheme.is_distance() {
            p.free_vertices.iter().map(|&v| x[v as usize]).collect()
        } else {
            Vec::new()
        };
        self.order = self.scheme.apply(&self.base, &keys, &points, self.seed, self.draws);
        self.draws += 1;
        self.count += 1;
    }
}

fn norm(a: &Vec3) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// Per free vertex: the distance one visit (`inner` Newton steps) would move
/// it from `x`, the others held at `x`.
pub fn trial_moves(p: &Problem, x: &[Vec3], ls: &LineSearch, inner: usize) -> Vec<f64> {
    moves_between(p, x, &trial_positions(p, x, ls, inner))
}

/// `x` with every free vertex where one visit from `x` (the others held at
/// `x`) would put it: a Jacobi step, which may invert elements that no
/// single visit would.
pub fn trial_positions(p: &Problem, x: &[Vec3], ls: &LineSearch, inner: usize) -> Vec<Vec3> {
    let mut patch = Patch::default();
    let mut y = x.to_vec();
    for &v in &p.free_vertices {
        y[v as usize] = visit(p, x, v as usize, ls, inner, &mut patch);
    }
    y
}

/// Per free vertex: how far it lies from `x` in `y`.
fn moves_between(p: &Problem, x: &[Vec3], y: &[Vec3]) -> Vec<f64> {
    p.free_vertices
        .iter()
        .map(|&v| {
            let (a, b) = (x[v as usize], y[v as usize]);
            norm(&[b[0] - a[0], b[1] - a[1], b[2] - a[2]])
        })
        .collect()
}

/// Per free vertex: the corners of every element it belongs to (an element
/// is found through the vertex's own corner in it).
pub fn patch_corners(p: &Problem) -> Csr {
    let element_corners = Csr::from_pairs(
        p.num_elements(),
        p.corner_element.iter().enumerate().map(|(c, &e)| (e, c as u32)),
    );
    let mut pairs = Vec::new();
    let mut elems = Vec::new();
    for (f, &v) in p.free_vertices.iter().enumerate() {
        elems.clear();
        elems.extend(
            p.incidence
                .of(v as usize)
                .iter()
                .map(|&k| p.corner_element[(k >> 2) as usize]),
        );
        elems.sort_unstable();
        elems.dedup();
        for &e in &elems {
            pairs.extend(element_corners.of(e as usize).iter().map(|&c| (f as u32, c)));
        }
    }
    Csr::from_pairs(p.free_vertices.len(), pairs.into_iter())
}

/// Per free vertex: the patch objective, the weighted mean of the corner
/// terms over `patch_corners` (infinite if a corner is inverted).
pub fn patch_quality(p: &Problem, x: &[Vec3], patch_corners: &Csr) -> Vec<f64> {
    (0..p.free_vertices.len())
        .map(|f| {
            let (mut sum, mut weight) = (0.0, 0.0);
            for &c in patch_corners.of(f) {
                let c = c as usize;
                match p.corner_term(x, c) {
                    Some(t) => sum += t,
                    None => return f64::INFINITY,
                }
                weight += p.corner_weight[c];
            }
            if weight > 0.0 { sum / weight } else { 0.0 }
        })
        .collect()
}

/// Per free vertex: |dF/dv| at `x` (tangential where the vertex slides).
pub fn gradient_norms(p: &Problem, x: &[Vec3]) -> Vec<f64> {
    let mut patch = Patch::default();
    p.free_vertices
        .iter()
        .map(|&v| {
            let v = v as usize;
            patch.load(p, x, v);
            let Some((_, g, h)) = patch.gradient_hessian(p, &x[v]) else {
                return f64::INFINITY;
            };
            let g = match p.sliding.as_ref().filter(|s| s.slides(v)) {
                Some(s) => constrain_block(&s.projector[v], &g, &h).0,
                None => g,
            };
            norm(&g)
        })
        .collect()
}
