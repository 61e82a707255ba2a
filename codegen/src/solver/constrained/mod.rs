//! What the constrained methods (the interior-point method and ADMM) share: how a solve ended, and the
//! emitted `Mpc` API around their solvers ([`emit`]).

pub mod emit;

/// How a constrained method's solve ended ([`crate::solver::ipm`] and [`crate::solver::admm`] alike).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// The solve's tolerance was met (the methods' `solve` only; a fixed-iteration solve never ends so).
    Converged,
    /// The iterations ran out: a fixed-iteration solve always ends so, and the residuals say how close it
    /// came.
    IterationLimit,
    /// The constraints admit no plan: the interior-point method's multipliers certify it (λ ≥ 0,
    /// Gᵀλ ≈ 0, hᵀλ < 0) or diverged; ADMM's last change of y certifies it (OSQP §3.4).
    Infeasible,
    /// Non-finite or inconsistent data or settings, a linear system that cannot be factored (even
    /// regularised), or a non-finite step or iterate.
    NumericalFailure,
}
