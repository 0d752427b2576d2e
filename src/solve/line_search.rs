//! Armijo backtracking: accept the first step alpha = beta^k with
//! F(x + alpha d) <= F(x) + sigma alpha g^T d; infeasible trials count as +inf.

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
