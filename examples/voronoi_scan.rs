//! Scan of the Voronoi generator against the rezoning paper's Example 2:
//! `cargo run --release --example voronoi_scan -- LLOYD SEED [rezone]`.
use meshsmooth::generate::{self, VoronoiOptions};
use meshsmooth::metric::smetric::MetricKind;
use meshsmooth::metric_report::{MetricSummary, displacement_percent, metric_summary};
use meshsmooth::solve::rezone;
use meshsmooth::solve::{Device, Method, Options, Params};

fn show(label: &str, s: &MetricSummary) {
    let bands: Vec<String> = s.bands.iter().map(|b| format!("{:.1}", b.2)).collect();
    println!(
        "{label}: min {:.2} avg {:.2} max {:.1} bands {}",
        s.min,
        s.avg,
        s.max,
        bands.join("/")
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let lloyd: usize = args[1].parse().unwrap();
    let seed: u64 = args[2].parse().unwrap();
    let run = args.get(3).is_some_and(|a| a == "run");
    let bcc = std::env::var("BCC").is_ok();
    let mut base = VoronoiOptions {
        lloyd,
        seed,
        bcc,
        ..Default::default()
    };
    if let Ok(j) = std::env::var("SMOOTH") {
        base.smooth = j.parse().unwrap();
    }
    if let Ok(j) = std::env::var("NOISE") {
        base.noise = j.parse().unwrap();
    }
    if let Ok(j) = std::env::var("WAVE") {
        base.wave = j.parse().unwrap();
    }
    if let Ok(j) = std::env::var("JITTER") {
        base.jitter = j.parse().unwrap();
    }
    if let Ok(c) = std::env::var("CELLS") {
        let v: Vec<usize> = c.split(',').map(|x| x.parse().unwrap()).collect();
        base.cells = [v[0], v[1], v[2]];
    }
    let plain = generate::voronoi_mesh(&base).unwrap();
    let mesh = generate::voronoi_mesh(&VoronoiOptions {
        distorted: true,
        ..base
    })
    .unwrap();
    println!("nodes {} cells {}", mesh.num_points(), mesh.num_elements());
    let m = MetricKind::ConditionNumberPaper;
    show("plain", &metric_summary(&plain, &plain.points, m, None).unwrap());
    show("orig ", &metric_summary(&mesh, &mesh.points, m, None).unwrap());
    for (label, mm) in [("plain", &plain), ("orig", &mesh)] {
        let v = meshsmooth::metric_report::element_values(mm, &mm.points, m, None).unwrap();
        let skin = meshsmooth::mesh::topology::skin_vertices(mm);
        let touches = |e: usize| mm.element(e).iter().any(|&x| skin[x as usize]);
        let n_b = (0..mm.num_elements()).filter(|&e| touches(e)).count();
        let bad_b = (0..mm.num_elements())
            .filter(|&e| touches(e) && v[e].unwrap() > 9.0)
            .count();
        let bad_i = (0..mm.num_elements())
            .filter(|&e| !touches(e) && v[e].unwrap() > 9.0)
            .count();
        let worst_i = (0..mm.num_elements())
            .filter(|&e| !touches(e))
            .map(|e| v[e].unwrap())
            .fold(0.0, f64::max);
        if std::env::var("DIAG").is_ok() {
            for e in (0..mm.num_elements())
                .filter(|&e| !touches(e) && v[e].unwrap() > 9.0)
                .take(3)
            {
                let vs = mm.element(e);
                let edges = mm.element_edges(e);
                let len = |a: u32, b: u32| {
                    let (p, q) = (mm.points[a as usize], mm.points[b as usize]);
                    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
                };
                let ls: Vec<f64> = edges.iter().map(|ed| len(ed[0], ed[1])).collect();
                println!(
                    "  cell {e} value {:.1} verts {} faces {} edge min {:.4} max {:.4}",
                    v[e].unwrap(),
                    vs.len(),
                    mm.faces.of(e).count(),
                    ls.iter().cloned().fold(f64::MAX, f64::min),
                    ls.iter().cloned().fold(0.0, f64::max)
                );
            }
        }
        println!("{label}: boundary cells {n_b}, >9: boundary {bad_b} interior {bad_i}, worst interior {worst_i:.1}");
    }
    if !run {
        return;
    }
    let mut rj = mesh.clone();
    let mut newton = rezone::default_options(Device::Cpu);
    newton.solve.method = Method::Newton;
    let info = rezone::rezone_mesh(&mut rj, &newton, &mut |_| true).unwrap();
    println!("RJ {:?} {}", info.info.stop, info.info.iterations);
    show("RJ   ", &metric_summary(&rj, &rj.points, m, None).unwrap());
    let mut cn = mesh.clone();
    let mut tight = Params::default();
    tight.tol = 1e-9;
    let ci = rezone::cn_optimise_mesh(&mut cn, &Options::cpu(Method::Newton, &tight), &mut |_| true).unwrap();
    println!("CN {:?} {}", ci.stop, ci.iterations);
    show("CN   ", &metric_summary(&cn, &cn.points, m, None).unwrap());
    let (a, b) = (
        displacement_percent(&mesh, &mesh.points, &rj.points),
        displacement_percent(&mesh, &mesh.points, &cn.points),
    );
    println!(
        "disp RJ {:.1}/{:.1}/{:.1} CN {:.1}/{:.1}/{:.1} ratio {:.1}",
        a.min,
        a.avg,
        a.max,
        b.min,
        b.avg,
        b.max,
        b.avg / a.avg
    );
}
