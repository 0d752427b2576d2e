//! The distorted prism and hexahedral boxes of the reference-Jacobian rezoning
//! paper (Example 1): a smooth quasi-uniform mesh with "some long-wave-length
//! distortion mixed with a short-wave-length noise".
//!
//! The paper gives no formulas, so the distortion here is ours:
//!
//! * long wave, on the unit cube `u in [0, 1]^3`, for each axis `i` (with
//!   `j = i + 1 mod 3`):
//!   `x_i = u_i + A sin(pi u_i) sin(2 pi u_j)`, `A = 0.06` (0.6 cell widths on
//!   the 10-cell box). The displacement along an axis vanishes on the two faces
//!   normal to it, so the box keeps its shape; its gradient is at most
//!   `2 pi A = 0.38`, which keeps the map orientation preserving.
//! * short wave: every free (non-skin) vertex then moves by [`perturb`] with
//!   `Random { alpha: 0.5 }`: a uniform random vector in `[-1, 1]^3` times 0.5
//!   times its mean edge length, in a seeded random order, each move halved
//!   until no incident element has a non-positive corner determinant.
//!
//! The amplitudes are tuned to the paper's original prism mesh (shape quality
//! avg 2.1, max 378 in its condition-number measure): the distorted prism
//! mesh has a mean inverse mean ratio of about 1.9 and a worst element in the
//! hundreds, while most elements stay good.
//!
//! Skin vertices keep the long-wave position only: the solver fixes them.

use super::grid::{cell_corners, hex_box};
use super::perturb::{PerturbOptions, Perturbation, perturb};
use crate::mesh::{ElementKind, Mesh};
use crate::metric::inverted_elements;

/// Long-wave amplitude on the unit cube.
pub const LONG_WAVE_AMPLITUDE: f64 = 0.06;
/// Short-wave noise, relative to each vertex's mean edge length.
pub const NOISE_ALPHA: f64 = 0.5;

/// Cells per axis of the paper's prism mesh: 11^3 = 1331 nodes.
const PRISM_CELLS: usize = 10;

/// The 1331-node, 2000-prism mesh of the unit cube: 11 x 11 x 11 nodes, each
/// 10 x 10 layer of squares split into 200 triangles (diagonal from lower-left
/// to upper-right), extruded through 10 layers along z. Vertices are numbered
/// x fastest, then y, then z. With `distorted`, the long-wave distortion and
/// seeded noise of the module doc are applied; without, `seed` is unused and
/// the mesh is the undistorted box (every prism a right prism).
pub fn prism_mesh(distorted: bool, seed: u64) -> Mesh {
    let n = PRISM_CELLS;
    let mut mesh = Mesh::new(hex_box(n, n, n, [1.0; 3]).points);
    let layer = ((n + 1) * (n + 1)) as u32;
    for k in 0..n {
        let base = layer * k as u32;
        for j in 0..n {
            for i in 0..n {
                let [a, b, c, d] = cell_corners(n, i, j).map(|v| v + base);
                for tri in [[a, b, c], [a, c, d]] {
                    let top = tri.map(|v| v + layer);
                    mesh.push_element(ElementKind::Prism, &[tri[0], tri[1], tri[2], top[0], top[1], top[2]]);
                }
            }
        }
    }
    if distorted {
        distort(&mut mesh, seed);
    }
    mesh
}

/// A unit cube of `n^3` hexahedra ([`hex_box`]) with the long-wave distortion
/// and seeded noise of the module doc.
///
/// # Panics
/// If `n` is zero.
pub fn distorted_hex_box(n: usize, seed: u64) -> Mesh {
    let mut mesh = hex_box(n, n, n, [1.0; 3]);
    distort(&mut mesh, seed);
    mesh
}

/// Applies the long wave (halving its amplitude while any element inverts,
/// which only a very coarse box can need) and then the noise.
fn distort(mesh: &mut Mesh, seed: u64) {
    let original = mesh.points.clone();
    let mut amplitude = LONG_WAVE_AMPLITUDE;
    loop {
        mesh.points = original.iter().map(|&u| long_wave(u, amplitude)).collect();
        if inverted_elements(mesh, &mesh.points).is_empty() {
            break;
        }
        amplitude *= 0.5;
    }
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: NOISE_ALPHA },
        fraction: 1.0,
        seed,
    };
    // only fails on an invalid or inverted mesh, which the loop above rules out
    perturb(mesh, &opts).expect("the long-wave mesh is valid and not inverted");
}

fn long_wave(u: [f64; 3], amplitude: f64) -> [f64; 3] {
    use std::f64::consts::PI;
    std::array::from_fn(|i| {
        let j = (i + 1) % 3;
        u[i] + amplitude * (PI * u[i]).sin() * (2.0 * PI * u[j]).sin()
    })
}
