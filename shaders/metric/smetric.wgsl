// Metrics as functions of one corner's S (n x n in the leading block of a
// mat3x3, n = 2 or 3) with value, gradient and structured Hessian in S
// (`shess.wgsl`). CPU twin: src/metric/smetric.rs (same names, same sum
// orders). The metric ids are those of `Model` in layout.wgsl.

#import mat3
#import shess
#import mean_ratio
#import condition
#import target
#if RJ
#import reference_jacobian
#endif

struct MetricEval {
    v: real,
    g: mat3x3<real>,
    h: SHess,
    ok: bool,
}

fn det_n(s: mat3x3<real>, n: u32) -> real {
    if n == 2u {
        return s[0][0] * s[1][1] - s[0][1] * s[1][0];
    }
    return det3(s);
}

fn cof_n(s: mat3x3<real>, n: u32) -> mat3x3<real> {
    if n == 2u {
        return mat3x3<real>(
            vec3<real>(s[1][1], -s[1][0], real(0.0)),
            vec3<real>(-s[0][1], s[0][0], real(0.0)),
            vec3<real>(real(0.0)),
        );
    }
    return cofactor3(s);
}

// `smetric::leading`: S with the rows and columns past n zeroed.
fn leading(s: mat3x3<real>, n: u32) -> mat3x3<real> {
    if n == 3u {
        return s;
    }
    return mat3x3<real>(
        vec3<real>(s[0][0], s[0][1], real(0.0)),
        vec3<real>(s[1][0], s[1][1], real(0.0)),
        vec3<real>(real(0.0)),
    );
}

// `frob_n` of a `leading` matrix (the zeros past n add nothing), in the
// CPU's order.
fn frob_n(s: mat3x3<real>, n: u32) -> real {
    if n == 2u {
        return s[0][0] * s[0][0] + s[0][1] * s[0][1] + s[1][0] * s[1][0] + s[1][1] * s[1][1];
    }
    return frobenius_sq(s);
}

// `smetric::d2det_term`
fn d2det_term(s: mat3x3<real>, n: u32, c: real) -> mat3x3<real> {
    if n == 2u {
        var m = mat3x3<real>();
        m[2][2] = c;
        return m;
    }
    return scaled3(s, c);
}

// NaN fails every comparison, so `finite` is false for it too.
fn finite(v: real) -> bool {
    return v >= -REAL_MAX && v <= REAL_MAX;
}

// chi(d, eps) of untangling with its first and second derivatives in d.
struct Chi {
    c: real,
    c1: real,
    c2: real,
}

// `smetric::chi`: (d + sqrt(eps^2 + d^2)) / 2, the conjugate form for d <= 0.
fn chi(d: real, eps: real) -> Chi {
    if eps == real(0.0) {
        return Chi(d, real(1.0), real(0.0));
    }
    let r = sqrt(eps * eps + d * d);
    var c = real(0.5) * eps * eps / (r - d);
    if d > real(0.0) {
        c = real(0.5) * (d + r);
    }
    return Chi(c, c / r, real(0.5) * eps * eps / (r * r * r));
}

// `smetric::eval_with`: ok = false when the corner is inverted or degenerate
// and eps = 0 (with eps > 0 det S is chi(det S, eps), untangling's
// regularisation); `rjm` is the reference-Jacobian metric's M (`rj_weight`),
// which the others ignore.
fn eval_metric(n: u32, s_in: mat3x3<real>, rjm: mat3x3<real>, hess: bool, eps: real) -> MetricEval {
    let s = leading(s_in, n);
    let d = det_n(s, n);
    if !finite(d) || (eps == real(0.0) && !is_finite_pos(d)) {
        var bad: MetricEval;
        bad.ok = false;
        return bad;
    }
    let x = chi(d, eps);
    var out: MetricEval;
    // one metric per compiled instance (`shader::Form`)
#if TMP
    out = tmp(n, s);
#endif
#if RJ
    out = rj(s, d, rjm, hess);
#endif
#if CN
    if n == 3u {
        out = cn3(s, x, hess);
    } else {
        out = imr(n, s, x, hess);
    }
#endif
#if IMR
    out = imr(n, s, x, hess);
#endif
#if SS
    out = shape_size(n, s, x, hess);
#endif
#if FAST
    // the closed forms are the inverse mean ratio's; this is their general twin
    out = imr(n, s, x, hess);
#endif
#if PLANAR
    // as for FAST: the planar closed forms' general twin (cn is imr in 2D)
    out = imr(n, s, x, hess);
#endif
    out.ok = finite(out.v);
    return out;
}
