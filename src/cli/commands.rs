//! The subcommands.

use super::brief;
use super::outputs;
use super::progress::{Log, Progress};
use super::{DemoArgs, ObjectiveArgs, QualityArgs, SmoothArgs, UntangleArgs};
use meshsmooth::Smoother;
use meshsmooth::backend::gpu::list_adapters;
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::io::{self, Format};
use meshsmooth::mesh::sweep_order::SweepOrder;
use meshsmooth::metric_report;
use meshsmooth::partition::{self, Partitioner};
use meshsmooth::report::quality_report;
use meshsmooth::smoother::Event;
use meshsmooth::solve::{self, Info, Method};
use meshsmooth::{Error, Mesh, Result, metric};
use std::path::Path;

pub(super) fn output_format(path: &Path, name: Option<&str>) -> Result<Format> {
    match name {
        Some(n) => Format::from_name(n).ok_or_else(|| {
            let names: Vec<&str> = Format::ALL.iter().map(|f| f.name()).collect();
            Error::InvalidArgument(format!("unknown format '{n}' (expected one of {})", names.join(", ")))
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

/// A partial result asked for by `--save-partial`: still tangled after a
/// failed untangling, it is written without the quality field (which
/// inverted elements lack).
fn write_partial(path: &Path, mesh: &Mesh, format: Format) -> Result<()> {
    if metric::inverted_elements(mesh, &mesh.points).is_empty() {
        io::write_mesh(path, mesh, format)
    } else {
        io::write(path, mesh, format, &[])
    }
}

fn params_strategy(o: &ObjectiveArgs) -> String {
    let inner = match o.inner_iterations {
        1 => String::new(),
        n => format!(", {n} inner iterations"),
    };
    match o.reorder_every {
        Some(k) => format!("dynamic, every {k} sweep(s){inner}"),
        None => format!("static{inner}"),
    }
}

/// The run in a line; `full` adds Newton's inner counts.
fn summary(info: &Info, f0: f64, full: bool) -> String {
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
    ) + &if full { newton_counts(info) } else { String::new() }
}

/// Where a Newton run's time went, for users tuning it: CG iterations, line
/// search trials and directions of negative curvature (empty for other methods).
fn newton_counts(info: &Info) -> String {
    match (
        info.cg_iterations,
        info.line_search_trials,
        info.negative_curvature_steps,
    ) {
        (Some(cg), Some(ls), Some(nc)) => {
            let sweeps = match info.start_sweeps {
                Some(n) if n > 0 => format!("{n} coloured BCD sweep(s) first, then "),
                _ => String::new(),
            };
            format!("; {sweeps}{cg} CG iterations, {ls} line-search trials, {nc} step(s) on negative curvature")
        }
        _ => String::new(),
    }
}

/// How much a command prints: the summary alone, a screenful, or every report.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum Verbosity {
    Quiet,
    Brief,
    Full,
}

impl Verbosity {
    pub(super) fn of(quiet: bool, verbose: bool) -> Verbosity {
        match (quiet, verbose) {
            (true, _) => Verbosity::Quiet,
            (false, false) => Verbosity::Brief,
            (false, true) => Verbosity::Full,
        }
    }
}

/// What the command line prints as a run goes: the reports before, the
/// untangling lines, the iterations (a bar on a terminal, a log otherwise).
struct Printer {
    say: Verbosity,
    max_iter: usize,
    progress: Option<Progress>,
}

impl Printer {
    fn new(say: Verbosity, max_iter: usize) -> Printer {
        Printer {
            say,
            max_iter,
            progress: None,
        }
    }

    fn event(&mut self, e: Event<'_>) -> bool {
        match e {
            Event::Start(start) => {
                for note in &start.notes {
                    eprintln!("note: {note}");
                }
                match self.say {
                    Verbosity::Quiet => {}
                    Verbosity::Brief => println!("{}", brief::start(start)),
                    Verbosity::Full => {
                        println!("== initial mesh ==\n{}", start.quality);
                        println!(
                            "{}",
                            brief::fixed_line(&start.fixed, start.quality.vertices, start.sliding.is_some())
                        );
                        for c in &start.rules {
                            println!("{}", brief::rule(c));
                        }
                        if let Some(note) = &start.targets {
                            println!("{note}\n");
                        }
                        if let Some(s) = &start.sliding {
                            println!(
                                "--boundary slide{} (feature angle {}°): {} vertices slide on boundary faces, {} along feature edges; {} corners fixed\n",
                                if s.geometry { " on the --surface geometry" } else { "" },
                                s.feature_angle,
                                s.surface,
                                s.edge,
                                s.corners
                            );
                        }
                    }
                }
            }
            Event::Untangling { inverted } if self.say > Verbosity::Quiet => println!(
                "the input is tangled ({inverted} inverted element(s)): untangling first (--no-untangle refuses instead)"
            ),
            Event::Untangled(info) => println!(
                "untangled {} inverted corner(s) in {} element(s) on {}: {} round(s) of eps, {} iteration(s), {:.3} s",
                info.inverted_corners_before,
                info.inverted_before,
                info.device,
                info.rounds,
                info.iterations,
                info.seconds
            ),
            Event::Iteration(r) => {
                let log = match self.say {
                    Verbosity::Quiet => Log::None,
                    Verbosity::Brief => Log::Slow,
                    Verbosity::Full => Log::Sparse,
                };
                let max_iter = self.max_iter;
                return self
                    .progress
                    .get_or_insert_with(|| Progress::new(max_iter, log))
                    .update(r);
            }
            _ => {}
        }
        true
    }

    fn finish(&mut self, last: Option<&solve::Record>) {
        if let Some(p) = &mut self.progress {
            p.finish(last);
        }
    }
}

/// Smooths `mesh` in place with `s`, printing as much as `say` asks.
fn run_smoother(mesh: &mut Mesh, s: &Smoother, objective: &ObjectiveArgs, say: Verbosity) -> Result<Info> {
    let mut printer = Printer::new(say, s.max_iter);
    let mut observer = |e: Event<'_>| printer.event(e);
    // under mpirun the smoothing is partitioned over the ranks (untangling stays on one)
    #[cfg(feature = "mpi")]
    let result = match super::ranks::cluster() {
        Some(c) => s.smooth_distributed(mesh, c, &mut observer),
        None => s.smooth_observed(mesh, &mut observer),
    };
    #[cfg(not(feature = "mpi"))]
    let result = s.smooth_observed(mesh, &mut observer);
    printer.finish(result.as_ref().ok().and_then(|r| r.info.history.last()));
    let report = result?;
    #[cfg(feature = "mpi")]
    if let Some(ranks) = report.ranks.as_ref().filter(|_| say > Verbosity::Quiet) {
        println!("\n{ranks}");
    }
    let info = &report.info;
    match say {
        Verbosity::Quiet => {}
        Verbosity::Brief => {
            println!("{}", brief::after(&report.quality));
            if let Some((before, after)) = &report.metric {
                println!("{}", brief::metric(before, after));
            }
            println!("{}", brief::moved(&report.displacement));
            if let Some(change) = &report.first_layer {
                println!("{change}");
            }
        }
        Verbosity::Full => {
            println!("\n== optimised mesh ==\n{}", report.quality);
            let d = report.displacement;
            match &report.metric {
                Some((before, after)) => {
                    let table = metric_report::Comparison {
                        before,
                        after,
                        displacement: Some(d),
                    };
                    println!("{table}");
                }
                None => println!(
                    "node displacement, % of the average local spacing: min {:.1}, avg {:.1}, max {:.1}\n",
                    d.min, d.avg, d.max
                ),
            }
            if let Some(change) = &report.first_layer {
                println!("{change}\n");
            }
        }
    }
    let f0 = info.history.first().map_or(info.objective, |r| r.objective);
    println!("{}", summary(info, f0, say == Verbosity::Full));
    if let Some(order) = s.order.sweep() {
        if info.reorderings > 0 {
            println!(
                "order {} ({}): COT {:.3} s, RT {:.3} s, TT {:.3} s; {} reordering(s)",
                order.paper_name(),
                params_strategy(objective),
                info.optimise_seconds,
                info.reorder_seconds,
                info.seconds,
                info.reorderings
            );
        } else if say > Verbosity::Quiet && order != SweepOrder::N {
            println!(
                "note: --order {} orders the sequential sweep (--method bcd on the CPU); {} ran in the input numbering",
                order.name(),
                info.method
            );
        }
    }
    Ok(report.info)
}

/// `meshsmooth untangle`: the untangling phase alone.
pub fn untangle(a: &UntangleArgs) -> Result<()> {
    outputs::check(Some(&a.input), &[("-o", &a.output)])?;
    let format = outputs::mesh_format("-o", &a.output, a.format.as_deref(), Some(&a.input))?;
    let settings = a.solver.smoother(true, a.save_partial)?;
    if a.save_partial && outputs::is_stdout(&a.output) {
        return Err(Error::InvalidArgument(
            "--save-partial writes NAME.partial.EXT beside the output: give -o a file, not standard output".into(),
        ));
    }
    let mut sink = outputs::MeshSink::open(&a.output)?;
    let mut mesh = io::read(&a.input)?;
    if a.drop_data {
        mesh.data = Default::default();
    }
    let start = mesh.points.clone();
    let run = |mesh: &mut Mesh| -> Result<Option<solve::UntangleInfo>> {
        let mut printer = Printer::new(Verbosity::of(a.quiet, a.verbose), settings.max_iter);
        let report = settings.untangle_observed(mesh, &mut |e| printer.event(e))?;
        match Verbosity::of(a.quiet, a.verbose) {
            _ if report.untangled.is_none() => {}
            Verbosity::Quiet => {}
            Verbosity::Brief => println!("{}", brief::after(&report.quality)),
            Verbosity::Full => println!("\n== untangled mesh ==\n{}", report.quality),
        }
        Ok(report.untangled)
    };
    match run(&mut mesh).map_err(|e| io::in_file(&a.input, e)) {
        Ok(None) => println!("{}: no inverted elements; written unchanged", a.input.display()),
        Ok(Some(_)) => {}
        Err(e) => {
            if a.save_partial && mesh.points != start {
                let partial = partial_path(&a.output);
                match write_partial(&partial, &mesh, format) {
                    Ok(()) => eprintln!("saved the last positions (still tangled) to {}", partial.display()),
                    Err(w) => eprintln!("could not save partial positions: {w}"),
                }
            }
            return Err(e);
        }
    }
    sink.stage(&mesh, format, true)?.commit()?;
    if !a.quiet {
        println!("wrote {}", sink.name());
    }
    Ok(())
}

pub fn smooth(a: &SmoothArgs) -> Result<()> {
    let settings = a.solver.smoother(!a.no_untangle, a.save_partial)?;
    let mut checked = vec![("-o", a.output.as_path())];
    if let Some(h) = &a.history {
        checked.push(("--history", h.as_path()));
    }
    outputs::check(Some(&a.input), &checked)?;
    let pieces = pieces_wanted(&a.output, a.pieces)?;
    let format = match pieces {
        Some(_) => piece_format(a.format.as_deref())?,
        None => outputs::mesh_format("-o", &a.output, a.format.as_deref(), Some(&a.input))?,
    };
    if let Some(count) = pieces {
        refuse_overwriting_pieces(&a.input, &a.output, count)?;
    }
    if a.save_partial && outputs::is_stdout(&a.output) {
        return Err(Error::InvalidArgument(
            "--save-partial writes NAME.partial.EXT beside the output: give -o a file, not standard output".into(),
        ));
    }
    #[cfg(feature = "mpi")]
    super::ranks::set_partitioner(a.partitioner);
    #[cfg(feature = "mpi")]
    if a.partitioner == Partitioner::Pieces {
        return smooth_pieces(a, &settings, pieces, format);
    }
    let mut sink = outputs::MeshSink::open(&a.output)?;
    let began = std::time::Instant::now();
    settings.prepare();
    #[cfg(feature = "mpi")]
    let mut mesh = read_on_ranks(&a.input, a.quiet)?;
    #[cfg(not(feature = "mpi"))]
    let mut mesh = io::read(&a.input)?;
    let read_s = began.elapsed().as_secs_f64();
    if a.drop_data {
        mesh.data = Default::default();
    }
    let start = mesh.points.clone();
    let say = Verbosity::of(a.quiet, a.verbose);
    let solved = run_smoother(&mut mesh, &settings, &a.solver.objective, say).map_err(|e| io::in_file(&a.input, e));
    let info = match solved {
        Ok(info) => info,
        Err(e) => {
            if a.save_partial && mesh.points != start {
                let mut partial = partial_path(&a.output);
                if pieces.is_some() {
                    partial.set_extension("vtu");
                }
                match write_partial(&partial, &mesh, format) {
                    Ok(()) => eprintln!("saved the last positions to {}", partial.display()),
                    Err(w) => eprintln!("could not save partial positions: {w}"),
                }
            }
            return Err(e);
        }
    };
    // every output staged before any is put in place: all of them or none
    let writing = std::time::Instant::now();
    let mut writes = outputs::Writes::default();
    if let Some(h) = &a.history {
        let csv = info.history.to_csv();
        writes.add(h, move || outputs::stage_text(h, csv));
    }
    if pieces.is_none() {
        writes.add(&a.output, || sink.stage(&mesh, format, true));
    }
    let staged = writes.stage()?;
    if let Some(count) = pieces {
        let (owner, count) = piece_owners(&mesh, count, a.partitioner)?;
        #[cfg(feature = "mpi")]
        let (written, by) = match super::ranks::cluster().filter(|c| c.size() > 1) {
            Some(c) => {
                let mut writer = c.piece_writer();
                let written = io::write_mesh_pieces_with(&a.output, &mesh, &owner, count, format, &mut writer)?;
                (written, Some(writer.ranks))
            }
            None => (io::write_mesh_pieces(&a.output, &mesh, &owner, count, format)?, None),
        };
        #[cfg(not(feature = "mpi"))]
        let (written, by): (_, Option<Vec<usize>>) =
            (io::write_mesh_pieces(&a.output, &mesh, &owner, count, format)?, None);
        if !a.quiet {
            println!(
                "wrote {} pieces ({} to {})",
                written.len(),
                written[0].display(),
                written[written.len() - 1].display()
            );
            if let Some(by) = by {
                println!("pieces written by ranks {}; the index by rank 0", list(&by));
            }
        }
    }
    staged.commit()?;
    if !a.quiet {
        println!("wrote {}", sink.name());
        println!(
            "{}",
            timings(
                read_s,
                &info,
                writing.elapsed().as_secs_f64(),
                began.elapsed().as_secs_f64()
            )
        );
    }
    Ok(())
}

/// Where a command's time went: the file, the problem's setup, the solve,
/// the output, the rest (checks, the default targets' tests, starting a GPU,
/// untangling, reports), and the whole.
fn timings(read: f64, info: &Info, write: f64, total: f64) -> String {
    let rest = (total - read - info.setup_seconds - info.seconds - write).max(0.0);
    format!(
        "time: read {read:.3} s, setup {:.3} s, solve {:.3} s, write {write:.3} s, other {rest:.3} s; {total:.3} s in all",
        info.setup_seconds, info.seconds
    )
}

fn is_pvtu(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("pvtu"))
}

/// `Some(count)` when the output is a .pvtu index with pieces (`None`: as
/// many as the partition has parts).
fn pieces_wanted(output: &Path, pieces: Option<Option<usize>>) -> Result<Option<Option<usize>>> {
    let pvtu = output.extension().is_some_and(|e| e.eq_ignore_ascii_case("pvtu"));
    match (pvtu, pieces) {
        (_, Some(Some(0))) => Err(Error::InvalidArgument("--pieces must be at least 1".into())),
        (true, p) => Ok(Some(p.flatten())),
        (false, Some(_)) => Err(Error::InvalidArgument(format!(
            "--pieces writes a .pvtu index and .vtu pieces beside it: give -o NAME.pvtu (not {})",
            output.display()
        ))),
        (false, None) => Ok(None),
    }
}

/// Refuses pieces that would replace the input or, when it is a .pvtu, one
/// of its pieces (checked before the solve, so no work is lost to it).
fn refuse_overwriting_pieces(input: &Path, output: &Path, count: Option<usize>) -> Result<()> {
    #[cfg(feature = "mpi")]
    let count = count.unwrap_or(super::ranks::size());
    #[cfg(not(feature = "mpi"))]
    let count = count.unwrap_or(1);
    let mut inputs = vec![input.to_path_buf()];
    if is_pvtu(input)
        && let Ok(data) = std::fs::read(input)
    {
        inputs.extend(io::piece_paths(input, &data).unwrap_or_default());
    }
    for r in 0..count {
        let piece = io::piece_path(output, r);
        if let Some(i) = inputs.iter().find(|i| io::same_file(i, &piece)) {
            return Err(Error::InvalidArgument(format!(
                "output piece {} is the input {}; meshsmooth never overwrites its input",
                piece.display(),
                i.display()
            )));
        }
    }
    Ok(())
}

/// The pieces' format: VTK XML, ASCII unless --format names another VTU encoding.
fn piece_format(name: Option<&str>) -> Result<Format> {
    match name.map(Format::from_name) {
        None => Ok(Format::VtuAscii),
        Some(Some(f @ (Format::VtuAscii | Format::VtuBinary | Format::VtuZlib))) => Ok(f),
        Some(_) => Err(Error::InvalidArgument(format!(
            "--format {}: .pvtu pieces are .vtu files (vtu, vtu-binary or vtu-zlib)",
            name.unwrap_or_default()
        ))),
    }
}

/// The owner of each vertex for the pieces, and their count: the partitioned
/// solve's own partition when there was one with that many parts, else a new
/// one by `partitioner`.
fn piece_owners(mesh: &Mesh, count: Option<usize>, partitioner: Partitioner) -> Result<(Vec<u32>, usize)> {
    #[cfg(feature = "mpi")]
    if let Some(report) = super::ranks::report()
        && count.is_none_or(|c| c == report.ranks.len())
        && report.owner.len() == mesh.num_points()
    {
        return Ok((report.owner, report.ranks.len()));
    }
    #[cfg(feature = "mpi")]
    let count = count.unwrap_or(super::ranks::size());
    #[cfg(not(feature = "mpi"))]
    let count = count.unwrap_or(1);
    Ok((partition::mesh_owners(mesh, count, partitioner)?, count))
}

/// Numbers separated by commas.
fn list(items: &[usize]) -> String {
    items.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")
}

/// `smooth --partitioner pieces`: the ranks smooth the input's pieces, each
/// setting up its own part (`Cluster::smooth_pieces`); rank 0 never holds
/// the whole mesh unless the output is one file.
#[cfg(feature = "mpi")]
fn smooth_pieces(a: &SmoothArgs, settings: &Smoother, pieces: Option<Option<usize>>, format: Format) -> Result<()> {
    let refuse = |what: &str| Err(Error::Unsupported(format!("--partitioner pieces: {what}")));
    let Some(cluster) = super::ranks::cluster().filter(|c| c.size() > 1 && is_pvtu(&a.input)) else {
        return refuse(
            "the parts are a .pvtu input's pieces: give a .pvtu input and run under mpirun on 2 or more ranks",
        );
    };
    let data = std::fs::read(&a.input).map_err(|e| Error::io(&a.input, e))?;
    let sources = io::piece_paths(&a.input, &data)?;
    if let Some(Some(c)) = pieces
        && c != sources.len()
    {
        return refuse(&format!(
            "the output has the input's {} pieces (--pieces {c} needs --partitioner metis or rcb)",
            sources.len()
        ));
    }
    let rules = settings.rules()?;
    if settings.boundary_mode() != meshsmooth::problem::BoundaryMode::Fixed
        || settings.reference.is_some()
        || settings.target.starts_with("reference:")
        || !(rules.fix_groups.is_empty() && rules.fixed_arrays.is_empty() && rules.fixed_ids.is_empty())
        || a.drop_data
        || a.save_partial
    {
        return refuse(
            "only the fixed boundary, the ideal targets and the file's own fixed flags (no --boundary slide, --surface, --reference, --fix-*, --drop-data or --save-partial)",
        );
    }
    let objective = settings.problem_options(None, None)?;
    let params = settings.params()?;
    let (backend, note) = settings.backend(&[settings.method])?;
    if let Some(note) = note {
        eprintln!("note: {note}");
    }
    let job = solve::pieces::PiecesJob {
        index: a.input.clone(),
        sources,
        method: a.solver.method,
        params: params.clone(),
        metric: objective.metric,
        template: objective.template,
        ordering: objective.ordering.to_string(),
        target: settings.target.clone(),
        order_seed: objective.order_seed,
        output: a.output.clone(),
        format,
        pieces: pieces.is_some(),
        gpu: settings.rank_gpu(&backend),
    };
    let mut progress = Progress::new(params.max_iter, if a.quiet { Log::None } else { Log::Sparse });
    let result = cluster.smooth_pieces(&job, &mut |r| progress.update(r));
    progress.finish(result.as_ref().ok().and_then(|o| o.info.history.last()));
    let out = result.map_err(|e| io::in_file(&a.input, e))?;
    if !a.quiet {
        let f0 = out.info.history.first().map_or(out.info.objective, |r| r.objective);
        println!(
            "note: the {} pieces of {} were read by ranks {} (in piece order); each rank set up its own part from them",
            out.readers.len(),
            a.input.display(),
            list(&out.readers)
        );
        println!("{}", summary(&out.info, f0, true));
        println!("\n{}", out.report);
        if pieces.is_some() {
            println!(
                "wrote {} pieces ({} to {})",
                out.written.len() - 1,
                out.written[0].display(),
                out.written[out.written.len() - 2].display()
            );
            println!("pieces written by ranks {}; the index by rank 0", list(&out.readers));
        }
    }
    if let Some(h) = &a.history {
        io::write_atomic(h, |w| Ok(w.write_all(out.info.history.to_csv().as_bytes())?))?;
    }
    if !a.quiet {
        println!("wrote {}", a.output.display());
    }
    Ok(())
}

/// The input; under mpirun a .pvtu's pieces are read by the ranks (see
/// `Cluster::read_pieces`) and merged on rank 0, which says so.
#[cfg(feature = "mpi")]
fn read_on_ranks(input: &Path, quiet: bool) -> Result<Mesh> {
    let Some(cluster) = super::ranks::cluster().filter(|c| c.size() > 1 && is_pvtu(input)) else {
        return io::read(input);
    };
    let mut readers = Vec::new();
    let mesh = io::read_pvtu_with(input, &mut |sources| {
        readers = (0..sources.len())
            .map(|i| solve::distributed::piece_reader(i, sources.len(), cluster.size()))
            .collect();
        cluster.read_pieces(input, sources)
    })?;
    if !quiet && !readers.is_empty() {
        println!(
            "note: the {} pieces of {} were read by ranks {} (in piece order) and merged on rank 0 by their global ids; the {} ranks get their parts from the partitioner, not from the pieces",
            readers.len(),
            input.display(),
            list(&readers),
            cluster.size()
        );
    }
    Ok(mesh)
}

pub fn quality(a: &QualityArgs) -> Result<()> {
    let mesh = io::read(&a.input)?;
    match mesh.unused_vertices().len() {
        0 => {}
        1 => eprintln!("note: 1 point is used by no element: it takes no part in the measures"),
        n => eprintln!("note: {n} points are used by no element: they take no part in the measures"),
    }
    // what smooth refuses is not measured either: a planar mesh without area
    // has no orientation to tell inverted elements by (one that is not flat
    // is a surface, each element measured in its own plane)
    let in_use = mesh.without_unused();
    let measured = in_use.as_ref().map_or(&mesh, |(_, m)| m);
    if !meshsmooth::mesh::plane::is_surface(measured, &measured.points) {
        meshsmooth::mesh::plane::Plane::fit(measured, &measured.points).map_err(|e| io::in_file(&a.input, e))?;
    }
    let report = quality_report(&mesh, &mesh.points);
    let target = meshsmooth::problem::Target::parse(&a.target)?;
    let before = match &a.before {
        Some(path) => {
            let before = io::read(path)?;
            meshsmooth::problem::same_connectivity(&mesh, &before, "it", "it").map_err(|e| match e {
                Error::InvalidArgument(why) => Error::InvalidArgument(format!(
                    "--before {} does not have the connectivity of {}: {why}",
                    path.display(),
                    a.input.display()
                )),
                other => other,
            })?;
            Some(before)
        }
        None => None,
    };
    let targets = match &before {
        Some(b) => meshsmooth::metric_report::target_report(b, Some(&mesh.points), target)?,
        None => meshsmooth::metric_report::target_report(&mesh, None, target)?,
    };
    if a.json {
        #[derive(serde::Serialize)]
        struct Out<'a> {
            #[serde(flatten)]
            quality: &'a meshsmooth::report::QualityReport,
            #[serde(skip_serializing_if = "Option::is_none")]
            targets: Option<&'a meshsmooth::metric_report::TargetReport>,
        }
        let out = Out {
            quality: &report,
            targets: targets.as_ref(),
        };
        println!("{}", serde_json::to_string_pretty(&out).expect("report serialises"));
    } else {
        println!("{}\n{report}", a.input.display());
        let intent = meshsmooth_intent(&mesh)?;
        println!("anisotropy: {}", intent.describe());
        if let Some(t) = &targets {
            print!("{t}");
        }
    }
    Ok(())
}

fn meshsmooth_intent(mesh: &Mesh) -> Result<meshsmooth::problem::targets::Intent> {
    meshsmooth::problem::targets::intent(mesh, &mesh.points)
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
    let settings = a.solver.smoother(true, false)?;
    let format = match &a.output {
        Some(out) => {
            outputs::check(None, &[("-o", out)])?;
            Some(Format::from_path(out)?)
        }
        None => None,
    };
    run_smoother(
        &mut mesh,
        &settings,
        &a.solver.objective,
        Verbosity::of(false, a.verbose),
    )?;
    if let (Some(out), Some(format)) = (&a.output, format) {
        io::write_mesh(out, &mesh, format)?;
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
