// Inverse mean ratio eta = |S|_F^2 / (n det(S)^(2/n)) with S = X B: the
// closed forms of a tetrahedron (CPU twin src/metric/mean_ratio.rs) and the
// dense S-Hessian for n = 2 or 3 (CPU twin `smetric::imr`); same names, same
// sum orders.

#import mat3
#import cbrt
#import smetric

// S = sum_k x_k b_k^T
fn s_of(x: array<vec3<real>, 4>, b: array<vec3<real>, 4>) -> mat3x3<real> {
    var s = mat3x3<real>();
    for (var k = 0; k < 4; k++) {
        for (var i = 0; i < 3; i++) {
            for (var j = 0; j < 3; j++) {
                s[i][j] += x[k][i] * b[k][j];
            }
        }
    }
    return s;
}

// S without vertex k's term, so that S(x_k = y) = rest + y b_k^T.
fn s_rest(x: array<vec3<real>, 4>, b: array<vec3<real>, 4>, k: u32) -> mat3x3<real> {
    var s = mat3x3<real>();
    for (var j = 0u; j < 4u; j++) {
        if j == k {
            continue;
        }
        for (var i = 0; i < 3; i++) {
            for (var c = 0; c < 3; c++) {
                s[i][c] += x[j][i] * b[j][c];
            }
        }
    }
    return s;
}

fn s_with(rest: mat3x3<real>, bk: vec3<real>, y: vec3<real>) -> mat3x3<real> {
    var s = rest;
    for (var i = 0; i < 3; i++) {
        for (var c = 0; c < 3; c++) {
            s[i][c] += y[i] * bk[c];
        }
    }
    return s;
}

fn cbrt_sq(d: real) -> real {
    let c = cbrt(d);
    return c * c;
}

// NaN fails every comparison, so `is_finite_pos` is false for it too.
fn is_finite_pos(v: real) -> bool {
    return v > real(0.0) && v <= REAL_MAX;
}

struct Eta {
    eta: real,
    ok: bool,
}

fn value_of_s(s: mat3x3<real>) -> Eta {
    let d = det3(s);
    if !is_finite_pos(d) {
        return Eta(real(0.0), false);
    }
    let eta = frobenius_sq(s) / (real(3.0) * cbrt_sq(d));
    return Eta(eta, eta <= REAL_MAX);
}

struct SParts {
    s: mat3x3<real>,
    cof: mat3x3<real>,
    d: real,
    // d^(-2/3)
    h: real,
    f: real,
    eta: real,
    grad_s: mat3x3<real>,
    ok: bool,
}

fn parts_of_s(s: mat3x3<real>) -> SParts {
    var p: SParts;
    p.ok = false;
    let d = det3(s);
    if !is_finite_pos(d) {
        return p;
    }
    let h = real(1.0) / cbrt_sq(d);
    let f = frobenius_sq(s);
    let eta = f * h / real(3.0);
    if !(eta <= REAL_MAX) {
        return p;
    }
    let cof = cofactor3(s);
    let a = real(2.0) * h / real(3.0);
    let c = real(2.0) * eta / (real(3.0) * d);
    var grad_s = mat3x3<real>();
    for (var i = 0; i < 3; i++) {
        for (var j = 0; j < 3; j++) {
            grad_s[i][j] = a * s[i][j] - c * cof[i][j];
        }
    }
    return SParts(s, cof, d, h, f, eta, grad_s, true);
}

struct VertexGH {
    eta: real,
    grad: vec3<real>,
    hess: mat3x3<real>,
    ok: bool,
}

// Value, gradient and 3x3 Hessian with respect to the vertex whose row of B
// is `b`; the det-curvature term drops out (det is linear in one vertex).
fn vertex_gradient_hessian_of_s(s: mat3x3<real>, b: vec3<real>) -> VertexGH {
    var out: VertexGH;
    let p = parts_of_s(s);
    out.ok = p.ok;
    if !p.ok {
        return out;
    }
    let grad = mul_vec(p.grad_s, b);
    let sb = mul_vec(p.s, b);
    let cb = mul_vec(p.cof, b);
    let bb = b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
    let h = p.h;
    let dm53 = h / p.d;
    let dm83 = dm53 / p.d;
    let diag = real(2.0) * h * bb / real(3.0);
    let cross = real(-(4.0 / 9.0)) * dm53;
    let cc = real(10.0 / 27.0) * p.f * dm83;
    var hess = mat3x3<real>();
    for (var i = 0; i < 3; i++) {
        for (var l = 0; l < 3; l++) {
            hess[i][l] = cross * (sb[i] * cb[l] + cb[i] * sb[l]) + cc * cb[i] * cb[l];
        }
        hess[i][i] += diag;
    }
    out.eta = p.eta;
    out.grad = grad;
    out.hess = hess;
    return out;
}

// sign of the permutation (a, b, c) of (0, 1, 2)
fn levi(a: i32, b: i32, c: i32) -> real {
    if (b - a + 3) % 3 == 1 {
        return real(1.0);
    }
    return real(-1.0);
}

// Hessian of eta with respect to S, index 3 i + j for S[i][j].
fn hess_s(p: SParts) -> array<array<real, 9>, 9> {
    let h = p.h;
    let dm53 = h / p.d;
    let dm83 = dm53 / p.d;
    var out: array<array<real, 9>, 9>;
    for (var i = 0; i < 3; i++) {
        for (var j = 0; j < 3; j++) {
            for (var k = 0; k < 3; k++) {
                for (var l = 0; l < 3; l++) {
                    let a = 3 * i + j;
                    let b = 3 * k + l;
                    var v = real(-(4.0 / 9.0)) * dm53 * (p.s[i][j] * p.cof[k][l] + p.cof[i][j] * p.s[k][l])
                        + real(10.0 / 27.0) * p.f * dm83 * p.cof[i][j] * p.cof[k][l];
                    if a == b {
                        v += real(2.0) * h / real(3.0);
                    }
                    if i != k && j != l {
                        let m = 3 - i - k;
                        let n = 3 - j - l;
                        let sign = levi(i, k, m) * levi(j, l, n);
                        v -= real(2.0 / 9.0) * p.f * dm53 * sign * p.s[m][n];
                    }
                    out[a][b] = v;
                }
            }
        }
    }
    return out;
}

// eta = f h / n with f = |S|^2, h = d^(-2/n), through the dense 9x9 Hessian.
fn imr(n: u32, s: mat3x3<real>, x: Chi, hess: bool) -> MetricEval {
    var out: MetricEval;
    let d = x.c;
    let nf = real(n);
    var h = real(1.0) / d;
    if n == 3u {
        h = real(1.0) / cbrt_sq(d);
    }
    let f = frob_n(s, n);
    out.v = f * h / nf;
    let c = cof_n(s, n);
    // d h / d det = -p h / d
    let p = real(2.0) / nf;
    for (var i = 0u; i < n; i++) {
        for (var j = 0u; j < n; j++) {
            out.g[i][j] = (real(2.0) * h * s[i][j] - f * p * h / d * (x.c1 * c[i][j])) / nf;
        }
    }
    if hess {
        let d2 = d2det(s, n);
        let sf = flat9(s);
        let cf = flat9(c);
        let cross = real(-2.0) * p * h / d / nf;
        let cc = f * p * (p + real(1.0)) * h / (d * d) / nf;
        let dd = -f * p * h / d / nf;
        for (var a = 0u; a < 9u; a++) {
            if a % 3u >= n || a / 3u >= n {
                continue;
            }
            for (var b = 0u; b < 9u; b++) {
                if b % 3u >= n || b / 3u >= n {
                    continue;
                }
                // grad chi = chi' C; Hess chi = chi' D2 + chi'' C C^T
                let ca = x.c1 * cf[a];
                let cb = x.c1 * cf[b];
                out.h[a][b] = cross * (sf[a] * cb + ca * sf[b]) + cc * ca * cb
                    + dd * (x.c1 * d2[a][b] + x.c2 * cf[a] * cf[b]);
            }
            out.h[a][a] += real(2.0) * h / nf;
        }
    }
    return out;
}
