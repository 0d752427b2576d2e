//! Corner-based inverse mean ratio for every element kind (value only): each
//! corner's edge matrix A is mapped by the ideal corner's W^-1, and the element
//! value is the mean of the corners' eta = |S|^2 / (n det(S)^(2/n)).

use super::mat3::{self, Mat3, Vec3, sub};
use crate::mesh::ElementKind;

/// Upper-triangular ideal corner matrix W for each kind (columns are the ideal edges).
pub fn ideal_corner(kind: ElementKind) -> Mat3 {
    let h = 3f64.sqrt() / 2.0;
    match kind {
        ElementKind::Triangle => [[1.0, 0.5, 0.0], [0.0, h, 0.0], [0.0, 0.0, 1.0]],
        // a polyhedron corner's ideal is the cube's (octant) corner, as in the
        // reference-Jacobian rezoning paper: three orthogonal unit edges
        ElementKind::Quadrilateral | ElementKind::Hexahedron | ElementKind::Polyhedron => {
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        }
        ElementKind::Tetrahedron => [
            [1.0, 0.5, 0.5],
            [0.0, h, 3f64.sqrt() / 6.0],
            [0.0, 0.0, (2.0f64 / 3.0).sqrt()],
        ],
        ElementKind::Prism => [[1.0, 0.5, 0.0], [0.0, h, 0.0], [0.0, 0.0, 1.0]],
    }
}

/// Inverse mean ratio of one corner matrix `a` (columns = edges) in dimension `n`.
pub fn corner_eta(a: &Mat3, winv: &Mat3, n: usize) -> Option<f64> {
    let mut s = [[0.0; 3]; 3];
    for i in 0..n {
        for j in 0..n {
            s[i][j] = (0..n).map(|k| a[i][k] * winv[k][j]).sum();
        }
    }
    let (d, f) = if n == 2 {
        (
            s[0][0] * s[1][1] - s[0][1] * s[1][0],
            s[0][0].powi(2) + s[0][1].powi(2) + s[1][0].powi(2) + s[1][1].powi(2),
        )
    } else {
        (mat3::det(&s), mat3::frobenius_sq(&s))
    };
    if d <= 0.0 || !d.is_finite() {
        return None;
    }
    let eta = if n == 2 {
        f / (2.0 * d)
    } else {
        f * super::inv_cbrt::inv_cbrt_sq(d) / 3.0
    };
    eta.is_finite().then_some(eta)
}

/// Element inverse mean ratio (mean over corners); `None` when any corner is
/// inverted or degenerate.
pub fn element_eta(kind: ElementKind, x: &[Vec3]) -> Option<f64> {
    corners_eta(kind, kind.optimised_corners(), x)
}

/// Mean inverse mean ratio over `corners` (local indices into `x`) of an
/// element of `kind` (a polyhedron's corners are per element).
pub fn corners_eta(kind: ElementKind, corners: &[[usize; 4]], x: &[Vec3]) -> Option<f64> {
    let n = kind.dim();
    let winv = mat3::upper_inverse(&ideal_corner(kind));
    let mut sum = 0.0;
    for c in corners {
        let mut a = [[0.0; 3]; 3];
        for (col, &nb) in c[1..=n].iter().enumerate() {
            let e = sub(&x[nb], &x[c[0]]);
            for (row, v) in e.iter().enumerate().take(n) {
                a[row][col] = *v;
            }
        }
        sum += corner_eta(&a, &winv, n)?;
    }
    Some(sum / corners.len() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::TetShape;

    #[test]
    fn ideal_elements_have_eta_one() {
        let h = 3f64.sqrt() / 2.0;
        let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, h, 0.0]];
        let quad = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        let mut hex = [[0.0; 3]; 8];
        for (i, p) in hex.iter_mut().enumerate() {
            *p = [quad[i % 4][0], quad[i % 4][1], (i / 4) as f64];
        }
        let mut prism = [[0.0; 3]; 6];
        for (i, p) in prism.iter_mut().enumerate() {
            *p = [tri[i % 3][0], tri[i % 3][1], (i / 3) as f64];
        }
        for (kind, x) in [
            (ElementKind::Triangle, &tri[..]),
            (ElementKind::Quadrilateral, &quad[..]),
            (ElementKind::Hexahedron, &hex[..]),
            (ElementKind::Prism, &prism[..]),
        ] {
            let eta = element_eta(kind, x).unwrap();
            assert!((eta - 1.0).abs() < 1e-14, "{kind}: {eta}");
        }
    }

    #[test]
    fn tet_value_matches_qr_form() {
        let x = [[0.1, 0.0, 0.2], [1.0, 0.1, 0.0], [0.3, 0.9, 0.1], [0.2, 0.3, 0.7]];
        let a = element_eta(ElementKind::Tetrahedron, &x).unwrap();
        let b = TetShape::equilateral().value(&x).unwrap();
        assert!((a - b).abs() < 1e-13 * b);
    }
}
