//! The exact reference of a constrained QP: what the certificates, `mpcc dump-qp` and the tests measure
//! every method against.
//!
//! The interior-point method run to [`EXACT_TOLERANCE`] solves nearly every QP the compiler forms, but
//! not all: on some feasible QPs of a double integrator with speed limits it ends
//! [`Status::NumericalFailure`] where DAQP and Clarabel agree to 1e-9. A reference that fails there would
//! have the certificate drop feasible draws as if they were infeasible, so where the interior-point
//! method does not converge, Clarabel (an independent interior-point implementation, pure Rust, with
//! its own KKT factorisation and infeasibility detection) is run on the same sides. A draw is called
//! infeasible only when one of the two certifies it; one that neither solves is a numerical failure,
//! which the sampling reports apart.
#![allow(non_snake_case)]

use super::constrained::InequalityQp;
use super::ipm::{solve, IpmResult, Layout};
use super::Status;
use nalgebra::{DMatrix, DVector};

/// The interior-point method's tolerance on its relative residuals, gap and complementarity.
pub const EXACT_TOLERANCE: f64 = 1e-10;
/// Its iterations at most.
pub const EXACT_ITERATIONS: usize = 200;
/// Clarabel's tolerances, tried tightest first until one ends `Solved`: at 1e-10 its plan can be 5e-6 of
/// the span off on the two-mass QP, and where it stalls at 1e-13 it returns `AlmostSolved` with the
/// reduced tolerances (5e-3 of the span off on a velocity-and-altitude case); the hover QP
/// (κ(H) = 2.8e4) can need 1e-8.
pub const CLARABEL_TOLERANCES: [f64; 6] = [1e-13, 1e-12, 1e-11, 1e-10, 1e-9, 1e-8];

/// Which solver produced an exact solution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Solver {
    /// The interior-point method ([`crate::solver::ipm::solve`]).
    InteriorPoint,
    /// Clarabel, after the interior-point method did not converge.
    Clarabel,
}

/// The exact solution of `qp`: its status is [`Status::Converged`] (a solution), [`Status::Infeasible`]
/// (certified by either solver) or [`Status::NumericalFailure`] (neither solved nor certified it).
/// Where it converged, λ and s are in the interior-point method's layout ([`Layout`]).
pub fn exact(qp: &InequalityQp) -> IpmResult {
    exact_by(qp).0
}

/// [`exact`], with the solver that produced it.
pub fn exact_by(qp: &InequalityQp) -> (IpmResult, Solver) {
    let first = solve(qp, EXACT_TOLERANCE, EXACT_ITERATIONS);
    if first.status == Status::Converged {
        return (first, Solver::InteriorPoint);
    }
    match clarabel(qp) {
        Clarabel::Solved(r) => (r, Solver::Clarabel),
        Clarabel::Infeasible => (
            IpmResult {
                status: Status::Infeasible,
                ..first
            },
            Solver::Clarabel,
        ),
        // Clarabel could not decide: the interior-point method's own verdict stands (its Farkas
        // certificate of infeasibility, or its failure).
        Clarabel::Undecided => (first, Solver::InteriorPoint),
    }
}

/// What Clarabel made of a QP.
pub enum Clarabel {
    /// Solved at one of [`CLARABEL_TOLERANCES`].
    Solved(IpmResult),
    /// Primal infeasible (certified by Clarabel's homogeneous embedding).
    Infeasible,
    /// Neither.
    Undecided,
}

/// Clarabel on `qp`, its finite sides stacked in [`Layout`]'s order as G z + s = h, s ≥ 0, so that its
/// duals are the interior-point method's λ.
pub fn clarabel(qp: &InequalityQp) -> Clarabel {
    use clarabel::algebra::CscMatrix;
    use clarabel::solver::{
        DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
    };
    let n = qp.n();
    if !(qp.H.iter().chain(&qp.f).chain(&qp.A).all(|v| v.is_finite())) {
        return Clarabel::Undecided;
    }
    let csc = |M: &DMatrix<f64>, upper_only: bool| {
        let (mut colptr, mut rowval, mut nzval) = (vec![0], Vec::new(), Vec::new());
        for j in 0..M.ncols() {
            let rows = if upper_only { j + 1 } else { M.nrows() };
            for i in 0..rows {
                if M[(i, j)] != 0.0 {
                    rowval.push(i);
                    nzval.push(M[(i, j)]);
                }
            }
            colptr.push(rowval.len());
        }
        CscMatrix::new(M.nrows(), M.ncols(), colptr, rowval, nzval)
    };
    let layout = Layout::of(qp);
    let m = layout.boxed.len() + layout.rows.len();
    let mut G = DMatrix::zeros(m, n);
    let mut h = Vec::with_capacity(m);
    for (k, &(i, sign)) in layout.boxed.iter().enumerate() {
        G[(k, i)] = sign;
        h.push(if sign > 0.0 {
            qp.z_max[i]
        } else {
            -qp.z_min[i]
        });
    }
    for (k, &(r, sign)) in layout.rows.iter().enumerate() {
        let at = layout.boxed.len() + k;
        for j in 0..n {
            G[(at, j)] = sign * qp.A[(r, j)];
        }
        h.push(if sign > 0.0 {
            qp.upper[r]
        } else {
            -qp.lower[r]
        });
    }
    let (P, A) = (csc(&qp.H, true), csc(&G, false));
    for tol in CLARABEL_TOLERANCES {
        let settings = DefaultSettings {
            verbose: false,
            tol_gap_abs: tol,
            tol_gap_rel: tol,
            tol_feas: tol,
            tol_ktratio: 1e3 * tol,
            ..DefaultSettings::default()
        };
        let Ok(mut solver) = DefaultSolver::new(
            &P,
            qp.f.as_slice(),
            &A,
            &h,
            &[SupportedConeT::NonnegativeConeT(m)],
            settings,
        ) else {
            return Clarabel::Undecided;
        };
        solver.solve();
        let s = &solver.solution;
        match s.status {
            SolverStatus::Solved => {
                let z = DVector::from_column_slice(&s.x);
                let objective = 0.5 * z.dot(&(&qp.H * &z)) + qp.f.dot(&z);
                if !z.iter().all(|v| v.is_finite()) {
                    return Clarabel::Undecided;
                }
                let (lambda, slack) = (
                    DVector::from_column_slice(&s.z),
                    DVector::from_column_slice(&s.s),
                );
                let complementarity = lambda
                    .iter()
                    .zip(&slack)
                    .map(|(l, s)| l.min(*s))
                    .fold(0.0, f64::max);
                return Clarabel::Solved(IpmResult {
                    z,
                    lambda,
                    s: slack,
                    iterations: s.iterations as usize,
                    primal_residual: s.r_prim,
                    dual_residual: s.r_dual,
                    gap: solver.info.gap_abs / m.max(1) as f64,
                    relative_gap: super::ipm::relative_gap(solver.info.gap_abs, objective),
                    complementarity,
                    status: Status::Converged,
                });
            }
            SolverStatus::PrimalInfeasible => return Clarabel::Infeasible,
            _ => {}
        }
    }
    Clarabel::Undecided
}
