// Target-matrix shape+size |S - I|^2: gradient 2 (S - I), Hessian 2 I.
// CPU twin: `smetric::tmp` (S is zero past n, so only the identity needs
// the dimension).

#import smetric

fn tmp(n: u32, s: mat3x3<real>) -> MetricEval {
    var out: MetricEval;
    var e = s;
    e[0][0] -= real(1.0);
    e[1][1] -= real(1.0);
    if n == 3u {
        e[2][2] -= real(1.0);
    }
    out.v = frob_n(e, n);
    out.g = scaled3(e, real(2.0));
    out.h = shess_identity(real(2.0), n);
    return out;
}
