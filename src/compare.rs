//! Runs several methods from one start and compares their histories the way
//! the Newton paper's Table 2 and Figures 2-3 do: iterations, time to
//! |grad F| < tol (T100), to 50% and 90% of the objective decrease (T50, T90),
//! setup time, memory, and where one method's curve passes another's.

use crate::Mesh;
use crate::error::Result;
use crate::problem::{Problem, ProblemOptions};
use crate::solve::{self, History, Info, Method, Options};
use serde::Serialize;

#[derive(Clone, Debug, Serialize)]
pub struct RunSummary {
    pub method: String,
    pub iterations: usize,
    pub stop: String,
    pub objective: f64,
    pub grad_norm: f64,
    pub t50: Option<f64>,
    pub t90: Option<f64>,
    /// Time at which |grad F| first fell below the tolerance.
    pub t100: Option<f64>,
    pub seconds: f64,
    /// The reordering paper's COT and RT (see `solve::Info`); `seconds` is its TT.
    pub optimise_seconds: f64,
    pub reorder_seconds: f64,
    /// Times the sweep list was ordered (a paper scheme with `bcd` on the CPU).
    pub reorderings: usize,
    pub setup_seconds: f64,
    pub memory_bytes: usize,
    /// The paper's estimate in 4-byte integers (BCD 23|V| + 12|E|, Newton 64|V| + 37|E|), as bytes.
    pub paper_memory_bytes: Option<usize>,
}

/// Where `second`'s objective curve passes below `first`'s for good.
#[derive(Clone, Debug, Serialize)]
pub struct Crossover {
    pub first: String,
    pub second: String,
    pub seconds: f64,
    /// How far `second` had come by then: 100 (F0 - F(t)) / (F0 - F_best).
    pub optimality_percent: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    pub vertices: usize,
    pub elements: usize,
    pub initial_objective: f64,
    /// The lowest final objective among the methods: the reference for T50/T90.
    pub best_objective: f64,
    pub runs: Vec<RunSummary>,
    pub crossovers: Vec<Crossover>,
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
        .map(|i| RunSummary {
            method: i.method.to_string(),
            iterations: i.iterations,
            stop: i.stop.to_string(),
            objective: i.objective,
            grad_norm: i.grad_norm,
            t50: i.history.time_to_fraction(0.5, best),
            t90: i.history.time_to_fraction(0.9, best),
            t100: i.history.records.iter().find(|r| r.grad_norm < tol).map(|r| r.seconds),
            seconds: i.seconds,
            optimise_seconds: i.optimise_seconds,
            reorder_seconds: i.reorder_seconds,
            reorderings: i.reorderings,
            setup_seconds: i.setup_seconds,
            memory_bytes: i.memory_bytes,
            paper_memory_bytes: paper_memory(i.method, vertices, elements),
        })
        .collect();
    let mut crossovers = Vec::new();
    for (ia, a) in infos.iter().enumerate() {
        for b in &infos[ia + 1..] {
            for (first, second) in [(a, b), (b, a)] {
                if let Some(t) = crossover_time(&first.history, &second.history)
                    && t > 0.0
                {
                    let f = value_at(&second.history, t);
                    let pct = if f0 > best {
                        100.0 * (f0 - f) / (f0 - best)
                    } else {
                        100.0
                    };
                    crossovers.push(Crossover {
                        first: first.method.to_string(),
                        second: second.method.to_string(),
                        seconds: t,
                        optimality_percent: pct,
                    });
                }
            }
        }
    }
    Comparison {
        vertices,
        elements,
        initial_objective: f0,
        best_objective: best,
        runs,
        crossovers,
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
    use crate::solve::Record;

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
}
