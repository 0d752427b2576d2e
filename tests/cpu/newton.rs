//! Inexact Newton: PCG against dense solves, negative curvature, the
//! assembled Hessian against finite differences, agreement with BCD.

use crate::common;
use common::perturbed_box;
use meshsmooth::backend::Backend;
use meshsmooth::backend::cpu::CpuBackend;
use meshsmooth::backend::cpu::bsr_spmv::BlockCsr;
use meshsmooth::backend::cpu::hessian_assemble::HessianPattern;
use meshsmooth::backend::cpu::sym_hessian::{SymBlockCsr, SymHessian};
use meshsmooth::objective;
use meshsmooth::problem::Problem;
use meshsmooth::solve::pcg::{NegativeCurvature, PcgInfo, PcgParams, PcgStop, PcgWork, Preconditioner, pcg};
use meshsmooth::solve::{self, Method, Params, StopReason};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

type Vec3 = [f64; 3];

/// A dense symmetric matrix stored as a full block matrix (every block present).
fn dense_blocks(a: &[Vec<f64>]) -> BlockCsr {
    let n = a.len() / 3;
    let mut m = BlockCsr::default();
    m.row_offsets.push(0);
    for i in 0..n {
        for j in 0..n {
            let mut b = [[0.0; 3]; 3];
            for r in 0..3 {
                for c in 0..3 {
                    b[r][c] = a[3 * i + r][3 * j + c];
                }
            }
            m.cols.push(j as u32);
            m.blocks.push(b);
        }
        m.diag.push((i * n + i) as u32);
        m.row_offsets.push(((i + 1) * n) as u32);
    }
    m
}

fn random_symmetric(n: usize, rng: &mut ChaCha8Rng, shift: f64) -> Vec<Vec<f64>> {
    let m = 3 * n;
    let b: Vec<Vec<f64>> = (0..m)
        .map(|_| (0..m).map(|_| rng.random_range(-1.0..1.0)).collect())
        .collect();
    (0..m)
        .map(|i| {
            (0..m)
                .map(|j| (0..m).map(|k| b[k][i] * b[k][j]).sum::<f64>() + if i == j { shift } else { 0.0 })
                .collect()
        })
        .collect()
}

fn dense_solve(a: &[Vec<f64>], b: &[f64]) -> Vec<f64> {
    let m = b.len();
    let mut aug: Vec<Vec<f64>> = a
        .iter()
        .zip(b)
        .map(|(r, &v)| r.iter().copied().chain([v]).collect())
        .collect();
    for c in 0..m {
        let piv = (c..m)
            .max_by(|&i, &j| aug[i][c].abs().total_cmp(&aug[j][c].abs()))
            .unwrap();
        aug.swap(c, piv);
        for r in 0..m {
            if r != c {
                let f = aug[r][c] / aug[c][c];
                for k in c..=m {
                    aug[r][k] -= f * aug[c][k];
                }
            }
        }
    }
    (0..m).map(|i| aug[i][m] / aug[i][i]).collect()
}

fn flat(v: &[Vec3]) -> Vec<f64> {
    v.iter().flatten().copied().collect()
}

/// The one PCG (`solve::pcg`) on a CPU backend holding only `m`.
fn run_pcg(m: &BlockCsr, b: &[Vec3], params: &PcgParams) -> (PcgInfo, Vec<Vec3>) {
    let mut be = CpuBackend::linear(m.clone());
    let work = PcgWork::new(&mut be).unwrap();
    let (bv, dv) = (be.vector().unwrap(), be.vector().unwrap());
    be.write_vector(bv, b).unwrap();
    be.factor_precond().unwrap();
    let info = pcg(&mut be, &work, bv, dv, params).unwrap();
    (info, be.read_vector(dv).unwrap())
}

#[test]
fn pcg_solves_random_spd_block_systems_like_a_dense_solve() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for n in [1, 4, 12] {
        let a = random_symmetric(n, &mut rng, 0.5);
        let m = dense_blocks(&a);
        let b: Vec<Vec3> = (0..n).map(|_| [0; 3].map(|_| rng.random_range(-1.0..1.0))).collect();
        let (info, d) = run_pcg(
            &m,
            &b,
            &PcgParams {
                max_iter: 500,
                rtol: 1e-12,
                ..Default::default()
            },
        );
        assert_eq!(info.stop, PcgStop::Converged, "{info:?}");
        let exact = dense_solve(&a, &flat(&b));
        let scale = exact.iter().map(|v| v.abs()).fold(0.0, f64::max);
        for (x, e) in flat(&d).iter().zip(&exact) {
            assert!((x - e).abs() <= 1e-8 * scale, "{x} vs {e}");
        }
    }
}

/// Q diag(lambda) Q^T with a random orthogonal Q (Gram-Schmidt).
fn with_spectrum(lambda: &[f64], rng: &mut ChaCha8Rng) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let m = lambda.len();
    let mut q: Vec<Vec<f64>> = Vec::new();
    while q.len() < m {
        let mut v: Vec<f64> = (0..m).map(|_| rng.random_range(-1.0..1.0)).collect();
        for u in &q {
            let d: f64 = v.iter().zip(u).map(|(a, b)| a * b).sum();
            v.iter_mut().zip(u).for_each(|(a, b)| *a -= d * b);
        }
        let n = v.iter().map(|a| a * a).sum::<f64>().sqrt();
        if n > 1e-3 {
            q.push(v.iter().map(|a| a / n).collect());
        }
    }
    let a = (0..m)
        .map(|i| {
            (0..m)
                .map(|j| (0..m).map(|k| q[k][i] * lambda[k] * q[k][j]).sum())
                .collect()
        })
        .collect();
    (a, q)
}

#[test]
fn pcg_returns_a_descent_direction_of_negative_curvature_on_indefinite_systems() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let n = 8;
    // one small negative eigenvalue among positive ones; the right-hand side
    // barely sees it, so CG meets the negative curvature after a few steps
    let mut lambda: Vec<f64> = (0..3 * n).map(|i| 1.0 + i as f64).collect();
    lambda[0] = -0.5;
    let (a, q) = with_spectrum(&lambda, &mut rng);
    let coef: Vec<f64> = (0..3 * n)
        .map(|k| if k == 0 { 1e-3 } else { rng.random_range(0.5..1.0) })
        .collect();
    let bf: Vec<f64> = (0..3 * n)
        .map(|i| (0..3 * n).map(|k| q[k][i] * coef[k]).sum())
        .collect();
    let b: Vec<Vec3> = bf.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
    let m = dense_blocks(&a);
    for mode in [NegativeCurvature::Direction, NegativeCurvature::Iterate] {
        let params = PcgParams {
            max_iter: 200,
            rtol: 1e-14,
            negative_curvature: mode,
        };
        let (info, d) = run_pcg(&m, &b, &params);
        assert_eq!(info.stop, PcgStop::NegativeCurvature, "{mode:?}: {info:?}");
        assert!(info.iterations > 0, "{mode:?}: {info:?}");
        let mut ad = vec![[0.0; 3]; n];
        m.mul(&d, &mut ad);
        let curvature: f64 = flat(&d).iter().zip(flat(&ad)).map(|(x, y)| x * y).sum();
        let downhill: f64 = flat(&d).iter().zip(flat(&b)).map(|(x, y)| x * y).sum();
        assert!(downhill > 0.0, "{mode:?}: d^T b = {downhill}");
        if mode == NegativeCurvature::Direction {
            assert!(curvature <= 0.0, "d^T A d = {curvature}");
        }
    }
}

#[test]
fn assembled_gradient_and_hessian_match_finite_differences() {
    let mesh = perturbed_box(4, 0.3, 9);
    let p = Problem::new(&mesh).unwrap();
    let x = p.gather(&mesh.points);
    let mut pat = HessianPattern::new(&p);
    let nfree = pat.free_vertex.len();
    let mut g = vec![[0.0; 3]; nfree];
    assert!(pat.assemble(&p, &x, &mut g));
    let (_, g2) = objective::gradient(&p, &x).unwrap();
    for (i, &v) in pat.free_vertex.iter().enumerate() {
        for c in 0..3 {
            assert!((g[i][c] - g2[v as usize][c]).abs() < 1e-15 + 1e-12 * g[i][c].abs());
        }
    }
    // H v against central differences of the gradient along a random v
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let dir: Vec<Vec3> = (0..nfree)
        .map(|_| [0; 3].map(|_| rng.random_range(-1.0..1.0)))
        .collect();
    let mut hv = vec![[0.0; 3]; nfree];
    pat.matrix.mul(&dir, &mut hv);
    let eps = 1e-6;
    let shifted = |s: f64| {
        let mut y = x.clone();
        for (d, &v) in dir.iter().zip(&pat.free_vertex) {
            for c in 0..3 {
                y[v as usize][c] += s * d[c];
            }
        }
        objective::gradient(&p, &y).unwrap().1
    };
    let (gp, gm) = (shifted(eps), shifted(-eps));
    let scale = hv.iter().flatten().map(|v| v.abs()).fold(0.0f64, f64::max);
    for (i, &v) in pat.free_vertex.iter().enumerate() {
        for c in 0..3 {
            let fd = (gp[v as usize][c] - gm[v as usize][c]) / (2.0 * eps);
            assert!(
                (fd - hv[i][c]).abs() < 1e-6 * scale,
                "row {i}.{c}: {fd} vs {}",
                hv[i][c]
            );
        }
    }
}

#[test]
fn newton_and_bcd_reach_the_same_vertex_positions() {
    let mesh = perturbed_box(8, 0.3, 4);
    let mut tight = Params::default();
    tight.tol = 1e-9;
    let (na, a) = converged(&mesh, Method::Newton, &tight);
    let (nb, b) = converged(&mesh, Method::Bcd, &tight);
    assert!(
        na.iterations < nb.iterations / 4,
        "Newton {} vs BCD {} iterations",
        na.iterations,
        nb.iterations
    );
    let worst = largest_difference(&mesh, &a, &b);
    assert!(worst < 1e-4, "largest difference {worst} mean edges");
    for w in na.history.records.windows(2) {
        assert!(w[1].objective <= w[0].objective);
    }
}

/// Smooths a copy of `mesh` on the CPU; the run must converge.
fn converged(mesh: &meshsmooth::Mesh, method: Method, params: &Params) -> (solve::Info, meshsmooth::Mesh) {
    let mut m = mesh.clone();
    let info = solve::smooth_mesh(
        &mut m,
        &Default::default(),
        &solve::Options::cpu(method, params),
        &mut |_| true,
    )
    .unwrap();
    assert_eq!(info.stop, StopReason::Converged, "{method:?}");
    (info, m)
}

/// Largest distance between corresponding points, in mean edge lengths of `mesh`.
fn largest_difference(mesh: &meshsmooth::Mesh, a: &meshsmooth::Mesh, b: &meshsmooth::Mesh) -> f64 {
    let p = Problem::new(mesh).unwrap();
    let edge = p.mean_edge_length(&p.gather(&mesh.points));
    let worst = a
        .points
        .iter()
        .zip(&b.points)
        .map(|(u, v)| (0..3).map(|i| (u[i] - v[i]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    worst / edge
}

/// A random symmetric block matrix with a random sparse pattern (diagonally
/// heavy, like a Hessian), in full storage.
fn random_sparse_symmetric(n: usize, per_row: usize, rng: &mut ChaCha8Rng) -> BlockCsr {
    let mut rows: Vec<Vec<(u32, [[f64; 3]; 3])>> = vec![Vec::new(); n];
    for i in 0..n {
        let mut d = [[0.0; 3]; 3];
        for r in 0..3 {
            for c in 0..=r {
                let v = rng.random_range(-1.0..1.0);
                d[r][c] = v;
                d[c][r] = v;
            }
            d[r][r] += 4.0 * per_row as f64;
        }
        rows[i].push((i as u32, d));
        for _ in 0..per_row / 2 {
            // mostly near the diagonal, sometimes far (across product ranges)
            let j = if rng.random_range(0..4) == 0 {
                rng.random_range(0..n)
            } else {
                (i + rng.random_range(1..40)).min(n - 1)
            };
            if j == i || rows[i].iter().any(|e| e.0 as usize == j) {
                continue;
            }
            let b: [[f64; 3]; 3] = [0; 3].map(|_| [0; 3].map(|_| rng.random_range(-1.0..1.0)));
            let bt = [0, 1, 2].map(|r| [0, 1, 2].map(|c| b[c][r]));
            rows[i].push((j as u32, b));
            rows[j].push((i as u32, bt));
        }
    }
    let mut m = BlockCsr::default();
    m.row_offsets.push(0);
    for (i, mut row) in rows.into_iter().enumerate() {
        row.sort_by_key(|e| e.0);
        for (j, b) in row {
            if j as usize == i {
                m.diag.push(m.cols.len() as u32);
            }
            m.cols.push(j);
            m.blocks.push(b);
        }
        m.row_offsets.push(m.cols.len() as u32);
    }
    m
}

fn rel_err(a: &[Vec3], b: &[Vec3]) -> f64 {
    let scale = b.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let worst = a
        .iter()
        .flatten()
        .zip(b.iter().flatten())
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    worst / scale
}

fn with_threads<T: Send>(n: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .unwrap()
        .install(f)
}

#[test]
fn symmetric_product_equals_the_full_product_and_ignores_the_thread_count() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    // 9000 rows: several product ranges, so the transposed pass has work
    for (n, per_row) in [(1, 0), (7, 4), (300, 10), (9000, 14)] {
        let full = random_sparse_symmetric(n, per_row, &mut rng);
        let sym = SymBlockCsr::from_full(&full);
        assert_eq!(sym.to_full().cols, full.cols);
        let x: Vec<Vec3> = (0..n).map(|_| [0; 3].map(|_| rng.random_range(-1.0..1.0))).collect();
        let mut want = vec![[0.0; 3]; n];
        full.mul(&x, &mut want);
        let run = |threads| {
            with_threads(threads, || {
                let mut y = vec![[7.0; 3]; n];
                sym.mul(&x, &mut y);
                y
            })
        };
        let (one, two) = (run(1), run(2));
        assert_eq!(one, two, "n = {n}: the product depends on the thread count");
        let e = rel_err(&one, &want);
        assert!(e <= 1e-14, "n = {n}: symmetric product off by {e:.1e}");
    }
}

#[test]
fn symmetric_hessian_equals_the_full_twin_on_a_real_problem() {
    // 18^3 cells: 4913 free rows, two product ranges
    let mesh = perturbed_box(18, 0.3, 6);
    let p = Problem::new(&mesh).unwrap();
    let x = p.gather(&mesh.points);
    let mut full = HessianPattern::new(&p);
    let nfree = full.free_vertex.len();
    let mut g_full = vec![[0.0; 3]; nfree];
    assert!(full.assemble(&p, &x, &mut g_full));
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let dir: Vec<Vec3> = (0..nfree)
        .map(|_| [0; 3].map(|_| rng.random_range(-1.0..1.0)))
        .collect();
    let mut want = vec![[0.0; 3]; nfree];
    full.matrix.mul(&dir, &mut want);
    let run = |threads| {
        with_threads(threads, || {
            let mut sym = SymHessian::new(&p);
            let mut g = vec![[0.0; 3]; nfree];
            assert!(sym.assemble(&p, &x, &mut g));
            let mut y = vec![[0.0; 3]; nfree];
            sym.matrix.mul(&dir, &mut y);
            (sym, g, y)
        })
    };
    let ((sym, g1, y1), (_, g2, y2)) = (run(1), run(2));
    assert_eq!((&g1, &y1), (&g2, &y2), "results depend on the thread count");
    assert_eq!(g1, g_full, "gradients differ");
    // the upper blocks are the twin's, bit for bit
    let m = &full.matrix;
    for i in 0..nfree {
        for s in m.row_offsets[i] as usize..m.row_offsets[i + 1] as usize {
            let j = m.cols[s];
            if j as usize > i {
                assert_eq!(sym.block(i as u32, j), m.blocks[s]);
            }
        }
        assert_eq!(sym.matrix.diag[i], m.blocks[m.diag[i] as usize]);
    }
    let e = rel_err(&y1, &want);
    assert!(e <= 1e-14, "symmetric product off by {e:.1e}");
}

#[test]
fn newton_memory_is_within_the_papers_formula() {
    let mesh = perturbed_box(16, 0.3, 7);
    let (cmp, _) = meshsmooth::compare::compare(
        &mesh,
        &Default::default(),
        &[Method::Newton],
        &solve::Options::cpu(Method::Newton, &{
            let mut p = Params::default();
            p.max_iter = 1;
            p
        }),
    )
    .unwrap();
    let r = &cmp.runs[0];
    let paper = r.paper_memory_bytes.unwrap();
    let ratio = r.memory_bytes as f64 / paper as f64;
    assert!(
        ratio <= 1.2,
        "{} bytes, {ratio:.2} x the paper's {paper}",
        r.memory_bytes
    );
}

/// PCG with a chosen preconditioner on a CPU backend holding only `m`.
fn run_pcg_with(m: &BlockCsr, b: &[Vec3], params: &PcgParams, pc: Preconditioner) -> (PcgInfo, Vec<Vec3>) {
    let mut be = CpuBackend::linear(m.clone());
    be.set_preconditioner(pc).unwrap();
    let work = PcgWork::new(&mut be).unwrap();
    let (bv, dv) = (be.vector().unwrap(), be.vector().unwrap());
    be.write_vector(bv, b).unwrap();
    be.factor_precond().unwrap();
    let info = pcg(&mut be, &work, bv, dv, params).unwrap();
    (info, be.read_vector(dv).unwrap())
}

#[test]
fn pcg_with_symmetric_gauss_seidel_solves_spd_systems_in_fewer_iterations() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    for (n, per_row) in [(12, 6), (5000, 14)] {
        let m = random_sparse_symmetric(n, per_row, &mut rng);
        let b: Vec<Vec3> = (0..n).map(|_| [0; 3].map(|_| rng.random_range(-1.0..1.0))).collect();
        let params = PcgParams {
            max_iter: 1000,
            rtol: 1e-10,
            ..Default::default()
        };
        let (ij, dj) = run_pcg_with(&m, &b, &params, Preconditioner::Jacobi);
        let (is, ds) = run_pcg_with(&m, &b, &params, Preconditioner::Sgs);
        assert_eq!(is.stop, PcgStop::Converged, "{is:?}");
        assert!(is.iterations <= ij.iterations, "SGS {is:?} vs Jacobi {ij:?}");
        let mut r = vec![[0.0; 3]; n];
        m.mul(&ds, &mut r);
        let e = rel_err(&r, &b);
        assert!(e <= 1e-8, "n = {n}: residual {e:.1e}");
        assert!(rel_err(&ds, &dj) <= 1e-7);
    }
}

/// Newton to 1e-10 with block Jacobi and with symmetric Gauss-Seidel: the
/// two runs' results (Jacobi first).
fn jacobi_and_sgs(mesh: &meshsmooth::Mesh) -> [(solve::Info, meshsmooth::Mesh); 2] {
    [Preconditioner::Jacobi, Preconditioner::Sgs].map(|pc| {
        let mut params = Params::default();
        params.tol = 1e-10;
        params.newton.preconditioner = pc;
        converged(mesh, Method::Newton, &params)
    })
}

#[test]
fn newton_with_symmetric_gauss_seidel_reaches_the_block_jacobi_optimum() {
    let mesh = perturbed_box(8, 0.3, 4);
    let [(ij, mj), (is, ms)] = jacobi_and_sgs(&mesh);
    assert!((ij.objective - is.objective).abs() <= 1e-8 * ij.objective);
    let worst = largest_difference(&mesh, &mj, &ms);
    assert!(worst <= 1e-8, "largest difference {worst} mean edges");
}

/// The same on planar meshes, where the Gauss-Seidel sweeps read only the
/// 2x2 part of the blocks (`sgs_dim::<2>`): quadrilaterals and triangles.
#[test]
fn planar_newton_with_symmetric_gauss_seidel_reaches_the_block_jacobi_optimum() {
    for mut mesh in [
        meshsmooth::generate::quad_grid(14, 11, [14.0, 11.0]),
        meshsmooth::generate::tri_grid(12, 12, [12.0, 12.0]),
    ] {
        let opts = meshsmooth::generate::PerturbOptions {
            perturbation: meshsmooth::generate::Perturbation::Random { alpha: 0.3 },
            fraction: 1.0,
            seed: 7,
        };
        meshsmooth::generate::perturb(&mut mesh, &opts).unwrap();
        let [(ij, mj), (is, ms)] = jacobi_and_sgs(&mesh);
        assert!(
            is.cg_iterations.unwrap() < ij.cg_iterations.unwrap(),
            "{is:?} vs {ij:?}"
        );
        assert!((ij.objective - is.objective).abs() <= 1e-9 * ij.objective);
        let worst = largest_difference(&mesh, &mj, &ms);
        assert!(worst <= 1e-7, "largest difference {worst} mean edges");
    }
}

/// The line search's step to 0.7 of the first corner inversion against the
/// paper's blind halving, on the biased horseshoe SQIV, where Newton's full
/// steps invert elements: the same optimum, no inverted element, and fewer
/// trial evaluations.
#[test]
fn inversion_fraction_saves_trials_and_keeps_the_optimum() {
    use meshsmooth::generate::{self, HorseshoeKind};
    let (mesh, _) = generate::horseshoe(HorseshoeKind::SqIV, 2000);
    let run = |fraction: f64| {
        let mut params = Params::default();
        params.tol = 1e-9;
        params.newton.inversion_fraction = fraction;
        let (info, m) = converged(&mesh, Method::Newton, &params);
        assert!(meshsmooth::metric::inverted_elements(&m, &m.points).is_empty());
        for w in info.history.records.windows(2) {
            assert!(w[1].objective <= w[0].objective);
        }
        info
    };
    let (blind, aimed) = (run(0.0), run(0.7));
    assert!(
        (blind.objective - aimed.objective).abs() <= 1e-10 * blind.objective,
        "{} vs {}",
        blind.objective,
        aimed.objective
    );
    let trials = |i: &solve::Info| i.line_search_trials.unwrap();
    // the blind search needs a trial per halving after each inverting step
    assert!(
        trials(&blind) > blind.iterations + 5,
        "blind: {} trials in {} iterations",
        trials(&blind),
        blind.iterations
    );
    assert!(
        2 * trials(&aimed) < trials(&blind),
        "aimed {} vs blind {} trials",
        trials(&aimed),
        trials(&blind)
    );
}

/// Newton after coloured BCD sweeps (`NewtonParams::start_sweeps`): the same
/// optimum as Newton alone, fewer Newton steps on a badly perturbed box, the
/// sweeps ended by the slowdown rule before their cap, and each history
/// record's F falling.
#[test]
fn start_sweeps_reach_newtons_optimum_in_fewer_newton_steps() {
    let mesh = perturbed_box(14, 0.3, 7);
    let p = Problem::new(&mesh).unwrap();
    let x0 = p.gather(&mesh.points);
    let run = |sweeps: usize| {
        let mut params = Params::default();
        params.tol = 1e-9;
        params.newton.start_sweeps = sweeps;
        let mut x = x0.clone();
        let info = common::solve_on(&p, &mut x, Method::Newton, &params, solve::Device::Cpu);
        assert_eq!(info.stop, StopReason::Converged, "{sweeps} start sweeps");
        (info, x)
    };
    let (plain, xp) = run(0);
    let (swept, xs) = run(50);
    assert_eq!(plain.start_sweeps, Some(0));
    let sweeps = swept.start_sweeps.unwrap();
    let newton_steps = swept.iterations - sweeps;
    eprintln!(
        "Newton alone: {} iterations ({} on negative curvature); {sweeps} sweeps, then {newton_steps} Newton ({})",
        plain.iterations,
        plain.negative_curvature_steps.unwrap(),
        swept.negative_curvature_steps.unwrap()
    );
    // the slowdown rule, not the cap, ends the sweeps
    assert!((2..50).contains(&sweeps), "{sweeps} sweeps");
    assert!(
        newton_steps >= 1 && newton_steps < plain.iterations,
        "{newton_steps} vs {}",
        plain.iterations
    );
    assert!((swept.objective - plain.objective).abs() <= 1e-8 * plain.objective);
    let edge = p.mean_edge_length(&x0);
    let far = xs
        .iter()
        .zip(&xp)
        .map(|(a, b)| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt())
        .fold(0.0, f64::max);
    assert!(far <= 1e-4 * edge, "minimisers {far:e} apart");
    // the last sweep gained more than a quarter of the one before it, none before did
    let f: Vec<f64> = swept.history.records.iter().map(|r| r.objective).collect();
    let gain = |k: usize| f[k - 1] - f[k];
    for k in 2..sweeps {
        assert!(
            gain(k) <= meshsmooth::solve::newton::START_SLOWDOWN * gain(k - 1),
            "sweep {k}"
        );
    }
    assert!(gain(sweeps) > meshsmooth::solve::newton::START_SLOWDOWN * gain(sweeps - 1));
    assert!(f.windows(2).all(|w| w[1] <= w[0]));
}
