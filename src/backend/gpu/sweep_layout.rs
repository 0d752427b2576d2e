//! The device numbering of vertices and corners: each colour's vertices
//! stored together in sweep order, so that the threads of one colour's
//! dispatch read neighbouring incidence offsets, incidence lists and
//! positions; the corners renumbered by the same order (each corner where
//! its first vertex in that order comes), so that those lists point at
//! neighbouring corner records. Built where the problem is uploaded; the
//! CPU path, the vectors over free vertices (problem free order) and what
//! the backend hands back stay in the problem's numbering.

use crate::mesh::topology::Csr;
use crate::metric::mat3::Vec3;
use crate::problem::Problem;

pub(crate) struct SweepLayout {
    /// Device index of each problem vertex.
    pub vertex: Vec<u32>,
    /// Problem vertex at each device index.
    pub vertex_of: Vec<u32>,
    /// Device index of each problem corner.
    pub corner: Vec<u32>,
    /// Problem corner at each device index.
    pub corner_of: Vec<u32>,
    /// The colour lists as device ids (offsets those of `Problem::colors`).
    pub colours: Vec<u32>,
}

fn inverse(perm: &[u32]) -> Vec<u32> {
    let mut inv = vec![0; perm.len()];
    for (i, &j) in perm.iter().enumerate() {
        inv[j as usize] = i as u32;
    }
    inv
}

impl SweepLayout {
    /// The problem's own numbering.
    pub fn identity(p: &Problem) -> SweepLayout {
        let v: Vec<u32> = (0..p.num_vertices() as u32).collect();
        let c: Vec<u32> = (0..p.num_corners() as u32).collect();
        SweepLayout {
            vertex: v.clone(),
            vertex_of: v,
            corner: c.clone(),
            corner_of: c,
            colours: p.colors.items.clone(),
        }
    }

    /// Colour 0's vertices in sweep order, then colour 1's, ..., then the
    /// vertices in no colour (fixed) in problem order; corners by their
    /// smallest device vertex, ties in problem order. With `by_valence`,
    /// each colour's vertices are stably sorted by their number of corners,
    /// so that the threads run in SIMD lanes together have loops of the
    /// same length (the vertices of a colour move independently: the order
    /// within a colour does not change the sweep's result).
    pub fn colour_by_colour(p: &Problem, by_valence: bool) -> SweepLayout {
        let nv = p.num_vertices();
        let mut vertex_of = Vec::with_capacity(nv);
        let mut placed = vec![false; nv];
        for c in 0..p.colors.len() {
            let start = vertex_of.len();
            for &v in p.colors.of(c) {
                if !placed[v as usize] {
                    placed[v as usize] = true;
                    vertex_of.push(v);
                }
            }
            if by_valence {
                vertex_of[start..].sort_by_key(|&v| p.incidence.of(v as usize).len());
            }
        }
        vertex_of.extend((0..nv as u32).filter(|&v| !placed[v as usize]));
        let vertex = inverse(&vertex_of);
        let first: Vec<u32> = p
            .corners
            .iter()
            .map(|c| c.iter().map(|&v| vertex[v as usize]).min().unwrap_or(0))
            .collect();
        let mut corner_of: Vec<u32> = (0..p.num_corners() as u32).collect();
        corner_of.sort_by_key(|&c| first[c as usize]);
        let corner = inverse(&corner_of);
        let colours = (0..p.colors.items.len() as u32).collect();
        SweepLayout {
            vertex,
            vertex_of,
            corner,
            corner_of,
            colours,
        }
    }

    /// Per-vertex values (`per` each) from problem to device order.
    pub fn to_device<T: Copy>(&self, values: &[T], per: usize) -> Vec<T> {
        self.vertex_of
            .iter()
            .flat_map(|&v| &values[per * v as usize..per * (v as usize + 1)])
            .copied()
            .collect()
    }

    /// Positions from device to problem order.
    pub fn to_problem(&self, x: &[Vec3]) -> Vec<Vec3> {
        self.vertex.iter().map(|&d| x[d as usize]).collect()
    }

    /// The incidence lists in device order, each item `corner << 2 | k`
    /// with its device corner; within a list the problem's order, so that
    /// the sweeps sum in the CPU's order.
    pub fn incidence(&self, inc: &Csr) -> Csr {
        self.incidence_ordered(inc, false)
    }

    /// `incidence` with each list in ascending device corner order, the
    /// order in which the gradient gathers run over windows of corners
    /// (`gradient_gather.wgsl`).
    pub fn gather_incidence(&self, inc: &Csr) -> Csr {
        self.incidence_ordered(inc, true)
    }

    fn incidence_ordered(&self, inc: &Csr, by_device_corner: bool) -> Csr {
        let mut offsets = Vec::with_capacity(inc.offsets.len());
        let mut items = Vec::with_capacity(inc.items.len());
        offsets.push(0);
        for &v in &self.vertex_of {
            let start = items.len();
            items.extend(
                inc.of(v as usize)
                    .iter()
                    .map(|&packed| (self.corner[(packed >> 2) as usize] << 2) | (packed & 3)),
            );
            if by_device_corner {
                items[start..].sort_unstable();
            }
            offsets.push(items.len() as u32);
        }
        Csr { offsets, items }
    }

    /// A per-vertex CSR (sliding candidates) in device order.
    pub fn lists(&self, lists: &Csr) -> Csr {
        let mut offsets = Vec::with_capacity(lists.offsets.len());
        let mut items = Vec::with_capacity(lists.items.len());
        offsets.push(0);
        for &v in &self.vertex_of {
            items.extend_from_slice(lists.of(v as usize));
            offsets.push(items.len() as u32);
        }
        Csr { offsets, items }
    }

    /// Problem vertex ids (free vertices, colour lists) as device ids.
    pub fn vertex_ids(&self, ids: &[u32]) -> Vec<u32> {
        ids.iter().map(|&v| self.vertex[v as usize]).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate;

    #[test]
    fn colours_are_contiguous_and_corners_follow() {
        let mesh = generate::tet_box(4, 3, 5, [1.0; 3]);
        let p = Problem::new(&mesh).unwrap();
        let l = SweepLayout::colour_by_colour(&p, false);
        // each colour's vertices occupy its own range, in sweep order
        let colours = l.vertex_ids(&p.colors.items);
        assert_eq!(colours, (0..colours.len() as u32).collect::<Vec<_>>());
        assert_eq!(l.colours, colours);
        // by valence: the same ranges, each sorted by corner count
        let lv = SweepLayout::colour_by_colour(&p, true);
        for c in 0..p.colors.len() {
            let range = p.colors.offsets[c] as usize..p.colors.offsets[c + 1] as usize;
            let mut got: Vec<u32> = lv.vertex_of[range.clone()].to_vec();
            let valence: Vec<usize> = got.iter().map(|&v| p.incidence.of(v as usize).len()).collect();
            assert!(valence.windows(2).all(|w| w[0] <= w[1]));
            got.sort();
            let mut want = p.colors.of(c).to_vec();
            want.sort();
            assert_eq!(got, want);
        }
        // both are permutations
        assert_eq!(inverse(&l.vertex), l.vertex_of);
        assert_eq!(inverse(&l.corner), l.corner_of);
        // corners by their smallest device vertex
        let first = |c: u32| {
            p.corners[c as usize]
                .iter()
                .map(|&v| l.vertex[v as usize])
                .min()
                .unwrap()
        };
        assert!(l.corner_of.windows(2).all(|w| first(w[0]) <= first(w[1])));
        // an incidence list names the same corners and local vertices
        let inc = l.incidence(&p.incidence);
        let gather = l.gather_incidence(&p.incidence);
        for v in 0..p.num_vertices() {
            let d = l.vertex[v] as usize;
            let back: Vec<u32> = inc
                .of(d)
                .iter()
                .map(|&q| (l.corner_of[(q >> 2) as usize] << 2) | (q & 3))
                .collect();
            assert_eq!(back, p.incidence.of(v));
            // the gathers' lists: the same items, ascending
            let mut sorted = inc.of(d).to_vec();
            sorted.sort();
            assert_eq!(gather.of(d), sorted);
        }
        let x: Vec<Vec3> = (0..p.num_vertices()).map(|i| [i as f64, 0.0, 1.0]).collect();
        let flat: Vec<f64> = x.iter().flatten().copied().collect();
        let dev: Vec<Vec3> = l.to_device(&flat, 3).chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
        assert_eq!(l.to_problem(&dev), x);
    }
}
