//! Vertex orderings for locality of reference.

use super::topology::Csr;

/// Reverse breadth-first order (section 3.3 of the Newton paper): BFS from the
/// boundary vertex farthest from the origin, then reversed. Disconnected parts
/// are started in turn from their own farthest vertex. Returns `order[new] = old`.
pub fn reverse_bfs(points: &[[f64; 3]], neighbours: &Csr, boundary: &[bool]) -> Vec<u32> {
    let n = points.len();
    let dist2 = |v: usize| points[v].iter().map(|c| c * c).sum::<f64>();
    // candidates for BFS roots: boundary vertices first, farthest first
    let mut roots: Vec<u32> = (0..n as u32).collect();
    roots.sort_by(|&a, &b| {
        let (a, b) = (a as usize, b as usize);
        boundary[b]
            .cmp(&boundary[a])
            .then(dist2(b).total_cmp(&dist2(a)))
            .then(a.cmp(&b))
    });
    let mut seen = vec![false; n];
    let mut order = Vec::with_capacity(n);
    for &root in &roots {
        if seen[root as usize] {
            continue;
        }
        seen[root as usize] = true;
        let start = order.len();
        order.push(root);
        let mut head = start;
        while head < order.len() {
            let v = order[head] as usize;
            head += 1;
            for &w in neighbours.of(v) {
                if !seen[w as usize] {
                    seen[w as usize] = true;
                    order.push(w);
                }
            }
        }
    }
    order.reverse();
    order
}

/// Inverse of a permutation: `inv[perm[i]] = i`.
pub fn invert(perm: &[u32]) -> Vec<u32> {
    let mut inv = vec![0u32; perm.len()];
    for (i, &p) in perm.iter().enumerate() {
        inv[p as usize] = i as u32;
    }
    inv
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reverse_bfs_visits_every_vertex_once_and_ends_at_the_farthest_boundary_vertex() {
        // a path 0-1-2-3 plus an isolated component 4-5
        let pairs = [(0, 1), (1, 0), (1, 2), (2, 1), (2, 3), (3, 2), (4, 5), (5, 4)];
        let nb = Csr::from_pairs(6, pairs.iter().copied());
        let pts: Vec<[f64; 3]> = (0..6).map(|i| [i as f64, 0.0, 0.0]).collect();
        let boundary = [true, false, false, true, true, true];
        let order = reverse_bfs(&pts, &nb, &boundary);
        let mut sorted = order.clone();
        sorted.sort();
        assert_eq!(sorted, vec![0, 1, 2, 3, 4, 5]);
        // root 5 is farthest: the BFS is 5,4, then 3,2,1,0; reversed
        assert_eq!(order, vec![0, 1, 2, 3, 4, 5]);
        assert_eq!(invert(&[2, 0, 1]), vec![1, 2, 0]);
    }
}
