//! Building a `Problem` as a pipeline: the vertex order as a parameter, and
//! the reports' light path (check + corners only) against the full problem.

use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::metric::smetric::MetricKind;
use meshsmooth::metric_report::element_values;
use meshsmooth::problem::{Ordering, Problem, ProblemOptions};
use meshsmooth::solve::{self, Method, Params};
use meshsmooth::{Mesh, objective};

fn perturbed(mut m: Mesh, alpha: f64, seed: u64) -> Mesh {
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha },
        fraction: 1.0,
        seed,
    };
    generate::perturb(&mut m, &opts).unwrap();
    m
}

fn with_ordering(ordering: Ordering) -> ProblemOptions<'static> {
    {
        let mut po = ProblemOptions::default();
        po.ordering = ordering;
        po
    }
}

#[test]
fn input_ordering_keeps_the_file_order_and_reaches_the_same_optimum() {
    let mesh = perturbed(generate::tet_box(6, 6, 6, [6.0; 3]), 0.3, 11);
    let input = Problem::with_options(&mesh, &with_ordering(Ordering::INPUT)).unwrap();
    let rbfs = Problem::new(&mesh).unwrap();
    assert_eq!(input.order, (0..mesh.num_points() as u32).collect::<Vec<_>>());
    assert_ne!(
        rbfs.order, input.order,
        "the default order must differ for the test to mean anything"
    );
    assert_eq!(input.gather(&mesh.points), mesh.points);
    // the same objective at the start, whatever the numbering
    let f0_input = objective::value(&input, &input.gather(&mesh.points)).unwrap();
    let f0_rbfs = objective::value(&rbfs, &rbfs.gather(&mesh.points)).unwrap();
    assert!((f0_input - f0_rbfs).abs() <= 1e-13 * f0_rbfs, "{f0_input} vs {f0_rbfs}");

    let mut params = Params::default();
    params.tol = 1e-9;
    let mut finals = Vec::new();
    for ordering in [Ordering::ReverseBfs, Ordering::INPUT, Ordering::CuthillMcKee] {
        let mut m = mesh.clone();
        let info = solve::smooth_mesh(
            &mut m,
            &with_ordering(ordering),
            &solve::Options::cpu(Method::Newton, &params),
            &mut |_| true,
        )
        .unwrap();
        assert!(
            info.objective < 0.99 * f0_rbfs,
            "{ordering}: {} from {f0_rbfs}",
            info.objective
        );
        // re-evaluated in the default numbering: the result, not its numbering
        let f = objective::value(&rbfs, &rbfs.gather(&m.points)).unwrap();
        assert!(
            (f - info.objective).abs() <= 1e-12 * f,
            "{ordering}: {f} vs {}",
            info.objective
        );
        finals.push((ordering, f));
    }
    let (_, f_rbfs) = finals[0];
    for &(ordering, f) in &finals[1..] {
        assert!(
            (f - f_rbfs).abs() <= 1e-9 * f_rbfs,
            "{ordering}: F {f} vs rbfs {f_rbfs}"
        );
    }
}

#[test]
fn input_ordering_numbers_elements_by_first_touch_from_vertex_zero() {
    let mesh = generate::quad_grid(3, 2, [3.0, 2.0]);
    let p = Problem::with_options(&mesh, &with_ordering(Ordering::INPUT)).unwrap();
    // vertex 0 touches only quad 0, vertex 1 quads 0 and 1, vertex 2 quads 1 and 2, ...
    assert_eq!(p.elem_order, vec![0, 1, 2, 3, 4, 5]);
    let p = Problem::new(&mesh).unwrap();
    let mut sorted = p.elem_order.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, vec![0, 1, 2, 3, 4, 5]);
}

/// `element_values` as it was: a full (reverse-BFS) problem on a copy of the
/// mesh, values mapped back through `elem_order`.
fn element_values_via_problem(
    mesh: &Mesh,
    points: &[[f64; 3]],
    metric: MetricKind,
    reference: Option<&Mesh>,
) -> meshsmooth::Result<Vec<Option<f64>>> {
    let mut m = mesh.clone();
    m.points = points.to_vec();
    let p = Problem::with_options(&m, &{
        let mut po = ProblemOptions::default();
        po.metric = metric;
        po.reference = reference;
        po
    })?;
    let x = p.gather(points);
    let mut sums = vec![Some(0.0); mesh.num_elements()];
    let mut counts = vec![0usize; mesh.num_elements()];
    for c in 0..p.num_corners() {
        let e = p.elem_order[p.corner_element[c] as usize] as usize;
        let v = p.model.value(p.shape(c), &p.corner_points(&x, c));
        sums[e] = match (sums[e], v) {
            (Some(s), Some(v)) => Some(s + v),
            _ => None,
        };
        counts[e] += 1;
    }
    Ok(sums
        .into_iter()
        .zip(counts)
        .map(|(s, n)| s.map(|s| s / n.max(1) as f64))
        .collect())
}

fn assert_bit_identical(mesh: &Mesh, points: &[[f64; 3]], metric: MetricKind, reference: Option<&Mesh>, name: &str) {
    let light = element_values(mesh, points, metric, reference).unwrap();
    let full = element_values_via_problem(mesh, points, metric, reference).unwrap();
    assert_eq!(light.len(), mesh.num_elements(), "{name} {metric}");
    for (e, (a, b)) in light.iter().zip(&full).enumerate() {
        assert_eq!(
            a.map(f64::to_bits),
            b.map(f64::to_bits),
            "{name} {metric} element {e}: {a:?} vs {b:?}"
        );
    }
    // the values are not trivial: perturbed elements are not all ideal
    let spread = light
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max((v - light[0].unwrap()).abs()));
    assert!(spread > 1e-3, "{name} {metric}: values barely vary ({spread})");
}

#[test]
fn light_report_path_matches_the_full_problem_bit_for_bit_on_a_mixed_mesh() {
    let ideal = generate::mixed_block(3, 2);
    let kinds: std::collections::BTreeSet<_> = ideal.kinds.iter().copied().collect();
    assert!(kinds.len() >= 3, "mixed block has {kinds:?}");
    let mesh = perturbed(ideal.clone(), 0.25, 3);
    for metric in [MetricKind::InverseMeanRatio, MetricKind::ConditionNumber] {
        assert_bit_identical(&mesh, &mesh.points, metric, None, "mixed");
    }
    assert_bit_identical(&mesh, &mesh.points, MetricKind::TargetShapeSize, Some(&ideal), "mixed");
    // positions other than the mesh's own
    let moved = perturbed(mesh.clone(), 0.1, 4).points;
    assert_bit_identical(&mesh, &moved, MetricKind::InverseMeanRatio, None, "mixed, moved");
}

#[test]
fn light_report_path_matches_the_full_problem_bit_for_bit_on_clockwise_planar_meshes() {
    for (name, m) in [
        ("triangles", generate::tri_grid(5, 4, [5.0, 4.0])),
        ("quads", generate::quad_grid(5, 4, [5.0, 4.0])),
    ] {
        // mirrored in y: every element wound clockwise
        let mut ideal = m;
        for p in &mut ideal.points {
            p[1] = -p[1];
        }
        assert!(meshsmooth::metric::is_clockwise(&ideal, &ideal.points), "{name}");
        let mesh = perturbed(ideal.clone(), 0.25, 9);
        for metric in [MetricKind::InverseMeanRatio, MetricKind::ConditionNumber] {
            assert_bit_identical(&mesh, &mesh.points, metric, None, name);
        }
        assert_bit_identical(&mesh, &mesh.points, MetricKind::TargetShapeSize, Some(&ideal), name);
        // and no element reads as inverted
        let values = element_values(&mesh, &mesh.points, MetricKind::InverseMeanRatio, None).unwrap();
        assert!(values.iter().all(Option::is_some), "{name}");
    }
}

#[test]
fn light_report_path_refuses_what_the_full_problem_refuses() {
    let mesh = generate::quad_grid(2, 2, [2.0, 2.0]);
    let light = element_values(&mesh, &mesh.points, MetricKind::TargetShapeSize, None).unwrap_err();
    let full = element_values_via_problem(&mesh, &mesh.points, MetricKind::TargetShapeSize, None).unwrap_err();
    assert_eq!(light.to_string(), full.to_string());
    let mut tilted = mesh.points.clone();
    tilted[4][2] = 1.0;
    // a bent grid is a surface: both paths measure it, alike
    let light = element_values(&mesh, &tilted, MetricKind::InverseMeanRatio, None).unwrap();
    let full = element_values_via_problem(&mesh, &tilted, MetricKind::InverseMeanRatio, None).unwrap();
    assert_eq!(light, full);
    let light = element_values(&mesh, &tilted, MetricKind::TargetShapeSize, Some(&mesh)).unwrap_err();
    let full = element_values_via_problem(&mesh, &tilted, MetricKind::TargetShapeSize, Some(&mesh)).unwrap_err();
    assert_eq!(light.to_string(), full.to_string());
}

/// The Newton Hessian pattern, built in parallel, holds every pair of free
/// vertices of every corner at the slot that names it, and each row range
/// lists exactly the corners touching its rows, ascending; the pattern is the
/// same on 1, 2 and 3 threads (the assembly ranges follow the thread count:
/// one on one thread).
#[test]
fn hessian_pattern_holds_every_corner_pair_and_is_the_same_on_any_thread_count() {
    use meshsmooth::backend::cpu::hessian_assemble::HessianPattern;
    for (name, m) in [
        ("mixed", generate::mixed_block(16, 12)),
        ("tets", generate::tet_box(20, 20, 20, [1.0, 1.0, 1.0])),
    ] {
        let p = Problem::new(&m).unwrap();
        let build = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| HessianPattern::new(&p))
        };
        let h = build(3);
        let (fi, mx) = (&h.free_index, &h.matrix);
        assert!(h.ranges.len() >= 2, "{name}: {} ranges", h.ranges.len());
        // each range lists exactly the corners touching its rows, ascending
        let check_ranges = |g: &HessianPattern, ctx: &str| {
            let mut touching: Vec<Vec<u32>> = vec![Vec::new(); g.ranges.len()];
            for (c, t) in p.corners.iter().enumerate() {
                let mut seen = Vec::new();
                for a in 0..=p.dim {
                    let i = fi[t[a] as usize];
                    if i == u32::MAX {
                        continue;
                    }
                    let r = g.ranges.iter().position(|r| r.start <= i && i < r.end).unwrap();
                    if !seen.contains(&r) {
                        seen.push(r);
                        touching[r].push(c as u32);
                    }
                }
            }
            assert_eq!(g.ranges.first().map(|r| r.start), Some(0), "{ctx}");
            assert_eq!(
                g.ranges.last().map(|r| r.end),
                Some(fi.iter().filter(|&&i| i != u32::MAX).count() as u32),
                "{ctx}"
            );
            for (r, range) in g.ranges.iter().enumerate() {
                assert_eq!(range.elements, touching[r], "{ctx}: range {r}");
            }
        };
        check_ranges(&h, name);
        for (c, t) in p.corners.iter().enumerate() {
            for a in 0..=p.dim {
                let i = fi[t[a] as usize];
                if i == u32::MAX {
                    continue;
                }
                for b in 0..=p.dim {
                    let j = fi[t[b] as usize];
                    let s = h.slots[c][4 * a + b];
                    if j == u32::MAX {
                        assert_eq!(s, u32::MAX, "{name}: corner {c} ({a}, {b})");
                        continue;
                    }
                    let (lo, hi) = (mx.row_offsets[i as usize], mx.row_offsets[i as usize + 1]);
                    assert!(
                        lo <= s && s < hi && mx.cols[s as usize] == j,
                        "{name}: corner {c} ({a}, {b})"
                    );
                }
            }
        }
        for i in 0..mx.diag.len() {
            let row = &mx.cols[mx.row_offsets[i] as usize..mx.row_offsets[i + 1] as usize];
            assert!(row.windows(2).all(|w| w[0] < w[1]), "{name}: row {i}");
            assert_eq!(mx.cols[mx.diag[i] as usize], i as u32, "{name}: row {i}");
        }
        for threads in [1, 2] {
            let g = build(threads);
            let ctx = format!("{name} on {threads} threads");
            assert_eq!(g.slots, h.slots, "{ctx}");
            assert_eq!(g.matrix.row_offsets, mx.row_offsets, "{ctx}");
            assert_eq!(g.matrix.cols, mx.cols, "{ctx}");
            assert_eq!(g.matrix.diag, mx.diag, "{ctx}");
            check_ranges(&g, &ctx);
            if threads == 1 {
                assert_eq!(g.ranges.len(), 1, "{ctx}");
            }
        }
    }
}
