//! Graph colouring of the free vertices: no two vertices of one colour share
//! an element, so all vertices of a colour can move at once (parallel block
//! coordinate descent on the GPU and on CPU threads).

use super::topology::Csr;

/// Greedy colouring in the given vertex order. `elements_of(v)` lists the
/// vertices sharing an element with `v` (duplicates allowed). Returns the
/// colour classes, each in the order the vertices were visited.
pub fn greedy<'a, I>(order: &[u32], num_vertices: usize, mut elements_of: impl FnMut(usize) -> I) -> Csr
where
    I: Iterator<Item = u32> + 'a,
{
    const NONE: u32 = u32::MAX;
    let mut color = vec![NONE; num_vertices];
    let mut used: Vec<usize> = Vec::new(); // used[c] == v marks colour c as taken around v
    let mut classes: Vec<Vec<u32>> = Vec::new();
    for (stamp, &v) in order.iter().enumerate() {
        for w in elements_of(v as usize) {
            let c = color[w as usize];
            if c != NONE && w != v {
                if used.len() <= c as usize {
                    used.resize(c as usize + 1, usize::MAX);
                }
                used[c as usize] = stamp;
            }
        }
        let c = (0..).find(|&c| used.get(c).is_none_or(|&s| s != stamp)).unwrap();
        color[v as usize] = c as u32;
        if classes.len() <= c {
            classes.resize_with(c + 1, Vec::new);
        }
        classes[c].push(v);
    }
    let pairs = classes
        .iter()
        .enumerate()
        .flat_map(|(c, vs)| vs.iter().map(move |&v| (c as u32, v)));
    Csr::from_pairs(classes.len(), pairs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_path_needs_two_colours_and_a_triangle_three() {
        let path: &'static [[u32; 2]] = &[[0u32, 1], [1, 2], [2, 3]];
        let around = |elems: &'static [[u32; 2]], v: usize| {
            elems
                .iter()
                .filter(move |e| e.contains(&(v as u32)))
                .flat_map(|e| e.iter().copied())
        };
        let c = greedy(&[0, 1, 2, 3], 4, |v| around(path, v));
        assert_eq!(c.len(), 2);
        assert_eq!(c.of(0), &[0, 2]);
        let tri: &'static [[u32; 2]] = &[[0, 1], [1, 2], [2, 0]];
        assert_eq!(greedy(&[0, 1, 2], 3, |v| around(tri, v)).len(), 3);
    }
}
