//! Helpers shared by the test modules: each test crate's `main.rs` includes
//! this with `#[path = "../common/mod.rs"] mod common;`, and its modules take
//! what they need with `use crate::common;`.
#![allow(dead_code)]

pub mod cli;
pub mod surface;

use meshsmooth::backend::gpu::{GpuContext, GpuOptions, Precision};
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::metric::corner_model::Template;
use meshsmooth::metric::mat3::Vec3;
use meshsmooth::metric::smetric::MetricKind;
use meshsmooth::metric::{TetShape, tet_det};
use meshsmooth::problem::{Problem, ProblemOptions};
use meshsmooth::solve::{self, Device, Info, Method, Options, Params};
use meshsmooth::{ElementKind, Mesh};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub type Tet = [Vec3; 4];

/// A device for the GPU tests: `None` (with the reason printed, see [`skipped`])
/// on a machine without an adapter, so the tests skip there — except under `CI`, where a
/// missing adapter fails them: CI installs lavapipe and must run them.
pub fn context(precision: Precision) -> Option<GpuContext> {
    context_with(GpuOptions {
        precision,
        ..Default::default()
    })
}

/// `context` with the given options.
pub fn context_with(opts: GpuOptions) -> Option<GpuContext> {
    match GpuContext::new(&opts) {
        Ok(ctx) => {
            eprintln!("GPU tests on {}", ctx.adapter_name());
            Some(ctx)
        }
        Err(e) if std::env::var_os("CI").is_some() => panic!("no GPU for the GPU tests in CI: {e}"),
        Err(e) => {
            skipped(&format!("no suitable GPU adapter (set CI to make this fail): {e}"));
            None
        }
    }
}

/// Says on the real stderr, past the test harness's capture (which shows a
/// passing test's `eprintln!` only with `--nocapture`), that the running test
/// skipped its checks and why, so that a skip is never silent.
pub fn skipped(reason: &str) {
    use std::io::Write;
    let thread = std::thread::current();
    let test = thread.name().unwrap_or("a test");
    // one write per line, so that lines from tests on other threads do not interleave
    let _ = std::io::stderr().write_all(format!("{test}: skipped: {reason}\n").as_bytes());
}

/// Whether the Gmsh that the unstructured ducts run (`MESHSMOOTH_GMSH`, else
/// `gmsh` on the PATH) answers; where it does not, the test that needs it
/// for `what` skips (said, see [`skipped`]) except under `CI`, which must
/// have it (see `.ci/install-test-deps`) and so fails instead.
pub fn gmsh_for(what: &str) -> bool {
    let program = std::env::var_os("MESHSMOOTH_GMSH").unwrap_or_else(|| "gmsh".into());
    let ok = std::process::Command::new(&program)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            std::env::var_os("CI").is_none(),
            "no Gmsh ({}), and CI must run {what} (see .ci/install-test-deps)",
            program.to_string_lossy()
        );
        skipped(&format!("no Gmsh for {what} (install gmsh or set MESHSMOOTH_GMSH)"));
    }
    ok
}

/// A Python that imports `modules` (`"meshio, vtk"`): `MESHSMOOTH_PYTHON`,
/// else the checkout's `.venv`; `None` (said, see [`skipped`]) where there is
/// none, except under `CI`, which must have it for the tests of `what` (see
/// `.ci/install-test-deps`).
pub fn python_with(modules: &str, what: &str) -> Option<std::path::PathBuf> {
    let p = std::env::var_os("MESHSMOOTH_PYTHON")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv/bin/python"));
    let ok = std::process::Command::new(&p)
        .args(["-c", &format!("import {modules}")])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            std::env::var_os("CI").is_none(),
            "no Python with {modules} at {}, and CI must run {what} (see .ci/install-test-deps)",
            p.display()
        );
        skipped(&format!("no Python with {modules} (set MESHSMOOTH_PYTHON)"));
    }
    ok.then_some(p)
}

/// What a Python `script` run on `args` prints, as JSON; it must succeed.
pub fn py_json(python: &std::path::Path, script: &str, args: &[&std::path::Path]) -> serde_json::Value {
    let o = std::process::Command::new(python)
        .args(["-c", script])
        .args(args)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

/// An n x n x n Kuhn box of side n (unit cells), every interior vertex
/// moved randomly by up to `alpha` of the edge length (never inverting).
pub fn perturbed_box(n: usize, alpha: f64, seed: u64) -> Mesh {
    let mut m = generate::tet_box(n, n, n, [n as f64; 3]);
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha },
        fraction: 1.0,
        seed,
    };
    generate::perturb(&mut m, &opts).unwrap();
    m
}

/// `count` random positively oriented tetrahedra in [-1, 1]^3 with z scaled
/// by `flatten`, each with an inverse mean ratio below `max_eta`.
pub fn random_tets(seed: u64, count: usize, flatten: f64, max_eta: f64) -> Vec<Tet> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    while out.len() < count {
        let mut t: Tet = [[0.0; 3]; 4];
        for v in t.iter_mut() {
            for c in v.iter_mut() {
                *c = rng.random_range(-1.0..1.0);
            }
            v[2] *= flatten;
        }
        if tet_det(&t) < 0.0 {
            t.swap(1, 2);
        }
        if TetShape::equilateral().value(&t).is_some_and(|eta| eta < max_eta) {
            out.push(t);
        }
    }
    out
}

/// Options for `method` on `device` with `params`.
pub fn options<'a>(method: Method, params: &Params, device: Device<'a>) -> Options<'a> {
    {
        let mut o = Options::default();
        o.method = method;
        o.params = params.clone();
        o.device = device;
        o
    }
}

/// Solves from `x` in place and returns what the solver reported.
pub fn solve_on(p: &Problem, x: &mut [Vec3], method: Method, params: &Params, device: Device) -> Info {
    solve::solve(p, x, &options(method, params, device), &mut |_| true).unwrap()
}

/// Smooths `mesh` in place on the CPU with the default objective.
pub fn smooth(mesh: &mut Mesh, method: Method, params: &Params) -> Info {
    solve::smooth_mesh(
        mesh,
        &ProblemOptions::default(),
        &options(method, params, Device::Cpu),
        &mut |_| true,
    )
    .unwrap()
}

/// Largest coordinate difference |a - b|.
pub fn max_abs_diff(a: &[Vec3], b: &[Vec3]) -> f64 {
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

/// Largest |a - b| over the largest |b|: errors measured against the vector's scale.
pub fn rel_diff(a: &[Vec3], b: &[Vec3]) -> f64 {
    let scale = b.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    max_abs_diff(a, b) / scale.max(f64::MIN_POSITIVE)
}

/// The CPU's and the device's histories iteration by iteration: F within
/// `f_rel` and |grad F| within `g_rel` relative.
pub fn assert_histories_agree(cpu: &Info, gpu: &Info, f_rel: f64, g_rel: f64) {
    for (c, g) in cpu.history.records.iter().zip(&gpu.history.records) {
        eprintln!(
            "iteration {}: F CPU {:.15} GPU {:.15}, |g| CPU {:.6e} GPU {:.6e}",
            c.iteration, c.objective, g.objective, c.grad_norm, g.grad_norm
        );
        assert!((c.objective - g.objective).abs() <= f_rel * c.objective);
        assert!((c.grad_norm - g.grad_norm).abs() <= g_rel * c.grad_norm);
    }
}

/// Every element kind the optimisers take.
pub const KINDS: [ElementKind; 6] = [
    ElementKind::Triangle,
    ElementKind::Quadrilateral,
    ElementKind::Tetrahedron,
    ElementKind::Hexahedron,
    ElementKind::Prism,
    ElementKind::Polyhedron,
];

/// The cells of [`voronoi_box`] that are whole truncated octahedra (24
/// vertices, 14 faces), vertices renumbered: clipping at the box leaves
/// slivers near its walls, edges and corners.
pub fn truncated_octahedra(n: usize, side: f64, seed: u64) -> Mesh {
    let m = voronoi_box(n, side, seed);
    let on_box = |v: u32| m.points[v as usize].iter().any(|&c| c == 0.0 || c == side);
    let mut id = vec![u32::MAX; m.num_points()];
    let mut points = Vec::new();
    let mut cells = Vec::new();
    for e in 0..m.num_elements() {
        if m.element(e).len() != 24 || m.faces.of(e).count() != 14 || m.element(e).iter().any(|&v| on_box(v)) {
            continue;
        }
        let mut renumber = |v: u32| {
            if id[v as usize] == u32::MAX {
                id[v as usize] = points.len() as u32;
                points.push(m.points[v as usize]);
            }
            id[v as usize]
        };
        let vs: Vec<u32> = m.element(e).iter().map(|&v| renumber(v)).collect();
        let faces: Vec<Vec<u32>> = m
            .faces
            .of(e)
            .map(|f| f.iter().map(|&v| renumber(v)).collect())
            .collect();
        cells.push((vs, faces));
    }
    let mut out = Mesh::new(points);
    for (vs, faces) in &cells {
        out.push_polyhedron(vs, faces.iter().map(|f| &f[..]));
    }
    out
}

/// A Voronoi mesh of `2 n^3` jittered body-centred sites in a cube of side
/// `side`: near truncated octahedra, clipped at the box.
pub fn voronoi_box(n: usize, side: f64, seed: u64) -> Mesh {
    let opts = generate::VoronoiOptions {
        cells: [n; 3],
        bcc: true,
        jitter: 0.02,
        // the lattice's own truncated octahedra
        lloyd: 0,
        smooth: 0,
        seed,
        ..Default::default()
    };
    let mut m = generate::voronoi_mesh(&opts).unwrap();
    for p in &mut m.points {
        *p = p.map(|c| c * side);
    }
    m
}

/// Triangles of a `n x n` grid extruded through `n` layers.
pub fn prism_stack(n: usize) -> Mesh {
    let tris = generate::tri_grid(n, n, [n as f64; 2]);
    let layer = tris.num_points() as u32;
    let points = (0..=n)
        .flat_map(|k| tris.points.iter().map(move |p| [p[0], p[1], k as f64]))
        .collect();
    let mut mesh = Mesh::new(points);
    for k in 0..n as u32 {
        for e in 0..tris.num_elements() {
            let t = tris.element(e);
            let (lo, hi) = (layer * k, layer * (k + 1));
            mesh.push_element(
                ElementKind::Prism,
                &[t[0] + lo, t[1] + lo, t[2] + lo, t[0] + hi, t[1] + hi, t[2] + hi],
            );
        }
    }
    mesh
}

/// A small regular mesh of `kind` (the reference) and a seeded perturbation of it.
pub fn meshes(kind: ElementKind, seed: u64) -> (Mesh, Mesh) {
    let reference = match kind {
        ElementKind::Triangle => generate::tri_grid(6, 6, [6.0, 6.0]),
        ElementKind::Quadrilateral => generate::quad_grid(6, 6, [6.0, 6.0]),
        ElementKind::Tetrahedron => generate::tet_box(3, 3, 3, [3.0; 3]),
        ElementKind::Hexahedron => generate::hex_box(3, 3, 3, [3.0; 3]),
        ElementKind::Prism => prism_stack(3),
        ElementKind::Polyhedron => truncated_octahedra(5, 80.0, 2),
    };
    let mut mesh = reference.clone();
    // a truncated octahedron's corners (120 degree faces) flatten sooner
    // than the others' under the same noise
    let alpha = if kind == ElementKind::Polyhedron { 0.1 } else { 0.25 };
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha },
        fraction: 1.0,
        seed,
    };
    generate::perturb(&mut mesh, &opts).unwrap();
    (mesh, reference)
}

/// Every metric with each template it allows; tmp targets the unperturbed mesh.
pub fn models() -> Vec<(MetricKind, Template)> {
    vec![
        (MetricKind::InverseMeanRatio, Template::Harmonic),
        (MetricKind::InverseMeanRatio, Template::Average),
        (MetricKind::ConditionNumber, Template::Harmonic),
        (MetricKind::ConditionNumber, Template::Average),
        (MetricKind::TargetShapeSize, Template::Harmonic),
    ]
}

pub fn problem(mesh: &Mesh, reference: &Mesh, metric: MetricKind, template: Template) -> Problem {
    let mut opts = ProblemOptions::default();
    opts.metric = metric;
    opts.template = template;
    opts.reference = matches!(metric, MetricKind::TargetShapeSize | MetricKind::ShapeSize).then_some(reference);
    Problem::with_options(mesh, &opts).unwrap()
}

/// The row of a study's Findings table whose claim contains `claim`,
/// checked to carry one of the three verdicts in its third column
/// (whichever way it went).
pub fn finding_line<'a>(md: &'a str, claim: &str) -> &'a str {
    let findings = md.split("## Findings").nth(1).expect("a Findings section");
    let line = findings
        .lines()
        .find(|l| l.contains(claim))
        .unwrap_or_else(|| panic!("no finding '{claim}'"));
    let verdict = line.split('|').nth(3).map(str::trim);
    assert!(
        matches!(
            verdict,
            Some("reproduced" | "in part" | "not reproduced" | "not measured")
        ),
        "{line}"
    );
    line
}

/// A named pipe at `path` (Unix).
#[cfg(unix)]
pub fn fifo(path: &std::path::Path) {
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(path.as_os_str().as_bytes()).unwrap();
    // SAFETY: a valid NUL-terminated path
    assert_eq!(
        unsafe { libc::mkfifo(c.as_ptr(), 0o600) },
        0,
        "mkfifo {}",
        path.display()
    );
}

/// A perturbed tetrahedral box (4×4×4 cells) with three extra points no
/// element uses (two inside the domain, one far away) and a point array
/// "temperature" over all points; with the ids of the unused points.
pub fn box_with_unused() -> (Mesh, Vec<usize>) {
    use meshsmooth::mesh::{DataArray, ValueType, Values};
    let mut mesh = generate::tet_box(4, 4, 4, [1.0, 1.0, 1.0]);
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: 0.3 },
        fraction: 1.0,
        seed: 7,
    };
    generate::perturb(&mut mesh, &opts).unwrap();
    let n = mesh.num_points();
    mesh.points
        .extend([[0.51, 0.49, 0.5], [0.3, 0.7, 0.1 + 1e-17], [9.0, -3.0, 1e-300]]);
    let values: Vec<f64> = (0..mesh.num_points()).map(|v| v as f64 * 0.1 + 1e-13).collect();
    mesh.data
        .point
        .push(DataArray::new("temperature", ValueType::F64, 1, Values::Float(values)));
    mesh.validate().unwrap();
    (mesh, vec![n, n + 1, n + 2])
}

/// A point's coordinates as bits, to compare them exactly (-0.0 and NaN included).
pub fn bits(p: &[f64; 3]) -> [u64; 3] {
    p.map(f64::to_bits)
}

/// A xorshift64 stream: the same pseudo-random numbers on every run, for
/// the fuzz tests' mutants.
pub fn xorshift(mut seed: u64) -> impl FnMut() -> u64 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    }
}
