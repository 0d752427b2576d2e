// Sliding-boundary constraints (CPU twin: backend/cpu/project_boundary.rs,
// problem/boundary.rs). A kernel importing this declares
// `slide_real: array<real>`: the projector of every vertex (9 reals, row
// major), then the primitives (9 reals: a, b, c; a segment is a, b, b); and
// `slide_idx: array<u32>`: the vertex count nv, the candidate offsets (nv + 1)
// and the candidates. A vertex without candidates does not slide.

#import mat3

fn slides(v: u32) -> bool {
    return slide_idx[1u + v] != slide_idx[2u + v];
}

fn projector(v: u32) -> mat3x3<real> {
    let o = 9u * v;
    return mat3x3<real>(
        vec3<real>(slide_real[o], slide_real[o + 1u], slide_real[o + 2u]),
        vec3<real>(slide_real[o + 3u], slide_real[o + 4u], slide_real[o + 5u]),
        vec3<real>(slide_real[o + 6u], slide_real[o + 7u], slide_real[o + 8u]),
    );
}

fn prim_point(prim: u32, k: u32) -> vec3<real> {
    let o = 9u * (slide_idx[0u] + prim) + 3u * k;
    return vec3<real>(slide_real[o], slide_real[o + 1u], slide_real[o + 2u]);
}

fn sub3(a: vec3<real>, b: vec3<real>) -> vec3<real> {
    return vec3<real>(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

fn lerp3(a: vec3<real>, d: vec3<real>, t: real) -> vec3<real> {
    return vec3<real>(a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2]);
}

fn closest_on_segment(p: vec3<real>, a: vec3<real>, b: vec3<real>) -> vec3<real> {
    let ab = sub3(b, a);
    let len2 = dot3(ab, ab);
    if !(len2 > real(0.0)) {
        return a;
    }
    let t = clamp(dot3(sub3(p, a), ab) / len2, real(0.0), real(1.0));
    return lerp3(a, ab, t);
}

// Ericson's closest point on a triangle, branch for branch as on the CPU.
fn closest_on_triangle(p: vec3<real>, a: vec3<real>, b: vec3<real>, c: vec3<real>) -> vec3<real> {
    if all(b == c) {
        return closest_on_segment(p, a, b);
    }
    let ab = sub3(b, a);
    let ac = sub3(c, a);
    let ap = sub3(p, a);
    let d1 = dot3(ab, ap);
    let d2 = dot3(ac, ap);
    if d1 <= real(0.0) && d2 <= real(0.0) {
        return a;
    }
    let bp = sub3(p, b);
    let d3 = dot3(ab, bp);
    let d4 = dot3(ac, bp);
    if d3 >= real(0.0) && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= real(0.0) && d1 >= real(0.0) && d3 <= real(0.0) {
        return lerp3(a, ab, d1 / (d1 - d3));
    }
    let cp = sub3(p, c);
    let d5 = dot3(ab, cp);
    let d6 = dot3(ac, cp);
    if d6 >= real(0.0) && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= real(0.0) && d2 >= real(0.0) && d6 <= real(0.0) {
        return lerp3(a, ac, d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= real(0.0) && (d4 - d3) >= real(0.0) && (d5 - d6) >= real(0.0) {
        return lerp3(b, sub3(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = real(1.0) / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    return vec3<real>(
        a[0] + ab[0] * v + ac[0] * w,
        a[1] + ab[1] * v + ac[1] * w,
        a[2] + ab[2] * v + ac[2] * w,
    );
}

// The closest point to p over the candidates of v (the first on ties).
fn project_vertex(v: u32, p: vec3<real>) -> vec3<real> {
    let nv = slide_idx[0u];
    var best = p;
    var best_d = REAL_MAX;
    var first = true;
    for (var it = slide_idx[1u + v]; it < slide_idx[2u + v]; it++) {
        let prim = slide_idx[nv + 2u + it];
        let q = closest_on_triangle(p, prim_point(prim, 0u), prim_point(prim, 1u), prim_point(prim, 2u));
        let e = sub3(q, p);
        let d = dot3(e, e);
        if first || d < best_d {
            best_d = d;
            best = q;
            first = false;
        }
    }
    return best;
}

// P g and P H P + (I - P): the Newton system of a vertex in its tangent space.
fn mul3x3(a: mat3x3<real>, b: mat3x3<real>) -> mat3x3<real> {
    var m = mat3x3<real>();
    for (var i = 0; i < 3; i++) {
        for (var j = 0; j < 3; j++) {
            m[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    return m;
}

fn constrain_hessian(p: mat3x3<real>, h: mat3x3<real>) -> mat3x3<real> {
    var out = mul3x3(p, mul3x3(h, p));
    for (var i = 0; i < 3; i++) {
        for (var j = 0; j < 3; j++) {
            var e = real(0.0);
            if i == j {
                e = real(1.0);
            }
            out[i][j] += e - p[i][j];
        }
    }
    return out;
}
