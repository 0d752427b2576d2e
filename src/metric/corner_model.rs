//! One corner of an element as the solvers see it: S = sum_k x_k b_k^T over
//! the corner vertex and its n neighbours (B = D W^-1), a metric of S, and a
//! template applied to it. Derivatives with respect to the vertices are
//! contractions of the S-derivatives with the rows b_k.
//!
//! The inverse mean ratio of tetrahedra under the harmonic template (the
//! papers' main case) takes the closed forms of `TetShape`; everything else
//! contracts the structured S-Hessian of `smetric` (`shess`) with the rows.

use super::mat3::{Mat3, Vec3, inverse, mul_vec, transpose};
use super::mean_ratio::TetShape;
use super::planar;
use super::reference_jacobian;
use super::shess::{SHess, TEMPLATE_SLOT};
use super::smetric::{self, MetricKind};
use super::surface;

/// How corner values are combined into the objective.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Template {
    /// F = mean over elements of the mean corner metric (for the inverse mean
    /// ratio: the harmonic mean of the mean ratios, equation 2 of the Newton paper).
    #[default]
    Harmonic,
    /// F = mean over elements of the mean of 1 - 1/m: maximises the linear
    /// average of the quality q = 1/m (mean ratio, inverse condition number).
    Average,
}

crate::error::by_name!(Template: "template" { Harmonic = "harmonic", Average = "average" });

/// A corner's reference: the B rows (vertex 0 = the corner, 1..=n its
/// neighbours; row n+1.. zero) and the dimension.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CornerShape {
    /// The B rows of the reference corner.
    pub tet: TetShape,
    /// The corner's dimension: 2 (planar) or 3.
    pub n: usize,
    /// A surface mesh's corner (in 3D): its element's unit reference normal,
    /// which it must keep facing (`surface.rs`); zero for every other corner.
    #[serde(default)]
    pub normal: Vec3,
}

impl CornerShape {
    /// From the reference corner matrix W (columns = reference edges), n x n in
    /// the leading block; `None` if W is singular or inverted.
    pub fn from_w(w: &Mat3, n: usize) -> Option<CornerShape> {
        let mut full = *w;
        if n == 2 {
            full[2] = [0.0, 0.0, 1.0];
            full[0][2] = 0.0;
            full[1][2] = 0.0;
        }
        if !(smetric::det_n(&full, n) > 0.0) {
            return None;
        }
        let mut winv = inverse(&full)?;
        if n == 2 {
            winv[2] = [0.0; 3];
            winv[0][2] = 0.0;
            winv[1][2] = 0.0;
        }
        Some(CornerShape {
            tet: TetShape::from_winv(&winv),
            n,
            normal: [0.0; 3],
        })
    }

    /// This planar shape as the corner of a surface element with unit
    /// reference normal `normal`.
    pub fn on_surface(mut self, normal: Vec3) -> CornerShape {
        self.normal = normal;
        self
    }

    /// A surface mesh's corner, measured in its own tangent plane.
    #[inline]
    pub fn is_surface(&self) -> bool {
        self.normal != [0.0; 3]
    }

    /// W^-1 (rows b_1..b_n).
    pub fn winv(&self) -> Mat3 {
        [*self.tet.b(1), *self.tet.b(2), *self.tet.b(3)]
    }
}

/// Metric, template and dimension: everything that turns corner positions
/// into objective terms.
#[derive(Clone, Copy, Debug, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Model {
    /// The corner metric.
    pub metric: MetricKind,
    /// How corner values combine into the objective.
    pub template: Template,
    /// Untangling's regularisation: det S becomes `smetric::chi(det S, eps)`
    /// (`smetric::eval_regularised`), so inverted corners have finite terms.
    /// 0 (the default) is the barrier metric itself.
    pub eps: f64,
}

impl Model {
    /// The closed forms apply: the inverse mean ratio in 3D under the harmonic template.
    #[inline]
    pub fn fast(&self, n: usize) -> bool {
        n == 3 && self.metric == MetricKind::InverseMeanRatio && self.template == Template::Harmonic && self.eps == 0.0
    }

    /// The planar closed forms apply (`planar.rs`): the inverse mean ratio
    /// (which the condition number equals in 2D) under the harmonic template.
    #[inline]
    pub fn planar(&self, n: usize) -> bool {
        n == 2
            && self.metric != MetricKind::TargetShapeSize
            && self.metric != MetricKind::ShapeSize
            && self.metric != MetricKind::ReferenceJacobian
            && self.template == Template::Harmonic
            && self.eps == 0.0
    }

    /// The template applied to a metric value, gradient and Hessian in S.
    #[inline]
    fn templated(&self, (m, g): (f64, Mat3), hess: Option<&mut SHess>) -> (f64, Mat3) {
        match self.template {
            Template::Harmonic => (m, g),
            Template::Average => {
                let (d1, d2) = (1.0 / (m * m), -2.0 / (m * m * m));
                if let Some(h) = hess {
                    h.scale(d1);
                    h.set_sq(TEMPLATE_SLOT, d2, &g);
                }
                (1.0 - 1.0 / m, g.map(|r| r.map(|v| v * d1)))
            }
        }
    }

    /// The metric of S for a corner of `shape` (the reference-Jacobian metric
    /// reads the corner's M from it; the others only its dimension).
    #[inline]
    fn eval(&self, shape: &CornerShape, s: &Mat3, mut hess: Option<&mut SHess>) -> Option<(f64, Mat3)> {
        let m = if self.metric == MetricKind::ReferenceJacobian {
            Some(reference_jacobian::weight(&shape.winv())?)
        } else {
            None
        };
        let mg = smetric::eval_full(self.metric, shape.n, s, m.as_ref(), hess.as_deref_mut(), self.eps)?;
        Some(self.templated(mg, hess))
    }

    /// Objective term of a corner of `shape` from its S.
    #[inline]
    pub fn value_of_s(&self, shape: &CornerShape, s: &Mat3) -> Option<f64> {
        if shape.is_surface() {
            return surface::value(self.template, s, &shape.normal);
        }
        if self.fast(shape.n) {
            return TetShape::value_of_s(s);
        }
        if self.planar(shape.n) {
            return planar::value_of_s(s);
        }
        Some(self.eval(shape, s, None)?.0)
    }

    /// The corner's objective term at positions `x` (corner first); `None` when the corner is infeasible.
    #[inline]
    pub fn value(&self, shape: &CornerShape, x: &[Vec3; 4]) -> Option<f64> {
        if self.planar(shape.n) && !shape.is_surface() {
            // the line searches' hot path: three points, the leading 2x2 block
            return planar::value_of_s(&planar::s_of(&shape.tet, x));
        }
        self.value_of_s(shape, &shape.tet.s_rest(x, usize::MAX))
    }

    /// Term, gradient and 3x3 Hessian with respect to vertex `k`, from S. In
    /// 2D the z row and column carry 1 on the diagonal so the blocks stay
    /// invertible; the z gradient is 0, so z never moves.
    #[inline]
    pub fn vertex_gradient_hessian_of_s(&self, shape: &CornerShape, s: Mat3, b: &Vec3) -> Option<(f64, Vec3, Mat3)> {
        let n = shape.n;
        if shape.is_surface() {
            let p = surface::parts(self.template, &s, &shape.normal)?;
            return Some((p.value, p.gradient(b), p.block(b, b)));
        }
        if self.fast(n) {
            return TetShape::vertex_gradient_hessian_at(s, b);
        }
        if self.planar(n) {
            let p = planar::parts(&s)?;
            let mut hv = p.block(b, b);
            hv[2][2] = 1.0;
            return Some((p.eta, p.gradient(b), hv));
        }
        let mut h = SHess::default();
        let (v, g) = self.eval(shape, &s, Some(&mut h))?;
        let mut hv = h.block(&h.row(b), &h.row(b));
        if n == 2 {
            hv[2][2] = 1.0;
        }
        Some((v, mul_vec(&g, b), hv))
    }

    /// Term and gradient with respect to the corner's vertices.
    pub fn gradient(&self, shape: &CornerShape, x: &[Vec3; 4]) -> Option<(f64, [Vec3; 4])> {
        if self.fast(shape.n) {
            return shape.tet.gradient(x);
        }
        let n = shape.n;
        let s = shape.tet.s_rest(x, usize::MAX);
        if shape.is_surface() {
            let p = surface::parts(self.template, &s, &shape.normal)?;
            return Some((p.value, three_vertex_gradient(shape, |b| p.gradient(b))));
        }
        if self.planar(n) {
            let p = planar::parts(&s)?;
            return Some((p.eta, three_vertex_gradient(shape, |b| p.gradient(b))));
        }
        let (v, g) = self.eval(shape, &s, None)?;
        let mut out = [[0.0; 3]; 4];
        for (k, o) in out.iter_mut().enumerate().take(n + 1) {
            *o = mul_vec(&g, shape.tet.b(k));
        }
        Some((v, out))
    }

    /// Term, gradient and the 4x4 vertex blocks of the Hessian (into `out`).
    pub fn blocks(&self, shape: &CornerShape, x: &[Vec3; 4], out: &mut [[Mat3; 4]; 4]) -> Option<(f64, [Vec3; 4])> {
        let r = self.upper_blocks(shape, x, out)?;
        // H is symmetric: the lower blocks are the upper ones transposed,
        // as the device's assembly stores them
        for k in 0..4 {
            for l in k + 1..4 {
                out[l][k] = transpose(&out[k][l]);
            }
        }
        Some(r)
    }

    /// `blocks` with only the blocks (k, l), k <= l, written: what a
    /// symmetric store needs, without the six transposes.
    pub fn upper_blocks(
        &self,
        shape: &CornerShape,
        x: &[Vec3; 4],
        out: &mut [[Mat3; 4]; 4],
    ) -> Option<(f64, [Vec3; 4])> {
        if self.fast(shape.n) {
            return shape.tet.upper_hessian_blocks(x, out);
        }
        let n = shape.n;
        let s = shape.tet.s_rest(x, usize::MAX);
        if shape.is_surface() {
            let p = surface::parts(self.template, &s, &shape.normal)?;
            let grad = three_vertex_blocks(shape, out, false, |b| p.gradient(b), |a, b| p.block(a, b));
            return Some((p.value, grad));
        }
        if self.planar(n) {
            let p = planar::parts(&s)?;
            let grad = three_vertex_blocks(shape, out, true, |b| p.gradient(b), |a, b| p.block(a, b));
            return Some((p.eta, grad));
        }
        let mut h = SHess::default();
        let (v, g) = self.eval(shape, &s, Some(&mut h))?;
        let nv = n + 1;
        let mut grad = [[0.0; 3]; 4];
        let mut rows = [h.row(&[0.0; 3]); 4];
        for l in 0..nv {
            rows[l] = h.row(shape.tet.b(l));
            grad[l] = mul_vec(&g, shape.tet.b(l));
        }
        for k in 0..4 {
            for l in k..4 {
                out[k][l] = if l < nv {
                    h.block(&rows[k], &rows[l])
                } else {
                    [[0.0; 3]; 3]
                };
            }
            if n == 2 && k < nv {
                out[k][k][2][2] = 1.0;
            }
        }
        Some((v, grad))
    }
}

/// The gradient of a corner with three vertices (planar or surface) from
/// the gradient for a vertex's B row.
fn three_vertex_gradient(shape: &CornerShape, gradient: impl Fn(&Vec3) -> Vec3) -> [Vec3; 4] {
    let mut out = [[0.0; 3]; 4];
    for (k, o) in out.iter_mut().enumerate().take(3) {
        *o = gradient(shape.tet.b(k));
    }
    out
}

/// `Model::upper_blocks` for a corner with three vertices from the gradient
/// and Hessian block for B rows; `pin_z` puts 1 on the z diagonal of a
/// planar corner's vertices, whose z never moves.
fn three_vertex_blocks(
    shape: &CornerShape,
    out: &mut [[Mat3; 4]; 4],
    pin_z: bool,
    gradient: impl Fn(&Vec3) -> Vec3,
    block: impl Fn(&Vec3, &Vec3) -> Mat3,
) -> [Vec3; 4] {
    for k in 0..4 {
        for l in k..4 {
            out[k][l] = if l < 3 {
                block(shape.tet.b(k), shape.tet.b(l))
            } else {
                [[0.0; 3]; 3]
            };
        }
        if pin_z && k < 3 {
            out[k][k][2][2] = 1.0;
        }
    }
    three_vertex_gradient(shape, gradient)
}
