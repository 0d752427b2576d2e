//! The distorted prism and hexahedral boxes of the reference-Jacobian rezoning
//! paper (Example 1): a smooth quasi-uniform mesh with "some long-wave-length
//! distortion mixed with a short-wave-length noise".
//!
//! The paper gives no formulas, so the distortion here is ours; it moves
//! **interior vertices only**, so the skin stays the undistorted box and the
//! undistorted grid (every prism a right prism, 1.222 in the paper's measure)
//! stays reachable with the boundary fixed:
//!
//! * long wave, on the unit cube `u in [0, 1]^3`, for each axis `i` (with
//!   `j = i + 1 mod 3`):
//!   `x_i = u_i + A sin(pi u_i) sin(2 pi u_j)`, `A = 0.04` (0.4 cell widths on
//!   the 10-cell box); its gradient is at most `2 pi A = 0.25`, which keeps
//!   the map orientation preserving.
//! * short wave: half of the interior vertices, picked at random, then move by
//!   [`perturb`] with `Random { alpha: 0.7 }`: a uniform random vector in
//!   `[-1, 1]^3` times 0.7 times its mean edge length, in a seeded random
//!   order, each move halved until no incident element has a non-positive
//!   corner determinant.
//!
//! Amplitudes and the default seed ([`PAPER_SEED`]) were picked by scanning
//! against the paper's Original column (min 1.1, avg 2.1, max 377.8; bands
//! 12.3 / 40.5 / 27.1 / 12.6 / 5.2 / 1.6 / 0.5 / 0.2 %) under the paper's
//! measure (`cn-paper`): seed 54 gives min 1.13, avg 1.99, max 398 and bands
//! 11.5 / 41.9 / 30.1 / 10.2 / 4.2 / 1.5 / 0.4 / 0.2 % (checked by a test).

use super::grid::{cell_corners, hex_box};
use super::perturb::{PerturbOptions, Perturbation, perturb};
use crate::mesh::topology::fixed_vertices;
use crate::mesh::{ElementKind, Mesh};
use crate::metric::inverted_elements;

/// Long-wave amplitude on the unit cube.
pub const LONG_WAVE_AMPLITUDE: f64 = 0.04;
/// Short-wave noise, relative to each vertex's mean edge length.
pub const NOISE_ALPHA: f64 = 0.7;
/// Fraction of the interior vertices the noise moves.
pub const NOISE_FRACTION: f64 = 0.5;
/// The seed whose distorted prism mesh is closest to the paper's.
pub const PAPER_SEED: u64 = 54;

/// Cells per axis of the paper's prism mesh: 11^3 = 1331 nodes.
const PRISM_CELLS: usize = 10;

/// The 1331-node, 2000-prism mesh of the unit cube: 11 x 11 x 11 nodes, each
/// 10 x 10 layer of squares split into 200 triangles (diagonal from lower-left
/// to upper-right), extruded through 10 layers along z. Vertices are numbered
/// x fastest, then y, then z. With `distorted`, the long-wave distortion and
/// seeded noise of the module doc are applied; without, `seed` is unused and
/// the mesh is the undistorted box (every prism a right prism).
pub fn prism_mesh(distorted: bool, seed: u64) -> Mesh {
    let mut mesh = right_prism_mesh();
    if distorted {
        distort(&mut mesh, &Distortion::with_seed(seed));
    }
    mesh
}

/// The prism mesh with the distortion `d`.
pub fn distorted_prism_mesh(d: &Distortion) -> Mesh {
    let mut mesh = right_prism_mesh();
    distort(&mut mesh, d);
    mesh
}

/// The distortion of the module doc, with its amplitudes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Distortion {
    /// Long-wave amplitude on the unit cube.
    pub amplitude: f64,
    /// Short-wave noise, relative to each vertex's mean edge length.
    pub noise: f64,
    /// Fraction of the interior vertices the noise moves.
    pub fraction: f64,
    /// Seed of the noise.
    pub seed: u64,
}

impl Distortion {
    /// The default amplitudes with `seed`.
    pub fn with_seed(seed: u64) -> Distortion {
        Distortion {
            amplitude: LONG_WAVE_AMPLITUDE,
            noise: NOISE_ALPHA,
            fraction: NOISE_FRACTION,
            seed,
        }
    }
}

fn right_prism_mesh() -> Mesh {
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
    mesh
}

/// A unit cube of `n^3` hexahedra ([`hex_box`]) with the long-wave distortion
/// and seeded noise of the module doc.
///
/// # Panics
/// If `n` is zero.
pub fn distorted_hex_box(n: usize, seed: u64) -> Mesh {
    let mut mesh = hex_box(n, n, n, [1.0; 3]);
    distort(&mut mesh, &Distortion::with_seed(seed));
    mesh
}

/// Applies the long wave (halving its amplitude while any element inverts,
/// which only a very coarse box can need) and then the noise.
fn distort(mesh: &mut Mesh, d: &Distortion) {
    let original = mesh.points.clone();
    // only interior vertices move: the skin keeps the undistorted box
    let fixed = fixed_vertices(mesh);
    let mut amplitude = d.amplitude;
    loop {
        mesh.points = original
            .iter()
            .zip(&fixed)
            .map(|(&u, &f)| if f { u } else { long_wave(u, amplitude) })
            .collect();
        if inverted_elements(mesh, &mesh.points).is_empty() {
            break;
        }
        amplitude *= 0.5;
    }
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: d.noise },
        fraction: d.fraction,
        seed: d.seed,
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
