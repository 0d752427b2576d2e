//! Sliding boundary (`--boundary slide`): boundary vertices move within
//! their patch or along their feature edge and stay on the original boundary
//! triangulation; corners stay. Checked on a box (flat faces, straight
//! edges, corners), a cylinder (curved side, flat caps, circular rims) and a
//! planar grid, on the CPU and against it on the GPU.

mod common;

use common::{context, options};
use meshsmooth::backend::gpu::Precision;
use meshsmooth::generate;
use meshsmooth::metric::mat3::{Vec3, dot, sub};
use meshsmooth::problem::{Boundary, BoundaryMode, Problem, ProblemOptions};
use meshsmooth::solve::{self, Device, Info, Method, Params};
use meshsmooth::{ElementKind, Mesh};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn slide() -> ProblemOptions<'static> {
    ProblemOptions {
        boundary: Boundary {
            mode: BoundaryMode::Slide,
            ..Default::default()
        },
        ..Default::default()
    }
}

fn smooth(mesh: &mut Mesh, po: &ProblemOptions, method: Method, device: Device) -> Info {
    let params = Params {
        max_iter: 200,
        ..Params::default()
    };
    solve::smooth_mesh(mesh, po, &options(method, &params, device), &mut |_| true).unwrap()
}

/// An n^3 Kuhn box of side n whose every non-corner vertex moved by up to
/// `alpha` cells within its face or edge (and interior ones anywhere).
fn box_shuffled(n: usize, alpha: f64, seed: u64) -> Mesh {
    let mut m = generate::tet_box(n, n, n, [n as f64; 3]);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for p in &mut m.points {
        for c in p.iter_mut() {
            if *c != 0.0 && *c != n as f64 {
                *c += rng.random_range(-alpha..alpha);
            }
        }
    }
    m
}

/// A cylinder of radius 1 and height 2: an n x n x layers Kuhn box whose
/// square cross-section is mapped onto the disk (x sqrt(1 - y^2/2),
/// y sqrt(1 - x^2/2)). Around the old square corners the cells are squeezed,
/// which sliding on the side can relieve.
fn cylinder(n: usize, layers: usize) -> Mesh {
    let mut m = generate::tet_box(n, n, layers, [2.0, 2.0, 2.0]);
    for p in &mut m.points {
        let (x, y) = (p[0] - 1.0, p[1] - 1.0);
        p[0] = x * (1.0 - y * y / 2.0).sqrt();
        p[1] = y * (1.0 - x * x / 2.0).sqrt();
    }
    m
}

/// The triangles of the skin.
fn skin_triangles(m: &Mesh) -> Vec<[Vec3; 3]> {
    let mut count = std::collections::HashMap::new();
    for e in 0..m.num_elements() {
        for f in m.kinds[e].facets() {
            let mut k: Vec<u32> = f.iter().map(|&l| m.element(e)[l]).collect();
            k.sort_unstable();
            *count.entry(k).or_insert(0) += 1;
        }
    }
    count
        .into_iter()
        .filter(|(_, c)| *c == 1)
        .map(|(k, _)| [0, 1, 2].map(|i| m.points[k[i] as usize]))
        .collect()
}

fn dist_to_segment(p: &Vec3, a: &Vec3, b: &Vec3) -> f64 {
    let ab = sub(b, a);
    let t = (dot(&sub(p, a), &ab) / dot(&ab, &ab)).clamp(0.0, 1.0);
    let q = [0, 1, 2].map(|i| a[i] + t * ab[i]);
    dot(&sub(p, &q), &sub(p, &q)).sqrt()
}

/// Distance from p to a triangle: to its plane when the foot is inside, else to its edges.
fn dist_to_triangle(p: &Vec3, t: &[Vec3; 3]) -> f64 {
    let (e1, e2) = (sub(&t[1], &t[0]), sub(&t[2], &t[0]));
    let n = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    let nn = dot(&n, &n);
    let h = dot(&sub(p, &t[0]), &n) / nn;
    let foot = [0, 1, 2].map(|i| p[i] - h * n[i]);
    let inside = (0..3).all(|k| {
        let (a, b) = (&t[k], &t[(k + 1) % 3]);
        let c = sub(b, a);
        let d = sub(&foot, a);
        let x = [
            c[1] * d[2] - c[2] * d[1],
            c[2] * d[0] - c[0] * d[2],
            c[0] * d[1] - c[1] * d[0],
        ];
        dot(&x, &n) >= -1e-15 * nn
    });
    if inside {
        h.abs() * nn.sqrt()
    } else {
        (0..3)
            .map(|k| dist_to_segment(p, &t[k], &t[(k + 1) % 3]))
            .fold(f64::INFINITY, f64::min)
    }
}

fn objective(mesh: &Mesh) -> f64 {
    let p = Problem::new(mesh).unwrap();
    let x = p.gather(&mesh.points);
    (0..p.num_corners()).map(|c| p.corner_term(&x, c).unwrap()).sum()
}

fn check_box(before: &Mesh, after: &Mesh, n: f64, tol: f64) {
    let on = |c: f64| c == 0.0 || c == n;
    let mut moved = 0;
    for (v, (a, b)) in before.points.iter().zip(&after.points).enumerate() {
        let bound = a.iter().filter(|&&c| on(c)).count();
        for k in 0..3 {
            if on(a[k]) {
                assert!(
                    (b[k] - a[k]).abs() <= tol * n,
                    "vertex {v} left its face: {a:?} -> {b:?}"
                );
            }
        }
        if bound == 3 {
            assert_eq!(a, b, "corner {v} moved");
        }
        if (1..3).contains(&bound) && a != b {
            moved += 1;
        }
        for k in 0..3 {
            assert!(
                b[k] >= -tol * n && b[k] <= n + tol * n,
                "vertex {v} left the box: {b:?}"
            );
        }
    }
    assert!(moved > 0, "no boundary vertex slid");
}

fn box_case(method: Method) {
    let start = box_shuffled(4, 0.2, 7);
    let mut fixed = start.clone();
    let f_fixed = smooth(&mut fixed, &ProblemOptions::default(), method, Device::Cpu).objective;
    let mut slid = start.clone();
    let info = smooth(&mut slid, &slide(), method, Device::Cpu);
    assert!(
        info.objective < f_fixed - 1e-3,
        "slide {} vs fixed {f_fixed}",
        info.objective
    );
    // the solver's F is the mesh's
    assert!((objective(&slid) - info.objective).abs() < 1e-9);
    check_box(&start, &slid, 4.0, 1e-12);
}

#[test]
fn box_faces_edges_and_corners_stay_in_place_newton() {
    box_case(Method::Newton);
}

#[test]
fn box_faces_edges_and_corners_stay_in_place_bcd() {
    box_case(Method::Bcd);
}

#[test]
fn box_faces_edges_and_corners_stay_in_place_bcd_colored() {
    box_case(Method::BcdColored);
}

fn cylinder_case(method: Method) {
    let start = cylinder(6, 4);
    let mut fixed = start.clone();
    let f_fixed = smooth(&mut fixed, &ProblemOptions::default(), method, Device::Cpu).objective;
    let mut slid = start.clone();
    let info = smooth(&mut slid, &slide(), method, Device::Cpu);
    assert!(
        info.objective < f_fixed - 1e-3,
        "slide {} vs fixed {f_fixed}",
        info.objective
    );
    let tris = skin_triangles(&start);
    let mut moved = 0;
    for (v, (a, b)) in start.points.iter().zip(&slid.points).enumerate() {
        let r = (a[0] * a[0] + a[1] * a[1]).sqrt();
        let on_side = (r - 1.0).abs() < 1e-12;
        let on_cap = a[2] == 0.0 || a[2] == 2.0;
        if on_side || on_cap {
            let d = tris
                .iter()
                .map(|t| dist_to_triangle(b, t))
                .fold(f64::INFINITY, f64::min);
            assert!(d <= 1e-9 * 2.0, "boundary vertex {v} is {d} off the original boundary");
            moved += usize::from(a != b);
        }
        if on_cap {
            assert!((b[2] - a[2]).abs() <= 1e-12, "cap vertex {v} left its cap");
        }
        if on_cap && on_side {
            // a rim vertex stays on the rim polyline of the original mesh
            let rim: Vec<&Vec3> = start
                .points
                .iter()
                .filter(|p| p[2] == a[2] && ((p[0] * p[0] + p[1] * p[1]).sqrt() - 1.0).abs() < 1e-12)
                .collect();
            let d = rim
                .iter()
                .flat_map(|p| rim.iter().map(move |q| (p, q)))
                .filter(|(p, q)| dot(&sub(p, q), &sub(p, q)).sqrt() < 0.6)
                .map(|(p, q)| dist_to_segment(b, p, q))
                .fold(f64::INFINITY, f64::min);
            assert!(d <= 1e-9, "rim vertex {v} is {d} off the rim");
        }
    }
    assert!(moved > 20, "only {moved} boundary vertices moved");
}

#[test]
fn cylinder_slides_on_its_original_boundary_newton() {
    cylinder_case(Method::Newton);
}

#[test]
fn cylinder_slides_on_its_original_boundary_bcd() {
    cylinder_case(Method::Bcd);
}
