//! Reference meshes: targets W from a mesh with the same connectivity, the
//! target-matrix metric, and the errors for references that do not fit.

use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::metric::corner_model::Template;
use meshsmooth::metric::smetric::MetricKind;
use meshsmooth::problem::{Problem, ProblemOptions};
use meshsmooth::solve::{self, Method, Params, StopReason};
use meshsmooth::{ElementKind, Mesh};

fn perturbed(mesh: &Mesh, seed: u64) -> Mesh {
    let mut m = mesh.clone();
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: 0.25 },
        fraction: 1.0,
        seed,
    };
    generate::perturb(&mut m, &opts).unwrap();
    m
}

/// A quad grid in the xy plane (z = 0), `n` x `n` cells, with a sheared reference.
fn quad_grid(n: usize, shear: f64) -> Mesh {
    let pts = (0..(n + 1) * (n + 1)).map(|i| {
        let (x, y) = ((i % (n + 1)) as f64, (i / (n + 1)) as f64);
        [x + shear * y, y, 0.0]
    });
    let mut m = Mesh::new(pts.collect());
    for j in 0..n {
        for i in 0..n {
            let v = (i + (n + 1) * j) as u32;
            let w = (n + 1) as u32;
            m.push_element(ElementKind::Quadrilateral, &[v, v + 1, v + 1 + w, v + w]);
        }
    }
    m
}

fn tmp_options(reference: &Mesh) -> ProblemOptions<'_> {
    {
        let mut po = ProblemOptions::default();
        po.metric = MetricKind::TargetShapeSize;
        po.template = Template::Harmonic;
        po.reference = Some(reference);
        po
    }
}

#[test]
fn the_target_metric_brings_a_perturbed_mesh_back_to_its_reference() {
    let tet = generate::tet_box(4, 4, 4, [4.0; 3]);
    let quad = quad_grid(8, 0.3);
    for (name, reference) in [("tets", tet), ("sheared quads", quad)] {
        for method in [Method::Newton, Method::Bcd] {
            let mut mesh = perturbed(&reference, 3);
            let mut params = Params::default();
            params.tol = 1e-10;
            let info = solve::smooth_mesh(
                &mut mesh,
                &tmp_options(&reference),
                &solve::Options::cpu(method, &params),
                &mut |_| true,
            )
            .unwrap_or_else(|e| panic!("{name} {method}: {e}"));
            assert_eq!(info.stop, StopReason::Converged, "{name} {method}");
            assert!(
                info.history.records[0].objective > 1e-3,
                "{name}: the start should be off target"
            );
            assert!(info.objective < 1e-16, "{name} {method}: F = {}", info.objective);
            let worst = mesh
                .points
                .iter()
                .zip(&reference.points)
                .map(|(a, b)| (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max))
                .fold(0.0, f64::max);
            assert!(worst < 1e-6, "{name} {method}: {worst} from the reference");
        }
    }
}

#[test]
fn every_metric_and_template_converges_on_hexahedra_and_quads() {
    // hexes: a box of cubes, perturbed
    let mut hexes = Mesh::new(
        (0..64)
            .map(|i| [(i % 4) as f64, ((i / 4) % 4) as f64, (i / 16) as f64])
            .collect(),
    );
    for k in 0..3u32 {
        for j in 0..3u32 {
            for i in 0..3u32 {
                let v = i + 4 * j + 16 * k;
                hexes.push_element(
                    ElementKind::Hexahedron,
                    &[v, v + 1, v + 5, v + 4, v + 16, v + 17, v + 21, v + 20],
                );
            }
        }
    }
    for reference in [hexes, quad_grid(6, 0.0)] {
        for (metric, template) in [
            (MetricKind::InverseMeanRatio, Template::Harmonic),
            (MetricKind::InverseMeanRatio, Template::Average),
            (MetricKind::ConditionNumber, Template::Harmonic),
            (MetricKind::ConditionNumber, Template::Average),
        ] {
            let mut mesh = perturbed(&reference, 8);
            let mut opts = ProblemOptions::default();
            opts.metric = metric;
            opts.template = template;
            opts.reference = None;
            let info = solve::smooth_mesh(
                &mut mesh,
                &opts,
                &solve::Options::cpu(Method::Newton, &Params::default()),
                &mut |_| true,
            )
            .unwrap();
            assert_eq!(info.stop, StopReason::Converged, "{metric} {template:?}");
            // the unperturbed grid is ideal for these metrics: back to it
            let ideal = if template == Template::Harmonic { 1.0 } else { 0.0 };
            assert!(
                (info.objective - ideal).abs() < 1e-9,
                "{metric} {template:?}: F = {}",
                info.objective
            );
        }
    }
}

#[test]
fn references_that_do_not_fit_are_refused_with_the_first_mismatch() {
    let mesh = generate::tet_box(2, 2, 2, [2.0; 3]);
    let small = generate::tet_box(1, 2, 2, [1.0, 2.0, 2.0]);
    let err = Problem::with_options(&mesh, &tmp_options(&small))
        .unwrap_err()
        .to_string();
    assert!(err.contains("vertices"), "{err}");

    let mut swapped = mesh.clone();
    let e = 7;
    let o = swapped.offsets[e];
    swapped.conn.swap(o + 1, o + 2);
    let err = Problem::with_options(&mesh, &tmp_options(&swapped))
        .unwrap_err()
        .to_string();
    assert!(err.contains("element 7"), "{err}");

    let mut inverted = mesh.clone();
    let centre = inverted.points.iter().position(|p| *p == [1.0, 1.0, 1.0]).unwrap();
    inverted.points[centre] = [2.5, 2.5, 2.5];
    let err = Problem::with_options(&mesh, &tmp_options(&inverted))
        .unwrap_err()
        .to_string();
    assert!(err.contains("inverted or degenerate"), "{err}");

    let mut no_ref = ProblemOptions::default();
    no_ref.metric = MetricKind::TargetShapeSize;
    assert!(
        Problem::with_options(&mesh, &no_ref)
            .unwrap_err()
            .to_string()
            .contains("needs a reference mesh")
    );
    let mut avg = tmp_options(&mesh);
    avg.template = Template::Average;
    assert!(
        Problem::with_options(&mesh, &avg)
            .unwrap_err()
            .to_string()
            .contains("average template")
    );
}
