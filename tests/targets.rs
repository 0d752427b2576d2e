//! Targets that keep what a mesh was built to have: a quad boundary layer
//! graded away from a wall (first layer 1e-3, growth 1.3) with its interior
//! perturbed by 0.3 of each vertex's shortest edge. The ideal objective
//! thickens the first layer many times over; input targets with the
//! shape+size metric bring it back near the unperturbed height. Also: the
//! size-field targets make elements smaller where the field is smaller, and
//! the result does not depend on the units.

use meshsmooth::generate;
use meshsmooth::mesh::data::{DataArray, ValueType, Values};
use meshsmooth::metric::smetric::MetricKind;
use meshsmooth::problem::{InputTargets, ProblemOptions, Target};
use meshsmooth::solve::{self, Method, Options, Params};
use meshsmooth::{ElementKind, Mesh, metric};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

const NX: usize = 24;
const NY: usize = 14;

/// Heights of the layers: 1e-3 growing by 1.3, scaled to a unit-high strip.
fn layer_y() -> Vec<f64> {
    let mut y = vec![0.0];
    let mut h = 1e-3;
    for _ in 0..NY {
        y.push(y.last().unwrap() + h);
        h *= 1.3;
    }
    y
}

fn layer_mesh() -> Mesh {
    let mut mesh = generate::quad_grid(NX, NY, [1.0, 1.0]);
    let ys = layer_y();
    for p in &mut mesh.points {
        let j = (p[1] * NY as f64).round() as usize;
        p[1] = ys[j];
    }
    mesh
}

/// Interior vertices moved by up to `alpha` of their shortest edge in x and y.
fn perturbed(mesh: &Mesh, alpha: f64, seed: u64) -> Mesh {
    let mut out = mesh.clone();
    let skin = meshsmooth::mesh::topology::skin_vertices(mesh);
    let nb = meshsmooth::mesh::topology::vertex_neighbours(mesh);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for v in 0..mesh.num_points() {
        if skin[v] {
            continue;
        }
        let p = mesh.points[v];
        let h = nb
            .of(v)
            .iter()
            .map(|&u| {
                let q = mesh.points[u as usize];
                ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt()
            })
            .fold(f64::INFINITY, f64::min);
        for k in 0..2 {
            out.points[v][k] += alpha * h * rng.random_range(-1.0..1.0);
        }
    }
    assert!(metric::inverted_elements(&out, &out.points).is_empty());
    out
}

fn smooth(mesh: &mut Mesh, opts: &ProblemOptions) -> solve::Info {
    let params = Params {
        max_iter: 200,
        ..Params::default()
    };
    solve::smooth_mesh(mesh, opts, &Options::cpu(Method::Newton, &params), &mut |_| true).unwrap()
}

/// First-layer heights (second row of vertices above the wall y = 0),
/// relative to the unperturbed ones: (median, max) of |h / h0 - 1|.
fn first_layer_error(mesh: &Mesh, base: &Mesh) -> (f64, f64) {
    let row = NX + 1;
    let mut err: Vec<f64> = (1..NX)
        .map(|i| {
            let v = row + i;
            (mesh.points[v][1] / base.points[v][1] - 1.0).abs()
        })
        .collect();
    err.sort_unstable_by(f64::total_cmp);
    (err[err.len() / 2], *err.last().unwrap())
}

fn input_opts() -> ProblemOptions<'static> {
    ProblemOptions {
        metric: MetricKind::ShapeSize,
        target: Target::Input(InputTargets::default()),
        ..Default::default()
    }
}

#[test]
fn input_targets_keep_a_boundary_layer_that_the_ideal_objective_destroys() {
    let base = layer_mesh();
    let start = perturbed(&base, 0.3, 7);
    let (m0, x0) = first_layer_error(&start, &base);
    let mut ideal = start.clone();
    smooth(&mut ideal, &ProblemOptions::default());
    let (mi, xi) = first_layer_error(&ideal, &base);
    let mut kept = start.clone();
    let info = smooth(&mut kept, &input_opts());
    let (mk, xk) = first_layer_error(&kept, &base);
    eprintln!(
        "first layer |h/h0 - 1| median/max: perturbed {m0:.3}/{x0:.3}, ideal {mi:.3}/{xi:.3}, input+shape-size {mk:.3}/{xk:.3} ({} iterations, {:?})",
        info.iterations, info.stop
    );
    assert!(metric::inverted_elements(&kept, &kept.points).is_empty());
    // the ideal objective thickens the first layer several times over
    assert!(mi > 2.0, "ideal: {mi}");
    // input targets keep it within 8% (median) and 20% (max)
    assert!(mk < 0.08 && xk < 0.2, "input: {mk} / {xk}");
    // and the perturbation's skew is repaired: the quads' corner angles
    // are closer to right angles than the perturbed input's
    let skew = |m: &Mesh| mean_skew_degrees(m);
    eprintln!(
        "mean quad skew: perturbed {:.2}°, input {:.2}°",
        skew(&start),
        skew(&kept)
    );
    assert!(skew(&kept) < 0.2 * skew(&start));
}

/// Mean over the quads' corners of |angle - 90°|.
fn mean_skew_degrees(mesh: &Mesh) -> f64 {
    let mut sum = 0.0;
    let mut n = 0.0;
    for e in 0..mesh.num_elements() {
        assert_eq!(mesh.kinds[e], ElementKind::Quadrilateral);
        let vs = mesh.element(e);
        for k in 0..4 {
            let p = mesh.points[vs[k] as usize];
            let a = mesh.points[vs[(k + 1) % 4] as usize];
            let b = mesh.points[vs[(k + 3) % 4] as usize];
            let (u, w) = ([a[0] - p[0], a[1] - p[1]], [b[0] - p[0], b[1] - p[1]]);
            let c = (u[0] * w[0] + u[1] * w[1]) / ((u[0].hypot(u[1])) * (w[0].hypot(w[1])));
            sum += (c.clamp(-1.0, 1.0).acos().to_degrees() - 90.0).abs();
            n += 1.0;
        }
    }
    sum / n
}

#[test]
fn an_unperturbed_layer_is_its_own_optimum_under_input_targets() {
    // targets from an exact (affine per element) layer are the elements
    // themselves: F is at its minimum 1 and nothing moves
    let mut mesh = layer_mesh();
    let before = mesh.points.clone();
    let info = smooth(&mut mesh, &input_opts());
    let worst = mesh
        .points
        .iter()
        .zip(&before)
        .map(|(a, b)| ((a[0] - b[0]).abs()).max((a[1] - b[1]).abs()))
        .fold(0.0, f64::max);
    eprintln!("F = {}, largest move {worst:e}", info.objective);
    assert!(info.objective - 1.0 < 1e-3, "F = {}", info.objective);
    assert!(worst < 1e-3 * 1e-3, "a vertex moved {worst}");
}

#[test]
fn input_targets_do_not_depend_on_units() {
    let base = layer_mesh();
    let start = perturbed(&base, 0.3, 3);
    let mut a = start.clone();
    smooth(&mut a, &input_opts());
    let mut b = start.clone();
    for p in &mut b.points {
        for v in p.iter_mut().take(2) {
            *v = *v * 1000.0 + 5.0;
        }
    }
    smooth(&mut b, &input_opts());
    for (p, q) in a.points.iter().zip(&b.points) {
        for k in 0..2 {
            let back = (q[k] - 5.0) / 1000.0;
            assert!((back - p[k]).abs() < 1e-9, "{} vs {}", back, p[k]);
        }
    }
}

#[test]
fn a_size_field_makes_elements_smaller_where_it_is_smaller() {
    let n = 16;
    let mut mesh = generate::tri_grid(n, n, [1.0, 1.0]);
    let h: Vec<f64> = mesh.points.iter().map(|p| 0.02 + 0.1 * p[0]).collect();
    mesh.data
        .point
        .push(DataArray::new("h", ValueType::F64, 1, Values::Float(h)));
    let area_ratio = |m: &Mesh| {
        let (mut left, mut right) = ((0.0, 0.0), (0.0, 0.0));
        for e in 0..m.num_elements() {
            let vs = m.element(e);
            let p: Vec<[f64; 3]> = vs.iter().map(|&v| m.points[v as usize]).collect();
            let area =
                0.5 * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1])).abs();
            let cx = (p[0][0] + p[1][0] + p[2][0]) / 3.0;
            if cx < 0.25 {
                left = (left.0 + area, left.1 + 1.0);
            } else if cx > 0.75 {
                right = (right.0 + area, right.1 + 1.0);
            }
        }
        (left.0 / left.1) / (right.0 / right.1)
    };
    let before = area_ratio(&mesh);
    let opts = ProblemOptions {
        metric: MetricKind::ShapeSize,
        target: Target::Size("h"),
        ..Default::default()
    };
    smooth(&mut mesh, &opts);
    let after = area_ratio(&mesh);
    eprintln!("left/right mean element area: before {before:.3}, after {after:.3}");
    assert!(metric::inverted_elements(&mesh, &mesh.points).is_empty());
    assert!(after < 0.5 * before, "{after} vs {before}");
    // a field that is missing or not positive is refused by name
    let mut bad = mesh.clone();
    let opts = ProblemOptions {
        target: Target::Size("nope"),
        ..Default::default()
    };
    let err = solve::smooth_mesh(
        &mut bad,
        &opts,
        &Options::cpu(Method::Newton, &Params::default()),
        &mut |_| true,
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("'nope'") && err.contains("h"), "{err}");
}
