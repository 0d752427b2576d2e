// 3D Frobenius condition number kappa = |S| |C| / (3 d) through L = ln kappa
// (2D equals the inverse mean ratio). Only sqrt is needed, which f64 has on
// every backend. CPU twin: `smetric::cn3` (same sum orders).

#import smetric

fn cn3(s: mat3x3<real>, x: Chi, hess: bool) -> MetricEval {
    var out: MetricEval;
    let d = x.c;
    let c = cofactor3(s);
    let a = frob_n(s, 3u);
    let cc = frob_n(c, 3u);
    let kappa = sqrt(a * cc) / (real(3.0) * d);
    let d2 = d2det(s, 3u);
    let sf = flat9(s);
    let cf = flat9(c);
    // grad of |C|^2
    var gc: array<real, 9>;
    for (var p = 0u; p < 9u; p++) {
        var acc = real(0.0);
        for (var b = 0u; b < 9u; b++) {
            acc += d2[b][p] * cf[b];
        }
        gc[p] = real(2.0) * acc;
    }
    var gl: array<real, 9>;
    for (var k = 0u; k < 9u; k++) {
        gl[k] = sf[k] / a + real(0.5) * gc[k] / cc - x.c1 * cf[k] / d;
    }
    for (var i = 0u; i < 3u; i++) {
        for (var j = 0u; j < 3u; j++) {
            out.g[i][j] = kappa * gl[3u * i + j];
        }
    }
    if hess {
        for (var p = 0u; p < 9u; p++) {
            for (var q = 0u; q < 9u; q++) {
                let pi = p / 3u;
                let pj = p % 3u;
                let qi = q / 3u;
                let qj = q % 3u;
                var e = real(0.0);
                for (var i = 0u; i < 3u; i++) {
                    for (var j = 0u; j < 3u; j++) {
                        e += c[i][j] * eps3(i, pi, qi) * eps3(j, pj, qj);
                    }
                }
                var dtd = real(0.0);
                for (var b = 0u; b < 9u; b++) {
                    dtd += d2[b][p] * d2[b][q];
                }
                let hc = real(2.0) * (dtd + e);
                var ha = real(0.0);
                if p == q {
                    ha = real(2.0);
                }
                let hl = real(0.5) * (ha / a - real(4.0) * sf[p] * sf[q] / (a * a))
                    + real(0.5) * (hc / cc - gc[p] * gc[q] / (cc * cc)) - ((x.c1 * d2[p][q] + x.c2 * cf[p] * cf[q]) / d - x.c1 * x.c1 * cf[p] * cf[q] / (d * d));
                out.h[p][q] = kappa * (hl + gl[p] * gl[q]);
            }
        }
    }
    out.v = kappa;
    return out;
}
