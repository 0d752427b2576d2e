// One corner as the solvers see it: a metric of S, a template applied to it,
// and vertex derivatives as contractions of the S-derivatives with the rows
// b_k. CPU twin: src/metric/corner_model.rs (same names, same sum orders).

#import layout
#import mean_ratio
#import smetric

// `Model::templated`: Average is g(m) = 1 - 1/m, g' = 1/m^2, g'' = -2/m^3.
fn templated(model: Model, m: MetricEval, hess: bool) -> MetricEval {
    if model.tmpl != TEMPLATE_AVERAGE {
        return m;
    }
    var out = m;
    let d1 = real(1.0) / (m.v * m.v);
    let d2 = real(-2.0) / (m.v * m.v * m.v);
    let gf = flat9(m.g);
    if hess {
        for (var a = 0u; a < 9u; a++) {
            for (var b = 0u; b < 9u; b++) {
                out.h[a][b] = d1 * m.h[a][b] + d2 * gf[a] * gf[b];
            }
        }
    }
    out.v = real(1.0) - real(1.0) / m.v;
    for (var i = 0u; i < 3u; i++) {
        for (var j = 0u; j < 3u; j++) {
            out.g[i][j] = m.g[i][j] * d1;
        }
    }
    return out;
}

// The reference-Jacobian metric's M of a corner with B rows `b` (`Model::eval`
// on the CPU); the other metrics do not read it.
fn model_rjm(model: Model, b: array<vec3<real>, 4>) -> mat3x3<real> {
#if RJ
    return rj_weight(b);
#else
    return mat3x3<real>();
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
#else
    let m = model_eval(model, s, rjm, false);
    return Eta(m.v, m.ok);
#endif
}

// `Model::vertex_gradient_hessian_of_s`: in 2D the z diagonal is 1 so the
// block stays invertible, and the z gradient is 0, so z never moves.
fn model_vertex_gh(model: Model, s: mat3x3<real>, b: vec3<real>, rjm: mat3x3<real>) -> VertexGH {
#if FAST
    return vertex_gradient_hessian_of_s(s, b);
#else
    var out: VertexGH;
    let n = model.dim;
    let m = model_eval(model, s, rjm, true);
    out.ok = m.ok;
    if !m.ok {
        return out;
    }
    out.eta = m.v;
    for (var i = 0u; i < n; i++) {
        var gi = real(0.0);
        for (var j = 0u; j < n; j++) {
            gi += m.g[i][j] * b[j];
        }
        out.grad[i] = gi;
        for (var q = 0u; q < n; q++) {
            var acc = real(0.0);
            for (var j = 0u; j < n; j++) {
                for (var l = 0u; l < n; l++) {
                    acc += m.h[3u * i + j][3u * q + l] * b[j] * b[l];
                }
            }
            out.hess[i][q] = acc;
        }
    }
    if n == 2u {
        out.hess[2][2] = real(1.0);
    }
    return out;
#endif
}

// sum_j g[i][j] b[j] over the leading n columns (`Model::gradient`).
fn contract_g(g: mat3x3<real>, b: vec3<real>, n: u32) -> vec3<real> {
    var out = vec3<real>(real(0.0));
    for (var i = 0u; i < n; i++) {
        var acc = real(0.0);
        for (var j = 0u; j < n; j++) {
            acc += g[i][j] * b[j];
        }
        out[i] = acc;
    }
    return out;
}
