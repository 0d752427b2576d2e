//! CPU twin of `shaders/bcd.wgsl`: one safeguarded Newton step per free
//! vertex on its 3x3 block, Armijo backtracking on the elements around it
//! (section 3.1 of the Newton paper). `sweep_color` runs one colour in
//! parallel, as the kernel does; `sweep` visits the vertices one at a time in
//! locality order, which only the CPU can (the sequential BCD is CPU-only).

use super::project_boundary::{active_projector, constrain_block, project_vertex};
use crate::backend::settings::LineSearch;
use crate::metric::TetShape;
use crate::metric::mat3::{Mat3, Vec3, dot, newton_direction};
use crate::problem::Problem;
use rayon::prelude::*;
use std::time::Instant;

/// The corners around one vertex, each as S without the vertex's term
/// (`TetShape::s_rest`), the vertex's B row and the corner's weight: trial
/// points then cost one rank-one update per corner instead of a gather.
#[derive(Default)]
pub struct Patch {
    rest: Vec<(Mat3, Vec3, f64, u32)>,
}

impl Patch {
    pub fn load(&mut self, p: &Problem, x: &[Vec3], v: usize) {
        self.rest.clear();
        for &packed in p.incidence.of(v) {
            let (c, k) = ((packed >> 2) as usize, (packed & 3) as usize);
            let shape = p.shape(c);
            self.rest.push((
                shape.tet.s_rest(&p.corner_points(x, c), k),
                *shape.tet.b(k),
                p.corner_weight[c],
                p.corner_shape[c],
            ));
        }
    }

    /// The objective terms of these corners with the vertex at `at`; `None` if
    /// any corner would be inverted.
    #[inline]
    pub fn value(&self, p: &Problem, at: &Vec3) -> Option<f64> {
        let mut sum = 0.0;
        // the branch hoisted out of the loop keeps the common case tight
        if p.model.fast(p.dim) {
            for (rest, b, w, _) in &self.rest {
                sum += w * TetShape::value_of_s(&s_with(rest, b, at))?;
            }
        } else {
            for (rest, b, w, shape) in &self.rest {
                sum += w * p.model.value_of_s(&p.shapes[*shape as usize], &s_with(rest, b, at))?;
            }
        }
        Some(sum)
    }

    /// That sum, its gradient and 3x3 Hessian with respect to the vertex at `at`.
    #[inline]
    pub fn gradient_hessian(&self, p: &Problem, at: &Vec3) -> Option<(f64, Vec3, Mat3)> {
        let mut f = 0.0;
        let mut g = [0.0; 3];
        let mut h = [[0.0; 3]; 3];
        let fast = p.model.fast(p.dim);
        for (rest, b, w, shape) in &self.rest {
            let s = s_with(rest, b, at);
            let (eta, ge, he) = if fast {
                TetShape::vertex_gradient_hessian_at(s, b)?
            } else {
                p.model.vertex_gradient_hessian_of_s(&p.shapes[*shape as usize], s, b)?
            };
            f += w * eta;
            for i in 0..3 {
                g[i] += w * ge[i];
                for j in 0..3 {
                    h[i][j] += w * he[i][j];
                }
            }
        }
        Some((f, g, h))
    }
}

/// rest + y b^T
#[inline]
fn s_with(rest: &Mat3, b: &Vec3, y: &Vec3) -> Mat3 {
    let mut s = *rest;
    for i in 0..3 {
        for c in 0..3 {
            s[i][c] += y[i] * b[c];
        }
    }
    s
}

/// One safeguarded Newton step for vertex `v`: the accepted new position, or
/// `None` when no trial point decreased the patch objective enough.
#[inline]
pub fn newton_step(p: &Problem, x: &[Vec3], v: usize, ls: &LineSearch, patch: &mut Patch) -> Option<Vec3> {
    patch.load(p, x, v);
    patch_step(p, patch, v, &x[v], ls, 0.0)
}

/// The step of [`newton_step`] on a loaded patch of vertex `v` placed at `xv`;
/// `None` also when the Newton direction d has |d|^2 <= `min_step_sq`.
#[inline]
pub fn patch_step(p: &Problem, patch: &Patch, v: usize, xv: &Vec3, ls: &LineSearch, min_step_sq: f64) -> Option<Vec3> {
    let (f0, g, h) = patch.gradient_hessian(p, xv)?;
    // a sliding vertex: the step in its tangent space, each trial put back on the boundary
    let slide = p.sliding.as_ref().filter(|s| s.slides(v));
    let (g, h) = match slide {
        Some(s) => constrain_block(&active_projector(s, v, xv, &g), &g, &h),
        None => (g, h),
    };
    let d = newton_direction(&g, &h);
    let slope = dot(&g, &d);
    if !(slope < 0.0) || dot(&d, &d) <= min_step_sq {
        return None;
    }
    let mut alpha = 1.0;
    for _ in 0..=ls.max_backtracks {
        let mut trial = [xv[0] + alpha * d[0], xv[1] + alpha * d[1], xv[2] + alpha * d[2]];
        if let Some(s) = slide {
            trial = project_vertex(s, v, &trial);
        }
        if let Some(f) = patch.value(p, &trial)
            && f <= f0 + ls.sigma * alpha * slope
        {
            return Some(trial);
        }
        alpha *= ls.beta;
    }
    None
}

fn dist_sq(a: &Vec3, b: &Vec3) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum()
}

/// Up to `inner` Newton steps for vertex `v` (fewer when one finds no
/// decrease): its position after the visit.
#[inline]
pub fn visit(p: &Problem, x: &[Vec3], v: usize, ls: &LineSearch, inner: usize, patch: &mut Patch) -> Vec3 {
    patch.load(p, x, v);
    let mut at = x[v];
    for _ in 0..inner.max(1) {
        match patch_step(p, patch, v, &at, ls, 0.0) {
            Some(y) => at = y,
            None => break,
        }
    }
    at
}

/// One sweep over the free vertices in `visit`'s order with its inner
/// iterations, writing each displacement to `moves` (indexed like
/// `free_vertices`); stops early (leaving a valid state) at `deadline`.
/// Returns the largest squared displacement.
pub fn sweep(
    p: &Problem,
    x: &mut [Vec3],
    ls: &LineSearch,
    visit_as: &crate::backend::Visit,
    mut moves: Option<&mut Vec<Vec3>>,
    deadline: Option<Instant>,
) -> f64 {
    let mut max_sq: f64 = 0.0;
    let mut patch = Patch::default();
    let n = visit_as.order.map_or(p.free_vertices.len(), |o| o.len());
    for i in 0..n {
        if i % 4096 == 4095 && deadline.is_some_and(|d| Instant::now() >= d) {
            break;
        }
        let f = visit_as.order.map_or(i, |o| o[i] as usize);
        let v = p.free_vertices[f] as usize;
        let y = visit(p, x, v, ls, visit_as.inner_iterations, &mut patch);
        if let Some(m) = moves.as_deref_mut() {
            m[f] = [y[0] - x[v][0], y[1] - x[v][1], y[2] - x[v][2]];
        }
        max_sq = max_sq.max(dist_sq(&x[v], &y));
        x[v] = y;
    }
    max_sq
}

/// One colour of a sweep: the vertices of a colour share no element, so
/// their steps are independent and run in parallel. Returns the largest
/// squared displacement.
pub fn sweep_color(p: &Problem, x: &mut [Vec3], color: usize, ls: &LineSearch) -> f64 {
    let xs: &[Vec3] = x;
    let moves: Vec<(usize, Vec3)> = p
        .colors
        .of(color)
        .par_iter()
        .with_min_len(256)
        .map_init(Patch::default, |patch, &v| {
            newton_step(p, xs, v as usize, ls, patch).map(|y| (v as usize, y))
        })
        .flatten()
        .collect();
    let mut max_sq: f64 = 0.0;
    for (v, y) in moves {
        max_sq = max_sq.max(dist_sq(&x[v], &y));
        x[v] = y;
    }
    max_sq
}
