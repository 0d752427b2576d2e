//! The vertex-reordering study (Shontz and Knupp, sections 3 and 6) on a
//! generated 2D horseshoe: a baseline run of scheme N for a fixed time sets
//! the target objective, then every scheme under every strategy runs the
//! sequential BCD sweep to that target, and the optimisation (COT),
//! reordering (RT) and total (TT) times are ranked per strategy, as in the
//! paper's ranking tables.
//!
//! Times are wall-clock on whatever machine runs the study: compare ranks
//! within one run, not numbers between runs.

use crate::error::Result;
use crate::finding::Finding;
use crate::generate::{HorseshoeKind, horseshoe};
use crate::mesh::sweep_order::SweepOrder;
use crate::metric::smetric::MetricKind;
use crate::problem::{Ordering, ProblemOptions};
use crate::solve::{self, BcdParams, Method, Options, Params, StopReason};
use serde::Serialize;
use std::time::Duration;

/// What the study runs.
#[derive(Clone, Debug)]
pub struct OrderStudyOptions {
    pub kind: HorseshoeKind,
    /// About this many free vertices.
    pub free: usize,
    /// How long the baseline (N, static) runs; its final F is the target.
    pub baseline: Duration,
    /// Dynamic strategies: reorder every k sweeps, for each k here (the
    /// static strategy always runs).
    pub every: Vec<usize>,
    /// Newton steps per vertex visit.
    pub inner_iterations: usize,
    /// Seed of the random schemes.
    pub seed: u64,
    /// A run that has not reached the target after this many times the
    /// baseline's time stops there (and is ranked last by its stop).
    pub time_cap_factor: f64,
}

impl OrderStudyOptions {
    /// The small study: a 1000-vertex mesh, a quarter-second baseline.
    pub fn quick() -> OrderStudyOptions {
        OrderStudyOptions {
            kind: HorseshoeKind::SqIV,
            free: 1000,
            baseline: Duration::from_millis(250),
            every: vec![1, 2, 5, 10],
            inner_iterations: 1,
            seed: 0,
            time_cap_factor: 10.0,
        }
    }
}

/// One scheme under one strategy.
#[derive(Clone, Debug, Serialize)]
pub struct StudyRow {
    /// The paper's name: "-D-GRVM".
    pub scheme: String,
    /// "static" or "every K".
    pub strategy: String,
    pub sweeps: usize,
    pub reached: bool,
    pub objective: f64,
    /// The paper's COT, RT and TT, seconds.
    pub cot: f64,
    pub rt: f64,
    pub tt: f64,
    /// Ranks among the schemes of the same strategy (1 = least time).
    pub cot_rank: usize,
    pub rt_rank: usize,
    pub tt_rank: usize,
    pub sweeps_rank: usize,
}

/// The study's results.
#[derive(Clone, Debug, Serialize)]
pub struct OrderStudy {
    pub mesh: String,
    pub free_vertices: usize,
    pub baseline_seconds: f64,
    pub baseline_sweeps: usize,
    pub initial_objective: f64,
    pub target: f64,
    pub rows: Vec<StudyRow>,
}

/// Runs the study; `progress` sees each finished row.
pub fn order_study(opts: &OrderStudyOptions, progress: &mut dyn FnMut(&StudyRow)) -> Result<OrderStudy> {
    let (mesh, reference) = horseshoe(opts.kind, opts.free);
    // the paper's metric: |T - I|^2 against the semi-annulus reference
    let problem = |ordering| ProblemOptions {
        metric: MetricKind::TargetShapeSize,
        reference: Some(&reference),
        ordering,
        order_seed: opts.seed,
        ..Default::default()
    };
    let bcd = |every: Option<usize>| BcdParams {
        reorder_every: every,
        inner_iterations: opts.inner_iterations,
        ..Default::default()
    };
    let run = |ordering, params: Params| {
        let mut m = mesh.clone();
        solve::smooth_mesh(
            &mut m,
            &problem(ordering),
            &Options::cpu(Method::Bcd, &params),
            &mut |_| true,
        )
    };
    let baseline = run(
        Ordering::INPUT,
        Params {
            tol: 0.0,
            max_iter: usize::MAX,
            time_limit: Some(opts.baseline),
            bcd: bcd(None),
            ..Default::default()
        },
    )?;
    let target = baseline.objective;
    let free = mesh.num_points()
        - crate::mesh::topology::fixed_vertices(&mesh)
            .iter()
            .filter(|&&f| f)
            .count();
    let mut strategies: Vec<Option<usize>> = vec![None];
    strategies.extend(opts.every.iter().map(|&k| Some(k.max(1))));
    let mut rows = Vec::new();
    for &every in &strategies {
        let first = rows.len();
        for order in SweepOrder::all() {
            let info = run(
                Ordering::Sweep(order),
                Params {
                    tol: 0.0,
                    max_iter: usize::MAX,
                    time_limit: Some(opts.baseline.mul_f64(opts.time_cap_factor)),
                    target_objective: Some(target),
                    bcd: bcd(every),
                    ..Default::default()
                },
            )?;
            let row = StudyRow {
                scheme: order.paper_name(),
                strategy: every.map_or("static".into(), |k| format!("every {k}")),
                sweeps: info.iterations,
                reached: info.stop == StopReason::TargetReached,
                objective: info.objective,
                cot: info.optimise_seconds,
                rt: info.reorder_seconds,
                tt: info.seconds,
                cot_rank: 0,
                rt_rank: 0,
                tt_rank: 0,
                sweeps_rank: 0,
            };
            progress(&row);
            rows.push(row);
        }
        rank(&mut rows[first..]);
    }
    Ok(OrderStudy {
        mesh: format!("horseshoe {:?}", opts.kind),
        free_vertices: free,
        baseline_seconds: baseline.seconds,
        baseline_sweeps: baseline.iterations,
        initial_objective: baseline.history.first().map_or(f64::NAN, |r| r.objective),
        target,
        rows,
    })
}

/// Ranks 1.. by increasing value; a run that missed the target ranks after
/// every run that reached it. Ties share the better rank.
fn rank(rows: &mut [StudyRow]) {
    type Get = fn(&StudyRow) -> f64;
    type Set = fn(&mut StudyRow, usize);
    let fields: [(Get, Set); 4] = [
        (|r| r.cot, |r, k| r.cot_rank = k),
        (|r| r.rt, |r, k| r.rt_rank = k),
        (|r| r.tt, |r, k| r.tt_rank = k),
        (|r| r.sweeps as f64, |r, k| r.sweeps_rank = k),
    ];
    for (get, set) in fields {
        let key = |r: &StudyRow| (!r.reached, get(r));
        let mut idx: Vec<usize> = (0..rows.len()).collect();
        idx.sort_by(|&a, &b| {
            let (ka, kb) = (key(&rows[a]), key(&rows[b]));
            ka.0.cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
        });
        let mut prev: Option<((bool, f64), usize)> = None;
        for (pos, &i) in idx.iter().enumerate() {
            let k = key(&rows[i]);
            let r = match prev {
                Some((pk, pr)) if pk == k => pr,
                _ => pos + 1,
            };
            prev = Some((k, r));
            set(&mut rows[i], r);
        }
    }
}

impl OrderStudy {
    pub fn to_csv(&self) -> String {
        let mut s =
            String::from("scheme,strategy,sweeps,reached,objective,cot,rt,tt,cot_rank,rt_rank,tt_rank,sweeps_rank\n");
        for r in &self.rows {
            s.push_str(&format!(
                "{},{},{},{},{:.12e},{:.6},{:.6},{:.6},{},{},{},{}\n",
                r.scheme,
                r.strategy,
                r.sweeps,
                r.reached,
                r.objective,
                r.cot,
                r.rt,
                r.tt,
                r.cot_rank,
                r.rt_rank,
                r.tt_rank,
                r.sweeps_rank
            ));
        }
        s
    }

    /// One table per strategy, rows by TT rank, as the paper's ranking tables.
    /// The reordering paper's qualitative findings that one study can test
    /// (TT, the paper's total time, throughout).
    pub fn findings(&self) -> Vec<Finding> {
        let tt = |scheme: &str, strategy: &str| {
            self.rows
                .iter()
                .find(|r| r.scheme == scheme && r.strategy == strategy)
                .map(|r| if r.reached { r.tt } else { f64::INFINITY })
        };
        let static_rows: Vec<&StudyRow> = self.rows.iter().filter(|r| r.strategy == "static").collect();
        let mut dynamic = (0, 0);
        for r in self.rows.iter().filter(|r| r.strategy != "static") {
            if let Some(st) = tt(&r.scheme, "static") {
                dynamic.1 += 1;
                dynamic.0 += (st < if r.reached { r.tt } else { f64::INFINITY }) as usize;
            }
        }
        let n_best = static_rows
            .iter()
            .filter(|r| r.scheme == "N" || r.scheme == "-N")
            .any(|r| r.tt_rank <= 5);
        let mut distance = (0, 0);
        for base in ["WQP", "GAVM", "GRVM", "LNG", "-WQP", "-GAVM", "-GRVM", "-LNG"] {
            let d = match base.strip_prefix('-') {
                Some(b) => format!("-D-{b}"),
                None => format!("D-{base}"),
            };
            if let (Some(b), Some(dd)) = (tt(base, "static"), tt(&d, "static")) {
                distance.1 += 1;
                distance.0 += (dd < b) as usize;
            }
        }
        vec![
            Finding {
                claim: "The static strategy takes less total time than reordering every k sweeps (scheme by scheme)",
                holds: dynamic.0,
                of: dynamic.1,
                ..Default::default()
            },
            Finding {
                claim: "N or -N is among the five best schemes under the static strategy",
                holds: n_best as usize,
                of: 1,
                ..Default::default()
            },
            Finding {
                claim: "A distance scheme takes less total time than its base scheme (static)",
                holds: distance.0,
                of: distance.1,
                ..Default::default()
            },
        ]
    }

    pub fn to_markdown(&self) -> String {
        let mut s = format!(
            "# Vertex-reordering study\n\n{} with {} free vertices, metric |T - I|^2 against the \
             semi-annulus reference, sequential BCD. Baseline N (static) for {:.3} s ({} sweeps): \
             F {:.8} -> target {:.8}.\n\nTimes are wall-clock seconds of this one run; compare \
             ranks, not numbers across machines or runs.\n",
            self.mesh,
            self.free_vertices,
            self.baseline_seconds,
            self.baseline_sweeps,
            self.initial_objective,
            self.target
        );
        let mut strategies: Vec<&str> = Vec::new();
        for r in &self.rows {
            if !strategies.contains(&r.strategy.as_str()) {
                strategies.push(&r.strategy);
            }
        }
        for st in strategies {
            s.push_str(&format!(
                "\n## {st}\n\n| Scheme | Sweeps | COT | COT rank | RT | RT rank | TT | TT rank |\n|---|---:|---:|---:|---:|---:|---:|---:|\n"
            ));
            let mut rows: Vec<&StudyRow> = self.rows.iter().filter(|r| r.strategy == st).collect();
            rows.sort_by_key(|r| (r.tt_rank, r.cot_rank));
            for r in rows {
                let mark = if r.reached { "" } else { " (target not reached)" };
                s.push_str(&format!(
                    "| {}{mark} | {} | {:.3} | {} | {:.4} | {} | {:.3} | {} |\n",
                    r.scheme, r.sweeps, r.cot, r.cot_rank, r.rt, r.rt_rank, r.tt, r.tt_rank
                ));
            }
        }
        s.push_str(&crate::finding::markdown(
            "The reordering paper's qualitative findings, tested on this run (a finding that \
             does not hold here is reported as such).",
            &self.findings(),
        ));
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(tt: f64, reached: bool) -> StudyRow {
        StudyRow {
            scheme: String::new(),
            strategy: String::new(),
            sweeps: 1,
            reached,
            objective: 0.0,
            cot: tt,
            rt: 0.0,
            tt,
            cot_rank: 0,
            rt_rank: 0,
            tt_rank: 0,
            sweeps_rank: 0,
        }
    }

    #[test]
    fn ranks_put_missed_targets_last_and_share_ties() {
        let mut rows = vec![row(3.0, true), row(1.0, false), row(2.0, true), row(2.0, true)];
        rank(&mut rows);
        let tt: Vec<usize> = rows.iter().map(|r| r.tt_rank).collect();
        assert_eq!(tt, vec![3, 4, 1, 1]);
        assert!(rows.iter().all(|r| r.rt_rank == if r.reached { 1 } else { 4 }));
    }
}
