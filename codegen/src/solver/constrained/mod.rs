//! What the constrained methods (the interior-point method and ADMM) share: the QP they solve
//! ([`InequalityQp`]), how a solve ended ([`Status`]) and how a control step made its plan
//! ([`Fallback`]), and the emitted `Mpc` API around their solvers ([`emit`]).
#![allow(non_snake_case)]

pub mod emit;

use crate::lower::problem::Qp;
use nalgebra::{DMatrix, DVector};

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

/// min ½zᵀHz + fᵀz subject to z_min ≤ z ≤ z_max and lower ≤ A z ≤ upper; ±∞ entries drop their side.
#[derive(Clone, Debug)]
pub struct InequalityQp {
    /// The Hessian (n × n), symmetric positive semidefinite.
    pub H: DMatrix<f64>,
    /// The linear term (n).
    pub f: DVector<f64>,
    /// Lower bounds on z (n).
    pub z_min: DVector<f64>,
    /// Upper bounds on z (n).
    pub z_max: DVector<f64>,
    /// The general rows (m × n).
    pub A: DMatrix<f64>,
    /// Lower bounds of the rows (m).
    pub lower: DVector<f64>,
    /// Upper bounds of the rows (m).
    pub upper: DVector<f64>,
}

impl InequalityQp {
    /// Today's condensed QP: ½UᵀHU + fᵀU over the input box repeated for the N steps, no rows.
    pub fn from_box(qp: &Qp, f: &DVector<f64>) -> Self {
        let nu = qp.u_min.len();
        let n = qp.Nc * nu;
        InequalityQp {
            H: qp.H.clone(),
            f: f.clone(),
            z_min: DVector::from_fn(n, |i, _| qp.u_min[i % nu]),
            z_max: DVector::from_fn(n, |i, _| qp.u_max[i % nu]),
            A: DMatrix::zeros(0, n),
            lower: DVector::zeros(0),
            upper: DVector::zeros(0),
        }
    }

    /// The same problem with the rows lower ≤ A z ≤ upper appended.
    pub fn with_rows(
        mut self,
        A: &DMatrix<f64>,
        lower: &DVector<f64>,
        upper: &DVector<f64>,
    ) -> Self {
        let (m0, m, n) = (self.A.nrows(), A.nrows(), self.A.ncols());
        let mut stacked = DMatrix::zeros(m0 + m, n);
        stacked.rows_mut(0, m0).copy_from(&self.A);
        stacked.rows_mut(m0, m).copy_from(A);
        self.A = stacked;
        self.lower = DVector::from_iterator(m0 + m, self.lower.iter().chain(lower.iter()).copied());
        self.upper = DVector::from_iterator(m0 + m, self.upper.iter().chain(upper.iter()).copied());
        self
    }

    /// The number of unknowns n.
    pub fn n(&self) -> usize {
        self.H.nrows()
    }

    /// Whether the dimensions agree.
    pub(crate) fn consistent(&self) -> bool {
        let n = self.n();
        let m = self.A.nrows();
        self.H.ncols() == n
            && self.f.len() == n
            && self.z_min.len() == n
            && self.z_max.len() == n
            && self.A.ncols() == n
            && self.lower.len() == m
            && self.upper.len() == m
    }

    /// Whether the data can be iterated on: finite H, f, A, and bounds that are not NaN.
    pub(crate) fn finite(&self) -> bool {
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        let not_nan = |v: &[f64]| v.iter().all(|x| !x.is_nan());
        finite(self.H.as_slice())
            && finite(self.f.as_slice())
            && finite(self.A.as_slice())
            && not_nan(self.z_min.as_slice())
            && not_nan(self.z_max.as_slice())
            && not_nan(self.lower.as_slice())
            && not_nan(self.upper.as_slice())
    }
}

/// How a constrained control step made its plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Fallback {
    /// The iterate, projected onto the input box (a no-op but for rounding).
    Solved,
    /// The iteration failed (non-finite, infeasibility detected, or residuals above the limits): the
    /// previous plan shifted by one step with the rest input appended, projected onto the box; the next
    /// solve starts cold.
    WarmStart,
    /// The hard rows admitted no plan at an earlier step, and this plan solves the QP with each hard
    /// row's bounds widened to the value the held plan (the previous plan shifted) gives it: it violates
    /// no hard row more than holding would, and the cost steers it back toward the rows
    /// ([`crate::solver::ipm::relaxed`]). The next solve starts cold.
    Relaxed,
}

/// The state fields of a constrained method's `Mpc` (see [`crate::plan::StateFields`]): the plan of
/// `plan_size`-byte entries, the method's warm-start `point`, the flags `warm` and `relax`, the last input
/// where it is kept, and `SolverStatus`, which `Status` holds too.
pub fn state_fields(
    p: &crate::lower::problem::Problem,
    plan_size: usize,
    point: &[(usize, usize)],
) -> crate::plan::StateFields {
    let real = crate::numeric::Numeric(p.scalar).bytes();
    let flag = (1, 1);
    // `SolverStatus`: iterations (u32), five f64 figures, four flags and `Fallback` (one byte).
    let solver_status = crate::plan::layout(&[(4, 4), (5 * 8, 8), (4, 1), flag]);
    let mut mpc = vec![(p.qp.Nc * p.nu * plan_size, plan_size)];
    mpc.extend_from_slice(point);
    mpc.extend([flag, flag]);
    if p.keeps_last_input() {
        mpc.push((p.nu * real, real));
    }
    mpc.push(solver_status);
    crate::plan::StateFields {
        mpc,
        status: vec![solver_status],
    }
}
