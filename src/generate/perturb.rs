//! Perturbations of an (optimal) mesh for the initial-configuration study
//! (random, translational and oscillatory moves of the free vertices).

use std::fmt;
use std::str::FromStr;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::mesh::topology::{fixed_vertices, vertex_elements, vertex_neighbours};
use crate::metric::{element_min_det, inverted_elements};

/// How each selected vertex moves. `alpha` is relative to the vertex's local
/// length scale `h` = mean length of its edges, so one value means the same
/// thing on coarse and fine meshes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Perturbation {
    /// `x + alpha h r`, each coordinate of `r` uniform in [-1, 1].
    Random {
        /// Amplitude, in local edge lengths `h`.
        alpha: f64,
    },
    /// The same with `h` the vertex's shortest edge: the scale of a
    /// boundary layer's thin cells, which the mean edge overshoots.
    RandomShortest {
        /// Amplitude, in local edge lengths `h`.
        alpha: f64,
    },
    /// `x + alpha h [1, 0, 0]` (the paper's "R" shift).
    ShiftR {
        /// Amplitude, in local edge lengths `h`.
        alpha: f64,
    },
    /// `x + alpha h [1, 1, 0] / sqrt(2)` (the paper's "NE" shift, normalised
    /// so that it moves as far as `ShiftR` for the same alpha).
    ShiftNe {
        /// Amplitude, in local edge lengths `h`.
        alpha: f64,
    },
    /// `x_i + alpha h sin(omega u_i)` per coordinate, where `u_i` is `x_i`
    /// rescaled to [0, 1] over the mesh bounding box: `omega = 2 pi` is one
    /// wave across the mesh.
    Oscillatory {
        /// Amplitude, in local edge lengths `h`.
        alpha: f64,
        /// Angular wave number over the rescaled coordinate (2 pi: one wave across the mesh).
        omega: f64,
    },
}

impl Perturbation {
    /// The perturbation's amplitude alpha (in local edge lengths).
    pub fn alpha(&self) -> f64 {
        match *self {
            Perturbation::Random { alpha }
            | Perturbation::RandomShortest { alpha }
            | Perturbation::ShiftR { alpha }
            | Perturbation::ShiftNe { alpha }
            | Perturbation::Oscillatory { alpha, .. } => alpha,
        }
    }
}

/// Same text as [`FromStr`] accepts; `f64` Display round-trips exactly.
impl fmt::Display for Perturbation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Perturbation::Random { alpha } => write!(f, "random:{alpha}"),
            Perturbation::RandomShortest { alpha } => write!(f, "random-shortest:{alpha}"),
            Perturbation::ShiftR { alpha } => write!(f, "shift-r:{alpha}"),
            Perturbation::ShiftNe { alpha } => write!(f, "shift-ne:{alpha}"),
            Perturbation::Oscillatory { alpha, omega } => write!(f, "osc:{alpha}:{omega}"),
        }
    }
}

const SYNTAX: &str = "expected random:ALPHA, random-shortest:ALPHA, shift-r:ALPHA, shift-ne:ALPHA or osc:ALPHA:OMEGA";

fn parse_number(text: &str, what: &str, whole: &str) -> Result<f64> {
    let v: f64 = text
        .trim()
        .parse()
        .map_err(|_| Error::InvalidArgument(format!("perturbation '{whole}': {what} '{text}' is not a number")))?;
    if !v.is_finite() || v < 0.0 {
        return Err(Error::InvalidArgument(format!(
            "perturbation '{whole}': {what} must be finite and >= 0, got {text}"
        )));
    }
    Ok(v)
}

impl FromStr for Perturbation {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        let parts: Vec<&str> = s.trim().split(':').collect();
        let arity = |n: usize| {
            if parts.len() == n {
                Ok(())
            } else {
                Err(Error::InvalidArgument(format!(
                    "perturbation '{s}': '{}' takes {} parameter(s), got {}; {SYNTAX}",
                    parts[0],
                    n - 1,
                    parts.len() - 1
                )))
            }
        };
        let name = parts[0].to_ascii_lowercase();
        match name.as_str() {
            "random" | "random-shortest" | "shift-r" | "shift-ne" => {
                arity(2)?;
                let alpha = parse_number(parts[1], "alpha", s)?;
                Ok(match name.as_str() {
                    "random" => Perturbation::Random { alpha },
                    "random-shortest" => Perturbation::RandomShortest { alpha },
                    "shift-r" => Perturbation::ShiftR { alpha },
                    _ => Perturbation::ShiftNe { alpha },
                })
            }
            "osc" => {
                arity(3)?;
                Ok(Perturbation::Oscillatory {
                    alpha: parse_number(parts[1], "alpha", s)?,
                    omega: parse_number(parts[2], "omega", s)?,
                })
            }
            _ => Err(Error::InvalidArgument(format!("unknown perturbation '{s}'; {SYNTAX}"))),
        }
    }
}

/// How to perturb a mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct PerturbOptions {
    /// How each moved vertex moves.
    pub perturbation: Perturbation,
    /// Share of the free vertices to move: 1.0 = all, else a random subset of
    /// `round(fraction * free)` vertices.
    pub fraction: f64,
    /// Seed of the random moves and of the subset.
    pub seed: u64,
}

impl Default for PerturbOptions {
    fn default() -> Self {
        PerturbOptions {
            perturbation: Perturbation::Random { alpha: 0.1 },
            fraction: 1.0,
            seed: 0,
        }
    }
}

/// What [`perturb`] did. `selected = moved + untouched`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct PerturbStats {
    /// Free vertices chosen to move.
    pub selected: usize,
    /// Vertices that moved, by the full or a shortened displacement.
    pub moved: usize,
    /// Of `moved`, those whose displacement had to be shortened.
    pub backtracked: usize,
    /// Selected vertices left in place: every shortened move inverted an element.
    pub untouched: usize,
}

/// Halvings tried before a vertex is left where it is.
const MAX_HALVINGS: u32 = 30;

/// Moves the free vertices (not on the skin, not user-fixed) of a valid mesh.
///
/// Random moves are made one vertex at a time in a seeded random order; a
/// move that would give any incident element a non-positive corner
/// determinant is halved until it does not (at most 30 times, then the
/// vertex stays). Shifts and oscillations move every selected vertex
/// together in increments of a quarter edge, each vertex taking (or halving)
/// its increment only where its elements stay valid. Either way a mesh without inverted elements stays without them. Planar meshes move in x and
/// y only. The result depends only on the mesh, the options and the seed.
pub fn perturb(mesh: &mut Mesh, opts: &PerturbOptions) -> Result<PerturbStats> {
    perturb_with(mesh, opts, true)
}

/// [`perturb`] without the inversion guard: every selected vertex moves by
/// its full displacement, inverting elements where it lands them inverted
/// (tangled inputs for untangling). The start must still be valid.
pub fn perturb_unguarded(mesh: &mut Mesh, opts: &PerturbOptions) -> Result<PerturbStats> {
    perturb_with(mesh, opts, false)
}

fn perturb_with(mesh: &mut Mesh, opts: &PerturbOptions, guard: bool) -> Result<PerturbStats> {
    let f = opts.fraction;
    if !(f > 0.0 && f <= 1.0) {
        return Err(Error::InvalidArgument(format!(
            "perturbation fraction must be in (0, 1], got {f}"
        )));
    }
    // re-check what FromStr checks, for values built in code
    let p = opts.perturbation;
    let omega_ok = match p {
        Perturbation::Oscillatory { omega, .. } => omega.is_finite(),
        _ => true,
    };
    if !(p.alpha().is_finite() && p.alpha() >= 0.0 && omega_ok) {
        return Err(Error::InvalidArgument(format!("perturbation {p} has a bad parameter")));
    }
    mesh.validate()?;
    // a clockwise planar mesh is perturbed mirrored (negation is exact) and mirrored back
    let mirror = crate::metric::is_clockwise(mesh, &mesh.points);
    let flip = |mesh: &mut Mesh| mesh.points.iter_mut().for_each(|p| p[1] = -p[1]);
    if mirror {
        flip(mesh);
    }
    let result = perturb_oriented(mesh, opts, guard);
    if mirror {
        flip(mesh);
    }
    result
}

fn perturb_oriented(mesh: &mut Mesh, opts: &PerturbOptions, guard: bool) -> Result<PerturbStats> {
    let (f, p) = (opts.fraction, opts.perturbation);
    let inverted = inverted_elements(mesh, &mesh.points);
    if !inverted.is_empty() {
        return Err(Error::Inverted {
            count: inverted.len(),
            first: inverted.into_iter().take(10).collect(),
        });
    }

    let fixed = fixed_vertices(mesh);
    let mut order: Vec<usize> = (0..mesh.num_points()).filter(|&v| !fixed[v]).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    shuffle(&mut order, &mut rng);
    let count = if f >= 1.0 {
        order.len()
    } else {
        (f * order.len() as f64).round() as usize
    };
    order.truncate(count);

    let h = edge_lengths(mesh, matches!(p, Perturbation::RandomShortest { .. }));
    let (lo, hi) = crate::mesh::frame::bounding_box(&mesh.points);
    let planar = mesh.dim() == 2;
    let ve = vertex_elements(mesh);
    let displacements: Vec<[f64; 3]> = order
        .iter()
        .map(|&v| {
            let mut d = displacement(&p, mesh.points[v], h[v], &lo, &hi, &mut rng);
            if planar {
                d[2] = 0.0;
            }
            d
        })
        .collect();
    if matches!(p, Perturbation::Random { .. } | Perturbation::RandomShortest { .. }) {
        Ok(one_at_a_time(mesh, &order, displacements, &ve, guard))
    } else {
        Ok(together(mesh, &order, &displacements, &h, &ve, guard))
    }
}

fn valid_around(mesh: &Mesh, ve: &crate::mesh::topology::Csr, v: usize) -> bool {
    ve.of(v)
        .iter()
        .all(|&e| element_min_det(mesh, &mesh.points, e as usize) > 0.0)
}

/// Random moves, vertex by vertex: each independent move is halved until
/// its own elements are valid.
fn one_at_a_time(
    mesh: &mut Mesh,
    order: &[usize],
    displacements: Vec<[f64; 3]>,
    ve: &crate::mesh::topology::Csr,
    guard: bool,
) -> PerturbStats {
    let mut stats = PerturbStats {
        selected: order.len(),
        ..Default::default()
    };
    for (&v, mut d) in order.iter().zip(displacements) {
        let x0 = mesh.points[v];
        let mut placed = false;
        for halvings in 0..=MAX_HALVINGS {
            mesh.points[v] = std::array::from_fn(|i| x0[i] + d[i]);
            if !guard || valid_around(mesh, ve, v) {
                stats.moved += 1;
                stats.backtracked += (halvings > 0) as usize;
                placed = true;
                break;
            }
            d = d.map(|c| 0.5 * c);
        }
        if !placed {
            mesh.points[v] = x0;
            stats.untouched += 1;
        }
    }
    stats
}

/// A displacement field (a shift, an oscillation) moves every selected
/// vertex together, as the Newton paper's translational and oscillatory
/// perturbations do, in small increments (a quarter of a local edge each):
/// in each increment every vertex, in the seeded order, takes its share of
/// the field unless that would invert one of its elements, then tries half
/// of it, and so on (the paper's node-by-node backtracking). Neighbours
/// that move together keep their elements, so vertices pile up against the
/// fixed boundary: a larger shift squeezes more elements, harder, instead of
/// being halved into the same small move everywhere.
fn together(
    mesh: &mut Mesh,
    order: &[usize],
    displacements: &[[f64; 3]],
    h: &[f64],
    ve: &crate::mesh::topology::Csr,
    guard: bool,
) -> PerturbStats {
    let x0: Vec<[f64; 3]> = order.iter().map(|&v| mesh.points[v]).collect();
    let norm = |d: &[f64; 3]| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let steps = order
        .iter()
        .zip(displacements)
        .map(|(&v, d)| {
            if h[v] > 0.0 {
                (4.0 * norm(d) / h[v]).ceil() as usize
            } else {
                1
            }
        })
        .max()
        .unwrap_or(0)
        .max(1);
    // the share of its move each vertex has made
    let mut t = vec![0.0f64; order.len()];
    for _ in 0..steps {
        for (k, &v) in order.iter().enumerate() {
            let mut dt = (1.0 - t[k]).min(1.0 / steps as f64);
            for _ in 0..=MAX_HALVINGS.min(8) {
                if dt <= 0.0 {
                    break;
                }
                mesh.points[v] = std::array::from_fn(|i| x0[k][i] + (t[k] + dt) * displacements[k][i]);
                if !guard || valid_around(mesh, ve, v) {
                    t[k] += dt;
                    break;
                }
                dt *= 0.5;
            }
            mesh.points[v] = std::array::from_fn(|i| x0[k][i] + t[k] * displacements[k][i]);
        }
    }
    let full = |x: f64| x >= 1.0 - 1e-12;
    PerturbStats {
        selected: order.len(),
        moved: t.iter().filter(|&&x| x > 0.0).count(),
        backtracked: t.iter().filter(|&&x| x > 0.0 && !full(x)).count(),
        untouched: t.iter().filter(|&&x| x == 0.0).count(),
    }
}

/// Fisher-Yates over `u64` draws, so the order does not depend on `usize` width.
fn shuffle(items: &mut [usize], rng: &mut ChaCha8Rng) {
    for i in (1..items.len()).rev() {
        let j = rng.random_range(0..=i as u64) as usize;
        items.swap(i, j);
    }
}

fn displacement(p: &Perturbation, x: [f64; 3], h: f64, lo: &[f64; 3], hi: &[f64; 3], rng: &mut ChaCha8Rng) -> [f64; 3] {
    match *p {
        Perturbation::Random { alpha } | Perturbation::RandomShortest { alpha } => {
            std::array::from_fn(|_| alpha * h * rng.random_range(-1.0..=1.0))
        }
        Perturbation::ShiftR { alpha } => [alpha * h, 0.0, 0.0],
        Perturbation::ShiftNe { alpha } => {
            let s = alpha * h * std::f64::consts::FRAC_1_SQRT_2;
            [s, s, 0.0]
        }
        Perturbation::Oscillatory { alpha, omega } => std::array::from_fn(|i| {
            let extent = hi[i] - lo[i];
            // a flat axis (z of a planar mesh) has nothing to oscillate over
            if extent > 0.0 {
                alpha * h * (omega * (x[i] - lo[i]) / extent).sin()
            } else {
                0.0
            }
        }),
    }
}

/// Mean (or, with `shortest`, the shortest) length of the edges at each vertex.
fn edge_lengths(mesh: &Mesh, shortest: bool) -> Vec<f64> {
    let nb = vertex_neighbours(mesh);
    (0..mesh.num_points())
        .map(|v| {
            let others = nb.of(v);
            let x = mesh.points[v];
            let lengths = others.iter().map(|&w| {
                let y = mesh.points[w as usize];
                ((x[0] - y[0]).powi(2) + (x[1] - y[1]).powi(2) + (x[2] - y[2]).powi(2)).sqrt()
            });
            if others.is_empty() {
                0.0
            } else if shortest {
                lengths.fold(f64::INFINITY, f64::min)
            } else {
                lengths.sum::<f64>() / others.len() as f64
            }
        })
        .collect()
}
