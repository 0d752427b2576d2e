//! The vertex-reordering schemes of Shontz and Knupp ("The effect of vertex
//! reordering on 2D local mesh optimization efficiency", section 4): N, R,
//! WQP, GAVM, GRVM, LNG, their distance variants D-WQP, D-GAVM, D-GRVM,
//! D-LNG, and the reverse of each (20 schemes).
//!
//! This module holds only the sort rules, over per-vertex keys that the
//! caller computes (patch quality, movement, gradient norm: see
//! `solve::reorder`), so that each rule can be checked by hand.
//!
//! Tie rule: the paper sorts with QuickSort and says nothing of ties (an
//! unstable sort leaves their order to the implementation). Here every sort
//! is stable over the base list (the free vertices in the input order), so
//! equal keys keep the input order and a run repeats exactly. A reverse
//! scheme is the whole forward list reversed, ties included, as the paper's
//! "-WQP orders the vertex patches from best quality first to worst quality
//! last" reads.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// One of the paper's ten forward schemes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Scheme {
    /// Null order: the input list as it is.
    N,
    /// Random order (seeded).
    R,
    /// Worst quality patch first: the patch objective, largest first.
    Wqp,
    /// Greatest absolute vertex movement first.
    Gavm,
    /// Greatest relative vertex movement first (movement over the first movement).
    Grvm,
    /// Largest norm of the local gradient first.
    Lng,
    /// Nearest first to the vertex of worst patch quality.
    DWqp,
    /// Nearest first to the vertex of greatest absolute movement.
    DGavm,
    /// Nearest first to the vertex of greatest relative movement.
    DGrvm,
    /// Nearest first to the vertex of largest gradient norm.
    DLng,
}

/// What a scheme sorts by: the per-vertex quantity the caller must supply.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Key {
    /// No key (N, R).
    None,
    /// Patch objective (larger is worse).
    PatchQuality,
    /// Distance moved at the last visit.
    AbsoluteMove,
    /// Distance moved at the last visit over the distance moved at the first.
    RelativeMove,
    /// 2-norm of the gradient of the objective with respect to the vertex.
    GradientNorm,
}

impl Scheme {
    /// Every scheme.
    pub const ALL: [Scheme; 10] = [
        Scheme::N,
        Scheme::R,
        Scheme::Wqp,
        Scheme::Gavm,
        Scheme::Grvm,
        Scheme::Lng,
        Scheme::DWqp,
        Scheme::DGavm,
        Scheme::DGrvm,
        Scheme::DLng,
    ];

    /// The paper's abbreviation, lower case.
    pub fn name(self) -> &'static str {
        match self {
            Scheme::N => "n",
            Scheme::R => "r",
            Scheme::Wqp => "wqp",
            Scheme::Gavm => "gavm",
            Scheme::Grvm => "grvm",
            Scheme::Lng => "lng",
            Scheme::DWqp => "d-wqp",
            Scheme::DGavm => "d-gavm",
            Scheme::DGrvm => "d-grvm",
            Scheme::DLng => "d-lng",
        }
    }

    /// The per-vertex quantity the scheme sorts by.
    pub fn key(self) -> Key {
        match self {
            Scheme::N | Scheme::R => Key::None,
            Scheme::Wqp | Scheme::DWqp => Key::PatchQuality,
            Scheme::Gavm | Scheme::DGavm => Key::AbsoluteMove,
            Scheme::Grvm | Scheme::DGrvm => Key::RelativeMove,
            Scheme::Lng | Scheme::DLng => Key::GradientNorm,
        }
    }

    /// A distance scheme: sorted by distance from the vertex its base scheme puts first.
    pub fn is_distance(self) -> bool {
        matches!(self, Scheme::DWqp | Scheme::DGavm | Scheme::DGrvm | Scheme::DLng)
    }
}

/// A scheme and its direction: one of the paper's 20 orderings.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SweepOrder {
    /// The scheme.
    pub scheme: Scheme,
    /// The paper's "-" schemes: the forward list reversed.
    pub reverse: bool,
}

impl SweepOrder {
    /// The input order, forward (the paper's N).
    pub const N: SweepOrder = SweepOrder {
        scheme: Scheme::N,
        reverse: false,
    };

    /// All 20, forward then reverse for each scheme.
    pub fn all() -> impl Iterator<Item = SweepOrder> {
        Scheme::ALL
            .into_iter()
            .flat_map(|scheme| [false, true].map(|reverse| SweepOrder { scheme, reverse }))
    }

    /// The paper's spelling: "WQP", "-D-GRVM".
    pub fn paper_name(self) -> String {
        let name = self.scheme.name().to_uppercase();
        if self.reverse { format!("-{name}") } else { name }
    }

    /// The command-line spelling: "wqp", "reverse-d-grvm".
    pub fn name(self) -> String {
        let name = self.scheme.name();
        if self.reverse {
            format!("reverse-{name}")
        } else {
            name.to_string()
        }
    }

    /// Parses a paper name, any case: "wqp", "D-GRVM", "-lng", "reverse-n"
    /// ("input" is N).
    pub fn parse(s: &str) -> Option<SweepOrder> {
        let lower = s.trim().to_ascii_lowercase();
        let (reverse, name) = match lower.strip_prefix("reverse-").or_else(|| lower.strip_prefix('-')) {
            Some(rest) => (true, rest),
            None => (false, lower.as_str()),
        };
        let scheme = if name == "input" {
            Scheme::N
        } else {
            *Scheme::ALL.iter().find(|s| s.name() == name)?
        };
        Some(SweepOrder { scheme, reverse })
    }

    /// The order (entries of `base`) this scheme gives. `base` is the input
    /// list; `keys[i]` and `points[i]` belong to `base[i]`'s vertex, indexed
    /// by the entry itself (`keys[base[j] as usize]`); `draw` numbers the
    /// random orders of one run (R draws a fresh permutation each time).
    pub fn apply(self, base: &[u32], keys: &[f64], points: &[[f64; 3]], seed: u64, draw: u64) -> Vec<u32> {
        let mut order = match self.scheme {
            Scheme::N => base.to_vec(),
            Scheme::R => random(base, seed, draw),
            s if s.is_distance() => nearest_first(base, &largest_first(base, keys), points),
            _ => largest_first(base, keys),
        };
        if self.reverse {
            order.reverse();
        }
        order
    }
}

/// `base` sorted by decreasing key; equal keys keep their place in `base`.
/// NaN keys count as largest, so that a vertex whose key could not be
/// evaluated is visited (and so looked at) first rather than never noticed.
pub fn largest_first(base: &[u32], keys: &[f64]) -> Vec<u32> {
    let mut order = base.to_vec();
    let key = |v: u32| {
        let k = keys[v as usize];
        if k.is_nan() { f64::INFINITY } else { k }
    };
    order.sort_by(|&a, &b| key(b).total_cmp(&key(a)));
    order
}

/// `sorted` (whose first entry is the reference vertex) reordered by
/// increasing distance from that vertex; equal distances keep the order of
/// `base` (the tie rule), not of `sorted`.
pub fn nearest_first(base: &[u32], sorted: &[u32], points: &[[f64; 3]]) -> Vec<u32> {
    let Some(&first) = sorted.first() else {
        return Vec::new();
    };
    let c = points[first as usize];
    let d2 = |v: u32| {
        let p = points[v as usize];
        (0..3).map(|k| (p[k] - c[k]).powi(2)).sum::<f64>()
    };
    let mut order = base.to_vec();
    order.sort_by(|&a, &b| d2(a).total_cmp(&d2(b)));
    order
}

/// A uniform permutation of `base` from `seed` and `draw` (Fisher–Yates over
/// u64 draws, so it does not depend on `usize` width).
pub fn random(base: &[u32], seed: u64, draw: u64) -> Vec<u32> {
    // the draw number is mixed in so that each reordering of a dynamic run
    // draws anew, while one (seed, draw) always gives the same list
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ draw.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    let mut order = base.to_vec();
    for i in (1..order.len()).rev() {
        let j = rng.random_range(0..=i as u64) as usize;
        order.swap(i, j);
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_in_any_case_with_either_reverse_spelling() {
        assert_eq!(SweepOrder::all().count(), 20);
        for o in SweepOrder::all() {
            assert_eq!(SweepOrder::parse(&o.name()), Some(o));
            assert_eq!(SweepOrder::parse(&o.paper_name()), Some(o));
        }
        let dgrvm = SweepOrder {
            scheme: Scheme::DGrvm,
            reverse: true,
        };
        assert_eq!(SweepOrder::parse("-D-GRVM"), Some(dgrvm));
        assert_eq!(SweepOrder::parse("Reverse-d-grvm"), Some(dgrvm));
        assert_eq!(SweepOrder::parse("input"), Some(SweepOrder::N));
        assert_eq!(SweepOrder::parse("dgrvm"), None);
        assert_eq!(SweepOrder::parse("--wqp"), None);
    }

    #[test]
    fn largest_first_is_stable_over_the_base_list() {
        let keys = [1.0, 3.0, 1.0, 2.0, f64::NAN];
        assert_eq!(largest_first(&[0, 1, 2, 3, 4], &keys), vec![4, 1, 3, 0, 2]);
        assert_eq!(largest_first(&[2, 1, 0, 3], &keys), vec![1, 3, 2, 0]);
    }

    #[test]
    fn distance_schemes_start_at_the_largest_key_and_go_outward() {
        let points: Vec<[f64; 3]> = (0..5).map(|i| [i as f64, 0.0, 0.0]).collect();
        // vertex 3 has the largest key; distances 3,2,1,0,1: 3 then 2 and 4
        // (tied: base order), then 1, then 0
        let keys = [0.0, 0.0, 0.0, 9.0, 5.0];
        let base = [0, 1, 2, 3, 4];
        let o = SweepOrder {
            scheme: Scheme::DLng,
            reverse: false,
        };
        assert_eq!(o.apply(&base, &keys, &points, 0, 0), vec![3, 2, 4, 1, 0]);
        let r = SweepOrder { reverse: true, ..o };
        assert_eq!(r.apply(&base, &keys, &points, 0, 0), vec![0, 1, 4, 2, 3]);
    }

    #[test]
    fn random_is_a_permutation_fixed_by_seed_and_draw() {
        let base: Vec<u32> = (0..50).collect();
        let a = random(&base, 7, 0);
        let mut sorted = a.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, base);
        assert_eq!(a, random(&base, 7, 0));
        assert_ne!(a, random(&base, 8, 0));
        assert_ne!(a, random(&base, 7, 1));
    }
}
