//! `meshsmooth rezone`: reference-Jacobian rezoning, optionally beside the
//! paper's CN optimisation from the same start, with section 6's tables.

use super::RezoneArgs;
use super::device;
use super::outputs;
use super::progress::{Log, Progress};
use meshsmooth::io::{self, Format};
use meshsmooth::metric::smetric::MetricKind;
use meshsmooth::metric_report::{SideBySide, displacement_percent, metric_summary};
use meshsmooth::solve::rezone::{RezoneOptions, cn_optimise_mesh, rezone_mesh};
use meshsmooth::solve::{self, Info};
use meshsmooth::{Mesh, Result, metric};

pub fn rezone(a: &RezoneArgs) -> Result<()> {
    let mut checked = vec![("-o", a.output.as_path())];
    checked.extend(a.compare_cn.as_deref().map(|cn| ("--compare-cn", cn)));
    outputs::check(Some(&a.input), &checked)?;
    let format = outputs::mesh_format("-o", &a.output, a.format.as_deref(), Some(&a.input))?;
    let cn_format = a.compare_cn.as_deref().map(Format::from_path).transpose()?;
    let mut sink = outputs::MeshSink::open(&a.output)?;
    let mesh = io::read(&a.input)?;
    metric::refuse_inverted(&mesh).map_err(|e| io::in_file(&a.input, e))?;
    let settings = device::settings(a.device, &a.gpu, &a.stop, None)?;
    let params = settings.params()?;
    let (backend, note) = settings.backend(&[a.method])?;
    if let Some(note) = note {
        eprintln!("note: {note}");
    }
    let opts = RezoneOptions {
        solve: {
            let mut o = solve::Options::default();
            o.method = a.method;
            o.params = params;
            o.device = backend.device();
            o
        },
        reference_iters: a.reference_iters,
    };
    let show = !a.quiet;
    let measure = |m: &Mesh| metric_summary(m, &m.points, MetricKind::ConditionNumberPaper, None);
    let original = measure(&mesh).map_err(|e| io::in_file(&a.input, e))?;

    let mut rj = mesh.clone();
    let mut progress = Progress::new(opts.solve.params.max_iter, if show { Log::Sparse } else { Log::None });
    let result = rezone_mesh(&mut rj, &opts, &mut |r| progress.update(r));
    progress.finish(result.as_ref().ok().and_then(|i| i.info.history.last()));
    let rj_info = result.map_err(|e| io::in_file(&a.input, e))?;
    // both meshes are put in place together, once both are written
    let mut staged = vec![sink.stage(&rj, format, true)?];
    println!(
        "step 1 (reference positions): {:.3} s; step 2 (F_RJ): {}",
        rj_info.reference_seconds,
        line(&rj_info.info)
    );

    let cn = match (&a.compare_cn, cn_format) {
        (Some(path), Some(fmt)) => {
            let mut cn = mesh.clone();
            let mut progress = Progress::new(opts.solve.params.max_iter, if show { Log::Sparse } else { Log::None });
            let result = cn_optimise_mesh(&mut cn, &opts.solve, &mut |r| progress.update(r));
            progress.finish(result.as_ref().ok().and_then(|i| i.history.last()));
            let info = result.map_err(|e| io::in_file(&a.input, e))?;
            staged.push(io::stage_mesh(path, &cn, fmt)?);
            println!("CN optimisation (cn-paper): {}", line(&info));
            Some(cn)
        }
        _ => None,
    };

    for s in staged {
        s.commit()?;
    }
    let rj_quality = measure(&rj)?;
    let cn_quality = cn.as_ref().map(measure).transpose()?;
    let mut table = SideBySide {
        quality: vec![("original", &original), ("RJ", &rj_quality)],
        displacement: vec![("RJ", displacement_percent(&mesh, &mesh.points, &rj.points))],
    };
    if let (Some(cn), Some(q)) = (&cn, &cn_quality) {
        table.quality.push(("CN", q));
        table
            .displacement
            .push(("CN", displacement_percent(&mesh, &mesh.points, &cn.points)));
    }
    println!("\n{table}");
    println!("wrote {}", sink.name());
    if let Some(path) = &a.compare_cn {
        println!("wrote {}", path.display());
    }
    Ok(())
}

fn line(info: &Info) -> String {
    format!(
        "{} on {}: {} after {} iterations in {:.3} s, F {:.6} -> {:.6}",
        info.method,
        info.device,
        info.stop,
        info.iterations,
        info.seconds,
        info.history.first().map_or(info.objective, |r| r.objective),
        info.objective
    )
}
