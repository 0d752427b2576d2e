// 3D Frobenius condition number kappa = |S| |C| / (3 d) through L = ln kappa
// (2D equals the inverse mean ratio). Only sqrt is needed, which f64 has on
// every backend. CPU twin: `smetric::cn3` (same sum orders).

#import smetric

// `smetric::cof_norm_gradient`: grad |cof S|^2 = 2 (|S|^2 S - S S^T S).
fn cof_norm_gradient(s: mat3x3<real>, a: real) -> mat3x3<real> {
    let sst = mat3x3<real>(
        vec3<real>(dot3(s[0], s[0]), dot3(s[0], s[1]), dot3(s[0], s[2])),
        vec3<real>(dot3(s[1], s[0]), dot3(s[1], s[1]), dot3(s[1], s[2])),
        vec3<real>(dot3(s[2], s[0]), dot3(s[2], s[1]), dot3(s[2], s[2])),
    );
    // row i of S S^T S = sum_k sst[i][k] s[k]
    let r0 = sst[0][0] * s[0] + sst[0][1] * s[1] + sst[0][2] * s[2];
    let r1 = sst[1][0] * s[0] + sst[1][1] * s[1] + sst[1][2] * s[2];
    let r2 = sst[2][0] * s[0] + sst[2][1] * s[1] + sst[2][2] * s[2];
    return mat3x3<real>(real(2.0) * (a * s[0] - r0), real(2.0) * (a * s[1] - r1), real(2.0) * (a * s[2] - r2));
}

fn cn3(s: mat3x3<real>, x: Chi, hess: bool) -> MetricEval {
    var out: MetricEval;
    let d = x.c;
    let d1 = x.c1;
    let c = cofactor3(s);
    let a = frob_n(s, 3u);
    let cc = frob_n(c, 3u);
    let kappa = sqrt(a * cc) / (real(3.0) * d);
    let gc = cof_norm_gradient(s, a);
    let gl = mat3x3<real>(
        s[0] / a + real(0.5) * gc[0] / cc - d1 * c[0] / d,
        s[1] / a + real(0.5) * gc[1] / cc - d1 * c[1] / d,
        s[2] / a + real(0.5) * gc[2] / cc - d1 * c[2] / d,
    );
    out.g = mat3x3<real>(kappa * gl[0], kappa * gl[1], kappa * gl[2]);
    if hess {
        out.h = shess_identity(kappa / a, 3u);
        out.h.sq_c[0] = real(-2.0) * kappa / (a * a);
        out.h.sq[0] = s;
        out.h.sq_c[1] = real(-0.5) * kappa / (cc * cc);
        out.h.sq[1] = gc;
        out.h.sq_c[2] = kappa * (d1 * d1 / (d * d) - x.c2 / d);
        out.h.sq[2] = c;
        out.h.sq_c[3] = kappa;
        out.h.sq[3] = gl;
        out.h.gram = kappa / cc;
        out.h.s = s;
        out.h.p = mat3x3<real>(
            kappa * (c[0] / cc - d1 * s[0] / d),
            kappa * (c[1] / cc - d1 * s[1] / d),
            kappa * (c[2] / cc - d1 * s[2] / d),
        );
    }
    out.v = kappa;
    return out;
}
