//! Summaries and a rank test for repeated timings: medians and quartiles to
//! report, and the one-sided Mann–Whitney U test the studies use before they
//! call one configuration faster than another. Wall-clock times of repeated
//! runs are far from normal (a run slowed by a neighbouring process is an
//! outlier, not a shift), so a test on ranks suits them better than a t-test.

/// The `q`-quantile (0..=1) of `v` by linear interpolation between order
/// statistics (the common "type 7" rule); NaN for an empty slice. Infinite
/// values (runs that missed their target) sort last.
pub fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let h = q.clamp(0.0, 1.0) * (s.len() - 1) as f64;
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    if lo == hi || s[lo] == s[hi] {
        s[lo]
    } else {
        s[lo] + (h - lo as f64) * (s[hi] - s[lo])
    }
}

pub fn median(v: &[f64]) -> f64 {
    quantile(v, 0.5)
}

/// Standard deviation over mean (population form): the "variation relative to
/// the average" the reordering paper quotes per mesh; NaN below two values,
/// infinite when any value is.
pub fn relative_spread(v: &[f64]) -> f64 {
    if v.len() < 2 {
        return f64::NAN;
    }
    if v.iter().any(|x| x.is_infinite()) {
        return f64::INFINITY;
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n;
    var.sqrt() / mean
}

/// Midranks (1-based; tied values share the mean of their ranks) of `v`.
fn midranks(v: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..v.len()).collect();
    idx.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
    let mut r = vec![0.0; v.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && v[idx[j + 1]] == v[idx[i]] {
            j += 1;
        }
        let mid = (i + j) as f64 / 2.0 + 1.0;
        for &k in &idx[i..=j] {
            r[k] = mid;
        }
        i = j + 1;
    }
    r
}

/// Above this many splits of the pooled sample the p-value comes from the
/// normal approximation rather than from counting every split.
const EXACT_SPLITS: f64 = 200_000.0;

/// Mann–Whitney U of `a` against `b`: the pairs (x in a, y in b) with x > y,
/// ties counting one half. 0 when every value of `a` lies below every value
/// of `b`.
pub fn mann_whitney_u(a: &[f64], b: &[f64]) -> f64 {
    let mut u = 0.0;
    for x in a {
        for y in b {
            u += if x > y {
                1.0
            } else if x == y {
                0.5
            } else {
                0.0
            };
        }
    }
    u
}

/// One-sided p-value of the Mann–Whitney test that `a` tends to be smaller
/// than `b`: the chance, were both samples drawn from one distribution, of a
/// U at most the observed. Exact (every split of the pooled values, ties
/// included, counted) for small samples, the normal approximation with tie
/// correction and continuity correction beyond. 1 when either sample is empty.
pub fn mann_whitney_less(a: &[f64], b: &[f64]) -> f64 {
    let (n1, n2) = (a.len(), b.len());
    if n1 == 0 || n2 == 0 {
        return 1.0;
    }
    let u = mann_whitney_u(a, b);
    let pooled: Vec<f64> = a.iter().chain(b).copied().collect();
    let ranks = midranks(&pooled);
    let n = n1 + n2;
    let splits = (0..n1).fold(1.0, |c, i| c * (n - i) as f64 / (i + 1) as f64);
    if splits <= EXACT_SPLITS {
        // U = (rank sum of a) - n1 (n1 + 1) / 2, so count rank sums
        let target = u + (n1 * (n1 + 1)) as f64 / 2.0;
        let (mut at_most, mut total) = (0u64, 0u64);
        let mut pick: Vec<usize> = (0..n1).collect();
        loop {
            let sum: f64 = pick.iter().map(|&i| ranks[i]).sum();
            total += 1;
            at_most += (sum <= target + 1e-9) as u64;
            // next n1-subset of 0..n in lexicographic order
            let mut k = n1;
            while k > 0 && pick[k - 1] == n - n1 + k - 1 {
                k -= 1;
            }
            if k == 0 {
                break;
            }
            pick[k - 1] += 1;
            for j in k..n1 {
                pick[j] = pick[j - 1] + 1;
            }
        }
        return at_most as f64 / total as f64;
    }
    let (n1f, n2f, nf) = (n1 as f64, n2 as f64, n as f64);
    let mut ties = 0.0;
    let mut sorted = pooled.clone();
    sorted.sort_by(f64::total_cmp);
    let mut i = 0;
    while i < sorted.len() {
        let j = sorted[i..].iter().take_while(|&&x| x == sorted[i]).count();
        ties += (j * j * j - j) as f64;
        i += j;
    }
    let var = n1f * n2f / 12.0 * ((nf + 1.0) - ties / (nf * (nf - 1.0)));
    if !(var > 0.0) {
        return 1.0;
    }
    let z = (u - n1f * n2f / 2.0 + 0.5) / var.sqrt();
    normal_cdf(z)
}

/// Standard normal CDF via erfc (Abramowitz–Stegun 7.1.26 is too coarse in
/// the tail; this is the complementary error function of Numerical Recipes,
/// relative error below 1.2e-7).
fn normal_cdf(z: f64) -> f64 {
    let x = -z / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.5 * x.abs());
    let y = t
        * (-x * x - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    let erfc = if x >= 0.0 { y } else { 2.0 - y };
    0.5 * erfc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_interpolate_between_order_statistics() {
        let v = [4.0, 1.0, 3.0, 2.0];
        assert_eq!(median(&v), 2.5);
        assert_eq!(quantile(&v, 0.25), 1.75);
        assert_eq!(quantile(&v, 1.0), 4.0);
        assert_eq!(median(&[1.0, f64::INFINITY, 2.0]), 2.0);
        assert!(median(&[]).is_nan());
        // population sd of 1, 2, 3 is sqrt(2/3); mean 2
        assert!((relative_spread(&[1.0, 2.0, 3.0]) - (2.0f64 / 3.0).sqrt() / 2.0).abs() < 1e-15);
    }

    #[test]
    fn mann_whitney_matches_hand_counts() {
        // 3 against 3: 20 equally likely splits, U counts 0..=9 occurring
        // 1, 1, 2, 3, 3, 3, 3, 2, 1, 1 times
        let p = mann_whitney_less(&[1.0, 2.0, 3.0], &[4.0, 5.0, 6.0]);
        assert!((p - 1.0 / 20.0).abs() < 1e-12, "{p}");
        // U = 3 (3 > 2; 5 > 2, 4): P(U <= 3) = (1 + 1 + 2 + 3) / 20
        assert_eq!(mann_whitney_u(&[1.0, 3.0, 5.0], &[2.0, 4.0, 6.0]), 3.0);
        let p = mann_whitney_less(&[1.0, 3.0, 5.0], &[2.0, 4.0, 6.0]);
        assert!((p - 7.0 / 20.0).abs() < 1e-12, "{p}");
        // the other way round everything lies above: P(U <= 9) = 1
        assert_eq!(mann_whitney_less(&[4.0, 5.0, 6.0], &[1.0, 2.0, 3.0]), 1.0);
        // ties: a = [1, 2], b = [2, 3]; midranks 1, 2.5, 2.5, 4; a's rank sums
        // over the 6 splits: 3.5, 3.5, 5, 5, 6.5, 6.5; observed 3.5 -> 2 of 6
        let p = mann_whitney_less(&[1.0, 2.0], &[2.0, 3.0]);
        assert!((p - 2.0 / 6.0).abs() < 1e-12, "{p}");
        // infinite times (missed targets) rank last
        let p = mann_whitney_less(&[1.0, 2.0, 3.0], &[f64::INFINITY; 3]);
        assert!((p - 0.05).abs() < 1e-12, "{p}");
    }

    #[test]
    fn the_normal_approximation_agrees_with_the_exact_count_where_both_apply() {
        // 12 against 12: 2.7M splits, beyond the exact limit. Interleaved
        // samples, a slightly lower on the whole.
        let a: Vec<f64> = (0..12).map(|i| (2 * i) as f64).collect();
        let b: Vec<f64> = (0..12).map(|i| (2 * i + 3) as f64).collect();
        let p = mann_whitney_less(&a, &b);
        // U = 12*12/2 - 12*1.5 ... computed by hand: a_i > b_j iff 2i > 2j+3,
        // i.e. j <= i - 2: sum over i of max(0, i - 1) = 0+0+1+...+10 = 55
        assert_eq!(mann_whitney_u(&a, &b), 55.0);
        // z = (55 - 72 + 0.5) / sqrt(144 * 25 / 12) = -16.5 / 17.32 = -0.9526
        assert!((p - 0.1704).abs() < 2e-3, "{p}");
        assert!((normal_cdf(0.0) - 0.5).abs() < 1e-7);
        assert!((normal_cdf(-1.959_964) - 0.025).abs() < 1e-6);
    }
}
