//! The vertex colouring behind parallel BCD: no two vertices of one colour
//! share an element, every free vertex has exactly one colour.

use meshsmooth::Mesh;
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::io::{self, Format};
use meshsmooth::problem::Problem;
use std::path::PathBuf;

fn check_coloring(mesh: &Mesh, name: &str) -> usize {
    let p = Problem::new(mesh).unwrap();
    let mut color_of = vec![usize::MAX; p.num_vertices()];
    for c in 0..p.colors.len() {
        for &v in p.colors.of(c) {
            assert_eq!(color_of[v as usize], usize::MAX, "{name}: vertex {v} has two colours");
            assert!(p.free[v as usize], "{name}: fixed vertex {v} coloured");
            color_of[v as usize] = c;
        }
    }
    for v in 0..p.num_vertices() {
        assert_eq!(
            p.free[v],
            color_of[v] != usize::MAX,
            "{name}: free vertex {v} uncoloured"
        );
    }
    for e in 0..p.num_elements() {
        let t = p.elements.of(e);
        for a in 0..t.len() {
            for b in a + 1..t.len() {
                let (ca, cb) = (color_of[t[a] as usize], color_of[t[b] as usize]);
                assert!(
                    ca == usize::MAX || ca != cb,
                    "{name}: element {e} has two vertices of colour {ca}"
                );
            }
        }
    }
    p.colors.len()
}

#[test]
fn colours_never_share_an_element_on_generated_meshes() {
    let mut m = generate::tet_box(12, 7, 5, [12.0, 7.0, 5.0]);
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: 0.3 },
        fraction: 1.0,
        seed: 5,
    };
    generate::perturb(&mut m, &opts).unwrap();
    let colours = check_coloring(&m, "box");
    // a Kuhn box vertex touches 14 others; greedy needs at most 15 colours
    assert!((2..=15).contains(&colours), "{colours} colours");
    check_coloring(&generate::duct(3), "duct");
}

#[test]
fn colours_never_share_an_element_on_gmsh_and_real_meshes() {
    // through a Gmsh file, as a user's mesh would arrive
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("box.msh");
    let mut m = generate::tet_box(6, 6, 6, [1.0; 3]);
    generate::perturb(
        &mut m,
        &PerturbOptions {
            perturbation: Perturbation::Random { alpha: 0.2 },
            fraction: 1.0,
            seed: 2,
        },
    )
    .unwrap();
    io::write(&path, &m, Format::Msh41Binary, &[]).unwrap();
    check_coloring(&io::read(&path).unwrap(), "gmsh box");
    let shared = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes");
    for name in ["cub_wedge_like.vtk", "tire.vtk", "cube-clip-5.vtk"] {
        if shared.join(name).exists() {
            let colours = check_coloring(&io::read(shared.join(name)).unwrap(), name);
            eprintln!("{name}: {colours} colours");
        }
    }
}
