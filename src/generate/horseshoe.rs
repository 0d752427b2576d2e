//! The 2D horseshoe test family of the vertex-reordering paper (section 5,
//! Table 1): a regular mesh of a logical domain is mapped analytically onto a
//! semi-annulus (the reference mesh, whose shapes are the targets) and onto a
//! horseshoe (the mesh to optimise); both share the connectivity and the
//! vertex order (row by row, as the paper's Figure 4).
//!
//! The paper names the meshes and shows them in figures, but does not give
//! the mappings, so the following are ours. Logical coordinates are
//! `(xi, eta)` in the unit square, `xi` along the bend, `eta` across it
//! (`eta = 0` on the inner wall); `r = 1 + eta` in both images.
//!
//! * Reference, the semi-annulus `1 <= r <= 2`, `y >= 0`: polar with uniform
//!   angle, `theta = pi (1 - xi)`, point `r (cos theta, sin theta)`.
//! * Horseshoe: the same half annulus for the bend plus two straight legs of
//!   length [`LEG`] = 2 hanging down from its ends (a U of width 1). The
//!   centre line (radius 1.5) is parametrised by arc length, `s = xi T`,
//!   `T = 2 LEG + 1.5 pi`, and `r` is the distance from the U's centre on
//!   the bend, the distance from the symmetry axis on the legs: left leg
//!   `(-r, s - LEG)`, bend `r (cos phi, sin phi)` with
//!   `phi = pi - (s - LEG) / 1.5`, right leg `(r, -(s - LEG - 1.5 pi))`.
//!   The map is C1 and orientation preserving, and differs from the
//!   reference by a stretch along `xi` (1.85 on the centre line), with the
//!   leg cells rectangles instead of annular sectors.
//!
//! Mesh types (reference-space sizes at the centre radius 1.5):
//!
//! * `SqI`: quads, cells 1:1 (arc length : radial width).
//! * `SqII`: quads, cells 5:1, long along the bend.
//! * `SqIV`: the `SqII` grid with its rows clustered toward the inner wall by a
//!   geometric progression whose outermost row spacing is [`BIAS`] = 5 times the
//!   innermost: row spacings run from 0.40 to 2.0 times `SqII`'s, so the
//!   cells range from about 12:1 (innermost) to 2.5:1 (outermost).
//! * `UtI`: triangles on a trapezoidal logical domain: row `j` (at `eta_j`)
//!   has `m_j` segments with `m_j` proportional to its radius
//!   `r_j = 1 + eta_j` (`m_j = round(pi r_j / e)`), so the logical domain is
//!   the trapezoid `0 <= xi <= r(eta)`, squeezed back onto the square by
//!   dividing `xi` by the row width. Rows are `sqrt(3)/2 e` apart so the
//!   reference triangles are nearly equilateral. Adjacent rows are zipped
//!   together, each step advancing along the row whose next vertex comes
//!   first in `xi` after a pseudo-random shift of up to [`ZIP_JITTER`] of a
//!   segment (a fixed-seed ChaCha stream, so the mesh is deterministic). Any
//!   zip of two straight rows gives counter-clockwise triangles, and the shift
//!   turns the otherwise regular diagonals into an irregular pattern with
//!   vertex degrees from 4 to 8, like an unstructured generator's.
//! * `UtIV`: the `UtI` construction with rows clustered as in `SqIV`.
//!
//! Grid sizes are chosen so the free (non-skin) vertex count is as close to
//! the requested one as the integer counts allow (within about 1% for a few
//! thousand vertices, a fraction of a percent from 20K), with at least 8 segments
//! along the bend, so tiny targets get more free vertices than asked.

use std::str::FromStr;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::{Error, Named, Result};
use crate::mesh::{ElementKind, Mesh};

/// Inner radius of the semi-annulus and of the horseshoe's bend.
pub const R_IN: f64 = 1.0;
/// Width of the annulus (and of the legs).
pub const WIDTH: f64 = 1.0;
/// Length of each straight leg of the horseshoe.
pub const LEG: f64 = 2.0;
/// Outermost to innermost row spacing of the biased types.
pub const BIAS: f64 = 5.0;

/// Largest shift, in segments, of the zipper's comparison (see the module doc).
pub const ZIP_JITTER: f64 = 0.5;
const ZIP_SEED: u64 = 0x05ee_d0f4_ca5e;

/// Fewest segments along the bend: coarser, the straight edges cut across the
/// curved walls and elements can invert.
const MIN_ALONG: usize = 8;

const R_CENTRE: f64 = R_IN + 0.5 * WIDTH;

/// The five mesh types of the paper's Table 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum HorseshoeKind {
    /// Structured quads, 1:1 cells.
    #[cfg_attr(feature = "cli", value(name = "sqi"))]
    SqI,
    /// Structured quads, 1:5 cells.
    #[cfg_attr(feature = "cli", value(name = "sqii"))]
    SqII,
    /// Structured quads, 1:5 cells biased toward the inner wall.
    #[cfg_attr(feature = "cli", value(name = "sqiv"))]
    SqIV,
    /// Unstructured triangles on a trapezoidal logical domain.
    #[cfg_attr(feature = "cli", value(name = "uti"))]
    UtI,
    /// Unstructured triangles, biased toward the inner wall.
    #[cfg_attr(feature = "cli", value(name = "utiv"))]
    UtIV,
}

impl HorseshoeKind {
    /// Every kind.
    pub const ALL: [HorseshoeKind; 5] = [
        HorseshoeKind::SqI,
        HorseshoeKind::SqII,
        HorseshoeKind::SqIV,
        HorseshoeKind::UtI,
        HorseshoeKind::UtIV,
    ];

    /// The kind's command-line name (`sqi`, `utiv`, ...).
    pub fn name(self) -> &'static str {
        crate::error::Named::name(&self)
    }

    fn biased(self) -> bool {
        matches!(self, HorseshoeKind::SqIV | HorseshoeKind::UtIV)
    }
}

crate::error::by_name!(HorseshoeKind { SqI = "sqi", SqII = "sqii", SqIV = "sqiv", UtI = "uti", UtIV = "utiv" });

impl FromStr for HorseshoeKind {
    type Err = Error;

    /// Case-insensitive: "sqi", "sqii", "sqiv", "uti", "utiv".
    fn from_str(s: &str) -> Result<Self> {
        let s = s.trim();
        <Self as Named>::by_name(s).ok_or_else(|| Error::InvalidArgument(format!("invalid variant: {s}")))
    }
}

/// The horseshoe mesh of type `kind` with about `target_free_vertices` free
/// vertices, and its reference semi-annulus (same connectivity and vertex
/// order); see the module doc for the mappings. Planar, z = 0, every corner of
/// every element positive in both meshes.
///
/// # Panics
/// If `target_free_vertices` is zero.
pub fn horseshoe(kind: HorseshoeKind, target_free_vertices: usize) -> (Mesh, Mesh) {
    assert!(target_free_vertices > 0, "horseshoe needs at least one free vertex");
    let (logical, mut mesh) = match kind {
        HorseshoeKind::SqI | HorseshoeKind::SqII | HorseshoeKind::SqIV => {
            let aspect = if kind == HorseshoeKind::SqI { 1.0 } else { 5.0 };
            structured(target_free_vertices, aspect, kind.biased())
        }
        HorseshoeKind::UtI | HorseshoeKind::UtIV => trapezoid(target_free_vertices, kind.biased()),
    };
    mesh.points = logical.iter().map(|&(xi, eta)| horseshoe_point(xi, eta)).collect();
    let mut reference = mesh.clone();
    reference.points = logical.iter().map(|&(xi, eta)| annulus_point(xi, eta)).collect();
    (mesh, reference)
}

/// Reference map: the semi-annulus, uniform in angle and radius.
fn annulus_point(xi: f64, eta: f64) -> [f64; 3] {
    let r = R_IN + WIDTH * eta;
    let theta = std::f64::consts::PI * (1.0 - xi);
    [r * theta.cos(), r * theta.sin(), 0.0]
}

/// Mesh map: the horseshoe, arc length along its centre line.
fn horseshoe_point(xi: f64, eta: f64) -> [f64; 3] {
    let r = R_IN + WIDTH * eta;
    let bend = std::f64::consts::PI * R_CENTRE;
    let s = xi * (2.0 * LEG + bend);
    if s < LEG {
        [-r, s - LEG, 0.0]
    } else if s <= LEG + bend {
        let phi = std::f64::consts::PI - (s - LEG) / R_CENTRE;
        [r * phi.cos(), r * phi.sin(), 0.0]
    } else {
        [r, -(s - LEG - bend), 0.0]
    }
}

/// Row positions `eta_0 = 0 < ... < eta_n = 1`, uniform or geometric with the
/// last spacing [`BIAS`] times the first.
fn rows(n: usize, biased: bool) -> Vec<f64> {
    if !biased || n < 2 {
        return (0..=n).map(|j| j as f64 / n as f64).collect();
    }
    let q = BIAS.powf(1.0 / (n - 1) as f64);
    let mut eta = Vec::with_capacity(n + 1);
    let mut sum = 0.0;
    let mut h = 1.0;
    eta.push(0.0);
    for _ in 0..n {
        sum += h;
        eta.push(sum);
        h *= q;
    }
    eta.iter_mut().for_each(|e| *e /= sum);
    eta[n] = 1.0;
    eta
}

/// Logical positions and a quad mesh (points not yet mapped) of
/// `n_xi x n_eta` cells, numbered row by row.
fn structured(target: usize, aspect: f64, biased: bool) -> (Vec<(f64, f64)>, Mesh) {
    // cells along / across for the requested reference aspect at the centre radius
    let q = std::f64::consts::PI * R_CENTRE / (aspect * WIDTH);
    // rows of free vertices across; a few rows either way hardly change the
    // aspect but let the product land closer to the target
    let across = (target as f64 / q).sqrt().round() as usize;
    let along = |m: usize| ((target as f64 / m as f64).round() as usize + 1).max(MIN_ALONG) - 1;
    let m = (across.saturating_sub(2).max(1)..=across.max(1) + 2)
        .min_by_key(|&m| (m * along(m)).abs_diff(target))
        .unwrap();
    let (n_eta, n_xi) = (m + 1, along(m) + 1);
    let etas = rows(n_eta, biased);
    let mut logical = Vec::with_capacity((n_xi + 1) * (n_eta + 1));
    for &eta in &etas {
        for i in 0..=n_xi {
            logical.push((i as f64 / n_xi as f64, eta));
        }
    }
    let mut mesh = Mesh::new(Vec::new());
    for j in 0..n_eta {
        for i in 0..n_xi {
            mesh.push_element(ElementKind::Quadrilateral, &super::grid::cell_corners(n_xi, i, j));
        }
    }
    (logical, mesh)
}

/// Segment counts per row of the trapezoid for edge length `e`.
fn trapezoid_rows(e: f64, biased: bool) -> (Vec<f64>, Vec<usize>) {
    let n_eta = ((WIDTH / (0.75f64.sqrt() * e)).round() as usize).max(2);
    let etas = rows(n_eta, biased);
    let segments = etas
        .iter()
        .map(|&eta| ((std::f64::consts::PI * (R_IN + WIDTH * eta) / e).round() as usize).max(2))
        .collect();
    (etas, segments)
}

fn trapezoid_free(segments: &[usize]) -> usize {
    segments[1..segments.len() - 1].iter().map(|m| m - 1).sum()
}

/// Logical positions and a triangle mesh (points not yet mapped) of the
/// trapezoid whose free vertex count is closest to `target`.
fn trapezoid(target: usize, biased: bool) -> (Vec<(f64, f64)>, Mesh) {
    // free vertices fall as the edge length grows; bisect on ln(e)
    let count = |e: f64| trapezoid_free(&trapezoid_rows(e, biased).1);
    let coarsest = std::f64::consts::PI * R_IN / MIN_ALONG as f64;
    let (mut lo, mut hi) = (1e-4f64.ln(), coarsest.ln());
    let mut best = (usize::MAX, hi);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        let c = count(mid.exp());
        let miss = c.abs_diff(target);
        if miss < best.0 {
            best = (miss, mid);
        }
        if c > target { lo = mid } else { hi = mid }
    }
    let (etas, segments) = trapezoid_rows(best.1.exp(), biased);

    let mut start = Vec::with_capacity(segments.len());
    let mut logical = Vec::new();
    for (&eta, &m) in etas.iter().zip(&segments) {
        start.push(logical.len() as u32);
        logical.extend((0..=m).map(|k| (k as f64 / m as f64, eta)));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(ZIP_SEED);
    let mut mesh = Mesh::new(Vec::new());
    for j in 0..segments.len() - 1 {
        let (ma, mb) = (segments[j], segments[j + 1]);
        let (a, b) = (start[j], start[j + 1]);
        let (mut i, mut k) = (0, 0);
        while i < ma || k < mb {
            let shift = ZIP_JITTER * rng.random_range(-1.0..=1.0) / ma.max(mb) as f64;
            let advance_lower = k == mb || (i < ma && (i + 1) as f64 / ma as f64 + shift <= (k + 1) as f64 / mb as f64);
            let (ai, bk) = (a + i as u32, b + k as u32);
            if advance_lower {
                mesh.push_element(ElementKind::Triangle, &[ai, ai + 1, bk]);
                i += 1;
            } else {
                mesh.push_element(ElementKind::Triangle, &[ai, bk + 1, bk]);
                k += 1;
            }
        }
    }
    (logical, mesh)
}
