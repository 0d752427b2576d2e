//! `meshsmooth compare`: several methods from one start, the Newton paper's
//! comparison figures.

use super::CompareArgs;
use super::device;
use super::outputs;
use meshsmooth::solve::Options;
use meshsmooth::{Error, Result, io};

fn opt_secs(t: Option<f64>) -> String {
    t.map_or("-".into(), |t| format!("{t:.3}"))
}

fn mib(bytes: usize) -> String {
    format!("{:.2} MiB", bytes as f64 / (1024.0 * 1024.0))
}

pub fn compare(a: &CompareArgs) -> Result<()> {
    let methods = &a.methods;
    if methods.is_empty() {
        return Err(Error::InvalidArgument("--methods needs at least one method".into()));
    }
    let checked: Vec<(&str, &std::path::Path)> = [("--csv", &a.csv), ("--plot", &a.plot)]
        .into_iter()
        .filter_map(|(flag, p)| p.as_deref().map(|p| (flag, p)))
        .collect();
    outputs::check(Some(&a.input), &checked)?;
    let mut settings = device::settings(a.device, &a.gpu, &a.stop, Some(&a.objective))?;
    settings.preconditioner = a.preconditioner;
    let params = settings.params()?;
    let mesh = io::read(&a.input)?;
    let reference = settings.reference_mesh()?;
    let surface = settings.surface_geometry()?;
    let options = settings.problem_options(reference.as_ref(), surface.as_ref())?;
    // every method needs a version on the device: checked before running any
    let (backend, note) = settings.backend(methods)?;
    if let Some(note) = note {
        eprintln!("note: {note}");
    }
    let mut opts = Options::default();
    opts.params = params.clone();
    opts.device = backend.device();
    let (cmp, infos) =
        meshsmooth::compare::compare(&mesh, &options, methods, &opts).map_err(|e| io::in_file(&a.input, e))?;
    let where_ = infos.first().map_or_else(String::new, |i| i.device.clone());
    if a.json {
        println!("{}", serde_json::to_string_pretty(&cmp).expect("comparison serialises"));
    } else {
        println!(
            "{}: {} vertices, {} elements; F0 = {:.8}, best F = {:.8}; {where_}",
            a.input.display(),
            cmp.vertices,
            cmp.elements,
            cmp.initial_objective,
            cmp.best_objective,
        );
        println!(
            "{:<12} {:>6} {:>9} {:>9} {:>9} {:>9} {:>9} {:>14} {:>10} {:>11} {:>13}",
            "method",
            "iters",
            "T50 s",
            "T90 s",
            "T100 s",
            "total s",
            "setup s",
            "F",
            "|grad F|",
            "memory",
            "paper est."
        );
        for r in &cmp.runs {
            println!(
                "{:<12} {:>6} {:>9} {:>9} {:>9} {:>9.3} {:>9.3} {:>14.10} {:>10.3e} {:>11} {:>13}",
                r.method,
                r.iterations,
                opt_secs(r.t50_with_setup),
                opt_secs(r.t90_with_setup),
                opt_secs(r.t100_with_setup),
                r.seconds,
                r.setup_seconds,
                r.objective,
                r.grad_norm,
                mib(r.memory_bytes),
                r.paper_memory_bytes.map_or("-".into(), mib)
            );
        }
        for r in cmp.runs.iter().filter(|r| r.reorderings > 0) {
            println!(
                "{}: order {}: COT {:.3} s, RT {:.3} s, TT {:.3} s; {} reordering(s)",
                r.method, options.ordering, r.optimise_seconds, r.reorder_seconds, r.seconds, r.reorderings
            );
        }
        println!("(T50/T90/T100 count each method's setup, as the Newton paper does; without it:)");
        for r in &cmp.runs {
            println!(
                "{:<12} solve only: T50 {} s, T90 {} s, T100 {} s",
                r.method,
                opt_secs(r.t50),
                opt_secs(r.t90),
                opt_secs(r.t100)
            );
        }
        for (c, counted) in cmp
            .crossovers
            .iter()
            .map(|c| (c, "setup counted"))
            .chain(cmp.crossovers_without_setup.iter().map(|c| (c, "solve only")))
        {
            println!(
                "{} passes {} at {:.3} s ({counted}), {:.1}% of the way to the best objective",
                c.second, c.first, c.seconds, c.optimality_percent
            );
        }
    }
    // both or neither
    let mut writes = outputs::Writes::default();
    if let Some(csv) = &a.csv {
        let text = meshsmooth::compare::histories_csv(&infos);
        writes.add(csv, move || outputs::stage_text(csv, text));
    }
    if let Some(plot) = &a.plot {
        let series: Vec<(String, &meshsmooth::solve::History)> =
            infos.iter().map(|i| (i.method.to_string(), &i.history)).collect();
        let svg = meshsmooth::plot::histories_svg(&series);
        writes.add(plot, move || outputs::stage_text(plot, svg));
    }
    writes.run()?;
    Ok(())
}
