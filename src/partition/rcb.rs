//! Recursive coordinate bisection: the geometric partitioner built in, so a
//! partitioned run needs no graph-partitioning library. Each cut halves the
//! longest extent of the current box, with part counts split as evenly as they
//! go, so any number of parts (not only powers of two) comes out balanced to
//! one vertex.

use crate::metric::mat3::Vec3;

/// The owning part of each point, `parts` parts of sizes within one of each other.
pub fn rcb(points: &[Vec3], parts: usize) -> Vec<u32> {
    let parts = parts.max(1);
    let mut owner = vec![0u32; points.len()];
    let mut ids: Vec<u32> = (0..points.len() as u32).collect();
    split(points, &mut ids, 0, parts, &mut owner);
    owner
}

fn split(points: &[Vec3], ids: &mut [u32], first: usize, parts: usize, owner: &mut [u32]) {
    if parts == 1 || ids.len() <= 1 {
        for &v in ids.iter() {
            owner[v as usize] = first as u32;
        }
        return;
    }
    let left_parts = parts / 2;
    // the cut keeps the share of vertices equal to the share of parts
    let left = ids.len() * left_parts / parts;
    let axis = longest_axis(points, ids);
    // ties broken by id, so the partition does not depend on the input's order of equal coordinates
    let key = |v: &u32| (points[*v as usize][axis], *v);
    if left > 0 && left < ids.len() {
        ids.select_nth_unstable_by(left, |a, b| {
            key(a).partial_cmp(&key(b)).unwrap_or(std::cmp::Ordering::Equal)
        });
    }
    let (lo, hi) = ids.split_at_mut(left);
    split(points, lo, first, left_parts, owner);
    split(points, hi, first + left_parts, parts - left_parts, owner);
}

fn longest_axis(points: &[Vec3], ids: &[u32]) -> usize {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &v in ids {
        for k in 0..3 {
            lo[k] = lo[k].min(points[v as usize][k]);
            hi[k] = hi[k].max(points[v as usize][k]);
        }
    }
    (0..3)
        .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_are_balanced_and_contiguous_along_a_line() {
        let pts: Vec<Vec3> = (0..10).map(|i| [i as f64, 0.0, 0.0]).collect();
        let owner = rcb(&pts, 3);
        assert_eq!(owner, vec![0, 0, 0, 1, 1, 1, 2, 2, 2, 2]);
        let counts = |k| owner.iter().filter(|&&o| o == k).count();
        assert!((0..3).all(|k| (3..=4).contains(&counts(k))));
    }
}
