// Metrics as functions of one corner's S (n x n in the leading block of a
// mat3x3, n = 2 or 3) with value, gradient and 9x9 Hessian in S, index
// 3 i + j for S[i][j]. CPU twin: src/metric/smetric.rs (same names, same sum
// orders). The metric ids are those of `Model` in layout.wgsl.

#import mat3
#import mean_ratio
#import condition
#import target
#if RJ
#import reference_jacobian
#endif

alias Hess9 = array<array<real, 9>, 9>;

struct MetricEval {
    v: real,
    g: mat3x3<real>,
    h: Hess9,
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

fn frob_n(s: mat3x3<real>, n: u32) -> real {
    var f = real(0.0);
    for (var i = 0u; i < n; i++) {
        for (var j = 0u; j < n; j++) {
            f += s[i][j] * s[i][j];
        }
    }
    return f;
}

fn eps2(i: u32, j: u32) -> real {
    if i == j {
        return real(0.0);
    }
    if i < j {
        return real(1.0);
    }
    return real(-1.0);
}

fn eps3(i: u32, j: u32, k: u32) -> real {
    if i == j || j == k || i == k {
        return real(0.0);
    }
    if (j + 3u - i) % 3u == 1u {
        return real(1.0);
    }
    return real(-1.0);
}

// Second derivative of det: 3D sum_{m,l} eps_ikm eps_jln S[m][l]; 2D eps_ik eps_jl.
fn d2det(s: mat3x3<real>, n: u32) -> Hess9 {
    var h: Hess9;
    for (var i = 0u; i < n; i++) {
        for (var j = 0u; j < n; j++) {
            for (var k = 0u; k < n; k++) {
                for (var l = 0u; l < n; l++) {
                    if i == k || j == l {
                        continue;
                    }
                    if n == 2u {
                        h[3u * i + j][3u * k + l] = eps2(i, k) * eps2(j, l);
                    } else {
                        h[3u * i + j][3u * k + l] = eps3(i, k, 3u - i - k) * eps3(j, l, 3u - j - l)
                            * s[3u - i - k][3u - j - l];
                    }
                }
            }
        }
    }
    return h;
}

fn flat9(m: mat3x3<real>) -> array<real, 9> {
    return array<real, 9>(m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2]);
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
fn eval_metric(n: u32, s: mat3x3<real>, rjm: mat3x3<real>, hess: bool, eps: real) -> MetricEval {
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
#if FAST
    // the closed forms are the inverse mean ratio's; this is their general twin
    out = imr(n, s, x, hess);
#endif
    out.ok = finite(out.v);
    return out;
}
