//! `meshsmooth generate`: the test meshes of the papers, written to a file.

use super::commands::output_format;
use super::{BoxType, GenerateCommand, GridType, OutputArgs, PerturbArgs};
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::io::write_mesh;
use meshsmooth::{ElementKind, Error, Mesh, Result};

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

fn save(out: &OutputArgs, mesh: &Mesh) -> Result<()> {
    let format = output_format(&out.output, out.format.as_deref())?;
    if meshsmooth::metric::inverted_elements(mesh, &mesh.points).is_empty() {
        write_mesh(&out.output, mesh, format)?;
    } else {
        // asked for with --tangle: written without the quality field inverted elements lack
        meshsmooth::io::write(&out.output, mesh, format, &[])?;
    }
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
            let mut mesh = if a.kind == BoxType::Hex {
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
            let mut mesh = if a.kind == GridType::Tri {
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
            let (mesh, reference) = generate::horseshoe(a.kind, a.free.max(1));
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
            save(&a.out, &generate::voronoi_mesh(&opts)?)
        }
        GenerateCommand::Mixed(a) => {
            positive(&[a.cells, a.layers], "--cells and --layers")?;
            let mut mesh = generate::mixed_block(a.cells, a.layers);
            perturb(&mut mesh, &a.perturb)?;
            save(&a.out, &mesh)
        }
        GenerateCommand::Hetero(a) => {
            positive(&[a.tets], "--tets")?;
            let opts = generate::HeteroOptions::paper(a.paper as usize, a.tets);
            save(&a.out, &generate::hetero_tet_box(&opts))
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
            save(&a.out, &mesh)
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
            save(&a.out, &mesh)
        }
    }
}
