//! Which cases the study runs (the paper's Table 2 over the meshes and sizes
//! asked) and their initial meshes: as generated, perturbed (6.3) or
//! renumbered red-black (6.8).

use super::OrderStudyOptions;
use crate::error::Result;
use crate::generate::{HorseshoeKind, PerturbOptions, Perturbation, horseshoe, perturb};
use crate::mesh::Mesh;
use crate::mesh::order::red_black;
use crate::mesh::topology::{fixed_vertices, vertex_neighbours};
use serde::Serialize;

/// Amplitude of the perturbed initial mesh (6.3), in mean edge lengths; a
/// move that would invert an element is halved until it does not, so this
/// is "as far as possible without inverting" for most vertices.
pub const PERTURBATION: f64 = 0.5;

/// The paper's experiments (its section numbers).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub enum Experiment {
    /// 6.2, 6.4, 6.5: static and dynamic at each frequency (always run).
    Main,
    /// 6.3: a second, perturbed initial mesh.
    Perturbed,
    /// 6.6: one more Newton step per vertex visit.
    InnerIterations,
    /// 6.7: a target from a baseline a fifth as long.
    Inaccurate,
    /// 6.8: the initial mesh renumbered red-black.
    RedBlack,
}

impl Experiment {
    /// The experiments besides the main one.
    pub const EXTRA: [Experiment; 4] = [
        Experiment::Perturbed,
        Experiment::InnerIterations,
        Experiment::Inaccurate,
        Experiment::RedBlack,
    ];

    /// The paper's section.
    pub fn section(self) -> &'static str {
        match self {
            Experiment::Main => "6.2, 6.4, 6.5",
            Experiment::Perturbed => "6.3",
            Experiment::InnerIterations => "6.6",
            Experiment::Inaccurate => "6.7",
            Experiment::RedBlack => "6.8",
        }
    }

    /// The name in the CSV and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Experiment::Main => "main",
            Experiment::Perturbed => "perturbed",
            Experiment::InnerIterations => "inner",
            Experiment::Inaccurate => "inaccurate",
            Experiment::RedBlack => "red-black",
        }
    }

    pub fn title(self) -> &'static str {
        match self {
            Experiment::Main => "static and dynamic",
            Experiment::Perturbed => "perturbed initial mesh",
            Experiment::InnerIterations => "inner iterations",
            Experiment::Inaccurate => "inaccurate target",
            Experiment::RedBlack => "red-black initial order",
        }
    }
}

/// How a case's initial mesh differs from the generated one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Variant {
    Generated,
    Perturbed,
    RedBlack,
}

/// What identifies an initial mesh (and, with the target's length, a baseline).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MeshKey {
    pub kind: HorseshoeKind,
    pub free: usize,
    pub variant: Variant,
}

/// One case to run.
#[derive(Clone, Debug)]
pub struct CaseSpec {
    pub experiment: Experiment,
    pub kind: HorseshoeKind,
    /// Free vertices asked for.
    pub free: usize,
    pub inner_iterations: usize,
    /// The target comes from a baseline a fifth as long.
    pub inaccurate: bool,
    /// `None` static, `Some(k)` every k sweeps.
    pub strategies: Vec<Option<usize>>,
}

impl CaseSpec {
    pub fn mesh_key(&self) -> MeshKey {
        MeshKey {
            kind: self.kind,
            free: self.free,
            variant: match self.experiment {
                Experiment::Perturbed => Variant::Perturbed,
                Experiment::RedBlack => Variant::RedBlack,
                _ => Variant::Generated,
            },
        }
    }

    fn suffix(&self) -> &'static str {
        match self.experiment {
            Experiment::Main => "",
            Experiment::Perturbed => "perturbed",
            Experiment::InnerIterations => "inner",
            Experiment::Inaccurate => "inaccurate",
            Experiment::RedBlack => "red-black",
        }
    }

    /// "SQIV 200", "SQI 200 perturbed", "SQII 200 inner 2".
    pub fn name(&self) -> String {
        let mut s = format!("{} {}", self.kind.name().to_uppercase(), self.free);
        match self.experiment {
            Experiment::Main => {}
            Experiment::InnerIterations => s += &format!(" inner {}", self.inner_iterations),
            _ => s += &format!(" {}", self.suffix()),
        }
        s
    }

    /// The name in file-name form: "sqiv-200", "sqi-200-perturbed".
    pub fn slug(&self) -> String {
        self.name().to_lowercase().replace(' ', "-")
    }
}

/// The cases of `opts`, in the order they run: the main experiment on every
/// mesh type and size, then each extra experiment asked.
pub fn cases(opts: &OrderStudyOptions) -> Vec<CaseSpec> {
    let mut sizes = opts.sizes.clone();
    sizes.sort_unstable();
    sizes.dedup();
    let largest = sizes.last().copied().unwrap_or(0);
    let inner = opts.inner_iterations.max(1);
    let mut every: Vec<Option<usize>> = vec![None];
    every.extend(opts.every.iter().map(|&k| Some(k.max(1))));
    every.dedup();
    let spec = |experiment, kind, free, strategies: Vec<Option<usize>>| CaseSpec {
        experiment,
        kind,
        free,
        inner_iterations: if experiment == Experiment::InnerIterations {
            inner + 1
        } else {
            inner
        },
        inaccurate: experiment == Experiment::Inaccurate,
        strategies,
    };
    let mut out = Vec::new();
    for &kind in &opts.meshes {
        for &free in &sizes {
            out.push(spec(Experiment::Main, kind, free, every.clone()));
        }
    }
    let dynamic = vec![Some(1)];
    for &e in &Experiment::EXTRA {
        if !opts.experiments.contains(&e) || opts.meshes.is_empty() {
            continue;
        }
        match e {
            Experiment::Perturbed => {
                let kind = if opts.meshes.contains(&HorseshoeKind::SqI) {
                    HorseshoeKind::SqI
                } else {
                    opts.meshes[0]
                };
                out.push(spec(e, kind, largest, vec![None, Some(1)]));
            }
            Experiment::InnerIterations => {
                for &kind in &opts.meshes {
                    out.push(spec(e, kind, largest, dynamic.clone()));
                }
            }
            Experiment::Inaccurate => {
                for &kind in &opts.meshes {
                    for &free in &sizes {
                        out.push(spec(e, kind, free, dynamic.clone()));
                    }
                }
            }
            Experiment::RedBlack => {
                for &kind in opts.meshes.iter().filter(|k| is_quadrilateral(**k)) {
                    out.push(spec(e, kind, largest, dynamic.clone()));
                }
            }
            Experiment::Main => {}
        }
    }
    out
}

/// The structured quadrilateral types: the red-black experiment's meshes
/// (on triangles the parity split is no checkerboard).
pub fn is_quadrilateral(kind: HorseshoeKind) -> bool {
    matches!(kind, HorseshoeKind::SqI | HorseshoeKind::SqII | HorseshoeKind::SqIV)
}

/// The mesh to optimise and its reference (the targets), in the same numbering.
pub fn initial_mesh(key: &MeshKey, seed: u64) -> Result<(Mesh, Mesh)> {
    let (mut mesh, mut reference) = horseshoe(key.kind, key.free);
    match key.variant {
        Variant::Generated => {}
        Variant::Perturbed => {
            perturb(
                &mut mesh,
                &PerturbOptions {
                    perturbation: Perturbation::Random { alpha: PERTURBATION },
                    fraction: 1.0,
                    seed,
                },
            )?;
        }
        Variant::RedBlack => {
            // the same coordinates, the vertices renumbered: the checkerboard
            // of a structured grid, both colours in the generator's order
            let order = red_black(&vertex_neighbours(&mesh));
            mesh = renumbered(&mesh, &order);
            reference = renumbered(&reference, &order);
        }
    }
    Ok((mesh, reference))
}

/// `mesh` with vertex `order[new]` numbered `new` (a generated mesh: points
/// and elements only).
fn renumbered(mesh: &Mesh, order: &[u32]) -> Mesh {
    let mut new_id = vec![0u32; order.len()];
    for (new, &old) in order.iter().enumerate() {
        new_id[old as usize] = new as u32;
    }
    Mesh {
        points: order.iter().map(|&v| mesh.points[v as usize]).collect(),
        conn: mesh.conn.iter().map(|&v| new_id[v as usize]).collect(),
        ..mesh.clone()
    }
}

pub fn free_vertices(mesh: &Mesh) -> usize {
    fixed_vertices(mesh).iter().filter(|&&f| !f).count()
}
