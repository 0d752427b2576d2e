//! Surface-mesh helpers: normals and folds, a sphere perturbed within
//! itself, distances to a triangulation.

use meshsmooth::Mesh;
use meshsmooth::backend::cpu::project_boundary::closest_on_triangle;
use meshsmooth::metric::mat3::{Vec3, cross, dot, sub};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub fn norm(a: &Vec3) -> f64 {
    dot(a, a).sqrt()
}

pub fn unit(a: Vec3) -> Vec3 {
    let l = norm(&a);
    a.map(|c| c / l)
}

/// The normal of element `e` (Newell's, unnormalised).
pub fn normal(mesh: &Mesh, points: &[Vec3], e: usize) -> Vec3 {
    let vs = mesh.element(e);
    let o = points[vs[0] as usize];
    let mut n = [0.0; 3];
    for i in 1..vs.len() - 1 {
        let c = cross(&sub(&points[vs[i] as usize], &o), &sub(&points[vs[i + 1] as usize], &o));
        for k in 0..3 {
            n[k] += c[k];
        }
    }
    n
}

/// Elements whose normal turned by more than a right angle from `before`.
pub fn flipped(mesh: &Mesh, before: &[Vec3], after: &[Vec3]) -> Vec<usize> {
    (0..mesh.num_elements())
        .filter(|&e| !(dot(&normal(mesh, before, e), &normal(mesh, after, e)) > 0.0))
        .collect()
}

/// Moves every vertex of a sphere mesh by `lo..hi` of its shortest edge in a
/// random tangent direction and back onto the sphere, shortening moves that
/// would fold a triangle.
pub fn perturb_on_sphere(m: &mut Mesh, lo: f64, hi: f64, seed: u64) {
    let nb = meshsmooth::mesh::topology::vertex_neighbours(m);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let start = m.points.clone();
    for v in 0..m.num_points() {
        let p = m.points[v];
        let h = nb
            .of(v)
            .iter()
            .map(|&w| norm(&sub(&m.points[w as usize], &p)))
            .fold(f64::INFINITY, f64::min);
        let n = unit(p);
        let a = if n[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let t1 = unit(cross(&n, &a));
        let t2 = cross(&n, &t1);
        let angle = rng.random_range(0.0..std::f64::consts::TAU);
        let mut step = h * rng.random_range(lo..hi);
        loop {
            let q: Vec3 = std::array::from_fn(|k| p[k] + step * (angle.cos() * t1[k] + angle.sin() * t2[k]));
            m.points[v] = unit(q);
            if flipped(m, &start, &m.points).is_empty() {
                break;
            }
            step *= 0.7;
            if step < 1e-3 * h {
                m.points[v] = p;
                break;
            }
        }
    }
}

/// Distance from `p` to the nearest triangle of `mesh` at `points`
/// (quadrilaterals as two triangles).
pub fn distance_to(mesh: &Mesh, points: &[Vec3], p: &Vec3) -> f64 {
    (0..mesh.num_elements())
        .flat_map(|e| {
            let vs = mesh.element(e);
            (1..vs.len() - 1).map(move |i| [vs[0], vs[i], vs[i + 1]])
        })
        .map(|t| {
            let tri = t.map(|v| points[v as usize]);
            norm(&sub(p, &closest_on_triangle(p, &tri)))
        })
        .fold(f64::INFINITY, f64::min)
}
