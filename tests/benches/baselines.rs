//! Established QP solvers set up on the benchmark's condensed QPs: min ½UᵀHU + fᵀU subject to
//! u_min ≤ U ≤ u_max (the box repeated for each of the N steps). Each solver is set up once per horizon
//! with H and the box; a solve only replaces the linear term q = f, as a controller calling them would.
//!
//! - Clarabel (pure Rust interior point): default settings but `verbose = false`; q replaced through its
//!   data-update API (`DefaultSolver::update_q`), no refactorisation of the KKT pattern, no warm start
//!   (an interior-point method has none).
//! - OSQP 0.6.3 (ADMM, C library, behind the `osqp` feature): default settings but `verbose = false`
//!   (eps_abs = eps_rel = 1e-3, warm start on, no polishing); q replaced with `update_lin_cost`, warm-started
//!   from the previous solve's primal and dual iterates.
//!
//! H is passed sparse: its upper triangle without its exact zeros (the three axes do not couple, so
//! H has nu·N² nonzeros of (nu·N)²), the same zeros the generated code skips.
#![allow(non_snake_case)]

use codegen::lower::Qp;

/// The upper triangle of the dense symmetric `H` in compressed sparse columns, exact zeros dropped:
/// (column pointers, row indices, values).
pub fn upper_triangle_csc(qp: &Qp) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
    let n = qp.H.nrows();
    let (mut colptr, mut rowval, mut nzval) = (vec![0], Vec::new(), Vec::new());
    for j in 0..n {
        for i in 0..=j {
            let v = qp.H[(i, j)];
            if v != 0.0 {
                rowval.push(i);
                nzval.push(v);
            }
        }
        colptr.push(rowval.len());
    }
    (colptr, rowval, nzval)
}

/// The box bounds repeated over the horizon: (lower, upper), N·nu entries each.
pub fn box_bounds(qp: &Qp) -> (Vec<f64>, Vec<f64>) {
    let nu = qp.u_min.len();
    let n = qp.N * nu;
    (
        (0..n).map(|i| qp.u_min[i % nu]).collect(),
        (0..n).map(|i| qp.u_max[i % nu]).collect(),
    )
}

/// Clarabel on the box QP: the box as the cone constraint [I; −I]·U + s = [u_max; −u_min], s ≥ 0.
pub struct Clarabel {
    solver: clarabel::solver::DefaultSolver<f64>,
    /// q for `update_q`, which takes a sized container (`Vec`), not a slice.
    q: Vec<f64>,
}

impl Clarabel {
    /// Set up once: H, the constraint matrix and the bounds; q starts at zero.
    pub fn new(qp: &Qp) -> Self {
        use clarabel::algebra::CscMatrix;
        use clarabel::solver::{DefaultSettings, DefaultSolver, SupportedConeT};

        let n = qp.H.nrows();
        let (colptr, rowval, nzval) = upper_triangle_csc(qp);
        let P = CscMatrix::new(n, n, colptr, rowval, nzval);
        // Column j of [I; −I]: +1 in row j, −1 in row n + j.
        let A = CscMatrix::new(
            2 * n,
            n,
            (0..=n).map(|j| 2 * j).collect(),
            (0..n).flat_map(|j| [j, n + j]).collect(),
            (0..n).flat_map(|_| [1.0, -1.0]).collect(),
        );
        let (lo, hi) = box_bounds(qp);
        let b: Vec<f64> = hi.iter().copied().chain(lo.iter().map(|v| -v)).collect();
        let cones = [SupportedConeT::NonnegativeConeT(2 * n)];
        let settings = DefaultSettings {
            verbose: false,
            ..DefaultSettings::default()
        };
        let solver = DefaultSolver::new(&P, &vec![0.0; n], &A, &b, &cones, settings)
            .expect("Clarabel set-up");
        assert!(
            solver.is_data_update_allowed(),
            "Clarabel presolved the box QP: q cannot be updated in place"
        );
        Clarabel {
            solver,
            q: vec![0.0; n],
        }
    }

    /// Replace q and solve; the minimiser U.
    pub fn solve(&mut self, q: &[f64]) -> &[f64] {
        use clarabel::solver::{IPSolver, SolverStatus};
        self.q.copy_from_slice(q);
        self.solver.update_q(&self.q).expect("Clarabel update_q");
        self.solver.solve();
        let status = self.solver.solution.status;
        assert!(
            matches!(status, SolverStatus::Solved | SolverStatus::AlmostSolved),
            "Clarabel: {status:?}"
        );
        &self.solver.solution.x
    }

    /// Interior-point iterations of the last solve.
    pub fn iterations(&self) -> u32 {
        self.solver.info.iterations
    }
}

/// OSQP on the box QP: the box as l ≤ I·U ≤ u.
#[cfg(feature = "osqp")]
pub struct Osqp {
    problem: osqp::Problem,
    iterations: u32,
}

#[cfg(feature = "osqp")]
impl Osqp {
    /// Set up once (factorises the KKT matrix); q starts at zero.
    pub fn new(qp: &Qp) -> Self {
        use osqp::{CscMatrix, Problem, Settings};
        use std::borrow::Cow;

        let n = qp.H.nrows();
        let (colptr, rowval, nzval) = upper_triangle_csc(qp);
        let P = CscMatrix {
            nrows: n,
            ncols: n,
            indptr: Cow::Owned(colptr),
            indices: Cow::Owned(rowval),
            data: Cow::Owned(nzval),
        };
        let A = CscMatrix {
            nrows: n,
            ncols: n,
            indptr: Cow::Owned((0..=n).collect()),
            indices: Cow::Owned((0..n).collect()),
            data: Cow::Owned(vec![1.0; n]),
        };
        let (lo, hi) = box_bounds(qp);
        let settings = Settings::default().verbose(false);
        let problem = Problem::new(P, &vec![0.0; n], A, &lo, &hi, &settings).expect("OSQP set-up");
        Osqp {
            problem,
            iterations: 0,
        }
    }

    /// Replace q and solve from the previous iterates; the minimiser U (to OSQP's tolerances).
    pub fn solve(&mut self, q: &[f64]) -> &[f64] {
        use osqp::Status;
        self.problem.update_lin_cost(q);
        let status = self.problem.solve();
        self.iterations = status.iter();
        match status {
            Status::Solved(s) | Status::SolvedInaccurate(s) | Status::MaxIterationsReached(s) => {
                s.x()
            }
            _ => panic!("OSQP: {status:?}"),
        }
    }

    /// ADMM iterations of the last solve.
    pub fn iterations(&self) -> u32 {
        self.iterations
    }
}
