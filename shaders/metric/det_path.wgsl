// Where a corner inverts along a straight move: det(S0 + t E) is a
// polynomial of degree n in t, so its first root on (0, 1] is found from
// its coefficients. CPU twin: src/metric/det_path.rs (same names, same sum
// orders); REAL_MAX stands for the CPU's +inf.

#import mat3

// (c0, c1, c2, c3) of det(A + t B), the leading 2x2 blocks when dim is 2
fn det_coefficients(a: mat3x3<real>, b: mat3x3<real>, dim: u32) -> vec4<real> {
    if dim == 2u {
        let c0 = a[0][0] * a[1][1] - a[0][1] * a[1][0];
        let c1 = a[0][0] * b[1][1] + b[0][0] * a[1][1] - a[0][1] * b[1][0] - b[0][1] * a[1][0];
        let c2 = b[0][0] * b[1][1] - b[0][1] * b[1][0];
        return vec4<real>(c0, c1, c2, real(0.0));
    }
    // tr(adj(X) Y) = the Frobenius product of X's cofactors with Y
    return vec4<real>(det3(a), frob_dot(cofactor3(a), b), frob_dot(cofactor3(b), a), det3(b));
}

fn det_poly(c: vec4<real>, t: real) -> real {
    return c[0] + t * (c[1] + t * (c[2] + t * c[3]));
}

// A root of the monotone polynomial on (lo, hi] with p(lo) > 0 >= p(hi):
// Illinois false position, as on the CPU
fn bracketed_root(c: vec4<real>, lo_in: real, hi_in: real) -> real {
    var lo = lo_in;
    var hi = hi_in;
    var flo = det_poly(c, lo);
    var fhi = det_poly(c, hi);
    var side = 0;
    let tol = real(1e-12) * (hi - lo);
    for (var it = 0u; it < 100u; it++) {
        if hi - lo <= tol || fhi == real(0.0) {
            break;
        }
        var t = (lo * fhi - hi * flo) / (fhi - flo);
        if !(t > lo && t < hi) {
            t = real(0.5) * (lo + hi);
        }
        let ft = det_poly(c, t);
        if ft > real(0.0) {
            lo = t;
            flo = ft;
            if side == -1 {
                fhi *= real(0.5);
            }
            side = -1;
        } else {
            hi = t;
            fhi = ft;
            if side == 1 {
                flo *= real(0.5);
            }
            side = 1;
        }
    }
    return hi;
}

// (c0, c1, c2, 0) of a surface corner's area facing its normal n along
// A + t B: n . ((a0 + t b0) x (a1 + t b1)) for the columns a_j, b_j
fn facing_coefficients(a: mat3x3<real>, b: mat3x3<real>, n: vec3<real>) -> vec4<real> {
    let a0 = vec3<real>(a[0][0], a[1][0], a[2][0]);
    let a1 = vec3<real>(a[0][1], a[1][1], a[2][1]);
    let b0 = vec3<real>(b[0][0], b[1][0], b[2][0]);
    let b1 = vec3<real>(b[0][1], b[1][1], b[2][1]);
    let c1 = dot3(cross3(a0, b1), n) + dot3(cross3(b0, a1), n);
    return vec4<real>(dot3(cross3(a0, a1), n), c1, dot3(cross3(b0, b1), n), real(0.0));
}

// The smallest t in (0, 1] with det(A + t B) <= 0; REAL_MAX when there is
// none; 0 when det A <= 0 already
fn first_inversion(a: mat3x3<real>, b: mat3x3<real>, dim: u32) -> real {
    return first_root(det_coefficients(a, b, dim));
}

// The smallest t in (0, 1] at which the cubic `c` is not positive
fn first_root(c: vec4<real>) -> real {
    if !(c[0] > real(0.0)) {
        return real(0.0);
    }
    if c[1] >= real(0.0) && c[2] >= real(0.0) && c[3] >= real(0.0) {
        return REAL_MAX;
    }
    // monotone pieces between the critical points in (0, 1)
    var cuts = array<real, 3>(real(1.0), real(1.0), real(1.0));
    var n = 0u;
    let qa = real(3.0) * c[3];
    let qb = real(2.0) * c[2];
    let qc = c[1];
    if qa != real(0.0) {
        let disc = qb * qb - real(4.0) * qa * qc;
        if disc >= real(0.0) {
            let r = sqrt(disc);
            var sr = r;
            if qb < real(0.0) {
                sr = -r;
            }
            let q = real(-0.5) * (qb + sr);
            let t0 = q / qa;
            if t0 > real(0.0) && t0 < real(1.0) {
                cuts[n] = t0;
                n += 1u;
            }
            if q != real(0.0) {
                let t1 = qc / q;
                if t1 > real(0.0) && t1 < real(1.0) {
                    cuts[n] = t1;
                    n += 1u;
                }
            }
        }
    } else if qb != real(0.0) {
        let t = -qc / qb;
        if t > real(0.0) && t < real(1.0) {
            cuts[n] = t;
            n += 1u;
        }
    }
    if n == 2u && cuts[1] < cuts[0] {
        let s = cuts[0];
        cuts[0] = cuts[1];
        cuts[1] = s;
    }
    var lo = real(0.0);
    for (var k = 0u; k <= n; k++) {
        let hi = cuts[k];
        if det_poly(c, hi) <= real(0.0) {
            return bracketed_root(c, lo, hi);
        }
        lo = hi;
    }
    return REAL_MAX;
}
