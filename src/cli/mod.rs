//! Argument parsing and the subcommands. No numerics live here: every
//! command calls the library and prints what it returns.

mod boundary;
mod brief;
mod commands;
mod compare;
mod device;
mod generate;
mod outputs;
mod progress;
#[cfg(feature = "mpi")]
pub(crate) mod ranks;
mod rezone;
#[cfg(feature = "studies")]
mod study;

use clap::{Args, Parser, Subcommand, ValueEnum};
use meshsmooth::DeviceChoice;
use meshsmooth::backend::gpu::Precision;
use meshsmooth::generate::HorseshoeKind;
use meshsmooth::metric::corner_model::Template;
use meshsmooth::metric::smetric::MetricKind;
use meshsmooth::partition::Partitioner;
use meshsmooth::problem::Ordering;
use meshsmooth::solve::newton::NewtonParams;
use meshsmooth::solve::pcg::{NegativeCurvature, Preconditioner};
use meshsmooth::solve::{Method, Params};
use std::collections::BTreeSet;
use std::ffi::OsString;
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    name = "meshsmooth",
    version,
    about = "Improve the shape quality of unstructured meshes by moving their vertices."
)]
#[command(
    long_about = "Improve the shape quality of unstructured meshes by moving their vertices.\n\n\
    Without a command, smooths a built-in perturbed box mesh and prints the quality reports (same as `meshsmooth demo`)."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Optimise vertex positions and write the improved mesh.
    Smooth(SmoothArgs),
    /// Untangle a mesh with inverted elements (only that: `smooth` untangles and then smooths).
    Untangle(UntangleArgs),
    /// Print the quality report of a mesh.
    Quality(QualityArgs),
    /// Run several methods from the same start and compare their histories
    /// (iterations, T50/T90/T100, setup time, memory, crossover points).
    Compare(CompareArgs),
    /// List the GPU adapters wgpu finds.
    Devices,
    /// Generate a test mesh.
    #[command(subcommand)]
    Generate(GenerateCommand),
    /// Smooth a built-in perturbed mesh and print the reports.
    Demo(DemoArgs),
    /// Reference-Jacobian rezoning (the rezoning paper): improve the bad elements while
    /// keeping the mesh close to the input; prints section 6's tables in the paper's
    /// shape measure (cn-paper).
    Rezone(RezoneArgs),
    /// Reproduce a paper's study on a generated mesh.
    #[cfg(feature = "studies")]
    #[command(subcommand)]
    Study(StudyCommand),
}

#[cfg(feature = "studies")]
#[derive(Subcommand, Debug)]
pub enum StudyCommand {
    /// The vertex-reordering study: per horseshoe mesh, size and experiment, a baseline (N,
    /// static) sets the target objective; every scheme under every strategy (static, dynamic
    /// every K) then runs the sequential BCD sweep to it, repeatedly. Writes Markdown (the
    /// paper's tables and findings with a rank test), CSV and SVG figures of F against time.
    Order(OrderStudyArgs),
    /// The Newton vs coordinate descent study: ducts of growing size, heterogeneous clipped
    /// cubes, small and large perturbations of an optimal duct; Newton and BCD on each, with
    /// the paper's tables beside ours. Writes Markdown, CSV and SVG figures.
    NewtonBcd(NewtonStudyArgs),
}

#[cfg(feature = "studies")]
#[derive(Args, Debug)]
pub struct NewtonStudyArgs {
    /// Output folder (newton-study.md, newton-study.csv, ratios.csv, fig*.svg).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Small meshes (about half a minute on two cores) instead of about the paper's sizes.
    #[arg(long)]
    pub quick: bool,
    /// Seed of the perturbations.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

#[cfg(feature = "studies")]
#[derive(Args, Debug)]
pub struct OrderStudyArgs {
    /// Output folder (order-study.md, order-study.csv, order-study-runs.csv,
    /// order-study-curves.csv, order-*.svg).
    #[arg(short, long)]
    pub output: PathBuf,
    /// The small study: the five meshes at about 200 free vertices, a 25-sweep baseline
    /// (the options below override it where given).
    #[arg(long)]
    pub quick: bool,
    /// Horseshoe meshes (default all five: sqi, sqii, sqiv, uti, utiv).
    #[arg(long, alias = "kind", value_enum, value_delimiter = ',')]
    pub meshes: Vec<HorseshoeKind>,
    /// About this many free vertices, one mesh of each type per size (default 200 with
    /// --quick, else 20000,40000,80000).
    #[arg(long, alias = "free", value_delimiter = ',')]
    pub sizes: Vec<usize>,
    /// Seconds the baseline runs (default 10 without --quick).
    #[arg(long, value_name = "SECONDS", conflicts_with = "baseline_sweeps")]
    pub baseline: Option<f64>,
    /// Sweeps the baseline runs instead: the same targets on any machine (default 25
    /// with --quick).
    #[arg(long, value_name = "SWEEPS")]
    pub baseline_sweeps: Option<usize>,
    /// Dynamic strategies to run besides the static one.
    #[arg(long, value_delimiter = ',', default_values_t = [1usize, 2, 5, 10])]
    pub every: Vec<usize>,
    /// Runs of each scheme and strategy: times are their medians, and findings need a
    /// rank test over them (at least 3).
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// The experiments besides static/dynamic (default all; "none" for none).
    #[arg(long, value_delimiter = ',')]
    pub experiments: Vec<ExperimentArg>,
    /// Newton steps per vertex visit.
    #[arg(long, default_value_t = 1)]
    pub inner_iterations: usize,
    /// Seed of the random orders and of the perturbed mesh.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

/// `--experiments`: the paper's experiments 6.3, 6.6, 6.7, 6.8, or none.
#[cfg(feature = "studies")]
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ExperimentArg {
    /// 6.3: a perturbed initial mesh.
    Perturbed,
    /// 6.6: one more Newton step per visit.
    Inner,
    /// 6.7: a target from a baseline a fifth as long.
    Inaccurate,
    /// 6.8: the quadrilateral meshes renumbered red-black.
    RedBlack,
    /// None of them.
    None,
}

#[derive(Args, Debug)]
pub struct RezoneArgs {
    /// Input mesh (.vtk, .vtu, .msh, .mesh), three-dimensional.
    pub input: PathBuf,
    #[command(flatten)]
    pub read: ReadArgs,
    /// Output mesh (the rezoned one).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also run the paper's CN optimisation (the cn-paper measure minimised) from the same
    /// start and write its mesh here.
    #[arg(long, value_name = "CN_OUTPUT")]
    pub compare_cn: Option<PathBuf>,
    /// Step 2's optimiser (and the CN comparison's).
    #[arg(long, value_enum, default_value_t = meshsmooth::solve::rezone::DEFAULT_METHOD)]
    pub method: Method,
    /// cpu, gpu or auto (as for smooth); step 1 runs as one GPU kernel there.
    #[arg(long, value_enum, default_value_t = DeviceChoice::Auto)]
    pub device: DeviceChoice,
    #[command(flatten)]
    pub gpu: GpuArgs,
    #[command(flatten)]
    pub stop: StopArgs,
    /// Most Newton steps per vertex in step 1 (the reference positions).
    #[arg(long, default_value_t = meshsmooth::solve::rezone::REFERENCE_ITERS)]
    pub reference_iters: usize,
    /// Output format (as for smooth); --compare-cn's follows its extension.
    #[arg(long)]
    pub format: Option<String>,
    /// No progress display.
    #[arg(short, long)]
    pub quiet: bool,
}

/// How meshes are read, shared by the commands that read them.
#[derive(Args, Debug, Clone, Default)]
pub struct ReadArgs {
    /// Most memory reading one mesh file may take (its bytes, decompressed blocks and
    /// decoded arrays): a size such as 512M or 4G. A file that would need more is refused
    /// with an error naming the array. Default: half the physical memory.
    #[arg(long, value_name = "SIZE", value_parser = parse_max_memory)]
    pub max_memory: Option<u64>,
}

fn parse_max_memory(s: &str) -> Result<u64, String> {
    meshsmooth::io::ReadLimits::parse_size(s).map_err(|e| e.to_string())
}

#[derive(Args, Debug)]
pub struct SmoothArgs {
    /// Input mesh (.vtk, .vtu, .msh, .mesh).
    pub input: PathBuf,
    #[command(flatten)]
    pub read: ReadArgs,
    /// Output mesh; the format follows the extension unless --format is given.
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub solver: SolverArgs,
    /// Write the iteration history as CSV (iteration, seconds, objective, gradient norm).
    #[arg(long, value_name = "FILE.csv")]
    pub history: Option<PathBuf>,
    /// Output format: vtk, vtk-binary, vtu, vtu-binary, vtu-zlib, vtp, vtp-ascii, vtp-zlib, msh2, msh2-binary, msh4,
    /// msh4-binary, medit, abaqus, exodus, vtkhdf, stl, stl-ascii, obj, ply, ply-ascii, openfoam, openfoam-binary (-o
    /// then names a case folder).
    #[arg(long)]
    pub format: Option<String>,
    /// Write the bare mesh: drop the input's point, cell and field arrays and Gmsh groups
    /// (kept by default where the output format can hold them).
    #[arg(long)]
    pub drop_data: bool,
    /// Print only the final summary line.
    #[arg(short, long, conflicts_with = "verbose")]
    pub quiet: bool,
    /// Print the full reports: statistics, histograms and worst elements before and after,
    /// every iteration logged, Newton's inner counts.
    #[arg(short, long)]
    pub verbose: bool,
    /// If the run fails midway (e.g. the GPU is lost), save the last feasible positions
    /// next to the output as NAME.partial.EXT.
    #[arg(long)]
    pub save_partial: bool,
    /// Refuse a tangled input (inverted elements) instead of untangling it first.
    #[arg(long)]
    pub no_untangle: bool,
    /// How the vertices are shared out among MPI ranks (under mpirun) and among --pieces:
    /// metis (METIS 5 on the vertex graph: fewest cut edges; built with --features mpi),
    /// rcb (recursive coordinate bisection) or pieces (a .pvtu input's own pieces under
    /// mpirun: each rank sets up its part from the pieces it reads, and writes them back;
    /// no rank holds the whole mesh).
    #[arg(long, value_enum, default_value_t = Partitioner::default())]
    pub partitioner: Partitioner,
    /// Write the output as a ParaView .pvtu index (-o NAME.pvtu) and N .vtu pieces beside it
    /// (NAME_0.vtu ...), each holding the elements one part owns; N defaults to the number of
    /// MPI ranks (the solve's own partition), or 1 without MPI. An -o ending in .pvtu implies it.
    #[arg(long, value_name = "N", num_args = 0..=1)]
    pub pieces: Option<Option<usize>>,
}

#[derive(Args, Debug)]
pub struct UntangleArgs {
    /// Input mesh (.vtk, .vtu, .msh, .mesh).
    pub input: PathBuf,
    #[command(flatten)]
    pub read: ReadArgs,
    /// Output mesh; the format follows the extension unless --format is given.
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub solver: SolverArgs,
    /// Output format (as for smooth).
    #[arg(long)]
    pub format: Option<String>,
    /// Write the bare mesh (as for smooth).
    #[arg(long)]
    pub drop_data: bool,
    /// Print only the untangling line.
    #[arg(short, long, conflicts_with = "verbose")]
    pub quiet: bool,
    /// Print the full reports (as for smooth).
    #[arg(short, long)]
    pub verbose: bool,
    /// If elements stay inverted, write the last positions anyway as NAME.partial.EXT.
    #[arg(long)]
    pub save_partial: bool,
}

#[derive(Args, Debug, Clone)]
pub struct SolverArgs {
    /// newton: inexact Newton with block-Jacobi PCG (reaches the optimum first on every
    /// mesh measured); bcd: block coordinate descent (per-vertex Newton); bcd-colored: the
    /// same, colour by colour in parallel; nlcg: nonlinear conjugate gradients (gradients
    /// only); laplace: smart Laplacian smoothing (CPU only).
    #[arg(long, value_enum, default_value_t = Method::default())]
    pub method: Method,
    /// cpu: f64 on all cores; gpu: wgpu (bcd runs colour by colour); auto: a hardware GPU if
    /// there is one, else the CPU.
    #[arg(long, value_enum, default_value_t = DeviceChoice::Auto)]
    pub device: DeviceChoice,
    #[command(flatten)]
    pub gpu: GpuArgs,
    #[command(flatten)]
    pub stop: StopArgs,
    #[command(flatten)]
    pub objective: ObjectiveArgs,
    #[command(flatten)]
    pub boundary: boundary::BoundaryArgs,
    /// Newton: what CG returns on negative curvature: the CG iterate so far (truncated
    /// Newton; fewer iterations on the test meshes) or the direction itself (the paper's).
    #[arg(long, value_enum, default_value_t = NewtonParams::default().negative_curvature)]
    pub negative_curvature: NegativeCurvature,
    /// Newton: CG's preconditioner: block Jacobi (the paper's; every device), symmetric block
    /// Gauss-Seidel (CPU only; fewer CG iterations, each dearer) or auto (Gauss-Seidel for
    /// planar meshes on the CPU, block Jacobi elsewhere).
    #[arg(long, value_enum, default_value_t = Preconditioner::Auto)]
    pub preconditioner: Preconditioner,
    /// Newton: after a trial step that inverts an element, try this fraction of the distance
    /// at which the first corner inverts (from the corners' determinant polynomials); 0 halves
    /// the step instead, as the paper's Armijo search does.
    #[arg(long, value_name = "FRACTION", default_value_t = NewtonParams::default().inversion_fraction)]
    pub inversion_fraction: f64,
    /// Newton: at most this many coloured BCD sweeps before the first Newton step, ending
    /// once a sweep gains more than a quarter of the one before (far from the optimum a
    /// sweep is cheaper than a Newton step on negative curvature and gains more: on badly
    /// perturbed large meshes); 0 starts with Newton, as the paper does.
    #[arg(long, value_name = "N", default_value_t = NewtonParams::default().start_sweeps)]
    pub start_sweeps: usize,
    /// Settings from a file (.toml or .json; keys as the Python keywords: method, tol,
    /// time_limit, target, fix_groups, ...); options given on the command line override it.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// The ids of the arguments given on the command line (for --config).
    #[arg(skip)]
    pub given: BTreeSet<String>,
}

/// Cells of a generated box.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum BoxType {
    Tet,
    Hex,
}

/// Cells of a generated grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum GridType {
    Quad,
    Tri,
}

/// Which GPU and what arithmetic.
#[derive(Args, Debug, Clone)]
pub struct GpuArgs {
    /// GPU arithmetic: f64 needs the adapter's SHADER_F64; auto takes f64 where available.
    #[arg(long, value_enum, default_value_t = Precision::default())]
    pub precision: Precision,
    /// Use the GPU adapter whose name contains this (also: MESHSMOOTH_ADAPTER).
    #[arg(long)]
    pub adapter: Option<String>,
}

/// When a solver stops.
#[derive(Args, Debug, Clone)]
pub struct StopArgs {
    /// Stop when the 2-norm of the objective's gradient, with lengths measured in mean
    /// edge lengths (unit-free, like the objective), falls below this.
    #[arg(long, default_value_t = Params::default().tol)]
    pub tol: f64,
    /// nlcg: also stop after a step that moved no vertex farther than this many mean edge
    /// lengths.
    #[arg(long, default_value_t = Params::default().nlcg.tol_x)]
    pub tol_x: f64,
    /// Most sweeps (bcd, laplace) or iterations (newton).
    #[arg(long, default_value_t = Params::default().max_iter)]
    pub max_iter: usize,
    /// Stop as soon as the objective F is at or below this value.
    #[arg(long, value_name = "F")]
    pub target_objective: Option<f64>,
    /// Stop after this many seconds, per method (the mesh so far is kept; it is always valid).
    #[arg(long, value_name = "SECONDS")]
    pub time_limit: Option<f64>,
}

/// What is optimised.
#[derive(Args, Debug, Clone)]
pub struct ObjectiveArgs {
    /// imr: inverse mean ratio |S|^2/(n det S^(2/n)); cn: condition number |S||S^-1|/n;
    /// tmp: target-matrix |S - I|^2 (needs --reference); shape-size: imr + tau + 1/tau - 2
    /// with tau = det S, which keeps the targets' sizes too. S = A W^-1 at each element
    /// corner. Default: imr, or shape-size with constructed targets (--target input, size:,
    /// metric:).
    #[arg(long, value_enum)]
    pub metric: Option<MetricKind>,
    /// harmonic: minimise the mean metric (for imr: the harmonic mean of the mean ratios);
    /// average: maximise the mean quality 1/metric (imr, cn).
    #[arg(long, value_enum, default_value_t = Template::default())]
    pub template: Template,
    /// Reference mesh with the same connectivity: its corners are the targets W.
    #[arg(long, value_name = "MESH")]
    pub reference: Option<PathBuf>,
    /// Targets W per corner: auto (the default: input where the mesh has a boundary layer
    /// or wall grading, ideal otherwise), ideal (each kind's ideal corner), input (the
    /// input's own corners, regularised: keeps boundary layers, grading and anisotropy),
    /// size:FIELD (a point-data edge length), metric:FIELD (a point-data metric tensor, unit
    /// edges in it) or reference:MESH (as --reference).
    #[arg(long, value_name = "SPEC")]
    pub target: Option<String>,
    /// Vertex order. rbfs (default; reverse breadth-first from the boundary), cuthill-mckee
    /// and red-black (checkerboard) number the problem for every method. The reordering
    /// paper's schemes order the sequential sweep (--method bcd on the CPU) and leave the
    /// input numbering: n (alias input), r, wqp, gavm, grvm, lng, d-wqp, d-gavm, d-grvm,
    /// d-lng, any case, each reversed as reverse-NAME or -NAME (--order=-wqp).
    #[arg(long, default_value_t = Ordering::default(), allow_hyphen_values = true, value_name = "NAME")]
    pub order: Ordering,
    /// Seed of the random orders r and reverse-r.
    #[arg(long, default_value_t = 0, value_name = "SEED")]
    pub order_seed: u64,
    /// Dynamic reordering: order the sweep list again after every K sweeps (a paper scheme
    /// with --method bcd); without it the list is ordered once, before the first sweep.
    #[arg(long, value_name = "K")]
    pub reorder_every: Option<usize>,
    /// Newton steps per vertex visit of the sequential sweep (--method bcd), the paper's
    /// inner iterations.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub inner_iterations: usize,
}

#[derive(Args, Debug)]
pub struct CompareArgs {
    pub input: PathBuf,
    #[command(flatten)]
    pub read: ReadArgs,
    #[command(flatten)]
    pub objective: ObjectiveArgs,
    /// Comma-separated methods to run.
    #[arg(long, value_enum, default_values_t = [Method::Bcd, Method::Newton], value_delimiter = ',')]
    pub methods: Vec<Method>,
    /// cpu, or gpu (bcd runs as the coloured sweep there; newton too).
    #[arg(long, value_enum, default_value_t = DeviceChoice::Cpu)]
    pub device: DeviceChoice,
    #[command(flatten)]
    pub gpu: GpuArgs,
    #[command(flatten)]
    pub stop: StopArgs,
    /// Newton: CG's preconditioner: block Jacobi (the paper's; every device), symmetric block
    /// Gauss-Seidel (CPU only; fewer CG iterations, each dearer) or auto (Gauss-Seidel for
    /// planar meshes on the CPU, block Jacobi elsewhere).
    #[arg(long, value_enum, default_value_t = Preconditioner::Auto)]
    pub preconditioner: Preconditioner,
    /// Write the merged histories as CSV.
    #[arg(long, value_name = "FILE.csv")]
    pub csv: Option<PathBuf>,
    /// Draw objective and gradient norm against time as SVG.
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
    /// Print the comparison as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Debug)]
pub struct QualityArgs {
    pub input: PathBuf,
    #[command(flatten)]
    pub read: ReadArgs,
    /// Also measure the mesh against targets: auto (what smoothing chooses by default),
    /// ideal, input, size:FIELD or metric:FIELD, built from --before where given.
    #[arg(long, default_value = "auto")]
    pub target: String,
    /// The mesh before smoothing (same connectivity): the targets are built from it, and the
    /// first-layer height change from it to INPUT is reported.
    #[arg(long, value_name = "MESH")]
    pub before: Option<PathBuf>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Subcommand, Debug)]
pub enum GenerateCommand {
    /// A box of NX x NY x NZ cubes: tetrahedra (each cube split into 6) or hexahedra.
    Box(BoxArgs),
    /// A planar grid of NX x NY squares: quadrilaterals or triangles (each square split into 2).
    Grid(GridArgs),
    /// A duct (a 4 x 1 x 1 box of tetrahedra) as the Newton study uses: unstructured, by
    /// Gmsh (needs gmsh on the PATH), or Kuhn-split cubes (--kuhn).
    Duct(DuctArgs),
    /// The 2D horseshoe family of the vertex-reordering paper, with its semi-annulus reference.
    Horseshoe(HorseshoeArgs),
    /// The 1331-node, 2000-prism mesh of the reference-Jacobian paper.
    Prism(PrismArgs),
    /// A tetrahedral box graded toward one corner (element volume max:min about RATIO), or
    /// with --aniso toward the wall z = 0.
    Graded(GradedArgs),
    /// A mesh graded toward a wall: the unit square with a quad boundary layer on y = 0 under
    /// triangles (--dim 2), or the unit cube of hexahedra graded toward z = 0 (--dim 3).
    BoundaryLayer(BoundaryLayerArgs),
    /// The Newton paper's heterogeneous meshes (Table 3): the unit cube less a clipped corner,
    /// graded toward it in geometric layers, interior vertices jittered.
    Hetero(HeteroArgs),
    /// A conforming mixed mesh: tetrahedra under prisms, hexahedra beside the prisms.
    Mixed(MixedArgs),
    /// A polyhedral Voronoi mesh of the unit cube (about the reference-Jacobian paper's
    /// 3566 nodes and 663 cells), written as VTK polyhedra (.vtk or .vtu).
    Voronoi(VoronoiArgs),
}

/// Perturbation of the interior vertices, shared by the generators.
#[derive(Args, Debug)]
pub struct PerturbArgs {
    /// random:ALPHA, random-shortest:ALPHA, shift-r:ALPHA, shift-ne:ALPHA or osc:ALPHA:OMEGA
    /// (ALPHA in units of the vertex's mean edge length, random-shortest: of its shortest, the
    /// scale of a boundary layer; OMEGA in waves across the bounding box times 2 pi).
    #[arg(long)]
    pub perturb: Option<String>,
    /// Fraction of the interior vertices to perturb.
    #[arg(long, default_value_t = 1.0)]
    pub fraction: f64,
    /// Seed of the random numbers.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Skip the inversion guard: every move is made in full, so elements may invert
    /// (tangled inputs for `untangle`).
    #[arg(long, requires = "perturb")]
    pub tangle: bool,
}

/// Where a generated mesh goes.
#[derive(Args, Debug)]
pub struct OutputArgs {
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output format (see `smooth --format`).
    #[arg(long)]
    pub format: Option<String>,
}

#[derive(Args, Debug)]
pub struct BoxArgs {
    /// Cells along x, y and z.
    #[arg(long, num_args = 3, value_names = ["NX", "NY", "NZ"], required = true)]
    pub cells: Vec<usize>,
    /// Element kind.
    #[arg(long = "type", value_enum, default_value_t = BoxType::Tet)]
    pub kind: BoxType,
    #[command(flatten)]
    pub perturb: PerturbArgs,
    #[command(flatten)]
    pub out: OutputArgs,
}

#[derive(Args, Debug)]
pub struct GridArgs {
    #[arg(long, num_args = 2, value_names = ["NX", "NY"], required = true)]
    pub cells: Vec<usize>,
    #[arg(long = "type", value_enum, default_value_t = GridType::Quad)]
    pub kind: GridType,
    #[command(flatten)]
    pub perturb: PerturbArgs,
    #[command(flatten)]
    pub out: OutputArgs,
}

#[derive(Args, Debug)]
pub struct DuctArgs {
    /// About this many vertices in the unstructured duct (Gmsh's Delaunay mesh; 4200 is the
    /// Newton paper's Duct12).
    #[arg(long, default_value_t = 4200, conflicts_with = "kuhn")]
    pub vertices: usize,
    /// Kuhn-split cubes instead, all tetrahedra alike (already optimal: perturb it).
    #[arg(long)]
    pub kuhn: bool,
    /// Cubes across the Kuhn-split duct.
    #[arg(long, default_value_t = 8, requires = "kuhn")]
    pub cells_across: usize,
    #[command(flatten)]
    pub perturb: PerturbArgs,
    #[command(flatten)]
    pub out: OutputArgs,
}

#[derive(Args, Debug)]
pub struct HorseshoeArgs {
    /// sqi, sqii, sqiv (structured quads 1:1, 1:5, biased 1:5), uti, utiv (triangles, biased).
    #[arg(long, value_enum, default_value_t = HorseshoeKind::SqI)]
    pub kind: HorseshoeKind,
    /// About this many free vertices.
    #[arg(long, default_value_t = 20_000)]
    pub free: usize,
    /// Also write the semi-annulus reference mesh (same connectivity) here.
    #[arg(long, value_name = "FILE")]
    pub reference_output: Option<PathBuf>,
    #[command(flatten)]
    pub out: OutputArgs,
}

#[derive(Args, Debug)]
pub struct PrismArgs {
    /// Add the paper's long-wavelength distortion and short-wavelength noise.
    #[arg(long)]
    pub distorted: bool,
    /// The default is the seed closest to the paper's original mesh.
    #[arg(long, default_value_t = meshsmooth::generate::prism::PAPER_SEED)]
    pub seed: u64,
    #[command(flatten)]
    pub out: OutputArgs,
}

#[derive(Args, Debug)]
pub struct VoronoiArgs {
    /// Sites of the jittered lattice per axis (cells = NX x NY x NZ).
    #[arg(long, num_args = 3, value_names = ["NX", "NY", "NZ"], default_values_t = meshsmooth::generate::voronoi::VORONOI_CELLS)]
    pub cells: Vec<usize>,
    /// How far each site moves from its lattice point, in spacings per axis (below 0.5).
    #[arg(long, default_value_t = meshsmooth::generate::voronoi::VORONOI_JITTER)]
    pub jitter: f64,
    /// Body-centred lattice (2 sites per lattice cell): truncated octahedra, no short edges.
    #[arg(long)]
    pub bcc: bool,
    /// Lloyd steps (sites to their cells' centroids) after the jitter; 0 keeps the lattice as drawn.
    #[arg(long, default_value_t = meshsmooth::generate::voronoi::VORONOI_LLOYD)]
    pub lloyd: usize,
    /// Laplacian sweeps on the cell vertices (box vertices slide on the box); 0 keeps the Voronoi vertices.
    #[arg(long, default_value_t = meshsmooth::generate::voronoi::VORONOI_SMOOTH)]
    pub smooth: usize,
    /// Add the prism mesh's long-wavelength distortion and short-wavelength noise.
    #[arg(long)]
    pub distorted: bool,
    /// With --distorted: the long wave's amplitude on the unit cube.
    #[arg(long, default_value_t = meshsmooth::generate::voronoi::VORONOI_WAVE)]
    pub wave: f64,
    /// With --distorted: the noise, relative to each node's mean edge length.
    #[arg(long, default_value_t = meshsmooth::generate::voronoi::VORONOI_NOISE)]
    pub noise: f64,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[command(flatten)]
    pub out: OutputArgs,
}

#[derive(Args, Debug)]
pub struct MixedArgs {
    /// Cells across each slab.
    #[arg(long, default_value_t = 6)]
    pub cells: usize,
    /// Cells up each slab.
    #[arg(long, default_value_t = 3)]
    pub layers: usize,
    #[command(flatten)]
    pub perturb: PerturbArgs,
    #[command(flatten)]
    pub out: OutputArgs,
}

#[derive(Args, Debug)]
pub struct GradedArgs {
    #[arg(long, default_value_t = 20)]
    pub cells: usize,
    /// Element volume max:min.
    #[arg(long, default_value_t = 1e3)]
    pub ratio: f64,
    /// Grade along z alone, toward the wall z = 0: flat cells near the wall (aspect up to
    /// about RATIO) instead of shapes kept while the size changes.
    #[arg(long)]
    pub aniso: bool,
    #[command(flatten)]
    pub perturb: PerturbArgs,
    #[command(flatten)]
    pub out: OutputArgs,
}

#[derive(Args, Debug)]
pub struct BoundaryLayerArgs {
    /// 2: the unit square with its wall at y = 0; 3: the unit cube with its wall at z = 0.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u8).range(2..=3))]
    pub dim: u8,
    /// The layer's elements: quad (quads under triangles) or tri (2D); hex, prism (prisms
    /// under tetrahedra) or tet (3D). Default: quad in 2D, hex in 3D.
    #[arg(long, value_enum)]
    pub kind: Option<meshsmooth::generate::LayerKind>,
    /// Cells along the wall (and the far-field cell size 1/CELLS).
    #[arg(long, default_value_t = 24)]
    pub cells: usize,
    /// Height of the first cell on the wall.
    #[arg(long, default_value_t = 1e-3)]
    pub first: f64,
    /// Ratio of each layer's height to the one below.
    #[arg(long, default_value_t = 1.25)]
    pub growth: f64,
    /// --dim 2: quad layers (the hexahedra of --dim 3 grow until they reach 1/CELLS).
    #[arg(long, default_value_t = 12)]
    pub layers: usize,
    #[command(flatten)]
    pub perturb: PerturbArgs,
    #[command(flatten)]
    pub out: OutputArgs,
}

#[derive(Args, Debug)]
pub struct HeteroArgs {
    /// Table 3's row: 1-4 (Hetero1-Hetero4: its volume ratio and worst element).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u8).range(1..=4))]
    pub paper: u8,
    /// About this many tetrahedra (the paper's have 54000-60000).
    #[arg(long, default_value_t = 55000)]
    pub tets: usize,
    #[command(flatten)]
    pub out: OutputArgs,
}

#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Also write the smoothed demo mesh here.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Cells per side of the demo box.
    #[arg(long, default_value_t = 16)]
    pub cells: usize,
    /// Print the full reports (as for smooth).
    #[arg(short, long)]
    pub verbose: bool,
    #[command(flatten)]
    pub solver: SolverArgs,
}

/// Parses `args` and runs the command; returns the process exit code.
pub fn run(args: impl IntoIterator<Item = OsString>) -> i32 {
    #[cfg(feature = "mpi")]
    if meshsmooth::solve::distributed::Cluster::launched() {
        return ranks::run_under_mpi(|| dispatch(args));
    }
    let args: Vec<OsString> = args.into_iter().collect();
    on_worker(|| dispatch(args))
}

/// Runs `f` on a worker thread of rayon's global pool. From the main thread
/// every parallel loop hands its work to the pool and sleeps until it is
/// done: a futex wake-up and two context switches per loop, which were a
/// third of the time of Newton on small meshes with one thread (hundreds of
/// CG dots and products). From a worker, a loop on one thread runs in
/// place. Not under MPI: the job's state is the main thread's.
fn on_worker<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    // the main thread's stack, not the workers' default 2 MiB
    let _ = rayon::ThreadPoolBuilder::new().stack_size(8 << 20).build_global();
    rayon::join(f, || ()).0
}

fn dispatch(args: impl IntoIterator<Item = OsString>) -> i32 {
    use clap::{CommandFactory, FromArgMatches};
    let parsed = Cli::command()
        .try_get_matches_from(args)
        .and_then(|m| Cli::from_arg_matches(&m).map(|cli| (cli, m)));
    let (mut cli, matches) = match parsed {
        Ok(p) => p,
        Err(e) => {
            let _ = e.print();
            return e.exit_code();
        }
    };
    // what --config may not override: the options given on the command line
    if let Some((_, sub)) = matches.subcommand() {
        let given: BTreeSet<String> = sub
            .ids()
            .filter(|id| sub.value_source(id.as_str()) == Some(clap::parser::ValueSource::CommandLine))
            .map(|id| id.to_string())
            .collect();
        match &mut cli.command {
            Some(Command::Smooth(a)) => a.solver.given = given,
            Some(Command::Untangle(a)) => a.solver.given = given,
            Some(Command::Demo(a)) => a.solver.given = given,
            _ => {}
        }
    }
    let read = match &cli.command {
        Some(Command::Smooth(a)) => Some(&a.read),
        Some(Command::Untangle(a)) => Some(&a.read),
        Some(Command::Quality(a)) => Some(&a.read),
        Some(Command::Compare(a)) => Some(&a.read),
        Some(Command::Rezone(a)) => Some(&a.read),
        _ => None,
    };
    if let Some(max_bytes) = read.and_then(|r| r.max_memory) {
        // every read in this process, the pieces of a .pvtu and other ranks' included
        meshsmooth::io::ReadLimits { max_bytes }.set_default();
    }
    let result = match cli.command {
        // no command: the demo with its defaults, as `meshsmooth demo` would parse them
        None => match Cli::parse_from(["meshsmooth", "demo"]).command {
            Some(Command::Demo(a)) => commands::demo(&a),
            _ => unreachable!("`demo` parses as the demo command"),
        },
        Some(Command::Demo(a)) => commands::demo(&a),
        Some(Command::Rezone(a)) => rezone::rezone(&a),
        Some(Command::Smooth(a)) => commands::smooth(&a),
        Some(Command::Untangle(a)) => commands::untangle(&a),
        Some(Command::Quality(a)) => commands::quality(&a),
        Some(Command::Compare(a)) => compare::compare(&a),
        Some(Command::Devices) => commands::devices(),
        Some(Command::Generate(g)) => generate::generate(&g),
        #[cfg(feature = "studies")]
        Some(Command::Study(StudyCommand::Order(a))) => study::order(&a),
        #[cfg(feature = "studies")]
        Some(Command::Study(StudyCommand::NewtonBcd(a))) => study::newton_bcd(&a),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {}", device::words(&e));
            1
        }
    }
}
