//! The papers' test meshes: horseshoe family, distorted prism and hex boxes,
//! graded tet boxes, and the structured hex/quad/triangle grids.

use meshsmooth::generate::{
    HorseshoeKind, distorted_hex_box, graded_tet_box, hex_box, horseshoe, prism_mesh, quad_grid, tri_grid,
};
use meshsmooth::mesh::topology::fixed_vertices;
use meshsmooth::metric::{element_min_det, inverted_elements};
use meshsmooth::report::quality_report;
use meshsmooth::{ElementKind, Mesh};

fn assert_sound(mesh: &Mesh, what: &str) {
    mesh.validate().unwrap_or_else(|e| panic!("{what}: {e}"));
    let inverted = inverted_elements(mesh, &mesh.points);
    assert!(
        inverted.is_empty(),
        "{what}: {} inverted elements, first {:?}",
        inverted.len(),
        &inverted[..inverted.len().min(5)]
    );
}

fn free_vertices(mesh: &Mesh) -> usize {
    fixed_vertices(mesh).iter().filter(|&&f| !f).count()
}

/// Tet volume from the corner determinant at vertex 0 (all corners agree for a tet).
fn volume(mesh: &Mesh, e: usize) -> f64 {
    let vs = mesh.element(e);
    let x: Vec<[f64; 3]> = vs.iter().map(|&v| mesh.points[v as usize]).collect();
    let d = |k: usize| std::array::from_fn::<f64, 3, _>(|i| x[k][i] - x[0][i]);
    let (a, b, c) = (d(1), d(2), d(3));
    (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0
}

#[test]
fn hex_box_counts_order_and_orientation() {
    let m = hex_box(3, 4, 5, [1.0, 2.0, 0.5]);
    assert_eq!(m.num_points(), 4 * 5 * 6);
    assert_eq!(m.count_kind(ElementKind::Hexahedron), 60);
    assert_eq!(m.points[1], [1.0 / 3.0, 0.0, 0.0], "x varies fastest");
    assert_sound(&m, "hex_box");
    // an axis-aligned box cell: every corner determinant is the cell volume
    let cell = (1.0 / 3.0) * (2.0 / 4.0) * (0.5 / 5.0);
    for e in 0..m.num_elements() {
        let d = element_min_det(&m, &m.points, e);
        assert!((d - cell).abs() < 1e-12, "hex {e}: {d} vs {cell}");
    }
    assert_eq!(free_vertices(&m), 2 * 3 * 4);
}

#[test]
fn planar_grids_counts_and_orientation() {
    let q = quad_grid(4, 3, [2.0, 1.0]);
    assert_eq!((q.num_points(), q.num_elements()), (20, 12));
    assert_eq!(q.dim(), 2);
    assert!(q.points.iter().all(|p| p[2] == 0.0));
    assert_sound(&q, "quad_grid");
    let t = tri_grid(4, 3, [2.0, 1.0]);
    assert_eq!((t.num_points(), t.count_kind(ElementKind::Triangle)), (20, 24));
    assert_sound(&t, "tri_grid");
    assert_eq!(free_vertices(&t), 3 * 2);
}

#[test]
fn prism_mesh_has_the_papers_counts() {
    for distorted in [false, true] {
        let m = prism_mesh(distorted, 7);
        assert_eq!(m.num_points(), 1331);
        assert_eq!(m.num_elements(), 2000);
        assert_eq!(m.count_kind(ElementKind::Prism), 2000);
        assert_sound(&m, &format!("prism_mesh(distorted = {distorted})"));
        assert_eq!(free_vertices(&m), 9 * 9 * 9);
    }
}

#[test]
fn distorted_meshes_are_deterministic_and_seed_dependent() {
    assert_eq!(prism_mesh(true, 3), prism_mesh(true, 3));
    assert_ne!(prism_mesh(true, 3).points, prism_mesh(true, 4).points);
    assert_eq!(
        prism_mesh(false, 3),
        prism_mesh(false, 4),
        "the undistorted mesh ignores the seed"
    );
    assert_eq!(distorted_hex_box(6, 11), distorted_hex_box(6, 11));
    assert_ne!(distorted_hex_box(6, 11).points, distorted_hex_box(6, 12).points);
}

#[test]
fn distortion_moves_interior_vertices_and_keeps_the_box() {
    let plain = prism_mesh(false, 0);
    let m = prism_mesh(true, 1);
    let fixed = fixed_vertices(&m);
    let moved = (0..m.num_points())
        .filter(|&v| !fixed[v] && m.points[v] != plain.points[v])
        .count();
    assert!(moved > 700, "only {moved} of 729 free vertices moved");
    for p in &m.points {
        assert!(
            p.iter().all(|&c| (-1e-12..=1.0 + 1e-12).contains(&c)),
            "{p:?} left the unit cube"
        );
    }
    // a visibly worse mesh than the right prisms, as the paper's original
    let before = quality_report(&plain, &plain.points);
    let after = quality_report(&m, &m.points);
    let (b, a) = (before.objective.unwrap(), after.objective.unwrap());
    assert!(a > b * 1.1, "mean eta {a} vs undistorted {b}");
}

#[test]
fn distorted_hex_boxes_are_not_inverted() {
    for (n, seed) in [(2, 0), (4, 1), (10, 2), (16, 3)] {
        let m = distorted_hex_box(n, seed);
        assert_eq!(m.count_kind(ElementKind::Hexahedron), n * n * n);
        assert_sound(&m, &format!("distorted_hex_box({n}, {seed})"));
    }
}

fn volume_ratio(m: &Mesh) -> f64 {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for e in 0..m.num_elements() {
        let v = volume(m, e);
        lo = lo.min(v);
        hi = hi.max(v);
    }
    hi / lo
}

#[test]
fn graded_tet_boxes_reach_the_requested_volume_ratio() {
    for ratio in [1e3, 1e5, 1e7] {
        let m = graded_tet_box(12, ratio);
        assert_eq!(m.count_kind(ElementKind::Tetrahedron), 6 * 12 * 12 * 12);
        assert_sound(&m, &format!("graded_tet_box(12, {ratio:e})"));
        let measured = volume_ratio(&m);
        assert!(
            measured > ratio / 2.0 && measured < ratio * 2.0,
            "asked {ratio:e}, got {measured:e}"
        );
        // clustered toward the origin corner, the cube kept
        let smallest = (0..m.num_elements())
            .min_by(|&a, &b| volume(&m, a).total_cmp(&volume(&m, b)))
            .unwrap();
        assert!(
            m.element(smallest).contains(&0),
            "smallest tet {smallest} is not at the corner"
        );
        assert!(m.points.iter().all(|p| p.iter().all(|&c| (0.0..=1.0).contains(&c))));
        assert_eq!(*m.points.last().unwrap(), [1.0; 3]);
    }
    let uniform = graded_tet_box(4, 1.0);
    assert!((volume_ratio(&uniform) - 1.0).abs() < 1e-9);
}

#[test]
fn horseshoe_kinds_parse_and_display() {
    for (text, kind) in [
        ("sqi", HorseshoeKind::SqI),
        ("sqii", HorseshoeKind::SqII),
        ("sqiv", HorseshoeKind::SqIV),
        ("uti", HorseshoeKind::UtI),
        ("utiv", HorseshoeKind::UtIV),
        ("SQIV", HorseshoeKind::SqIV),
        (" UtI ", HorseshoeKind::UtI),
    ] {
        assert_eq!(text.parse::<HorseshoeKind>().unwrap(), kind);
        assert_eq!(kind.to_string().parse::<HorseshoeKind>().unwrap(), kind);
    }
    for bad in ["", "sq", "sqiii", "ut1"] {
        assert!(bad.parse::<HorseshoeKind>().is_err(), "{bad:?}");
    }
}

fn check_horseshoe(kind: HorseshoeKind, target: usize) {
    let (mesh, reference) = horseshoe(kind, target);
    let what = format!("{kind} {target}");
    assert_sound(&mesh, &format!("horseshoe {what}"));
    assert_sound(&reference, &format!("reference {what}"));
    assert_eq!(mesh.num_points(), reference.num_points(), "{what}");
    assert_eq!(
        (&mesh.kinds, &mesh.offsets, &mesh.conn),
        (&reference.kinds, &reference.offsets, &reference.conn)
    );
    let expected = match kind {
        HorseshoeKind::SqI | HorseshoeKind::SqII | HorseshoeKind::SqIV => ElementKind::Quadrilateral,
        HorseshoeKind::UtI | HorseshoeKind::UtIV => ElementKind::Triangle,
    };
    assert_eq!(mesh.count_kind(expected), mesh.num_elements(), "{what}");
    assert!(mesh.points.iter().chain(&reference.points).all(|p| p[2] == 0.0));
    let free = free_vertices(&mesh);
    assert_eq!(free, free_vertices(&reference));
    assert!(free.abs_diff(target) * 10 <= target, "{what}: {free} free vertices");
    // the reference is the half annulus 1 <= r <= 2, y >= 0
    for p in &reference.points {
        let r = p[0].hypot(p[1]);
        assert!(
            (1.0 - 1e-12..=2.0 + 1e-12).contains(&r) && p[1] >= -1e-12,
            "{what}: {p:?}"
        );
    }
    // the horseshoe has legs reaching down to y = -2
    let lowest = mesh.points.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
    assert!((lowest + 2.0).abs() < 1e-9, "{what}: lowest y {lowest}");
}

#[test]
fn horseshoe_family_small() {
    for kind in HorseshoeKind::ALL {
        for target in [200, 2000] {
            check_horseshoe(kind, target);
        }
        // too coarse for the count to come near, but still a sound mesh pair
        for target in [1, 10] {
            let (mesh, reference) = horseshoe(kind, target);
            assert_sound(&mesh, &format!("{kind} {target}"));
            assert_sound(&reference, &format!("{kind} {target} reference"));
            assert!(free_vertices(&mesh) > 0);
        }
    }
}

#[test]
fn horseshoe_20k_counts() {
    for kind in HorseshoeKind::ALL {
        check_horseshoe(kind, 20_000);
    }
}

#[test]
fn horseshoe_is_deterministic() {
    for kind in HorseshoeKind::ALL {
        assert_eq!(horseshoe(kind, 500), horseshoe(kind, 500));
    }
}

#[test]
fn unstructured_triangles_have_irregular_vertex_degrees() {
    let (mesh, _) = horseshoe(HorseshoeKind::UtI, 2000);
    let fixed = fixed_vertices(&mesh);
    let mut degree = vec![0usize; mesh.num_points()];
    for &v in &mesh.conn {
        degree[v as usize] += 1;
    }
    let interior: Vec<usize> = (0..mesh.num_points())
        .filter(|&v| !fixed[v])
        .map(|v| degree[v])
        .collect();
    let irregular = interior.iter().filter(|&&d| d != 6).count();
    assert!(
        irregular > interior.len() / 4,
        "{irregular} of {} interior vertices irregular",
        interior.len()
    );
}
