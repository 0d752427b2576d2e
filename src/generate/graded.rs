//! Graded tetrahedral boxes for the element-size heterogeneity study of the
//! Newton vs coordinate descent paper (its Table 3: GRUMMP meshes of a unit
//! cube clustered toward one corner, element volume max:min from 5.5e3 to
//! 7.2e7, shape quality close to the uniform meshes).

use super::box_mesh::tet_box;
use crate::mesh::Mesh;

/// Largest grading exponent tried; far beyond any ratio an f64 mesh can hold.
const MAX_EXPONENT: f64 = 64.0;
const BISECTIONS: usize = 100;

/// A unit cube of `n^3` cells split into `6 n^3` tets ([`tet_box`]), whose
/// vertices are pulled toward the corner (0, 0, 0) so that the element volume
/// max:min is `ratio` (to about 1e-9 relative).
///
/// The map is radial in the max norm: `x -> x s^(p-1)`, `s = max(x, y, z)`.
/// It keeps the cube and each shell `s = const` (a set of cube faces), shrinks
/// the shell at `s` uniformly by `s^(p-1)` and spaces the shells by
/// `p s^(p-1)`, so cells stay within aspect `p` of the cube cells instead of
/// becoming needles as a per-axis grading would (whose worst cells have
/// aspect `ratio^(1/3)`, 215 for 1e7); the paper's graded meshes have
/// ordinary shapes. The Jacobian determinant is `s^(2p-2) p s^(p-1) > 0`
/// away from the corner, and the corner cell is only scaled, so no tet
/// inverts. The exponent `p >= 1` is found by bisection on the measured
/// ratio, which grows monotonically with `p`; it is about
/// `1 + log(ratio / p) / (3 log n)`.
///
/// # Panics
/// If `n` is zero, or `ratio` is below 1, not finite, or beyond what
/// `p = 64` reaches.
pub fn graded_tet_box(n: usize, ratio: f64) -> Mesh {
    graded_by(n, ratio, grade)
}

/// [`graded_tet_box`]'s anisotropic sibling: the same cube and volume
/// ratio, graded along z alone (`z -> z^p`) toward the wall z = 0, so the
/// cells near the wall are flat, of aspect up to about `ratio`: the layered
/// anisotropy input targets keep and the ideal objective flattens out.
///
/// # Panics
/// As [`graded_tet_box`].
pub fn graded_tet_box_aniso(n: usize, ratio: f64) -> Mesh {
    graded_by(n, ratio, |x, p| [x[0], x[1], x[2].powf(p)])
}

fn graded_by(n: usize, ratio: f64, grade: fn([f64; 3], f64) -> [f64; 3]) -> Mesh {
    assert!(n > 0, "graded_tet_box needs at least one cell per axis");
    assert!(
        ratio.is_finite() && ratio >= 1.0,
        "graded_tet_box needs a finite volume ratio >= 1, got {ratio}"
    );
    let mut mesh = tet_box(n, n, n, [1.0; 3]);
    let base = std::mem::take(&mut mesh.points);
    let target = ratio.ln();
    let log_ratio = |p: f64, mesh: &mut Mesh| {
        mesh.points = base.iter().map(|&x| grade(x, p)).collect();
        volume_log_ratio(mesh)
    };
    let (mut lo, mut hi) = (1.0, 2.0);
    while log_ratio(hi, &mut mesh) < target {
        lo = hi;
        hi *= 2.0;
        assert!(
            hi <= MAX_EXPONENT,
            "graded_tet_box cannot reach a volume ratio of {ratio} with {n} cells"
        );
    }
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (lo + hi);
        if log_ratio(mid, &mut mesh) < target {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi {
            break;
        }
    }
    mesh.points = base.iter().map(|&x| grade(x, 0.5 * (lo + hi))).collect();
    mesh
}

fn grade(x: [f64; 3], p: f64) -> [f64; 3] {
    let s = x[0].max(x[1]).max(x[2]);
    if s == 0.0 {
        return x;
    }
    let scale = s.powf(p - 1.0);
    x.map(|c| c * scale)
}

/// ln(max volume / min volume) over the tets of `mesh`.
pub(crate) fn volume_log_ratio(mesh: &Mesh) -> f64 {
    let (mut min, mut max) = (f64::INFINITY, 0.0f64);
    for e in 0..mesh.num_elements() {
        let v = tet_volume(mesh, e);
        min = min.min(v);
        max = max.max(v);
    }
    (max / min).ln()
}

pub(crate) fn tet_volume(mesh: &Mesh, e: usize) -> f64 {
    let vs = mesh.element(e);
    let o = mesh.points[vs[0] as usize];
    let d = |k: usize| {
        let p = mesh.points[vs[k] as usize];
        [p[0] - o[0], p[1] - o[1], p[2] - o[2]]
    };
    let (a, b, c) = (d(1), d(2), d(3));
    (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0
}
