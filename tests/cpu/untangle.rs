//! Untangling (issue 15): generated meshes perturbed without the inversion
//! guard until 5–30% of their elements invert, every kind, box, duct and
//! graded mesh; zero inverted elements after, fixed vertices unmoved, and the
//! smoothed result within 1% of what smoothing reaches from an untangled
//! start of the same mesh.

use crate::common;
use common::prism_stack;

use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::mesh::topology::fixed_vertices;
use meshsmooth::metric::inverted_elements;
use meshsmooth::problem::ProblemOptions;
use meshsmooth::solve::untangle::{UntangleParams, convention_problem, untangle_mesh};
use meshsmooth::solve::{self, Method, Options, Params};
use meshsmooth::{Error, Mesh};

/// `reference` perturbed without the guard (random moves of `alpha` mean
/// edge lengths, all free vertices), with the share of elements it inverted.
fn tangled(reference: &Mesh, alpha: f64, seed: u64) -> (Mesh, f64) {
    let mut m = reference.clone();
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha },
        fraction: 1.0,
        seed,
    };
    generate::perturb_unguarded(&mut m, &opts).unwrap();
    let share = inverted_elements(&m, &m.points).len() as f64 / m.num_elements() as f64;
    (m, share)
}

fn params() -> Params {
    {
        let mut p = Params::default();
        p.tol = 1e-7;
        p.max_iter = 400;
        p
    }
}

/// Untangles then smooths `mesh`; checks the three properties
/// against a guarded perturbation of `reference` smoothed the same way.
fn check(name: &str, reference: &Mesh, alpha: f64, method: Method) {
    let (mut mesh, share) = tangled(reference, alpha, 11);
    assert!(
        (0.05..=0.30).contains(&share),
        "{name}: {:.1}% of the elements inverted, want 5-30%",
        100.0 * share
    );
    let before = mesh.points.clone();
    let fixed = fixed_vertices(&mesh);
    let opts = Options::cpu(method, &params());
    let info = untangle_mesh(
        &mut mesh,
        &ProblemOptions::default(),
        &opts,
        &UntangleParams::default(),
        &mut |_| true,
    )
    .unwrap_or_else(|e| panic!("{name}: {e}"));
    assert!(info.inverted_before > 0 && info.inverted_after == 0, "{name}: {info:?}");
    assert!(inverted_elements(&mesh, &mesh.points).is_empty(), "{name}");
    for (v, &f) in fixed.iter().enumerate() {
        if f {
            assert_eq!(mesh.points[v], before[v], "{name}: fixed vertex {v} moved");
        }
    }
    let untangled = solve::smooth_mesh(&mut mesh, &ProblemOptions::default(), &opts, &mut |_| true).unwrap();
    assert!(inverted_elements(&mesh, &mesh.points).is_empty(), "{name}");
    for (v, &f) in fixed.iter().enumerate() {
        if f {
            assert_eq!(mesh.points[v], before[v], "{name}: fixed vertex {v} moved");
        }
    }
    // the same mesh from a start that was never tangled
    let mut start = reference.clone();
    let opts_p = PerturbOptions {
        perturbation: Perturbation::Random { alpha: 0.2 },
        fraction: 1.0,
        seed: 3,
    };
    generate::perturb(&mut start, &opts_p).unwrap();
    let plain = solve::smooth_mesh(&mut start, &ProblemOptions::default(), &opts, &mut |_| true).unwrap();
    let gap = (untangled.objective - plain.objective).abs() / plain.objective;
    assert!(
        gap < 0.01,
        "{name}: F after untangling {} vs {} from an untangled start ({:.2}%), {} rounds",
        untangled.objective,
        plain.objective,
        100.0 * gap,
        info.rounds
    );
    eprintln!(
        "{name}: {:.1}% inverted, {} rounds / {} inner iterations, F {} vs {}",
        100.0 * share,
        info.rounds,
        info.iterations,
        untangled.objective,
        plain.objective
    );
}

#[test]
fn tangled_triangles_untangle() {
    check("tri", &generate::tri_grid(12, 12, [12.0, 12.0]), 0.6, Method::Newton);
}

#[test]
fn tangled_quads_untangle() {
    check("quad", &generate::quad_grid(12, 12, [12.0, 12.0]), 0.6, Method::Newton);
}

#[test]
fn tangled_tet_box_untangles() {
    check("tet box", &generate::tet_box(6, 6, 6, [6.0; 3]), 0.6, Method::Newton);
}

#[test]
fn tangled_hexes_untangle() {
    check("hex", &generate::hex_box(6, 6, 6, [6.0; 3]), 0.45, Method::Newton);
}

#[test]
fn tangled_prisms_untangle() {
    check("prism", &prism_stack(6), 0.6, Method::Newton);
}

#[test]
fn tangled_duct_untangles() {
    check("duct", &generate::duct(3), 0.6, Method::Newton);
}

#[test]
fn tangled_graded_box_untangles() {
    check("graded", &generate::graded_tet_box(6, 1e2), 0.6, Method::Newton);
}

#[test]
fn tangled_box_untangles_with_bcd() {
    check("tet box bcd", &generate::tet_box(5, 5, 5, [5.0; 3]), 0.6, Method::Bcd);
}

/// Two tetrahedra sharing a face, every vertex on the boundary (Mesquite's
/// `two_tets.vtk` case): one inverted cannot be repaired.
#[test]
fn an_inverted_element_with_every_vertex_fixed_is_refused_with_the_reason() {
    let mut m = Mesh::new(vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.2, 0.2, 0.2],
    ]);
    m.push_element(meshsmooth::ElementKind::Tetrahedron, &[0, 1, 2, 3]);
    m.push_element(meshsmooth::ElementKind::Tetrahedron, &[0, 2, 1, 4]);
    assert_eq!(inverted_elements(&m, &m.points), vec![1]);
    let before = m.points.clone();
    let err = untangle_mesh(
        &mut m,
        &ProblemOptions::default(),
        &Options::cpu(Method::Newton, &params()),
        &UntangleParams::default(),
        &mut |_| true,
    )
    .unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, Error::Untangle { count: 1, .. }), "{text}");
    assert!(
        text.contains("element(s) 1") && text.contains("every vertex fixed"),
        "{text}"
    );
    assert_eq!(m.points, before, "a failed untangle leaves the mesh as it was");
}

/// Every prism mirrored (a wedge node order from another convention) is not a
/// tangle: refused with that explanation.
#[test]
fn every_element_of_a_kind_mirrored_is_a_convention_problem() {
    let m = prism_stack(3);
    assert!(convention_problem(&m).is_none());
    let n = m.num_elements();
    let mut flipped = Mesh::new(m.points.clone());
    for e in 0..n {
        let v = m.element(e).to_vec();
        flipped.push_element(meshsmooth::ElementKind::Prism, &[v[0], v[2], v[1], v[3], v[5], v[4]]);
    }
    assert_eq!(inverted_elements(&flipped, &flipped.points).len(), n);
    let msg = convention_problem(&flipped).expect("a convention problem");
    assert!(
        msg.contains("node-ordering convention") && msg.contains("prism"),
        "{msg}"
    );
    let err = untangle_mesh(
        &mut flipped,
        &ProblemOptions::default(),
        &Options::cpu(Method::Newton, &params()),
        &UntangleParams::default(),
        &mut |_| true,
    )
    .unwrap_err();
    assert!(err.to_string().contains("convention"), "{err}");
    // one tangled prism among valid ones is a tangle, not a convention problem
    let (t, _) = tangled(&prism_stack(4), 0.6, 11);
    assert!(!inverted_elements(&t, &t.points).is_empty());
    assert!(convention_problem(&t).is_none());
}

/// The result does not depend on the units: scaling and shifting the
/// tangled input scales and shifts the untangled output.
#[test]
fn untangling_is_unit_free() {
    let (m, _) = tangled(&generate::tri_grid(8, 8, [8.0, 8.0]), 0.6, 5);
    let run = |mut mesh: Mesh| {
        untangle_mesh(
            &mut mesh,
            &ProblemOptions::default(),
            &Options::cpu(Method::Newton, &params()),
            &UntangleParams::default(),
            &mut |_| true,
        )
        .unwrap();
        mesh
    };
    let a = run(m.clone());
    let mut scaled = m.clone();
    // a power of two and a shift: the frame makes the runs identical
    scaled
        .points
        .iter_mut()
        .for_each(|p| *p = [4.0 * p[0] + 1000.0, 4.0 * p[1] - 7.0, p[2]]);
    let b = run(scaled);
    for (p, q) in a.points.iter().zip(&b.points) {
        for k in 0..2 {
            let back = if k == 0 {
                (q[0] - 1000.0) / 4.0
            } else {
                (q[1] + 7.0) / 4.0
            };
            assert!((p[k] - back).abs() <= 1e-9 * 8.0, "{p:?} vs {q:?}");
        }
    }
}

/// Mesquite's tangled meshes (`../shared/meshes/tangled`, read when the
/// folder exists; the generated cases above need nothing outside the crate):
/// untangled with zero inverted elements, fixed vertices unmoved, and then
/// smoothed to a valid mesh.
#[test]
fn mesquite_tangled_meshes_untangle() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes/tangled");
    if !dir.exists() {
        eprintln!("skipping: {} not present", dir.display());
        return;
    }
    for name in ["tangled_quad", "tangled_tri", "inverted-hole-1", "tet_4_tangled"] {
        let path = dir.join(format!("{name}.vtk"));
        let mut mesh = meshsmooth::io::read(&path).unwrap();
        let before = mesh.points.clone();
        let inverted = inverted_elements(&mesh, &mesh.points).len();
        assert!(inverted > 0, "{name} is not tangled");
        let fixed = fixed_vertices(&mesh);
        let opts = Options::cpu(Method::Newton, &params());
        let info = untangle_mesh(
            &mut mesh,
            &ProblemOptions::default(),
            &opts,
            &UntangleParams::default(),
            &mut |_| true,
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(info.inverted_before, inverted, "{name}");
        assert!(inverted_elements(&mesh, &mesh.points).is_empty(), "{name}");
        let smoothed = solve::smooth_mesh(&mut mesh, &ProblemOptions::default(), &opts, &mut |_| true).unwrap();
        assert!(smoothed.objective.is_finite() && inverted_elements(&mesh, &mesh.points).is_empty());
        for (v, &f) in fixed.iter().enumerate() {
            if f {
                assert_eq!(mesh.points[v], before[v], "{name}: fixed vertex {v} moved");
            }
        }
        eprintln!(
            "{name}: {inverted} inverted -> 0 in {} rounds, F after smoothing {}",
            info.rounds, smoothed.objective
        );
    }
}

/// Rounds of a few inner iterations each: eps follows Garanzha et al.'s
/// schedule down (never up) and the mesh still ends untangled.
#[test]
fn eps_decreases_over_short_rounds_and_the_mesh_untangles() {
    for (name, r) in [
        ("tet", generate::tet_box(5, 5, 5, [5.0; 3])),
        ("quad", generate::quad_grid(10, 10, [10.0, 10.0])),
    ] {
        let (mut m, _) = tangled(&r, 1.0, 2);
        let params = UntangleParams {
            inner_max_iter: 1,
            ..Default::default()
        };
        let info = untangle_mesh(
            &mut m,
            &ProblemOptions::default(),
            &Options::cpu(Method::Newton, &Params::default()),
            &params,
            &mut |_| true,
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(info.rounds > 1, "{name}: {info:?}");
        assert!(
            info.schedule.windows(2).all(|w| w[1].0 <= w[0].0),
            "{name}: {:?}",
            info.schedule
        );
        assert!(inverted_elements(&m, &m.points).is_empty(), "{name}");
    }
}

/// A fan of triangles around one free vertex whose fixed boundary is a "C":
/// no point sees the whole boundary, so no position of the free vertex makes
/// every triangle valid. The error says so; the partial variant keeps the
/// last positions.
fn c_fan() -> Mesh {
    let boundary = [
        [0.0, 0.0],
        [4.0, 0.0],
        [4.0, 1.0],
        [1.0, 1.0],
        [1.0, 2.0],
        [4.0, 2.0],
        [4.0, 3.0],
        [0.0, 3.0],
    ];
    let mut points: Vec<[f64; 3]> = boundary.iter().map(|p| [p[0], p[1], 0.0]).collect();
    points.push([0.5, 1.5, 0.0]);
    let mut m = Mesh::new(points);
    for i in 0..8u32 {
        m.push_element(meshsmooth::ElementKind::Triangle, &[8, i, (i + 1) % 8]);
    }
    m
}

#[test]
fn a_tangle_without_a_valid_position_fails_after_its_rounds() {
    let m = c_fan();
    let bad = inverted_elements(&m, &m.points);
    assert!(!bad.is_empty() && bad.len() < 8);
    let run = |partial: bool| {
        let mut mesh = m.clone();
        let params = UntangleParams {
            max_rounds: 8,
            ..Default::default()
        };
        let opts = Options::cpu(Method::Newton, &Params::default());
        let err = if partial {
            meshsmooth::solve::untangle::untangle_mesh_partial(
                &mut mesh,
                &ProblemOptions::default(),
                &opts,
                &params,
                &mut |_| true,
            )
        } else {
            untangle_mesh(&mut mesh, &ProblemOptions::default(), &opts, &params, &mut |_| true)
        }
        .unwrap_err();
        (err, mesh)
    };
    let (err, mesh) = run(false);
    let text = err.to_string();
    assert!(matches!(err, Error::Untangle { .. }), "{text}");
    assert!(
        text.contains("no positions of their free vertices") && text.contains("8 rounds"),
        "{text}"
    );
    assert_eq!(mesh.points, m.points, "nothing moves without the partial variant");
    let (_, partial) = run(true);
    assert_ne!(
        partial.points[8], m.points[8],
        "the partial variant keeps the last positions"
    );
    assert_eq!(partial.points[..8], m.points[..8]);
}

#[test]
fn the_time_limit_covers_every_round_and_is_named_when_it_ends_the_run() {
    let mut m = c_fan();
    let mut params = Params::default();
    params.time_limit = Some(std::time::Duration::from_nanos(1));
    let err = untangle_mesh(
        &mut m,
        &ProblemOptions::default(),
        &Options::cpu(Method::Newton, &params),
        &UntangleParams::default(),
        &mut |_| true,
    )
    .unwrap_err();
    assert!(
        err.to_string().contains("the time limit ran out after 0 rounds"),
        "{err}"
    );
}
