//! The subcommands.

use super::device;
use super::progress::Progress;
use super::{DemoArgs, ObjectiveArgs, QualityArgs, SmoothArgs, SolverArgs, StopArgs};
use meshsmooth::backend::gpu::list_adapters;
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::io::{self, Format};
use meshsmooth::metric::smetric::MetricKind;
use meshsmooth::metric_report;
use meshsmooth::problem::ProblemOptions;
use meshsmooth::report::quality_report;
use meshsmooth::solve::{self, Info, Method, Params};
use meshsmooth::{Error, Mesh, Result, metric};
use std::path::Path;
use std::time::Duration;

impl SolverArgs {
    fn params(&self) -> Result<Params> {
        let mut p = self.stop.params()?;
        p.newton.negative_curvature = self.negative_curvature;
        Ok(p)
    }
}

impl StopArgs {
    pub(super) fn params(&self) -> Result<Params> {
        let (tol, max_iter, time_limit) = (self.tol, self.max_iter, self.time_limit);
        if !(tol.is_finite() && tol >= 0.0) {
            return Err(Error::InvalidArgument(format!(
                "--tol must be a non-negative number, got {tol}"
            )));
        }
        let time_limit = match time_limit {
            None => None,
            Some(t) if t.is_finite() && t > 0.0 => Some(Duration::from_secs_f64(t)),
            Some(t) => {
                return Err(Error::InvalidArgument(format!(
                    "--time-limit must be a positive number of seconds, got {t}"
                )));
            }
        };
        if let Some(t) = self.target_objective
            && !t.is_finite()
        {
            return Err(Error::InvalidArgument(format!(
                "--target-objective must be a finite number, got {t}"
            )));
        }
        if !(self.tol_x.is_finite() && self.tol_x >= 0.0) {
            return Err(Error::InvalidArgument(format!(
                "--tol-x must be a non-negative number, got {}",
                self.tol_x
            )));
        }
        let mut params = Params {
            tol,
            max_iter,
            time_limit,
            target_objective: self.target_objective,
            ..Params::default()
        };
        params.nlcg.tol_x = self.tol_x;
        Ok(params)
    }
}

impl ObjectiveArgs {
    /// The reference mesh, read when given.
    pub(super) fn reference(&self) -> Result<Option<Mesh>> {
        self.reference.as_deref().map(io::read).transpose()
    }

    pub(super) fn options<'a>(&self, reference: Option<&'a Mesh>) -> Result<ProblemOptions<'a>> {
        Ok(ProblemOptions {
            metric: self.metric,
            template: self.template,
            reference,
            ordering: self.order,
        })
    }
}

pub(super) fn output_format(path: &Path, name: Option<&str>) -> Result<Format> {
    match name {
        Some(n) => Format::from_name(n).ok_or_else(|| {
            Error::InvalidArgument(format!(
                "unknown format '{n}' (expected vtk, vtk-binary, vtu, vtu-binary, vtu-zlib, msh2, msh2-binary, msh4, msh4-binary or medit)"
            ))
        }),
        None => Format::from_path(path),
    }
}

/// `out.vtk` -> `out.partial.vtk`
fn partial_path(output: &Path) -> std::path::PathBuf {
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = match output.extension() {
        Some(ext) => format!("{stem}.partial.{}", ext.to_string_lossy()),
        None => format!("{stem}.partial"),
    };
    output.with_file_name(name)
}

pub(super) fn refuse_overwrite(input: &Path, output: &Path) -> Result<()> {
    if io::same_file(input, output) {
        return Err(Error::InvalidArgument(format!(
            "output {} is the input file; meshsmooth never overwrites its input",
            output.display()
        )));
    }
    Ok(())
}

fn summary(info: &Info, f0: f64) -> String {
    let change = if f0 != 0.0 {
        100.0 * (info.objective - f0) / f0
    } else {
        0.0
    };
    format!(
        "{} on {}: {} after {} {} in {:.3} s (setup {:.3} s); F {:.8} -> {:.8} ({:+.2}%), |grad F| = {:.3e}",
        info.method,
        info.device,
        info.stop,
        info.iterations,
        match info.method {
            Method::Newton | Method::Nlcg => "iterations".to_string(),
            Method::BcdColored => format!("sweeps of {} colours", info.colors),
            _ => "sweeps".to_string(),
        },
        info.seconds,
        info.setup_seconds,
        f0,
        info.objective,
        change,
        info.grad_norm
    )
}

/// Smooths `mesh` in place, printing reports and iterations unless `quiet`.
fn run_solver(mesh: &mut Mesh, solver: &SolverArgs, quiet: bool, save_partial: bool) -> Result<Info> {
    let method = solver.method;
    let params = solver.params()?;
    let reference = solver.objective.reference()?;
    let options = solver.objective.options(reference.as_ref())?;
    // refuse what cannot be smoothed before printing anything
    options.check(mesh)?;
    let bad = metric::inverted_elements(mesh, &mesh.points);
    if !bad.is_empty() {
        return Err(Error::Inverted {
            count: bad.len(),
            first: bad.into_iter().take(5).collect(),
        });
    }
    let choice = device::choose(solver.device, &solver.gpu, &[method])?;
    let before = quality_report(mesh, &mesh.points);
    if !quiet {
        println!("== initial mesh ==\n{before}");
    }
    let start = mesh.points.clone();
    // other metrics get the paper-style table of their own values as well
    let metric_before = (options.metric != MetricKind::InverseMeanRatio)
        .then(|| metric_report::metric_summary(mesh, &mesh.points, options.metric, options.reference))
        .transpose()?;
    let mut progress = Progress::new(params.max_iter, !quiet);
    let opts = solve::Options {
        method,
        params,
        device: choice.device(),
        checkpoint_every: save_partial.then_some(10),
        fail_after: None,
    };
    let result = solve::smooth_mesh(mesh, &options, &opts, &mut |r| progress.update(r));
    progress.finish(result.as_ref().ok().and_then(|i| i.history.last()));
    let info = result?;
    if !quiet {
        println!("\n== optimised mesh ==\n{}", quality_report(mesh, &mesh.points));
        let displacement = metric_report::displacement_percent(mesh, &start, &mesh.points);
        match &metric_before {
            Some(b) => {
                let after = metric_report::metric_summary(mesh, &mesh.points, options.metric, options.reference)?;
                let table = metric_report::Comparison {
                    before: b,
                    after: &after,
                    displacement: Some(displacement),
                };
                println!("{table}");
            }
            None => println!(
                "node displacement, % of the average local spacing: min {:.1}, avg {:.1}, max {:.1}\n",
                displacement.min, displacement.avg, displacement.max
            ),
        }
    }
    let f0 = info.history.first().map_or(info.objective, |r| r.objective);
    println!("{}", summary(&info, f0));
    Ok(info)
}

pub fn smooth(a: &SmoothArgs) -> Result<()> {
    let format = output_format(&a.output, a.format.as_deref())?;
    refuse_overwrite(&a.input, &a.output)?;
    if let Some(h) = &a.history {
        refuse_overwrite(&a.input, h)?;
        for (other, what) in [(&a.output, "the output mesh (-o)"), (&a.input, "the input mesh")] {
            if io::same_target(h, other) {
                return Err(Error::InvalidArgument(format!(
                    "--history {} is {what}; give the history its own file",
                    h.display()
                )));
            }
        }
    }
    let mut mesh = io::read(&a.input)?;
    if a.drop_data {
        mesh.data = Default::default();
    }
    let start = mesh.points.clone();
    let solved = run_solver(&mut mesh, &a.solver, a.quiet, a.save_partial).map_err(|e| io::in_file(&a.input, e));
    let info = match solved {
        Ok(info) => info,
        Err(e) => {
            if a.save_partial && mesh.points != start {
                let partial = partial_path(&a.output);
                match io::write_mesh(&partial, &mesh, format) {
                    Ok(()) => eprintln!("saved the last feasible positions to {}", partial.display()),
                    Err(w) => eprintln!("could not save partial positions: {w}"),
                }
            }
            return Err(e);
        }
    };
    io::write_mesh(&a.output, &mesh, format)?;
    if let Some(h) = &a.history {
        io::write_atomic(h, |w| Ok(w.write_all(info.history.to_csv().as_bytes())?))?;
    }
    if !a.quiet {
        println!("wrote {}", a.output.display());
    }
    Ok(())
}

pub fn quality(a: &QualityArgs) -> Result<()> {
    let mesh = io::read(&a.input)?;
    let report = quality_report(&mesh, &mesh.points);
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).expect("report serialises"));
    } else {
        println!("{}\n{report}", a.input.display());
    }
    Ok(())
}

pub fn demo(a: &DemoArgs) -> Result<()> {
    let n = a.cells.max(1);
    let mut mesh = generate::tet_box(n, n, n, [1.0, 1.0, 1.0]);
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: 0.3 },
        fraction: 1.0,
        seed: 1,
    };
    generate::perturb(&mut mesh, &opts)?;
    println!(
        "meshsmooth demo: a {n}x{n}x{n} box of {} tetrahedra, interior vertices perturbed randomly by 0.3 of the edge length\n",
        mesh.num_elements()
    );
    run_solver(&mut mesh, &a.solver, false, false)?;
    if let Some(out) = &a.output {
        io::write_mesh(out, &mesh, Format::from_path(out)?)?;
        println!("wrote {}", out.display());
    }
    Ok(())
}

pub fn devices() -> Result<()> {
    let adapters = list_adapters();
    if adapters.is_empty() {
        println!("no GPU adapters found (install a Vulkan driver; for software Vulkan: mesa-vulkan-drivers)");
        return Ok(());
    }
    println!(
        "{:<44} {:<8} {:<14} {:<5} {:<8} driver",
        "adapter", "backend", "type", "f64", "compute"
    );
    for a in adapters {
        println!(
            "{:<44} {:<8} {:<14} {:<5} {:<8} {} {}",
            a.name,
            a.backend,
            a.device_type,
            if a.f64 { "yes" } else { "no" },
            if a.compute { "yes" } else { "no" },
            a.driver,
            a.driver_info
        );
    }
    Ok(())
}
