//! Quality report, element volumes and displacement statistics.

use approx::assert_relative_eq;
use meshsmooth::generate::tet_box;
use meshsmooth::report::{Stats, displacement_stats, element_volume, quality_report};
use meshsmooth::{ElementKind, Mesh};

const KUHN_ETA: f64 = 1.32283;

#[test]
fn stats_of_a_known_set() {
    let s = Stats::of(&[4.0, 1.0, 3.0, 2.0]);
    assert_eq!(s.count, 4);
    assert_eq!((s.avg, s.median, s.min, s.max), (2.5, 2.5, 1.0, 4.0));
    assert_relative_eq!(s.sigma_n, 1.25f64.sqrt() / 2.5, epsilon = 1e-15);
    assert_eq!(s.max_min_ratio, 4.0);
    assert_eq!(Stats::of(&[5.0, 1.0, 3.0]).median, 3.0);
    let empty = Stats::of(&[]);
    assert_eq!(empty.count, 0);
    assert!(empty.avg.is_nan());
    assert_eq!(Stats::of(&[-1.0, 2.0]).max_min_ratio, f64::INFINITY);
}

#[test]
fn unperturbed_box_report_is_uniform() {
    let m = tet_box(5, 5, 5, [1.0; 3]);
    let r = quality_report(&m, &m.points);
    assert_eq!((r.vertices, r.elements, r.dim), (216, 750, 3));
    assert_eq!((r.free_vertices, r.fixed_vertices), (64, 152));
    assert_eq!(r.kinds, vec![("tetrahedron".to_string(), 750)]);
    assert!((r.eta.avg - KUHN_ETA).abs() < 1e-5);
    assert!((r.eta.max - KUHN_ETA).abs() < 1e-5);
    assert!(r.eta.sigma_n < 1e-12);
    assert_relative_eq!(r.volume.avg, 1.0 / 750.0, max_relative = 1e-12);
    assert_relative_eq!(r.volume.max_min_ratio, 1.0, max_relative = 1e-12);
    assert!(r.volume.sigma_n < 1e-12);
    assert_eq!(r.inverted, 0);
    assert_relative_eq!(r.objective.unwrap(), r.eta.avg, max_relative = 1e-14);
    assert_eq!(r.histogram.iter().map(|b| b.count).sum::<usize>(), 750);
    assert_eq!(r.histogram[3].count, 750, "1.32 lies in [1.2, 1.5)");
    assert_eq!(r.histogram.last().unwrap().hi, None);
    assert_eq!(r.worst.len(), 5);
    let text = r.to_string();
    for needle in [
        "216 vertices",
        "inverse mean ratio",
        "volume",
        "eta histogram",
        "worst elements",
    ] {
        assert!(text.contains(needle), "missing {needle}:\n{text}");
    }
}

#[test]
fn inverted_element_is_counted_and_listed() {
    let m = tet_box(3, 3, 3, [1.0; 3]);
    let mut points = m.points.clone();
    // push interior vertex (1,1,1) far past its neighbours
    let v = 1 + 4 * (1 + 4);
    points[v][0] += 0.9;
    let r = quality_report(&m, &points);
    assert!(r.inverted > 0);
    assert!(r.objective.is_none());
    assert_eq!(r.inverted_ids.len(), r.inverted.min(10));
    for &e in &r.inverted_ids {
        assert!(m.element(e).contains(&(v as u32)));
    }
    assert_eq!(r.worst[0].eta, None);
    assert!(r.inverted_ids.contains(&r.worst[0].id));
    assert_eq!(r.eta.count + r.inverted, r.elements);
    assert!(r.volume.min < 0.0);
    assert!(r.to_string().contains("inverted"));
}

#[test]
fn report_serialises_to_json() {
    let m = tet_box(2, 2, 2, [1.0; 3]);
    let r = quality_report(&m, &m.points);
    let json = serde_json::to_string(&r).unwrap();
    for key in [
        "vertices",
        "elements",
        "free_vertices",
        "fixed_vertices",
        "kinds",
        "dim",
        "eta",
        "volume",
        "sigma_n",
        "max_min_ratio",
        "inverted",
        "inverted_ids",
        "objective",
        "histogram",
        "worst",
        "centroid",
    ] {
        assert!(json.contains(&format!("\"{key}\"")), "missing {key}: {json}");
    }
    let value: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(value["elements"], 48);
}

#[test]
fn volumes_of_known_elements() {
    let tri = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    assert_relative_eq!(element_volume(ElementKind::Triangle, &tri), 1.0);
    let quad = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 3.0, 0.0], [0.0, 3.0, 0.0]];
    assert_relative_eq!(element_volume(ElementKind::Quadrilateral, &quad), 6.0);
    let tet = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    assert_relative_eq!(element_volume(ElementKind::Tetrahedron, &tet), 1.0 / 6.0);
    let mut hex: Vec<[f64; 3]> = (0..8)
        .map(|i| [quad[i % 4][0], quad[i % 4][1], (i / 4) as f64 * 0.5])
        .collect();
    assert_relative_eq!(element_volume(ElementKind::Hexahedron, &hex), 3.0, max_relative = 1e-14);
    // lift corner 6: the trilinear volume grows by (2 * 3) * t / 4
    hex[6][2] += 0.4;
    assert_relative_eq!(
        element_volume(ElementKind::Hexahedron, &hex),
        3.0 + 6.0 * 0.4 / 4.0,
        max_relative = 1e-14
    );
    let mut prism: Vec<[f64; 3]> = (0..6).map(|i| [tri[i % 3][0], tri[i % 3][1], (i / 3) as f64]).collect();
    assert_relative_eq!(element_volume(ElementKind::Prism, &prism), 1.0, max_relative = 1e-14);
    // lift top corner 4 by t: the extra volume is a tet-like wedge 1 * t / 3
    prism[4][2] += 0.6;
    assert_relative_eq!(
        element_volume(ElementKind::Prism, &prism),
        1.0 + 0.6 / 3.0,
        max_relative = 1e-14
    );
}

#[test]
fn box_volumes_add_up() {
    let m = tet_box(3, 2, 4, [1.0, 2.0, 3.0]);
    let total: f64 = (0..m.num_elements())
        .map(|e| {
            let x: Vec<[f64; 3]> = m.element(e).iter().map(|&v| m.points[v as usize]).collect();
            element_volume(m.kinds[e], &x)
        })
        .sum();
    assert_relative_eq!(total, 6.0, max_relative = 1e-12);
}

#[test]
fn quad_mesh_report_is_planar() {
    let n = 4;
    let pts = (0..n * n).map(|i| [(i % n) as f64, (i / n) as f64, 0.0]).collect();
    let mut m = Mesh::new(pts);
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let v = (i + n * j) as u32;
            m.push_element(ElementKind::Quadrilateral, &[v, v + 1, v + 1 + n as u32, v + n as u32]);
        }
    }
    let r = quality_report(&m, &m.points);
    assert_eq!(r.dim, 2);
    assert_relative_eq!(r.eta.avg, 1.0, max_relative = 1e-14);
    assert_relative_eq!(r.volume.avg, 1.0);
    assert!(r.to_string().contains("area"));
}

#[test]
fn displacement_finds_the_furthest_vertex() {
    let before = [[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
    let after = [[0.0; 3], [1.0, 3.0, 4.0], [2.0, 1.0, 0.0]];
    let d = displacement_stats(&before, &after);
    assert_eq!(d.max, 5.0);
    assert_eq!(d.max_vertex, Some(1));
    assert_relative_eq!(d.mean, 2.0);
    assert_eq!(displacement_stats(&[], &[]).max_vertex, None);
}
