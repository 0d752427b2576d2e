//! CPU twin of `shaders/mean_ratio_eval.wgsl`: per tetrahedron the inverse
//! mean ratio, its 12 gradient and 144 Hessian entries (`TetShape::hessian`),
//! an infeasible element getting value -1 and zero derivatives.

use crate::backend::ElementEval;
use crate::metric::TetShape;
use crate::metric::mat3::Vec3;

/// Per-tetrahedron inverse mean ratio, its gradient and Hessian (-1 and zeros when infeasible).
pub fn mean_ratio_eval(shape: &TetShape, tets: &[[u32; 4]], x: &[Vec3]) -> ElementEval {
    let n = tets.len();
    let mut out = ElementEval {
        value: vec![-1.0; n],
        grad: vec![0.0; 12 * n],
        hess: vec![0.0; 144 * n],
    };
    for (e, t) in tets.iter().enumerate() {
        let pts = t.map(|v| x[v as usize]);
        if let Some((eta, g, h)) = shape.hessian(&pts) {
            out.value[e] = eta;
            out.grad[12 * e..12 * e + 12].copy_from_slice(g.as_flattened());
            out.hess[144 * e..144 * e + 144].copy_from_slice(h.as_flattened());
        }
    }
    out
}
