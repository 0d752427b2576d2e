// 3x3 helpers, CPU twin src/metric/mat3.rs. A mat3x3 holds m[i][j] = row i,
// column j (the CPU's indexing); built-in matrix products are avoided so that
// every sum runs in the CPU's order.

fn det3(m: mat3x3<real>) -> real {
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

fn cofactor3(m: mat3x3<real>) -> mat3x3<real> {
    return mat3x3<real>(
        vec3<real>(
            m[1][1] * m[2][2] - m[1][2] * m[2][1],
            m[1][2] * m[2][0] - m[1][0] * m[2][2],
            m[1][0] * m[2][1] - m[1][1] * m[2][0],
        ),
        vec3<real>(
            m[0][2] * m[2][1] - m[0][1] * m[2][2],
            m[0][0] * m[2][2] - m[0][2] * m[2][0],
            m[0][1] * m[2][0] - m[0][0] * m[2][1],
        ),
        vec3<real>(
            m[0][1] * m[1][2] - m[0][2] * m[1][1],
            m[0][2] * m[1][0] - m[0][0] * m[1][2],
            m[0][0] * m[1][1] - m[0][1] * m[1][0],
        ),
    );
}

// sum_ij a[i][j] b[i][j] in row order, unrolled (llvmpipe counts every loop
// iteration against one budget per invocation, see `shess.wgsl`).
fn frob_dot(a: mat3x3<real>, b: mat3x3<real>) -> real {
    return a[0][0] * b[0][0] + a[0][1] * b[0][1] + a[0][2] * b[0][2] + a[1][0] * b[1][0] + a[1][1] * b[1][1]
        + a[1][2] * b[1][2] + a[2][0] * b[2][0] + a[2][1] * b[2][1] + a[2][2] * b[2][2];
}

fn frobenius_sq(m: mat3x3<real>) -> real {
    return frob_dot(m, m);
}

fn mul_vec(m: mat3x3<real>, v: vec3<real>) -> vec3<real> {
    return vec3<real>(
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    );
}

fn cross3(a: vec3<real>, b: vec3<real>) -> vec3<real> {
    return vec3<real>(a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]);
}

fn dot3(a: vec3<real>, b: vec3<real>) -> real {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// `h d = rhs` by Cholesky; ok = false when h is not (numerically) positive definite.
struct CholeskySolve {
    x: vec3<real>,
    ok: bool,
}

fn cholesky_solve(h: mat3x3<real>, rhs: vec3<real>) -> CholeskySolve {
    var out = CholeskySolve(vec3<real>(real(0.0)), false);
    let a00 = h[0][0];
    if !(a00 > real(0.0)) {
        return out;
    }
    let l00 = sqrt(a00);
    let l10 = h[1][0] / l00;
    let l20 = h[2][0] / l00;
    let d11 = h[1][1] - l10 * l10;
    if !(d11 > real(0.0)) {
        return out;
    }
    let l11 = sqrt(d11);
    let l21 = (h[2][1] - l20 * l10) / l11;
    let d22 = h[2][2] - l20 * l20 - l21 * l21;
    if !(d22 > real(0.0)) {
        return out;
    }
    let l22 = sqrt(d22);
    let y0 = rhs[0] / l00;
    let y1 = (rhs[1] - l10 * y0) / l11;
    let y2 = (rhs[2] - l20 * y0 - l21 * y1) / l22;
    let x2 = y2 / l22;
    let x1 = (y1 - l21 * x2) / l11;
    let x0 = (y0 - l10 * x1 - l20 * x2) / l00;
    out.x = vec3<real>(x0, x1, x2);
    out.ok = true;
    return out;
}

// `mat3::newton_direction`: the Newton step -h^-1 g on a vertex block, or a
// scaled steepest descent step where Cholesky fails (the block is positive
// definite for the mean ratio; rounding may say otherwise).
fn newton_direction(g: vec3<real>, h: mat3x3<real>) -> vec3<real> {
    let neg_g = vec3<real>(-g[0], -g[1], -g[2]);
    let chol = cholesky_solve(h, neg_g);
    if chol.ok {
        return chol.x;
    }
    let tr = h[0][0] + h[1][1] + h[2][2];
    var s = real(1.0);
    if tr > real(0.0) {
        s = real(3.0) / tr;
    }
    return vec3<real>(neg_g[0] * s, neg_g[1] * s, neg_g[2] * s);
}
