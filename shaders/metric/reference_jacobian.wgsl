// The reference-Jacobian corner term (equation 4 of the rezoning paper) as a
// metric of S = J Jr^-1: tr(A M A^T) / det(S) with A = S - I and
// M = Jr Jr^T / |Jr|^2, M recovered from the corner's B rows (b_1..b_3 are
// the rows of Jr^-1). CPU twin: src/metric/reference_jacobian.rs (same
// names, same sum orders).

#import mat3
#import smetric

// `reference_jacobian::weight`: M from Jr^-1 = rows b_1, b_2, b_3.
fn rj_weight(b: array<vec3<real>, 4>) -> mat3x3<real> {
    let winv = mat3x3<real>(b[1], b[2], b[3]);
    let d = det3(winv);
    let c = cofactor3(winv);
    let w = mat3x3<real>(
        vec3<real>(c[0][0], c[1][0], c[2][0]) / d,
        vec3<real>(c[0][1], c[1][1], c[2][1]) / d,
        vec3<real>(c[0][2], c[1][2], c[2][2]) / d,
    );
    let norm = frobenius_sq(w);
    return mat3x3<real>(
        vec3<real>(dot3(w[0], w[0]), dot3(w[0], w[1]), dot3(w[0], w[2])) / norm,
        vec3<real>(dot3(w[1], w[0]), dot3(w[1], w[1]), dot3(w[1], w[2])) / norm,
        vec3<real>(dot3(w[2], w[0]), dot3(w[2], w[1]), dot3(w[2], w[2])) / norm,
    );
}

// `reference_jacobian::rj`
fn rj(s: mat3x3<real>, d: real, m: mat3x3<real>, hess: bool) -> MetricEval {
    var a = s;
    a[0][0] -= real(1.0);
    a[1][1] -= real(1.0);
    a[2][2] -= real(1.0);
    // row i of A M = sum_j a[i][j] m[j]
    let am = mat3x3<real>(
        a[0][0] * m[0] + a[0][1] * m[1] + a[0][2] * m[2],
        a[1][0] * m[0] + a[1][1] * m[1] + a[1][2] * m[2],
        a[2][0] * m[0] + a[2][1] * m[1] + a[2][2] * m[2],
    );
    let q = frob_dot(am, a);
    let c = cofactor3(s);
    var out: MetricEval;
    out.v = q / d;
    let dd = d * d;
    out.g = mat3x3<real>(
        real(2.0) * am[0] / d - q * c[0] / dd,
        real(2.0) * am[1] / d - q * c[1] / dd,
        real(2.0) * am[2] / d - q * c[2] / dd,
    );
    if hess {
        out.h = shess_identity(real(0.0), 3u);
        out.h.r = mat3x3<real>(real(2.0) * m[0] / d, real(2.0) * m[1] / d, real(2.0) * m[2] / d);
        out.h.pair_c = real(-2.0) / dd;
        out.h.pair0 = am;
        out.h.pair1 = c;
        out.h.sq_c[0] = real(2.0) * q / (dd * d);
        out.h.sq[0] = c;
        out.h.p = scaled3(s, -q / dd);
    }
    return out;
}
