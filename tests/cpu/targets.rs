//! Targets that keep what a mesh was built to have: a quad boundary layer
//! graded away from a wall (first layer 1e-3, growth 1.3) with its interior
//! perturbed by 0.3 of each vertex's shortest edge. The ideal objective
//! thickens the first layer many times over; input targets with the
//! shape+size metric bring it back near the unperturbed height. Also: the
//! size-field targets make elements smaller where the field is smaller, and
//! the result does not depend on the units. And a Gmsh channel whose
//! cylinder and lower wall carry a quad boundary layer (Gmsh's
//! BoundaryLayer field, triangles elsewhere), perturbed the same way, is
//! smoothed back by the default target choice.

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

/// Interior vertices moved by up to `alpha` of their shortest edge along each axis.
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
                (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt()
            })
            .fold(f64::INFINITY, f64::min);
        for k in 0..mesh.dim() {
            out.points[v][k] += alpha * h * rng.random_range(-1.0..1.0);
        }
    }
    assert!(metric::inverted_elements(&out, &out.points).is_empty());
    out
}

fn smooth(mesh: &mut Mesh, opts: &ProblemOptions) -> solve::Info {
    let mut params = Params::default();
    params.max_iter = 200;
    solve::smooth_mesh(mesh, opts, &Options::cpu(Method::Newton, &params), &mut |_| true).unwrap()
}

/// The free vertices of `base` at height `h` above the wall where
/// coordinate `axis` is 0: its first layer.
fn layer_at(base: &Mesh, axis: usize, h: f64) -> Vec<usize> {
    let skin = meshsmooth::mesh::topology::skin_vertices(base);
    (0..base.num_points())
        .filter(|&v| !skin[v] && (base.points[v][axis] - h).abs() < 1e-12)
        .collect()
}

/// Median and max over `layer` of |h / h0 - 1|, the heights along `axis`
/// in `mesh` over those in `base`.
fn height_error(mesh: &Mesh, base: &Mesh, layer: &[usize], axis: usize) -> (f64, f64) {
    let mut e: Vec<f64> = layer
        .iter()
        .map(|&v| (mesh.points[v][axis] / base.points[v][axis] - 1.0).abs())
        .collect();
    e.sort_unstable_by(f64::total_cmp);
    (e[e.len() / 2], *e.last().unwrap())
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
    {
        let mut po = ProblemOptions::default();
        po.metric = MetricKind::ShapeSize;
        po.target = Target::Input(InputTargets::default());
        po
    }
}

#[test]
fn input_targets_keep_a_boundary_layer_that_the_ideal_objective_destroys() {
    let base = layer_mesh();
    let start = perturbed(&base, 0.3, 7);
    let (m0, x0) = first_layer_error(&start, &base);
    let mut ideal = start.clone();
    let mut ideal_opts = ProblemOptions::default();
    ideal_opts.target = Target::Ideal;
    smooth(&mut ideal, &ideal_opts);
    let (mi, xi) = first_layer_error(&ideal, &base);
    // the default sees the layer and keeps it like input targets
    let mut auto = start.clone();
    smooth(&mut auto, &ProblemOptions::default());
    assert_eq!(
        first_layer_error(&auto, &base),
        first_layer_error(&kept_ref(&start), &base)
    );
    let mut kept = start.clone();
    let info = smooth(&mut kept, &input_opts());
    let (mk, xk) = first_layer_error(&kept, &base);
    eprintln!(
        "first layer |h/h0 - 1| median/max: perturbed {m0:.3}/{x0:.3}, ideal {mi:.3}/{xi:.3}, input+shape-size {mk:.3}/{xk:.3} ({} iterations, {:?})",
        info.iterations, info.stop
    );
    assert!(metric::inverted_elements(&kept, &kept.points).is_empty());
    // the report's wall-normal first-layer change reads the same heights
    let reported = meshsmooth::problem::targets::first_layer_change(&start, &base.points, &kept.points).unwrap();
    assert!(reported.vertices >= NX - 1, "{reported}");
    assert!((reported.median_change - mk).abs() < 0.01, "{reported} vs {mk}");
    let thickened = meshsmooth::problem::targets::first_layer_change(&start, &base.points, &ideal.points).unwrap();
    assert!(thickened.median_ratio > 3.0, "{thickened}");
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

fn kept_ref(start: &Mesh) -> Mesh {
    let mut m = start.clone();
    smooth(&mut m, &input_opts());
    m
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
fn split_layer_targets_turn_and_scale_with_the_mesh() {
    // the layers of stretched tetrahedra take their targets from their own
    // regularised corners: a turned, scaled and moved mesh gets the same
    // targets turned and scaled
    let base = generate::boundary_layer(generate::LayerKind::Tet, 6, 1e-3, 1.5, 12).unwrap();
    let start = perturbed(&base, 0.3, 9);
    let (c, s) = (0.6f64, 0.8f64);
    let scale = 250.0;
    let turn = |p: &[f64; 3]| {
        [
            scale * (c * p[0] - s * p[2]) + 3.0,
            scale * p[1] - 7.0,
            scale * (s * p[0] + c * p[2]) + 1.0,
        ]
    };
    let mut moved = start.clone();
    for p in &mut moved.points {
        *p = turn(p);
    }
    let input = Target::Input(InputTargets::default());
    let build = |m: &Mesh| {
        meshsmooth::problem::targets::build(m, &m.points, false, input, 1.0)
            .unwrap()
            .unwrap()
    };
    let (a, b) = (build(&start), build(&moved));
    assert_eq!(a.w.len(), b.w.len());
    let mut worst: f64 = 0.0;
    for (wa, wb) in a.w.iter().zip(&b.w) {
        // R W against the turned mesh's W, relative to the column's length
        for col in 0..3 {
            let x = [wa[0][col], wa[1][col], wa[2][col]];
            let len = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt() * scale;
            let t = turn(&x);
            let t = [t[0] - 3.0, t[1] + 7.0, t[2] - 1.0];
            for r in 0..3 {
                worst = worst.max((t[r] - wb[r][col]).abs() / len);
            }
        }
    }
    assert!(worst < 1e-8, "targets differ by {worst:e} of a column");
    // and they are not the raw corners: the noise is gone from the layer
    let raw = meshsmooth::problem::targets::build(
        &start,
        &start.points,
        false,
        Target::Input(InputTargets { passes: 0 }),
        1.0,
    )
    .unwrap()
    .unwrap();
    let exact = meshsmooth::problem::targets::build(
        &base,
        &base.points,
        false,
        Target::Input(InputTargets { passes: 0 }),
        1.0,
    )
    .unwrap()
    .unwrap();
    // the first layer's targets: their extent across the wall against the
    // unperturbed mesh's, median of |ratio - 1|
    let off = |t: &meshsmooth::problem::targets::CornerTargets| {
        let across = |w: &[[f64; 3]; 3]| {
            let z = [0.0, w[2][0], w[2][1], w[2][2]];
            z.iter().cloned().fold(f64::MIN, f64::max) - z.iter().cloned().fold(f64::MAX, f64::min)
        };
        let mut d: Vec<f64> = (0..base.num_elements())
            .filter(|&e| base.element(e).iter().all(|&v| base.points[v as usize][2] < 1.1e-3))
            .map(|e| (across(&t.of(e)[0]) / across(&exact.of(e)[0]) - 1.0).abs())
            .collect();
        assert!(d.len() >= 100, "{}", d.len());
        d.sort_by(f64::total_cmp);
        d[d.len() / 2]
    };
    let (o_raw, o_reg) = (off(&raw), off(&a));
    eprintln!("first-layer targets across the wall, median |h/h0 - 1|: raw {o_raw:.4}, regularised {o_reg:.4}");
    assert!(o_reg < 0.3 * o_raw, "raw {o_raw}, regularised {o_reg}");
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
    let mut opts = ProblemOptions::default();
    opts.metric = MetricKind::ShapeSize;
    opts.target = Target::Size("h");
    smooth(&mut mesh, &opts);
    let after = area_ratio(&mesh);
    eprintln!("left/right mean element area: before {before:.3}, after {after:.3}");
    assert!(metric::inverted_elements(&mesh, &mesh.points).is_empty());
    assert!(after < 0.5 * before, "{after} vs {before}");
    // a field that is missing or not positive is refused by name
    let mut bad = mesh.clone();
    let mut opts = ProblemOptions::default();
    opts.target = Target::Size("nope");
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

/// Runs Gmsh on tests/data/channel_bl.geo; `None` (with a note) where Gmsh
/// is missing outside CI.
fn gmsh_channel() -> Option<Mesh> {
    let ok = std::process::Command::new("gmsh")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            std::env::var_os("CI").is_none(),
            "gmsh is not installed, and CI must run the boundary-layer test"
        );
        eprintln!("skipping the Gmsh boundary-layer test: gmsh is not installed");
        return None;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("channel.msh");
    let geo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/channel_bl.geo");
    let run = std::process::Command::new("gmsh")
        .args(["-2", "-format", "msh4", "-o"])
        .arg(&out)
        .arg(&geo)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    Some(meshsmooth::io::read(&out).unwrap())
}

/// Distance to the channel's walls with a layer: the lower wall y = 0 and
/// the cylinder of radius 0.15 around (0.6, 0.5).
fn wall_distance(p: &[f64; 3]) -> f64 {
    p[1].min(((p[0] - 0.6).powi(2) + (p[1] - 0.5).powi(2)).sqrt() - 0.15)
}

/// The first-layer vertex of each free wall vertex's quads: its nearest
/// neighbour off the wall.
fn first_layer_vertices(mesh: &Mesh) -> Vec<usize> {
    let nb = meshsmooth::mesh::topology::vertex_neighbours(mesh);
    let skin = meshsmooth::mesh::topology::skin_vertices(mesh);
    let on_wall = |v: usize| wall_distance(&mesh.points[v]).abs() < 1e-9;
    let mut out: Vec<usize> = (0..mesh.num_points())
        .filter(|&w| on_wall(w))
        .filter_map(|w| {
            nb.of(w)
                .iter()
                .map(|&u| u as usize)
                .filter(|&u| !on_wall(u) && !skin[u])
                .min_by(|&a, &b| wall_distance(&mesh.points[a]).total_cmp(&wall_distance(&mesh.points[b])))
        })
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// (median, max) of |d / d0 - 1| over `vs`, d the wall distance.
fn wall_distance_error(mesh: &Mesh, base: &Mesh, vs: &[usize]) -> (f64, f64) {
    let mut err: Vec<f64> = vs
        .iter()
        .map(|&v| (wall_distance(&mesh.points[v]) / wall_distance(&base.points[v]) - 1.0).abs())
        .collect();
    err.sort_unstable_by(f64::total_cmp);
    (err[err.len() / 2], *err.last().unwrap())
}

/// Mean over the quads' corners of |angle - 90°|, and the mean inverse mean
/// ratio of the triangles farther than 0.1 from the walls.
fn quads_skew_and_far_triangles(mesh: &Mesh) -> (f64, f64) {
    let (mut skew, mut corners, mut eta, mut tris) = (0.0, 0.0, 0.0, 0.0);
    for e in 0..mesh.num_elements() {
        let vs = mesh.element(e);
        let pts: Vec<[f64; 3]> = vs.iter().map(|&v| mesh.points[v as usize]).collect();
        match mesh.kinds[e] {
            ElementKind::Quadrilateral => {
                for k in 0..4 {
                    let (p, a, b) = (pts[k], pts[(k + 1) % 4], pts[(k + 3) % 4]);
                    let (u, w) = ([a[0] - p[0], a[1] - p[1]], [b[0] - p[0], b[1] - p[1]]);
                    let c = (u[0] * w[0] + u[1] * w[1]) / (u[0].hypot(u[1]) * w[0].hypot(w[1]));
                    skew += (c.clamp(-1.0, 1.0).acos().to_degrees() - 90.0).abs();
                    corners += 1.0;
                }
            }
            ElementKind::Triangle => {
                let c: [f64; 3] = std::array::from_fn(|k| pts.iter().map(|p| p[k]).sum::<f64>() / 3.0);
                if wall_distance(&c) > 0.1 {
                    eta += metric::element_eta(mesh, &mesh.points, e).unwrap();
                    tris += 1.0;
                }
            }
            k => panic!("unexpected {k}"),
        }
    }
    (skew / corners, eta / tris)
}

#[test]
fn a_gmsh_boundary_layer_survives_smoothing_with_the_default_targets() {
    let Some(base) = gmsh_channel() else { return };
    assert!(base.kinds.contains(&ElementKind::Quadrilateral) && base.kinds.contains(&ElementKind::Triangle));
    let layer = first_layer_vertices(&base);
    assert!(layer.len() > 80, "{} first-layer vertices", layer.len());
    let (skew0, far0) = quads_skew_and_far_triangles(&base);
    // the first-layer errors pooled over four perturbations: each leaves
    // some long-wavelength thickening that no local regularisation can tell
    // from the mesh's own (one of them 5.6% in the median on its own)
    let seeds = [5u64, 6, 7, 11];
    for (name, opts) in [("default", ProblemOptions::default()), ("input", input_opts())] {
        let mut pooled = vec![];
        for seed in seeds {
            let start = perturbed(&base, 0.3, seed);
            if name == "default" {
                // the default decides for input targets and says why
                let (chosen, note) = ProblemOptions::default().resolved(&start).unwrap();
                assert_eq!(chosen.target, Target::Input(InputTargets::default()));
                assert_eq!(chosen.metric, MetricKind::ShapeSize);
                assert!(note.unwrap().starts_with("targets: input"));
            }
            let (skew_p, far_p) = quads_skew_and_far_triangles(&start);
            let (mp, xp) = wall_distance_error(&start, &base, &layer);
            let mut m = start.clone();
            let info = smooth(&mut m, &opts);
            assert!(metric::inverted_elements(&m, &m.points).is_empty(), "{name}");
            let (med, max) = wall_distance_error(&m, &base, &layer);
            let (skew, far) = quads_skew_and_far_triangles(&m);
            eprintln!(
                "{name}, seed {seed}: first layer |d/d0 - 1| median/max {med:.3}/{max:.3} (perturbed {mp:.3}/{xp:.3}); quad skew {skew:.2}° (perturbed {skew_p:.2}°, unperturbed {skew0:.2}°); far triangles' mean eta {far:.4} (perturbed {far_p:.4}, unperturbed {far0:.4}); {} iterations, {:?}",
                info.iterations, info.stop
            );
            assert!(skew <= 0.5 * skew_p, "{name}: skew {skew} vs {skew_p}");
            assert!(
                far_p - far >= 0.5 * (far_p - far0),
                "{name}: far field {far} (perturbed {far_p}, unperturbed {far0})"
            );
            pooled.extend(
                layer
                    .iter()
                    .map(|&v| (wall_distance(&m.points[v]) / wall_distance(&base.points[v]) - 1.0).abs()),
            );
        }
        pooled.sort_unstable_by(f64::total_cmp);
        let (med, max) = (pooled[pooled.len() / 2], *pooled.last().unwrap());
        eprintln!("{name}: pooled first layer |d/d0 - 1| median {med:.3}, max {max:.3}");
        assert!(med < 0.05 && max < 0.25, "{name}: first layer {med} / {max}");
    }
    let start = perturbed(&base, 0.3, seeds[0]);
    // and the ideal objective, asked for, thickens the layer
    let mut ideal = start.clone();
    let mut opts = ProblemOptions::default();
    opts.target = Target::Ideal;
    smooth(&mut ideal, &opts);
    let (med, _) = wall_distance_error(&ideal, &base, &layer);
    eprintln!("ideal: first layer median |d/d0 - 1| {med:.3}");
    assert!(med > 1.0, "ideal: {med}");
}

#[test]
fn a_hex_box_graded_toward_a_wall_keeps_its_first_layer() {
    // first cell 1e-3 growing by 1.5: the layer the ideal objective thickens
    let base = generate::graded_hex_box(6, 1e-3, 1.5).unwrap();
    let start = perturbed(&base, 0.3, 5);
    let (chosen, _) = ProblemOptions::default().resolved(&start).unwrap();
    assert_eq!(chosen.target, Target::Input(InputTargets::default()));
    let first = layer_at(&base, 2, 1e-3);
    assert!(first.len() >= 25, "{}", first.len());
    let error = |m: &Mesh| height_error(m, &base, &first, 2);
    let mut kept = start.clone();
    smooth(&mut kept, &ProblemOptions::default());
    let mut ideal = start.clone();
    smooth(&mut ideal, &{
        let mut po = ProblemOptions::default();
        po.target = Target::Ideal;
        po
    });
    let ((mk, xk), (mi, _), (mp, _)) = (error(&kept), error(&ideal), error(&start));
    eprintln!(
        "hex first layer |h/h0 - 1| median/max: default {mk:.3}/{xk:.3}, ideal {mi:.3} median, perturbed {mp:.3}"
    );
    assert!(metric::inverted_elements(&kept, &kept.points).is_empty());
    assert!(mk < 0.10, "default: {mk}");
    assert!(mi > 1.0, "ideal: {mi}");
}

#[test]
fn every_kind_of_boundary_layer_keeps_its_first_layer_by_default() {
    use meshsmooth::error::Named;
    use meshsmooth::generate::LayerKind;
    for kind in LayerKind::NAMES.iter().map(|&(_, k)| k) {
        let (n, growth) = if kind.dim() == 2 { (24, 1.25) } else { (6, 1.5) };
        let base = generate::boundary_layer(kind, n, 1e-3, growth, 12).unwrap();
        let axis = kind.dim() - 1;
        let start = perturbed(&base, 0.3, 5);
        let (chosen, _) = ProblemOptions::default().resolved(&start).unwrap();
        assert_eq!(chosen.target, Target::Input(InputTargets::default()), "{kind:?}");
        let first = layer_at(&base, axis, 1e-3);
        assert!(first.len() >= 15, "{kind:?}: {}", first.len());
        let error = |m: &Mesh| height_error(m, &base, &first, axis);
        let mut kept = start.clone();
        let info = smooth(&mut kept, &ProblemOptions::default());
        let (mk, xk) = error(&kept);
        let (mp, xp) = error(&start);
        // the shape against the unperturbed mesh's own cells (1: the same
        // shapes): the perturbation is repaired, not only the heights kept
        let shape = |m: &Mesh| {
            let v =
                meshsmooth::metric_report::element_values(&base, &m.points, MetricKind::InverseMeanRatio, Some(&base))
                    .unwrap();
            v.iter().map(|x| x.unwrap() - 1.0).sum::<f64>() / v.len() as f64
        };
        eprintln!(
            "{kind:?}: first layer |h/h0 - 1| median/max {mk:.3}/{xk:.3} (perturbed {mp:.3}/{xp:.3}); {} iterations, {:?}",
            info.iterations, info.stop
        );
        assert!(metric::inverted_elements(&kept, &kept.points).is_empty(), "{kind:?}");
        // the quads under triangles keep a long-wavelength part of the
        // perturbation's thickening that no local fit tells from the mesh's
        // own (8% for this seed; the Gmsh channel pools four seeds to 4.4%)
        let median = if kind == LayerKind::Quad { 0.10 } else { 0.05 };
        assert!(mk < median && xk < 0.25, "{kind:?}: {mk} / {xk}");
        let (sk, sp) = (shape(&kept), shape(&start));
        eprintln!("{kind:?}: mean imr - 1 against the unperturbed cells {sk:.4} (perturbed {sp:.4})");
        assert!(sk < 0.5 * sp, "{kind:?}: {sk} vs {sp}");
    }
}

#[test]
fn an_anisotropically_graded_tet_box_keeps_its_first_layer_by_default() {
    let base = generate::graded_tet_box_aniso(8, 100.0);
    let volumes: Vec<f64> = (0..base.num_elements())
        .map(|e| metric::element_min_det(&base, &base.points, e))
        .collect();
    let ratio = volumes.iter().cloned().fold(0.0, f64::max) / volumes.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!((ratio / 100.0 - 1.0).abs() < 1e-6, "{ratio}");
    // graded along z alone: every layer of vertices stays a plane z = const
    let mut zs: Vec<f64> = base.points.iter().map(|p| p[2]).collect();
    zs.sort_by(f64::total_cmp);
    zs.dedup();
    assert_eq!(zs.len(), 9);
    let first = zs[1];
    let start = perturbed(&base, 0.3, 3);
    let (chosen, _) = ProblemOptions::default().resolved(&start).unwrap();
    assert_eq!(chosen.target, Target::Input(InputTargets::default()));
    let layer = layer_at(&base, 2, first);
    let error = |m: &Mesh| height_error(m, &base, &layer, 2).0;
    let mut kept = start.clone();
    smooth(&mut kept, &ProblemOptions::default());
    let mut ideal = start.clone();
    smooth(&mut ideal, &{
        let mut po = ProblemOptions::default();
        po.target = Target::Ideal;
        po
    });
    let (mk, mi, mp) = (error(&kept), error(&ideal), error(&start));
    eprintln!("aniso graded tets, first layer median |h/h0 - 1|: default {mk:.3}, ideal {mi:.3}, perturbed {mp:.3}");
    assert!(metric::inverted_elements(&kept, &kept.points).is_empty());
    // flat tetrahedra (a graded cell split six ways, growth 5.9 from the wall)
    assert!(mk < 0.05, "default {mk}");
    assert!(mi > 3.0, "ideal {mi}");
}

#[test]
fn a_layer_whose_wall_vertices_slide_keeps_its_heights_with_every_method() {
    use meshsmooth::problem::{Boundary, BoundaryMode};
    let base = generate::boundary_layer(generate::LayerKind::Quad, 24, 1e-3, 1.25, 12).unwrap();
    let dx = 1.0 / 24.0;
    // the interior perturbed, and the wall's own vertices moved along it
    let mut start = perturbed(&base, 0.3, 9);
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let wall: Vec<usize> = (0..base.num_points())
        .filter(|&v| base.points[v][1] == 0.0 && base.points[v][0] > 0.0 && base.points[v][0] < 1.0)
        .collect();
    for &v in &wall {
        start.points[v][0] += 0.3 * dx * rng.random_range(-1.0..1.0);
    }
    let first = layer_at(&base, 1, 1e-3);
    let spacing_spread = |m: &Mesh| {
        let mut xs: Vec<f64> = wall.iter().map(|&v| m.points[v][0]).chain([0.0, 1.0]).collect();
        xs.sort_by(f64::total_cmp);
        let gaps: Vec<f64> = xs.windows(2).map(|w| w[1] - w[0]).collect();
        gaps.iter().cloned().fold(0.0, f64::max) / gaps.iter().cloned().fold(f64::INFINITY, f64::min)
    };
    for method in [Method::Newton, Method::Bcd, Method::Nlcg] {
        let mut po = ProblemOptions::default();
        po.boundary = Boundary {
            mode: BoundaryMode::Slide,
            ..Default::default()
        };
        let mut m = start.clone();
        let mut params = Params::default();
        params.max_iter = if method == Method::Newton { 200 } else { 3000 };
        let info = solve::smooth_mesh(&mut m, &po, &Options::cpu(method, &params), &mut |_| true).unwrap();
        assert!(metric::inverted_elements(&m, &m.points).is_empty(), "{method:?}");
        // the wall stays the wall, and its spacing is evened out again
        for &v in &wall {
            assert!(
                m.points[v][1].abs() < 1e-12,
                "{method:?}: wall vertex {v} left the wall"
            );
        }
        let (sm, sp) = (spacing_spread(&m), spacing_spread(&start));
        let (med, max) = height_error(&m, &base, &first, 1);
        eprintln!(
            "slide, {method:?}: first layer |h/h0 - 1| median/max {med:.3}/{max:.3}; wall spacing max/min {sm:.3} (perturbed {sp:.3}); {} iterations, {:?}",
            info.iterations, info.stop
        );
        assert!(sm < 1.0 + 0.5 * (sp - 1.0), "{method:?}: wall spacing {sm} vs {sp}");
        assert!(med < 0.05 && max < 0.25, "{method:?}: first layer {med} / {max}");
    }
}

#[test]
fn the_mesquite_meshes_keep_the_ideal_target_by_default() {
    // their F and iterations stay those of the ideal objective
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes");
    if !dir.exists() {
        assert!(std::env::var_os("CI").is_none(), "CI must have ../shared/meshes");
        eprintln!("skipping: ../shared/meshes is not here");
        return;
    }
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .chain(std::fs::read_dir(dir.join("planar")).unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "vtk"))
        .collect();
    files.sort();
    assert!(files.len() >= 10, "{files:?}");
    for f in files {
        // (meshes with pyramids are refused by the reader, and never smoothed)
        let mesh = match meshsmooth::io::read(&f) {
            Ok(m) => m,
            Err(e) => {
                assert!(e.to_string().contains("pyramid"), "{}: {e}", f.display());
                continue;
            }
        };
        let (chosen, note) = ProblemOptions::default().resolved(&mesh).unwrap();
        assert_eq!(chosen.target, Target::Ideal, "{}: {note:?}", f.display());
        assert_eq!(chosen.metric, MetricKind::InverseMeanRatio);
    }
}

#[test]
fn a_metric_field_stretches_elements_along_its_eigenvectors() {
    // a band across the middle where the field asks for edges 3x shorter
    // across the band than along it: the band's elements get thinner across
    // it, whichever way the band (the field's eigenvectors) runs
    let n = 16;
    let spacing = 1.0 / n as f64;
    for across in [1usize, 0] {
        let mut mesh = generate::tri_grid(n, n, [1.0, 1.0]);
        let along = 1 - across;
        let m: Vec<f64> = mesh
            .points
            .iter()
            .flat_map(|p| {
                let d = (p[across] - 0.5).abs();
                let h_across = spacing * (1.0 - (2.0 / 3.0) * (-(d / 0.15).powi(2)).exp());
                let (l_across, l_along) = (1.0 / (h_across * h_across), 1.0 / (spacing * spacing));
                // [m_xx, m_xy, m_yy]
                if across == 1 {
                    [l_along, 0.0, l_across]
                } else {
                    [l_across, 0.0, l_along]
                }
            })
            .collect();
        mesh.data
            .point
            .push(DataArray::new("m", ValueType::F64, 3, Values::Float(m)));
        // the mean extent across and along the band of the elements in it
        let extents = |m: &Mesh| {
            let (mut a, mut b, mut count) = (0.0, 0.0, 0.0);
            for e in 0..m.num_elements() {
                let p: Vec<[f64; 3]> = m.element(e).iter().map(|&v| m.points[v as usize]).collect();
                let c = (p[0][across] + p[1][across] + p[2][across]) / 3.0;
                if (c - 0.5).abs() < 0.1 {
                    let span = |k: usize| {
                        let (lo, hi) = p
                            .iter()
                            .fold((f64::MAX, f64::MIN), |(lo, hi), q| (lo.min(q[k]), hi.max(q[k])));
                        hi - lo
                    };
                    a += span(across);
                    b += span(along);
                    count += 1.0;
                }
            }
            (a / count, b / count)
        };
        let (a0, b0) = extents(&mesh);
        let mut opts = ProblemOptions::default();
        opts.metric = MetricKind::ShapeSize;
        opts.target = Target::Metric("m");
        smooth(&mut mesh, &opts);
        let (a1, b1) = extents(&mesh);
        eprintln!("band across axis {across}: extent across {a0:.4} -> {a1:.4}, along {b0:.4} -> {b1:.4}");
        assert!(metric::inverted_elements(&mesh, &mesh.points).is_empty());
        assert!(
            a1 / b1 < 0.75 * (a0 / b0),
            "axis {across}: across/along {} -> {}",
            a0 / b0,
            a1 / b1
        );
    }
}
