//! Runs several methods from one start and compares their histories the way
//! the Newton paper's Table 2 and Figures 2-3 do: iterations, time to
//! |grad F| < tol (T100), to 50% and 90% of the objective decrease (T50, T90),
//! setup time, memory, and where one method's curve passes another's.
//!
//! The headline times count each method's setup (problem and solver: Newton's
//! Hessian pattern, the colouring), as the paper does — its Conclusion 2 rests
//! on Newton's setup cost; the solve-only times are kept beside them.

use crate::Mesh;
use crate::error::Result;
use crate::problem::{Problem, ProblemOptions};
use crate::solve::{self, History, Info, Method, Options, Record};
use serde::Serialize;

/// One method's run in a comparison, as `meshsmooth compare` reports it.
#[derive(Clone, Debug, Serialize)]
pub struct RunSummary {
    /// The method's name.
    pub method: String,
    /// Iterations run.
    pub iterations: usize,
    /// Why it stopped.
    pub stop: String,
    /// The final objective F.
    pub objective: f64,
    /// The final |grad F|.
    pub grad_norm: f64,
    /// Seconds of the solve alone (setup left out) to 50% and 90% of the
    /// decrease to the best objective.
    pub t50: Option<f64>,
    /// Seconds of the solve alone to 90% of the decrease to the best objective.
    pub t90: Option<f64>,
    /// Time at which |grad F| first fell below the tolerance.
    pub t100: Option<f64>,
    /// The same with this method's setup counted: the paper's measure, and
    /// the headline of `meshsmooth compare`.
    pub t50_with_setup: Option<f64>,
    /// Seconds to 90% of the decrease with setup counted.
    pub t90_with_setup: Option<f64>,
    /// Seconds until |grad F| fell below the tolerance, setup counted.
    pub t100_with_setup: Option<f64>,
    /// Wall-clock seconds of the whole run.
    pub seconds: f64,
    /// The reordering paper's COT and RT (see `solve::Info`); `seconds` is its TT.
    pub optimise_seconds: f64,
    /// Seconds spent ordering the sweep list (RT).
    pub reorder_seconds: f64,
    /// Times the sweep list was ordered (a paper scheme with `bcd` on the CPU).
    pub reorderings: usize,
    /// Seconds of the method's setup (Hessian pattern, colouring, ...).
    pub setup_seconds: f64,
    /// Bytes the backend held.
    pub memory_bytes: usize,
    /// The paper's estimate in 4-byte integers (BCD 23|V| + 12|E|, Newton 64|V| + 37|E|), as bytes.
    pub paper_memory_bytes: Option<usize>,
}

/// Where `second`'s objective curve passes below `first`'s for good.
#[derive(Clone, Debug, Serialize)]
pub struct Crossover {
    /// The method that was ahead.
    pub first: String,
    /// The method that overtakes it.
    pub second: String,
    /// Seconds at which `second` passes below `first` for good.
    pub seconds: f64,
    /// How far `second` had come by then: 100 (F0 - F(t)) / (F0 - F_best).
    pub optimality_percent: f64,
}

/// Several methods run from the same start on one mesh.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    /// Vertices of the mesh.
    pub vertices: usize,
    /// Elements of the mesh.
    pub elements: usize,
    /// The objective F at the start.
    pub initial_objective: f64,
    /// The lowest final objective among the methods: the reference for T50/T90.
    pub best_objective: f64,
    /// One summary per method, in the order run.
    pub runs: Vec<RunSummary>,
    /// Crossovers with each method's setup counted (its curve stays at F0
    /// until its setup is done).
    pub crossovers: Vec<Crossover>,
    /// Crossovers of the solve-only curves.
    pub crossovers_without_setup: Vec<Crossover>,
}

/// Objective at time `t` of a piecewise-constant history.
fn value_at(h: &History, t: f64) -> f64 {
    let i = h.records.partition_point(|r| r.seconds <= t);
    h.records[i.saturating_sub(1)].objective
}

/// The earliest time after which `b`'s objective is never above `a`'s;
/// `None` if `b` ends above `a`.
pub fn crossover_time(a: &History, b: &History) -> Option<f64> {
    let mut times: Vec<f64> = a.records.iter().chain(&b.records).map(|r| r.seconds).collect();
    times.sort_by(f64::total_cmp);
    times.dedup();
    let mut last_behind = None;
    for &t in &times {
        if value_at(b, t) > value_at(a, t) {
            last_behind = Some(t);
        }
    }
    match last_behind {
        None => Some(0.0),
        Some(t) => times.iter().copied().find(|&u| u > t),
    }
}

/// `h` as a curve that starts at 0 with its first objective and runs
/// `setup` seconds late: the history of a run whose setup is counted.
pub fn with_setup(h: &History, setup: f64) -> History {
    let mut out = History::default();
    if let Some(first) = h.records.first() {
        out.push(Record { seconds: 0.0, ..*first });
    }
    for r in &h.records {
        out.push(Record {
            seconds: r.seconds + setup,
            ..*r
        });
    }
    out
}

/// Where each method's curve passes another's for good, with how far the
/// passing one had come by then.
fn crossovers(named: &[(String, History)], f0: f64, best: f64) -> Vec<Crossover> {
    let mut out = Vec::new();
    for (ia, a) in named.iter().enumerate() {
        for b in &named[ia + 1..] {
            for (first, second) in [(a, b), (b, a)] {
                if let Some(t) = crossover_time(&first.1, &second.1)
                    && t > 0.0
                {
                    let f = value_at(&second.1, t);
                    let pct = if f0 > best {
                        100.0 * (f0 - f) / (f0 - best)
                    } else {
                        100.0
                    };
                    out.push(Crossover {
                        first: first.0.clone(),
                        second: second.0.clone(),
                        seconds: t,
                        optimality_percent: pct,
                    });
                }
            }
        }
    }
    out
}

fn paper_memory(method: Method, vertices: usize, elements: usize) -> Option<usize> {
    match method {
        Method::Bcd | Method::BcdColored => Some(4 * (23 * vertices + 12 * elements)),
        Method::Newton => Some(4 * (64 * vertices + 37 * elements)),
        Method::Laplace | Method::Nlcg => None,
    }
}

/// Summarises finished runs that started from the same mesh.
pub fn summarise(vertices: usize, elements: usize, infos: &[Info], tol: f64) -> Comparison {
    let f0 = infos[0].history.records[0].objective;
    let best = infos.iter().map(|i| i.objective).fold(f64::INFINITY, f64::min);
    let runs = infos
        .iter()
        .map(|i| {
            let t100 = i.history.records.iter().find(|r| r.grad_norm < tol).map(|r| r.seconds);
            let t50 = i.history.time_to_fraction(0.5, best);
            let t90 = i.history.time_to_fraction(0.9, best);
            let counted = |t: Option<f64>| t.map(|t| t + i.setup_seconds);
            RunSummary {
                method: i.method.to_string(),
                iterations: i.iterations,
                stop: i.stop.to_string(),
                objective: i.objective,
                grad_norm: i.grad_norm,
                t50,
                t90,
                t100,
                t50_with_setup: counted(t50),
                t90_with_setup: counted(t90),
                t100_with_setup: counted(t100),
                seconds: i.seconds,
                optimise_seconds: i.optimise_seconds,
                reorder_seconds: i.reorder_seconds,
                reorderings: i.reorderings,
                setup_seconds: i.setup_seconds,
                memory_bytes: i.memory_bytes,
                paper_memory_bytes: paper_memory(i.method, vertices, elements),
            }
        })
        .collect();
    let solve_only: Vec<(String, History)> = infos
        .iter()
        .map(|i| (i.method.to_string(), i.history.clone()))
        .collect();
    let counted: Vec<(String, History)> = infos
        .iter()
        .map(|i| (i.method.to_string(), with_setup(&i.history, i.setup_seconds)))
        .collect();
    Comparison {
        vertices,
        elements,
        initial_objective: f0,
        best_objective: best,
        runs,
        crossovers: crossovers(&counted, f0, best),
        crossovers_without_setup: crossovers(&solve_only, f0, best),
    }
}

/// Runs every method of `methods` from the same start (a copy of `mesh`),
/// each with `opts` (device, settings) and its own method, and summarises.
pub fn compare(
    mesh: &Mesh,
    problem: &ProblemOptions,
    methods: &[Method],
    opts: &Options,
) -> Result<(Comparison, Vec<Info>)> {
    let p = Problem::with_options(mesh, problem)?;
    let x0 = p.gather(&mesh.points);
    let mut infos = Vec::new();
    for &method in methods {
        let mut x = x0.clone();
        let run = Options { method, ..opts.clone() };
        infos.push(solve::solve(&p, &mut x, &run, &mut |_| true)?);
    }
    Ok((
        summarise(mesh.num_points(), mesh.num_elements(), &infos, opts.params.tol),
        infos,
    ))
}

/// Merged histories as CSV: `method,iteration,seconds,objective,grad_norm`.
pub fn histories_csv(infos: &[Info]) -> String {
    let mut s = String::from("method,iteration,seconds,objective,grad_norm\n");
    for i in infos {
        for r in &i.history.records {
            s.push_str(&format!(
                "{},{},{:.6},{:.17e},{:.6e}\n",
                i.method, r.iteration, r.seconds, r.objective, r.grad_norm
            ));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn history(points: &[(f64, f64)]) -> History {
        let mut h = History::default();
        for (i, &(t, f)) in points.iter().enumerate() {
            h.push(Record {
                iteration: i,
                seconds: t,
                objective: f,
                grad_norm: 1.0,
            });
        }
        h
    }

    #[test]
    fn crossover_is_where_the_second_curve_stays_below() {
        let fast_start = history(&[(0.0, 10.0), (1.0, 5.0), (2.0, 4.0), (3.0, 3.5), (4.0, 3.2)]);
        let slow_start = history(&[(0.0, 10.0), (1.5, 8.0), (2.5, 3.0), (3.5, 2.0)]);
        assert_eq!(crossover_time(&fast_start, &slow_start), Some(2.5));
        assert_eq!(crossover_time(&slow_start, &fast_start), None);
        assert_eq!(crossover_time(&fast_start, &fast_start), Some(0.0));
    }

    #[test]
    fn setup_delays_a_curve_and_can_move_the_crossover() {
        let cheap = history(&[(0.0, 10.0), (1.0, 6.0), (2.0, 5.0), (3.0, 4.5), (4.0, 4.2)]);
        let dear = history(&[(0.0, 10.0), (0.5, 5.0), (1.0, 3.0)]);
        // solve-only, the dear method is never behind; 3 s of setup keep it at
        // F0 until 3 s, and at 3.5 s (5 against 4.5) it is still behind
        assert_eq!(crossover_time(&cheap, &dear), Some(0.0));
        let late = with_setup(&dear, 3.0);
        assert_eq!(late.records[0].seconds, 0.0);
        assert_eq!(value_at(&late, 3.4), 10.0);
        assert_eq!(crossover_time(&cheap, &late), Some(4.0));
        assert_eq!(crossover_time(&cheap, &with_setup(&dear, 0.0)), Some(0.0));
    }
}
