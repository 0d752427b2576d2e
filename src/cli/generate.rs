//! `meshsmooth generate`: the test meshes of the papers, written to a file.

use super::outputs;
use super::{BoxType, GenerateCommand, GridType, OutputArgs, PerturbArgs};
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::{ElementKind, Error, Mesh, Result};
use std::path::Path;

pub(super) fn perturb(mesh: &mut Mesh, a: &PerturbArgs) -> Result<()> {
    let Some(spec) = &a.perturb else { return Ok(()) };
    let perturbation: Perturbation = spec.parse()?;
    if !(a.fraction > 0.0 && a.fraction <= 1.0) {
        return Err(Error::InvalidArgument(format!(
            "--fraction must be in (0, 1], got {}",
            a.fraction
        )));
    }
    let opts = PerturbOptions {
        perturbation,
        fraction: a.fraction,
        seed: a.seed,
    };
    if a.tangle {
        let stats = generate::perturb_unguarded(mesh, &opts)?;
        let bad = meshsmooth::metric::inverted_elements(mesh, &mesh.points).len();
        println!(
            "perturbed {} vertices without the inversion guard: {bad} of {} elements inverted",
            stats.moved,
            mesh.num_elements()
        );
        return Ok(());
    }
    let stats = generate::perturb(mesh, &opts)?;
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

/// Where the command's meshes go: the mesh, and the horseshoe's reference.
fn destinations(g: &GenerateCommand) -> (&OutputArgs, Option<&Path>) {
    match g {
        GenerateCommand::Box(a) => (&a.out, None),
        GenerateCommand::Grid(a) => (&a.out, None),
        GenerateCommand::Duct(a) => (&a.out, None),
        GenerateCommand::Horseshoe(a) => (&a.out, a.reference_output.as_deref()),
        GenerateCommand::Prism(a) => (&a.out, None),
        GenerateCommand::Graded(a) => (&a.out, None),
        GenerateCommand::BoundaryLayer(a) => (&a.out, None),
        GenerateCommand::Hetero(a) => (&a.out, None),
        GenerateCommand::Mixed(a) => (&a.out, None),
        GenerateCommand::Voronoi(a) => (&a.out, None),
    }
}

fn wrote(name: &str, mesh: &Mesh) {
    let kinds: Vec<String> = ElementKind::ALL
        .iter()
        .filter_map(|&k| match mesh.count_kind(k) {
            0 => None,
            n => Some(format!("{n} {k}")),
        })
        .collect();
    println!("wrote {name} ({} vertices; {})", mesh.num_points(), kinds.join(", "));
}

/// The outputs are checked before the mesh is made, and written together.
pub fn generate(g: &GenerateCommand) -> Result<()> {
    let (out, reference) = destinations(g);
    let mut checked = vec![("-o", out.output.as_path())];
    checked.extend(reference.map(|r| ("--reference-output", r)));
    outputs::check(None, &checked)?;
    let format = outputs::mesh_format("-o", &out.output, out.format.as_deref(), None)?;
    let reference_format = reference
        .map(|r| outputs::mesh_format("--reference-output", r, out.format.as_deref(), None))
        .transpose()?;
    let mut sink = outputs::MeshSink::open(&out.output)?;
    let mut reference_sink = reference.map(outputs::MeshSink::open).transpose()?;
    let (mesh, reference_mesh) = make(g)?;
    // asked for with --tangle: written without the quality field inverted elements lack
    let valid = |m: &Mesh| meshsmooth::metric::inverted_elements(m, &m.points).is_empty();
    let mut writes = outputs::Writes::default();
    writes.add(&out.output, || sink.stage(&mesh, format, valid(&mesh)));
    if let (Some(path), Some(rs), Some(rm), Some(rf)) = (
        reference,
        reference_sink.as_mut(),
        reference_mesh.as_ref(),
        reference_format,
    ) {
        writes.add(path, move || rs.stage(rm, rf, valid(rm)));
    }
    writes.run()?;
    wrote(&sink.name(), &mesh);
    if let (Some(rs), Some(rm)) = (&reference_sink, &reference_mesh) {
        wrote(&rs.name(), rm);
    }
    Ok(())
}

fn make(g: &GenerateCommand) -> Result<(Mesh, Option<Mesh>)> {
    match g {
        GenerateCommand::Box(a) => {
            positive(&a.cells, "--cells")?;
            let [nx, ny, nz] = [a.cells[0], a.cells[1], a.cells[2]];
            let lengths = [nx as f64, ny as f64, nz as f64];
            let mut mesh = if a.kind == BoxType::Hex {
                generate::hex_box(nx, ny, nz, lengths)
            } else {
                generate::tet_box(nx, ny, nz, lengths)
            };
            perturb(&mut mesh, &a.perturb)?;
            Ok((mesh, None))
        }
        GenerateCommand::Grid(a) => {
            positive(&a.cells, "--cells")?;
            let (nx, ny) = (a.cells[0], a.cells[1]);
            let lengths = [nx as f64, ny as f64];
            let mut mesh = if a.kind == GridType::Tri {
                generate::tri_grid(nx, ny, lengths)
            } else {
                generate::quad_grid(nx, ny, lengths)
            };
            perturb(&mut mesh, &a.perturb)?;
            Ok((mesh, None))
        }
        GenerateCommand::Duct(a) => {
            let mut mesh = if a.kuhn {
                positive(&[a.cells_across], "--cells-across")?;
                generate::duct(a.cells_across)
            } else {
                positive(&[a.vertices], "--vertices")?;
                generate::unstructured_duct(generate::duct_size_for(a.vertices))?
            };
            perturb(&mut mesh, &a.perturb)?;
            Ok((mesh, None))
        }
        GenerateCommand::Horseshoe(a) => {
            let (mesh, reference) = generate::horseshoe(a.kind, a.free.max(1));
            Ok((mesh, a.reference_output.is_some().then_some(reference)))
        }
        GenerateCommand::Prism(a) => Ok((generate::prism_mesh(a.distorted, a.seed), None)),
        GenerateCommand::Voronoi(a) => {
            let cells = [a.cells[0], a.cells[1], a.cells[2]];
            let opts = generate::VoronoiOptions {
                cells,
                bcc: a.bcc,
                jitter: a.jitter,
                lloyd: a.lloyd,
                smooth: a.smooth,
                distorted: a.distorted,
                wave: a.wave,
                noise: a.noise,
                seed: a.seed,
            };
            Ok((generate::voronoi_mesh(&opts)?, None))
        }
        GenerateCommand::Mixed(a) => {
            positive(&[a.cells, a.layers], "--cells and --layers")?;
            let mut mesh = generate::mixed_block(a.cells, a.layers);
            perturb(&mut mesh, &a.perturb)?;
            Ok((mesh, None))
        }
        GenerateCommand::Hetero(a) => {
            positive(&[a.tets], "--tets")?;
            let opts = generate::HeteroOptions::paper(a.paper as usize, a.tets);
            Ok((generate::hetero_tet_box(&opts), None))
        }
        GenerateCommand::Graded(a) => {
            positive(&[a.cells], "--cells")?;
            if !(a.ratio >= 1.0 && a.ratio.is_finite()) {
                return Err(Error::InvalidArgument(format!(
                    "--ratio must be at least 1, got {}",
                    a.ratio
                )));
            }
            let mut mesh = if a.aniso {
                generate::graded_tet_box_aniso(a.cells, a.ratio)
            } else {
                generate::graded_tet_box(a.cells, a.ratio)
            };
            perturb(&mut mesh, &a.perturb)?;
            Ok((mesh, None))
        }
        GenerateCommand::BoundaryLayer(a) => {
            positive(&[a.cells], "--cells")?;
            use generate::LayerKind;
            let kind = a
                .kind
                .unwrap_or(if a.dim == 2 { LayerKind::Quad } else { LayerKind::Hex });
            if kind.dim() != a.dim as usize {
                return Err(Error::InvalidArgument(format!(
                    "--kind {kind} is a {}D layer, not one for --dim {}",
                    kind.dim(),
                    a.dim
                )));
            }
            let mut mesh = generate::boundary_layer(kind, a.cells, a.first, a.growth, a.layers)?;
            perturb(&mut mesh, &a.perturb)?;
            Ok((mesh, None))
        }
    }
}
