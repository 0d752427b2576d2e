//! `meshsmooth compare`: several methods from one start, the Newton paper's
//! comparison figures.

use super::CompareArgs;
use super::commands::refuse_overwrite;
use super::device::{self, Backend};
use meshsmooth::backend::gpu::{GpuRunOptions, solve_gpu_with, solve_newton_gpu};
use meshsmooth::solve::Method;
use meshsmooth::{Error, Result, io};

fn opt_secs(t: Option<f64>) -> String {
    t.map_or("-".into(), |t| format!("{t:.3}"))
}

fn mib(bytes: usize) -> String {
    format!("{:.2} MiB", bytes as f64 / (1024.0 * 1024.0))
}

pub fn compare(a: &CompareArgs) -> Result<()> {
    let methods: Vec<Method> = a.methods.iter().map(|m| m.trim().parse()).collect::<Result<_>>()?;
    if methods.is_empty() {
        return Err(Error::InvalidArgument("--methods needs at least one method".into()));
    }
    for out in [&a.csv, &a.plot].into_iter().flatten() {
        refuse_overwrite(&a.input, out)?;
    }
    let params = a.stop.params()?;
    let mesh = io::read(&a.input)?;
    let reference = a.objective.reference()?;
    let options = a.objective.options(reference.as_ref())?;
    let mut where_ = format!("cpu (f64), {} threads", rayon::current_num_threads());
    let (cmp, infos) = if a.device == "gpu" {
        // every method needs a device version: check them all before running any
        for &m in &methods {
            device::gpu_allowed(m)?;
        }
        let backend = device::choose("gpu", &a.gpu, methods[0])?;
        where_ = backend.describe();
        let Backend::Gpu(ctx) = backend else {
            unreachable!("--device gpu gives a GPU backend")
        };
        let opts = GpuRunOptions::default();
        meshsmooth::compare::compare_on(&mesh, &options, &methods, &params, &mut |p, x, m| match m {
            Method::Newton => solve_newton_gpu(&ctx, p, x, &params, &opts, &mut |_| true),
            _ => solve_gpu_with(&ctx, p, x, &params, &opts, &mut |_| true),
        })?
    } else {
        meshsmooth::compare::compare_with(&mesh, &options, &methods, &params)?
    };
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
                opt_secs(r.t50),
                opt_secs(r.t90),
                opt_secs(r.t100),
                r.seconds,
                r.setup_seconds,
                r.objective,
                r.grad_norm,
                mib(r.memory_bytes),
                r.paper_memory_bytes.map_or("-".into(), mib)
            );
        }
        for c in &cmp.crossovers {
            println!(
                "{} passes {} at {:.3} s, {:.1}% of the way to the best objective",
                c.second, c.first, c.seconds, c.optimality_percent
            );
        }
    }
    if let Some(csv) = &a.csv {
        io::write_atomic(csv, |w| {
            Ok(w.write_all(meshsmooth::compare::histories_csv(&infos).as_bytes())?)
        })?;
    }
    if let Some(plot) = &a.plot {
        let series: Vec<(String, &meshsmooth::solve::History)> =
            infos.iter().map(|i| (i.method.to_string(), &i.history)).collect();
        io::write_atomic(plot, |w| {
            Ok(w.write_all(meshsmooth::plot::histories_svg(&series).as_bytes())?)
        })?;
    }
    Ok(())
}
