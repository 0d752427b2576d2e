// One corner as the solvers see it: a metric of S, a template applied to it,
// and vertex derivatives as contractions of the S-derivatives with the rows
// b_k. CPU twin: src/metric/corner_model.rs (same names, same sum orders).

#import layout
#import mean_ratio
#import smetric
#if PLANAR
#import planar
#endif
#if SURFACE
#import surface
#endif

// `Model::templated`: Average is g(m) = 1 - 1/m, g' = 1/m^2, g'' = -2/m^3.
fn templated(model: Model, m: MetricEval, hess: bool) -> MetricEval {
    if model.tmpl != TEMPLATE_AVERAGE {
        return m;
    }
    var out = m;
    let d1 = real(1.0) / (m.v * m.v);
    let d2 = real(-2.0) / (m.v * m.v * m.v);
    if hess {
        out.h = shess_scale(m.h, d1);
        out.h.sq_c[TEMPLATE_SLOT] = d2;
        out.h.sq[TEMPLATE_SLOT] = m.g;
    }
    out.v = real(1.0) - real(1.0) / m.v;
    out.g = scaled3(m.g, d1);
    return out;
}

// What a corner's term reads beyond S: the reference-Jacobian metric's M
// (`Model::eval` on the CPU), or a surface corner's reference normal as row
// 0; the other forms read nothing.
fn model_aux(model: Model, cr: CornerRef) -> mat3x3<real> {
#if RJ
    return rj_weight(cr.b);
#endif
#if SURFACE
    return mat3x3<real>(cr.n, vec3<real>(real(0.0)), vec3<real>(real(0.0)));
#endif
#if !RJ
#if !SURFACE
    return mat3x3<real>();
#endif
#endif
}

fn model_eval(model: Model, s: mat3x3<real>, rjm: mat3x3<real>, hess: bool) -> MetricEval {
    let m = eval_metric(model.dim, s, rjm, hess, model.eps);
    if !m.ok {
        return m;
    }
    return templated(model, m, hess);
}

// `Model::value_of_s`
fn model_value_of_s(model: Model, s: mat3x3<real>, rjm: mat3x3<real>) -> Eta {
#if FAST
    return value_of_s(s);
#endif
#if PLANAR
    return planar_value_of_s(s);
#endif
#if SURFACE
    return surface_value_of_s(model.tmpl, s, rjm[0]);
#endif
#if GENERAL
    let m = model_eval(model, s, rjm, false);
    return Eta(m.v, m.ok);
#endif
}

// `Model::vertex_gradient_hessian_of_s`: in 2D the z diagonal is 1 so the
// block stays invertible, and the z gradient is 0, so z never moves.
fn model_vertex_gh(model: Model, s: mat3x3<real>, b: vec3<real>, rjm: mat3x3<real>) -> VertexGH {
#if FAST
    return vertex_gradient_hessian_of_s(s, b);
#endif
#if PLANAR
    var out: VertexGH;
    let p = planar_parts(s);
    out.ok = p.ok;
    if !p.ok {
        return out;
    }
    out.eta = p.eta;
    out.grad = planar_gradient(p, b);
    out.hess = planar_block(p, b, b);
    out.hess[2][2] = real(1.0);
    return out;
#endif
#if SURFACE
    // a surface vertex moves in 3D (its projector keeps it on the surface)
    var out: VertexGH;
    let p = surface_parts(model.tmpl, s, rjm[0]);
    out.ok = p.ok;
    if !p.ok {
        return out;
    }
    out.eta = p.value;
    out.grad = surface_gradient(p, b);
    out.hess = surface_block(p, b, b);
    return out;
#endif
#if GENERAL
    var out: VertexGH;
    let m = model_eval(model, s, rjm, true);
    out.ok = m.ok;
    if !m.ok {
        return out;
    }
    out.eta = m.v;
    out.grad = mul_vec(m.g, b);
    let row = shess_row(m.h, b);
    out.hess = shess_block(m.h, row, row);
    if model.dim == 2u {
        out.hess[2][2] = real(1.0);
    }
    return out;
#endif
}
