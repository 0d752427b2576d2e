// Target-matrix shape+size |S - I|^2: gradient 2 (S - I), Hessian 2 I.
// CPU twin: `smetric::tmp`.

#import smetric

fn tmp(n: u32, s: mat3x3<real>) -> MetricEval {
    var out: MetricEval;
    var v = real(0.0);
    for (var i = 0u; i < n; i++) {
        for (var j = 0u; j < n; j++) {
            var e = s[i][j];
            if i == j {
                e -= real(1.0);
            }
            v += e * e;
            out.g[i][j] = real(2.0) * e;
            out.h[3u * i + j][3u * i + j] = real(2.0);
        }
    }
    out.v = v;
    return out;
}
