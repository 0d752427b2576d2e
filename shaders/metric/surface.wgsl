// A corner of a surface mesh, measured in its own tangent plane from
// f = |S|^2 and its area d = |s0 x s1| (the inverse mean ratio f / (2 d),
// which the condition number equals in 2D), under either template. CPU twin:
// src/metric/surface.rs (same names, same formulas); the module doc there
// says why no tangent frame is built. A corner is feasible while s0 x s1
// faces its element's reference normal `n`.

#import mat3
#import mean_ratio

struct SurfaceParts {
    value: real,
    // d value / d s_i (the columns of S)
    g: array<vec3<real>, 2>,
    // d^2 value / d s_i d s_j at 2 i + j
    h: array<mat3x3<real>, 4>,
    ok: bool,
}

fn surface_column(s: mat3x3<real>, j: u32) -> vec3<real> {
    return vec3<real>(s[0][j], s[1][j], s[2][j]);
}

// `surface::facing_area`: (s0 x s1) . n
fn surface_facing_area(s: mat3x3<real>, n: vec3<real>) -> real {
    return dot3(cross3(surface_column(s, 0u), surface_column(s, 1u)), n);
}

// `skew`: the matrix of v -> a x v (m[i][j] as the CPU's row i, column j)
fn surface_skew(a: vec3<real>) -> mat3x3<real> {
    return mat3x3<real>(
        vec3<real>(real(0.0), -a[2], a[1]),
        vec3<real>(a[2], real(0.0), -a[0]),
        vec3<real>(-a[1], a[0], real(0.0)),
    );
}

// `outer`: m[i][j] = a_i b_j
fn surface_outer(a: vec3<real>, b: vec3<real>) -> mat3x3<real> {
    return mat3x3<real>(a[0] * b, a[1] * b, a[2] * b);
}

// `at_b`: A^T B
fn surface_at_b(a: mat3x3<real>, b: mat3x3<real>) -> mat3x3<real> {
    return surface_outer(a[0], b[0]) + surface_outer(a[1], b[1]) + surface_outer(a[2], b[2]);
}

// `surface::value`
fn surface_value_of_s(tmpl: u32, s: mat3x3<real>, n: vec3<real>) -> Eta {
    let s0 = surface_column(s, 0u);
    let s1 = surface_column(s, 1u);
    let c = cross3(s0, s1);
    if !(dot3(c, n) > real(0.0)) {
        return Eta(real(0.0), false);
    }
    let d = sqrt(dot3(c, c));
    let f = dot3(s0, s0) + dot3(s1, s1);
    let m = f / (real(2.0) * d);
    if !(m <= REAL_MAX) {
        return Eta(real(0.0), false);
    }
    if tmpl == TEMPLATE_AVERAGE {
        return Eta(real(1.0) - real(1.0) / m, true);
    }
    return Eta(m, true);
}

// `surface::parts`
fn surface_parts(tmpl: u32, s: mat3x3<real>, n: vec3<real>) -> SurfaceParts {
    var p: SurfaceParts;
    let sc = array<vec3<real>, 2>(surface_column(s, 0u), surface_column(s, 1u));
    let c = cross3(sc[0], sc[1]);
    if !(dot3(c, n) > real(0.0)) {
        return p;
    }
    let d = sqrt(dot3(c, c));
    let f = dot3(sc[0], sc[0]) + dot3(sc[1], sc[1]);
    let ch = c / d;
    // m = f / (2 d) and its partial derivatives (m_ff = 0)
    let m = f / (real(2.0) * d);
    if !(m <= REAL_MAX) {
        return p;
    }
    let mf = real(1.0) / (real(2.0) * d);
    let md = -f / (real(2.0) * d * d);
    let mfd = real(-1.0) / (real(2.0) * d * d);
    let mdd = f / (d * d * d);
    let gf = array<vec3<real>, 2>(real(2.0) * sc[0], real(2.0) * sc[1]);
    let gd = array<vec3<real>, 2>(cross3(sc[1], ch), cross3(ch, sc[0]));
    // d c / d s0 = -[s1]x, d c / d s1 = [s0]x
    let l = array<mat3x3<real>, 2>(real(-1.0) * surface_skew(sc[1]), surface_skew(sc[0]));
    let chx = surface_skew(ch);
    let eye = mat3x3<real>(vec3<real>(real(1.0), real(0.0), real(0.0)), vec3<real>(real(0.0), real(1.0), real(0.0)), vec3<real>(real(0.0), real(0.0), real(1.0)));
    for (var i = 0u; i < 2u; i++) {
        p.g[i] = mf * gf[i] + md * gd[i];
        for (var j = 0u; j < 2u; j++) {
            let dd = surface_outer(gd[i], gd[j]);
            // d^2 d: (|dc|^2 - (c^ . dc)^2) / d + 2 c^ . (ds0 x ds1)
            var hd = (surface_at_b(l[i], l[j]) - dd) * (real(1.0) / d);
            if i == 0u && j == 1u {
                hd -= chx;
            } else if i == 1u && j == 0u {
                hd -= transpose(chx);
            }
            var hf = mat3x3<real>();
            if i == j {
                hf = real(2.0) * eye;
            }
            let fd = surface_outer(gf[i], gd[j]) + surface_outer(gd[i], gf[j]);
            p.h[2u * i + j] = mfd * fd + mdd * dd + mf * hf + md * hd;
        }
    }
    p.ok = true;
    p.value = m;
    if tmpl == TEMPLATE_AVERAGE {
        let d1 = real(1.0) / (m * m);
        let d2 = real(-2.0) / (m * m * m);
        for (var i = 0u; i < 2u; i++) {
            for (var j = 0u; j < 2u; j++) {
                p.h[2u * i + j] = d1 * p.h[2u * i + j] + d2 * surface_outer(p.g[i], p.g[j]);
            }
        }
        p.value = real(1.0) - real(1.0) / m;
        p.g[0] = d1 * p.g[0];
        p.g[1] = d1 * p.g[1];
    }
    return p;
}

// `Parts::gradient`: for a vertex whose B row is `b`
fn surface_gradient(p: SurfaceParts, b: vec3<real>) -> vec3<real> {
    return b[0] * p.g[0] + b[1] * p.g[1];
}

// `Parts::block`: the 3x3 block of two vertices with B rows `bk`, `bl`
fn surface_block(p: SurfaceParts, bk: vec3<real>, bl: vec3<real>) -> mat3x3<real> {
    return (bk[0] * bl[0]) * p.h[0] + (bk[0] * bl[1]) * p.h[1] + (bk[1] * bl[0]) * p.h[2] + (bk[1] * bl[1]) * p.h[3];
}

// `S` as a gradient matrix: G[a][j] = d value / d S_aj
fn surface_grad_s(p: SurfaceParts) -> mat3x3<real> {
    return mat3x3<real>(
        vec3<real>(p.g[0][0], p.g[1][0], real(0.0)),
        vec3<real>(p.g[0][1], p.g[1][1], real(0.0)),
        vec3<real>(p.g[0][2], p.g[1][2], real(0.0)),
    );
}
