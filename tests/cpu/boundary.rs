//! Sliding boundary (`--boundary slide`): boundary vertices move within
//! their patch or along their feature edge and stay on the original boundary
//! triangulation; corners stay. Checked on a box (flat faces, straight
//! edges, corners), a cylinder (curved side, flat caps, circular rims) and a
//! planar grid, on the CPU and against it on the GPU.

use crate::common;

use common::{context, options};
use meshsmooth::Mesh;
use meshsmooth::backend::gpu::{GpuContext, Precision};
use meshsmooth::generate;
use meshsmooth::metric::mat3::{Vec3, dot, sub};
use meshsmooth::problem::{Boundary, BoundaryMode, Problem, ProblemOptions};
use meshsmooth::solve::{self, Device, Info, Method, Params};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn slide() -> ProblemOptions<'static> {
    {
        let mut po = ProblemOptions::default();
        po.boundary = Boundary {
            mode: BoundaryMode::Slide,
            ..Default::default()
        };
        po
    }
}

fn smooth(mesh: &mut Mesh, po: &ProblemOptions, method: Method, device: Device) -> Info {
    let mut params = Params::default();
    params.max_iter = 200;
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

/// A 3^3 box with shuffled boundary whose skin triangles are Gmsh lower cells
/// in groups "bottom" (z = 0, tag 1), "top" (tag 2) and "walls" (tag 3), the
/// tetrahedra in "solid" (tag 10), written as a Gmsh 2.2 file and read back.
fn gmsh_box(dir: &std::path::Path) -> (std::path::PathBuf, Mesh) {
    use meshsmooth::io::{self, Format};
    use meshsmooth::mesh::data::{GMSH_PHYSICAL, PhysicalName};
    use meshsmooth::mesh::{DataArray, LowerKind, ValueType, Values};
    let mut m = box_shuffled(3, 0.2, 3);
    let ideal = generate::tet_box(3, 3, 3, [3.0; 3]);
    let mut tags = Vec::new();
    for t in skin_triangles(&ideal) {
        let id = |p: &Vec3| ideal.points.iter().position(|q| q == p).unwrap() as u32;
        m.lower.push((LowerKind::Triangle, t.iter().map(id).collect()));
        tags.push(if t.iter().all(|p| p[2] == 0.0) {
            1
        } else if t.iter().all(|p| p[2] == 3.0) {
            2
        } else {
            3
        });
    }
    m.fixed = vec![false; m.num_points()];
    for (_, vs) in &m.lower {
        vs.iter().for_each(|&v| m.fixed[v as usize] = true);
    }
    m.data.cell = vec![DataArray::new(
        GMSH_PHYSICAL,
        ValueType::I32,
        1,
        Values::Int(vec![10; m.num_elements()]),
    )];
    m.data.lower = vec![DataArray::new(GMSH_PHYSICAL, ValueType::I32, 1, Values::Int(tags))];
    m.data.physical_names = [(2, 1, "bottom"), (2, 2, "top"), (2, 3, "walls"), (3, 10, "solid")]
        .map(|(dim, tag, name)| PhysicalName {
            dim,
            tag,
            name: name.into(),
        })
        .to_vec();
    let path = dir.join("box.msh");
    io::write_mesh(&path, &m, Format::Msh22Ascii).unwrap();
    let back = io::read(&path).unwrap();
    (path, back)
}

#[test]
fn gmsh_groups_by_name_stay_fixed_while_the_rest_slides() {
    use meshsmooth::mesh::fixing::FixRules;
    let dir = tempfile::tempdir().unwrap();
    let (_, start) = gmsh_box(dir.path());
    let mut mesh = start.clone();
    let rules = FixRules {
        fix_groups: vec!["bottom".into()],
        release_facets: true,
        ..Default::default()
    };
    let report = rules.apply(&mut mesh).unwrap();
    assert_eq!(report.last().unwrap().vertices, 16, "{report:?}");
    smooth(&mut mesh, &slide(), Method::Newton, Device::Cpu);
    let mut slid_top = 0;
    for (v, (a, b)) in start.points.iter().zip(&mesh.points).enumerate() {
        if a[2] == 0.0 {
            assert_eq!(a, b, "bottom vertex {v} moved");
        } else if a[2] == 3.0 && a != b {
            assert!((b[2] - 3.0).abs() < 1e-12);
            slid_top += 1;
        }
    }
    assert!(slid_top > 0, "the top did not slide");
    // by number, the same group
    let mut by_number = start.clone();
    let r = FixRules {
        fix_groups: vec!["1".into()],
        ..Default::default()
    };
    assert_eq!(r.apply(&mut by_number).unwrap()[0].vertices, 16);
}

#[test]
fn cli_reports_each_rule_and_keeps_fixed_groups() {
    let dir = tempfile::tempdir().unwrap();
    let (input, start) = gmsh_box(dir.path());
    let ids = dir.path().join("ids.txt");
    std::fs::write(&ids, "# pinned\n21, 22\n").unwrap();
    let out = dir.path().join("out.msh");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_meshsmooth"))
        .args(["smooth", input.to_str().unwrap(), "-o", out.to_str().unwrap()])
        .args([
            "--boundary",
            "slide",
            "--fix-group",
            "bottom",
            "--fixed-file",
            ids.to_str().unwrap(),
        ])
        .args(["--device", "cpu"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{text}");
    assert!(text.contains("--fix-group bottom: 16 vertices"), "{text}");
    assert!(
        text.contains(&format!("--fixed-file {}: 2 vertices", ids.display())),
        "{text}"
    );
    assert!(text.contains("along feature edges; 8 corners fixed"), "{text}");
    let after = meshsmooth::io::read(&out).unwrap();
    for v in 0..start.num_points() {
        if start.points[v][2] == 0.0 || v == 21 || v == 22 {
            assert_eq!(start.points[v], after.points[v], "vertex {v}");
        }
    }
    // a group that does not exist, and a bad id file: clear errors, no output
    let bad = dir.path().join("bad.msh");
    for extra in [["--fix-group", "inlet"], ["--fixed-file", "/nonexistent/ids.txt"]] {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_meshsmooth"))
            .args(["smooth", input.to_str().unwrap(), "-o", bad.to_str().unwrap()])
            .args(extra)
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(!o.status.success());
        assert!(text.contains(extra[1]), "{text}");
        assert!(!bad.exists());
    }
    std::fs::write(&ids, "3\n4 x5\n").unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_meshsmooth"))
        .args(["smooth", input.to_str().unwrap(), "-o", bad.to_str().unwrap()])
        .args(["--fixed-file", ids.to_str().unwrap()])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(!o.status.success());
    assert!(
        text.contains("ids.txt") && text.contains("line 2") && text.contains("x5"),
        "{text}"
    );
}

#[test]
fn planar_boundary_slides_along_its_sides() {
    let n = 6;
    let mut start = generate::tri_grid(n, n, [n as f64; 2]);
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    for p in &mut start.points {
        for c in p.iter_mut().take(2) {
            if *c != 0.0 && *c != n as f64 {
                *c += rng.random_range(-0.25..0.25);
            }
        }
    }
    for method in [Method::Newton, Method::Bcd, Method::Laplace] {
        let mut fixed = start.clone();
        let f_fixed = smooth(&mut fixed, &ProblemOptions::default(), method, Device::Cpu).objective;
        let mut slid = start.clone();
        let info = smooth(&mut slid, &slide(), method, Device::Cpu);
        if method != Method::Laplace {
            assert!(
                info.objective < f_fixed - 1e-4,
                "{method}: {} vs {f_fixed}",
                info.objective
            );
        }
        let nf = n as f64;
        let on = |c: f64| c == 0.0 || c == nf;
        let mut moved = 0;
        for (v, (a, b)) in start.points.iter().zip(&slid.points).enumerate() {
            let bound = a[..2].iter().filter(|&&c| on(c)).count();
            for k in 0..2 {
                if on(a[k]) {
                    assert!((b[k] - a[k]).abs() <= 1e-12 * nf, "{method}: vertex {v} left its side");
                }
            }
            if bound == 2 {
                assert_eq!(a, b, "{method}: corner {v} moved");
            }
            moved += usize::from(bound == 1 && a != b);
            assert_eq!(a[2], b[2]);
        }
        assert!(moved > 0, "{method}: nothing slid");
    }
}

#[test]
fn sliding_does_not_depend_on_units() {
    let start = cylinder(4, 3);
    let mut a = start.clone();
    smooth(&mut a, &slide(), Method::Newton, Device::Cpu);
    let (s, t) = (1e3, [5e4, -2e3, 7.0]);
    let mut b = start.clone();
    for p in &mut b.points {
        *p = [0, 1, 2].map(|k| s * p[k] + t[k]);
    }
    smooth(&mut b, &slide(), Method::Newton, Device::Cpu);
    for (p, q) in a.points.iter().zip(&b.points) {
        for k in 0..3 {
            assert!((s * p[k] + t[k] - q[k]).abs() <= 1e-9 * s, "{p:?} vs {q:?}");
        }
    }
}

#[test]
fn fixed_boundary_is_the_default_and_unchanged() {
    let m = cylinder(4, 3);
    let p = Problem::new(&m).unwrap();
    assert!(p.sliding.is_none());
    let skin = meshsmooth::mesh::topology::skin_vertices(&m);
    for (new, &old) in p.order.iter().enumerate() {
        assert_eq!(p.free[new], !skin[old as usize]);
    }
    let slid = Problem::with_options(&m, &slide()).unwrap();
    let s = slid.sliding.as_ref().unwrap();
    // the cylinder has no corners: every skin vertex slides
    assert_eq!(s.counts[2], 0);
    assert!(slid.free.iter().all(|&f| f));
}

/// Mesquite's flat-tet-sphere (when ../shared holds it): a real curved
/// boundary; sliding improves on fixed and every vertex stays on the sphere's
/// original triangulation.
#[test]
fn flat_tet_sphere_slides_on_its_triangulation() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes/flat-tet-sphere.vtk");
    if !path.exists() {
        eprintln!("skipping: {} not present", path.display());
        return;
    }
    let mut start = meshsmooth::io::read(&path).unwrap();
    // its `fixed` array pins the whole skin (Mesquite's setting): released here
    assert!(!start.fixed.is_empty());
    start.fixed.clear();
    let mut params = Params::default();
    params.max_iter = 20;
    let run = |po: &ProblemOptions| {
        let mut m = start.clone();
        let info = solve::smooth_mesh(&mut m, po, &options(Method::Newton, &params, Device::Cpu), &mut |_| {
            true
        })
        .unwrap();
        (m, info)
    };
    let (_, fixed) = run(&ProblemOptions::default());
    let (slid, info) = run(&slide());
    assert!(
        info.objective < fixed.objective,
        "{} vs {}",
        info.objective,
        fixed.objective
    );
    let tris = skin_triangles(&start);
    let skin = meshsmooth::mesh::topology::skin_vertices(&start);
    let extent = start.points.iter().map(|p| dot(p, p).sqrt()).fold(0.0, f64::max);
    for v in (0..start.num_points()).filter(|&v| skin[v]) {
        let d = tris
            .iter()
            .map(|t| dist_to_triangle(&slid.points[v], t))
            .fold(f64::INFINITY, f64::min);
        assert!(d <= 1e-9 * extent, "vertex {v} is {d} off the sphere's triangulation");
    }
}

/// The cylinder slid on a GPU next to the CPU: the same F (f64 tightly, f32
/// to its rounding), every boundary vertex on the original boundary (f64 to
/// 1e-9; f32 positions are rounded to f32 after the projection) and the rims
/// on their caps. `#[ignore]`: a full solve on lavapipe.
fn gpu_cylinder(ctx: &GpuContext, method: Method, f_tol: f64, d_tol: f64) {
    let start = cylinder(5, 3);
    let mut cpu = start.clone();
    // a GPU sweeps BCD colour by colour: the CPU's twin of that is bcd-colored
    let cpu_method = if method == Method::Bcd {
        Method::BcdColored
    } else {
        method
    };
    let fc = smooth(&mut cpu, &slide(), cpu_method, Device::Cpu).objective;
    let mut gpu = start.clone();
    let info = smooth(&mut gpu, &slide(), method, Device::Gpu(ctx));
    assert!(
        (info.objective - fc).abs() <= f_tol * fc,
        "{method}: GPU {} vs CPU {fc}",
        info.objective
    );
    let mut fixed = start.clone();
    let ff = smooth(&mut fixed, &ProblemOptions::default(), method, Device::Gpu(ctx)).objective;
    assert!(
        info.objective < ff - 1e-3,
        "{method}: slide {} vs fixed {ff}",
        info.objective
    );
    let tris = skin_triangles(&start);
    for (v, (a, b)) in start.points.iter().zip(&gpu.points).enumerate() {
        let on_cap = a[2] == 0.0 || a[2] == 2.0;
        if on_cap || ((a[0] * a[0] + a[1] * a[1]).sqrt() - 1.0).abs() < 1e-12 {
            let d = tris
                .iter()
                .map(|t| dist_to_triangle(b, t))
                .fold(f64::INFINITY, f64::min);
            assert!(d <= d_tol * 2.0, "{method}: vertex {v} is {d} off the boundary");
        }
        if on_cap {
            assert!(
                (b[2] - a[2]).abs() <= d_tol * 2.0,
                "{method}: cap vertex {v} left its cap"
            );
        }
    }
}

#[test]
#[ignore]
fn gpu_sliding_matches_cpu_f64() {
    let Some(ctx) = context(Precision::F64) else {
        return;
    };
    for method in [Method::Newton, Method::Bcd] {
        gpu_cylinder(&ctx, method, 1e-9, 1e-9);
    }
}

#[test]
#[ignore]
fn gpu_sliding_matches_cpu_f32() {
    let Some(ctx) = context(Precision::F32) else {
        return;
    };
    for method in [Method::Newton, Method::Bcd] {
        gpu_cylinder(&ctx, method, 1e-4, 1e-6);
    }
}

/// A planar mesh whose bottom side bends up by 16.7° at vertex b (an edge
/// vertex: it slides along l-b-r) with an interior vertex i 0.03 above b-r.
/// Points: l, b, r, tr, tl, i.
fn bent_side() -> Mesh {
    let mut m = Mesh::new(vec![
        [-1.0, 0.0, 0.0],
        [0.0, 0.0, 0.0],
        [1.0, 0.3, 0.0],
        [1.0, 2.0, 0.0],
        [-1.0, 2.0, 0.0],
        [0.5, 0.18, 0.0],
    ]);
    for t in [[0, 1, 4], [1, 5, 4], [1, 2, 5], [2, 3, 5], [5, 3, 4]] {
        m.push_element(meshsmooth::ElementKind::Triangle, &t);
    }
    m
}

/// A step of b along its tangent line that leaves every element valid, but
/// whose projection back onto the original side b-r crosses the line i-tl and
/// inverts (b, i, tl): the line search's trial (CPU, and the GPU where there is
/// one) is infeasible, so the step is rejected; a solve keeps every element valid.
#[test]
fn projection_that_inverts_an_element_is_rejected() {
    use meshsmooth::backend::cpu::CpuBackend;
    use meshsmooth::backend::gpu::GpuBackend;
    use meshsmooth::backend::{Backend, Coef, EvalSlots, Points, Slot};
    let mesh = bent_side();
    let p = Problem::with_options(&mesh, &slide()).unwrap();
    let x0 = p.gather(&mesh.points);
    let b = p.order.iter().position(|&o| o == 1).unwrap();
    let s = p.sliding.as_ref().unwrap();
    assert!(s.slides(b));
    assert_eq!(s.counts, [0, 1, 4], "b slides along the side, the rest are corners");
    // the tangent at b is the mean of its sides' directions
    let t = {
        let (e1, e2) = ([1.0, 0.3, 0.0f64], [1.0, 0.0, 0.0f64]);
        let n1 = dot(&e1, &e1).sqrt();
        let m = [e1[0] / n1 + e2[0], e1[1] / n1 + e2[1], 0.0];
        let nm = dot(&m, &m).sqrt();
        m.map(|c| c / nm)
    };
    let step = 0.566;
    let mut d = vec![[0.0; 3]; p.free_vertices.len()];
    let k = p.free_vertices.iter().position(|&v| v as usize == b).unwrap();
    d[k] = t.map(|c| c * step);
    let mut unprojected = x0.clone();
    for c in 0..3 {
        unprojected[b][c] += d[k][c];
    }
    assert!(
        p.infeasible_elements(&unprojected).is_empty(),
        "the unprojected step is valid"
    );
    let q = {
        let mut x = unprojected.clone();
        meshsmooth::backend::cpu::project_boundary::project(s, &p.free_vertices, &mut x);
        x
    };
    assert!(
        (q[b][1] - 0.3 * q[b][0]).abs() < 1e-12,
        "projected onto b-r: {:?}",
        q[b]
    );
    assert!(q[b][0] > 0.52, "{:?}", q[b]);
    assert_eq!(p.infeasible_elements(&q).len(), 1, "the projection inverts (b, i, tl)");

    let (value, infeasible) = (Slot(0), Slot(1));
    let out = EvalSlots {
        value,
        infeasible,
        min_det: None,
    };
    let probe = |be: &mut dyn Backend, name: &str| {
        let v = be.vector().unwrap();
        be.write_vector(v, &d).unwrap();
        be.evaluate(Points::Current, out, None).unwrap();
        let f0 = be.flush().unwrap();
        assert!(
            f0[value.0 as usize].is_finite() && f0[infeasible.0 as usize] == 0.0,
            "{name}"
        );
        be.trial(Coef::value(1.0), v).unwrap();
        be.evaluate(Points::Trial, out, None).unwrap();
        let f = be.flush().unwrap();
        // the line search rejects a trial with inverted corners
        assert!(
            f[infeasible.0 as usize] > 0.0,
            "{name}: the projected trial counts inverted corners"
        );
        // half the step stays short of the crossing: feasible
        be.trial(Coef::value(0.5), v).unwrap();
        be.evaluate(Points::Trial, out, None).unwrap();
        let f = be.flush().unwrap();
        assert!(
            f[infeasible.0 as usize] == 0.0 && f[value.0 as usize].is_finite(),
            "{name}"
        );
    };
    let ls = Default::default();
    probe(&mut CpuBackend::new(&p, &x0, &ls).unwrap(), "cpu");
    for precision in [Precision::F32, Precision::F64] {
        if let Some(ctx) = context(precision) {
            probe(&mut GpuBackend::new(&ctx, &p, &x0, &ls).unwrap(), "gpu");
        }
    }

    // a full solve: b slides, stays on its side, nothing inverts
    for method in [Method::Newton, Method::Bcd, Method::Laplace] {
        let mut m = mesh.clone();
        let info = smooth(&mut m, &slide(), method, Device::Cpu);
        let pm = Problem::new(&m).unwrap();
        assert!(pm.infeasible_elements(&pm.gather(&m.points)).is_empty(), "{method}");
        let xb = m.points[1];
        let on_left = xb[0] <= 0.0 && xb[1].abs() < 1e-12;
        let on_right = xb[0] >= 0.0 && (xb[1] - 0.3 * xb[0]).abs() < 1e-12;
        assert!(on_left || on_right, "{method}: b left its side: {xb:?}");
        assert!(info.objective.is_finite(), "{method}");
    }
}
