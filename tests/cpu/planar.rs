//! Planar meshes in any plane: the xy plane, the xz plane (either winding), a
//! tilted plane. Each is checked, reported and optimised in its own 2D
//! coordinates: the same F as the xy copy, points written back on the input
//! plane (its constant coordinate bit for bit where it has one), fixed
//! vertices untouched. A mesh that is not flat is refused with its deviation.

use crate::common;
use common::options;

use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::metric::mat3::Vec3;
use meshsmooth::report::quality_report;
use meshsmooth::solve::{self, Device, Info, Method, Params};
use meshsmooth::{Mesh, io};
use std::path::Path;

fn xy_start(kind_quad: bool) -> Mesh {
    let mut m = if kind_quad {
        generate::quad_grid(6, 5, [6.0, 5.0])
    } else {
        generate::tri_grid(6, 5, [6.0, 5.0])
    };
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: 0.3 },
        fraction: 1.0,
        seed: 4,
    };
    generate::perturb(&mut m, &opts).unwrap();
    m
}

fn placed(m: &Mesh, f: impl Fn(&Vec3) -> Vec3) -> Mesh {
    Mesh {
        points: m.points.iter().map(f).collect(),
        ..m.clone()
    }
}

/// Where a plane's copy of the xy mesh goes.
type Placement = Box<dyn Fn(&Vec3) -> Vec3>;

fn smooth(m: &mut Mesh, method: Method) -> Info {
    let mut params = Params::default();
    params.tol = 1e-9;
    solve::smooth_mesh(
        m,
        &Default::default(),
        &options(method, &params, Device::Cpu),
        &mut |_| true,
    )
    .unwrap()
}

#[test]
fn every_plane_gives_the_xy_answer_on_the_input_plane() {
    let (c, s) = (0.6f64, 0.8f64);
    for quad in [false, true] {
        let xy = xy_start(quad);
        let cases: [(&str, Placement); 3] = [
            ("xz", Box::new(|p: &Vec3| [p[0], 0.1, p[1]])),
            ("xz, other winding", Box::new(|p: &Vec3| [p[1], -3.7, p[0]])),
            (
                "tilted",
                Box::new(move |p: &Vec3| [p[0], c * p[1] + 2.0, s * p[1] - 1.0]),
            ),
        ];
        for method in [Method::Newton, Method::Bcd] {
            let mut base = xy.clone();
            let want = smooth(&mut base, method);
            for (name, f) in &cases {
                let start = placed(&xy, f);
                let report = quality_report(&start, &start.points);
                assert_eq!(report.inverted, 0, "{name}: read in its own plane");
                let mut m = start.clone();
                let info = smooth(&mut m, method);
                let case = format!("{} {name} {method}", if quad { "quad" } else { "tri" });
                assert!(
                    (info.objective - want.objective).abs() <= 1e-10 * want.objective,
                    "{case}: F {} vs the xy copy's {}",
                    info.objective,
                    want.objective
                );
                assert!(info.iterations.abs_diff(want.iterations) <= 1, "{case}: iterations");
                // the same mesh, on the input plane
                let expect = placed(&base, f);
                for (v, (got, exp)) in m.points.iter().zip(&expect.points).enumerate() {
                    let d = (0..3).map(|k| (got[k] - exp[k]).abs()).fold(0.0, f64::max);
                    assert!(d < 1e-7, "{case}: vertex {v} at {got:?}, expected {exp:?}");
                    if base.points[v] == xy.points[v] {
                        assert_eq!(*got, start.points[v], "{case}: fixed vertex {v} moved");
                    }
                    match *name {
                        "xz" => assert_eq!(got[1].to_bits(), 0.1f64.to_bits(), "{case}: y changed"),
                        "xz, other winding" => assert_eq!(got[1], -3.7, "{case}: y changed"),
                        _ => {
                            let off = -s * (got[1] - 2.0) + c * (got[2] + 1.0);
                            assert!(off.abs() < 1e-12, "{case}: vertex {v} is {off:e} off the plane");
                        }
                    }
                }
                assert_eq!(quality_report(&m, &m.points).inverted, 0, "{case}");
            }
        }
    }
}

#[test]
fn a_planar_mesh_bent_out_of_its_plane_is_smoothed_as_a_surface() {
    let start = {
        let mut m = placed(&xy_start(false), |p| [p[0], 0.6 * p[1], 0.8 * p[1]]);
        m.points[20][0] += 0.2;
        m.points[20][1] += 0.5;
        m
    };
    let mut m = start.clone();
    let info = solve::smooth_mesh(
        &mut m,
        &Default::default(),
        &options(Method::Newton, &Params::default(), Device::Cpu),
        &mut |_| true,
    )
    .unwrap();
    assert!(info.objective < info.history.first().unwrap().objective);
    // the rim stays, as a planar mesh's boundary does
    let rim = meshsmooth::mesh::topology::skin_vertices(&start);
    for v in (0..m.num_points()).filter(|&v| rim[v]) {
        assert_eq!(m.points[v], start.points[v], "rim vertex {v} moved");
    }
}

/// Mesquite's off-axis planar meshes, where the folder is present (it is in CI).
#[test]
fn mesquites_planar_meshes_smooth_in_their_planes() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes/planar");
    if !dir.is_dir() {
        eprintln!("skipping: {} not found", dir.display());
        return;
    }
    for name in ["tri_5_xz.vtk", "tri_5_not_xy.vtk", "quad_2_not_xy.vtk"] {
        let start = io::read(dir.join(name)).unwrap();
        assert_eq!(quality_report(&start, &start.points).inverted, 0, "{name}");
        let mut m = start.clone();
        let info = smooth(&mut m, Method::Newton);
        let f0 = info.history.first().unwrap().objective;
        eprintln!(
            "{name}: F {f0:.8} -> {:.8} in {} iterations",
            info.objective, info.iterations
        );
        assert_eq!(info.stop, solve::StopReason::Converged, "{name}");
        assert!(info.objective < f0, "{name}");
        assert_eq!(quality_report(&m, &m.points).inverted, 0, "{name}");
        if name == "tri_5_xz.vtk" {
            assert!(
                m.points.iter().zip(&start.points).all(|(a, b)| a[1] == b[1]),
                "{name}: y changed"
            );
        }
    }
}
