//! Targets of layers made of stretched simplices (a quad or prism layer
//! split into triangles or tetrahedra): the corners of the layer itself,
//! with the noise of its vertices averaged away along its rows and columns.
//!
//! A split cell is a sheared image of the ideal simplex, and its height
//! above the wall is a tiny difference of its long edges (a triangle with
//! legs w and h along and across the wall has a hypotenuse of
//! w (1 + h^2 / 2 w^2)): an error of 10^-3 in a target's long edges, far
//! below what any per-element fit of noisy corners reaches, asks for a
//! layer twice as thick. Targets read off a conforming mesh are consistent
//! by construction (that mesh is their exact optimum), so these elements
//! take the corners of the input with its layers' vertices regularised:
//! each interior layer vertex moved, a few Jacobi rounds, to the mean
//! height of its row (the neighbours along the wall, heights measured
//! along the pair's mean normal, so a curved wall's chords do not pull
//! a row down) and to the mean tangential place of its column (the
//! neighbours across the wall). Grading and anisotropy are in the rows'
//! heights, which are not mixed; what a perturbation added is not.

use crate::mesh::Mesh;
use crate::mesh::topology::{skin_vertices, vertex_elements, vertex_neighbours};
use crate::metric::mat3::{Mat3, Vec3, cross, dot, sub};
use rayon::prelude::*;

use super::{element_aspects, sym_eigen};

/// Simplices at least this stretched are layer cells.
const STRETCHED: f64 = 2.0;
/// A vertex is in a layer when its elements' thin axes agree this well (|cos|).
const ALIGNED: f64 = 0.8;
/// A row edge climbs less than this share of the thickness of the cells on
/// its side, and a column edge more than the rest of it.
const ROW_CLIMB: f64 = 0.5;
/// [`ROW_CLIMB`] where the noise of the input cannot confuse a row with a
/// diagonal (a perturbation of 0.3 of the shortest edge at either end).
const SURE_CLIMB: f64 = 0.3;
/// A column edge leans less than this share of its climb.
const COLUMN_LEAN: f64 = 0.6;
/// A vertex moves at most this share of its cells' mean thickness (the thinner side's).
const MAX_MOVE: f64 = 0.5;
/// A regularised cell keeps at least this share of its input volume.
const KEPT_VOLUME: f64 = 0.1;
/// Rows of a layer its walls are found through.
const MAX_ROWS: usize = 200;
/// Jacobi rounds per regularisation pass (a row of a 2D layer is a chain,
/// along which the noise averages out slowly).
const ROUNDS_PER_PASS: usize = 25;

/// The layer cells (stretched simplices) of `mesh` given their raw
/// metrics `g`, and the points with the layers' interior vertices
/// regularised over `passes` passes; `None` where the mesh has no layer
/// vertex to move.
pub(super) fn regularised_layers(
    mesh: &Mesh,
    points: &[Vec3],
    g: &[Mat3],
    passes: usize,
) -> Option<(Vec<bool>, Vec<Vec3>)> {
    let n = mesh.dim();
    let aspects = element_aspects(g, n);
    // the thin axis and thickness of each layer cell
    let thin: Vec<Option<(Vec3, f64)>> = (0..mesh.num_elements())
        .into_par_iter()
        .map(|e| {
            if !mesh.kinds[e].is_simplex() || !(aspects[e] >= STRETCHED) {
                return None;
            }
            let (l, v) = sym_eigen(&g[e]);
            let k = (0..3)
                .filter(|&k| n == 3 || v[2][k].abs() < 0.5)
                .min_by(|&a, &b| l[a].total_cmp(&l[b]))?;
            Some(([v[0][k], v[1][k], v[2][k]], l[k].max(0.0).sqrt()))
        })
        .collect();
    if thin.iter().all(Option::is_none) {
        return None;
    }
    let skin = skin_vertices(mesh);
    let ve = vertex_elements(mesh);
    let nbrs = vertex_neighbours(mesh);
    // the walls: skin facets of layer cells that lie across the cell's thin axis
    let walls: Vec<Wall> = (0..mesh.num_elements())
        .filter_map(|e| Some((e, thin[e]?.0)))
        .flat_map(|(e, axis)| {
            let vs = mesh.element(e);
            mesh.kinds[e]
                .facets()
                .iter()
                .filter(|f| {
                    // on the skin: no other element holds the facet (a diagonal
                    // across a corner's cell has its ends on the skin too)
                    f.iter().all(|&l| skin[vs[l] as usize])
                        && ve
                            .of(vs[f[0]] as usize)
                            .iter()
                            .filter(|&&o| f.iter().all(|&l| mesh.element(o as usize).contains(&vs[l])))
                            .count()
                            == 1
                })
                .map(|f| {
                    let ids: Vec<u32> = f.iter().map(|&l| vs[l]).collect();
                    let x: Vec<Vec3> = ids.iter().map(|&v| points[v as usize]).collect();
                    facet_wall(&ids, &x, n)
                })
                .filter(|w| dot(&w.normal, &axis).abs() >= ALIGNED)
                .collect::<Vec<_>>()
        })
        .collect();
    // each vertex of the layer cells takes the nearest wall its cells' thin
    // axes agree with, round after round from the skin inward (the wall a
    // layer was grown from, not a side wall it happens to be near)
    let in_layer: Vec<Option<Vec3>> = (0..mesh.num_points())
        .into_par_iter()
        .map(|v| {
            let es = ve.of(v);
            let first = thin[*es.first()? as usize]?.0;
            let mut axis = [0.0; 3];
            for &e in es {
                let a = thin[e as usize]?.0;
                let s = dot(&a, &first).signum();
                for k in 0..3 {
                    axis[k] += s * a[k];
                }
            }
            let len = dot(&axis, &axis).sqrt();
            (len > 0.0).then(|| axis.map(|x| x / len))
        })
        .collect();
    let dist2 = |v: usize, w: usize| {
        let d = sub(&points[v], &walls[w].point);
        dot(&d, &d)
    };
    let aligned = |v: usize, w: usize| in_layer[v].is_some_and(|a| dot(&a, &walls[w].normal).abs() >= ALIGNED);
    let mut wall_of: Vec<Option<usize>> = vec![None; mesh.num_points()];
    for (w, wall) in walls.iter().enumerate() {
        for v in wall.vertices.iter().flatten() {
            let v = *v as usize;
            if aligned(v, w) && wall_of[v].is_none_or(|o| dist2(v, w) < dist2(v, o)) {
                wall_of[v] = Some(w);
            }
        }
    }
    for _ in 0..MAX_ROWS {
        let next: Vec<Option<usize>> = (0..mesh.num_points())
            .into_par_iter()
            .map(|v| {
                in_layer[v]?;
                nbrs.of(v)
                    .iter()
                    .filter_map(|&u| wall_of[u as usize])
                    .chain(wall_of[v])
                    .filter(|&w| aligned(v, w))
                    .min_by(|&a, &b| dist2(v, a).total_cmp(&dist2(v, b)))
            })
            .collect();
        let changed = next != wall_of;
        wall_of = next;
        if !changed {
            break;
        }
    }
    // per interior vertex whose elements are all layer cells: its wall's
    // normal and its cells' mean thickness along it, below and above it (a
    // mean: one perturbed cell's is far off)
    let frame: Vec<Option<(Vec3, [f64; 2])>> = (0..mesh.num_points())
        .into_par_iter()
        .map(|v| {
            let es = ve.of(v);
            if skin[v] || es.is_empty() {
                return None;
            }
            let normal = walls[wall_of[v]?].normal;
            let at = dot(&points[v], &normal);
            // the mean thickness along the normal of the cells below and above
            let mut sums = [(0.0, 0usize); 2];
            for &e in es {
                thin[e as usize]?;
                let vs = mesh.element(e as usize);
                let hs: Vec<f64> = vs.iter().map(|&u| dot(&points[u as usize], &normal)).collect();
                let (lo, hi) = hs.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &h| {
                    (lo.min(h), hi.max(h))
                });
                let side = usize::from(hs.iter().sum::<f64>() / hs.len() as f64 > at);
                sums[side].0 += hi - lo;
                sums[side].1 += 1;
            }
            let t = sums.map(|(s, k)| s / k as f64);
            t.iter().all(|t| *t > 0.0 && t.is_finite()).then_some((normal, t))
        })
        .collect();
    if frame.iter().all(Option::is_none) {
        return None;
    }
    // the pair's mean normal (the vertex's own where the other is no layer vertex)
    let mean_normal = |v: usize, u: usize| -> Vec3 {
        let a = frame[v].expect("a layer vertex").0;
        let Some((b, _)) = frame[u] else { return a };
        let s = dot(&a, &b).signum();
        let m: Vec3 = std::array::from_fn(|k| a[k] + s * b[k]);
        let len = dot(&m, &m).sqrt();
        if len > 0.0 { m.map(|x| x / len) } else { a }
    };
    let split = |d: &Vec3, nb: &Vec3| -> (f64, Vec3) {
        let dn = dot(d, nb);
        (dn, std::array::from_fn(|k| d[k] - dn * nb[k]))
    };
    // rows and columns, told apart on the positions `x` (a row edge climbs
    // less than `row_climb` of the thickness of the cells on its side)
    let classify = |x: &[Vec3], row_climb: f64| -> Vec<(Vec<u32>, Vec<u32>)> {
        (0..mesh.num_points())
            .into_par_iter()
            .map(|v| {
                let Some((_, t)) = frame[v] else {
                    return Default::default();
                };
                let (mut row, mut column) = (Vec::new(), Vec::new());
                for &u in nbrs.of(v) {
                    let (dn, dt) = split(&sub(&x[u as usize], &x[v]), &mean_normal(v, u as usize));
                    let lean = dot(&dt, &dt).sqrt();
                    let climbs = dn.abs() >= row_climb * t[usize::from(dn > 0.0)];
                    let rises = dn.abs() >= (1.0 - row_climb) * t[usize::from(dn > 0.0)];
                    if !climbs && lean > dn.abs() {
                        row.push(u);
                    } else if rises && lean < COLUMN_LEAN * dn.abs() {
                        column.push(u);
                    }
                }
                // a vertex inside a layer has a row and a column
                if row.is_empty() || column.is_empty() {
                    return Default::default();
                }
                (row, column)
            })
            .collect()
    };
    // Jacobi rounds from the input over the links
    let rounds = |links: &[(Vec<u32>, Vec<u32>)]| -> Vec<Vec3> {
        let mut x = points.to_vec();
        for _ in 0..passes * ROUNDS_PER_PASS {
            x = (0..x.len())
                .into_par_iter()
                .map(|v| {
                    let (row, column) = &links[v];
                    let Some((normal, t)) = frame[v].filter(|_| !row.is_empty()) else {
                        return x[v];
                    };
                    // the self term damps the round (a Jacobi step of 1 / (count + 1))
                    let climb = row
                        .iter()
                        .map(|&u| split(&sub(&x[u as usize], &x[v]), &mean_normal(v, u as usize)).0)
                        .sum::<f64>()
                        / (row.len() + 1) as f64;
                    // a column's neighbours weighted by the inverse square of
                    // their climb, the self term by its thinner side's: a
                    // vertex's noise is a share of its shortest edge, and the
                    // thick cells far from the wall must not shift the thin ones
                    let own = 1.0 / (t[0].min(t[1]) * t[0].min(t[1]));
                    let (mut lean, mut total) = ([0.0; 3], own);
                    for &u in column {
                        let (dn, dt) = split(&sub(&x[u as usize], &x[v]), &mean_normal(v, u as usize));
                        let w = 1.0 / (dn * dn).max(f64::MIN_POSITIVE);
                        total += w;
                        for k in 0..3 {
                            lean[k] += w * dt[k];
                        }
                    }
                    let lean = lean.map(|l| l / total);
                    // the lean without its part along the vertex's own normal
                    let along = dot(&lean, &normal);
                    let to: Vec3 = std::array::from_fn(|k| x[v][k] + climb * normal[k] + lean[k] - along * normal[k]);
                    // never further from the input than a perturbation's noise
                    let d = sub(&to, &points[v]);
                    let len = dot(&d, &d).sqrt();
                    let cap = MAX_MOVE * t[0].min(t[1]);
                    if len > cap {
                        std::array::from_fn(|k| points[v][k] + d[k] * cap / len)
                    } else {
                        to
                    }
                })
                .collect();
        }
        x
    };
    // the links the noise cannot confuse first, then all of them, told
    // apart on the positions those gave
    let sure = rounds(&classify(points, SURE_CLIMB));
    let links = classify(&sure, ROW_CLIMB);
    // the cells whose every vertex is on the skin or moved here: a layer's
    // (a simplex that the noise stretched in an isotropic region keeps the
    // metric targets, which repair its shape)
    let moved = |v: usize| frame[v].is_some() && !links[v].0.is_empty();
    let layer_cell: Vec<bool> = (0..mesh.num_elements())
        .map(|e| {
            let vs = mesh.element(e);
            thin[e].is_some()
                && vs.iter().any(|&v| moved(v as usize))
                && vs.iter().all(|&v| skin[v as usize] || moved(v as usize))
        })
        .collect();
    if !layer_cell.contains(&true) {
        return None;
    }
    let mut x = rounds(&links);
    // a cell the rounds flattened or turned keeps its input vertices (and
    // so may its neighbours, round after round)
    let volume = |x: &[Vec3], e: usize| crate::metric::element_min_det(mesh, x, e);
    for _ in 0..MAX_ROWS {
        let bad: Vec<usize> = (0..mesh.num_elements())
            .into_par_iter()
            .filter(|&e| {
                // (a ratio: a planar mesh wound clockwise has negative volumes)
                layer_cell[e]
                    && mesh.element(e).iter().any(|&v| x[v as usize] != points[v as usize])
                    && !(volume(&x, e) / volume(points, e) >= KEPT_VOLUME)
            })
            .collect();
        if bad.is_empty() {
            return Some((layer_cell, x));
        }
        for e in bad {
            for &v in mesh.element(e) {
                x[v as usize] = points[v as usize];
            }
        }
    }
    None
}

/// A skin facet: its vertices, centroid and unit normal (either way round).
#[derive(Clone, Copy, Debug)]
struct Wall {
    vertices: [Option<u32>; 4],
    point: Vec3,
    normal: Vec3,
}

/// The wall of the facet at `x`.
fn facet_wall(vertices: &[u32], x: &[Vec3], n: usize) -> Wall {
    let mut point = [0.0; 3];
    for p in x {
        for k in 0..3 {
            point[k] += p[k] / x.len() as f64;
        }
    }
    let normal = if n == 2 {
        let t = sub(&x[1], &x[0]);
        [-t[1], t[0], 0.0]
    } else if x.len() == 4 {
        cross(&sub(&x[2], &x[0]), &sub(&x[3], &x[1]))
    } else {
        cross(&sub(&x[1], &x[0]), &sub(&x[2], &x[0]))
    };
    let len = dot(&normal, &normal).sqrt();
    Wall {
        vertices: std::array::from_fn(|k| vertices.get(k).copied()),
        point,
        normal: normal.map(|v| v / len),
    }
}
