//! First-layer heights of a perturbed boundary layer after smoothing with
//! the ideal objective and with the default (input) targets: a table in
//! results/targets-boundary-layer.md and the picture the book shows,
//! docs/src/images/targets-first-layer.svg.
//!
//! cargo bench --bench targets

mod common;

use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::problem::{ProblemOptions, Target};
use meshsmooth::solve::{self, Method, Options, Params};
use meshsmooth::{Mesh, metric};
use plotters::prelude::*;
use std::fmt::Write;

const NX: usize = 48;
const LAYERS: usize = 14;

/// Height above the wall y = 0 of each first-layer vertex (the second row),
/// by x.
fn first_layer(mesh: &Mesh) -> Vec<(f64, f64)> {
    (1..NX).map(|i| mesh.points[NX + 1 + i]).map(|p| (p[0], p[1])).collect()
}

/// `base` with its interior vertices moved by up to 0.3 of their shortest edge.
fn perturbed(base: &Mesh, seed: u64) -> Mesh {
    let mut start = base.clone();
    let perturb = PerturbOptions {
        perturbation: Perturbation::RandomShortest { alpha: 0.3 },
        seed,
        ..Default::default()
    };
    generate::perturb(&mut start, &perturb).unwrap();
    start
}

/// A second table: every kind of layer `generate boundary-layer` builds,
/// perturbed the same way, smoothed with the ideal target and the default.
fn every_kind(md: &mut String) {
    use meshsmooth::error::Named;
    use meshsmooth::generate::LayerKind;
    use meshsmooth::problem::targets::first_layer_change;
    writeln!(
        md,
        "\n## Every kind of layer\n\n`meshsmooth generate boundary-layer --kind K` (first height 1e-3, 12 layers; 2D: 24 cells along the wall, growth 1.25; 3D: 8 x 8 cells, growth 1.5), perturbed as above (seed 5), Newton. First-layer height after over before on every wall vertex under a stretched cell (what `smooth` prints): median \\|h/h0 - 1\\| and the largest.\n\n| kind | cells | perturbed, median / max | ideal target, median | default, median / max | default resolved to |\n|---|---|---|---|---|---|"
    )
    .unwrap();
    let worst =
        |c: &meshsmooth::problem::targets::LayerChange| (c.min_ratio - 1.0).abs().max((c.max_ratio - 1.0).abs());
    for kind in LayerKind::NAMES.iter().map(|&(_, k)| k) {
        let (n, growth) = if kind.dim() == 2 { (24, 1.25) } else { (8, 1.5) };
        let base = generate::boundary_layer(kind, n, 1e-3, growth, 12).unwrap();
        let start = perturbed(&base, 5);
        let params = Params::default();
        let smoothed = |target: Target<'static>| {
            let mut m = start.clone();
            let mut opts = ProblemOptions::default();
            opts.target = target;
            solve::smooth_mesh(&mut m, &opts, &Options::cpu(Method::Newton, &params), &mut |_| true).unwrap();
            assert!(metric::inverted_elements(&m, &m.points).is_empty());
            first_layer_change(&base, &base.points, &m.points).unwrap()
        };
        let p = first_layer_change(&base, &base.points, &start.points).unwrap();
        let (ideal, auto) = (smoothed(Target::Ideal), smoothed(Target::Auto));
        let (resolved, _) = ProblemOptions::default().resolved(&start).unwrap();
        writeln!(
            md,
            "| {kind} | {} | {:.3} / {:.3} | {:.1}x as thick | {:.3} / {:.3} | `{}`, `{}` |",
            base.num_elements(),
            p.median_change,
            worst(&p),
            ideal.median_ratio,
            auto.median_change,
            worst(&auto),
            resolved.target.name(),
            resolved.metric.name()
        )
        .unwrap();
    }
}

fn main() {
    let base = generate::boundary_layer_2d(NX, 1e-3, 1.25, LAYERS).unwrap();
    let start = perturbed(&base, 3);
    let params = Params::default();
    let run = |target: Target<'static>| {
        let mut m = start.clone();
        let mut opts = ProblemOptions::default();
        opts.target = target;
        let (resolved, _) = opts.resolved(&m).unwrap();
        let t = std::time::Instant::now();
        let info = solve::smooth_mesh(&mut m, &opts, &Options::cpu(Method::Newton, &params), &mut |_| true).unwrap();
        assert!(metric::inverted_elements(&m, &m.points).is_empty());
        (m, info, resolved, t.elapsed().as_secs_f64())
    };
    let (ideal, ideal_info, _, ideal_s) = run(Target::Ideal);
    let (auto, auto_info, resolved, auto_s) = run(Target::Auto);
    let h0 = first_layer(&base);
    let rel = |m: &Mesh| -> Vec<f64> { first_layer(m).iter().zip(&h0).map(|(a, b)| a.1 / b.1).collect() };
    let stats = |r: &[f64]| {
        let mut e: Vec<f64> = r.iter().map(|x| (x - 1.0).abs()).collect();
        e.sort_by(f64::total_cmp);
        (e[e.len() / 2], *e.last().unwrap())
    };
    let (rp, ri, ra) = (rel(&start), rel(&ideal), rel(&auto));
    let mut md = String::new();
    writeln!(md, "# First-layer heights of a perturbed boundary layer\n").unwrap();
    md.push_str(&common::provenance("cargo bench --bench targets"));
    writeln!(
        md,
        "\nThe unit square with {LAYERS} quad layers on the wall y = 0 (first height 1e-3, growth 1.25) under triangles, {NX} cells along the wall (`meshsmooth generate boundary-layer --cells {NX} --layers {LAYERS}`), interior vertices moved by up to 0.3 of their shortest edge (`--perturb random-shortest:0.3`, seed 3). Newton, default settings. The default resolved to `{}` with the `{}` metric.\n",
        resolved.target.name(),
        resolved.metric.name()
    )
    .unwrap();
    writeln!(
        md,
        "| run | first layer, median \\|h/h0 - 1\\| | max | F end | iterations | seconds |\n|---|---|---|---|---|---|"
    )
    .unwrap();
    let (pm, px) = stats(&rp);
    writeln!(md, "| perturbed input | {pm:.3} | {px:.3} | | | |").unwrap();
    for (name, r, info, s) in [
        ("ideal target", &ri, &ideal_info, ideal_s),
        ("default (input targets)", &ra, &auto_info, auto_s),
    ] {
        let (m, x) = stats(r);
        writeln!(
            md,
            "| {name} | {m:.3} | {x:.3} | {:.4} | {} | {s:.3} |",
            info.objective, info.iterations
        )
        .unwrap();
    }
    every_kind(&mut md);
    std::fs::create_dir_all("results").unwrap();
    std::fs::write("results/targets-boundary-layer.md", &md).unwrap();
    print!("{md}");

    std::fs::create_dir_all("docs/src/images").unwrap();
    let path = "docs/src/images/targets-first-layer.svg";
    let root = SVGBackend::new(path, (760, 420)).into_drawing_area();
    root.fill(&WHITE).unwrap();
    let ymax = ri.iter().cloned().fold(2.0, f64::max) * 1.1;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "First-layer height along the wall, relative to the unperturbed mesh",
            ("sans-serif", 18),
        )
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(52)
        .build_cartesian_2d(0.0..1.0, (0.5f64..ymax).log_scale())
        .unwrap();
    chart
        .configure_mesh()
        .x_desc("x along the wall")
        .y_desc("h / h0")
        .draw()
        .unwrap();
    let xs: Vec<f64> = h0.iter().map(|p| p.0).collect();
    for (name, r, color) in [
        ("perturbed input", &rp, RGBColor(150, 150, 150)),
        ("ideal target", &ri, RED),
        ("default (input targets)", &ra, BLUE),
    ] {
        chart
            .draw_series(LineSeries::new(
                xs.iter().cloned().zip(r.iter().cloned()),
                color.stroke_width(2),
            ))
            .unwrap()
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.9))
        .draw()
        .unwrap();
    root.present().unwrap();
    println!("wrote results/targets-boundary-layer.md and {path}");
}
