//! The exact reference of the constrained QPs: Clarabel (pure Rust interior point) on a
//! `codegen::ipm::InequalityQp`, at the tightest tolerance it solves to. Shared by
//! `codegen/tests/ipm.rs` and `tests/tests/constrained.rs` through `#[path]`.
#![allow(non_snake_case)]

use codegen::ipm::InequalityQp;
use nalgebra::{DMatrix, DVector};

/// Clarabel on the same QP, its finite sides stacked as G z + s = h, s ≥ 0.
pub fn clarabel(qp: &InequalityQp) -> DVector<f64> {
    use clarabel::algebra::CscMatrix;
    use clarabel::solver::{
        DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
    };
    let n = qp.n();
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
    let mut rows: Vec<(DVector<f64>, f64)> = Vec::new();
    for i in 0..n {
        let e = DVector::from_fn(n, |j, _| if i == j { 1.0 } else { 0.0 });
        if qp.z_max[i].is_finite() {
            rows.push((e.clone(), qp.z_max[i]));
        }
        if qp.z_min[i].is_finite() {
            rows.push((-e, -qp.z_min[i]));
        }
    }
    for r in 0..qp.A.nrows() {
        let a = qp.A.row(r).transpose();
        if qp.upper[r].is_finite() {
            rows.push((a.clone(), qp.upper[r]));
        }
        if qp.lower[r].is_finite() {
            rows.push((-a, -qp.lower[r]));
        }
    }
    let m = rows.len();
    let G = DMatrix::from_fn(m, n, |r, j| rows[r].0[j]);
    let h: Vec<f64> = rows.iter().map(|r| r.1).collect();
    // The tightest tolerance Clarabel reaches with `Solved`: at 1e-10 its plan can be 5e-6 of the span
    // off on the two-mass QP, and where it stalls at 1e-13 it returns `AlmostSolved` with the reduced
    // tolerances (5e-3 of the span off on a velocity-and-altitude case). The hover QP (κ(H) = 2.8e4) can
    // need 1e-8.
    for tol in [1e-13, 1e-12, 1e-11, 1e-10, 1e-9, 1e-8] {
        let settings = DefaultSettings {
            verbose: false,
            tol_gap_abs: tol,
            tol_gap_rel: tol,
            tol_feas: tol,
            tol_ktratio: 1e3 * tol,
            ..DefaultSettings::default()
        };
        let mut solver = DefaultSolver::new(
            &csc(&qp.H, true),
            qp.f.as_slice(),
            &csc(&G, false),
            &h,
            &[SupportedConeT::NonnegativeConeT(m)],
            settings,
        )
        .expect("Clarabel set-up");
        solver.solve();
        if solver.solution.status == SolverStatus::Solved {
            return DVector::from_column_slice(&solver.solution.x);
        }
    }
    panic!("Clarabel solved the QP to none of 1e-13 … 1e-8");
}
