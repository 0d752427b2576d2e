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
    var w: mat3x3<real>;
    for (var i = 0u; i < 3u; i++) {
        for (var j = 0u; j < 3u; j++) {
            w[i][j] = c[j][i] / d;
        }
    }
    var norm = real(0.0);
    for (var i = 0u; i < 3u; i++) {
        for (var j = 0u; j < 3u; j++) {
            norm += w[i][j] * w[i][j];
        }
    }
    var m: mat3x3<real>;
    for (var j = 0u; j < 3u; j++) {
        for (var k = 0u; k < 3u; k++) {
            var acc = real(0.0);
            for (var c2 = 0u; c2 < 3u; c2++) {
                acc += w[j][c2] * w[k][c2];
            }
            m[j][k] = acc / norm;
        }
    }
    return m;
}

// `reference_jacobian::rj`
fn rj(s: mat3x3<real>, d: real, m: mat3x3<real>, hess: bool) -> MetricEval {
    var a = s;
    for (var i = 0u; i < 3u; i++) {
        a[i][i] -= real(1.0);
    }
    var am: mat3x3<real>;
    for (var i = 0u; i < 3u; i++) {
        for (var k = 0u; k < 3u; k++) {
            var acc = real(0.0);
            for (var j = 0u; j < 3u; j++) {
                acc += a[i][j] * m[j][k];
            }
            am[i][k] = acc;
        }
    }
    var q = real(0.0);
    for (var i = 0u; i < 3u; i++) {
        for (var k = 0u; k < 3u; k++) {
            q += am[i][k] * a[i][k];
        }
    }
    let c = cofactor3(s);
    var out: MetricEval;
    out.v = q / d;
    for (var i = 0u; i < 3u; i++) {
        for (var j = 0u; j < 3u; j++) {
            out.g[i][j] = real(2.0) * am[i][j] / d - q * c[i][j] / (d * d);
        }
    }
    if hess {
        let d2 = d2det(s, 3u);
        for (var x = 0u; x < 9u; x++) {
            let i = x / 3u;
            let j = x % 3u;
            for (var y = 0u; y < 9u; y++) {
                let k = y / 3u;
                let l = y % 3u;
                var d2q = real(0.0);
                if i == k {
                    d2q = real(2.0) * m[j][l];
                }
                out.h[x][y] = d2q / d - real(2.0) * (am[i][j] * c[k][l] + c[i][j] * am[k][l]) / (d * d)
                    + q * (real(2.0) * c[i][j] * c[k][l] / (d * d * d) - d2[x][y] / (d * d));
            }
        }
    }
    return out;
}
