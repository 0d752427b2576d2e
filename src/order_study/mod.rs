//! The vertex-reordering study (Shontz and Knupp, sections 3 and 6) on the
//! generated 2D horseshoes. Each case (a mesh type, a size and an
//! experiment's variant) first runs a baseline, scheme N under the static
//! strategy, whose final F is the case's target; every scheme under every
//! strategy of the case then runs the sequential BCD sweep to that target,
//! `repeats` times, and the optimisation (COT), reordering (RT) and total
//! (TT) times are ranked per strategy by their medians, as in the paper's
//! ranking tables.
//!
//! The experiments (the paper's Table 2):
//! - 6.2, 6.4, 6.5: every mesh type and size, static and reordered every k
//!   sweeps for each k asked;
//! - 6.3: SQI (or the first mesh type asked) at the largest size, its free
//!   vertices moved at random as far as [`PERTURBATION`] of their mean edge
//!   length allows without inverting an element, static and every sweep;
//! - 6.6: every mesh type at the largest size, one more Newton step per
//!   visit, every sweep, to the target of the ordinary inner count;
//! - 6.7: every mesh type and size, a target from a baseline a fifth as long
//!   (the paper's one minute against five), every sweep;
//! - 6.8: the quadrilateral types at the largest size, the mesh (and its
//!   reference) renumbered red-black, every sweep.
//!
//! A repeat runs the same computation again, so sweeps and objectives repeat
//! exactly and only the times vary. The repeats go in rounds (every scheme
//! once, then again), so that a change of load on the machine falls on all
//! schemes alike. Times are wall-clock on whatever machine runs the study:
//! compare within one run.

mod findings;
mod plan;
mod ranking;
mod report;

pub use plan::{Experiment, PERTURBATION};
pub use ranking::{OverallRank, PAPER_TABLE6, PAPER_TABLE7};

use crate::error::Result;
use crate::mesh::sweep_order::SweepOrder;
use crate::metric::smetric::MetricKind;
use crate::problem::{Ordering, ProblemOptions};
use crate::solve::{self, BcdParams, Info, Method, Options, Params, StopReason};
use crate::stats;
use serde::Serialize;
use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::time::Duration;

/// How long the baseline (N, static) runs; its final F is a case's target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Baseline {
    /// Wall-clock time, as the paper (five minutes there).
    Seconds(Duration),
    /// A number of sweeps: the same target on any machine.
    Sweeps(usize),
}

impl Baseline {
    /// The inaccurate experiment's baseline: a fifth as long.
    fn fifth(self) -> Baseline {
        match self {
            Baseline::Seconds(d) => Baseline::Seconds(d / 5),
            Baseline::Sweeps(k) => Baseline::Sweeps((k / 5).max(1)),
        }
    }
}

/// What the study runs.
#[derive(Clone, Debug)]
pub struct OrderStudyOptions {
    /// Mesh types (the paper's Table 1).
    pub meshes: Vec<crate::generate::HorseshoeKind>,
    /// About this many free vertices, one mesh of each type per size.
    pub sizes: Vec<usize>,
    pub baseline: Baseline,
    /// Dynamic strategies: reorder every k sweeps, for each k here (the
    /// static strategy always runs).
    pub every: Vec<usize>,
    /// Newton steps per vertex visit (the inner-iteration experiment adds one).
    pub inner_iterations: usize,
    /// Runs of each scheme and strategy.
    pub repeats: usize,
    /// The experiments besides 6.2/6.4/6.5, which always run.
    pub experiments: Vec<Experiment>,
    /// Seed of the random schemes and of the perturbed mesh.
    pub seed: u64,
    /// A run that has not reached the target after this many times the
    /// baseline's sweeps (or time) stops there, and ranks last.
    pub cap_factor: f64,
}

impl OrderStudyOptions {
    /// The small study: all five mesh types at about 200 free vertices, a
    /// 25-sweep baseline, three repeats, every experiment.
    pub fn quick() -> OrderStudyOptions {
        OrderStudyOptions {
            meshes: crate::generate::HorseshoeKind::ALL.to_vec(),
            sizes: vec![200],
            baseline: Baseline::Sweeps(25),
            every: vec![1, 2, 5, 10],
            inner_iterations: 1,
            repeats: 3,
            experiments: Experiment::EXTRA.to_vec(),
            seed: 0,
            cap_factor: 10.0,
        }
    }

    /// The paper's sizes (20K, 40K and 80K free vertices) and a 10 s baseline.
    pub fn full() -> OrderStudyOptions {
        OrderStudyOptions {
            sizes: vec![20_000, 40_000, 80_000],
            baseline: Baseline::Seconds(Duration::from_secs(10)),
            ..OrderStudyOptions::quick()
        }
    }
}

/// One mesh and variant with its target: the runs of its strategies share them.
#[derive(Clone, Debug, Serialize)]
pub struct Case {
    /// "SQIV 200", "SQI 200 perturbed", ...
    pub name: String,
    /// The name for files: "sqiv-200", "sqi-200-perturbed".
    pub slug: String,
    pub experiment: Experiment,
    /// The paper's mesh name: "SQIV".
    pub mesh: String,
    /// Free vertices asked for.
    pub size: usize,
    /// Free vertices of the generated mesh (near the size asked).
    pub free_vertices: usize,
    pub inner_iterations: usize,
    pub baseline_seconds: f64,
    pub baseline_sweeps: usize,
    pub initial_objective: f64,
    pub target: f64,
    /// "static", "every 1", ...
    pub strategies: Vec<String>,
}

/// One scheme under one strategy of one case, over the repeats.
#[derive(Clone, Debug, Serialize)]
pub struct StudyRow {
    /// Index into [`OrderStudy::cases`].
    pub case: usize,
    /// The paper's name: "-D-GRVM".
    pub scheme: String,
    /// "static" or "every K".
    pub strategy: String,
    pub sweeps: usize,
    pub reached: bool,
    pub objective: f64,
    /// The paper's COT, RT and TT per repeat, seconds.
    pub cot: Vec<f64>,
    pub rt: Vec<f64>,
    pub tt: Vec<f64>,
    /// Ranks of the medians among the schemes of the same case and strategy
    /// (1 = least time).
    pub cot_rank: usize,
    pub rt_rank: usize,
    pub tt_rank: usize,
    pub sweeps_rank: usize,
    /// (TT seconds, F) after each sweep, the start included, of the repeat
    /// with the median TT: a curve of the paper's Figure 5.
    #[serde(skip)]
    pub curve: Vec<(f64, f64)>,
}

impl StudyRow {
    pub fn cot_median(&self) -> f64 {
        stats::median(&self.cot)
    }

    pub fn rt_median(&self) -> f64 {
        stats::median(&self.rt)
    }

    pub fn tt_median(&self) -> f64 {
        stats::median(&self.tt)
    }

    /// The TTs to compare: infinite where the target was missed, so that a
    /// missed target loses to any run that reached it.
    pub fn tt_to_target(&self) -> Vec<f64> {
        if self.reached {
            self.tt.clone()
        } else {
            vec![f64::INFINITY; self.tt.len()]
        }
    }
}

/// The study's results.
#[derive(Clone, Debug, Serialize)]
pub struct OrderStudy {
    pub repeats: usize,
    pub baseline: String,
    pub cases: Vec<Case>,
    pub rows: Vec<StudyRow>,
}

/// The problem the paper optimises: |T - I|^2 against the semi-annulus reference.
fn problem(reference: &crate::Mesh, ordering: Ordering, seed: u64) -> ProblemOptions<'_> {
    ProblemOptions {
        metric: MetricKind::TargetShapeSize,
        reference: Some(reference),
        ordering,
        order_seed: seed,
        ..Default::default()
    }
}

fn strategy_name(every: Option<usize>) -> String {
    every.map_or("static".into(), |k| format!("every {k}"))
}

/// Runs the study; `progress` sees each finished row.
pub fn order_study(opts: &OrderStudyOptions, progress: &mut dyn FnMut(&Case, &StudyRow)) -> Result<OrderStudy> {
    let repeats = opts.repeats.max(1);
    let mut meshes = HashMap::new();
    let mut baselines: HashMap<(plan::MeshKey, usize), (Info, usize)> = HashMap::new();
    let mut cases = Vec::new();
    let mut rows: Vec<StudyRow> = Vec::new();
    for spec in plan::cases(opts) {
        let key = spec.mesh_key();
        if let Entry::Vacant(e) = meshes.entry(key) {
            e.insert(plan::initial_mesh(&key, opts.seed)?);
        }
        let (mesh, reference) = &meshes[&key];
        let run = |ordering, every: Option<usize>, inner: usize, params: Params| {
            let mut m = mesh.clone();
            let params = Params {
                tol: 0.0,
                bcd: BcdParams {
                    reorder_every: every,
                    inner_iterations: inner,
                    ..Default::default()
                },
                ..params
            };
            solve::smooth_mesh(
                &mut m,
                &problem(reference, ordering, opts.seed),
                &Options::cpu(Method::Bcd, &params),
                &mut |_| true,
            )
        };
        let baseline = if spec.inaccurate {
            opts.baseline.fifth()
        } else {
            opts.baseline
        };
        // the inner-iteration experiment keeps the ordinary target, as the
        // paper's "increases the time-to-convergence" compares like with like
        let bkey = (key, spec.inaccurate as usize);
        if let Entry::Vacant(e) = baselines.entry(bkey) {
            let params = match baseline {
                Baseline::Seconds(d) => Params {
                    max_iter: usize::MAX,
                    time_limit: Some(d),
                    ..Default::default()
                },
                Baseline::Sweeps(k) => Params {
                    max_iter: k,
                    ..Default::default()
                },
            };
            let info = run(Ordering::INPUT, None, opts.inner_iterations, params)?;
            let free = plan::free_vertices(mesh);
            e.insert((info, free));
        }
        let (base, free) = &baselines[&bkey];
        let target = base.objective;
        let cap_sweeps = ((base.iterations.max(1) as f64) * opts.cap_factor).ceil() as usize;
        let cap_time = match baseline {
            Baseline::Seconds(_) => Some(Duration::from_secs_f64(base.seconds * opts.cap_factor)),
            Baseline::Sweeps(_) => None,
        };
        let ci = cases.len();
        cases.push(Case {
            name: spec.name(),
            slug: spec.slug(),
            experiment: spec.experiment,
            mesh: spec.kind.name().to_uppercase(),
            size: spec.free,
            free_vertices: *free,
            inner_iterations: spec.inner_iterations,
            baseline_seconds: base.seconds,
            baseline_sweeps: base.iterations,
            initial_objective: base.history.first().map_or(f64::NAN, |r| r.objective),
            target,
            strategies: spec.strategies.iter().map(|&k| strategy_name(k)).collect(),
        });
        for &every in &spec.strategies {
            let first = rows.len();
            let orders: Vec<SweepOrder> = SweepOrder::all().collect();
            let mut runs: Vec<Vec<Info>> = vec![Vec::with_capacity(repeats); orders.len()];
            for _ in 0..repeats {
                for (i, &order) in orders.iter().enumerate() {
                    let params = Params {
                        max_iter: cap_sweeps,
                        time_limit: cap_time,
                        target_objective: Some(target),
                        ..Default::default()
                    };
                    runs[i].push(run(Ordering::Sweep(order), every, spec.inner_iterations, params)?);
                }
            }
            for (order, infos) in orders.iter().zip(runs) {
                let row = summarise(ci, order.paper_name(), strategy_name(every), &infos);
                progress(&cases[ci], &row);
                rows.push(row);
            }
            ranking::rank(&mut rows[first..]);
        }
    }
    Ok(OrderStudy {
        repeats,
        baseline: match opts.baseline {
            Baseline::Seconds(d) => format!("{:.3} s", d.as_secs_f64()),
            Baseline::Sweeps(k) => format!("{k} sweeps"),
        },
        cases,
        rows,
    })
}

/// One row from the repeats of one scheme and strategy.
fn summarise(case: usize, scheme: String, strategy: String, infos: &[Info]) -> StudyRow {
    let tt: Vec<f64> = infos.iter().map(|i| i.seconds).collect();
    // the repeat whose TT is the median (the lower middle for an even count)
    let mut by_tt: Vec<usize> = (0..infos.len()).collect();
    by_tt.sort_by(|&a, &b| tt[a].total_cmp(&tt[b]));
    let mid = &infos[by_tt[(by_tt.len() - 1) / 2]];
    let last = &infos[0];
    StudyRow {
        case,
        scheme,
        strategy,
        sweeps: last.iterations,
        reached: last.stop == StopReason::TargetReached,
        objective: last.objective,
        cot: infos.iter().map(|i| i.optimise_seconds).collect(),
        rt: infos.iter().map(|i| i.reorder_seconds).collect(),
        tt,
        cot_rank: 0,
        rt_rank: 0,
        tt_rank: 0,
        sweeps_rank: 0,
        curve: mid.history.records.iter().map(|r| (r.seconds, r.objective)).collect(),
    }
}

impl OrderStudy {
    /// The rows of one case and strategy.
    pub fn group(&self, case: usize, strategy: &str) -> impl Iterator<Item = &StudyRow> {
        self.rows
            .iter()
            .filter(move |r| r.case == case && r.strategy == strategy)
    }

    /// One row, if the study ran it.
    pub fn row(&self, case: usize, strategy: &str, scheme: &str) -> Option<&StudyRow> {
        self.group(case, strategy).find(|r| r.scheme == scheme)
    }

    /// The cases of one experiment.
    pub fn cases_of(&self, e: Experiment) -> impl Iterator<Item = (usize, &Case)> {
        self.cases.iter().enumerate().filter(move |(_, c)| c.experiment == e)
    }

    /// The main experiment's case of the same mesh type and size as case `c`.
    pub fn main_case_like(&self, c: &Case) -> Option<usize> {
        self.cases_of(Experiment::Main)
            .find(|(_, m)| m.mesh == c.mesh && m.size == c.size)
            .map(|(i, _)| i)
    }

    /// TT's standard deviation over its mean across the schemes' median TTs
    /// of one case and strategy: the paper's "variation".
    pub fn variation(&self, case: usize, strategy: &str) -> f64 {
        let tts: Vec<f64> = self
            .group(case, strategy)
            .map(|r| if r.reached { r.tt_median() } else { f64::INFINITY })
            .collect();
        stats::relative_spread(&tts)
    }

    pub fn findings(&self) -> Vec<crate::finding::Finding> {
        findings::findings(self)
    }

    /// Table 7: every scheme's TT ranks over all cases and strategies.
    pub fn overall_ranking(&self) -> Vec<OverallRank> {
        ranking::overall(self, |r| r.tt_rank, &PAPER_TABLE7)
    }

    /// Table 6: the same for the reordering time RT.
    pub fn reordering_time_ranking(&self) -> Vec<OverallRank> {
        ranking::overall(self, |r| r.rt_rank, &PAPER_TABLE6)
    }

    /// One table per case and strategy, the paper's other tables, the
    /// overall ranking and the findings.
    pub fn to_markdown(&self) -> String {
        report::markdown(self)
    }

    /// One line per case, strategy and scheme: medians, spreads and ranks.
    pub fn to_csv(&self) -> String {
        report::csv(self)
    }

    /// One line per run: the times of every repeat.
    pub fn runs_csv(&self) -> String {
        report::runs_csv(self)
    }

    /// The curves the figures draw: (TT, F) after each sweep.
    pub fn curves_csv(&self) -> String {
        report::curves_csv(self)
    }

    /// (file name, SVG): F against TT per scheme (the paper's Figure 5), one
    /// figure per case for the static strategy and for reordering every sweep.
    pub fn figures(&self) -> Vec<(String, String)> {
        report::figures(self)
    }
}
