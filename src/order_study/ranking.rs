//! Ranks: the schemes of one case and strategy by their median times (the
//! paper's ranking tables), and every scheme's TT ranks over all of them
//! (its Table 7).

use super::{OrderStudy, StudyRow};
use serde::Serialize;

/// The paper's Table 7, "a rough scheme ranking over all runs": (scheme, rank).
pub const PAPER_TABLE7: [(&str, usize); 20] = [
    ("N", 1),
    ("-N", 2),
    ("D-GAVM", 3),
    ("D-LNG", 4),
    ("D-GRVM", 5),
    ("D-WQP", 6),
    ("-D-GAVM", 7),
    ("-D-LNG", 8),
    ("-GRVM", 9),
    ("-D-GRVM", 10),
    ("GRVM", 11),
    ("-D-WQP", 12),
    ("-R", 13),
    ("R", 14),
    ("-GAVM", 15),
    ("-LNG", 16),
    ("LNG", 17),
    ("GAVM", 18),
    ("WQP", 19),
    ("-WQP", 20),
];

/// The paper's Table 6, "a rough reordering time ranking over all runs".
pub const PAPER_TABLE6: [(&str, usize); 20] = [
    ("N", 1),
    ("-N", 2),
    ("R", 3),
    ("-R", 4),
    ("GRVM", 5),
    ("D-GAVM", 6),
    ("-GRVM", 7),
    ("D-LNG", 8),
    ("D-GRVM", 9),
    ("WQP", 10),
    ("-WQP", 11),
    ("D-WQP", 12),
    ("-D-GRVM", 13),
    ("-D-GAVM", 14),
    ("-D-LNG", 15),
    ("-D-WQP", 16),
    ("-GAVM", 17),
    ("LNG", 18),
    ("GAVM", 19),
    ("-LNG", 20),
];

/// Ranks 1.. by increasing median; a run that missed the target ranks after
/// every run that reached it. Ties share the better rank.
pub fn rank(rows: &mut [StudyRow]) {
    type Get = fn(&StudyRow) -> f64;
    type Set = fn(&mut StudyRow, usize);
    let fields: [(Get, Set); 4] = [
        (|r| r.cot_median(), |r, k| r.cot_rank = k),
        (|r| r.rt_median(), |r, k| r.rt_rank = k),
        (|r| r.tt_median(), |r, k| r.tt_rank = k),
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

/// One scheme's line of the overall ranking.
#[derive(Clone, Debug, Serialize)]
pub struct OverallRank {
    pub scheme: String,
    /// 1 = best mean rank.
    pub rank: usize,
    pub mean_rank: f64,
    /// The most frequent TT rank (the smallest of equals), and the next.
    pub mode: usize,
    pub second_mode: Option<usize>,
    pub best: usize,
    pub worst: usize,
    /// Cases x strategies counted.
    pub count: usize,
    /// The scheme's place in the paper's Table 7.
    pub paper_rank: usize,
}

/// The histogram of each scheme's ranks (`rank_of`: TT for Table 7, RT for
/// Table 6) over every case and strategy, summarised as the paper's table
/// `paper`; ordered by mean rank (the paper looked at each histogram's mode
/// and spread by eye, which a mean replaces).
pub fn overall(st: &OrderStudy, rank_of: fn(&StudyRow) -> usize, paper: &[(&str, usize)]) -> Vec<OverallRank> {
    let mut out: Vec<OverallRank> = paper
        .iter()
        .filter_map(|&(scheme, paper_rank)| {
            let ranks: Vec<usize> = st.rows.iter().filter(|r| r.scheme == scheme).map(rank_of).collect();
            if ranks.is_empty() {
                return None;
            }
            let mut hist = [0usize; 21];
            for &k in &ranks {
                hist[k.min(20)] += 1;
            }
            let mut by_count: Vec<usize> = (1..=20).filter(|&k| hist[k] > 0).collect();
            by_count.sort_by_key(|&k| (std::cmp::Reverse(hist[k]), k));
            Some(OverallRank {
                scheme: scheme.to_string(),
                rank: 0,
                mean_rank: ranks.iter().sum::<usize>() as f64 / ranks.len() as f64,
                mode: by_count[0],
                second_mode: by_count.get(1).copied(),
                best: *ranks.iter().min().unwrap(),
                worst: *ranks.iter().max().unwrap(),
                count: ranks.len(),
                paper_rank,
            })
        })
        .collect();
    out.sort_by(|a, b| {
        a.mean_rank
            .total_cmp(&b.mean_rank)
            .then(a.best.cmp(&b.best))
            .then(a.paper_rank.cmp(&b.paper_rank))
    });
    for (i, r) in out.iter_mut().enumerate() {
        r.rank = i + 1;
    }
    out
}

/// Spearman's rank correlation of our overall ranks with the paper's (1: the
/// same order, -1: reversed); NaN with fewer than two schemes.
pub fn spearman_with_paper(ranks: &[OverallRank]) -> f64 {
    let n = ranks.len() as f64;
    if ranks.len() < 2 {
        return f64::NAN;
    }
    // the paper's ranks of the schemes present, renumbered 1..n
    let mut paper: Vec<(usize, usize)> = ranks.iter().enumerate().map(|(i, r)| (r.paper_rank, i)).collect();
    paper.sort_unstable();
    let mut d2 = 0.0;
    for (p, &(_, i)) in paper.iter().enumerate() {
        let d = (ranks[i].rank as f64) - (p + 1) as f64;
        d2 += d * d;
    }
    1.0 - 6.0 * d2 / (n * (n * n - 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(tt: f64, reached: bool) -> StudyRow {
        StudyRow {
            case: 0,
            scheme: String::new(),
            strategy: String::new(),
            sweeps: 1,
            reached,
            objective: 0.0,
            cot: vec![tt],
            rt: vec![0.0],
            tt: vec![tt, tt + 10.0, tt - 0.5],
            cot_rank: 0,
            rt_rank: 0,
            tt_rank: 0,
            sweeps_rank: 0,
            curve: Vec::new(),
        }
    }

    #[test]
    fn ranks_go_by_medians_put_missed_targets_last_and_share_ties() {
        let mut rows = vec![row(3.0, true), row(1.0, false), row(2.0, true), row(2.0, true)];
        // an outlier repeat does not move a median
        rows[0].tt[1] = 1e9;
        rank(&mut rows);
        let tt: Vec<usize> = rows.iter().map(|r| r.tt_rank).collect();
        assert_eq!(tt, vec![3, 4, 1, 1]);
        assert!(rows.iter().all(|r| r.rt_rank == if r.reached { 1 } else { 4 }));
    }

    #[test]
    fn the_overall_ranking_counts_each_schemes_ranks() {
        let mut st = OrderStudy {
            repeats: 1,
            baseline: String::new(),
            cases: Vec::new(),
            rows: Vec::new(),
        };
        // N ranks 1, 1, 3; -N ranks 2, 2, 1
        for (n, minus) in [(1, 2), (1, 2), (3, 1)] {
            let mut a = row(1.0, true);
            a.scheme = "N".into();
            a.tt_rank = n;
            let mut b = row(1.0, true);
            b.scheme = "-N".into();
            b.tt_rank = minus;
            st.rows.extend([a, b]);
        }
        let o = overall(&st, |r| r.tt_rank, &PAPER_TABLE7);
        assert_eq!(o.len(), 2);
        assert_eq!((o[0].scheme.as_str(), o[0].mode, o[0].second_mode), ("-N", 2, Some(1)));
        assert_eq!((o[1].scheme.as_str(), o[1].best, o[1].worst), ("N", 1, 3));
        assert!((o[0].mean_rank - 5.0 / 3.0).abs() < 1e-12);
        // the paper has N before -N: reversed, rho = -1
        assert_eq!(spearman_with_paper(&o), -1.0);
    }
}
