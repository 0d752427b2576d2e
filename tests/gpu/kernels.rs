//! Every WGSL kernel against its CPU twin (same stem in `shaders/` and
//! `src/backend/cpu/`), through the backend operation that dispatches it, on
//! every element kind, with the closed-form and the general variants, in f32
//! and f64. Inputs are seeded and quantised (positions and vectors are
//! multiples of 1/64), so differences show the kernels, not the inputs.
//! Without an adapter these tests print why and pass — except under `CI`,
//! where they fail.

use crate::common;
use common::{KINDS, context, context_with, max_abs_diff, meshes, problem, rel_diff};

use meshsmooth::ElementKind;
use meshsmooth::backend::cpu::CpuBackend;
use meshsmooth::backend::cpu::bsr_spmv::BlockCsr;
use meshsmooth::backend::cpu::constrain_blocks::constrain_blocks;
use meshsmooth::backend::cpu::hessian_assemble::HessianPattern;
use meshsmooth::backend::cpu::project_boundary::{active_projector, active_projectors, project_vertex};
use meshsmooth::backend::gpu::shader::Form;
use meshsmooth::backend::gpu::{GpuBackend, GpuContext, GpuOptions, KernelForms, Precision};
use meshsmooth::backend::{Backend, Coef, Entries, EvalSlots, Points, Slot, Vector};
use meshsmooth::metric::corner_model::Template;
use meshsmooth::metric::mat3::Vec3;
use meshsmooth::metric::smetric::MetricKind;
use meshsmooth::problem::{Boundary, BoundaryMode, Problem, ProblemOptions};
use meshsmooth::solve::Device;
use meshsmooth::solve::rezone;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// One input: a problem and quantised positions.
struct Case {
    name: String,
    p: Problem,
    x: Vec<Vec3>,
}

fn quantise(v: f64) -> f64 {
    (v * 64.0).round() / 64.0
}

/// Every kind, under the closed-form model where it exists (the tetrahedral
/// inverse mean ratio) and every general one's structured Hessian terms (the
/// condition number's Gram and rank-one terms under the average template, the
/// inverse mean ratio's pair term under it, the target metric's identity).
fn cases() -> Vec<Case> {
    let mut out = Vec::new();
    for kind in KINDS {
        let (mesh, reference) = meshes(kind, 5);
        for (metric, template) in [
            (MetricKind::InverseMeanRatio, Template::Harmonic),
            (MetricKind::ConditionNumber, Template::Average),
            (MetricKind::InverseMeanRatio, Template::Average),
            (MetricKind::TargetShapeSize, Template::Harmonic),
            (MetricKind::ShapeSize, Template::Harmonic),
            (MetricKind::ShapeSize, Template::Average),
        ] {
            let p = problem(&mesh, &reference, metric, template);
            let x: Vec<Vec3> = p.gather(&mesh.points).iter().map(|c| c.map(quantise)).collect();
            assert!(p.check_feasible(&x).is_ok(), "quantising inverted a {kind}");
            out.push(Case {
                name: format!("{kind} {metric} {template:?}"),
                p,
                x,
            });
        }
        if kind.dim() == 3 {
            // rezoning's two problems: the paper's measure (step 1) and F_RJ
            // with per-corner reference Jacobians (step 2)
            let p1 = Problem::with_options(&mesh, &rezone::cn_paper_options()).unwrap();
            let xl = p1.gather(&mesh.points);
            let xr = p1.scatter(&rezone::reference_positions(&p1, &xl, Device::Cpu, 20).unwrap());
            let p2 = rezone::rj_problem(&mesh, &xr).unwrap();
            for (metric, p) in [("cn-paper", p1), ("rj", p2)] {
                let x: Vec<Vec3> = p.gather(&mesh.points).iter().map(|c| c.map(quantise)).collect();
                assert!(p.check_feasible(&x).is_ok(), "quantising inverted a {kind}");
                out.push(Case {
                    name: format!("{kind} {metric}"),
                    p,
                    x,
                });
            }
        }
    }
    out
}

/// The same meshes with a sliding boundary (the constraint kernels and BCD's
/// constrained step; the planar kinds slide along their boundary lines).
fn slide_cases() -> Vec<Case> {
    let mut out = Vec::new();
    for kind in KINDS {
        let (mesh, _) = meshes(kind, 5);
        // the whole truncated octahedra leave a bumpy skin whose faces meet at
        // 55 and 71 degrees: every skin vertex would be a corner at 30
        let feature_angle = if kind == ElementKind::Polyhedron { 80.0 } else { 30.0 };
        let mut opts = ProblemOptions::default();
        opts.boundary = Boundary {
            mode: BoundaryMode::Slide,
            feature_angle,
        };
        let p = Problem::with_options(&mesh, &opts).unwrap();
        assert!(
            p.sliding.as_ref().is_some_and(|s| s.counts[0] + s.counts[1] > 0),
            "{kind}: nothing slides"
        );
        let x: Vec<Vec3> = p.gather(&mesh.points).iter().map(|c| c.map(quantise)).collect();
        out.push(Case {
            name: format!("{kind} sliding"),
            p,
            x,
        });
    }
    out
}

/// The planar closed forms' problems (`Model::planar`): triangles and
/// quadrilaterals under the inverse mean ratio and the condition number with
/// the harmonic template.
fn planar_cases() -> Vec<Case> {
    let mut out = Vec::new();
    for kind in [ElementKind::Triangle, ElementKind::Quadrilateral] {
        let (mesh, reference) = meshes(kind, 5);
        for metric in [MetricKind::InverseMeanRatio, MetricKind::ConditionNumber] {
            let p = problem(&mesh, &reference, metric, Template::Harmonic);
            assert!(p.model.planar(p.dim));
            let x: Vec<Vec3> = p.gather(&mesh.points).iter().map(|c| c.map(quantise)).collect();
            out.push(Case {
                name: format!("{kind} {metric} Harmonic"),
                p,
                x,
            });
        }
    }
    out
}

fn random_vec(n: usize, seed: u64) -> Vec<Vec3> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| [0; 3].map(|_: i32| rng.random_range(-64i32..=64) as f64 / 64.0))
        .collect()
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
}

/// The same case on both backends.
struct Pair<'c> {
    gpu: GpuBackend<'c>,
    cpu: CpuBackend<'c>,
}

impl<'c> Pair<'c> {
    fn new(ctx: &'c GpuContext, c: &'c Case) -> Pair<'c> {
        let ls = Default::default();
        Pair {
            gpu: GpuBackend::new(ctx, &c.p, &c.x, &ls).unwrap(),
            cpu: CpuBackend::new(&c.p, &c.x, &ls).unwrap(),
        }
    }

    /// Runs `f` on both backends.
    fn both<T>(&mut self, mut f: impl FnMut(&mut dyn Backend) -> T) -> (T, T) {
        (f(&mut self.gpu), f(&mut self.cpu))
    }

    /// Vectors with the same handles on both, filled with `data`.
    fn vectors(&mut self, data: &[Vec<Vec3>]) -> Vec<Vector> {
        data.iter()
            .map(|d| {
                let (g, c) = self.both(|be| {
                    let v = be.vector().unwrap();
                    be.write_vector(v, d).unwrap();
                    v
                });
                assert_eq!(g, c);
                g
            })
            .collect()
    }

    fn read(&mut self, v: Vector) -> (Vec<Vec3>, Vec<Vec3>) {
        self.both(|be| be.read_vector(v).unwrap())
    }

    fn slots(&mut self) -> ([f64; 32], [f64; 32]) {
        self.both(|be| be.flush().unwrap())
    }
}

const EVAL: EvalSlots = EvalSlots {
    value: Slot(0),
    infeasible: Slot(1),
    min_det: Some(Slot(2)),
};

fn check_objective(pair: &mut Pair, c: &Case, tol: f64) {
    for at in [Points::Current, Points::Trial] {
        pair.both(|be| be.evaluate(at, EVAL, None).unwrap());
        let (g, cp) = pair.slots();
        assert!(rel(g[0], cp[0]) <= tol, "{}: F {} vs {}", c.name, g[0], cp[0]);
        assert_eq!((g[1], cp[1]), (0.0, 0.0), "{}: infeasible", c.name);
    }
}

fn check_reduce(pair: &mut Pair, c: &Case, tol: f64) {
    // the smallest determinant (a min) and the infeasible count (a count) of the objective
    pair.both(|be| be.evaluate(Points::Current, EVAL, None).unwrap());
    let (g, cp) = pair.slots();
    assert!(rel(g[2], cp[2]) <= tol, "{}: min det {} vs {}", c.name, g[2], cp[2]);
    assert!(g[2] > 0.0);
    // a count above zero: the trial point is the start moved far along a random vector
    let n = c.p.free_vertices.len();
    let v = pair.vectors(&[random_vec(n, 9).iter().map(|d| d.map(|t| 8.0 * t)).collect()]);
    pair.both(|be| {
        be.trial(Coef::value(1.0), v[0]).unwrap();
        be.evaluate(Points::Trial, EVAL, None).unwrap();
    });
    let (g, cp) = pair.slots();
    assert!(cp[1] > 0.0, "{}: the far trial point should invert corners", c.name);
    assert_eq!(g[1], cp[1], "{}: infeasible corners", c.name);
}

fn check_gradient_gather(pair: &mut Pair, c: &Case, tol: f64) {
    let g = pair.vectors(&[vec![[0.0; 3]; c.p.free_vertices.len()]])[0];
    pair.both(|be| be.evaluate(Points::Current, EVAL, Some(g)).unwrap());
    let (gg, cg) = pair.read(g);
    let e = rel_diff(&gg, &cg);
    assert!(e <= tol, "{}: gradient differs by {e:.1e}", c.name);
}

fn check_bcd(pair: &mut Pair, c: &Case, tol: f64) {
    let edge = c.p.mean_edge_length(&c.x);
    for color in 0..c.p.colors.len() {
        pair.both(|be| {
            be.bcd_color(color).unwrap();
            be.max_move(Slot(3)).unwrap();
        });
        let (g, cp) = pair.slots();
        assert!(
            (g[3].sqrt() - cp[3].sqrt()).abs() <= tol * edge,
            "{}: colour {color} largest move {} vs {}",
            c.name,
            g[3].sqrt(),
            cp[3].sqrt()
        );
    }
    let (gx, cx) = pair.both(|be| be.download().unwrap());
    let worst = max_abs_diff(&gx, &cx);
    assert!(
        worst <= tol * edge,
        "{}: a sweep differs by {:.1e} edges",
        c.name,
        worst / edge
    );
    assert!(
        rel_diff(&cx, &c.x) > 1e-3 * edge / 64.0,
        "{}: the sweep moved nothing",
        c.name
    );
}

fn check_reference_position(pair: &mut Pair, c: &Case, tol: f64) {
    let edge = c.p.mean_edge_length(&c.x);
    // one safeguarded Newton step per vertex, as the bcd check sweeps once:
    // later steps near the minimiser are decided by rounding
    let (g, cp) = pair.both(|be| be.reference_positions(1).unwrap());
    let worst = max_abs_diff(&g, &cp);
    assert!(
        worst <= tol * edge,
        "{}: reference positions differ by {:.1e} edges",
        c.name,
        worst / edge
    );
    assert!(
        rel_diff(&cp, &c.x) > 1e-3,
        "{}: no vertex has a reference elsewhere",
        c.name
    );
    // nothing moved
    let (gx, cx) = pair.both(|be| be.download().unwrap());
    assert_eq!((gx.as_slice(), cx.as_slice()), (c.x.as_slice(), c.x.as_slice()));
}

/// Prepares and assembles the Hessian on both; returns the gradient vector.
fn assembled(pair: &mut Pair, c: &Case) -> Vector {
    let g = pair.vectors(&[vec![[0.0; 3]; c.p.free_vertices.len()]])[0];
    pair.both(|be| {
        be.prepare_hessian().unwrap();
        be.assemble(g).unwrap();
    });
    g
}

fn check_hessian_assemble(pair: &mut Pair, c: &Case, tol: f64) {
    // the gradient part of the per-corner records, gathered
    let g = assembled(pair, c);
    let (gg, cg) = pair.read(g);
    let e = rel_diff(&gg, &cg);
    assert!(e <= tol, "{}: assembled gradient differs by {e:.1e}", c.name);
}

/// The GPU kernels' CPU twins in full storage (`hessian_assemble`,
/// `constrain_blocks`): the reference, since the CPU backend's Newton keeps
/// only the upper triangle. Its upper blocks must equal the twin's.
fn twin_hessian(pair: &CpuBackend, c: &Case) -> BlockCsr {
    let mut pat = HessianPattern::new(&c.p);
    let mut g = vec![[0.0; 3]; c.p.free_vertices.len()];
    assert!(pat.assemble(&c.p, &c.x, &mut g));
    if let Some(s) = &c.p.sliding {
        let active = active_projectors(s, &c.p.free_vertices, &c.x, &g);
        constrain_blocks(&active, &c.p.free_vertices, &mut pat.matrix);
    }
    let sym = &pair.hessian().unwrap().matrix;
    let full = sym.to_full();
    assert_eq!(full.cols, pat.matrix.cols, "{}: patterns differ", c.name);
    let e = rel_diff(
        &full.blocks.iter().flatten().copied().collect::<Vec<_>>(),
        &pat.matrix.blocks.iter().flatten().copied().collect::<Vec<_>>(),
    );
    assert!(e <= 1e-14, "{}: upper storage differs from the twin by {e:.1e}", c.name);
    pat.matrix
}

fn check_hessian_gather(pair: &mut Pair, c: &Case, tol: f64) {
    assembled(pair, c);
    let gb = pair.gpu.hessian_blocks().unwrap();
    let twin = twin_hessian(&pair.cpu, c);
    let cb = &twin.blocks;
    assert_eq!(gb.len(), cb.len());
    let flat = |b: &[[[f64; 3]; 3]]| -> Vec<Vec3> { b.iter().flatten().copied().collect() };
    let e = rel_diff(&flat(&gb), &flat(cb));
    assert!(e <= tol, "{}: Hessian blocks differ by {e:.1e}", c.name);
}

fn check_bsr_spmv(pair: &mut Pair, c: &Case, tol: f64) {
    assembled(pair, c);
    let n = c.p.free_vertices.len();
    let u = random_vec(n, 2);
    let v = pair.vectors(&[u.clone(), vec![[0.0; 3]; n]]);
    pair.both(|be| be.hess_mul(v[0], v[1]).unwrap());
    let (gy, sy) = pair.read(v[1]);
    let mut cy = vec![[0.0; 3]; n];
    twin_hessian(&pair.cpu, c).mul(&u, &mut cy);
    let e = rel_diff(&sy, &cy);
    assert!(
        e <= 1e-13,
        "{}: symmetric H u differs from the twin's by {e:.1e}",
        c.name
    );
    let e = rel_diff(&gy, &cy);
    assert!(e <= tol, "{}: H u differs by {e:.1e}", c.name);
}

fn check_block_jacobi(pair: &mut Pair, c: &Case, tol: f64) {
    assembled(pair, c);
    let n = c.p.free_vertices.len();
    let v = pair.vectors(&[random_vec(n, 3), vec![[0.0; 3]; n]]);
    pair.both(|be| {
        be.factor_precond().unwrap();
        be.precond(v[0], v[1]).unwrap();
    });
    let (gy, cy) = pair.read(v[1]);
    let e = rel_diff(&gy, &cy);
    assert!(e <= tol, "{}: M^-1 u differs by {e:.1e}", c.name);
}

fn check_block_jacobi_factor(pair: &mut Pair, c: &Case, tol: f64) {
    assembled(pair, c);
    pair.both(|be| be.factor_precond().unwrap());
    let g = pair.gpu.block_jacobi_factors().unwrap();
    let cf = pair.cpu.block_jacobi_factors().unwrap();
    assert_eq!(g.len(), cf.len());
    // each factor against the largest of its block's (l and 1/d scale differently)
    for (i, (a, b)) in g.iter().zip(cf).enumerate() {
        for k in 0..6 {
            let scale = if k < 3 {
                1.0f64.max(b[..3].iter().fold(0.0, |m, v| m.max(v.abs())))
            } else {
                b[k].abs()
            };
            assert!(
                (a[k] - b[k]).abs() <= tol * scale,
                "{}: block {i} factor {k}: {} vs {}",
                c.name,
                a[k],
                b[k]
            );
        }
    }
}

fn check_dot(pair: &mut Pair, c: &Case, tol: f64) {
    let n = c.p.free_vertices.len();
    let v = pair.vectors(&[random_vec(n, 4), random_vec(n, 5)]);
    pair.both(|be| be.dot(v[0], v[1], Slot(4), Some(Slot(5))).unwrap());
    let (g, cp) = pair.slots();
    // the products are exact (multiples of 1/64^2); only the sum order differs
    assert!(
        (g[4] - cp[4]).abs() <= tol * n as f64,
        "{}: dot {} vs {}",
        c.name,
        g[4],
        cp[4]
    );
    assert_eq!(g[5], cp[5], "{}: max |b_i|^2", c.name);
}

fn check_axpby(pair: &mut Pair, c: &Case, tol: f64) {
    let n = c.p.free_vertices.len();
    let v = pair.vectors(&[random_vec(n, 6), random_vec(n, 7), random_vec(n, 8)]);
    pair.both(|be| {
        be.set_slot(Slot(6), Coef::value(0.75), None).unwrap();
        be.set_slot(Slot(7), Coef::value(-1.5), None).unwrap();
        be.set_slot(Slot(8), Coef::value(0.0), None).unwrap();
        // y = (0.75 / -1.5) x + 2 y; then skipped by a failing guard; then y = 3 y (aliased); z = -x
        be.axpby(
            Coef::ratio(1.0, Slot(6), Slot(7)),
            v[0],
            Coef::value(2.0),
            v[1],
            Some(Slot(6)),
        )
        .unwrap();
        be.axpby(Coef::value(5.0), v[0], Coef::value(1.0), v[1], Some(Slot(8)))
            .unwrap();
        be.axpby(Coef::value(1.0), v[1], Coef::value(2.0), v[1], None).unwrap();
        be.axpby(Coef::slot(Slot(7)), v[0], Coef::value(0.0), v[2], None)
            .unwrap();
        be.scale(Coef::ratio(-1.0, Slot(6), Slot(6)), v[2]).unwrap();
    });
    let x = random_vec(n, 6);
    let y0 = random_vec(n, 7);
    let expect_y: Vec<Vec3> = x
        .iter()
        .zip(&y0)
        .map(|(a, b)| [0, 1, 2].map(|k| 3.0 * (-0.5 * a[k] + 2.0 * b[k])))
        .collect();
    let expect_z: Vec<Vec3> = x.iter().map(|a| a.map(|t| 1.5 * t)).collect();
    for (v, want, what) in [(v[1], &expect_y, "y"), (v[2], &expect_z, "z")] {
        let (gy, cy) = pair.read(v);
        assert!(rel_diff(&cy, want) <= 1e-15, "{}: CPU {what} is wrong", c.name);
        let e = rel_diff(&gy, &cy);
        assert!(e <= tol, "{}: {what} differs by {e:.1e}", c.name);
    }
}

/// Every third free entry, last first: the list's order, not the entries',
/// is the packing order.
fn halo_list(c: &Case) -> Vec<u32> {
    (0..c.p.free_vertices.len() as u32).rev().step_by(3).collect()
}

fn check_halo_gather(pair: &mut Pair, c: &Case, _tol: f64) {
    let n = c.p.free_vertices.len();
    let data = random_vec(n, 10);
    let v = pair.vectors(std::slice::from_ref(&data))[0];
    let idx = halo_list(c);
    for (of, src) in [
        (
            Entries::Points(Points::Current),
            c.p.free_vertices.iter().map(|&i| c.x[i as usize]).collect(),
        ),
        (Entries::Vector(v), data.clone()),
    ] {
        let (g, cp) = pair.both(|be| {
            let mut out = vec![7.0];
            be.read_entries(of, &idx, &mut out).unwrap();
            out
        });
        let want: Vec<f64> = [7.0]
            .into_iter()
            .chain(idx.iter().flat_map(|&i| src[i as usize]))
            .collect();
        assert_eq!(cp, want, "{}: CPU gather of {of:?}", c.name);
        // multiples of 1/64: exact in either precision
        assert_eq!(g, cp, "{}: gather of {of:?}", c.name);
    }
}

fn check_halo_scatter(pair: &mut Pair, c: &Case, _tol: f64) {
    let n = c.p.free_vertices.len();
    let v = pair.vectors(&[random_vec(n, 11)])[0];
    let idx = halo_list(c);
    let data: Vec<f64> = random_vec(idx.len(), 12).into_iter().flatten().collect();
    pair.both(|be| {
        be.write_entries(Entries::Points(Points::Current), &idx, &data).unwrap();
        be.write_entries(Entries::Vector(v), &idx, &data).unwrap();
    });
    let (gx, cx) = pair.both(|be| be.download().unwrap());
    let (gv, cv) = pair.read(v);
    let mut want_x = c.x.clone();
    let mut want_v = random_vec(n, 11);
    for (&i, d) in idx.iter().zip(data.chunks_exact(3)) {
        want_x[c.p.free_vertices[i as usize] as usize] = [d[0], d[1], d[2]];
        want_v[i as usize] = [d[0], d[1], d[2]];
    }
    assert_eq!(cx, want_x, "{}: CPU scatter into positions", c.name);
    assert_eq!(cv, want_v, "{}: CPU scatter into a vector", c.name);
    assert_eq!(gx, cx, "{}: scatter into positions", c.name);
    assert_eq!(gv, cv, "{}: scatter into a vector", c.name);
}

/// `restrict_sums`: F, the infeasible count and dot over a subset only (a
/// part's owned share), the gradient and min det still over everything.
fn check_restricted_sums(pair: &mut Pair, c: &Case, tol: f64) {
    let n = c.p.free_vertices.len();
    let free: Vec<u32> = (0..n as u32).filter(|i| i % 3 != 1).collect();
    let corners: Vec<u32> = (0..c.p.num_corners() as u32).filter(|k| k % 4 != 2).collect();
    let v = pair.vectors(&[random_vec(n, 4), random_vec(n, 5), vec![[0.0; 3]; n]]);
    // the whole problem's gradient and min det, before restricting
    pair.both(|be| be.evaluate(Points::Current, EVAL, Some(v[2])).unwrap());
    let (gwhole, cwhole) = pair.slots();
    let (gw, _) = pair.read(v[2]);
    pair.both(|be| {
        be.restrict_sums(&free, &corners).unwrap();
        be.evaluate(Points::Current, EVAL, Some(v[2])).unwrap();
        be.dot(v[0], v[1], Slot(4), Some(Slot(5))).unwrap();
        be.norm_sq(v[1], Slot(6)).unwrap();
    });
    let (g, cp) = pair.slots();
    let f: f64 = corners
        .iter()
        .map(|&k| c.p.corner_term(&c.x, k as usize).unwrap())
        .sum();
    assert!(rel(cp[0], f) <= 1e-13, "{}: CPU partial F {} vs {f}", c.name, cp[0]);
    assert!(rel(g[0], cp[0]) <= tol, "{}: partial F {} vs {}", c.name, g[0], cp[0]);
    assert_eq!((g[1], cp[1]), (0.0, 0.0), "{}: infeasible", c.name);
    // min det over the share (GPU) or the whole (CPU): a minimum over the
    // parts is the whole's either way
    assert!(
        g[2] >= gwhole[2] && cp[2] == cwhole[2],
        "{}: min det {} (whole {}), CPU {} (whole {})",
        c.name,
        g[2],
        gwhole[2],
        cp[2],
        cwhole[2]
    );
    let (a, b) = (random_vec(n, 4), random_vec(n, 5));
    let dot = |x: &[Vec3], y: &[Vec3]| -> (f64, f64) {
        free.iter().fold((0.0, 0.0f64), |(s, m), &i| {
            let (p, q) = (x[i as usize], y[i as usize]);
            (
                s + p[0] * q[0] + p[1] * q[1] + p[2] * q[2],
                m.max(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]),
            )
        })
    };
    // products of multiples of 1/64 add exactly
    assert_eq!(
        (cp[4], cp[5], cp[6]),
        (dot(&a, &b).0, dot(&a, &b).1, dot(&b, &b).0),
        "{}: CPU partial dot",
        c.name
    );
    assert_eq!((g[4], g[5], g[6]), (cp[4], cp[5], cp[6]), "{}: partial dot", c.name);
    let (gg, cg) = pair.read(v[2]);
    assert!(rel_diff(&gg, &cg) <= tol, "{}: gradient", c.name);
    assert!(rel_diff(&gg, &gw) <= tol, "{}: the gradient is restricted", c.name);
}

fn check_set_slot(pair: &mut Pair, c: &Case, _tol: f64) {
    pair.both(|be| {
        be.set_slot(Slot(9), Coef::value(3.0), None).unwrap();
        be.set_slot(Slot(10), Coef::value(-2.0), None).unwrap();
        be.set_slot(Slot(11), Coef::ratio(-1.0, Slot(9), Slot(10)), None)
            .unwrap();
        // guarded by a negative slot: skipped; by a positive one: done
        be.set_slot(Slot(12), Coef::value(7.0), Some(Slot(10))).unwrap();
        be.set_slot(Slot(13), Coef::value(7.0), Some(Slot(9))).unwrap();
    });
    let (g, cp) = pair.slots();
    assert_eq!(cp[11], 1.5, "{}", c.name);
    assert_eq!((cp[12], cp[13]), (0.0, 7.0), "{}", c.name);
    assert_eq!(&g[9..14], &cp[9..14], "{}", c.name);
}

fn check_line_search(pair: &mut Pair, c: &Case, tol: f64) {
    let n = c.p.free_vertices.len();
    let d = pair.vectors(&[random_vec(n, 10).iter().map(|v| v.map(|t| t / 16.0)).collect()])[0];
    pair.both(|be| {
        be.set_slot(Slot(14), Coef::value(0.5), None).unwrap();
        be.trial(Coef::slot(Slot(14)), d).unwrap();
        be.evaluate(Points::Trial, EVAL, None).unwrap();
        be.accept_trial().unwrap();
    });
    let (g, cp) = pair.slots();
    assert_eq!((g[1], cp[1]), (0.0, 0.0), "{}: the short trial stays feasible", c.name);
    assert!(
        rel(g[0], cp[0]) <= tol,
        "{}: F at the trial {} vs {}",
        c.name,
        g[0],
        cp[0]
    );
    let (gx, cx) = pair.both(|be| be.download().unwrap());
    let e = rel_diff(&gx, &cx);
    assert!(e <= tol, "{}: accepted positions differ by {e:.1e}", c.name);
    assert_ne!(cx, c.x);
}

/// A trial twice as far as the unit random step inverts corners on every
/// case; a short one inverts none (the CPU's +inf, the GPU's largest real).
fn check_inversion(pair: &mut Pair, c: &Case, tol: f64) {
    let n = c.p.free_vertices.len();
    let d = pair.vectors(&[random_vec(n, 12)])[0];
    let mut inverted = 0;
    for alpha in [2.0, 1e-3] {
        pair.both(|be| {
            be.trial(Coef::value(alpha), d).unwrap();
            be.inversion_fraction(Slot(3)).unwrap();
        });
        let (g, cp) = pair.slots();
        let (g, cp) = (g[3], cp[3]);
        if cp.is_finite() {
            inverted += 1;
            assert!(cp > 0.0 && cp <= 1.0, "{}: fraction {cp}", c.name);
            assert!(rel(g, cp) <= tol, "{}: step {alpha}: fraction {g} vs {cp}", c.name);
        } else {
            assert!(
                g >= f32::MAX as f64 * 0.99,
                "{}: step {alpha}: the CPU finds no inversion, the GPU {g}",
                c.name
            );
        }
    }
    assert_eq!(inverted, 1, "{}: the long step inverts, the short one does not", c.name);
}

fn check_project_boundary(pair: &mut Pair, c: &Case, tol: f64) {
    let n = c.p.free_vertices.len();
    let d = pair.vectors(&[random_vec(n, 11).iter().map(|v| v.map(|t| t / 8.0)).collect()])[0];
    pair.both(|be| {
        be.trial(Coef::value(1.0), d).unwrap();
        be.accept_trial().unwrap();
    });
    let (gx, cx) = pair.both(|be| be.download().unwrap());
    let e = rel_diff(&gx, &cx);
    assert!(e <= tol, "{}: projected positions differ by {e:.1e}", c.name);
    // the CPU's points are on the boundary: projecting again keeps them
    let s = c.p.sliding.as_ref().unwrap();
    let mut sliding = 0;
    for &v in &c.p.free_vertices {
        let v = v as usize;
        if s.slides(v) {
            sliding += 1;
            let again = project_vertex(s, v, &cx[v]);
            assert!(
                rel_diff(&[again], &[cx[v]]) <= 1e-15,
                "{}: vertex {v} is off the boundary",
                c.name
            );
        }
    }
    assert!(sliding > 0, "{}: nothing slides", c.name);
}

fn check_constrain(pair: &mut Pair, c: &Case, tol: f64) {
    check_gradient_gather(pair, c, tol);
    // the constrained gradient is the raw one projected by the active
    // constraint's projector, which keeps it in the tangent space of a face
    // or a crease: P g = g again
    let g = pair.vectors(&[vec![[0.0; 3]; c.p.free_vertices.len()]])[0];
    pair.cpu.evaluate(Points::Current, EVAL, Some(g)).unwrap();
    let cg = pair.cpu.read_vector(g).unwrap();
    let (_, raw) = meshsmooth::objective::free_gradient(&c.p, &c.x).unwrap();
    let s = c.p.sliding.as_ref().unwrap();
    let mut held = 0;
    for (i, &v) in c.p.free_vertices.iter().enumerate() {
        let p = active_projector(s, v as usize, &c.x[v as usize], &raw[i]);
        let pg = |w: &Vec3| [0, 1, 2].map(|r| p[r][0] * w[0] + p[r][1] * w[1] + p[r][2] * w[2]);
        let scale = 1e-14 * raw[i].iter().fold(0.0f64, |m, c| m.max(c.abs()));
        assert!(
            max_abs_diff(&[pg(&raw[i])], &[cg[i]]) <= scale,
            "{}: vertex {v}",
            c.name
        );
        assert!(max_abs_diff(&[pg(&cg[i])], &[cg[i]]) <= scale, "{}: vertex {v}", c.name);
        held += usize::from(s.slides(v as usize) && cg[i] == [0.0; 3]);
    }
    assert!(held < c.p.free_vertices.len() / 2, "{}: {held} vertices held", c.name);
}

type Check = fn(&mut Pair, &Case, f64);

/// `shaders/metric/planar.wgsl` against its twin `src/metric/planar.rs`
/// through every kernel that compiles it (`Form::Planar`): the objective and
/// its gradient, the assembled Hessian blocks, and a BCD sweep (positions,
/// relative to the mean edge).
fn run_planar(precision: Precision, tol: f64) {
    let Some(ctx) = context(precision) else {
        return;
    };
    let checks: [Check; 4] = [check_objective, check_gradient_gather, check_hessian_gather, check_bcd];
    for c in planar_cases() {
        for check in checks {
            let mut pair = Pair::new(&ctx, &c);
            assert_eq!(pair.gpu.form(), Form::Planar, "{}", c.name);
            check(&mut pair, &c, tol);
        }
    }
}

/// On lavapipe the f64 kernels agree with `planar.rs` to 1e-15 in every
/// check (3e-16 relative in F); 1e-12 leaves room for another device's
/// contractions.
#[test]
fn planar_matches_cpu_f64() {
    run_planar(Precision::F64, 1e-12);
}

/// f32 keeps about 7 digits: on lavapipe every check here agrees to 1e-6
/// relative (6e-7 in the gradient, the worst); 1e-5 is that with room for
/// the Newton solves and Hessian cancellations of another device.
#[test]
fn planar_matches_cpu_f32() {
    run_planar(Precision::F32, 1e-5);
}

/// The inverse mean ratio under the harmonic template on the 3D kinds, whose
/// corners have a closed form (`Form::Fast`), through each choice of
/// `GpuOptions::forms`: the instance compiled is the one asked for (`Auto`
/// takes the general one only for f32 on a hardware GPU), and each agrees
/// with the CPU in the objective, gradient, Hessian blocks and a BCD sweep
/// within the tolerances of the kernel tests above.
fn run_forms(precision: Precision, tol: f64) {
    let checks: [Check; 4] = [check_objective, check_gradient_gather, check_hessian_gather, check_bcd];
    for forms in [KernelForms::Auto, KernelForms::Closed, KernelForms::General] {
        let Some(ctx) = context_with(GpuOptions {
            precision,
            forms,
            ..Default::default()
        }) else {
            return;
        };
        let closed = match forms {
            KernelForms::Closed => true,
            KernelForms::General => false,
            KernelForms::Auto => ctx.is_software() || ctx.is_f64(),
        };
        let fast = cases()
            .into_iter()
            .filter(|c| c.p.dim == 3 && c.p.model.fast(3) && !c.name.contains("cn-paper"));
        let mut n = 0;
        for c in fast {
            for check in checks {
                let mut pair = Pair::new(&ctx, &c);
                let want = if closed { Form::Fast } else { Form::Imr };
                assert_eq!(pair.gpu.form(), want, "{} with {forms:?}", c.name);
                check(&mut pair, &c, tol);
            }
            n += 1;
        }
        assert!(n >= 3, "only {n} cases with a closed form");
    }
}

#[test]
fn forms_match_cpu_f64() {
    run_forms(Precision::F64, 1e-11);
}

#[test]
fn forms_match_cpu_f32() {
    run_forms(Precision::F32, 1e-3);
}

fn run_sliding(precision: Precision, tol: f64, check: Check) {
    let Some(ctx) = context(precision) else {
        return;
    };
    for c in slide_cases() {
        let mut pair = Pair::new(&ctx, &c);
        check(&mut pair, &c, tol);
    }
}

/// Tests of the sliding-boundary kernels on the sliding cases.
macro_rules! sliding_tests {
    ($($check:ident: $f32:ident ($tol32:expr), $f64:ident ($tol64:expr);)*) => {$(
        #[test]
        fn $f32() {
            run_sliding(Precision::F32, $tol32, $check);
        }
        #[test]
        fn $f64() {
            run_sliding(Precision::F64, $tol64, $check);
        }
    )*};
}

sliding_tests! {
    check_project_boundary: project_boundary_matches_cpu_f32(1e-5), project_boundary_matches_cpu_f64(1e-13);
    check_constrain: constrain_matches_cpu_f32(1e-4), constrain_matches_cpu_f64(1e-12);
    check_hessian_gather: constrain_blocks_matches_cpu_f32(1e-4), constrain_blocks_matches_cpu_f64(1e-12);
    check_bcd: bcd_sliding_matches_cpu_f32(1e-3), bcd_sliding_matches_cpu_f64(1e-11);
}

fn run(precision: Precision, tol: f64, check: Check) {
    let Some(ctx) = context(precision) else {
        return;
    };
    for c in cases() {
        let mut pair = Pair::new(&ctx, &c);
        check(&mut pair, &c, tol);
    }
}

/// One test per kernel and precision, named `STEM_matches_cpu_{f32,f64}`.
macro_rules! kernel_tests {
    ($($check:ident: $f32:ident ($tol32:expr), $f64:ident ($tol64:expr);)*) => {$(
        #[test]
        fn $f32() {
            run(Precision::F32, $tol32, $check);
        }
        #[test]
        fn $f64() {
            run(Precision::F64, $tol64, $check);
        }
    )*};
}

kernel_tests! {
    check_objective: objective_matches_cpu_f32(1e-5), objective_matches_cpu_f64(1e-13);
    check_reduce: reduce_matches_cpu_f32(1e-5), reduce_matches_cpu_f64(1e-13);
    check_gradient_gather: gradient_gather_matches_cpu_f32(1e-4), gradient_gather_matches_cpu_f64(1e-12);
    check_bcd: bcd_matches_cpu_f32(1e-3), bcd_matches_cpu_f64(1e-11);
    check_reference_position: reference_position_matches_cpu_f32(1e-3), reference_position_matches_cpu_f64(1e-10);
    check_hessian_assemble: hessian_assemble_matches_cpu_f32(1e-4), hessian_assemble_matches_cpu_f64(1e-12);
    check_hessian_gather: hessian_gather_matches_cpu_f32(1e-4), hessian_gather_matches_cpu_f64(1e-12);
    check_bsr_spmv: bsr_spmv_matches_cpu_f32(1e-4), bsr_spmv_matches_cpu_f64(1e-12);
    check_block_jacobi_factor: block_jacobi_factor_matches_cpu_f32(1e-3), block_jacobi_factor_matches_cpu_f64(1e-11);
    check_block_jacobi: block_jacobi_matches_cpu_f32(1e-3), block_jacobi_matches_cpu_f64(1e-11);
    check_dot: dot_matches_cpu_f32(1e-6), dot_matches_cpu_f64(1e-15);
    check_axpby: axpby_matches_cpu_f32(1e-6), axpby_matches_cpu_f64(1e-15);
    check_set_slot: set_slot_matches_cpu_f32(0.0), set_slot_matches_cpu_f64(0.0);
    check_line_search: line_search_matches_cpu_f32(1e-5), line_search_matches_cpu_f64(1e-13);
    check_inversion: inversion_matches_cpu_f32(1e-3), inversion_matches_cpu_f64(1e-10);
    check_halo_gather: halo_gather_matches_cpu_f32(0.0), halo_gather_matches_cpu_f64(0.0);
    check_halo_scatter: halo_scatter_matches_cpu_f32(0.0), halo_scatter_matches_cpu_f64(0.0);
    check_restricted_sums: restricted_sums_match_cpu_f32(1e-5), restricted_sums_match_cpu_f64(1e-13);
}
