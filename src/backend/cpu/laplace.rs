//! Smart Laplacian smoothing, the baseline users know: each free vertex moves
//! toward the centroid of its edge neighbours, but a move that would invert an
//! element or worsen the worst element around the vertex is not taken. CPU
//! only: it is sequential by nature and a baseline, not an optimiser.

use super::project_boundary::project_vertex;
use crate::metric::mat3::{Vec3, dot, mul_vec, sub};
use crate::problem::Problem;
use std::time::Instant;

/// Worst corner term around `v` with `v` at `at`; `None` if inverted.
fn patch_worst(p: &Problem, x: &[Vec3], v: usize, at: &Vec3) -> Option<f64> {
    let mut worst: f64 = f64::NEG_INFINITY;
    for &packed in p.incidence.of(v) {
        let (c, k) = ((packed >> 2) as usize, (packed & 3) as usize);
        let mut xc = p.corner_points(x, c);
        xc[k] = *at;
        if p.dim == 2 {
            xc[3] = xc[0];
        }
        worst = worst.max(p.model.value(p.shape(c), &xc)?);
    }
    Some(worst)
}

/// One sweep; returns the largest squared displacement.
pub fn sweep(p: &Problem, x: &mut [Vec3], deadline: Option<Instant>) -> f64 {
    let mut max_sq: f64 = 0.0;
    for (i, &v) in p.free_vertices.iter().enumerate() {
        if i % 4096 == 4095 && deadline.is_some_and(|d| Instant::now() >= d) {
            break;
        }
        let v = v as usize;
        let nb = p.neighbours.of(v);
        if nb.is_empty() {
            continue;
        }
        let mut c = [0.0; 3];
        for &w in nb {
            for i in 0..3 {
                c[i] += x[w as usize][i];
            }
        }
        let c = c.map(|s| s / nb.len() as f64);
        let Some(before) = patch_worst(p, x, v, &x[v]) else {
            continue;
        };
        let mut d = [c[0] - x[v][0], c[1] - x[v][1], c[2] - x[v][2]];
        // a sliding vertex moves toward the centroid within its tangent
        // space, then back onto the boundary
        let slide = p.sliding.as_ref().filter(|s| s.slides(v));
        if let Some(s) = slide {
            d = mul_vec(&s.projector[v], &d);
        }
        // full move first, then shorter ones toward the centroid
        for t in [1.0, 0.5, 0.25] {
            let mut trial = [x[v][0] + t * d[0], x[v][1] + t * d[1], x[v][2] + t * d[2]];
            if let Some(s) = slide {
                trial = project_vertex(s, v, &trial);
            }
            if patch_worst(p, x, v, &trial).is_some_and(|w| w <= before) {
                let m = sub(&trial, &x[v]);
                max_sq = max_sq.max(dot(&m, &m));
                x[v] = trial;
                break;
            }
        }
    }
    max_sq
}
