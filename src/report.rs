//! Quality reports: the columns of the papers' mesh tables (inverse mean
//! ratio and element volume: avg, median, sigma_n, max, max:min), an eta
//! histogram, the worst elements, and displacement statistics.

use std::fmt;

use rayon::prelude::*;

use crate::mesh::topology::{skin_vertices, with_user_fixed};
use crate::mesh::{ElementKind, Mesh};

/// Summary of a set of values. `sigma_n` is the population standard deviation
/// divided by the mean, as in the papers' tables. Empty sets give NaN (null in JSON).
#[derive(serde::Serialize, Clone, Copy, Debug, PartialEq)]
pub struct Stats {
    /// Number of values.
    pub count: usize,
    /// Mean.
    pub avg: f64,
    /// Median.
    pub median: f64,
    /// Population standard deviation divided by the mean.
    pub sigma_n: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// max / min; infinite when min <= 0 (useful for volumes only).
    pub max_min_ratio: f64,
}

/// The sum of `f` over `values` in parallel, the same to the last bit on
/// every run (fixed chunks, summed in order), so reports repeat exactly.
fn chunked_sum(values: &[f64], f: impl Fn(f64) -> f64 + Sync) -> f64 {
    let parts: Vec<f64> = values
        .par_chunks(1 << 14)
        .map(|c| c.iter().map(|&v| f(v)).sum())
        .collect();
    parts.iter().sum()
}

impl Stats {
    /// The statistics of `values`.
    pub fn of(values: &[f64]) -> Stats {
        let n = values.len();
        if n == 0 {
            let nan = f64::NAN;
            return Stats {
                count: 0,
                avg: nan,
                median: nan,
                sigma_n: nan,
                min: nan,
                max: nan,
                max_min_ratio: nan,
            };
        }
        // the middle order statistics by selection, not a sort: reports run
        // on every smooth, over every element of meshes of tens of millions
        let mut scratch = values.to_vec();
        let (left, mid, _) = scratch.select_nth_unstable_by(n / 2, f64::total_cmp);
        let median = if n % 2 == 1 {
            *mid
        } else {
            0.5 * (left.iter().copied().fold(f64::NEG_INFINITY, f64::max) + *mid)
        };
        let avg = chunked_sum(values, |v| v) / n as f64;
        let var = chunked_sum(values, |v| (v - avg).powi(2)) / n as f64;
        let (min, max) = values
            .par_iter()
            .fold(
                || (f64::INFINITY, f64::NEG_INFINITY),
                |(lo, hi), &v| (lo.min(v), hi.max(v)),
            )
            .reduce(
                || (f64::INFINITY, f64::NEG_INFINITY),
                |a, b| (a.0.min(b.0), a.1.max(b.1)),
            );
        Stats {
            count: n,
            avg,
            median,
            sigma_n: var.sqrt() / avg,
            min,
            max,
            max_min_ratio: if min > 0.0 { max / min } else { f64::INFINITY },
        }
    }
}

/// One histogram bin `[lo, hi)`; `hi` is `None` for the open last bin. The
/// first bin also holds values just below 1 from rounding.
#[derive(serde::Serialize, Clone, Debug, PartialEq)]
pub struct Bin {
    /// Lower edge (inclusive).
    pub lo: f64,
    /// Upper edge (exclusive); `None` for the open last bin.
    pub hi: Option<f64>,
    /// Elements in the bin.
    pub count: usize,
}

/// Bin edges of the eta histogram: fine near the optimum 1, coarse in the tail.
pub const ETA_BIN_EDGES: [f64; 9] = [1.0, 1.05, 1.1, 1.2, 1.5, 2.0, 3.0, 5.0, 10.0];

/// One of the worst elements of a report.
#[derive(serde::Serialize, Clone, Debug, PartialEq)]
pub struct Worst {
    /// Element id.
    pub id: usize,
    /// Element kind name.
    pub kind: String,
    /// `None` for an inverted element.
    pub eta: Option<f64>,
    /// Centroid of the element's vertices.
    pub centroid: [f64; 3],
}

/// Mesh quality summary: sizes, eta and volume statistics, inversions, histogram and worst elements.
#[derive(serde::Serialize, Clone, Debug)]
pub struct QualityReport {
    /// Number of vertices.
    pub vertices: usize,
    /// Number of elements.
    pub elements: usize,
    /// Vertices that may move.
    pub free_vertices: usize,
    /// Skin plus user-fixed vertices.
    pub fixed_vertices: usize,
    /// (kind name, count) for each kind present.
    pub kinds: Vec<(String, usize)>,
    /// Dimension of the mesh: 2 or 3.
    pub dim: usize,
    /// A surface mesh: 2D elements in 3D, each measured in its own plane.
    #[serde(default)]
    pub surface: bool,
    /// Inverse mean ratio over the non-inverted elements.
    pub eta: Stats,
    /// Element volume (area in 2D) over all elements; see [`element_volume`].
    pub volume: Stats,
    /// Number of inverted (or degenerate) elements.
    pub inverted: usize,
    /// The first 10 inverted element ids.
    pub inverted_ids: Vec<usize>,
    /// The objective F = mean eta over all elements; `None` if any is inverted.
    pub objective: Option<f64>,
    /// Histogram of eta over `ETA_BIN_EDGES`.
    pub histogram: Vec<Bin>,
    /// The 5 worst elements, inverted ones first, then by decreasing eta.
    pub worst: Vec<Worst>,
}

const WORST: usize = 5;
const INVERTED_IDS: usize = 10;

/// Quality of `mesh` with its vertices at `points` (which may differ from `mesh.points`).
///
/// # Panics
/// If `points` does not have one entry per mesh vertex.
pub fn quality_report(mesh: &Mesh, points: &[[f64; 3]]) -> QualityReport {
    quality_report_on_skin(mesh, points, &skin_vertices(mesh))
}

/// [`quality_report`] with the mesh's [`skin_vertices`] already at hand.
pub fn quality_report_on_skin(mesh: &Mesh, points: &[[f64; 3]], skin: &[bool]) -> QualityReport {
    assert_eq!(points.len(), mesh.num_points(), "one position per mesh vertex");
    let ne = mesh.num_elements();
    // clockwise planar meshes are measured mirrored (centroids below use the real points)
    let measured = crate::metric::oriented(mesh, points);
    // shapes at a size whose determinants neither underflow nor overflow
    let shaped = crate::metric::Measured::new(mesh, points);
    // (eta, volume); eta None when any corner determinant is not positive
    let per_element: Vec<(Option<f64>, f64)> = (0..ne)
        .into_par_iter()
        .map(|e| {
            let min_det = shaped.min_det(mesh, e);
            let eta = shaped.eta(mesh, e).filter(|_| min_det > 0.0);
            (eta, mesh_element_volume(mesh, &measured, e))
        })
        .collect();

    let etas: Vec<f64> = per_element.par_iter().filter_map(|p| p.0).collect();
    let volumes: Vec<f64> = per_element.par_iter().map(|p| p.1).collect();
    let inverted_all: Vec<usize> = (0..ne)
        .into_par_iter()
        .filter(|&e| per_element[e].0.is_none())
        .collect();
    let objective = (inverted_all.is_empty() && ne > 0).then(|| chunked_sum(&etas, |v| v) / ne as f64);

    let mut histogram: Vec<Bin> = ETA_BIN_EDGES
        .iter()
        .enumerate()
        .map(|(i, &lo)| Bin {
            lo,
            hi: ETA_BIN_EDGES.get(i + 1).copied(),
            count: 0,
        })
        .collect();
    let counts = etas
        .par_iter()
        .fold(
            || vec![0; ETA_BIN_EDGES.len()],
            |mut c, &eta| {
                c[ETA_BIN_EDGES[1..].iter().take_while(|&&edge| eta >= edge).count()] += 1;
                c
            },
        )
        .reduce(
            || vec![0; ETA_BIN_EDGES.len()],
            |a, b| a.iter().zip(&b).map(|(x, y)| x + y).collect(),
        );
    for (bin, count) in histogram.iter_mut().zip(counts) {
        bin.count = count;
    }

    let nfixed = with_user_fixed(mesh, skin.to_vec()).iter().filter(|&&f| f).count();
    QualityReport {
        vertices: mesh.num_points(),
        elements: ne,
        free_vertices: mesh.num_points() - nfixed,
        fixed_vertices: nfixed,
        kinds: ElementKind::ALL
            .iter()
            .map(|&k| (k.name().to_string(), mesh.count_kind(k)))
            .filter(|(_, c)| *c > 0)
            .collect(),
        dim: mesh.dim(),
        surface: shaped.is_surface(),
        eta: Stats::of(&etas),
        volume: Stats::of(&volumes),
        inverted: inverted_all.len(),
        inverted_ids: inverted_all.into_iter().take(INVERTED_IDS).collect(),
        objective,
        histogram,
        worst: worst_elements(mesh, points, &per_element),
    }
}

fn gather(mesh: &Mesh, points: &[[f64; 3]], e: usize) -> Vec<[f64; 3]> {
    mesh.element(e).iter().map(|&v| points[v as usize]).collect()
}

fn worst_elements(mesh: &Mesh, points: &[[f64; 3]], per_element: &[(Option<f64>, f64)]) -> Vec<Worst> {
    let badness = |e: usize| per_element[e].0.unwrap_or(f64::INFINITY);
    // a bounded insertion list: one pass, no sort of all elements
    let mut ids: Vec<usize> = Vec::with_capacity(WORST + 1);
    for e in 0..per_element.len() {
        let pos = ids.iter().position(|&w| badness(e) > badness(w)).unwrap_or(ids.len());
        if pos < WORST {
            ids.insert(pos, e);
            ids.truncate(WORST);
        }
    }
    ids.into_iter()
        .map(|id| {
            let x = gather(mesh, points, id);
            let centroid = std::array::from_fn(|i| x.iter().map(|p| p[i]).sum::<f64>() / x.len() as f64);
            Worst {
                id,
                kind: mesh.kinds[id].name().to_string(),
                eta: per_element[id].0,
                centroid,
            }
        })
        .collect()
}

/// Signed volume of an element (area in the xy plane for 2D kinds), positive
/// for a well-oriented element. Exact for the isoparametric (bilinear,
/// trilinear) elements: tets and triangles by their determinant, quads by the
/// shoelace formula, hexahedra by 2x2x2 Gauss quadrature of the trilinear
/// Jacobian, prisms by centroid x 2-point Gauss (the Jacobian determinants are
/// polynomials those rules integrate exactly). A polyhedron's volume needs
/// its faces ([`mesh_element_volume`]): NaN here.
pub fn element_volume(kind: ElementKind, x: &[[f64; 3]]) -> f64 {
    let d = |a: usize, b: usize| -> [f64; 3] { std::array::from_fn(|i| x[b][i] - x[a][i]) };
    match kind {
        ElementKind::Triangle => 0.5 * cross2(&d(0, 1), &d(0, 2)),
        ElementKind::Quadrilateral => 0.5 * (0..4).map(|i| cross2(&x[i], &x[(i + 1) % 4])).sum::<f64>(),
        ElementKind::Tetrahedron => det3(&d(0, 1), &d(0, 2), &d(0, 3)) / 6.0,
        ElementKind::Hexahedron => hex_volume(x),
        ElementKind::Prism => prism_volume(x),
        ElementKind::Polyhedron => f64::NAN,
    }
}

/// Signed volume of element `e` of `mesh` at `points` (see
/// [`element_volume`]; a polyhedron's from its faces, each split into
/// triangles about its centroid).
pub fn mesh_element_volume(mesh: &Mesh, points: &[[f64; 3]], e: usize) -> f64 {
    match mesh.kinds[e] {
        ElementKind::Polyhedron => crate::mesh::polyhedron::volume(points, mesh.faces.of(e)),
        kind => element_volume(kind, &gather(mesh, points, e)),
    }
}

fn cross2(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

fn det3(a: &[f64; 3], b: &[f64; 3], c: &[f64; 3]) -> f64 {
    a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])
}

/// Gauss points of the 2-point rule on [0, 1].
fn gauss2() -> [f64; 2] {
    let g = 0.5 / 3f64.sqrt();
    [0.5 - g, 0.5 + g]
}

/// Jacobian columns `sum_i x_i dN_i/ds_a` from shape derivatives `dn[i][a]`.
fn jacobian_det(x: &[[f64; 3]], dn: impl Fn(usize) -> [f64; 3]) -> f64 {
    let mut j = [[0.0; 3]; 3];
    for (i, p) in x.iter().enumerate() {
        let g = dn(i);
        for (col, ga) in j.iter_mut().zip(g) {
            for (c, pc) in col.iter_mut().zip(p) {
                *c += ga * pc;
            }
        }
    }
    det3(&j[0], &j[1], &j[2])
}

fn hex_volume(x: &[[f64; 3]]) -> f64 {
    // VTK node i sits at reference corner REF[i] of the unit cube
    const REF: [[f64; 3]; 8] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
    ];
    let mut vol = 0.0;
    for a in gauss2() {
        for b in gauss2() {
            for c in gauss2() {
                let s = [a, b, c];
                // 1D factor of node corner r at coordinate t, and its derivative
                let f = |r: f64, t: f64| if r > 0.5 { t } else { 1.0 - t };
                let df = |r: f64| if r > 0.5 { 1.0 } else { -1.0 };
                vol += 0.125
                    * jacobian_det(x, |i| {
                        let r = REF[i];
                        let v: [f64; 3] = std::array::from_fn(|k| f(r[k], s[k]));
                        [df(r[0]) * v[1] * v[2], v[0] * df(r[1]) * v[2], v[0] * v[1] * df(r[2])]
                    });
            }
        }
    }
    vol
}

fn prism_volume(x: &[[f64; 3]]) -> f64 {
    // triangle coordinates at the centroid: L = (1 - xi - eta, xi, eta)
    const L: f64 = 1.0 / 3.0;
    const DL_DXI: [f64; 3] = [-1.0, 1.0, 0.0];
    const DL_DETA: [f64; 3] = [-1.0, 0.0, 1.0];
    let mut vol = 0.0;
    for z in gauss2() {
        // weight: triangle area 1/2 times Gauss weight 1/2
        vol += 0.25
            * jacobian_det(x, |i| {
                let (t, top) = (i % 3, i >= 3);
                let zf = if top { z } else { 1.0 - z };
                [DL_DXI[t] * zf, DL_DETA[t] * zf, if top { L } else { -L }]
            });
    }
    vol
}

/// How far vertices moved between two position sets.
#[derive(serde::Serialize, Clone, Copy, Debug, PartialEq)]
pub struct DisplacementStats {
    /// Largest displacement (length units of the mesh).
    pub max: f64,
    /// Mean displacement over all vertices.
    pub mean: f64,
    /// The vertex that moved furthest (`None` when there are no vertices).
    pub max_vertex: Option<usize>,
}

/// # Panics
/// If the two position sets differ in length.
pub fn displacement_stats(before: &[[f64; 3]], after: &[[f64; 3]]) -> DisplacementStats {
    assert_eq!(before.len(), after.len(), "position sets differ in length");
    let mut out = DisplacementStats {
        max: 0.0,
        mean: 0.0,
        max_vertex: None,
    };
    let mut sum = 0.0;
    for (v, (p, q)) in before.iter().zip(after).enumerate() {
        let d = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
        sum += d;
        if out.max_vertex.is_none() || d > out.max {
            out.max = d;
            out.max_vertex = Some(v);
        }
    }
    if !before.is_empty() {
        out.mean = sum / before.len() as f64;
    }
    out
}

/// Numbers in a table column: fixed point near 1, scientific otherwise.
pub fn num(x: f64) -> String {
    if x.is_nan() {
        "-".into()
    } else if x.is_infinite() {
        "inf".into()
    } else if x == 0.0 || (1e-3..1e5).contains(&x.abs()) {
        format!("{x:.4}")
    } else {
        format!("{x:.3e}")
    }
}

impl QualityReport {
    /// "2D", "3D" or "surface": what kind of mesh was measured.
    pub fn kind_name(&self) -> String {
        if self.surface {
            "surface".into()
        } else {
            format!("{}D", self.dim)
        }
    }
}

impl fmt::Display for QualityReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let kinds: Vec<String> = self.kinds.iter().map(|(k, c)| format!("{c} {k}")).collect();
        writeln!(
            f,
            "{} mesh: {} vertices ({} free, {} fixed), {} elements ({})",
            self.kind_name(),
            self.vertices,
            self.free_vertices,
            self.fixed_vertices,
            self.elements,
            kinds.join(", ")
        )?;
        let measure = if self.dim == 2 { "area" } else { "volume" };
        writeln!(
            f,
            "{:<20}{:>12}{:>12}{:>12}{:>12}{:>12}{:>12}",
            "", "avg", "median", "sigma_n", "min", "max", "max:min"
        )?;
        for (name, s, ratio) in [
            ("inverse mean ratio", &self.eta, "".to_string()),
            (measure, &self.volume, num(self.volume.max_min_ratio)),
        ] {
            writeln!(
                f,
                "{:<20}{:>12}{:>12}{:>12}{:>12}{:>12}{:>12}",
                name,
                num(s.avg),
                num(s.median),
                num(s.sigma_n),
                num(s.min),
                num(s.max),
                ratio
            )?;
        }
        writeln!(
            f,
            "(eta, the inverse mean ratio: 1 for the ideal shape, higher is worse; sigma_n: standard deviation / mean)"
        )?;
        match self.objective {
            // the count is shown when zero too, so reports before and after untangling compare
            Some(obj) => writeln!(f, "objective F (mean eta): {} (inverted elements: 0)", num(obj))?,
            None => writeln!(
                f,
                "inverted elements: {} (first ids: {:?}); objective undefined",
                self.inverted, self.inverted_ids
            )?,
        }
        writeln!(f, "eta histogram:")?;
        let top = self.histogram.iter().map(|b| b.count).max().unwrap_or(0).max(1);
        for b in &self.histogram {
            let range = match b.hi {
                Some(hi) => format!("[{:.2}, {:.2})", b.lo, hi),
                None => format!("[{:.2}, inf)", b.lo),
            };
            let bar = "#".repeat((40 * b.count).div_ceil(top));
            writeln!(f, "  {range:<14}{:>10} {bar}", b.count)?;
        }
        writeln!(f, "worst elements:")?;
        for w in &self.worst {
            let eta = w.eta.map_or("inverted".to_string(), num);
            let c = w.centroid;
            writeln!(
                f,
                "  #{:<10} {:<14}eta {:>10}  at ({}, {}, {})",
                w.id,
                w.kind,
                eta,
                num(c[0]),
                num(c[1]),
                num(c[2])
            )?;
        }
        Ok(())
    }
}
