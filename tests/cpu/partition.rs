//! The partitioners: METIS (multilevel k-way on the vertex graph) cuts no
//! more edges than recursive coordinate bisection on generated meshes, and
//! both give every part its share of the vertices. The cuts are computed
//! from the vertex graph here, not taken from either partitioner's report.

use meshsmooth::Mesh;
use meshsmooth::generate::{mixed_block, tet_box};
use meshsmooth::partition::{Partitioner, edge_cut};
use meshsmooth::problem::Problem;

/// Cut edges counted from scratch: every element edge once, its ends' owners compared.
fn cut_of(mesh: &Mesh, owner: &[u32]) -> usize {
    let mut edges: Vec<[u32; 2]> = (0..mesh.num_elements())
        .flat_map(|e| mesh.element_edges(e))
        .map(|[a, b]| [a.min(b), a.max(b)])
        .collect();
    edges.sort_unstable();
    edges.dedup();
    edges
        .iter()
        .filter(|[a, b]| owner[*a as usize] != owner[*b as usize])
        .count()
}

fn check(mesh: &Mesh, what: &str) {
    let p = Problem::new(mesh).unwrap();
    let x = p.gather(&mesh.points);
    for parts in 2..=4 {
        let metis = Partitioner::Metis.owners(&p, &x, parts).unwrap();
        let rcb = Partitioner::Rcb.owners(&p, &x, parts).unwrap();
        let (cm, cr) = (edge_cut(&p, &metis), edge_cut(&p, &rcb));
        // the library's count agrees with one from the mesh's own edges (mesh numbering)
        let mut by_mesh = vec![0; mesh.num_points()];
        for (&old, &r) in p.order.iter().zip(&metis) {
            by_mesh[old as usize] = r;
        }
        assert_eq!(cm, cut_of(mesh, &by_mesh), "{what}, {parts} parts: edge cut miscounted");
        assert!(cm <= cr, "{what}, {parts} parts: METIS cuts {cm} edges, RCB {cr}");
        for (name, owner) in [("metis", &metis), ("rcb", &rcb)] {
            let mut count = vec![0usize; parts];
            for &r in owner.iter() {
                count[r as usize] += 1;
            }
            let mean = p.num_vertices() as f64 / parts as f64;
            let max = *count.iter().max().unwrap() as f64;
            assert!(
                count.iter().all(|&c| c > 0),
                "{what}: {name} left a part empty: {count:?}"
            );
            // METIS's default tolerance is 3%; a vertex more or less on a small mesh adds to it
            assert!(max / mean <= 1.03 + 1.0 / mean, "{what}: {name} unbalanced: {count:?}");
        }
    }
}

#[test]
fn metis_cuts_no_more_edges_than_bisection_on_a_box() {
    check(&tet_box(8, 6, 5, [1.0, 1.0, 1.0]), "tet box 8x6x5");
    check(&tet_box(5, 4, 4, [1.0, 1.0, 1.0]), "tet box 5x4x4");
}

#[test]
fn metis_cuts_no_more_edges_than_bisection_on_a_mixed_mesh() {
    check(&mixed_block(6, 3), "mixed block");
}

#[test]
fn metis_repeats_itself() {
    let mesh = tet_box(6, 5, 4, [1.0, 2.0, 1.0]);
    let p = Problem::new(&mesh).unwrap();
    let x = p.gather(&mesh.points);
    let a = Partitioner::Metis.owners(&p, &x, 3).unwrap();
    // also when called from several threads at once
    let others: Vec<Vec<u32>> = std::thread::scope(|s| {
        let runs: Vec<_> = (0..4)
            .map(|_| s.spawn(|| Partitioner::Metis.owners(&p, &x, 3).unwrap()))
            .collect();
        runs.into_iter().map(|r| r.join().unwrap()).collect()
    });
    for b in others {
        assert_eq!(a, b);
    }
    // and after partitioning another graph (METIS's state outlives a call)
    let other = tet_box(8, 6, 5, [1.0, 1.0, 1.0]);
    let q = Problem::new(&other).unwrap();
    for parts in 2..=4 {
        Partitioner::Metis.owners(&q, &q.gather(&other.points), parts).unwrap();
    }
    assert_eq!(Partitioner::Metis.owners(&p, &x, 3).unwrap(), a);
}
