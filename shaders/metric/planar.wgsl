// The inverse mean ratio of a planar corner, eta = |S|^2 / (2 det S) for the
// 2x2 S, in closed form: the path of triangles and quadrilaterals under the
// harmonic template (the condition number equals it in 2D). CPU twin:
// src/metric/planar.rs (same names, same sum orders); the module doc there
// has the block formula. Only the leading 2x2 block of S is read, so a
// kernel carries four reals per corner instead of the 3D structured Hessian.

#import mean_ratio

struct PlanarParts {
    eta: real,
    d: real,
    // rows of the 2x2 S, cof S and grad eta = (S - eta C) / d
    s0: vec2<real>,
    s1: vec2<real>,
    c0: vec2<real>,
    c1: vec2<real>,
    g0: vec2<real>,
    g1: vec2<real>,
    ok: bool,
}

fn planar_det(s: mat3x3<real>) -> real {
    return s[0][0] * s[1][1] - s[0][1] * s[1][0];
}

// `s_rest` of a planar corner: S without vertex k's term, its leading 2x2
// block only (all the planar forms read) and from the corner's three
// vertices (b_3 is zero in 2D, so its term adds exact zeros), in the CPU's
// order. What it leaves out is what llvmpipe need not load.
fn planar_s_rest(x: array<vec3<real>, 4>, b: array<vec3<real>, 4>, k: u32) -> mat3x3<real> {
    let zero = vec2<real>(real(0.0));
    let x0 = select(x[0].xy, zero, k == 0u);
    let x1 = select(x[1].xy, zero, k == 1u);
    let x2 = select(x[2].xy, zero, k == 2u);
    let r0 = x0[0] * b[0].xy + x1[0] * b[1].xy + x2[0] * b[2].xy;
    let r1 = x0[1] * b[0].xy + x1[1] * b[1].xy + x2[1] * b[2].xy;
    return mat3x3<real>(vec3<real>(r0, real(0.0)), vec3<real>(r1, real(0.0)), vec3<real>(real(0.0)));
}

// `planar::value_of_s`
fn planar_value_of_s(s: mat3x3<real>) -> Eta {
    let d = planar_det(s);
    if !(d > real(0.0)) {
        return Eta(real(0.0), false);
    }
    let f = s[0][0] * s[0][0] + s[0][1] * s[0][1] + s[1][0] * s[1][0] + s[1][1] * s[1][1];
    let eta = f / (real(2.0) * d);
    return Eta(eta, eta <= REAL_MAX);
}

// `planar::parts`
fn planar_parts(s: mat3x3<real>) -> PlanarParts {
    var p: PlanarParts;
    let e = planar_value_of_s(s);
    p.ok = e.ok;
    if !e.ok {
        return p;
    }
    let d = planar_det(s);
    p.eta = e.eta;
    p.d = d;
    p.s0 = vec2<real>(s[0][0], s[0][1]);
    p.s1 = vec2<real>(s[1][0], s[1][1]);
    p.c0 = vec2<real>(s[1][1], -s[1][0]);
    p.c1 = vec2<real>(-s[0][1], s[0][0]);
    p.g0 = (p.s0 - e.eta * p.c0) / d;
    p.g1 = (p.s1 - e.eta * p.c1) / d;
    return p;
}

// `planar::mv`: the 2x2 matrix of rows r0, r1 times the leading two of v.
fn planar_mv(r0: vec2<real>, r1: vec2<real>, v: vec3<real>) -> vec2<real> {
    return vec2<real>(r0[0] * v[0] + r0[1] * v[1], r1[0] * v[0] + r1[1] * v[1]);
}

// `Parts::gradient`
fn planar_gradient(p: PlanarParts, b: vec3<real>) -> vec3<real> {
    let g = planar_mv(p.g0, p.g1, b);
    return vec3<real>(g[0], g[1], real(0.0));
}

// `Parts::block`: rows `u` and `v`, z row and column zero.
fn planar_block(p: PlanarParts, u: vec3<real>, v: vec3<real>) -> mat3x3<real> {
    let su = planar_mv(p.s0, p.s1, u);
    let cu = planar_mv(p.c0, p.c1, u);
    let sv = planar_mv(p.s0, p.s1, v);
    let cv = planar_mv(p.c0, p.c1, v);
    let d = p.d;
    let diag = (u[0] * v[0] + u[1] * v[1]) / d;
    let cross = real(-1.0) / (d * d);
    let cc = real(2.0) * p.eta / (d * d);
    let skew = -p.eta / d * (u[0] * v[1] - u[1] * v[0]);
    var m = mat3x3<real>();
    m[0][0] = cross * (su[0] * cv[0] + cu[0] * sv[0]) + cc * cu[0] * cv[0] + diag;
    m[0][1] = cross * (su[0] * cv[1] + cu[0] * sv[1]) + cc * cu[0] * cv[1] + skew;
    m[1][0] = cross * (su[1] * cv[0] + cu[1] * sv[0]) + cc * cu[1] * cv[0] - skew;
    m[1][1] = cross * (su[1] * cv[1] + cu[1] * sv[1]) + cc * cu[1] * cv[1] + diag;
    return m;
}
