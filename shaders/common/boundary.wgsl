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

// The nearest candidate of v to p (`prim`, NONE when v does not slide) and
// the closest point on it (the first on ties).
struct Nearest {
    prim: u32,
    q: vec3<real>,
}

fn nearest(v: u32, p: vec3<real>) -> Nearest {
    let nv = slide_idx[0u];
    var best = Nearest(NONE, p);
    var best_d = REAL_MAX;
    var first = true;
    for (var it = slide_idx[1u + v]; it < slide_idx[2u + v]; it++) {
        let prim = slide_idx[nv + 2u + it];
        let q = closest_on_triangle(p, prim_point(prim, 0u), prim_point(prim, 1u), prim_point(prim, 2u));
        let e = sub3(q, p);
        let d = dot3(e, e);
        if first || d < best_d {
            best_d = d;
            best = Nearest(prim, q);
            first = false;
        }
    }
    return best;
}

// The closest point to p over the candidates of v, p itself if it has none.
fn project_vertex(v: u32, p: vec3<real>) -> vec3<real> {
    return nearest(v, p).q;
}

fn dist3(a: vec3<real>, b: vec3<real>) -> real {
    let d = sub3(a, b);
    return sqrt(dot3(d, d));
}

fn unit3(a: vec3<real>) -> vec3<real> {
    let n = sqrt(dot3(a, a));
    if n > real(0.0) {
        return vec3<real>(a[0] / n, a[1] / n, a[2] / n);
    }
    return a;
}

fn identity3() -> mat3x3<real> {
    return mat3x3<real>(
        vec3<real>(real(1.0), real(0.0), real(0.0)),
        vec3<real>(real(0.0), real(1.0), real(0.0)),
        vec3<real>(real(0.0), real(0.0), real(1.0)),
    );
}

// t t^T
fn line_projector(t: vec3<real>) -> mat3x3<real> {
    var m = mat3x3<real>();
    for (var i = 0; i < 3; i++) {
        for (var j = 0; j < 3; j++) {
            m[i][j] = t[i] * t[j];
        }
    }
    return m;
}

// I - n n^T
fn plane_projector(n: vec3<real>) -> mat3x3<real> {
    var m = identity3();
    for (var i = 0; i < 3; i++) {
        for (var j = 0; j < 3; j++) {
            m[i][j] -= n[i] * n[j];
        }
    }
    return m;
}

fn tri_normal(prim: u32) -> vec3<real> {
    let a = prim_point(prim, 0u);
    return unit3(cross3(sub3(prim_point(prim, 1u), a), sub3(prim_point(prim, 2u), a)));
}

fn has_point(prim: u32, p: vec3<real>) -> bool {
    return all(prim_point(prim, 0u) == p) || all(prim_point(prim, 1u) == p) || all(prim_point(prim, 2u) == p);
}

// Whether edge (e0, e1) of candidate triangle t of v is a crease: another
// candidate triangle shares it at an angle, or none shares it.
fn is_crease(v: u32, t: u32, e0: vec3<real>, e1: vec3<real>) -> bool {
    let nv = slide_idx[0u];
    let n = tri_normal(t);
    var met = false;
    for (var it = slide_idx[1u + v]; it < slide_idx[2u + v]; it++) {
        let c = slide_idx[nv + 2u + it];
        if c == t || all(prim_point(c, 1u) == prim_point(c, 2u)) {
            continue;
        }
        if has_point(c, e0) && has_point(c, e1) {
            met = true;
            let m = cross3(n, tri_normal(c));
            if dot3(m, m) > real(CREASE_SIN * CREASE_SIN) {
                return true;
            }
        }
    }
    return !met;
}

fn on_segment(p: vec3<real>, a: vec3<real>, b: vec3<real>, eps: real) -> bool {
    return dist3(closest_on_segment(p, a, b), p) <= eps;
}

// The projector of the constraint active for v at x with unconstrained
// gradient g, where the gradient mapping Proj(x - t g) leads it: zero where
// the mapping does not move, a crease's or curve segment's t t^T, otherwise
// the plane of the face it ends in (the CPU twin's comment has the why).
fn tri_length(prim: u32) -> real {
    let a = prim_point(prim, 0u);
    let b = prim_point(prim, 1u);
    let c = prim_point(prim, 2u);
    return max(max(dist3(a, b), dist3(b, c)), dist3(c, a));
}

// The candidate of v nearest to p, decided whatever the candidates' order:
// among those within eps of the nearest distance, one passing within eps of
// at, then the lowest index (CPU twin: `nearest_from`).
fn nearest_from(v: u32, p: vec3<real>, at: vec3<real>, eps: real) -> Nearest {
    let nv = slide_idx[0u];
    var near = REAL_MAX;
    for (var it = slide_idx[1u + v]; it < slide_idx[2u + v]; it++) {
        let c = slide_idx[nv + 2u + it];
        near = min(near, dist3(closest_on_triangle(p, prim_point(c, 0u), prim_point(c, 1u), prim_point(c, 2u)), p));
    }
    var best = Nearest(NONE, p);
    var best_holds = false;
    for (var it = slide_idx[1u + v]; it < slide_idx[2u + v]; it++) {
        let c = slide_idx[nv + 2u + it];
        let a = prim_point(c, 0u);
        let b = prim_point(c, 1u);
        let cc = prim_point(c, 2u);
        let q = closest_on_triangle(p, a, b, cc);
        if dist3(q, p) > near + eps {
            continue;
        }
        let holds = dist3(closest_on_triangle(at, a, b, cc), at) <= eps;
        if best.prim == NONE || (holds && !best_holds) || (holds == best_holds && c < best.prim) {
            best = Nearest(c, q);
            best_holds = holds;
        }
    }
    return best;
}

fn active_projector(v: u32, x: vec3<real>, g: vec3<real>) -> mat3x3<real> {
    if !slides(v) {
        return identity3();
    }
    let nv = slide_idx[0u];
    var len = real(0.0);
    for (var it = slide_idx[1u + v]; it < slide_idx[2u + v]; it++) {
        len = max(len, tri_length(slide_idx[nv + 2u + it]));
    }
    let q0 = project_vertex(v, x);
    let gg = dot3(g, g);
    let step = MAPPING_STEP * len;
    let eps = MAPPING_EPS * step;
    if !(gg > real(0.0)) {
        return mat3x3<real>();
    }
    let t = step / sqrt(gg);
    let n1 = nearest_from(v, vec3<real>(x[0] - t * g[0], x[1] - t * g[1], x[2] - t * g[2]), q0, eps);
    if dist3(n1.q, q0) <= eps {
        return mat3x3<real>();
    }
    let a = prim_point(n1.prim, 0u);
    let b = prim_point(n1.prim, 1u);
    let c = prim_point(n1.prim, 2u);
    if all(b == c) {
        return line_projector(unit3(sub3(b, a)));
    }
    let q1 = n1.q;
    let tri = n1.prim;
    if on_segment(q0, a, b, eps) && on_segment(q1, a, b, eps) && is_crease(v, tri, a, b) {
        return line_projector(unit3(sub3(b, a)));
    }
    if on_segment(q0, b, c, eps) && on_segment(q1, b, c, eps) && is_crease(v, tri, b, c) {
        return line_projector(unit3(sub3(c, b)));
    }
    if on_segment(q0, c, a, eps) && on_segment(q1, c, a, eps) && is_crease(v, tri, c, a) {
        return line_projector(unit3(sub3(a, c)));
    }
    return plane_projector(tri_normal(tri));
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
