//! The paper's conclusions (its section 7 and the experiments' selected
//! results) tested on one run of the study. A claim that one configuration
//! is faster than another counts a case only when the one-sided
//! Mann–Whitney test over the repeats gives p <= [`ALPHA`]; a claim about
//! the variation over the schemes compares the two numbers as they are.

use super::{Experiment, OrderStudy, StudyRow};
use crate::finding::Finding;
use crate::stats::mann_whitney_less;

/// Significance level of the rank test. With three repeats against three
/// the smallest one-sided p is 1/20 = 0.05: a case counts only when every
/// repeat of one configuration is faster than every repeat of the other.
pub const ALPHA: f64 = 0.05;

const NOISE: &str = "one number per case and no test: on short runs the schemes' TTs differ mostly by timing noise";

const FORWARD: [&str; 10] = [
    "N", "R", "WQP", "GAVM", "GRVM", "LNG", "D-WQP", "D-GAVM", "D-GRVM", "D-LNG",
];

fn reverse(s: &str) -> String {
    format!("-{s}")
}

/// Pairwise comparisons by the rank test: how many came out faster, slower
/// or undecided.
#[derive(Default)]
struct Tally {
    faster: usize,
    slower: usize,
    undecided: usize,
}

impl Tally {
    /// Is `a` faster than `b`?
    fn add(&mut self, a: &StudyRow, b: &StudyRow) {
        let (x, y) = (a.tt_to_target(), b.tt_to_target());
        if mann_whitney_less(&x, &y) <= ALPHA {
            self.faster += 1;
        } else if mann_whitney_less(&y, &x) <= ALPHA {
            self.slower += 1;
        } else {
            self.undecided += 1;
        }
    }

    fn finding(self, claim: &'static str) -> Finding {
        Finding {
            claim,
            holds: self.faster,
            of: self.faster + self.slower + self.undecided,
            against: self.slower,
            numbers: format!(
                "{} faster, {} slower, {} undecided (Mann-Whitney, p <= {ALPHA})",
                self.faster, self.slower, self.undecided
            ),
            cause: "the schemes' times differ by less than their spread over the repeats, or the other way".into(),
        }
    }
}

/// Comparisons of two plain numbers, listed.
#[derive(Default)]
struct Count {
    holds: usize,
    of: usize,
    items: Vec<String>,
}

impl Count {
    fn add(&mut self, holds: bool, item: String) {
        self.holds += holds as usize;
        self.of += 1;
        self.items.push(item);
    }

    fn finding(self, claim: &'static str, cause: &'static str) -> Finding {
        Finding {
            claim,
            holds: self.holds,
            of: self.of,
            against: 0,
            numbers: self.items.join("; "),
            cause: cause.into(),
        }
    }
}

fn percent(v: f64) -> String {
    if v.is_finite() {
        format!("{:.1}%", 100.0 * v)
    } else {
        "a missed target".into()
    }
}

pub fn findings(st: &OrderStudy) -> Vec<Finding> {
    let static_cases: Vec<usize> = (0..st.cases.len())
        .filter(|&c| st.cases[c].strategies.iter().any(|s| s == "static"))
        .collect();

    // first: the static strategy beats the dynamic ones
    let mut dynamic = Tally::default();
    for &c in &static_cases {
        for strategy in st.cases[c].strategies.iter().filter(|s| *s != "static") {
            for r in st.group(c, strategy) {
                if let Some(s) = st.row(c, "static", &r.scheme) {
                    dynamic.add(s, r);
                }
            }
        }
    }

    // fifth: N is among the more efficient orders; reversing often helps
    let mut n_good = Count::default();
    let mut reversed = Tally::default();
    let mut distance = Tally::default();
    for &c in &static_cases {
        if let Some(n) = st.row(c, "static", "N") {
            let ahead = st
                .group(c, "static")
                .filter(|r| r.scheme != "N" && mann_whitney_less(&r.tt_to_target(), &n.tt_to_target()) <= ALPHA)
                .count();
            n_good.add(ahead <= 4, format!("{}: {ahead} faster than N", st.cases[c].name));
        }
        for base in FORWARD {
            if let (Some(f), Some(r)) = (st.row(c, "static", base), st.row(c, "static", &reverse(base))) {
                reversed.add(r, f);
            }
        }
        // sixth: distance schemes beat their bases
        for base in ["WQP", "GAVM", "GRVM", "LNG"] {
            for (d, b) in [
                (format!("D-{base}"), base.to_string()),
                (format!("-D-{base}"), reverse(base)),
            ] {
                if let (Some(d), Some(b)) = (st.row(c, "static", &d), st.row(c, "static", &b)) {
                    distance.add(d, b);
                }
            }
        }
    }
    let mut n_good = n_good.finding(
        "N is among the more efficient schemes: at most four of the other 19 significantly faster (static)",
        "more schemes lead N by more than the spread of the repeats",
    );
    n_good.against = n_good.of - n_good.holds;

    // fourth: within a factor of two
    let mut factor = Count::default();
    let mut worst = (0.0f64, String::new());
    for (c, case) in st.cases.iter().enumerate() {
        for strategy in &case.strategies {
            let tts: Vec<f64> = st
                .group(c, strategy)
                .map(|r| if r.reached { r.tt_median() } else { f64::INFINITY })
                .collect();
            let (lo, hi) = tts
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(a, b), &t| (a.min(t), b.max(t)));
            let ratio = hi / lo;
            if !(ratio <= worst.0) {
                worst = (ratio, format!("{}, {strategy}", case.name));
            }
            factor.holds += (ratio < 2.0) as usize;
            factor.of += 1;
        }
    }
    if factor.of > 0 {
        factor.items.push(format!("largest ratio {:.2} ({})", worst.0, worst.1));
    }

    // second and third: where reordering matters more (larger variation)
    let variation_against_main = |e: Experiment, strategies: &dyn Fn(&str) -> bool| {
        let mut count = Count::default();
        for (c, case) in st.cases_of(e) {
            let Some(m) = st.main_case_like(case) else { continue };
            for s in case.strategies.iter().filter(|s| strategies(s)) {
                if !st.cases[m].strategies.contains(s) {
                    continue;
                }
                let (v, v0) = (st.variation(c, s), st.variation(m, s));
                count.add(v > v0, format!("{}, {s}: {} vs {}", case.name, percent(v), percent(v0)));
            }
        }
        count
    };
    let inaccurate = variation_against_main(Experiment::Inaccurate, &|_| true);
    let perturbed = variation_against_main(Experiment::Perturbed, &|_| true);
    let red_black = variation_against_main(Experiment::RedBlack, &|_| true);

    let mut biased = Count::default();
    let pairs = [("SQII", "SQI"), ("SQIV", "SQI"), ("UTIV", "UTI")];
    for (c, case) in st.cases_of(Experiment::Main) {
        for (hard, easy) in pairs {
            if case.mesh != hard {
                continue;
            }
            let Some((e, _)) = st
                .cases_of(Experiment::Main)
                .find(|(_, o)| o.mesh == easy && o.size == case.size)
            else {
                continue;
            };
            let (v, v0) = (st.variation(c, "static"), st.variation(e, "static"));
            biased.add(
                v > v0,
                format!(
                    "{} vs {}: {} vs {}",
                    case.name,
                    st.cases[e].name,
                    percent(v),
                    percent(v0)
                ),
            );
        }
    }

    // 6.6: more inner iterations take longer, and do not widen the variation
    let mut inner = Tally::default();
    let mut inner_variation = Count::default();
    for (c, case) in st.cases_of(Experiment::InnerIterations) {
        let Some(m) = st.main_case_like(case) else { continue };
        for r in st.group(c, "every 1") {
            if let Some(one) = st.row(m, "every 1", &r.scheme) {
                inner.add(one, r);
            }
        }
        if st.cases[m].strategies.iter().any(|s| s == "every 1") {
            let (v, v0) = (st.variation(c, "every 1"), st.variation(m, "every 1"));
            inner_variation.add(v <= v0, format!("{}: {} vs {}", case.name, percent(v), percent(v0)));
        }
    }

    // Table 7: N and -N at the top overall
    let overall = st.overall_ranking();
    let mut top = Count::default();
    for scheme in ["N", "-N"] {
        if let Some(r) = overall.iter().find(|r| r.scheme == scheme) {
            top.add(r.rank <= 5, format!("{scheme} ranks {}", r.rank));
        }
    }
    if top.of > 0 {
        top.items.push(format!(
            "Spearman rho with the paper's order {:.2}",
            super::ranking::spearman_with_paper(&overall)
        ));
    }

    vec![
        dynamic.finding("The static strategy takes less total time than reordering every k sweeps (scheme by scheme)"),
        inaccurate.finding(
            "The schemes' TT varies more (sd/mean) with an inaccurate target than with the ordinary one (every 1)",
            NOISE,
        ),
        perturbed.finding(
            "The schemes' TT varies more from a perturbed initial mesh than from the generated one",
            NOISE,
        ),
        biased.finding(
            "The schemes' TT varies more on the anisotropic and biased meshes (SQII, SQIV over SQI; UTIV over UTI; static)",
            NOISE,
        ),
        red_black.finding(
            "The schemes' TT varies more from a red-black initial order than from the generator's (every 1)",
            NOISE,
        ),
        factor.finding(
            "The schemes' median TTs lie within a factor of two (per case and strategy)",
            "a scheme that missed the target, or runs so short that a pause of the machine doubles one",
        ),
        n_good,
        reversed.finding("Reversing the list often takes less total time: -X against X (static)"),
        distance.finding("A distance scheme takes less total time than its base scheme (static)"),
        inner.finding("One Newton step per visit reaches the target sooner than one more (every 1, scheme by scheme)"),
        inner_variation.finding(
            "The schemes' TT varies no more with one more inner iteration (every 1)",
            NOISE,
        ),
        top.finding(
            "N and -N rank among the five best schemes overall (Table 7)",
            "the mean ranks average few cases, each ranked on noisy times",
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::sweep_order::SweepOrder;
    use crate::order_study::Case;

    /// One main case: every scheme static in 1.0-1.2 s, every sweep in
    /// `dynamic` (three repeats each).
    fn study(dynamic: [f64; 3]) -> OrderStudy {
        let case = Case {
            name: "SQI 100".into(),
            slug: "sqi-100".into(),
            experiment: Experiment::Main,
            mesh: "SQI".into(),
            size: 100,
            free_vertices: 100,
            inner_iterations: 1,
            baseline_seconds: 1.0,
            baseline_sweeps: 10,
            initial_objective: 2.0,
            target: 1.0,
            strategies: vec!["static".into(), "every 1".into()],
        };
        let mut rows = Vec::new();
        for (strategy, tt) in [("static", [1.0, 1.1, 1.2]), ("every 1", dynamic)] {
            for o in SweepOrder::all() {
                rows.push(StudyRow {
                    case: 0,
                    scheme: o.paper_name(),
                    strategy: strategy.into(),
                    sweeps: 10,
                    reached: true,
                    objective: 1.0,
                    cot: tt.to_vec(),
                    rt: vec![0.0; 3],
                    tt: tt.to_vec(),
                    cot_rank: 1,
                    rt_rank: 1,
                    tt_rank: 1,
                    sweeps_rank: 1,
                    curve: Vec::new(),
                });
            }
        }
        OrderStudy {
            repeats: 3,
            baseline: "10 sweeps".into(),
            cases: vec![case],
            rows,
        }
    }

    fn find<'a>(f: &'a [Finding], claim: &str) -> &'a Finding {
        f.iter().find(|f| f.claim.contains(claim)).unwrap()
    }

    #[test]
    fn a_faster_strategy_counts_only_where_every_repeat_is_ahead() {
        let f = findings(&study([2.0, 2.1, 2.2]));
        let d = find(&f, "static strategy");
        assert_eq!((d.holds, d.against, d.of, d.verdict()), (20, 0, 20, "reproduced"));
        // 2.2 within the static repeats' range: no longer significant
        let f = findings(&study([1.15, 2.1, 2.2]));
        let d = find(&f, "static strategy");
        assert_eq!((d.holds, d.against, d.of, d.verdict()), (0, 0, 20, "not reproduced"));
        // equal times: neither way
        let r = find(&f, "Reversing");
        assert_eq!((r.holds, r.against, r.of), (0, 0, 10));
        // dynamic medians 2.1 against static 1.1: each group within a factor of two
        let x = find(&f, "factor of two");
        assert_eq!((x.holds, x.of), (2, 2));
        // no experiment beside the main one: its findings are not measured
        assert_eq!(find(&f, "inaccurate target").verdict(), "not measured");
        assert_eq!(find(&f, "red-black").of, 0);
    }
}
