// Inverse mean ratio eta = |S|_F^2 / (n det(S)^(2/n)) with S = X B: the
// closed forms of a tetrahedron (CPU twin src/metric/mean_ratio.rs) and the
// dense S-Hessian for n = 2 or 3 (CPU twin `smetric::imr`); same names, same
// sum orders.

#import mat3
#import cbrt
#import smetric

// S = sum_k x_k b_k^T
fn s_of(x: array<vec3<real>, 4>, b: array<vec3<real>, 4>) -> mat3x3<real> {
    return s_rest(x, b, 4u);
}

// S without vertex k's term, so that S(x_k = y) = rest + y b_k^T (k = 4: all
// terms). Row i is sum_j x_j[i] b_j in j order, as on the CPU; the skipped
// term adds an exact zero. Unrolled: see `shess.wgsl` on llvmpipe's loop budget.
fn s_rest(x: array<vec3<real>, 4>, b: array<vec3<real>, 4>, k: u32) -> mat3x3<real> {
    let zero = vec3<real>(real(0.0));
    let x0 = select(x[0], zero, k == 0u);
    let x1 = select(x[1], zero, k == 1u);
    let x2 = select(x[2], zero, k == 2u);
    let x3 = select(x[3], zero, k == 3u);
    return mat3x3<real>(
        x0[0] * b[0] + x1[0] * b[1] + x2[0] * b[2] + x3[0] * b[3],
        x0[1] * b[0] + x1[1] * b[1] + x2[1] * b[2] + x3[1] * b[3],
        x0[2] * b[0] + x1[2] * b[1] + x2[2] * b[2] + x3[2] * b[3],
    );
}

fn s_with(rest: mat3x3<real>, bk: vec3<real>, y: vec3<real>) -> mat3x3<real> {
    return mat3x3<real>(rest[0] + y[0] * bk, rest[1] + y[1] * bk, rest[2] + y[2] * bk);
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

// eta = f h / n with f = |S|^2, h = d^(-2/n) (`smetric::imr`).
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
    let gc = f * p * h / d;
    // s and c are zero past n, so the full matrix is the leading block
    out.g = mat3x3<real>(
        (real(2.0) * h * s[0] - gc * (x.c1 * c[0])) / nf,
        (real(2.0) * h * s[1] - gc * (x.c1 * c[1])) / nf,
        (real(2.0) * h * s[2] - gc * (x.c1 * c[2])) / nf,
    );
    if hess {
        let cross = real(-2.0) * p * h / d / nf;
        let cc = f * p * (p + real(1.0)) * h / (d * d) / nf;
        let dd = -f * p * h / d / nf;
        out.h = shess_identity(real(2.0) * h / nf, n);
        out.h.pair_c = cross * x.c1;
        out.h.pair0 = s;
        out.h.pair1 = c;
        out.h.sq_c[0] = cc * x.c1 * x.c1 + dd * x.c2;
        out.h.sq[0] = c;
        out.h.p = d2det_term(s, n, dd * x.c1);
    }
    return out;
}

// `smetric::shape_size`: eta(S) + tau + 1/tau - 2 with tau = chi(det S); the
// size term adds sigma' chi' C to the gradient, (sigma'' chi'^2 + sigma' chi'')
// to the rank-one slot 0 (C C^T) and sigma' chi' D2 to P.
fn shape_size(n: u32, s: mat3x3<real>, x: Chi, hess: bool) -> MetricEval {
    var out = imr(n, s, x, hess);
    let tau = x.c;
    let s1 = real(1.0) - real(1.0) / (tau * tau);
    let s2 = real(2.0) / (tau * tau * tau);
    let c = cof_n(s, n);
    out.g = out.g + scaled3(c, s1 * x.c1);
    if hess {
        out.h.sq_c[0] += s2 * x.c1 * x.c1 + s1 * x.c2;
        out.h.p = out.h.p + d2det_term(s, n, s1 * x.c1);
    }
    out.v = out.v + tau + real(1.0) / tau - real(2.0);
    return out;
}
