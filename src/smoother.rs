//! The one entry that owns the rules of smoothing: [`Smoother`].
//!
//! Every front end (the command line, Python, a library caller) fills in
//! the same settings and calls [`Smoother::smooth`] or [`Smoother::untangle`];
//! the checks, the defaults, the device choice, the fixed-vertex rules, the
//! default targets and the untangle-then-smooth sequence live here once.
//!
//! ```
//! use meshsmooth::{Smoother, generate};
//! let mut mesh = generate::tet_box(3, 3, 3, [1.0, 1.0, 1.0]);
//! let opts = generate::PerturbOptions {
//!     perturbation: generate::Perturbation::Random { alpha: 0.3 },
//!     fraction: 1.0,
//!     seed: 1,
//! };
//! generate::perturb(&mut mesh, &opts)?;
//! let mut smoother = Smoother::default();
//! smoother.device = meshsmooth::DeviceChoice::Cpu;
//! let report = smoother.smooth(&mut mesh)?;
//! assert!(report.quality.eta.avg < report.start.quality.eta.avg);
//! # Ok::<(), meshsmooth::Error>(())
//! ```

#[cfg(feature = "gpu")]
use crate::backend::gpu::{self, GpuContext, GpuOptions};
use crate::backend::settings::Precision;
use crate::error::{Error, Result};
use crate::mesh::fixing::{FixRules, RuleCount};
use crate::mesh::topology;
use crate::metric::corner_model::Template;
use crate::metric::smetric::MetricKind;
use crate::metric_report::{self, MetricSummary, SpacingDisplacement};
use crate::problem::boundary::VertexClass;
use crate::problem::targets::{LayerChange, first_layer_change_on_skin};
use crate::problem::{Boundary, BoundaryMode, Ordering, ProblemOptions, Target};
use crate::report::{QualityReport, quality_report_on_skin};
use crate::solve::newton::NewtonParams;
use crate::solve::pcg::{NegativeCurvature, Preconditioner};
use crate::solve::{self, Device, Info, Method, Params, Record, UntangleInfo, UntangleParams};
use crate::{Mesh, io, metric};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Where a run goes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[non_exhaustive]
pub enum DeviceChoice {
    /// A hardware GPU when there is one and every method of the run has a GPU
    /// version; else the CPU. Software adapters (lavapipe, llvmpipe) emulate
    /// a GPU on the CPU and are slower than the CPU backend, so `auto` passes
    /// them over unless an adapter is named.
    #[default]
    Auto,
    /// The f64 reference backend on all cores.
    Cpu,
    /// wgpu (block coordinate descent runs colour by colour there).
    Gpu,
}

crate::error::by_name!(DeviceChoice: "device" { Auto = "auto", Cpu = "cpu", Gpu = "gpu" });

/// Everything a smoothing run is told: what to optimise, how, where and
/// which vertices stay. `Default` is the command line's default; the field
/// names are the keys of a settings file (`Smoother::from_toml`,
/// `from_json`) and the keyword arguments of the Python `smooth`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
#[non_exhaustive]
pub struct Smoother {
    /// The optimiser.
    #[serde(with = "by_name")]
    pub method: Method,
    /// Where it runs: `auto`, `cpu` or `gpu`.
    #[serde(with = "by_name")]
    pub device: DeviceChoice,
    /// GPU arithmetic (f64 needs the adapter's `SHADER_F64`).
    #[serde(with = "by_name")]
    pub precision: Precision,
    /// The GPU adapter whose name contains this (else `MESHSMOOTH_ADAPTER`).
    pub adapter: Option<String>,
    /// Stop when |∇F|, lengths in mean edge lengths, is below this.
    pub tol: f64,
    /// NLCG: stop after a step that moved no vertex farther than this many mean edge lengths.
    pub tol_x: f64,
    /// Most sweeps (BCD, Laplace) or iterations (Newton, NLCG).
    pub max_iter: usize,
    /// Seconds per method; the mesh so far is kept (it is always valid).
    pub time_limit: Option<f64>,
    /// Stop as soon as F is at or below this.
    pub target_objective: Option<f64>,
    /// The corner metric; `None`: the targets' default (inverse mean ratio,
    /// or shape+size with constructed targets).
    #[serde(with = "by_name_opt")]
    pub metric: Option<MetricKind>,
    /// How corner values are combined into the objective (harmonic or average).
    #[serde(with = "by_name")]
    pub template: Template,
    /// The targets W: `auto`, `ideal`, `input`, `size:FIELD`, `metric:FIELD`
    /// or `reference:MESH` (a file, read when the run starts).
    pub target: String,
    /// A reference mesh file with the input's connectivity (its corners are the targets).
    pub reference: Option<PathBuf>,
    /// The vertex order (`rbfs`, `cuthill-mckee`, `red-black`, or a
    /// reordering-paper scheme for the sequential sweep).
    #[serde(with = "by_name")]
    pub order: Ordering,
    /// Seed of the random orders.
    pub order_seed: u64,
    /// Dynamic reordering of the sequential sweep every this many sweeps.
    pub reorder_every: Option<usize>,
    /// Newton steps per vertex visit of the sequential sweep.
    pub inner_iterations: usize,
    /// What skin vertices may do: stay fixed, or slide on the boundary.
    #[serde(with = "by_name")]
    pub boundary: BoundaryMode,
    /// Degrees: with a sliding boundary, faces meeting at more than this
    /// form a feature edge.
    pub feature_angle: f64,
    /// Gmsh physical groups (name or number) whose vertices are fixed.
    pub fix_groups: Vec<String>,
    /// Gmsh physical groups whose boundary cells do not fix their vertices.
    pub free_groups: Vec<String>,
    /// Point-data arrays: a vertex where one is non-zero is fixed.
    pub fixed_arrays: Vec<String>,
    /// Files of 0-based vertex ids to fix.
    pub fixed_files: Vec<PathBuf>,
    /// Untangle a tangled input first (else it is refused).
    pub untangle: bool,
    /// On a failure midway, leave the last feasible (or, untangling, the
    /// last) positions in the mesh instead of the input's.
    pub keep_partial: bool,
    /// Newton: CG's answer on negative curvature.
    #[serde(with = "by_name")]
    pub negative_curvature: NegativeCurvature,
    /// Newton: CG's preconditioner.
    #[serde(with = "by_name")]
    pub preconditioner: Preconditioner,
    /// Newton: after a trial step that inverts an element, try this fraction
    /// of the distance to the first inversion (0: halve the step).
    pub inversion_fraction: f64,
    /// Newton: at most this many coloured BCD sweeps first, while they gain
    /// fast (0: Newton from the start, as the paper).
    pub start_sweeps: usize,
    /// A reference mesh given in memory (instead of `reference`).
    #[serde(skip)]
    pub reference_mesh: Option<Mesh>,
    /// A geometry file (a triangulated surface such as STL, OBJ, PLY, or a
    /// volume mesh whose skin is used) the skin slides on instead of its own
    /// skin; giving one makes the boundary slide.
    pub surface: Option<PathBuf>,
    /// The geometry given in memory (instead of `surface`).
    #[serde(skip)]
    pub surface_mesh: Option<Mesh>,
}

impl Default for Smoother {
    fn default() -> Self {
        let params = Params::default();
        let newton = NewtonParams::default();
        Smoother {
            method: Method::default(),
            device: DeviceChoice::Auto,
            precision: Precision::default(),
            adapter: None,
            tol: params.tol,
            tol_x: params.nlcg.tol_x,
            max_iter: params.max_iter,
            time_limit: None,
            target_objective: None,
            metric: None,
            template: Template::default(),
            target: "auto".into(),
            reference: None,
            order: Ordering::default(),
            order_seed: 0,
            reorder_every: None,
            inner_iterations: 1,
            boundary: BoundaryMode::Fixed,
            feature_angle: Boundary::default().feature_angle,
            fix_groups: Vec::new(),
            free_groups: Vec::new(),
            fixed_arrays: Vec::new(),
            fixed_files: Vec::new(),
            untangle: true,
            keep_partial: false,
            negative_curvature: newton.negative_curvature,
            // planar meshes on the CPU get Gauss-Seidel, the rest block Jacobi
            preconditioner: Preconditioner::Auto,
            inversion_fraction: newton.inversion_fraction,
            start_sweeps: newton.start_sweeps,
            reference_mesh: None,
            surface: None,
            surface_mesh: None,
        }
    }
}

/// What a run tells its observer as it goes.
#[derive(Debug)]
#[non_exhaustive]
pub enum Event<'a> {
    /// Before anything moves.
    Start(&'a Start),
    /// The input is tangled; untangling begins.
    Untangling {
        /// Elements with an inverted or degenerate corner.
        inverted: usize,
    },
    /// Untangling is done (smoothing follows unless the run only untangles).
    Untangled(&'a UntangleInfo),
    /// A smoothing iteration's record.
    Iteration(&'a Record),
}

/// The run as it starts: the input, what the rules fixed, what was chosen.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct Start {
    /// The input's quality.
    pub quality: QualityReport,
    /// What each fixed-vertex rule did.
    pub rules: Vec<RuleCount>,
    /// Why the fixed vertices are fixed, each counted once.
    pub fixed: Fixed,
    /// The default targets' decision, where it keeps the input's stretching.
    pub targets: Option<String>,
    /// With a sliding boundary: how the skin was classified.
    pub sliding: Option<Sliding>,
    /// Other things the caller should know (e.g. why the CPU was chosen).
    pub notes: Vec<String>,
}

/// Why vertices are fixed: each fixed vertex counted once, under the first
/// reason that holds in this order (skin, file, rules, unused).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct Fixed {
    /// Skin vertices that stay: all of them with `boundary = fixed` (the
    /// default), the corners and any flagged ones with `slide`.
    pub skin: usize,
    /// Vertices inside the mesh that the file marks fixed (VTK point data
    /// `fixed`, lower cells, Medit required vertices, Gmsh point elements).
    pub file: usize,
    /// Vertices inside the mesh that the rules (groups, arrays, id files)
    /// fixed beyond the file's own.
    pub rules: usize,
    /// Vertices no element uses (kept where they are).
    pub unused: usize,
}

impl Fixed {
    /// All fixed vertices.
    pub fn total(&self) -> usize {
        self.skin + self.file + self.rules + self.unused
    }

    /// `held`: whether a skin vertex stays (the boundary rule's answer).
    fn count(skin: &[bool], mesh: &Mesh, file_fixed: &[bool], held: impl Fn(usize) -> bool, unused: usize) -> Fixed {
        let mut fixed = Fixed {
            unused,
            ..Fixed::default()
        };
        for (v, &on_skin) in skin.iter().enumerate() {
            if on_skin {
                fixed.skin += usize::from(held(v));
            } else if file_fixed.get(v).copied().unwrap_or(false) {
                fixed.file += 1;
            } else if mesh.is_fixed(v) {
                fixed.rules += 1;
            }
        }
        fixed
    }
}

/// How a sliding boundary's skin was classified.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct Sliding {
    /// The feature angle used (degrees).
    pub feature_angle: f64,
    /// Vertices sliding in a boundary face.
    pub surface: usize,
    /// Vertices sliding along a feature edge.
    pub edge: usize,
    /// Corners (fixed).
    pub corners: usize,
    /// Whether the skin slides on a given geometry rather than on itself.
    pub geometry: bool,
}

/// What a smoothing run did.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct Report {
    /// The run as it started.
    pub start: Start,
    /// What untangling did, when the input was tangled.
    pub untangled: Option<UntangleInfo>,
    /// The smoothing solve.
    pub info: Info,
    /// The result's quality.
    pub quality: QualityReport,
    /// How far the vertices moved, in % of the local spacing (from after untangling).
    pub displacement: SpacingDisplacement,
    /// For metrics other than the inverse mean ratio: the metric's own values before and after.
    pub metric: Option<(MetricSummary, MetricSummary)>,
    /// Where the mesh has a boundary layer: how its first-layer heights changed.
    pub first_layer: Option<LayerChange>,
    /// The partition and communication of a partitioned (MPI) run.
    #[cfg(feature = "mpi")]
    pub ranks: Option<solve::distributed::Report>,
}

/// What an untangling run did.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct UntangleReport {
    /// The run as it started.
    pub start: Start,
    /// `None`: the input had no inverted element and was left as it was.
    pub untangled: Option<UntangleInfo>,
    /// The result's quality.
    pub quality: QualityReport,
}

/// The backend a run was given: the CPU, or a GPU context kept for it.
#[non_exhaustive]
pub enum Backend {
    /// The f64 reference backend.
    Cpu,
    /// A wgpu device.
    #[cfg(feature = "gpu")]
    Gpu(Box<GpuContext>),
}

impl Backend {
    /// The solver's view of it.
    pub fn device(&self) -> Device<'_> {
        match self {
            Backend::Cpu => Device::Cpu,
            #[cfg(feature = "gpu")]
            Backend::Gpu(ctx) => Device::Gpu(ctx),
        }
    }
}

/// An unusable option: its settings name and what is wrong.
fn bad(option: &'static str, message: impl Into<String>) -> Error {
    Error::InvalidOption {
        option,
        message: message.into(),
    }
}

impl Smoother {
    /// Settings from a TOML document (keys as the fields; unknown keys refused).
    pub fn from_toml(text: &str) -> Result<Smoother> {
        let s: Smoother = toml::from_str(text).map_err(|e| Error::InvalidArgument(format!("settings: {e}")))?;
        s.validate()?;
        Ok(s)
    }

    /// Settings from a JSON object (keys as the fields; unknown keys refused).
    pub fn from_json(text: &str) -> Result<Smoother> {
        let s: Smoother = serde_json::from_str(text).map_err(|e| Error::InvalidArgument(format!("settings: {e}")))?;
        s.validate()?;
        Ok(s)
    }

    /// Settings from a file: `.toml` or `.json`.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Smoother> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        let parsed = match ext.as_deref() {
            Some("toml") => Smoother::from_toml(&text),
            Some("json") => Smoother::from_json(&text),
            _ => {
                return Err(Error::InvalidArgument(format!(
                    "{}: settings files are .toml or .json",
                    path.display()
                )));
            }
        };
        parsed.map_err(|e| match e {
            Error::InvalidArgument(msg) => Error::parse(path, None, msg),
            e @ Error::InvalidOption { .. } => Error::parse(path, None, e.to_string()),
            other => other,
        })
    }

    /// The settings as TOML (what `from_toml` reads back).
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("settings serialise")
    }

    /// Checks every setting that can be checked without a mesh.
    pub fn validate(&self) -> Result<()> {
        self.params()?;
        self.target_spec()?;
        let a = self.feature_angle;
        if !(a > 0.0 && a < 180.0) {
            return Err(bad(
                "feature_angle",
                format!("must be between 0 and 180 degrees, got {a}"),
            ));
        }
        if self.device == DeviceChoice::Cpu {
            self.cpu_precision()?;
        }
        if self.device == DeviceChoice::Gpu {
            gpu_allowed(self.method)?;
        }
        if self.reference.is_some() && self.target.starts_with("reference:") {
            return Err(bad(
                "reference",
                "give the reference mesh once: as reference or as target reference:MESH",
            ));
        }
        Ok(())
    }

    /// The solver settings.
    pub fn params(&self) -> Result<Params> {
        if !(self.tol.is_finite() && self.tol >= 0.0) {
            return Err(bad("tol", format!("must be a non-negative number, got {}", self.tol)));
        }
        if !(self.tol_x.is_finite() && self.tol_x >= 0.0) {
            return Err(bad(
                "tol_x",
                format!("must be a non-negative number, got {}", self.tol_x),
            ));
        }
        let time_limit = match self.time_limit {
            None => None,
            // a limit beyond what a Duration holds is no limit
            Some(t) if t.is_finite() && t > 0.0 => Duration::try_from_secs_f64(t).ok(),
            Some(t) if t > 0.0 => None,
            Some(t) => {
                return Err(bad(
                    "time_limit",
                    format!("must be a positive number of seconds, got {t}"),
                ));
            }
        };
        if let Some(t) = self.target_objective
            && !t.is_finite()
        {
            return Err(bad("target_objective", format!("must be a finite number, got {t}")));
        }
        if self.reorder_every == Some(0) {
            return Err(bad("reorder_every", "must be at least 1"));
        }
        if self.inner_iterations == 0 {
            return Err(bad("inner_iterations", "must be at least 1"));
        }
        if self.reorder_every.is_some() && self.order.sweep().is_none() {
            // a graph numbering is fixed when the problem is built: there is no list to reorder
            return Err(bad(
                "reorder_every",
                format!(
                    "needs one of the reordering paper's schemes as the order (n, r, wqp, gavm, grvm, lng, d-wqp, d-gavm, d-grvm, d-lng or their reverses), not '{}'",
                    self.order
                ),
            ));
        }
        let mut p = Params {
            tol: self.tol,
            max_iter: self.max_iter,
            time_limit,
            target_objective: self.target_objective,
            ..Params::default()
        };
        p.nlcg.tol_x = self.tol_x;
        p.bcd.reorder_every = self.reorder_every;
        p.bcd.inner_iterations = self.inner_iterations;
        p.newton.negative_curvature = self.negative_curvature;
        p.newton.preconditioner = self.preconditioner;
        p.newton.inversion_fraction = self.inversion_fraction;
        p.newton.start_sweeps = self.start_sweeps;
        p.newton
            .check()
            .map_err(|e| bad("inversion_fraction", e.to_string().replace("invalid argument: ", "")))?;
        Ok(p)
    }

    /// The target spec as the library's [`Target`]; `reference:MESH` gives
    /// the ideal corners (the reference mesh carries the targets).
    fn target_spec(&self) -> Result<Target<'_>> {
        if self.target.starts_with("reference:") {
            return Ok(Target::Ideal);
        }
        Target::parse(&self.target).map_err(|e| bad("target", e.to_string().replace("invalid argument: ", "")))
    }

    /// The reference mesh: given in memory, or read from its file.
    pub fn reference_mesh(&self) -> Result<Option<Mesh>> {
        if let Some(m) = &self.reference_mesh {
            return Ok(Some(m.clone()));
        }
        let path = self
            .target
            .strip_prefix("reference:")
            .map(Path::new)
            .or(self.reference.as_deref());
        path.map(io::read).transpose()
    }

    /// The surface geometry: given in memory, or read from its file.
    pub fn surface_geometry(&self) -> Result<Option<Mesh>> {
        if let Some(m) = &self.surface_mesh {
            return Ok(Some(m.clone()));
        }
        self.surface.as_deref().map(io::read).transpose()
    }

    /// What the skin does: a surface geometry makes it slide.
    pub fn boundary_mode(&self) -> BoundaryMode {
        if self.surface.is_some() || self.surface_mesh.is_some() {
            BoundaryMode::Slide
        } else {
            self.boundary
        }
    }

    /// What is optimised, with `reference` as the reference mesh and
    /// `surface` as the geometry the skin slides on.
    pub fn problem_options<'a>(
        &'a self,
        reference: Option<&'a Mesh>,
        surface: Option<&'a Mesh>,
    ) -> Result<ProblemOptions<'a>> {
        let target = self.target_spec()?;
        Ok(ProblemOptions {
            metric: self.metric.unwrap_or(target.default_metric()),
            template: self.template,
            target,
            reference,
            ordering: self.order,
            order_seed: self.order_seed,
            boundary: Boundary {
                mode: self.boundary_mode(),
                feature_angle: self.feature_angle,
            },
            surface,
            ..Default::default()
        })
    }

    /// The fixed-vertex rules (reads the id files).
    pub fn rules(&self) -> Result<FixRules> {
        let fixed_ids = self
            .fixed_files
            .iter()
            .map(|p| Ok((p.display().to_string(), io::read_vertex_ids(p)?)))
            .collect::<Result<_>>()?;
        Ok(FixRules {
            fix_groups: self.fix_groups.clone(),
            free_groups: self.free_groups.clone(),
            fixed_arrays: self.fixed_arrays.clone(),
            fixed_ids,
            release_facets: self.boundary_mode() == BoundaryMode::Slide,
        })
    }

    /// The GPU options of these settings.
    #[cfg(feature = "gpu")]
    pub fn gpu_options(&self) -> GpuOptions {
        GpuOptions {
            adapter: self.adapter.clone(),
            precision: self.precision,
            ..Default::default()
        }
    }

    /// Refuses f32 asked of the CPU (`auto` falling back to the CPU notes
    /// it instead): the CPU computes in f64 only, and an explicit f32 there
    /// is a mistake better told than silently widened.
    fn cpu_precision(&self) -> Result<()> {
        if self.precision == Precision::F32 {
            return Err(bad(
                "precision",
                "f32 is a GPU arithmetic; the CPU backend computes in f64 (choose the gpu device)",
            ));
        }
        Ok(())
    }

    /// Starts, in the background, what a run will need and the mesh does
    /// not decide: with `device = auto`, the question to the GPU drivers
    /// (a tenth of a second or more), so that it overlaps with reading the
    /// input. Optional; [`Smoother::smooth`] works the same without it.
    pub fn prepare(&self) {
        #[cfg(feature = "gpu")]
        if self.device == DeviceChoice::Auto {
            gpu::list_adapters_in_background();
        }
    }

    /// Picks the backend for `methods` (see [`DeviceChoice`]); a note says
    /// why `auto` chose the CPU.
    #[cfg_attr(not(feature = "gpu"), allow(unused_variables))]
    pub fn backend(&self, methods: &[Method]) -> Result<(Backend, Option<String>)> {
        match self.device {
            DeviceChoice::Cpu => {
                self.cpu_precision()?;
                Ok((Backend::Cpu, None))
            }
            #[cfg(not(feature = "gpu"))]
            DeviceChoice::Gpu => Err(Error::Unsupported(
                "this build of meshsmooth has no GPU backend (it was built without the gpu feature)".into(),
            )),
            #[cfg(not(feature = "gpu"))]
            DeviceChoice::Auto => Ok((Backend::Cpu, None)),
            #[cfg(feature = "gpu")]
            DeviceChoice::Gpu => {
                for &m in methods {
                    gpu_allowed(m)?;
                }
                Ok((Backend::Gpu(Box::new(GpuContext::new(&self.gpu_options())?)), None))
            }
            #[cfg(feature = "gpu")]
            DeviceChoice::Auto => {
                // nobody asked for a GPU: the CPU needs no note, unless it
                // cannot give the f32 that was asked for
                if methods.iter().any(|&m| gpu_allowed(m).is_err()) {
                    return Ok((Backend::Cpu, None));
                }
                let adapters = gpu::list_adapters();
                let hardware = adapters.iter().any(|a| a.compute && a.device_type != "Cpu");
                if hardware || self.adapter.is_some() {
                    return Ok((Backend::Gpu(Box::new(GpuContext::new(&self.gpu_options())?)), None));
                }
                if self.precision != Precision::F32 {
                    return Ok((Backend::Cpu, None));
                }
                let found: Vec<String> = adapters
                    .iter()
                    .map(|a| format!("{} ({})", a.name, a.device_type))
                    .collect();
                let note = format!(
                    "no hardware GPU found{}; running on the CPU in f64, not the f32 asked for \
                     (the gpu device uses a software adapter)",
                    if found.is_empty() {
                        String::new()
                    } else {
                        format!(" (adapters: {})", found.join(", "))
                    },
                );
                Ok((Backend::Cpu, Some(note)))
            }
        }
    }

    /// Smooths `mesh` in place: the rules of [`Smoother::smooth_observed`]
    /// without an observer.
    pub fn smooth(&self, mesh: &mut Mesh) -> Result<Report> {
        self.smooth_observed(mesh, &mut |_| true)
    }

    /// Smooths `mesh` in place and tells `observer` as it goes (returning
    /// `false` from an iteration stops the run, keeping the mesh so far).
    /// The sequence: settings checked, the fixed-vertex rules applied for
    /// this run only (the mesh keeps its own flags), the default targets
    /// decided on the input, the device chosen, a tangled input untangled
    /// (or refused when `untangle` is off), then smoothed in the mesh's
    /// unit-free frame. On an error the mesh keeps its input positions,
    /// unless `keep_partial` asks for the last ones.
    pub fn smooth_observed(&self, mesh: &mut Mesh, observer: &mut dyn FnMut(Event<'_>) -> bool) -> Result<Report> {
        self.smooth_on(mesh, None, observer)
    }

    /// [`Smoother::smooth_observed`] with the smoothing partitioned over the
    /// ranks of an MPI job (untangling stays on this rank).
    #[cfg(feature = "mpi")]
    pub fn smooth_distributed(
        &self,
        mesh: &mut Mesh,
        cluster: &solve::distributed::Cluster,
        observer: &mut dyn FnMut(Event<'_>) -> bool,
    ) -> Result<Report> {
        self.smooth_on(mesh, Some(cluster), observer)
    }

    #[cfg_attr(not(feature = "mpi"), allow(unused_variables))]
    fn smooth_on(
        &self,
        mesh: &mut Mesh,
        #[cfg(feature = "mpi")] cluster: Option<&solve::distributed::Cluster>,
        #[cfg(not(feature = "mpi"))] cluster: Option<&()>,
        observer: &mut dyn FnMut(Event<'_>) -> bool,
    ) -> Result<Report> {
        let input = mesh.points.clone();
        let input_points = mesh.num_points();
        let result = self.with_rules(mesh, |s, mesh, ruled| {
            s.smooth_ruled(mesh, ruled, input_points, cluster, observer)
        });
        if result.is_err() && !self.keep_partial {
            mesh.points = input;
        }
        result
    }

    /// Untangles `mesh` in place (a no-op for an untangled one): the same
    /// checks, rules and device choice as [`Smoother::smooth`], without the
    /// smoothing. With `keep_partial`, a failure leaves the last positions.
    pub fn untangle(&self, mesh: &mut Mesh) -> Result<UntangleReport> {
        self.untangle_observed(mesh, &mut |_| true)
    }

    /// [`Smoother::untangle`] with an observer.
    pub fn untangle_observed(
        &self,
        mesh: &mut Mesh,
        observer: &mut dyn FnMut(Event<'_>) -> bool,
    ) -> Result<UntangleReport> {
        let input = mesh.points.clone();
        let input_points = mesh.num_points();
        let result = self.with_rules(mesh, |s, mesh, ruled| {
            let reference = s.reference_for(ruled.used.as_deref(), input_points)?;
            let surface = s.surface_geometry()?;
            let options = s.problem_options(reference.as_ref(), surface.as_ref())?;
            crate::problem::check(mesh, &mesh.points, &options)?;
            let (backend, note) = s.backend(&[untangle_method(s.method)])?;
            let unused = ruled.unused;
            // the skin is topology: the same before and after untangling
            let skin = crate::mesh::topology::skin_vertices(mesh);
            let start = s.start(mesh, &skin, &options, ruled, None, note);
            observer(Event::Start(&start));
            let inverted = metric::inverted_elements(mesh, &mesh.points);
            let untangled = s.untangle_phase(mesh, &inverted, &options, backend.device(), observer)?;
            Ok(UntangleReport {
                quality: with_unused(quality_report_on_skin(mesh, &mesh.points, &skin), unused),
                start,
                untangled,
            })
        });
        if result.is_err() && !self.keep_partial {
            mesh.points = input;
        }
        result
    }

    /// Runs `run` with the fixed-vertex rules applied to `mesh` for its
    /// duration: the mesh keeps the file's own flags afterwards. Vertices no
    /// element uses take no part: `run` gets the mesh without them (and a
    /// note saying so), and they keep their coordinates bit for bit.
    fn with_rules<T>(&self, mesh: &mut Mesh, run: impl FnOnce(&Smoother, &mut Mesh, Ruled) -> Result<T>) -> Result<T> {
        self.validate()?;
        let rules = self.rules()?;
        let file_fixed = mesh.fixed.clone();
        let result = rules.apply(mesh).and_then(|counts| {
            let Some((used, mut elements)) = mesh.without_unused() else {
                return run(
                    self,
                    mesh,
                    Ruled {
                        counts,
                        file_fixed: file_fixed.clone(),
                        unused: 0,
                        used: None,
                        notes: Vec::new(),
                    },
                );
            };
            let unused = mesh.num_points() - used.len();
            let note = unused_note(unused);
            let result = run(
                self,
                &mut elements,
                Ruled {
                    counts,
                    file_fixed: if file_fixed.is_empty() {
                        Vec::new()
                    } else {
                        used.iter().map(|&v| file_fixed[v]).collect()
                    },
                    unused,
                    used: Some(used.clone()),
                    notes: vec![note],
                },
            );
            // the positions `run` left (the caller restores the input on an error)
            for (l, &v) in used.iter().enumerate() {
                mesh.points[v] = elements.points[l];
            }
            result
        });
        mesh.fixed = file_fixed;
        result
    }

    /// The reference mesh for a run on the mesh without its unused vertices
    /// (`used`: the vertices kept, in the input's numbering): a reference
    /// numbered like the input loses the same vertices.
    fn reference_for(&self, used: Option<&[usize]>, input_points: usize) -> Result<Option<Mesh>> {
        let reference = self.reference_mesh()?;
        Ok(match (reference, used) {
            (Some(r), Some(used)) if r.num_points() == input_points => Some(r.keep_vertices(used)),
            (r, _) => r,
        })
    }

    /// `skin`: the mesh's skin vertices ([`skin_vertices`](crate::mesh::topology::skin_vertices)).
    fn start(
        &self,
        mesh: &Mesh,
        skin: &[bool],
        options: &ProblemOptions,
        ruled: Ruled,
        targets: Option<String>,
        note: Option<String>,
    ) -> Start {
        // an error here comes back from the problem's build, which stops the run
        let class = crate::problem::boundary::skin_classes(mesh, &mesh.points, options)
            .ok()
            .flatten()
            .map(|c| c.class);
        let sliding = class.as_ref().map(|class| {
            let count = |k: VertexClass| {
                (0..mesh.num_points())
                    .filter(|&v| class[v] == k && (k == VertexClass::Corner || !mesh.is_fixed(v)))
                    .count()
            };
            Sliding {
                feature_angle: options.boundary.feature_angle,
                surface: count(VertexClass::Surface),
                edge: count(VertexClass::Edge),
                corners: count(VertexClass::Corner),
                geometry: options.surface.is_some(),
            }
        });
        let held = |v: usize| {
            class
                .as_ref()
                .is_none_or(|c| c[v] == VertexClass::Corner || mesh.is_fixed(v))
        };
        Start {
            quality: with_unused(quality_report_on_skin(mesh, &mesh.points, skin), ruled.unused),
            fixed: Fixed::count(skin, mesh, &ruled.file_fixed, held, ruled.unused),
            rules: ruled.counts,
            targets,
            sliding,
            notes: ruled.notes.into_iter().chain(note).collect(),
        }
    }

    /// Untangles a tangled `mesh` whose inverted elements are `inverted`
    /// (a no-op when there are none).
    fn untangle_phase(
        &self,
        mesh: &mut Mesh,
        inverted: &[usize],
        options: &ProblemOptions,
        device: Device,
        observer: &mut dyn FnMut(Event<'_>) -> bool,
    ) -> Result<Option<UntangleInfo>> {
        if inverted.is_empty() {
            return Ok(None);
        }
        if let Some(msg) = solve::untangle::convention_problem(mesh) {
            return Err(Error::InvalidMesh(msg));
        }
        observer(Event::Untangling {
            inverted: inverted.len(),
        });
        let opts = solve::Options {
            method: untangle_method(self.method),
            params: self.params()?,
            device,
            ..Default::default()
        };
        let params = UntangleParams::default();
        // the inner solves' iterations are untangling's own, not smoothing's
        let mut quiet = |_: &Record| true;
        let info = if self.keep_partial {
            solve::untangle::untangle_mesh_partial(mesh, options, &opts, &params, &mut quiet)?
        } else {
            solve::untangle_mesh(mesh, options, &opts, &params, &mut quiet)?
        };
        observer(Event::Untangled(&info));
        Ok(Some(info))
    }

    #[cfg_attr(not(feature = "mpi"), allow(unused_variables))]
    fn smooth_ruled(
        &self,
        mesh: &mut Mesh,
        ruled: Ruled,
        input_points: usize,
        #[cfg(feature = "mpi")] cluster: Option<&solve::distributed::Cluster>,
        #[cfg(not(feature = "mpi"))] cluster: Option<&()>,
        observer: &mut dyn FnMut(Event<'_>) -> bool,
    ) -> Result<Report> {
        let params = self.params()?;
        let reference = self.reference_for(ruled.used.as_deref(), input_points)?;
        let surface = self.surface_geometry()?;
        let options = self.problem_options(reference.as_ref(), surface.as_ref())?;
        // refuse what cannot be smoothed before anything moves or is
        // reported (a planar mesh that is not flat included: its "inverted"
        // elements would be those of a projection)
        crate::problem::check(mesh, &mesh.points, &options)?;
        // once for the run: nothing moves before untangling, which is handed it
        let inverted = metric::inverted_elements(mesh, &mesh.points);
        // the default target is decided on the input, before any untangling
        let (options, targets) = options.resolved_with(mesh, Some(&inverted))?;
        let tangled = !inverted.is_empty();
        if tangled && !self.untangle {
            return Err(Error::inverted(inverted));
        }
        if let Some(msg) = tangled.then(|| solve::untangle::convention_problem(mesh)).flatten() {
            return Err(Error::InvalidMesh(msg));
        }
        let (backend, note) = self.backend(&[self.method, untangle_method(self.method)])?;
        let unused = ruled.unused;
        // the skin is topology: one for the reports before and after
        let ve = topology::vertex_elements(mesh);
        let skin = topology::skin_vertices_with(mesh, &ve);
        let start = self.start(mesh, &skin, &options, ruled, targets, note);
        if !observer(Event::Start(&start)) {
            return Err(Error::InvalidArgument("cancelled before the run began".into()));
        }
        let untangled = self.untangle_phase(mesh, &inverted, &options, backend.device(), observer)?;
        let begin = mesh.points.clone();
        // other metrics get a table of their own values as well (reference
        // meshes, not constructed targets, give that table its targets)
        let own_table = options.metric != MetricKind::InverseMeanRatio && !options.target.is_constructed();
        let metric_before = own_table
            .then(|| metric_report::metric_summary(mesh, &mesh.points, options.metric, options.reference))
            .transpose()?;
        #[cfg(feature = "mpi")]
        let device = match cluster {
            Some(c) => {
                c.set_gpu(self.rank_gpu(&backend));
                Device::Mpi(c)
            }
            None => backend.device(),
        };
        #[cfg(not(feature = "mpi"))]
        let device = backend.device();
        let opts = solve::Options {
            method: self.method,
            params,
            device,
            checkpoint_every: self.keep_partial.then_some(10),
            ..Default::default()
        };
        let info = solve::smooth_mesh(mesh, &options, &opts, &mut |r| observer(Event::Iteration(r)))?;
        let metric = match metric_before {
            Some(before) => Some((
                before,
                metric_report::metric_summary(mesh, &mesh.points, options.metric, options.reference)?,
            )),
            None => None,
        };
        // three reports side by side: each has sequential parts
        let after = &mesh.points;
        let (quality, (displacement, first_layer)) = rayon::join(
            || with_unused(quality_report_on_skin(mesh, after, &skin), unused),
            || {
                rayon::join(
                    || {
                        let fixed = topology::with_user_fixed(mesh, skin.clone());
                        let nb = topology::vertex_neighbours_with(mesh, &ve);
                        metric_report::displacement_percent_on(mesh, &fixed, &nb, &begin, after)
                    },
                    || first_layer_change_on_skin(mesh, &skin, &ve, &begin, after),
                )
            },
        );
        Ok(Report {
            untangled,
            quality,
            displacement,
            metric,
            first_layer,
            #[cfg(feature = "mpi")]
            ranks: cluster.and_then(|c| c.report()),
            start,
            info,
        })
    }
}

impl Smoother {
    /// Each MPI rank's GPU when this rank's backend is a GPU, else `None` (the CPU).
    #[cfg(feature = "mpi")]
    pub fn rank_gpu(&self, backend: &Backend) -> Option<solve::distributed::RankGpu> {
        match backend {
            Backend::Cpu => None,
            #[cfg(feature = "gpu")]
            Backend::Gpu(_) => Some(solve::distributed::RankGpu {
                adapter: self.adapter.clone(),
                precision: self.precision,
            }),
        }
    }
}

/// What [`Smoother::with_rules`] hands a run: the rules' counts, the
/// vertices the run's mesh keeps when the input has vertices no element
/// uses (in the input's numbering), and notes for the start report.
struct Ruled {
    counts: Vec<RuleCount>,
    /// The file's own fixed flags in the run's numbering (empty: none).
    file_fixed: Vec<bool>,
    /// How many vertices no element uses (left out of the run's mesh).
    unused: usize,
    used: Option<Vec<usize>>,
    notes: Vec<String>,
}

/// A report on the mesh without its `unused` vertices counted as one on
/// the whole mesh: they are vertices, and fixed ones.
fn with_unused(mut q: QualityReport, unused: usize) -> QualityReport {
    q.vertices += unused;
    q.fixed_vertices += unused;
    q
}

/// The note on vertices no element uses.
pub fn unused_note(count: usize) -> String {
    if count == 1 {
        "1 point is used by no element: kept where it is".into()
    } else {
        format!("{count} points are used by no element: kept where they are")
    }
}

/// Untangling's solver: Laplace is no optimiser, so a Laplace run untangles with Newton.
fn untangle_method(method: Method) -> Method {
    match method {
        Method::Laplace => Method::Newton,
        m => m,
    }
}

/// Why `method` cannot run on the GPU, if it cannot: [`Device::supports`]'s
/// check, asked before a GPU context is made and worded as a setting's error.
fn gpu_allowed(method: Method) -> Result<()> {
    match method.cpu_only() {
        Some(why) => Err(bad("device", why)),
        None => Ok(()),
    }
}

/// Settings enums by the names the command line and Python use.
mod by_name {
    use serde::{Deserialize, Deserializer, Serializer, de::Error};
    use std::fmt::Display;
    use std::str::FromStr;

    pub fn serialize<T: Display, S: Serializer>(v: &T, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(v)
    }

    pub fn deserialize<'de, T, D>(d: D) -> Result<T, D::Error>
    where
        T: FromStr<Err = crate::Error>,
        D: Deserializer<'de>,
    {
        let s = String::deserialize(d)?;
        s.parse()
            .map_err(|e: crate::Error| D::Error::custom(e.to_string().replace("invalid argument: ", "")))
    }
}

/// [`by_name`] for an optional setting.
mod by_name_opt {
    use serde::{Deserialize, Deserializer, Serializer, de::Error};
    use std::fmt::Display;
    use std::str::FromStr;

    pub fn serialize<T: Display, S: Serializer>(v: &Option<T>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(v) => s.collect_str(v),
            None => s.serialize_none(),
        }
    }

    pub fn deserialize<'de, T, D>(d: D) -> Result<Option<T>, D::Error>
    where
        T: FromStr<Err = crate::Error>,
        D: Deserializer<'de>,
    {
        Option::<String>::deserialize(d)?
            .map(|s| {
                s.parse()
                    .map_err(|e: crate::Error| D::Error::custom(e.to_string().replace("invalid argument: ", "")))
            })
            .transpose()
    }
}

#[cfg(test)]
#[allow(clippy::field_reassign_with_default)] // the tests set a few settings on the defaults, as a user would
mod tests {
    use super::*;

    #[test]
    fn settings_round_trip_through_toml_and_json() {
        let s = Smoother {
            method: Method::BcdColored,
            metric: Some(MetricKind::ShapeSize),
            time_limit: Some(2.5),
            order: "d-wqp".parse().unwrap(),
            fix_groups: vec!["wall".into()],
            ..Default::default()
        };
        let back = Smoother::from_toml(&s.to_toml()).unwrap();
        assert_eq!(back, s);
        let json = serde_json::to_string(&s).unwrap();
        assert!(json.contains("\"method\":\"bcd-colored\""), "{json}");
        assert_eq!(Smoother::from_json(&json).unwrap(), s);
    }

    #[test]
    fn unknown_keys_and_bad_values_are_named() {
        let e = Smoother::from_toml("methd = \"newton\"").unwrap_err().to_string();
        assert!(e.contains("methd"), "{e}");
        let e = Smoother::from_toml("method = \"gauss\"").unwrap_err().to_string();
        assert!(e.contains("gauss") && e.contains("newton"), "{e}");
        for (toml, option) in [
            ("time_limit = 0", "time_limit"),
            ("tol = -1", "tol"),
            ("feature_angle = 190", "feature_angle"),
            ("inner_iterations = 0", "inner_iterations"),
            ("reorder_every = 3", "reorder_every"),
            ("target = \"size:\"", "target"),
            ("device = \"cpu\"\nprecision = \"f32\"", "precision"),
            ("device = \"gpu\"\nmethod = \"laplace\"", "device"),
        ] {
            match Smoother::from_toml(toml) {
                Err(Error::InvalidOption { option: o, .. }) => assert_eq!(o, option, "{toml}"),
                other => panic!("{toml}: {other:?}"),
            }
        }
    }

    #[test]
    fn a_refused_tangled_input_keeps_its_positions_and_flags() {
        let mut mesh = crate::generate::tet_box(2, 2, 2, [1.0, 1.0, 1.0]);
        let centre = (0..mesh.num_points())
            .find(|&v| mesh.points[v] == [0.5, 0.5, 0.5])
            .unwrap();
        mesh.points[centre] = [1.4, 0.5, 0.5];
        let input = mesh.clone();
        let mut s = Smoother {
            device: DeviceChoice::Cpu,
            untangle: false,
            ..Default::default()
        };
        let e = s.smooth(&mut mesh).unwrap_err();
        assert!(matches!(e, Error::Inverted { .. }), "{e}");
        assert!(
            !e.to_string().contains("--"),
            "the library names no command-line flag: {e}"
        );
        assert_eq!(mesh.points, input.points);
        assert_eq!(mesh.fixed, input.fixed);
        s.untangle = true;
        let report = s.smooth(&mut mesh).unwrap();
        assert!(report.untangled.is_some());
        assert_eq!(report.quality.inverted, 0);
    }
}
