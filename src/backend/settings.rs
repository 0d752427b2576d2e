//! What the solvers tell a backend: the per-vertex Armijo line search,
//! Newton's preconditioner, the tolerance of the reference-position steps.
//! Both backends and the solvers import them from here (the solvers'
//! modules re-export them: `solve::line_search::LineSearch`,
//! `solve::pcg::Preconditioner`), so that no backend depends on `solve`.

/// Armijo backtracking constants, shared by the per-vertex steps of BCD and
/// the global line search of Newton.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LineSearch {
    /// Step reduction factor.
    pub beta: f64,
    /// Sufficient-decrease constant.
    pub sigma: f64,
    /// Reductions tried before the vertex is left where it is.
    pub max_backtracks: usize,
}

impl Default for LineSearch {
    fn default() -> Self {
        LineSearch {
            beta: 0.5,
            sigma: 1e-4,
            max_backtracks: 40,
        }
    }
}

/// Newton's preconditioner for CG.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Preconditioner {
    /// Symmetric block Gauss-Seidel where the CPU solves a planar problem,
    /// block Jacobi everywhere else (other devices, 3D, partitioned runs).
    /// On Mesquite's planar meshes SGS took shashkov from 99 Newton
    /// iterations to 59 and halved its time; on tetrahedra it cost more than
    /// it saved (README, "Against Mesquite"). The command line's default.
    Auto,
    /// Block Jacobi: an LDL^T of each 3x3 diagonal block (section 3.2 of the
    /// Newton paper); every backend has it. The library's default
    /// (`NewtonParams::default()`), so that every backend runs the same method.
    #[default]
    Jacobi,
    /// Symmetric block Gauss-Seidel within fixed row ranges (CPU only):
    /// about twice a product per application, fewer CG iterations.
    Sgs,
}

crate::error::by_name!(Preconditioner: "preconditioner" { Auto = "auto", Jacobi = "jacobi", Sgs = "sgs" });

/// The reference-position steps (`Backend::reference_positions`, on every
/// backend) stop once Newton's direction is shorter than this fraction of the
/// vertex's local size: Newton converges quadratically, so the position is
/// then known far beyond any use, and the next steps would be decided by
/// rounding (the line search cannot tell f apart there), which would make
/// the answer depend on the device.
pub const STEP_TOL: f64 = 1e-6;

/// Device arithmetic wanted by the caller (a GPU's; the CPU computes in f64).
/// Here, not in `backend::gpu`, because settings name it with or without the
/// GPU backend built.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Precision {
    /// Single precision.
    F32,
    /// Double precision (needs the adapter's `SHADER_F64`).
    F64,
    /// f64 where the adapter has `SHADER_F64`, else f32.
    #[default]
    Auto,
}

crate::error::by_name!(Precision: "precision" { F32 = "f32", F64 = "f64", Auto = "auto" });
