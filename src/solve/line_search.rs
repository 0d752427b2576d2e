//! Armijo backtracking: accept the first step alpha = beta^k with
//! F(x + alpha d) <= F(x) + sigma alpha g^T d; infeasible trials count as +inf.

pub use crate::backend::settings::LineSearch;
