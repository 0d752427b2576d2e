//! Inexact Newton: PCG against dense solves, negative curvature, the
//! assembled Hessian against finite differences, agreement with BCD.

mod common;
use common::perturbed_box;
use meshsmooth::backend::Backend;
use meshsmooth::backend::cpu::CpuBackend;
use meshsmooth::backend::cpu::bsr_spmv::BlockCsr;
use meshsmooth::backend::cpu::hessian_assemble::HessianPattern;
use meshsmooth::objective;
use meshsmooth::problem::Problem;
use meshsmooth::solve::pcg::{NegativeCurvature, PcgInfo, PcgParams, PcgStop, PcgWork, pcg};
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
    let tight = Params {
        tol: 1e-9,
        ..Params::default()
    };
    let mut a = mesh.clone();
    let na = solve::smooth_mesh(
        &mut a,
        &Default::default(),
        &solve::Options::cpu(Method::Newton, &tight),
        &mut |_| true,
    )
    .unwrap();
    let mut b = mesh.clone();
    let nb = solve::smooth_mesh(
        &mut b,
        &Default::default(),
        &solve::Options::cpu(Method::Bcd, &tight),
        &mut |_| true,
    )
    .unwrap();
    assert_eq!(na.stop, StopReason::Converged);
    assert_eq!(nb.stop, StopReason::Converged);
    assert!(
        na.iterations < nb.iterations / 4,
        "Newton {} vs BCD {} iterations",
        na.iterations,
        nb.iterations
    );
    let p = Problem::new(&mesh).unwrap();
    let edge = p.mean_edge_length(&p.gather(&mesh.points));
    let worst = a
        .points
        .iter()
        .zip(&b.points)
        .map(|(u, v)| (0..3).map(|i| (u[i] - v[i]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    assert!(worst < 1e-4 * edge, "largest difference {worst} vs mean edge {edge}");
    for w in na.history.records.windows(2) {
        assert!(w[1].objective <= w[0].objective);
    }
}
