//! Targets: the corner matrix W each corner is measured against (S = A W^-1).
//!
//! A target is built from a per-element metric tensor G (symmetric positive
//! definite, in length^2: the ideal element's edges have unit length in
//! G^-1, so an isotropic element of edge h has G = h^2 I) and an orientation:
//! W_c = G^(1/2) Q R_c, where R_c is corner c's matrix in the kind's ideal
//! element (unit edges; [`reference_points`]) and Q a rotation. G carries
//! size, aspect and the direction of anisotropy; skew is ideal.
//!
//! - [`Target::Ideal`]: no targets here; every corner is measured against its
//!   kind's ideal corner (the classic shape objective).
//! - [`Target::Input`]: G from the input's own corners, regularised (see
//!   [`InputTargets`]), so that perturbation noise goes and boundary layers,
//!   grading and anisotropy stay.
//! - [`Target::Size`]: G = h^2 I from a scalar point-data field h (an edge
//!   length), averaged over the element's vertices.
//! - [`Target::Metric`]: G = M^-1 from a symmetric-tensor point-data field M
//!   (Mmg's and Gmsh's convention: unit edge length in M; 3 components
//!   m11 m12 m22 in 2D, 6 components m11 m12 m13 m22 m23 m33 in 3D),
//!   averaged over the element's vertices.
//!
//! Q is the rotation nearest to the element's own Jacobian seen in G's unit
//! space, snapped onto G's eigenvectors for the kinds whose ideal has right
//! angles (quadrilaterals and hexahedra: every axis; prisms: the extrusion
//! axis), so a target rectangle in a boundary layer is a rectangle and not a
//! sheared one. Rotations on the right of T do not change the metrics of an
//! isotropic G, so Q matters only where G is anisotropic.

use crate::error::{Error, Result};
use crate::mesh::topology::{Csr, vertex_elements};
use crate::mesh::{ElementKind, Mesh};
use crate::metric::mat3::{Mat3, Vec3, det, sub, transpose};
use crate::metric::smetric::MetricKind;
use rayon::prelude::*;
use std::borrow::Cow;

mod split_layers;

/// Where each corner's target W comes from.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Target<'a> {
    /// The default: [`Target::Input`] with the shape+size metric where the
    /// mesh's [`Intent`] says its stretching and grading were built on
    /// purpose, [`Target::Ideal`] otherwise (see [`ProblemOptions::resolved`](super::ProblemOptions::resolved)).
    #[default]
    Auto,
    /// Each kind's ideal corner: equilateral or right-angled, unit-free.
    Ideal,
    /// The input's own corners, regularised.
    Input(InputTargets),
    /// A scalar point-data field: the target edge length.
    Size(&'a str),
    /// A symmetric-tensor point-data field: unit edge length in it.
    Metric(&'a str),
}

impl<'a> Target<'a> {
    /// Whether per-corner targets are built (everything but `Ideal`).
    pub fn is_constructed(&self) -> bool {
        !matches!(self, Target::Ideal | Target::Auto)
    }

    /// A target spec as the front ends spell it: auto, ideal, input,
    /// size:FIELD or metric:FIELD (a reference mesh is given as a mesh).
    pub fn parse(spec: &'a str) -> Result<Target<'a>> {
        let field = |rest: &'a str, kind: &str| -> Result<&'a str> {
            if rest.is_empty() {
                return Err(Error::InvalidArgument(format!(
                    "target '{spec}' needs the point-data field's name ({kind}:NAME)"
                )));
            }
            Ok(rest)
        };
        Ok(match spec {
            "auto" => Target::Auto,
            "ideal" => Target::Ideal,
            "input" => Target::Input(InputTargets::default()),
            s => match s.split_once(':') {
                Some(("size", f)) => Target::Size(field(f, "size")?),
                Some(("metric", f)) => Target::Metric(field(f, "metric")?),
                _ => {
                    return Err(Error::InvalidArgument(format!(
                        "unknown target '{spec}': expected auto, ideal, input, size:FIELD, metric:FIELD or reference:MESH"
                    )));
                }
            },
        })
    }

    /// The metric a front end uses when none is named: shape+size where
    /// targets are constructed (their sizes are what was asked for; the
    /// size-invariant inverse mean ratio would ignore them), the inverse
    /// mean ratio otherwise (`Auto` switches to shape+size itself when it
    /// chooses input targets).
    pub fn default_metric(&self) -> MetricKind {
        if self.is_constructed() {
            MetricKind::ShapeSize
        } else {
            MetricKind::default()
        }
    }

    /// The target's name as settings spell it (`auto`, `ideal`, `input`, `size:FIELD`, `metric:FIELD`).
    pub fn name(&self) -> String {
        match self {
            Target::Auto => "auto".into(),
            Target::Ideal => "ideal".into(),
            Target::Input(_) => "input".into(),
            Target::Size(f) => format!("size:{f}"),
            Target::Metric(f) => format!("metric:{f}"),
        }
    }
}

/// How the input's targets are regularised. Each element's log G is
/// replaced, `passes` times, by the value at its centroid of a
/// least-squares affine fit over the elements sharing a vertex with it
/// (itself included), with the offsets between centroids measured in the
/// mesh's logical coordinates (see `logical_offsets`): the fitted tensor
/// gives the axes and each axis's log-length is fitted from the neighbours'
/// matching eigenvalues. Then, `2 * passes` times, stretched elements (aspect
/// 2 and more) are fitted along their layer only (the neighbours in their
/// own row, in the layer's tangent coordinates), which spreads the averaging
/// along a wall, where a layer's cells are alike, and not across it, where
/// they grow. An affine fit reproduces linear trends exactly, also at a wall
/// where the neighbourhood is one-sided, so geometric grading (log-linear
/// in the layer index) and smooth anisotropy stay while the noise of
/// perturbed vertices averages out. Layers of stretched simplices take
/// instead the corners of the input with the layers' vertices regularised
/// along their rows and columns, `25 * passes` rounds (see `split_layers`).
/// 0 passes: the input's own (noisy) corners.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct InputTargets {
    /// Regularisation passes (0: the input's own corners).
    pub passes: usize,
}

impl Default for InputTargets {
    fn default() -> Self {
        InputTargets { passes: 4 }
    }
}

/// Vertex coordinates of `kind`'s ideal element (unit edges), in the
/// vertex order of the mesh's kinds; its first corner is
/// [`ideal_corner`](crate::metric::corner::ideal_corner). `None` for polyhedra, whose corners are measured
/// against the octant corner.
pub fn reference_points(kind: ElementKind) -> Option<&'static [Vec3]> {
    const H: f64 = 0.866_025_403_784_438_6; // sqrt(3) / 2
    const T6: f64 = 0.288_675_134_594_812_9; // sqrt(3) / 6
    const Z: f64 = 0.816_496_580_927_726; // sqrt(2 / 3)
    Some(match kind {
        ElementKind::Triangle => &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, H, 0.0]],
        ElementKind::Quadrilateral => &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
        ElementKind::Tetrahedron => &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, H, 0.0], [0.5, T6, Z]],
        ElementKind::Hexahedron => &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 1.0],
        ],
        ElementKind::Prism => &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, H, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [0.5, H, 1.0],
        ],
        ElementKind::Polyhedron => return None,
    })
}

pub(crate) fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// Corner matrix (columns = edges from the corner vertex) of local corner
/// `c` at the element's points `x`, in the leading n x n block (the rest
/// identity, so every matrix here stays invertible in 2D).
pub(crate) fn corner_matrix(x: &[Vec3], c: &[usize; 4], n: usize) -> Mat3 {
    let mut a = IDENTITY;
    for col in 0..n {
        let e = sub(&x[c[col + 1]], &x[c[0]]);
        for row in 0..n {
            a[row][col] = e[row];
        }
    }
    a
}

const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Eigenvalues and eigenvectors (columns of V) of a symmetric matrix by
/// cyclic Jacobi rotations (exact to rounding for 3x3).
pub fn sym_eigen(m: &Mat3) -> (Vec3, Mat3) {
    let mut a = *m;
    let mut v = IDENTITY;
    for _ in 0..50 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        let diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if off <= 1e-30 * diag || off == 0.0 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A <- R^T A R and V <- V R for the rotation R in the (p, q)
            // plane, touching only the rows and columns it changes: this runs
            // for every element of every mesh the default targets look at
            for row in a.iter_mut().chain(v.iter_mut()) {
                let (x, y) = (row[p], row[q]);
                row[p] = c * x - s * y;
                row[q] = s * x + c * y;
            }
            for j in 0..3 {
                let (x, y) = (a[p][j], a[q][j]);
                a[p][j] = c * x - s * y;
                a[q][j] = s * x + c * y;
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2]], v)
}

/// V f(Lambda) V^T for a symmetric matrix.
pub fn sym_fn(m: &Mat3, f: impl Fn(f64) -> f64) -> Mat3 {
    let (l, v) = sym_eigen(m);
    let fl = l.map(f);
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| v[i][k] * fl[k] * v[j][k]).sum()))
}

/// The rotation of the polar decomposition M = Q U, `None` unless det M > 0.
fn polar_rotation(m: &Mat3) -> Option<Mat3> {
    if !(det(m) > 0.0) {
        return None;
    }
    let mtm = mul(&transpose(m), m);
    let inv_sqrt = sym_fn(&mtm, |l| 1.0 / l.max(f64::MIN_POSITIVE).sqrt());
    let q = mul(m, &inv_sqrt);
    q.iter().flatten().all(|v| v.is_finite()).then_some(q)
}

/// Q with its columns snapped onto G's eigenvectors (`axes`: which columns;
/// the others are re-orthogonalised), kept as it is where that would not be
/// a rotation.
fn snap(q: &Mat3, v: &Mat3, axes: &[usize], n: usize) -> Mat3 {
    let col = |m: &Mat3, j: usize| -> Vec3 { [m[0][j], m[1][j], m[2][j]] };
    let mut out = *q;
    let mut used = [false; 3];
    for &i in axes {
        let qi = col(q, i);
        let (k, d) = (0..n)
            .filter(|&k| !used[k])
            .map(|k| (k, crate::metric::mat3::dot(&qi, &col(v, k))))
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .unwrap();
        used[k] = true;
        for r in 0..3 {
            out[r][i] = d.signum() * v[r][k];
        }
    }
    if axes.len() == 1 && n == 3 {
        // prism: the base axes re-orthogonalised against the snapped axis 2
        let a2 = col(&out, 2);
        let q0 = col(q, 0);
        let d = crate::metric::mat3::dot(&q0, &a2);
        let mut a0 = [q0[0] - d * a2[0], q0[1] - d * a2[1], q0[2] - d * a2[2]];
        let len = crate::metric::mat3::dot(&a0, &a0).sqrt();
        if !(len > 1e-12) {
            return *q;
        }
        a0 = a0.map(|x| x / len);
        let a1 = crate::metric::mat3::cross(&a2, &a0);
        for r in 0..3 {
            out[r][0] = a0[r];
            out[r][1] = a1[r];
        }
    }
    if det(&out) > 0.5 { out } else { *q }
}

/// The corners a target is built for: the ones the objective uses.
fn used_corners(mesh: &Mesh, e: usize) -> Result<Cow<'static, [[usize; 4]]>> {
    mesh.optimised_corners(e)
        .map_err(|m| Error::InvalidMesh(format!("element {e} ({}): {m}", mesh.kinds[e])))
}

/// The corners an element's metric is read from: all of them (a simplex's
/// corners all see the same affine map).
fn all_corners(mesh: &Mesh, e: usize) -> Result<Cow<'static, [[usize; 4]]>> {
    mesh.element_corners(e)
        .map_err(|m| Error::InvalidMesh(format!("element {e} ({}): {m}", mesh.kinds[e])))
}

/// Element `e`'s vertex positions, read in the problem's order (reversed for
/// a planar mesh wound clockwise).
fn element_points(mesh: &Mesh, points: &[Vec3], e: usize, flip: bool) -> Vec<Vec3> {
    super::corners::element_vertices(mesh, e, flip)
        .iter()
        .map(|&v| points[v as usize])
        .collect()
}

/// Corner c's matrix in the ideal element, or the octant corner for polyhedra.
fn reference_corner(kind: ElementKind, c: &[usize; 4], n: usize) -> Mat3 {
    match reference_points(kind) {
        Some(r) => corner_matrix(r, c, n),
        None => IDENTITY,
    }
}

/// Each element's G from its own corners: the mean over its corners of
/// (A_c R_c^-1)(A_c R_c^-1)^T (for an affine image J of the ideal element,
/// exactly J J^T).
pub fn element_metrics(mesh: &Mesh, points: &[Vec3], flip: bool) -> Result<Vec<Mat3>> {
    (0..mesh.num_elements())
        .into_par_iter()
        .map(|e| element_metric(mesh, points, flip, e))
        .collect()
}

/// Element `e`'s G of [`element_metrics`].
fn element_metric(mesh: &Mesh, points: &[Vec3], flip: bool, e: usize) -> Result<Mat3> {
    let n = mesh.dim();
    let kind = mesh.kinds[e];
    let x = element_points(mesh, points, e, flip);
    let cs = all_corners(mesh, e)?;
    let mut g = [[0.0; 3]; 3];
    for c in cs.iter() {
        let rinv = crate::metric::mat3::inverse(&reference_corner(kind, c, n)).expect("ideal corners are valid");
        let j = mul(&corner_matrix(&x, c, n), &rinv);
        let jjt = mul(&j, &transpose(&j));
        for r in 0..n {
            for s in 0..n {
                g[r][s] += jjt[r][s] / cs.len() as f64;
            }
        }
    }
    for k in n..3 {
        g[k][k] = 1.0;
    }
    Ok(g)
}

/// Per-corner targets: `offsets[e]..offsets[e + 1]` index element e's used
/// corners (in [`Mesh::optimised_corners`] order) in `w`.
#[derive(Clone, Debug, Default)]
pub struct CornerTargets {
    /// Per element, the offset of its first target in `w` (`elements + 1` entries).
    pub offsets: Vec<usize>,
    /// The target matrices W, element after element.
    pub w: Vec<Mat3>,
}

impl CornerTargets {
    /// The targets of element `e`'s used corners.
    pub fn of(&self, e: usize) -> &[Mat3] {
        &self.w[self.offsets[e]..self.offsets[e + 1]]
    }
}

/// The targets of `target` for `mesh` at `points` (in the problem's frame:
/// lengths of the size and metric fields are divided by `unit`), `None` for
/// [`Target::Ideal`].
pub fn build(mesh: &Mesh, points: &[Vec3], flip: bool, target: Target, unit: f64) -> Result<Option<CornerTargets>> {
    let n = mesh.dim();
    let unit = if unit > 0.0 { unit } else { 1.0 };
    // the input's layers of stretched simplices: their cells and the points
    // whose corners are those cells' targets (see `split_layers`)
    let mut layers = None;
    let g = match target {
        // an unresolved default is the ideal objective (today's): only the
        // smoothing entry, which sees the whole mesh, decides otherwise
        Target::Ideal | Target::Auto => return Ok(None),
        Target::Input(opts) => {
            let mut g = element_metrics(mesh, points, flip)?;
            if opts.passes > 0 {
                layers = split_layers::regularised_layers(mesh, points, &g, opts.passes);
            }
            let logs: Vec<Mat3> = g.iter().map(|m| sym_fn(m, |l| l.max(f64::MIN_POSITIVE).ln())).collect();
            let smoothed = regularise(mesh, points, logs, opts.passes);
            for (gi, l) in g.iter_mut().zip(&smoothed) {
                *gi = sym_fn(l, f64::exp);
            }
            g
        }
        Target::Size(name) => {
            let h = point_field(mesh, name, 1)?;
            (0..mesh.num_elements())
                .map(|e| {
                    let vs = mesh.element(e);
                    let mean = vs.iter().map(|&v| h[v as usize][0]).sum::<f64>() / vs.len() as f64 / unit;
                    let mut g = IDENTITY;
                    for k in 0..n {
                        g[k][k] = mean * mean;
                    }
                    g
                })
                .collect()
        }
        Target::Metric(name) => {
            let comps = if n == 2 { 3 } else { 6 };
            let m = point_field(mesh, name, comps)?;
            let tensor = |t: &[f64]| -> Mat3 {
                if n == 2 {
                    [[t[0], t[1], 0.0], [t[1], t[2], 0.0], [0.0, 0.0, 1.0]]
                } else {
                    [[t[0], t[1], t[2]], [t[1], t[3], t[4]], [t[2], t[4], t[5]]]
                }
            };
            for (v, t) in m.iter().enumerate() {
                let (l, _) = sym_eigen(&tensor(t));
                if !l.iter().all(|x| *x > 0.0 && x.is_finite()) {
                    return Err(Error::InvalidArgument(format!(
                        "metric field '{name}' is not positive definite at point {v} (eigenvalues {:.3e}, {:.3e}{})",
                        l[0],
                        l[1],
                        if n == 3 {
                            format!(", {:.3e}", l[2])
                        } else {
                            String::new()
                        }
                    )));
                }
            }
            (0..mesh.num_elements())
                .map(|e| {
                    let vs = mesh.element(e);
                    let mut mean = [[0.0; 3]; 3];
                    for &v in vs {
                        let t = tensor(&m[v as usize]);
                        for r in 0..3 {
                            for s in 0..3 {
                                mean[r][s] += t[r][s] / vs.len() as f64;
                            }
                        }
                    }
                    // lengths in the frame: M (1 / length^2) times unit^2
                    let inv = sym_fn(&mean, |l| 1.0 / l);
                    let mut g = inv.map(|r| r.map(|x| x / (unit * unit)));
                    if n == 2 {
                        g[2] = [0.0, 0.0, 1.0];
                        g[0][2] = 0.0;
                        g[1][2] = 0.0;
                    }
                    g
                })
                .collect()
        }
    };
    let mut out = from_metrics(mesh, points, flip, &g)?;
    if let Some((cells, x)) = layers {
        for e in (0..mesh.num_elements()).filter(|&e| cells[e]) {
            let xe = element_points(mesh, &x, e, flip);
            let used = used_corners(mesh, e)?;
            for (w, c) in out.w[out.offsets[e]..out.offsets[e + 1]].iter_mut().zip(used.iter()) {
                *w = corner_matrix(&xe, c, n);
            }
        }
    }
    Ok(Some(out))
}

/// A point-data field of `comps` components as f64 tuples, checked finite
/// (and positive for a scalar size).
fn point_field(mesh: &Mesh, name: &str, comps: usize) -> Result<Vec<Vec<f64>>> {
    let names = || {
        mesh.data
            .point
            .iter()
            .map(|a| a.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let a = mesh.data.point.iter().find(|a| a.name == name).ok_or_else(|| {
        Error::InvalidArgument(format!(
            "the mesh has no point-data field '{name}' (its point fields: {})",
            if mesh.data.point.is_empty() {
                "none".into()
            } else {
                names()
            }
        ))
    })?;
    if a.components != comps {
        return Err(Error::InvalidArgument(format!(
            "point-data field '{name}' has {} components; a {} target needs {comps}",
            a.components,
            if comps == 1 { "size" } else { "metric" }
        )));
    }
    (0..mesh.num_points())
        .map(|v| {
            let t: Vec<f64> = (0..comps).map(|k| a.get_f64(v * comps + k)).collect();
            if !t.iter().all(|x| x.is_finite()) || (comps == 1 && !(t[0] > 0.0)) {
                return Err(Error::InvalidArgument(format!(
                    "point-data field '{name}' has value {:?} at point {v}; {}",
                    t,
                    if comps == 1 {
                        "a size must be positive and finite"
                    } else {
                        "values must be finite"
                    }
                )));
            }
            Ok(t)
        })
        .collect()
}

/// W_c = G^(1/2) Q R_c for every used corner (see the module doc).
pub fn from_metrics(mesh: &Mesh, points: &[Vec3], flip: bool, g: &[Mat3]) -> Result<CornerTargets> {
    let n = mesh.dim();
    let per: Vec<Result<Vec<Mat3>>> = (0..mesh.num_elements())
        .into_par_iter()
        .map(|e| {
            let kind = mesh.kinds[e];
            let x = element_points(mesh, points, e, flip);
            let root = sym_fn(&g[e], |l| l.max(f64::MIN_POSITIVE).sqrt());
            let inv_root = sym_fn(&g[e], |l| 1.0 / l.max(f64::MIN_POSITIVE).sqrt());
            let used = used_corners(mesh, e)?;
            let metric_space = |c: &[usize; 4]| {
                let rinv =
                    crate::metric::mat3::inverse(&reference_corner(kind, c, n)).expect("ideal corners are valid");
                mul(&inv_root, &mul(&corner_matrix(&x, c, n), &rinv))
            };
            let q_of = |m: &Mat3| {
                let q = polar_rotation(m).unwrap_or(IDENTITY);
                let (_, v) = sym_eigen(&g[e]);
                let v = if n == 2 {
                    // the 2D eigenvectors of the leading block (z is its own)
                    let (_, v2) = sym_eigen(&[
                        [g[e][0][0], g[e][0][1], 0.0],
                        [g[e][1][0], g[e][1][1], 0.0],
                        [0.0, 0.0, 0.0],
                    ]);
                    let mut v = v2;
                    // keep the xy eigenvectors first
                    let zcol = (0..3)
                        .max_by(|&a, &b| v2[2][a].abs().total_cmp(&v2[2][b].abs()))
                        .unwrap();
                    let cols: Vec<usize> = (0..3).filter(|&k| k != zcol).chain([zcol]).collect();
                    for r in 0..3 {
                        for (j, &k) in cols.iter().enumerate() {
                            v[r][j] = v2[r][k];
                        }
                    }
                    v
                } else {
                    v
                };
                match kind {
                    ElementKind::Quadrilateral => snap(&q, &v, &[0, 1], 2),
                    ElementKind::Hexahedron => snap(&q, &v, &[0, 1, 2], 3),
                    ElementKind::Prism => snap(&q, &v, &[2], 3),
                    _ => q,
                }
            };
            let element_q = if kind == ElementKind::Polyhedron {
                None
            } else {
                // the mean metric-space Jacobian over all corners
                let cs = all_corners(mesh, e)?;
                let mut m = [[0.0; 3]; 3];
                for c in cs.iter() {
                    let mc = metric_space(c);
                    for r in 0..3 {
                        for s in 0..3 {
                            m[r][s] += mc[r][s] / cs.len() as f64;
                        }
                    }
                }
                Some(q_of(&m))
            };
            Ok(used
                .iter()
                .map(|c| {
                    let q = element_q.unwrap_or_else(|| q_of(&metric_space(c)));
                    let w = mul(&root, &mul(&q, &reference_corner(kind, c, n)));
                    if n == 2 {
                        [[w[0][0], w[0][1], 0.0], [w[1][0], w[1][1], 0.0], [0.0, 0.0, 1.0]]
                    } else {
                        w
                    }
                })
                .collect())
        })
        .collect();
    let mut out = CornerTargets {
        offsets: vec![0],
        w: Vec::new(),
    };
    for p in per {
        out.w.extend(p?);
        out.offsets.push(out.w.len());
    }
    Ok(out)
}

/// `passes` rounds of the local affine fit of the symmetric matrices `vals`
/// (one per element) over each element's vertex neighbours (see [`InputTargets`]).
fn regularise(mesh: &Mesh, points: &[Vec3], mut vals: Vec<Mat3>, passes: usize) -> Vec<Mat3> {
    if passes == 0 {
        return vals;
    }
    let n = mesh.dim();
    let (centroid, nb) = neighbourhoods(mesh, points);
    for pass in 0..passes * (1 + ALONG_PER_PASS) {
        let across = pass < passes;
        let eigen: Vec<(Vec3, Mat3)> = vals.par_iter().map(sym_eigen).collect();
        let quarter = quarters(&eigen);
        vals = (0..mesh.num_elements())
            .into_par_iter()
            .map(|e| {
                let nb = nb.of(e);
                if across {
                    let local = logical_offsets(e, nb, &centroid, &quarter, &eigen, n);
                    return fit_log_metric(&local, n, |i| nb[i] as usize, &vals, &eigen);
                }
                // along a layer: its own row only, in the layer's coordinates
                let Some((axis, 1.0)) = distinct_axis(&eigen[e], n) else {
                    return vals[e];
                };
                let local = logical_offsets(e, nb, &centroid, &quarter, &eigen, n);
                let (_, v) = &eigen[e];
                let tangents: Vec<Vec3> = (0..3)
                    .map(|k| [v[0][k], v[1][k], v[2][k]])
                    .filter(|t| (0..3).map(|i| t[i] * axis[i]).sum::<f64>().abs() < 0.5 && (n == 3 || t[2].abs() < 0.5))
                    .collect();
                let dot = |a: &Vec3, b: &Vec3| (0..3).map(|i| a[i] * b[i]).sum::<f64>();
                let row: Vec<usize> = (0..nb.len()).filter(|&i| dot(&local[i], &axis).abs() < 0.5).collect();
                let along: Vec<Vec3> = row
                    .iter()
                    .map(|&i| std::array::from_fn(|k| tangents.get(k).map_or(0.0, |t| dot(&local[i], t))))
                    .collect();
                fit_log_metric(&along, n - 1, |i| nb[row[i]] as usize, &vals, &eigen)
            })
            .collect();
    }
    vals
}

/// exp(-L / 4) of each log-metric L, from its eigen decomposition.
fn quarters(eigen: &[(Vec3, Mat3)]) -> Vec<Mat3> {
    eigen
        .par_iter()
        .map(|(l, v)| {
            let f = l.map(|x| (-0.25 * x).exp());
            std::array::from_fn(|r| std::array::from_fn(|c| (0..3).map(|k| v[r][k] * f[k] * v[c][k]).sum()))
        })
        .collect()
}

/// `passes` rounds of a plain local mean of log G: what the default's
/// detection reads the mesh through. It is the cheap
/// cousin of [`regularise`] (every smoothing run with the default target
/// pays for the detection); the thresholds of [`Intent::keeps_input`] were
/// measured with it.
fn mean_regularise(mesh: &Mesh, nb: &Neighbours<'_>, mut vals: Vec<Mat3>, passes: usize) -> Vec<Mat3> {
    // each vertex takes the mean of its elements' values, then each element
    // the mean of its vertices': the support of the elements sharing a
    // vertex, weighted toward those sharing more, for a tenth of the cost of
    // visiting those neighbours element by element (entry by entry in one
    // order, so a mean of symmetric matrices stays exactly symmetric)
    let mean = |items: &mut dyn Iterator<Item = Mat3>| {
        let (mut sum, mut count) = ([[0.0; 3]; 3], 0usize);
        for m in items {
            sum.iter_mut()
                .flatten()
                .zip(m.iter().flatten())
                .for_each(|(s, x)| *s += x);
            count += 1;
        }
        sum.map(|row| row.map(|s| s / count.max(1) as f64))
    };
    for _ in 0..passes {
        let at_vertices: Vec<Mat3> = (0..mesh.num_points())
            .into_par_iter()
            .map(|v| mean(&mut nb.ve.of(v).iter().map(|&j| vals[j as usize])))
            .collect();
        vals = (0..mesh.num_elements())
            .into_par_iter()
            .map(|e| mean(&mut mesh.element(e).iter().map(|&v| at_vertices[v as usize])))
            .collect();
    }
    vals
}

/// The elements sharing a vertex with an element (itself included), in
/// ascending order, merged on the fly from the vertices' sorted element
/// lists. The default targets' test, which runs on every smooth, reads
/// them without storing them: stored they take about 70 ids per
/// tetrahedron (3 GB for 10M tetrahedra), and that allocation dominated
/// the test on large meshes.
struct Neighbours<'a> {
    mesh: &'a Mesh,
    ve: Csr,
}

impl<'a> Neighbours<'a> {
    fn of(mesh: &'a Mesh) -> Neighbours<'a> {
        Neighbours {
            mesh,
            ve: vertex_elements(mesh),
        }
    }

    /// Calls `f` with each neighbour of element `e` once, ascending.
    fn visit(&self, e: usize, mut f: impl FnMut(u32)) {
        const MOST: usize = 8;
        let vs = self.mesh.element(e);
        if vs.len() > MOST {
            // polyhedra: rare, and not worth a merge of many lists
            let mut all: Vec<u32> = vs
                .iter()
                .flat_map(|&v| self.ve.of(v as usize).iter().copied())
                .collect();
            all.sort_unstable();
            all.dedup();
            return all.into_iter().for_each(f);
        }
        let mut heads: [&[u32]; MOST] = [&[]; MOST];
        for (h, &v) in heads.iter_mut().zip(vs) {
            *h = self.ve.of(v as usize);
        }
        let heads = &mut heads[..vs.len()];
        // each round takes the smallest head and advances every list it heads
        while let Some(j) = heads.iter().filter_map(|h| h.first().copied()).min() {
            for h in heads.iter_mut() {
                if h.first() == Some(&j) {
                    *h = &h[1..];
                }
            }
            f(j);
        }
    }

    /// The neighbours of `e` into `out` (cleared first).
    fn collect(&self, e: usize, out: &mut Vec<u32>) {
        out.clear();
        self.visit(e, |j| out.push(j));
    }

    /// Every element's neighbours, stored: for the targets' regularisation,
    /// which reads them many rounds over.
    fn stored(&self) -> Csr {
        crate::mesh::topology::build_par(self.mesh.num_elements(), |e, out| self.visit(e, |j| out.push(j)))
    }
}

/// Each element's centroid, and the elements sharing a vertex with it.
fn neighbourhoods(mesh: &Mesh, points: &[Vec3]) -> (Vec<Vec3>, Csr) {
    (centroids(mesh, points), Neighbours::of(mesh).stored())
}

/// Each element's centroid.
fn centroids(mesh: &Mesh, points: &[Vec3]) -> Vec<Vec3> {
    (0..mesh.num_elements())
        .into_par_iter()
        .map(|e| {
            let vs = mesh.element(e);
            let mut c = [0.0; 3];
            for &v in vs {
                for k in 0..3 {
                    c[k] += points[v as usize][k] / vs.len() as f64;
                }
            }
            c
        })
        .collect()
}

/// Per stretched element (aspect [`ANISOTROPIC_ASPECT`] or more), the ratio
/// of thicknesses between it and its neighbours one cell away along its
/// thin axis (1 or more; the geometric mean over those neighbours): a
/// boundary layer's growth rate. Read from the eigen-decompositions of log G.
fn layer_growths(mesh: &Mesh, points: &[Vec3], nb: &Neighbours<'_>, eigen: &[(Vec3, Mat3)]) -> Vec<f64> {
    let n = mesh.dim();
    let centroid = centroids(mesh, points);
    let quarter = quarters(eigen);
    let dot = |a: &Vec3, b: &Vec3| (0..3).map(|i| a[i] * b[i]).sum::<f64>();
    (0..mesh.num_elements())
        .into_par_iter()
        .filter_map(|e| {
            let (axis, _) = distinct_axis(&eigen[e], n)?;
            let (l, v) = &eigen[e];
            let k = (0..3).max_by(|&a, &b| {
                dot(&[v[0][a], v[1][a], v[2][a]], &axis)
                    .abs()
                    .total_cmp(&dot(&[v[0][b], v[1][b], v[2][b]], &axis).abs())
            })?;
            let others: Vec<f64> = (0..3)
                .filter(|&b| b != k && (n == 3 || v[2][b].abs() < 0.5))
                .map(|b| l[b])
                .collect();
            // the distinct axis must be the thin one, and stretched enough
            if others.iter().any(|&o| o - l[k] < 2.0 * ANISOTROPIC_ASPECT.ln()) {
                return None;
            }
            let mut nbs = Vec::new();
            nb.collect(e, &mut nbs);
            let nbs = &nbs[..];
            let local = logical_offsets(e, nbs, &centroid, &quarter, eigen, n);
            let ratios: Vec<f64> = nbs
                .iter()
                .zip(&local)
                .filter(|&(_, d)| {
                    let along = dot(d, &axis).abs();
                    let across = (dot(d, d) - along * along).max(0.0).sqrt();
                    (0.5..1.5).contains(&along) && across < 0.5
                })
                .map(|(&j, d)| {
                    let axes: Mat3 = std::array::from_fn(|r| std::array::from_fn(|c| v[r][c]));
                    let lj = matched_eigenvalues(&axes, &eigen[j as usize])[k][k];
                    (0.5 * (lj - l[k]) / dot(d, &axis).abs()).abs()
                })
                .collect();
            (!ratios.is_empty()).then(|| (ratios.iter().sum::<f64>() / ratios.len() as f64).exp())
        })
        .collect()
}

/// Rounds of fitting along a layer (see [`InputTargets`]) per round across it.
const ALONG_PER_PASS: usize = 2;

/// The regularised log G at offset 0 from neighbours at offsets `local`
/// (element `id(i)` at `local[i]`, in `dims` coordinates). The fitted tensor
/// gives the axes; its eigenvalues are not used: where the axes turn (a
/// layer around a cylinder) a mean of tensors mixes the thin direction with
/// the long one and thickens the layer pass after pass. Each axis's
/// log-length is fitted instead from the neighbours' own eigenvalues of
/// their axis nearest to it.
fn fit_log_metric(
    local: &[Vec3],
    dims: usize,
    id: impl Fn(usize) -> usize,
    vals: &[Mat3],
    eigen: &[(Vec3, Mat3)],
) -> Mat3 {
    let (_, axes) = sym_eigen(&affine_fit(local, dims, |i| vals[id(i)]));
    let lengths = affine_fit(local, dims, |i| matched_eigenvalues(&axes, &eigen[id(i)]));
    std::array::from_fn(|r| std::array::from_fn(|c| (0..3).map(|k| axes[r][k] * lengths[k][k] * axes[c][k]).sum()))
}

/// The eigenvalues of `eigen` (values, vectors as columns) in the order of
/// the columns of `axes`, each axis taking the eigenvector most parallel to
/// it (greedily, the best-aligned pair first), as a diagonal matrix.
fn matched_eigenvalues(axes: &Mat3, eigen: &(Vec3, Mat3)) -> Mat3 {
    let (l, v) = eigen;
    let mut out = [[0.0; 3]; 3];
    let (mut axis_used, mut vec_used) = ([false; 3], [false; 3]);
    for _ in 0..3 {
        let mut best = (0, 0, -1.0);
        for a in (0..3).filter(|&a| !axis_used[a]) {
            for b in (0..3).filter(|&b| !vec_used[b]) {
                let dot = (0..3).map(|i| axes[i][a] * v[i][b]).sum::<f64>().abs();
                if dot > best.2 {
                    best = (a, b, dot);
                }
            }
        }
        let (a, b, _) = best;
        axis_used[a] = true;
        vec_used[b] = true;
        out[a][a] = l[b];
    }
    out
}

/// The least-squares affine fit of `vals` over the elements `nb` (centroids
/// relative to element e's), evaluated at e's centroid; the plain mean where
/// the centroids do not span the dimension.
#[cfg(test)]
fn affine_fit_at(e: usize, nb: &[u32], centroid: &[Vec3], vals: &[Mat3], n: usize) -> Mat3 {
    let eigen: Vec<(Vec3, Mat3)> = vals.iter().map(sym_eigen).collect();
    let local = logical_offsets(e, nb, centroid, &quarters(&eigen), &eigen, n);
    affine_fit(&local, n, |i| vals[nb[i] as usize])
}

/// Offsets of the neighbours `nb` from element e, close to offsets in the
/// mesh's logical index space, where a geometric layer's log G is linear
/// (also where its growth makes it curved in physical space) so that the
/// fit reproduces it. Each centroid offset is measured in the metric halfway
/// (log-Euclidean) between the two elements and turned back by half the
/// rotation between their most distinct axes (a layer's normal): around a
/// cylinder the chords to the neighbours along the layer tilt toward the
/// wall, and without the turn they read as cells nearer the wall and thicken
/// the layer pass after pass. The turn fades out as e's stretching does
/// (full from an aspect of 2), where axes mean nothing.
///
/// `quarter[e]` is exp(-log G_e / 4) (see [`quarters`]): the halfway
/// metric's exp(-(log G_e + log G_j) / 4) is taken as the symmetric product
/// of the two, exact where the axes agree and without an eigen
/// decomposition per pair (a tetrahedron has about 100 neighbours).
fn logical_offsets(
    e: usize,
    nb: &[u32],
    centroid: &[Vec3],
    quarter: &[Mat3],
    eigen: &[(Vec3, Mat3)],
    n: usize,
) -> Vec<Vec3> {
    let ce = centroid[e];
    let axis = distinct_axis(&eigen[e], n);
    nb.iter()
        .map(|&j| {
            let j = j as usize;
            let d = sub(&centroid[j], &ce);
            let (ab, ba) = (mul(&quarter[e], &quarter[j]), mul(&quarter[j], &quarter[e]));
            let m: Mat3 = std::array::from_fn(|r| std::array::from_fn(|s| 0.5 * (ab[r][s] + ba[r][s])));
            let md: Vec3 = std::array::from_fn(|r| (0..n).map(|s| m[r][s] * d[s]).sum());
            match axis {
                Some((a, weight)) if j != e => {
                    let (_, vj) = &eigen[j];
                    let (mut best, mut dot) = ([0.0; 3], 0.0f64);
                    for b in 0..3 {
                        let u: Vec3 = [vj[0][b], vj[1][b], vj[2][b]];
                        let c = (0..3).map(|i| a[i] * u[i]).sum::<f64>();
                        if c.abs() > dot.abs() {
                            (best, dot) = (u, c);
                        }
                    }
                    let u = best.map(|x| x * dot.signum());
                    // turn md by minus half the (weighted) rotation taking a to u
                    let axis = crate::metric::mat3::cross(&a, &u);
                    let s = axis.iter().map(|x| x * x).sum::<f64>().sqrt();
                    if s < 1e-12 {
                        return md;
                    }
                    let angle = -0.5 * weight * s.atan2(dot.abs());
                    rotate(&md, &axis.map(|x| x / s), angle)
                }
                _ => md,
            }
        })
        .collect()
}

/// The unit eigenvector of a stretched element's log G whose eigenvalue is
/// farthest from the others (in 2D among the in-plane ones), with the
/// weight of its transport: 0 for an isotropic element, 1 from an aspect
/// of 2 (a log-eigenvalue gap of ln 4). `None` when isotropic.
fn distinct_axis(eigen: &(Vec3, Mat3), n: usize) -> Option<(Vec3, f64)> {
    let (l, v) = eigen;
    let col = |k: usize| -> Vec3 { [v[0][k], v[1][k], v[2][k]] };
    // in 2D the z axis carries element_metrics' 1 and does not count
    let axes: Vec<usize> = (0..3).filter(|&k| n == 3 || col(k)[2].abs() < 0.5).collect();
    let gap = |k: usize| {
        axes.iter()
            .filter(|&&b| b != k)
            .map(|&b| (l[k] - l[b]).abs())
            .fold(f64::INFINITY, f64::min)
    };
    let k = *axes.iter().max_by(|&&a, &&b| gap(a).total_cmp(&gap(b)))?;
    let weight = (gap(k) / 4f64.ln()).min(1.0);
    (weight > 0.0 && weight.is_finite()).then(|| (col(k), weight))
}

/// `x` turned by `angle` about the unit `axis` (Rodrigues).
fn rotate(x: &Vec3, axis: &Vec3, angle: f64) -> Vec3 {
    let (s, c) = angle.sin_cos();
    let kx = crate::metric::mat3::cross(axis, x);
    let kd = (0..3).map(|i| axis[i] * x[i]).sum::<f64>();
    std::array::from_fn(|i| x[i] * c + kx[i] * s + axis[i] * kd * (1.0 - c))
}

/// The least-squares affine fit of `value(i)` over neighbours at the
/// offsets `local[i]`, evaluated at offset 0; the plain mean where the
/// offsets do not span the dimension.
fn affine_fit(local: &[Vec3], n: usize, value: impl Fn(usize) -> Mat3) -> Mat3 {
    let k = n + 1;
    let mut m = [[0.0f64; 4]; 4];
    let mut rhs = [[[0.0f64; 3]; 3]; 4];
    // lengths relative to the neighbourhood's spread keep the system scaled
    let spread = local
        .iter()
        .flat_map(|d| d.iter().take(n))
        .fold(0.0f64, |a, x| a.max(x.abs()));
    let spread = if spread > 0.0 && spread.is_finite() {
        spread
    } else {
        1.0
    };
    for (i, d) in local.iter().enumerate() {
        let vj = value(i);
        let phi: [f64; 4] = std::array::from_fn(|i| {
            if i == 0 {
                1.0
            } else if i <= n {
                d[i - 1] / spread
            } else {
                0.0
            }
        });
        for a in 0..k {
            for b in 0..k {
                m[a][b] += phi[a] * phi[b];
            }
            for r in 0..3 {
                for s in 0..3 {
                    rhs[a][r][s] += phi[a] * vj[r][s];
                }
            }
        }
    }
    // the value at the centroid is the first unknown: solve M c = rhs by
    // Gaussian elimination with partial pivoting
    let count = local.len() as f64;
    let mean = rhs[0].map(|r| r.map(|x| x / count));
    let scale = m[0][0];
    for col in 0..k {
        let piv = (col..k)
            .max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))
            .unwrap();
        if !(m[piv][col].abs() > 1e-8 * scale) {
            return mean;
        }
        m.swap(col, piv);
        rhs.swap(col, piv);
        for row in 0..k {
            if row != col {
                let f = m[row][col] / m[col][col];
                for c2 in col..k {
                    m[row][c2] -= f * m[col][c2];
                }
                for r in 0..3 {
                    for s in 0..3 {
                        rhs[row][r][s] -= f * rhs[col][r][s];
                    }
                }
            }
        }
    }
    let out = rhs[0].map(|r| r.map(|x| x / m[0][0]));
    if out.iter().flatten().all(|x| x.is_finite()) {
        out
    } else {
        mean
    }
}

/// Per element, the ratio of its G's largest to smallest principal length
/// (sqrt of the eigenvalue ratio): 1 for an ideal element's affine image
/// under a scaled rotation.
pub fn element_aspects(g: &[Mat3], n: usize) -> Vec<f64> {
    g.par_iter().map(|m| aspect(&sym_eigen(m).0, n)).collect()
}

/// The aspect of [`element_aspects`] from G's eigenvalues `l`.
fn aspect(l: &Vec3, n: usize) -> f64 {
    let (hi, lo) = in_plane(l, n).fold((f64::MIN, f64::MAX), |(hi, lo), x| (hi.max(x), lo.min(x)));
    if lo > 0.0 { (hi / lo).sqrt() } else { f64::INFINITY }
}

/// The eigenvalues `l` of a G that measure the element: all three in 3D; in
/// 2D the two left when the one nearest 1 (the z axis that
/// [`element_metrics`] sets to 1) is dropped.
fn in_plane(l: &Vec3, n: usize) -> impl Iterator<Item = f64> + '_ {
    let z = (n == 2).then(|| {
        (0..3)
            .min_by(|&a, &b| (l[a] - 1.0).abs().total_cmp(&(l[b] - 1.0).abs()))
            .unwrap()
    });
    (0..3).filter(move |&k| Some(k) != z).map(move |k| l[k])
}

/// How the first cells on the walls changed between `before` and `after`:
/// for every skin vertex whose elements include a stretched one (aspect
/// [`ANISOTROPIC_ASPECT`] or more at `before`), the free vertex of those
/// elements nearest to it across the layer (at most twice the element's
/// thickness away) is its first-layer vertex, and the height is the
/// distance between the two. `None` where no wall has a stretched layer.
pub fn first_layer_change(mesh: &Mesh, before: &[Vec3], after: &[Vec3]) -> Option<LayerChange> {
    let ve = vertex_elements(mesh);
    first_layer_change_on_skin(
        mesh,
        &crate::mesh::topology::skin_vertices_with(mesh, &ve),
        &ve,
        before,
        after,
    )
}

/// [`first_layer_change`] with the mesh's skin vertices and
/// [`vertex_elements`] at hand.
pub fn first_layer_change_on_skin(
    mesh: &Mesh,
    skin: &[bool],
    ve: &Csr,
    before: &[Vec3],
    after: &[Vec3],
) -> Option<LayerChange> {
    let n = mesh.dim();
    // (aspect, thickness) of the elements at the walls, the only ones read:
    // thickness is the smallest principal length (in 2D among the in-plane axes)
    let pts = crate::metric::oriented(mesh, before);
    let at_wall: Vec<bool> = (0..mesh.num_elements())
        .into_par_iter()
        .map(|e| mesh.element(e).iter().any(|&v| skin[v as usize]))
        .collect();
    let shape: Vec<(f64, f64)> = (0..mesh.num_elements())
        .into_par_iter()
        .map(|e| {
            if !at_wall[e] {
                return Ok((f64::NAN, f64::NAN));
            }
            let (l, v) = sym_eigen(&element_metric(mesh, &pts, false, e)?);
            let thickness = (0..3)
                .filter(|&k| n == 3 || v[2][k].abs() < 0.5)
                .map(|k| l[k])
                .fold(f64::INFINITY, f64::min)
                .max(0.0)
                .sqrt();
            Ok((aspect(&l, n), thickness))
        })
        .collect::<Result<_>>()
        .ok()?;
    let (aspects, thickness): (Vec<f64>, Vec<f64>) = shape.into_iter().unzip();
    let dist = |p: &[Vec3], a: usize, b: usize| sub(&p[a], &p[b]).iter().map(|x| x * x).sum::<f64>().sqrt();
    let mut ratios: Vec<f64> = (0..mesh.num_points())
        .into_par_iter()
        .filter(|&w| skin[w])
        .filter_map(|w| {
            // across the layer from the wall: an edge about as long as the
            // stretched element is thin (a side wall's neighbours lie along it)
            ve.of(w)
                .iter()
                .map(|&e| e as usize)
                .filter(|&e| aspects[e] >= ANISOTROPIC_ASPECT)
                .flat_map(|e| mesh.element(e).iter().map(move |&u| (u as usize, e)))
                .filter(|&(u, e)| !skin[u] && !mesh.is_fixed(u) && dist(before, u, w) <= 2.0 * thickness[e])
                .map(|(u, _)| u)
                .min_by(|&a, &b| dist(before, a, w).total_cmp(&dist(before, b, w)))
                .map(|u| dist(after, u, w) / dist(before, u, w))
        })
        .filter(|r| r.is_finite())
        .collect();
    if ratios.is_empty() {
        return None;
    }
    ratios.par_sort_unstable_by(f64::total_cmp);
    let mut changes: Vec<f64> = ratios.par_iter().map(|r| (r - 1.0).abs()).collect();
    changes.par_sort_unstable_by(f64::total_cmp);
    Some(LayerChange {
        vertices: ratios.len(),
        median_ratio: ratios[ratios.len() / 2],
        min_ratio: ratios[0],
        max_ratio: *ratios.last().unwrap(),
        median_change: changes[changes.len() / 2],
    })
}

/// What [`first_layer_change`] measured: the first-layer heights after over
/// before, at `vertices` wall vertices.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LayerChange {
    /// Wall vertices measured.
    pub vertices: usize,
    /// The median of after / before.
    pub median_ratio: f64,
    /// The smallest after / before.
    pub min_ratio: f64,
    /// The largest after / before.
    pub max_ratio: f64,
    /// The median of |after / before - 1|.
    pub median_change: f64,
}

impl std::fmt::Display for LayerChange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "first-layer height on the walls, after / before ({} wall vertices with a stretched layer): median {:.3} (median change {:.1}%), range {:.3} to {:.3}",
            self.vertices,
            self.median_ratio,
            100.0 * self.median_change,
            self.min_ratio,
            self.max_ratio
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::corner::ideal_corner;

    /// Numbers in [-0.5, 0.5) from an xorshift generator.
    fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        }
    }

    #[test]
    fn reference_elements_start_at_the_ideal_corner_and_have_positive_corners() {
        for kind in ElementKind::ALL {
            let Some(r) = reference_points(kind) else { continue };
            let n = kind.dim();
            let w = corner_matrix(r, &kind.corners()[0], n);
            let id = ideal_corner(kind);
            for i in 0..n {
                for j in 0..n {
                    assert!((w[i][j] - id[i][j]).abs() < 1e-15, "{kind}");
                }
            }
            for c in kind.corners() {
                let a = corner_matrix(r, c, n);
                assert!(det(&a) > 0.1, "{kind} corner {c:?}");
                // every corner of the ideal element is ideal: eta = 1
                let eta = crate::metric::corner::corner_eta(&a, &crate::metric::mat3::inverse(&id).unwrap(), n);
                if kind.is_simplex() || matches!(kind, ElementKind::Quadrilateral | ElementKind::Hexahedron) {
                    assert!((eta.unwrap() - 1.0).abs() < 1e-12, "{kind} corner {c:?}: {eta:?}");
                }
            }
        }
    }

    #[test]
    fn closed_form_eigenvalues_match_the_jacobi_ones() {
        let mut r = uniform(0x2545_f491_4f6c_dd1d);
        let sorted = |mut l: Vec3| {
            l.sort_by(f64::total_cmp);
            l
        };
        let mut cases: Vec<Mat3> = vec![
            IDENTITY,
            [[2.0, 0.0, 0.0], [0.0, 5.0, 0.0], [0.0, 0.0, 1.0]],
            // a stretched 2D element's G (z set to 1), and a near-degenerate pair
            [[9.0, 3.0, 0.0], [3.0, 1.5, 0.0], [0.0, 0.0, 1.0]],
            [[1.0, 1e-9, 0.0], [1e-9, 1.0, 0.0], [0.0, 0.0, 3.0]],
        ];
        for k in 0..2000 {
            // A A^T + shift: symmetric positive definite, aspects up to about 1e4
            let a: Mat3 = std::array::from_fn(|_| std::array::from_fn(|_| r()));
            let mut m = mul(&a, &transpose(&a));
            for (i, row) in m.iter_mut().enumerate() {
                row[i] += 1e-8 * (k % 7) as f64;
            }
            cases.push(m.map(|row| row.map(|x| x * 1e3f64.powi(k % 5 - 2))));
        }
        for m in &cases {
            let (want, got) = (sorted(sym_eigen(m).0), sorted(sym_eigenvalues(m)));
            let scale = want[2].abs().max(f64::MIN_POSITIVE);
            for i in 0..3 {
                assert!((want[i] - got[i]).abs() <= 1e-8 * scale, "{m:?}: {want:?} vs {got:?}");
            }
            // the aspect the gate reads
            for n in [2, 3] {
                let (a, b) = (aspect(&sym_eigen(m).0, n), aspect(&sym_eigenvalues(m), n));
                assert!(a == b || (a - b).abs() <= 1e-6 * a, "{m:?} n = {n}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn the_closed_form_log_matches_the_jacobi_one() {
        let mut r = uniform(0x9e37_79b9_7f4a_7c15);
        let mut cases: Vec<Mat3> = vec![
            IDENTITY,
            [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0 + 1e-12]],
            [[9.0, 3.0, 0.0], [3.0, 1.5, 0.0], [0.0, 0.0, 1.0]],
            [[1.0, 1e-9, 0.0], [1e-9, 1.0, 0.0], [0.0, 0.0, 3.0]],
            // flat (aspect 1e4) and singular: the Jacobi fallback
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1e-8]],
            [[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        ];
        for k in 0..3000 {
            let a: Mat3 = std::array::from_fn(|_| std::array::from_fn(|_| r()));
            let mut m = mul(&a, &transpose(&a));
            for (i, row) in m.iter_mut().enumerate() {
                row[i] += [1e-3, 0.05, 0.5][k % 3];
            }
            cases.push(m.map(|row| row.map(|x| x * 1e3f64.powi(k as i32 % 5 - 2))));
        }
        for m in &cases {
            for n in [2, 3] {
                let mut g = *m;
                if n == 2 {
                    // element_metrics' 2D form: z alone, 1
                    for k in 0..2 {
                        g[2][k] = 0.0;
                        g[k][2] = 0.0;
                    }
                    g[2][2] = 1.0;
                }
                let want = sym_fn(&g, |l| l.max(f64::MIN_POSITIVE).ln());
                let got = sym_log(&g, &sym_eigenvalues_in(&g, n), n);
                let scale = want.iter().flatten().fold(1.0f64, |s, x| s.max(x.abs()));
                for i in 0..3 {
                    for j in 0..3 {
                        assert!(
                            (want[i][j] - got[i][j]).abs() <= 1e-8 * scale,
                            "n = {n}, {g:?}: {want:?} vs {got:?}"
                        );
                    }
                }
                // and its eigenvalues are the eigenvalues' logs
                let mut la = sym_eigenvalues_in(&got, n).to_vec();
                let mut lb = sym_eigenvalues_in(&g, n)
                    .map(|x| x.max(f64::MIN_POSITIVE).ln())
                    .to_vec();
                la.sort_by(f64::total_cmp);
                lb.sort_by(f64::total_cmp);
                if sym_eigenvalues_in(&g, n).iter().all(|&x| x > 1e-6 * scale.exp()) {
                    for (a, b) in la.iter().zip(&lb) {
                        assert!((a - b).abs() <= 1e-7 * scale, "n = {n}, {g:?}: {la:?} vs {lb:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn eigen_decomposition_reconstructs() {
        let m = [[4.0, 1.0, 0.5], [1.0, 3.0, -0.2], [0.5, -0.2, 0.2]];
        let back = sym_fn(&m, |l| l);
        for i in 0..3 {
            for j in 0..3 {
                assert!((back[i][j] - m[i][j]).abs() < 1e-13);
            }
        }
        let r = sym_fn(&m, |l| l.abs().sqrt());
        let (l, _) = sym_eigen(&m);
        assert!(l.iter().all(|x| *x > 0.0));
        let sq = mul(&r, &r);
        for i in 0..3 {
            for j in 0..3 {
                assert!((sq[i][j] - m[i][j]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn affine_fit_reproduces_a_geometric_layer_at_the_wall_and_inside() {
        // two columns of unit width, rows of height 0.01 * 1.5^j: log G is
        // linear in the row index but curved in y, and the fit in the
        // halfway metric gives every element back its own log G
        let rows = 6;
        let h: Vec<f64> = (0..rows).map(|j| 0.01 * 1.5f64.powi(j)).collect();
        let mut centroid = Vec::new();
        let mut vals = Vec::new();
        let mut y = 0.0;
        for hj in &h {
            for col in 0..2 {
                centroid.push([col as f64 + 0.5, y + 0.5 * hj, 0.0]);
                vals.push([[0.0, 0.0, 0.0], [0.0, 2.0 * hj.ln(), 0.0], [0.0, 0.0, 0.0]]);
            }
            y += hj;
        }
        for (e, rows_in) in [(0usize, 0..2u32), (5, 1..4), (10, 4..6)] {
            let nb: Vec<u32> = rows_in.flat_map(|j| [2 * j, 2 * j + 1]).collect();
            let fit = affine_fit_at(e, &nb, &centroid, &vals, 2);
            for r in 0..3 {
                for c in 0..3 {
                    assert!(
                        (fit[r][c] - vals[e][r][c]).abs() < 1e-12,
                        "element {e}: {fit:?} vs {:?}",
                        vals[e]
                    );
                }
            }
        }
    }
}

/// What a mesh was built to have, as the default target choice reads it.
/// Stretching that was built on purpose (boundary layers, anisotropic
/// refinement) is coherent: neighbours are stretched alike, so it survives
/// the regularisation of [`InputTargets`]; a distorted or perturbed
/// isotropic mesh's stretching is noise that the regularisation averages
/// away. The intent is read from the regularised metric.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Intent {
    /// Share of the (non-inverted) elements whose regularised aspect
    /// (`element_aspects` of the `Input` targets' G) is at least [`ANISOTROPIC_ASPECT`].
    pub anisotropic_share: f64,
    /// The median and the largest regularised element aspect.
    pub median_aspect: f64,
    /// The largest regularised element aspect.
    pub max_aspect: f64,
    /// The same share for the raw (unregularised) aspects.
    pub raw_share: f64,
    /// The 99th over the 1st percentile of the regularised elements'
    /// thicknesses (their smallest principal length): a boundary layer or a
    /// graded mesh spans decades, a uniformly stretched one does not.
    pub thickness_range: f64,
    /// The median over the stretched elements of their thickness ratio to
    /// the next cell along their thin axis: a boundary layer's growth rate
    /// (Gmsh's default 1.1 to 1.5), about 1 for a mesh merely stretched.
    pub growth: f64,
}

/// An element stretched at least this much after regularisation was made so on purpose.
pub const ANISOTROPIC_ASPECT: f64 = 4.0;
/// The share of such elements above which a mesh is smoothed towards its
/// own (input) targets by default.
pub const ANISOTROPIC_SHARE: f64 = 0.02;

/// Thresholds of [`Intent::keeps_input`]. Measured (after the detection's
/// regularisation): Gmsh channels with a BoundaryLayer field (growth 1.25)
/// read 15% to 31% stretched, a median aspect of 1.06 to 1.26 and a growth
/// of 1.248; Mesquite's stretched test meshes read cub_fru 65% stretched,
/// median aspect 4.6, growth 1.16, span 19x; shest_grid32 4.9%, median
/// 2.3, growth 1.5 (from its few stretched cells); shashkov and
/// shashkov_quad 96% to 97%, median 10, growth 1.000; they are smoothed
/// toward the ideal shape as before.
pub const LAYER_GROWTH: f64 = 1.05;
/// Below this median aspect the mesh's bulk is isotropic and a graded,
/// stretched minority is a layer.
pub const ISOTROPIC_BULK: f64 = 2.0;
/// A mesh stretched throughout (at least this share of stretched cells)...
pub const STRETCHED_THROUGHOUT: f64 = 0.25;
/// ...keeps its stretching when it grows at least this much per cell, or
/// spans at least [`GRADED_RANGE`] in thickness: wall grading.
pub const STRONG_GROWTH: f64 = 1.25;
/// The alternative to [`STRONG_GROWTH`]: a stretched mesh whose thickest cell is at least this many times its thinnest is wall-graded.
pub const GRADED_RANGE: f64 = 100.0;

/// Rounds of regularisation the detection reads the mesh through: fewer than
/// the targets' own, enough to average a perturbation's noise away.
const INTENT_PASSES: usize = 2;

impl Intent {
    /// The mesh's stretching was built on purpose: keep it (input targets).
    /// Coherent stretched cells whose thickness grows from cell to cell, and
    /// either a bulk that is isotropic (a boundary layer on walls) or, in a
    /// mesh stretched throughout, a growth or a thickness span that only
    /// wall grading produces; merely stretched or distorted meshes have
    /// none of these.
    pub fn keeps_input(&self) -> bool {
        let wall_graded = self.anisotropic_share >= STRETCHED_THROUGHOUT
            && (self.growth >= STRONG_GROWTH || self.thickness_range >= GRADED_RANGE);
        self.anisotropic_share >= ANISOTROPIC_SHARE
            && self.growth >= LAYER_GROWTH
            && (self.median_aspect < ISOTROPIC_BULK || wall_graded)
    }

    /// One line for a user.
    pub fn describe(&self) -> String {
        format!(
            "{:.1}% of the elements are stretched {ANISOTROPIC_ASPECT}:1 or more coherently with their neighbours (median aspect {:.2}, largest {:.3e}; {:.1}% before regularisation; thicknesses span {:.1}x, growing {:.3} per cell across the stretching)",
            100.0 * self.anisotropic_share,
            self.median_aspect,
            self.max_aspect,
            100.0 * self.raw_share,
            self.thickness_range,
            self.growth
        )
    }
}

/// The share of elements stretched [`ANISOTROPIC_ASPECT`]:1 or more as they
/// are, before any regularisation: a cheap bound for the default's
/// decision, since averaging neighbours does not make a mesh more coherently
/// stretched than its elements are.
pub fn raw_anisotropic_share(mesh: &Mesh, points: &[Vec3]) -> Result<f64> {
    Ok(Shapes::of(mesh, points)?.raw_share(mesh.dim()))
}

/// Each element's G (see [`element_metrics`]) at oriented points, computed
/// once for the default target's tests.
pub struct Shapes<'a> {
    pts: Cow<'a, [Vec3]>,
    g: Vec<Mat3>,
}

impl<'a> Shapes<'a> {
    /// The shapes of `mesh` at `points`.
    pub fn of(mesh: &Mesh, points: &'a [Vec3]) -> Result<Shapes<'a>> {
        let pts = crate::metric::oriented(mesh, points);
        let g = element_metrics(mesh, &pts, false)?;
        Ok(Shapes { pts, g })
    }

    /// [`raw_anisotropic_share`], from closed-form eigenvalues: the gate
    /// every default smooth passes through, where a threshold on the aspect
    /// needs no eigenvectors and no last bits.
    pub fn raw_share(&self, n: usize) -> f64 {
        let stretched = self
            .g
            .par_iter()
            .filter(|m| aspect(&sym_eigenvalues(m), n) >= ANISOTROPIC_ASPECT)
            .count();
        stretched as f64 / self.g.len().max(1) as f64
    }
}

/// The eigenvalues of a symmetric 3x3 matrix in closed form (the
/// trigonometric solution of the characteristic cubic), in no set order:
/// about ten times cheaper than [`sym_eigen`], to a relative accuracy of
/// about 1e-8 where two eigenvalues nearly coincide.
fn sym_eigenvalues(m: &Mat3) -> Vec3 {
    let off = m[0][1] * m[0][1] + m[0][2] * m[0][2] + m[1][2] * m[1][2];
    if off == 0.0 {
        return [m[0][0], m[1][1], m[2][2]];
    }
    let q = (m[0][0] + m[1][1] + m[2][2]) / 3.0;
    let d = [m[0][0] - q, m[1][1] - q, m[2][2] - q];
    let p = ((d[0] * d[0] + d[1] * d[1] + d[2] * d[2] + 2.0 * off) / 6.0).sqrt();
    if p == 0.0 {
        return [q; 3];
    }
    let b = |i: usize, j: usize| if i == j { d[i] / p } else { m[i][j] / p };
    let det = b(0, 0) * (b(1, 1) * b(2, 2) - b(1, 2) * b(2, 1)) - b(0, 1) * (b(1, 0) * b(2, 2) - b(1, 2) * b(2, 0))
        + b(0, 2) * (b(1, 0) * b(2, 1) - b(1, 1) * b(2, 0));
    let phi = (det / 2.0).clamp(-1.0, 1.0).acos() / 3.0;
    let hi = q + 2.0 * p * phi.cos();
    let lo = q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos();
    [hi, 3.0 * q - hi - lo, lo]
}

/// [`sym_eigenvalues`] of a G or a log G of [`element_metrics`]: in 2D the
/// in-plane block's pair in closed form and z's own entry, exactly.
fn sym_eigenvalues_in(m: &Mat3, n: usize) -> Vec3 {
    if n == 2 {
        let mid = 0.5 * (m[0][0] + m[1][1]);
        let r = (0.25 * (m[0][0] - m[1][1]).powi(2) + m[0][1] * m[0][1]).sqrt();
        [mid + r, mid - r, m[2][2]]
    } else {
        sym_eigenvalues(m)
    }
}

/// log G of a G of [`element_metrics`] with eigenvalues `l`
/// ([`sym_eigenvalues_in`]), by Newton's divided differences of the log on
/// the eigenvalues: log G = ln l1 I + d12 (G - l1 I) + d123 (G - l1 I)(G - l2 I),
/// accurate where the eigenvalues are within a thousandth of each other or
/// coincide. Flatter elements (where closed-form eigenvalues lose the small
/// ones' digits) and singular ones take the Jacobi decomposition.
fn sym_log(m: &Mat3, l: &Vec3, n: usize) -> Mat3 {
    let mut l: Vec<f64> = l[..n].to_vec();
    l.sort_by(|a, b| b.total_cmp(a));
    if !(l[n - 1] > 1e-6 * l[0]) || !l[0].is_finite() {
        return sym_fn(m, |x| x.max(f64::MIN_POSITIVE).ln());
    }
    // ln(a / b) / (a - b), stable as a -> b
    let dd = |a: f64, b: f64| {
        let t = (a - b) / b;
        if t == 0.0 { 1.0 / b } else { t.ln_1p() / t / b }
    };
    let shifted =
        |s: f64| -> Mat3 { std::array::from_fn(|i| std::array::from_fn(|j| m[i][j] - if i == j { s } else { 0.0 })) };
    let (a, b) = (shifted(l[0]), shifted(l[1]));
    let d12 = dd(l[0], l[1]);
    let d123 = if n == 3 {
        let gap = l[0] - l[2];
        if gap > 1e-9 * l[0] {
            (d12 - dd(l[1], l[2])) / gap
        } else {
            // f''/2 at the (triple) eigenvalue
            -0.5 / (l[1] * l[1])
        }
    } else {
        0.0
    };
    let ab = mul(&a, &b);
    let mut out: Mat3 = std::array::from_fn(|i| {
        std::array::from_fn(|j| if i == j { l[0].ln() } else { 0.0 } + d12 * a[i][j] + d123 * ab[i][j])
    });
    if n == 2 {
        // z's 1, exactly: its log is 0
        for k in 0..3 {
            out[2][k] = 0.0;
            out[k][2] = 0.0;
        }
    }
    out
}

/// The [`Intent`] of `mesh` at `points` (inverted elements are left out).
pub fn intent(mesh: &Mesh, points: &[Vec3]) -> Result<Intent> {
    Ok(intent_of(mesh, &Shapes::of(mesh, points)?))
}

/// [`intent`] from the shapes at hand. G is regularised in the log domain:
/// exp and log keep eigenvectors, so one decomposition of each of log G and
/// its regularised mean serves every measure below.
pub fn intent_of(mesh: &Mesh, shapes: &Shapes<'_>) -> Intent {
    let n = mesh.dim();
    let pts = &shapes.pts;
    // closed forms where they are accurate: this runs on every default smooth
    let raw: Vec<Vec3> = shapes.g.par_iter().map(|m| sym_eigenvalues_in(m, n)).collect();
    let logs: Vec<Mat3> = shapes.g.par_iter().zip(&raw).map(|(m, l)| sym_log(m, l, n)).collect();
    let nb = Neighbours::of(mesh);
    let smoothed_logs = mean_regularise(mesh, &nb, logs, INTENT_PASSES);
    let log_values: Vec<Vec3> = smoothed_logs.par_iter().map(|m| sym_eigenvalues_in(m, n)).collect();
    // the regularised G's eigenvalues: exp of its log's
    let smooth: Vec<Vec3> = log_values.par_iter().map(|l| l.map(f64::exp)).collect();
    // only an element whose log spread reaches the stretch has a growth
    // (layer_growths), and only those need eigenvectors
    // (read on G's eigenvalues, where 2D's z is the 1 that `aspect` drops;
    // closed forms are good to about 1e-8 of log G's largest)
    let stretched = smooth.par_iter().zip(&log_values).any(|(l, logs)| {
        let slack = 1e-6 * logs.iter().fold(1.0f64, |s, x| s.max(x.abs()));
        aspect(l, n).ln() >= ANISOTROPIC_ASPECT.ln() - slack
    });
    let mut growths = if stretched {
        let log_eigen: Vec<(Vec3, Mat3)> = smoothed_logs.par_iter().map(sym_eigen).collect();
        layer_growths(mesh, pts, &nb, &log_eigen)
    } else {
        Vec::new()
    };
    growths.par_sort_unstable_by(f64::total_cmp);
    let growth = growths.get(growths.len() / 2).copied().unwrap_or(1.0);
    let valid: Vec<bool> = (0..mesh.num_elements())
        .into_par_iter()
        .map(|e| crate::metric::element_min_det(mesh, pts, e) > 0.0)
        .collect();
    let pick = |l: &[Vec3]| -> Vec<f64> {
        let mut a: Vec<f64> = l
            .par_iter()
            .zip(&valid)
            .map(|(l, &ok)| if ok { aspect(l, n) } else { f64::NAN })
            .filter(|a| a.is_finite())
            .collect();
        a.par_sort_unstable_by(f64::total_cmp);
        a
    };
    let share = |a: &[f64]| a.iter().filter(|&&x| x >= ANISOTROPIC_ASPECT).count() as f64 / a.len().max(1) as f64;
    let (raw, reg) = (pick(&raw), pick(&smooth));
    if reg.is_empty() {
        return Intent {
            anisotropic_share: 0.0,
            median_aspect: 1.0,
            max_aspect: 1.0,
            raw_share: 0.0,
            thickness_range: 1.0,
            growth: 1.0,
        };
    }
    Intent {
        anisotropic_share: share(&reg),
        median_aspect: reg[reg.len() / 2],
        max_aspect: *reg.last().unwrap(),
        raw_share: share(&raw),
        growth,
        thickness_range: {
            let mut sz: Vec<f64> = smooth
                .par_iter()
                .zip(&valid)
                .filter(|&(_, &ok)| ok)
                .map(|(l, _)| in_plane(l, n).fold(f64::MAX, f64::min).max(0.0).sqrt())
                .collect();
            sz.par_sort_unstable_by(f64::total_cmp);
            sz[sz.len() * 99 / 100] / sz[sz.len() / 100].max(f64::MIN_POSITIVE)
        },
    }
}
