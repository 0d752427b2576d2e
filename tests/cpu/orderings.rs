//! The vertex orderings of the reordering paper (issue #11): each is a
//! permutation of the free vertices, the rules of section 4 on a mesh small
//! enough to check by hand, the static and dynamic strategies, and that the
//! order changes the path but not the optimum nor the output numbering.

use crate::common;
use meshsmooth::Mesh;
use meshsmooth::backend::Backend;
use meshsmooth::backend::cpu::CpuBackend;
use meshsmooth::generate::{self, HorseshoeKind, PerturbOptions, Perturbation};
use meshsmooth::mesh::sweep_order::{Scheme, SweepOrder};
use meshsmooth::problem::{Ordering, Problem, ProblemOptions};
use meshsmooth::solve::bcd::Bcd;
use meshsmooth::solve::reorder::{Reorder, Strategy};
use meshsmooth::solve::{self, BcdParams, Method, Options, Params, StopReason};

fn with_order(ordering: Ordering, seed: u64) -> ProblemOptions<'static> {
    // the ideal objective, the one the orderings are studied on (the biased
    // horseshoe is graded toward its inner wall and would get input targets)
    {
        let mut po = ProblemOptions::default();
        po.ordering = ordering;
        po.order_seed = seed;
        po.target = meshsmooth::problem::Target::Ideal;
        po
    }
}

/// A 7 x 5 vertex quad grid (35 vertices, 15 free), every free vertex moved.
fn perturbed_grid(seed: u64) -> Mesh {
    let mut m = generate::quad_grid(6, 4, [6.0, 4.0]);
    generate::perturb(
        &mut m,
        &PerturbOptions {
            perturbation: Perturbation::Random { alpha: 0.3 },
            fraction: 1.0,
            seed,
        },
    )
    .unwrap();
    m
}

/// The static order of `order` on `mesh` at its own positions, as mesh vertex ids.
fn static_order(mesh: &Mesh, order: SweepOrder, seed: u64) -> Vec<u32> {
    let p = Problem::with_options(mesh, &with_order(Ordering::Sweep(order), seed)).unwrap();
    let x = p.gather(&mesh.points);
    let mut r = Reorder::new(&p, order, Strategy::Static, seed);
    r.initial(&p, &x, &Default::default(), 1);
    r.vertices(&p)
}

fn free_vertices(mesh: &Mesh) -> Vec<u32> {
    let p = Problem::with_options(mesh, &with_order(Ordering::INPUT, 0)).unwrap();
    p.free_vertices.iter().map(|&v| p.order[v as usize]).collect()
}

#[test]
fn every_scheme_is_a_permutation_of_the_free_vertices_and_n_is_the_input_order() {
    let m = perturbed_grid(1);
    let free = free_vertices(&m);
    assert_eq!(free.len(), 15);
    for o in SweepOrder::all() {
        let order = static_order(&m, o, 3);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, free, "{}", o.paper_name());
    }
    assert_eq!(static_order(&m, SweepOrder::N, 0), free);
    // the graph numberings too are permutations (of all vertices)
    for o in [Ordering::ReverseBfs, Ordering::CuthillMcKee, Ordering::RedBlack] {
        let p = Problem::with_options(&m, &with_order(o, 0)).unwrap();
        let mut sorted = p.order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..m.num_points() as u32).collect::<Vec<_>>(), "{o}");
    }
}

#[test]
fn each_reverse_scheme_is_its_forward_scheme_reversed() {
    let m = perturbed_grid(2);
    for scheme in Scheme::ALL {
        let forward = static_order(&m, SweepOrder { scheme, reverse: false }, 5);
        let mut reverse = static_order(&m, SweepOrder { scheme, reverse: true }, 5);
        reverse.reverse();
        assert_eq!(forward, reverse, "{}", scheme.name());
    }
}

#[test]
fn random_order_repeats_for_a_seed_and_differs_between_seeds() {
    let m = perturbed_grid(3);
    let r = SweepOrder {
        scheme: Scheme::R,
        reverse: false,
    };
    assert_eq!(static_order(&m, r, 11), static_order(&m, r, 11));
    assert_ne!(static_order(&m, r, 11), static_order(&m, r, 12));
    assert_ne!(static_order(&m, r, 11), free_vertices(&m));
}

/// Inverse mean ratio of the corner at `p` with neighbours `next` and
/// `prev` (counter-clockwise), target the unit square: |A|^2 / (2 det A).
fn imr_corner(p: [f64; 3], next: [f64; 3], prev: [f64; 3]) -> f64 {
    let a = [next[0] - p[0], next[1] - p[1]];
    let b = [prev[0] - p[0], prev[1] - p[1]];
    let det = a[0] * b[1] - a[1] * b[0];
    (a[0] * a[0] + a[1] * a[1] + b[0] * b[0] + b[1] * b[1]) / (2.0 * det)
}

#[test]
fn wqp_puts_the_worst_patch_first_as_computed_by_hand() {
    // a 5 x 3 vertex grid of unit squares: free vertices 6, 7, 8 in a row;
    // 6 moves a little, 8 a lot, 7 stays. 8's patch holds its four
    // distorted squares, 7's two of those and two slightly distorted, 6's
    // four slightly distorted ones.
    let mut m = generate::quad_grid(4, 2, [4.0, 2.0]);
    m.points[6][1] += 0.1;
    m.points[8][0] += 0.3;
    m.points[8][1] += 0.25;
    // the patch objective by hand: the mean over the patch's quads of the
    // mean of their four corner terms (the harmonic template's average)
    let quad_mean = |e: usize| {
        let v = m.element(e);
        (0..4)
            .map(|k| {
                let at = |i: usize| m.points[v[i % 4] as usize];
                imr_corner(at(k), at(k + 1), at(k + 3))
            })
            .sum::<f64>()
            / 4.0
    };
    let patch = |vertex: u32| {
        let elems: Vec<usize> = (0..m.num_elements())
            .filter(|&e| m.element(e).contains(&vertex))
            .collect();
        elems.iter().map(|&e| quad_mean(e)).sum::<f64>() / elems.len() as f64
    };
    let (q6, q7, q8) = (patch(6), patch(7), patch(8));
    assert!(q8 > q7 && q7 > q6 && q6 > 1.0, "{q6} {q7} {q8}");
    let wqp = SweepOrder {
        scheme: Scheme::Wqp,
        reverse: false,
    };
    assert_eq!(static_order(&m, wqp, 0), vec![8, 7, 6]);
    assert_eq!(static_order(&m, SweepOrder { reverse: true, ..wqp }, 0), vec![6, 7, 8]);
    // D-WQP: from the worst vertex (8) outward: 7 at distance ~1.3, 6 at ~2.3
    let dwqp = SweepOrder {
        scheme: Scheme::DWqp,
        reverse: false,
    };
    assert_eq!(static_order(&m, dwqp, 0), vec![8, 7, 6]);
    // an ideal patch everywhere: all keys tie, and ties keep the input order
    let ideal = generate::quad_grid(4, 2, [4.0, 2.0]);
    assert_eq!(static_order(&ideal, wqp, 0), vec![6, 7, 8]);
}

#[test]
fn lng_and_gavm_put_the_vertex_farthest_from_rest_first() {
    // only vertex 7 is displaced: its neighbours 6 and 8 feel it too (their
    // patches share its elements), but it has the largest gradient and the
    // largest trial move, so it comes first
    let mut m = generate::quad_grid(4, 2, [4.0, 2.0]);
    m.points[7][0] += 0.3;
    for scheme in [Scheme::Lng, Scheme::Gavm] {
        let o = static_order(&m, SweepOrder { scheme, reverse: false }, 0);
        assert_eq!(o[0], 7, "{}", scheme.name());
    }
}

#[test]
fn static_grvm_sorts_by_a_second_trial_over_the_first_and_is_not_n() {
    use meshsmooth::mesh::sweep_order::largest_first;
    use meshsmooth::solve::reorder::{trial_moves, trial_positions};
    let (m, _) = generate::horseshoe(HorseshoeKind::SqIV, 150);
    let grvm = SweepOrder {
        scheme: Scheme::Grvm,
        reverse: false,
    };
    let p = Problem::with_options(&m, &with_order(Ordering::Sweep(grvm), 0)).unwrap();
    let x = p.gather(&m.points);
    let ls = Default::default();
    // the relative movement: the trial move from where the first trial put
    // every vertex, over the first trial's move
    let (d0, d1) = (
        trial_moves(&p, &x, &ls, 1),
        trial_moves(&p, &trial_positions(&p, &x, &ls, 1), &ls, 1),
    );
    let keys: Vec<f64> = d1
        .iter()
        .zip(&d0)
        .map(|(&b, &a)| if b == 0.0 { 0.0 } else { b / a })
        .collect();
    assert!(keys.iter().any(|&k| (k - 1.0).abs() > 0.05), "{keys:?}");
    let base: Vec<u32> = (0..keys.len() as u32).collect();
    let mut r = Reorder::new(&p, grvm, Strategy::Static, 0);
    r.initial(&p, &x, &ls, 1);
    assert_eq!(r.order, largest_first(&base, &keys));
    // so GRVM, -GRVM and D-GRVM are orders of their own, not N, -N and N
    let input = free_vertices(&m);
    let o = static_order(&m, grvm, 0);
    assert_ne!(o, input);
    let mut reversed = input.clone();
    reversed.reverse();
    let minus = SweepOrder { reverse: true, ..grvm };
    assert_ne!(static_order(&m, minus, 0), reversed);
    let d = SweepOrder {
        scheme: Scheme::DGrvm,
        reverse: false,
    };
    assert_ne!(static_order(&m, d, 0), input);
    // and the sweeps they make differ: another objective history
    let params = {
        let mut p = Params::default();
        p.tol = 0.0;
        p.max_iter = 6;
        p
    };
    let f = |o: Ordering| -> Vec<f64> {
        smooth(&m, o, &params)
            .1
            .history
            .records
            .iter()
            .map(|r| r.objective)
            .collect()
    };
    let (fg, fn_) = (f(Ordering::Sweep(grvm)), f(Ordering::INPUT));
    assert_eq!(fg.len(), fn_.len());
    assert!(fg.iter().zip(&fn_).skip(1).all(|(a, b)| a != b), "{fg:?} {fn_:?}");
}

fn bcd_params(reorder_every: Option<usize>, inner: usize) -> Params {
    {
        let mut p = Params::default();
        p.tol = 1e-9;
        p.max_iter = 5000;
        p.bcd = BcdParams {
            reorder_every,
            inner_iterations: inner,
            ..Default::default()
        };
        p
    }
}

#[test]
fn dynamic_reordering_every_sweep_changes_the_list_as_quality_changes() {
    let m = perturbed_grid(4);
    for scheme in [Scheme::Wqp, Scheme::Lng, Scheme::Gavm, Scheme::DGrvm] {
        let order = SweepOrder { scheme, reverse: false };
        let p = Problem::with_options(&m, &with_order(Ordering::Sweep(order), 0)).unwrap();
        let x = p.gather(&m.points);
        let mut be = CpuBackend::new(&p, &x, &Default::default()).unwrap();
        let mut bcd = Bcd::new(&mut be, &p, true, &bcd_params(Some(1), 1).bcd).unwrap();
        bcd.start(&mut be).unwrap().unwrap();
        let mut lists = vec![bcd.reorder.as_ref().unwrap().order.clone()];
        for _ in 0..3 {
            bcd.step(&mut be, None).unwrap();
            lists.push(bcd.reorder.as_ref().unwrap().order.clone());
        }
        assert_eq!(bcd.reorder.as_ref().unwrap().count, 4, "{}", scheme.name());
        assert!(lists.windows(2).any(|w| w[0] != w[1]), "{}: {lists:?}", scheme.name());
        // the static strategy keeps its first list
        let mut be = CpuBackend::new(&p, &x, &Default::default()).unwrap();
        let mut bcd = Bcd::new(&mut be, &p, true, &bcd_params(None, 1).bcd).unwrap();
        bcd.start(&mut be).unwrap().unwrap();
        let first = bcd.reorder.as_ref().unwrap().order.clone();
        for _ in 0..3 {
            bcd.step(&mut be, None).unwrap();
        }
        assert_eq!(bcd.reorder.as_ref().unwrap().order, first, "{}", scheme.name());
        assert_eq!(bcd.reorder.as_ref().unwrap().count, 1);
    }
}

fn smooth(mesh: &Mesh, ordering: Ordering, params: &Params) -> (Mesh, solve::Info) {
    let mut out = mesh.clone();
    let info = solve::smooth_mesh(
        &mut out,
        &with_order(ordering, 9),
        &Options::cpu(Method::Bcd, params),
        &mut |_| true,
    )
    .unwrap();
    (out, info)
}

#[test]
fn every_ordering_reaches_the_same_optimum_in_the_input_numbering() {
    // the biased horseshoe: an optimum that is not the ideal element everywhere
    let (m, _) = generate::horseshoe(HorseshoeKind::SqIV, 60);
    let params = bcd_params(None, 1);
    let (reference, ref_info) = smooth(&m, Ordering::INPUT, &params);
    assert_eq!(ref_info.stop, StopReason::Converged);
    for (ordering, every) in Ordering::all()
        .into_iter()
        .map(|o| (o, None))
        .chain([(Ordering::Sweep(SweepOrder::parse("d-gavm").unwrap()), Some(2))])
    {
        let params = bcd_params(every, 1);
        let (out, info) = smooth(&m, ordering, &params);
        assert_eq!(
            info.stop,
            StopReason::Converged,
            "{ordering}: {} sweeps, F {}, grad {}",
            info.iterations,
            info.objective,
            info.grad_norm
        );
        let rel = (info.objective - ref_info.objective).abs() / ref_info.objective;
        assert!(
            rel <= 1e-8,
            "{ordering}: F {} vs {}",
            info.objective,
            ref_info.objective
        );
        // the output is in the input's numbering, whatever order the sweep took
        let worst = out
            .points
            .iter()
            .zip(&reference.points)
            .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max))
            .fold(0.0, f64::max);
        assert!(worst < 1e-5, "{ordering}: a vertex differs by {worst}");
    }
}

#[test]
fn two_inner_iterations_move_farther_per_sweep_and_reach_the_same_optimum() {
    let m = perturbed_grid(6);
    let one_sweep = |inner| {
        let mut p = bcd_params(None, inner);
        p.max_iter = 1;
        smooth(&m, Ordering::INPUT, &p).1.objective
    };
    let (f1, f2) = (one_sweep(1), one_sweep(2));
    assert!(f2 < f1, "one sweep: inner 1 F {f1}, inner 2 F {f2}");
    let (_, a) = smooth(&m, Ordering::INPUT, &bcd_params(None, 1));
    let (_, b) = smooth(&m, Ordering::INPUT, &bcd_params(None, 2));
    assert!((a.objective - b.objective).abs() <= 1e-8 * a.objective);
}

#[test]
fn times_split_into_optimisation_and_reordering_within_the_total() {
    let (m, _) = generate::horseshoe(HorseshoeKind::SqIV, 300);
    let wqp = Ordering::Sweep(SweepOrder::parse("wqp").unwrap());
    let mut params = bcd_params(Some(5), 1);
    params.max_iter = 20;
    let (_, info) = smooth(&m, wqp, &params);
    assert_eq!(info.iterations, 20);
    // at the start, then after sweeps 5, 10, 15 and 20
    assert_eq!(info.reorderings, 5);
    assert!(info.reorder_seconds > 0.0 && info.optimise_seconds > 0.0);
    assert!(info.optimise_seconds + info.reorder_seconds <= info.seconds);
    // a graph numbering has no list to reorder
    let (_, info) = smooth(&m, Ordering::ReverseBfs, &params);
    assert_eq!((info.reorderings, info.reorder_seconds), (0, 0.0));
}

#[test]
fn a_target_objective_stops_a_reordered_sweep_at_the_first_sweep_below_it() {
    let m = perturbed_grid(7);
    let dlng = Ordering::Sweep(SweepOrder::parse("D-LNG").unwrap());
    let (_, free_run) = smooth(&m, dlng, &bcd_params(Some(1), 1));
    let f0 = free_run.history.first().unwrap().objective;
    let target = free_run.objective + 0.1 * (f0 - free_run.objective);
    let mut params = bcd_params(Some(1), 1);
    params.target_objective = Some(target);
    let (_, info) = smooth(&m, dlng, &params);
    assert_eq!(info.stop, StopReason::TargetReached);
    assert!(info.objective <= target);
    let r = &info.history.records;
    assert!(
        r[r.len() - 2].objective > target,
        "it went on after reaching the target"
    );
}

#[test]
fn the_backend_reports_the_sweep_it_has() {
    let m = perturbed_grid(8);
    let p = Problem::with_options(&m, &with_order(Ordering::INPUT, 0)).unwrap();
    let be = CpuBackend::new(&p, &p.gather(&m.points), &Default::default()).unwrap();
    assert!(be.has_sequential_sweep());
}

fn meshsmooth(args: &[&str]) -> (bool, String) {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_meshsmooth"))
        .args(args)
        .output()
        .expect("runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o.status.success(), text)
}

#[test]
fn the_cli_takes_paper_names_in_any_case_and_refuses_unknown_ones() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("h.vtk");
    let out = dir.path().join("o.vtk");
    let (i, o) = (input.to_str().unwrap(), out.to_str().unwrap());
    let (ok, text) = meshsmooth(&["generate", "horseshoe", "--kind", "sqiv", "--free", "80", "-o", i]);
    assert!(ok, "{text}");
    let smooth = |extra: &[&str]| {
        let mut args = vec![
            "smooth",
            i,
            "-o",
            o,
            "-q",
            "--method",
            "bcd",
            "--device",
            "cpu",
            "--max-iter",
            "6",
        ];
        args.extend_from_slice(extra);
        meshsmooth(&args)
    };
    for (arg, paper) in [
        ("--order=-wqp", "-WQP"),
        ("--order=D-GRVM", "D-GRVM"),
        ("--order=reverse-lng", "-LNG"),
        ("--order=N", "N"),
    ] {
        let (ok, text) = smooth(&[arg, "--reorder-every", "2", "--inner-iterations", "2"]);
        assert!(ok, "{arg}: {text}");
        assert!(
            text.contains(&format!(
                "order {paper} (dynamic, every 2 sweep(s), 2 inner iterations): COT"
            )),
            "{arg}: {text}"
        );
        assert!(text.contains("4 reordering(s)"), "{arg}: {text}");
    }
    // the space-separated form of a leading hyphen
    let (ok, text) = smooth(&["--order", "-gavm"]);
    assert!(ok && text.contains("order -GAVM (static)"), "{text}");
    for (ordering, other) in [("red-black", "rbfs"), ("cuthill-mckee", "input")] {
        assert!(smooth(&["--order", ordering]).0, "{ordering}");
        assert!(smooth(&["--order", other]).0, "{other}");
    }
    let (ok, text) = smooth(&["--order", "wqpp"]);
    assert!(!ok);
    assert!(text.contains("unknown ordering 'wqpp'"), "{text}");
    assert!(
        text.contains("rbfs, cuthill-mckee, red-black, n, r, wqp, gavm, grvm, lng, d-wqp"),
        "{text}"
    );
    let (ok, text) = smooth(&["--order", "rbfs", "--reorder-every", "2"]);
    assert!(
        !ok && text.contains("--reorder-every: needs one of the reordering paper's schemes"),
        "{text}"
    );
    let (ok, text) = smooth(&["--order", "wqp", "--inner-iterations", "0"]);
    assert!(!ok && text.contains("--inner-iterations: must be at least 1"), "{text}");
    let (ok, text) = meshsmooth(&["compare", i, "--order", "bogus"]);
    assert!(!ok && text.contains("unknown ordering 'bogus'"), "{text}");
    let (ok, text) = meshsmooth(&[
        "compare",
        i,
        "--order=-d-lng",
        "--reorder-every",
        "1",
        "--methods",
        "bcd,newton",
        "--max-iter",
        "3",
    ]);
    assert!(ok, "{text}");
    // only the sequential sweep reorders: initially and after each of 3 sweeps
    assert!(text.contains("bcd: order reverse-d-lng: COT"), "{text}");
    assert!(
        text.contains("4 reordering(s)") && !text.contains("newton: order"),
        "{text}"
    );
}

/// A CSV with a header as maps from column name to field.
#[cfg(feature = "studies")]
fn read_csv(path: &std::path::Path) -> Vec<std::collections::HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    lines
        .map(|l| header.iter().cloned().zip(l.split(',').map(String::from)).collect())
        .collect()
}

/// The polylines of an SVG written by `plot::curves_svg`, mapped back to data
/// through the frame's ranges: (series, points).
#[cfg(feature = "studies")]
fn svg_curves(svg: &str) -> Vec<(String, Vec<(f64, f64)>)> {
    use quick_xml::events::Event;
    use std::collections::HashMap;
    let mut reader = quick_xml::reader::Reader::from_str(svg);
    let mut frame: Option<HashMap<String, String>> = None;
    let mut lines = Vec::new();
    loop {
        match reader.read_event().expect("well-formed XML") {
            Event::Eof => break,
            Event::Start(e) | Event::Empty(e) => {
                let attrs: HashMap<String, String> = e
                    .attributes()
                    .map(|a| {
                        let a = a.unwrap();
                        (
                            a.key.as_ref().to_string(),
                            a.normalized_value(quick_xml::XmlVersion::Implicit1_0)
                                .unwrap()
                                .into_owned(),
                        )
                    })
                    .collect();
                match e.name().as_ref() {
                    "rect" if attrs.get("class").map(String::as_str) == Some("frame") => frame = Some(attrs),
                    "polyline" => lines.push(attrs),
                    _ => {}
                }
            }
            _ => {}
        }
    }
    let f = frame.expect("a plot frame");
    let num = |k: &str| -> f64 { f[k].parse().unwrap() };
    let range = |k: &str| -> (f64, f64) {
        let v: Vec<f64> = f[k].split(' ').map(|x| x.parse().unwrap()).collect();
        (v[0], v[1])
    };
    let ((x0, x1), (y0, y1)) = (range("data-x"), range("data-y"));
    let (left, top, w, h) = (num("x"), num("y"), num("width"), num("height"));
    lines
        .iter()
        .map(|l| {
            let pts = l["points"]
                .split(' ')
                .filter(|p| !p.is_empty())
                .map(|p| {
                    let (px, py) = p.split_once(',').unwrap();
                    let (px, py): (f64, f64) = (px.parse().unwrap(), py.parse().unwrap());
                    (x0 + (px - left) / w * (x1 - x0), y0 + (top + h - py) / h * (y1 - y0))
                })
                .collect();
            (l["data-series"].clone(), pts)
        })
        .collect()
}

#[cfg(feature = "studies")]
#[test]
fn the_order_study_repeats_ranks_draws_and_tests_every_experiment() {
    use meshsmooth::stats::{mann_whitney_less, median};
    use std::collections::{BTreeSet, HashMap};
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("study");
    let o = out.to_str().unwrap();
    let (ok, text) = meshsmooth(&[
        "study",
        "order",
        "--quick",
        "--meshes",
        "sqi,sqiv",
        "--sizes",
        "100",
        "--baseline-sweeps",
        "8",
        "--every",
        "1",
        "--repeats",
        "3",
        "-o",
        o,
    ]);
    assert!(ok, "{text}");
    let rows = read_csv(&out.join("order-study.csv"));
    let runs = read_csv(&out.join("order-study-runs.csv"));
    let curves = read_csv(&out.join("order-study-curves.csv"));
    // main SQI and SQIV (static, every 1), SQI perturbed (static, every 1), and
    // every 1 for inner 2 x2, inaccurate x2, red-black x2: 12 groups of 20
    let groups: BTreeSet<(String, String)> = rows
        .iter()
        .map(|r| (r["case"].clone(), r["strategy"].clone()))
        .collect();
    assert_eq!(groups.len(), 12, "{groups:?}");
    assert_eq!(rows.len(), 240);
    let experiments: BTreeSet<&str> = rows.iter().map(|r| r["experiment"].as_str()).collect();
    assert_eq!(
        experiments,
        BTreeSet::from(["inaccurate", "inner", "main", "perturbed", "red-black"])
    );
    for (case, strategy) in &groups {
        let of: Vec<_> = rows
            .iter()
            .filter(|r| &r["case"] == case && &r["strategy"] == strategy)
            .collect();
        assert_eq!(of.len(), 20, "{case} {strategy}");
        let ranks: Vec<usize> = of.iter().map(|r| r["tt_rank"].parse().unwrap()).collect();
        assert!(
            ranks.contains(&1) && ranks.iter().all(|&k| (1..=20).contains(&k)),
            "{ranks:?}"
        );
    }
    // the reported TT is the median of the three repeats, inside their range
    let mut times: HashMap<(String, String, String), Vec<f64>> = HashMap::new();
    for r in &runs {
        times
            .entry((r["case"].clone(), r["strategy"].clone(), r["scheme"].clone()))
            .or_default()
            .push(r["tt"].parse().unwrap());
    }
    assert_eq!(times.len(), 240);
    let key = |r: &HashMap<String, String>| (r["case"].clone(), r["strategy"].clone(), r["scheme"].clone());
    for r in &rows {
        let t = &times[&key(r)];
        assert_eq!(t.len(), 3);
        let get = |k: &str| -> f64 { r[k].parse().unwrap() };
        assert!((get("tt") - median(t)).abs() < 2e-9, "{r:?} {t:?}");
        assert!(get("tt_min") <= get("tt") && get("tt") <= get("tt_max"));
    }
    // static GRVM is an order of its own: another path than N's
    let path = |scheme: &str| -> Vec<String> {
        curves
            .iter()
            .filter(|r| r["case"] == "SQIV 100" && r["strategy"] == "static" && r["scheme"] == scheme)
            .map(|r| r["objective"].clone())
            .collect()
    };
    assert!(path("N").len() > 2);
    assert_ne!(path("GRVM"), path("N"));
    // a figure per case for static and for every 1, one curve per scheme,
    // whose points are the curves CSV's
    let md = std::fs::read_to_string(out.join("order-study.md")).unwrap();
    let mut figures = 0;
    for (case, strategy) in &groups {
        let name = format!(
            "order-{}-{}.svg",
            case.to_lowercase().replace(' ', "-"),
            strategy.replace(' ', "-")
        );
        assert!(md.contains(&format!("]({name})")), "{name}");
        let svg = std::fs::read_to_string(out.join(&name)).unwrap();
        let drawn = svg_curves(&svg);
        let names: BTreeSet<&str> = drawn.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!((drawn.len(), names.len()), (20, 20), "{name}");
        let of_group: Vec<_> = curves
            .iter()
            .filter(|r| &r["case"] == case && &r["strategy"] == strategy)
            .map(|r| -> (f64, f64) { (r["seconds"].parse().unwrap(), r["objective"].parse().unwrap()) })
            .collect();
        let tmax = of_group.iter().map(|p| p.0).fold(0.0, f64::max);
        let (flo, fhi) = of_group
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.1), b.max(p.1)));
        for (scheme, pts) in &drawn {
            let want: Vec<(f64, f64)> = curves
                .iter()
                .filter(|r| &r["case"] == case && &r["strategy"] == strategy && &r["scheme"] == scheme)
                .map(|r| (r["seconds"].parse().unwrap(), r["objective"].parse().unwrap()))
                .collect();
            assert_eq!(pts.len(), want.len(), "{name} {scheme}");
            for (a, b) in pts.iter().zip(&want) {
                // points are printed to a thousandth of a pixel in a frame
                // hundreds of pixels across
                assert!((a.0 - b.0).abs() <= 1e-5 * tmax, "{name} {scheme}: {a:?} vs {b:?}");
                assert!(
                    (a.1 - b.1).abs() <= 1e-5 * (fhi - flo),
                    "{name} {scheme}: {a:?} vs {b:?}"
                );
            }
        }
        figures += 1;
    }
    assert_eq!(figures, 12);
    for section in [
        "(Table 3)",
        "(Table 4)",
        "(Table 5)",
        "(Table 6)",
        "(Table 7)",
        "does and does not reproduce",
    ] {
        assert!(md.contains(section), "{section}");
    }
    // the distance finding, recounted from the repeats with the same test
    let tt_to_target = |case: &str, scheme: &str| -> Vec<f64> {
        let r = rows
            .iter()
            .find(|r| r["case"] == case && r["strategy"] == "static" && r["scheme"] == scheme)
            .unwrap();
        let t = &times[&key(r)];
        if r["reached"] == "true" {
            t.clone()
        } else {
            vec![f64::INFINITY; 3]
        }
    };
    let (mut faster, mut of) = (0, 0);
    for case in ["SQI 100", "SQIV 100", "SQI 100 perturbed"] {
        for base in ["WQP", "GAVM", "GRVM", "LNG"] {
            for (d, b) in [
                (format!("D-{base}"), base.to_string()),
                (format!("-D-{base}"), format!("-{base}")),
            ] {
                of += 1;
                faster += (mann_whitney_less(&tt_to_target(case, &d), &tt_to_target(case, &b)) <= 0.05) as usize;
            }
        }
    }
    let line = common::finding_line(&md, "distance scheme");
    assert!(
        line.contains(&format!("| {faster} of {of} |")),
        "{line} (counted {faster} of {of})"
    );
    for claim in [
        "static strategy",
        "N is among",
        "inaccurate target",
        "perturbed initial mesh",
        "red-black",
        "factor of two",
        "one more inner iteration",
        "Table 7",
    ] {
        let line = common::finding_line(&md, claim);
        assert_ne!(line.split('|').nth(3).map(str::trim), Some("not measured"), "{line}");
    }
}

#[test]
fn the_cli_stops_at_the_target_objective_with_a_reordered_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("h.vtk");
    let (out, hist) = (dir.path().join("o.vtk"), dir.path().join("h.csv"));
    let (i, o, h) = (input.to_str().unwrap(), out.to_str().unwrap(), hist.to_str().unwrap());
    let (ok, text) = meshsmooth(&["generate", "horseshoe", "--kind", "sqiv", "--free", "150", "-o", i]);
    assert!(ok, "{text}");
    let run = |extra: &[&str]| {
        let mut args = vec![
            "smooth",
            i,
            "-o",
            o,
            "-q",
            "--method",
            "bcd",
            "--device",
            "cpu",
            "--history",
            h,
        ];
        args.extend_from_slice(extra);
        let (ok, text) = meshsmooth(&args);
        assert!(ok, "{text}");
        let csv = std::fs::read_to_string(&hist).unwrap();
        let f: Vec<f64> = csv
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(2).unwrap().parse().unwrap())
            .collect();
        std::fs::remove_file(&hist).unwrap();
        std::fs::remove_file(&out).unwrap();
        (f, text)
    };
    let (free, _) = run(&["--order", "d-gavm", "--max-iter", "40"]);
    let target = free[free.len() - 1] + 0.3 * (free[0] - free[free.len() - 1]);
    let t = format!("{target}");
    let (f, text) = run(&["--order", "d-gavm", "--reorder-every", "1", "--target-objective", &t]);
    assert!(text.contains("target objective reached"), "{text}");
    assert!(f[f.len() - 1] <= target && f[f.len() - 2] > target, "{f:?} vs {target}");
}

#[test]
fn red_black_is_the_checkerboard_on_a_structured_grid() {
    // 7 x 5 vertices, row-major: vertex j * 7 + i is red when i + j is even
    let m = generate::quad_grid(6, 4, [6.0, 4.0]);
    let p = Problem::with_options(&m, &with_order(Ordering::RedBlack, 0)).unwrap();
    let red = |v: u32| ((v % 7) + (v / 7)).is_multiple_of(2);
    let reds = (0..35).filter(|&v| red(v)).count();
    assert_eq!(reds, 18);
    assert!(p.order[..reds].iter().all(|&v| red(v)), "{:?}", p.order);
    assert!(p.order[reds..].iter().all(|&v| !red(v)), "{:?}", p.order);
    // each colour in input order
    assert!(p.order[..reds].windows(2).all(|w| w[0] < w[1]));
    assert!(p.order[reds..].windows(2).all(|w| w[0] < w[1]));
    // and it is a proper 2-colouring: no edge joins two vertices of one colour
    for e in 0..m.num_elements() {
        let v = m.element(e);
        for k in 0..4 {
            assert_ne!(red(v[k]), red(v[(k + 1) % 4]), "element {e}");
        }
    }
}

#[test]
fn dynamic_movement_schemes_sort_by_the_last_sweeps_moves() {
    use meshsmooth::mesh::sweep_order::largest_first;
    let m = perturbed_grid(9);
    let mut lists = Vec::new();
    for scheme in [Scheme::Gavm, Scheme::Grvm] {
        let order = SweepOrder { scheme, reverse: false };
        let p = Problem::with_options(&m, &with_order(Ordering::Sweep(order), 0)).unwrap();
        let x0 = p.gather(&m.points);
        let mut be = CpuBackend::new(&p, &x0, &Default::default()).unwrap();
        let mut bcd = Bcd::new(&mut be, &p, true, &bcd_params(Some(1), 1).bcd).unwrap();
        bcd.start(&mut be).unwrap().unwrap();
        bcd.step(&mut be, None).unwrap();
        let x1 = be.download().unwrap();
        // each vertex is visited once per sweep: its move at that visit is
        // where it ended minus where it began
        let moved: Vec<f64> = p
            .free_vertices
            .iter()
            .map(|&v| {
                let (a, b) = (x1[v as usize], x0[v as usize]);
                ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
            })
            .collect();
        let first = meshsmooth::solve::reorder::trial_moves(&p, &x0, &Default::default(), 1);
        let keys: Vec<f64> = match scheme {
            Scheme::Gavm => moved,
            _ => moved.iter().zip(&first).map(|(&d, &d0)| d / d0).collect(),
        };
        assert!(keys.iter().all(|k| k.is_finite() && *k > 0.0), "{keys:?}");
        let base: Vec<u32> = (0..keys.len() as u32).collect();
        assert_eq!(
            bcd.reorder.as_ref().unwrap().order,
            largest_first(&base, &keys),
            "{}",
            scheme.name()
        );
        lists.push(largest_first(&base, &keys));
    }
    // relative and absolute movement order this mesh differently, so the
    // check above tells them apart
    assert_ne!(lists[0], lists[1]);
}
