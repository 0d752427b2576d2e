// A metric's Hessian in S as structured terms (delta_ik R_jl; the det-Hessian
// form of P; the Gram term of D2(S); rank-one and symmetric pair terms), so
// that vertex blocks come out in closed form. Written without loops: llvmpipe
// gives all loops of one invocation a shared budget of 65535 iterations,
// which a high-valence vertex's corners would otherwise spend. CPU twin:
// src/metric/shess.rs (same names, same sum orders); the module doc there
// has the formulas.

#import mat3

const NSQ: u32 = 5u;
const TEMPLATE_SLOT: u32 = 4u;

struct SHess {
    // in 2D the delta_iq of the r term stops at 2 (z rows and columns stay zero)
    n: u32,
    r: mat3x3<real>,
    p: mat3x3<real>,
    gram: real,
    s: mat3x3<real>,
    sq_c: array<real, 5>,
    sq: array<mat3x3<real>, 5>,
    pair_c: real,
    pair0: mat3x3<real>,
    pair1: mat3x3<real>,
}

struct SRow {
    b: vec3<real>,
    rb: vec3<real>,
    sq: array<vec3<real>, 5>,
    pu: vec3<real>,
    pv: vec3<real>,
    w0: vec3<real>,
    w1: vec3<real>,
    w2: vec3<real>,
}

fn scaled3(m: mat3x3<real>, c: real) -> mat3x3<real> {
    return mat3x3<real>(m[0] * c, m[1] * c, m[2] * c);
}

// `SHess::identity`: c on the leading n x n diagonal.
fn shess_identity(c: real, n: u32) -> SHess {
    var h: SHess;
    h.n = n;
    h.r[0][0] = c;
    h.r[1][1] = c;
    if n == 3u {
        h.r[2][2] = c;
    }
    return h;
}

fn shess_scale(h_in: SHess, c: real) -> SHess {
    var h = h_in;
    h.r = scaled3(h.r, c);
    h.p = scaled3(h.p, c);
    h.gram *= c;
    h.sq_c[0] *= c;
    h.sq_c[1] *= c;
    h.sq_c[2] *= c;
    h.sq_c[3] *= c;
    h.sq_c[4] *= c;
    h.pair_c *= c;
    return h;
}

fn shess_row(h: SHess, b: vec3<real>) -> SRow {
    var o: SRow;
    o.b = b;
    o.rb = mul_vec(h.r, b);
    // most metrics use a few of the terms: the others' products stay zero
    if h.pair_c != real(0.0) {
        o.pu = mul_vec(h.pair0, b);
        o.pv = mul_vec(h.pair1, b);
    }
    if h.sq_c[0] != real(0.0) {
        o.sq[0] = mul_vec(h.sq[0], b);
    }
    if h.sq_c[1] != real(0.0) {
        o.sq[1] = mul_vec(h.sq[1], b);
    }
    if h.sq_c[2] != real(0.0) {
        o.sq[2] = mul_vec(h.sq[2], b);
    }
    if h.sq_c[3] != real(0.0) {
        o.sq[3] = mul_vec(h.sq[3], b);
    }
    if h.sq_c[4] != real(0.0) {
        o.sq[4] = mul_vec(h.sq[4], b);
    }
    if h.gram != real(0.0) {
        o.w0 = cross3(b, h.s[0]);
        o.w1 = cross3(b, h.s[1]);
        o.w2 = cross3(b, h.s[2]);
    }
    return o;
}

// m + c u v^T, each entry m[i][q] + (c u[i]) v[q].
fn outer_add(m: mat3x3<real>, c: real, u: vec3<real>, v: vec3<real>) -> mat3x3<real> {
    return mat3x3<real>(m[0] + (c * u[0]) * v, m[1] + (c * u[1]) * v, m[2] + (c * u[2]) * v);
}

// `SHess::block`
fn shess_block(h: SHess, a: SRow, c: SRow) -> mat3x3<real> {
    var m = mat3x3<real>();
    let d = dot3(a.b, c.rb);
    if h.sq_c[0] != real(0.0) {
        m = outer_add(m, h.sq_c[0], a.sq[0], c.sq[0]);
    }
    if h.sq_c[1] != real(0.0) {
        m = outer_add(m, h.sq_c[1], a.sq[1], c.sq[1]);
    }
    if h.sq_c[2] != real(0.0) {
        m = outer_add(m, h.sq_c[2], a.sq[2], c.sq[2]);
    }
    if h.sq_c[3] != real(0.0) {
        m = outer_add(m, h.sq_c[3], a.sq[3], c.sq[3]);
    }
    if h.sq_c[4] != real(0.0) {
        m = outer_add(m, h.sq_c[4], a.sq[4], c.sq[4]);
    }
    if h.pair_c != real(0.0) {
        m[0] += h.pair_c * (a.pu[0] * c.pv + a.pv[0] * c.pu);
        m[1] += h.pair_c * (a.pu[1] * c.pv + a.pv[1] * c.pu);
        m[2] += h.pair_c * (a.pu[2] * c.pv + a.pv[2] * c.pu);
    }
    m[0][0] += d;
    m[1][1] += d;
    if h.n == 3u {
        m[2][2] += d;
    }
    if h.gram != real(0.0) {
        // G[k][l] = w_k(a) . w_l(c); the term is delta_iq tr G - G[q][i]
        let g0 = vec3<real>(dot3(a.w0, c.w0), dot3(a.w0, c.w1), dot3(a.w0, c.w2));
        let g1 = vec3<real>(dot3(a.w1, c.w0), dot3(a.w1, c.w1), dot3(a.w1, c.w2));
        let g2 = vec3<real>(dot3(a.w2, c.w0), dot3(a.w2, c.w1), dot3(a.w2, c.w2));
        let tr = g0[0] + g1[1] + g2[2];
        m[0] -= h.gram * vec3<real>(g0[0], g1[0], g2[0]);
        m[0][0] += h.gram * tr;
        m[1] -= h.gram * vec3<real>(g0[1], g1[1], g2[1]);
        m[1][1] += h.gram * tr;
        m[2] -= h.gram * vec3<real>(g0[2], g1[2], g2[2]);
        m[2][2] += h.gram * tr;
    }
    let z = mul_vec(h.p, cross3(a.b, c.b));
    m[0][1] += z[2];
    m[1][0] -= z[2];
    m[1][2] += z[0];
    m[2][1] -= z[0];
    m[2][0] += z[1];
    m[0][2] -= z[1];
    return m;
}
