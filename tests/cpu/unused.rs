//! Vertices used by no element (a Gmsh mesh exported with only its volume
//! cells) are kept where they are: never moved, their point data untouched.

use crate::common::box_with_unused;
use meshsmooth::smoother::Event;
use meshsmooth::{DeviceChoice, Smoother, metric};

use crate::common::bits;

#[test]
fn smoothing_keeps_unused_points_bit_for_bit_and_says_so() {
    let (mut mesh, unused) = box_with_unused();
    let input = mesh.clone();
    assert_eq!(mesh.unused_vertices(), unused);
    let mut smoother = Smoother::default();
    smoother.device = DeviceChoice::Cpu;
    let mut notes = Vec::new();
    let report = smoother
        .smooth_observed(&mut mesh, &mut |e| {
            if let Event::Start(s) = e {
                notes = s.notes.clone();
            }
            true
        })
        .unwrap();
    assert!(
        notes
            .iter()
            .any(|n| n == "3 points are used by no element: kept where they are"),
        "{notes:?}"
    );
    assert_eq!(report.start.notes, notes);
    assert_eq!(mesh.num_points(), input.num_points());
    for &v in &unused {
        assert_eq!(bits(&mesh.points[v]), bits(&input.points[v]), "unused point {v} moved");
    }
    assert_eq!(mesh.data, input.data);
    let moved = (0..unused[0]).filter(|&v| mesh.points[v] != input.points[v]).count();
    assert!(moved > 10, "only {moved} points moved");
    assert!(report.quality.eta.avg < report.start.quality.eta.avg);
    let before = meshsmooth::report::quality_report(&input, &input.points);
    let after = meshsmooth::report::quality_report(&mesh, &mesh.points);
    assert!(after.eta.avg < before.eta.avg);
    assert_eq!(after.vertices, input.num_points());
}

#[test]
fn untangling_and_quality_ignore_unused_points() {
    let (mut mesh, unused) = box_with_unused();
    let v = (0..unused[0])
        .find(|&v| mesh.points[v].iter().all(|&c| c > 0.4 && c < 0.6))
        .unwrap();
    mesh.points[v][0] += 0.45;
    assert!(!metric::inverted_elements(&mesh, &mesh.points).is_empty());
    let input = mesh.clone();
    let q = meshsmooth::report::quality_report(&mesh, &mesh.points);
    assert_eq!(q.vertices, mesh.num_points());
    let mut smoother = Smoother::default();
    smoother.device = DeviceChoice::Cpu;
    let report = smoother.untangle(&mut mesh).unwrap();
    assert!(report.untangled.is_some());
    assert_eq!(report.quality.inverted, 0);
    assert!(report.start.notes.iter().any(|n| n.contains("used by no element")));
    for &u in &unused {
        assert_eq!(bits(&mesh.points[u]), bits(&input.points[u]));
    }
    // smoothing a tangled input untangles it first, the unused points still in place
    let mut tangled = input.clone();
    smoother.smooth(&mut tangled).unwrap();
    assert!(metric::inverted_elements(&tangled, &tangled.points).is_empty());
    for &u in &unused {
        assert_eq!(bits(&tangled.points[u]), bits(&input.points[u]));
    }
}

#[test]
fn a_reference_with_the_inputs_numbering_loses_the_same_points() {
    let (mut mesh, unused) = box_with_unused();
    let reference = mesh.clone();
    let input = mesh.clone();
    let mut smoother = Smoother::default();
    smoother.device = DeviceChoice::Cpu;
    smoother.reference_mesh = Some(reference);
    smoother.smooth(&mut mesh).unwrap();
    for &u in &unused {
        assert_eq!(bits(&mesh.points[u]), bits(&input.points[u]));
    }
}
