//! The subcommands.

use super::device::{self, Backend};
use super::progress::Progress;
use super::{
    CompareArgs, DemoArgs, GenerateCommand, ObjectiveArgs, OutputArgs, PerturbArgs, QualityArgs, SmoothArgs, SolverArgs,
};
use meshsmooth::backend::gpu::{
    GpuRunOptions, list_adapters, smooth_mesh_gpu_method, solve_gpu_with, solve_newton_gpu,
};
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::io::{self, CellData, Format};
use meshsmooth::metric::smetric::MetricKind;
use meshsmooth::metric_report;
use meshsmooth::problem::ProblemOptions;
use meshsmooth::report::quality_report;
use meshsmooth::solve::pcg::NegativeCurvature;
use meshsmooth::solve::{self, Info, Method, Params};
use meshsmooth::{ElementKind, Error, Mesh, Result, metric};
use std::path::Path;
use std::time::Duration;

impl SolverArgs {
    fn method(&self) -> Result<Method> {
        self.method.parse()
    }

    fn params(&self) -> Result<Params> {
        let mut p = params(self.tol, self.max_iter, self.time_limit)?;
        p.newton.negative_curvature = match self.negative_curvature.as_str() {
            "direction" => NegativeCurvature::Direction,
            _ => NegativeCurvature::Iterate,
        };
        Ok(p)
    }
}

fn params(tol: f64, max_iter: usize, time_limit: Option<f64>) -> Result<Params> {
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
    Ok(Params {
        tol,
        max_iter,
        time_limit,
        ..Params::default()
    })
}

impl ObjectiveArgs {
    /// The reference mesh, read when given.
    fn reference(&self) -> Result<Option<Mesh>> {
        self.reference.as_deref().map(io::read).transpose()
    }

    fn options<'a>(&self, reference: Option<&'a Mesh>) -> Result<ProblemOptions<'a>> {
        Ok(ProblemOptions {
            metric: self.metric.parse()?,
            template: self.template.parse()?,
            reference,
        })
    }

    fn is_default(&self) -> bool {
        self.metric == "imr" && self.template == "harmonic" && self.reference.is_none()
    }
}

fn output_format(path: &Path, name: Option<&str>) -> Result<Format> {
    match name {
        Some(n) => Format::from_name(n).ok_or_else(|| {
            Error::InvalidArgument(format!(
                "unknown format '{n}' (expected vtk, vtk-binary, vtu, vtu-binary, msh2, msh2-binary, msh4, msh4-binary or medit)"
            ))
        }),
        None => Format::from_path(path),
    }
}

/// Per-element inverse mean ratio, written as cell data so ParaView can colour by it.
fn eta_field(mesh: &Mesh) -> Vec<f64> {
    (0..mesh.num_elements())
        .map(|e| metric::element_eta(mesh, &mesh.points, e).unwrap_or(f64::INFINITY))
        .collect()
}

fn write_mesh(path: &Path, mesh: &Mesh, format: Format) -> Result<()> {
    // the last line of defence: an output mesh never holds an inverted element
    let bad = metric::inverted_elements(mesh, &mesh.points);
    if !bad.is_empty() {
        return Err(Error::Inverted {
            count: bad.len(),
            first: bad.into_iter().take(5).collect(),
        });
    }
    let eta = eta_field(mesh);
    io::write(
        path,
        mesh,
        format,
        &[CellData {
            name: "inverse_mean_ratio",
            values: &eta,
        }],
    )
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

fn refuse_overwrite(input: &Path, output: &Path) -> Result<()> {
    if io::same_file(input, output) {
        return Err(Error::InvalidArgument(format!(
            "output {} is the input file; meshsmooth never overwrites its input",
            output.display()
        )));
    }
    Ok(())
}

fn summary(info: &Info, f0: f64, backend: &Backend) -> String {
    let change = if f0 != 0.0 {
        100.0 * (info.objective - f0) / f0
    } else {
        0.0
    };
    format!(
        "{} on {}: {} after {} {} in {:.3} s (setup {:.3} s); F {:.8} -> {:.8} ({:+.2}%), |grad F| = {:.3e}",
        info.method,
        backend.describe(),
        info.stop,
        info.iterations,
        match info.method {
            Method::Newton => "iterations".to_string(),
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
    let method = solver.method()?;
    let params = solver.params()?;
    let reference = solver.objective.reference()?;
    let options = solver.objective.options(reference.as_ref())?;
    let backend = device::choose(
        &solver.device,
        &solver.precision,
        solver.adapter.as_deref(),
        method,
        solver.objective.is_default() && mesh.kinds.iter().all(|&k| k == meshsmooth::ElementKind::Tetrahedron),
    )?;
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
    let result = match &backend {
        Backend::Cpu => solve::smooth_mesh_with(mesh, &options, method, &params, &mut |r| progress.update(r)),
        Backend::Gpu(ctx) => {
            let opts = GpuRunOptions {
                checkpoint_every: save_partial.then_some(10),
                fail_after: None,
            };
            smooth_mesh_gpu_method(ctx, mesh, method, &params, &opts, &mut |r| progress.update(r))
        }
    };
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
    println!("{}", summary(&info, f0, &backend));
    Ok(info)
}

pub fn smooth(a: &SmoothArgs) -> Result<()> {
    let format = output_format(&a.output, a.format.as_deref())?;
    refuse_overwrite(&a.input, &a.output)?;
    if let Some(h) = &a.history {
        refuse_overwrite(&a.input, h)?;
    }
    let mut mesh = io::read(&a.input)?;
    let start = mesh.points.clone();
    let info = match run_solver(&mut mesh, &a.solver, a.quiet, a.save_partial) {
        Ok(info) => info,
        Err(e) => {
            if a.save_partial && mesh.points != start {
                let partial = partial_path(&a.output);
                match write_mesh(&partial, &mesh, format) {
                    Ok(()) => eprintln!("saved the last feasible positions to {}", partial.display()),
                    Err(w) => eprintln!("could not save partial positions: {w}"),
                }
            }
            return Err(e);
        }
    };
    write_mesh(&a.output, &mesh, format)?;
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

fn perturb(mesh: &mut Mesh, a: &PerturbArgs) -> Result<()> {
    let Some(spec) = &a.perturb else { return Ok(()) };
    let perturbation: Perturbation = spec.parse()?;
    if !(a.fraction > 0.0 && a.fraction <= 1.0) {
        return Err(Error::InvalidArgument(format!(
            "--fraction must be in (0, 1], got {}",
            a.fraction
        )));
    }
    let stats = generate::perturb(
        mesh,
        &PerturbOptions {
            perturbation,
            fraction: a.fraction,
            seed: a.seed,
        },
    )?;
    println!(
        "perturbed {} vertices ({} shortened to keep elements valid)",
        stats.moved, stats.backtracked
    );
    Ok(())
}

fn positive(counts: &[usize], what: &str) -> Result<()> {
    if counts.contains(&0) {
        return Err(Error::InvalidArgument(format!(
            "{what} needs positive cell counts, got {counts:?}"
        )));
    }
    Ok(())
}

fn save(out: &OutputArgs, mesh: &Mesh) -> Result<()> {
    let format = output_format(&out.output, out.format.as_deref())?;
    write_mesh(&out.output, mesh, format)?;
    let kinds: Vec<String> = ElementKind::ALL
        .iter()
        .filter_map(|&k| match mesh.count_kind(k) {
            0 => None,
            n => Some(format!("{n} {k}")),
        })
        .collect();
    println!(
        "wrote {} ({} vertices; {})",
        out.output.display(),
        mesh.num_points(),
        kinds.join(", ")
    );
    Ok(())
}

pub fn generate(g: &GenerateCommand) -> Result<()> {
    match g {
        GenerateCommand::Box(a) => {
            positive(&a.cells, "--cells")?;
            let [nx, ny, nz] = [a.cells[0], a.cells[1], a.cells[2]];
            let lengths = [nx as f64, ny as f64, nz as f64];
            let mut mesh = if a.kind == "hex" {
                generate::hex_box(nx, ny, nz, lengths)
            } else {
                generate::tet_box(nx, ny, nz, lengths)
            };
            perturb(&mut mesh, &a.perturb)?;
            save(&a.out, &mesh)
        }
        GenerateCommand::Grid(a) => {
            positive(&a.cells, "--cells")?;
            let (nx, ny) = (a.cells[0], a.cells[1]);
            let lengths = [nx as f64, ny as f64];
            let mut mesh = if a.kind == "tri" {
                generate::tri_grid(nx, ny, lengths)
            } else {
                generate::quad_grid(nx, ny, lengths)
            };
            perturb(&mut mesh, &a.perturb)?;
            save(&a.out, &mesh)
        }
        GenerateCommand::Duct(a) => {
            positive(&[a.cells_across], "--cells-across")?;
            let mut mesh = generate::duct(a.cells_across);
            perturb(&mut mesh, &a.perturb)?;
            save(&a.out, &mesh)
        }
        GenerateCommand::Horseshoe(a) => {
            let kind: generate::HorseshoeKind = a.kind.parse()?;
            let (mesh, reference) = generate::horseshoe(kind, a.free.max(1));
            save(&a.out, &mesh)?;
            if let Some(r) = &a.reference_output {
                save(
                    &OutputArgs {
                        output: r.clone(),
                        format: a.out.format.clone(),
                    },
                    &reference,
                )?;
            }
            Ok(())
        }
        GenerateCommand::Prism(a) => save(&a.out, &generate::prism_mesh(a.distorted, a.seed)),
        GenerateCommand::Mixed(a) => {
            positive(&[a.cells, a.layers], "--cells and --layers")?;
            let mut mesh = generate::mixed_block(a.cells, a.layers);
            perturb(&mut mesh, &a.perturb)?;
            save(&a.out, &mesh)
        }
        GenerateCommand::Graded(a) => {
            positive(&[a.cells], "--cells")?;
            if !(a.ratio >= 1.0 && a.ratio.is_finite()) {
                return Err(Error::InvalidArgument(format!(
                    "--ratio must be at least 1, got {}",
                    a.ratio
                )));
            }
            let mut mesh = generate::graded_tet_box(a.cells, a.ratio);
            perturb(&mut mesh, &a.perturb)?;
            save(&a.out, &mesh)
        }
    }
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
        write_mesh(out, &mesh, Format::from_path(out)?)?;
        println!("wrote {}", out.display());
    }
    Ok(())
}

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
    let params = params(a.tol, a.max_iter, a.time_limit)?;
    let mesh = io::read(&a.input)?;
    let reference = a.objective.reference()?;
    let options = a.objective.options(reference.as_ref())?;
    let tets = mesh.kinds.iter().all(|&k| k == ElementKind::Tetrahedron);
    let mut where_ = format!("cpu (f64), {} threads", rayon::current_num_threads());
    let (cmp, infos) = if a.device == "gpu" {
        // every method needs a device version: check them all before running any
        for &m in &methods {
            device::gpu_allowed(m, a.objective.is_default() && tets)?;
        }
        let backend = device::choose("gpu", &a.precision, a.adapter.as_deref(), methods[0], true)?;
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
