//! 3x3 matrix helpers, row-major `m[row][col]`.

/// A point or vector in 3D.
pub type Vec3 = [f64; 3];
/// A 3x3 matrix, row-major `m[row][col]`.
pub type Mat3 = [[f64; 3]; 3];

/// Determinant.
pub fn det(m: &Mat3) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Cofactor matrix: `cof[i][j] = d det / d m[i][j]`.
pub fn cofactor(m: &Mat3) -> Mat3 {
    [
        [
            m[1][1] * m[2][2] - m[1][2] * m[2][1],
            m[1][2] * m[2][0] - m[1][0] * m[2][2],
            m[1][0] * m[2][1] - m[1][1] * m[2][0],
        ],
        [
            m[0][2] * m[2][1] - m[0][1] * m[2][2],
            m[0][0] * m[2][2] - m[0][2] * m[2][0],
            m[0][1] * m[2][0] - m[0][0] * m[2][1],
        ],
        [
            m[0][1] * m[1][2] - m[0][2] * m[1][1],
            m[0][2] * m[1][0] - m[0][0] * m[1][2],
            m[0][0] * m[1][1] - m[0][1] * m[1][0],
        ],
    ]
}

/// Transpose.
pub fn transpose(m: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|q| m[q][i]))
}

/// sum_ij a[i][j] b[i][j] in row order (CPU twin of WGSL `frob_dot`).
pub fn frob_dot(a: &Mat3, b: &Mat3) -> f64 {
    a.iter().flatten().zip(b.iter().flatten()).map(|(x, y)| x * y).sum()
}

/// Squared Frobenius norm: the sum of the squared entries.
pub fn frobenius_sq(m: &Mat3) -> f64 {
    m.iter().flatten().map(|v| v * v).sum()
}

/// Matrix-vector product m v.
pub fn mul_vec(m: &Mat3, v: &Vec3) -> Vec3 {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// Dot product.
pub fn dot(a: &Vec3, b: &Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// a / |a|, or a itself when it is zero.
pub fn unit(a: Vec3) -> Vec3 {
    let n = dot(&a, &a).sqrt();
    if n > 0.0 { a.map(|c| c / n) } else { a }
}

/// Difference a - b.
pub fn sub(a: &Vec3, b: &Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Inverse of an upper-triangular matrix with a positive diagonal.
pub fn upper_inverse(r: &Mat3) -> Mat3 {
    let mut x = [[0.0; 3]; 3];
    for i in 0..3 {
        x[i][i] = 1.0 / r[i][i];
    }
    x[0][1] = -r[0][1] * x[1][1] / r[0][0];
    x[1][2] = -r[1][2] * x[2][2] / r[1][1];
    x[0][2] = -(r[0][1] * x[1][2] + r[0][2] * x[2][2]) / r[0][0];
    x
}

/// Solves `h d = rhs` for a symmetric positive definite `h` by Cholesky;
/// `None` when `h` is not (numerically) positive definite.
pub fn cholesky_solve(h: &Mat3, rhs: &Vec3) -> Option<Vec3> {
    let l00 = h[0][0];
    if l00.is_nan() || l00 <= 0.0 {
        return None;
    }
    let l00 = l00.sqrt();
    let l10 = h[1][0] / l00;
    let l20 = h[2][0] / l00;
    let d11 = h[1][1] - l10 * l10;
    if d11.is_nan() || d11 <= 0.0 {
        return None;
    }
    let l11 = d11.sqrt();
    let l21 = (h[2][1] - l20 * l10) / l11;
    let d22 = h[2][2] - l20 * l20 - l21 * l21;
    if d22.is_nan() || d22 <= 0.0 {
        return None;
    }
    let l22 = d22.sqrt();
    let y0 = rhs[0] / l00;
    let y1 = (rhs[1] - l10 * y0) / l11;
    let y2 = (rhs[2] - l20 * y0 - l21 * y1) / l22;
    let x2 = y2 / l22;
    let x1 = (y1 - l21 * x2) / l11;
    let x0 = (y0 - l10 * x1 - l20 * x2) / l00;
    Some([x0, x1, x2])
}

/// General inverse through the adjugate; `None` for a singular matrix.
/// The Newton step -h^-1 g on a vertex block, or a scaled steepest descent
/// step where Cholesky fails (the block is positive definite for the mean
/// ratio; rounding may say otherwise). Twin of `newton_direction` in
/// `shaders/common/mat3.wgsl`.
pub fn newton_direction(g: &Vec3, h: &Mat3) -> Vec3 {
    let neg_g = [-g[0], -g[1], -g[2]];
    cholesky_solve(h, &neg_g).unwrap_or_else(|| {
        let tr = h[0][0] + h[1][1] + h[2][2];
        let s = if tr > 0.0 { 3.0 / tr } else { 1.0 };
        neg_g.map(|c| c * s)
    })
}

/// The inverse; `None` when the determinant is 0 or not finite.
pub fn inverse(m: &Mat3) -> Option<Mat3> {
    let d = det(m);
    if d == 0.0 || !d.is_finite() {
        return None;
    }
    let c = cofactor(m);
    let mut inv = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            inv[i][j] = c[j][i] / d;
        }
    }
    Some(inv)
}

/// The cross product a × b.
pub fn cross(a: &Vec3, b: &Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_solves_spd_and_rejects_indefinite() {
        let h = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]];
        let b = [1.0, -2.0, 0.5];
        let x = cholesky_solve(&h, &b).unwrap();
        let r = mul_vec(&h, &x);
        for i in 0..3 {
            assert!((r[i] - b[i]).abs() < 1e-14);
        }
        let bad = [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert!(cholesky_solve(&bad, &b).is_none());
    }

    #[test]
    fn upper_inverse_inverts() {
        let r = [[2.0, 0.3, -0.7], [0.0, 1.5, 0.4], [0.0, 0.0, 0.8]];
        let x = upper_inverse(&r);
        for i in 0..3 {
            for j in 0..3 {
                let v: f64 = (0..3).map(|k| r[i][k] * x[k][j]).sum();
                assert!((v - if i == j { 1.0 } else { 0.0 }).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn cofactor_is_derivative_of_det() {
        let m = [[1.0, 0.2, -0.3], [0.4, 1.1, 0.5], [-0.2, 0.3, 0.9]];
        let c = cofactor(&m);
        for i in 0..3 {
            for j in 0..3 {
                let h = 1e-6;
                let mut p = m;
                p[i][j] += h;
                let mut q = m;
                q[i][j] -= h;
                assert!(((det(&p) - det(&q)) / (2.0 * h) - c[i][j]).abs() < 1e-9);
            }
        }
    }
}
