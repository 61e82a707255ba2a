//! The generic runtime solver: the same algorithms as the emitted code, written once over nalgebra
//! matrices built at run time, in f64. It is the oracle every generated controller is tested against
//! and the baseline the benchmarks compare with.
#![allow(non_snake_case)]

use crate::linalg::{kalman_gain_and_posterior, project, symmetrize};
use crate::lower::{Problem, Qp};
use crate::solver::{algorithm, Algorithm, Fgm};
use mpc_spec::{FilterKind, Method};
use nalgebra::{DMatrix, DVector};

/// Fixed-iteration, warm-started MPC over the condensed QP.
#[derive(Clone, Debug)]
pub struct Mpc {
    qp: Qp,
    /// The last plan U (N·nu), stacked by step.
    plan: DVector<f64>,
}

impl Mpc {
    /// A cold controller: its first solve starts from the rest input.
    pub fn new(problem: &Problem) -> Self {
        let qp = problem.qp.clone();
        let plan = rest_plan(&qp);
        Mpc { qp, plan }
    }

    /// The problem's QP.
    pub fn qp(&self) -> &Qp {
        &self.qp
    }

    /// The last plan, N·nu entries stacked by step.
    pub fn plan(&self) -> &DVector<f64> {
        &self.plan
    }

    /// Forgets the warm start.
    pub fn reset(&mut self) {
        self.plan = rest_plan(&self.qp);
    }

    /// The gradient map f = Fx·x0 − Fr·Xref (eq. 10), `xref[k]` the reference of predicted state k+1.
    pub fn linear_term(&self, x0: &DVector<f64>, xref: &[DVector<f64>]) -> DVector<f64> {
        let Xref = stack(xref);
        &self.qp.Fx * x0 - &self.qp.Fr * Xref
    }

    /// One control step: warm start, fixed iterations, first input. Non-finite inputs give the rest input
    /// and reset the warm start, as the emitted code does.
    pub fn solve(&mut self, x0: &DVector<f64>, xref: &[DVector<f64>]) -> DVector<f64> {
        let d = DVector::zeros(self.qp.Fd.ncols());
        self.solve_with_disturbance(x0, &d, xref)
    }

    /// One control step of the offset-free MPC: the prediction includes the estimated input disturbance
    /// `d` and the input cost is on u + d, so f gains Fd·d.
    pub fn solve_with_disturbance(
        &mut self,
        x0: &DVector<f64>,
        d: &DVector<f64>,
        xref: &[DVector<f64>],
    ) -> DVector<f64> {
        let nu = self.qp.u_min.len();
        let finite = |v: &DVector<f64>| v.iter().all(|x| x.is_finite());
        if !finite(x0) || !finite(d) || !xref.iter().all(finite) {
            self.reset();
            return self.qp.rest_input();
        }
        let f = self.linear_term(x0, xref) + &self.qp.Fd * d;
        let start = self.warm_start();
        self.plan = iterate(&self.qp, &f, start, self.qp.iterations);
        self.plan.rows(0, nu).into_owned()
    }

    /// The previous plan shifted by one step, with the rest input appended (Algorithm 1, line 8).
    pub fn warm_start(&self) -> DVector<f64> {
        let nu = self.qp.u_min.len();
        let n = self.plan.len();
        let mut u = DVector::zeros(n);
        u.rows_mut(0, n - nu).copy_from(&self.plan.rows(nu, n - nu));
        u.rows_mut(n - nu, nu).copy_from(&self.qp.rest_input());
        u
    }
}

/// `iterations` steps of the spec's method from `start`, projecting onto the box after each: the
/// algorithm's reference iteration ([`crate::solver::Algorithm::reference`]).
pub fn iterate(qp: &Qp, f: &DVector<f64>, start: DVector<f64>, iterations: usize) -> DVector<f64> {
    let step = |y: &DVector<f64>| project_box(qp, &(y - (&qp.H * y + f) * qp.step));
    algorithm(qp.method).reference(&qp.parameters(), start, iterations, &step)
}

/// The exact minimiser of the box-constrained QP ½UᵀHU + fᵀU, by projected gradient with step 1/L run
/// until the KKT residual is below `tol` (relative to the gradient's scale) or `max_iterations` pass.
pub fn exact_solution(qp: &Qp, f: &DVector<f64>, tol: f64, max_iterations: usize) -> DVector<f64> {
    let mut fast = qp.clone();
    fast.method = Method::Fgm;
    fast.step = 1.0 / qp.L;
    fast.momentum = Fgm.momentum(fast.step, qp.mu);
    let mut u = rest_plan(qp);
    for _ in 0..max_iterations / 100 {
        u = iterate(&fast, f, u, 100);
        if kkt_residual(qp, f, &u) <= tol * (1.0 + f.amax()) {
            break;
        }
    }
    u
}

/// The KKT residual of the box QP at U: the distance between U and its projected gradient step
/// (zero exactly at the optimum), in the gradient's units.
pub fn kkt_residual(qp: &Qp, f: &DVector<f64>, U: &DVector<f64>) -> f64 {
    let g = &qp.H * U + f;
    let stepped = project_box(qp, &(U - &g));
    (U - stepped).amax()
}

fn project_box(qp: &Qp, v: &DVector<f64>) -> DVector<f64> {
    let nu = qp.u_min.len();
    DVector::from_iterator(
        v.len(),
        v.iter()
            .enumerate()
            .map(|(i, x)| project(*x, qp.u_min[i % nu], qp.u_max[i % nu])),
    )
}

fn rest_plan(qp: &Qp) -> DVector<f64> {
    let rest = qp.rest_input();
    DVector::from_iterator(
        qp.N * rest.len(),
        (0..qp.N).flat_map(|_| rest.iter().copied()),
    )
}

fn stack(xs: &[DVector<f64>]) -> DVector<f64> {
    DVector::from_iterator(
        xs.iter().map(|x| x.len()).sum(),
        xs.iter().flat_map(|x| x.iter().copied()),
    )
}

/// The linear Kalman filter: time-varying (Joseph-form update) or with the steady-state gain.
#[derive(Clone, Debug)]
pub struct Kalman {
    F: DMatrix<f64>,
    G: DMatrix<f64>,
    C: DMatrix<f64>,
    Qn: DMatrix<f64>,
    Rn: DMatrix<f64>,
    K_inf: Option<DMatrix<f64>>,
    x: DVector<f64>,
    P: DMatrix<f64>,
}

impl Kalman {
    /// A filter at x0 (and a zero disturbance estimate) with the spec's initial covariance.
    pub fn new(problem: &Problem, x0: DVector<f64>) -> Self {
        let f = &problem.filter;
        let x0 = DVector::from_iterator(
            x0.len() + f.nd,
            x0.iter().copied().chain(std::iter::repeat_n(0.0, f.nd)),
        );
        Kalman {
            F: f.Fa.clone(),
            G: f.Ga.clone(),
            C: f.Ca.clone(),
            Qn: f.Qn.clone(),
            Rn: f.Rn.clone(),
            K_inf: (f.kind == FilterKind::SteadyState).then(|| f.K_inf.clone()),
            P: if f.kind == FilterKind::SteadyState {
                f.P_inf.clone()
            } else {
                f.P0.clone()
            },
            x: x0,
        }
    }

    /// x ← F x + G u; P ← F P Fᵀ + Q. A non-finite input changes nothing.
    pub fn predict(&mut self, u: &DVector<f64>) {
        if !u.iter().all(|v| v.is_finite()) {
            return;
        }
        self.x = &self.F * &self.x + &self.G * u;
        if self.K_inf.is_none() {
            self.P = symmetrize(&(&self.F * &self.P * self.F.transpose() + &self.Qn));
        }
    }

    /// The measurement update; a non-finite measurement is rejected (false, nothing changes).
    pub fn update(&mut self, z: &DVector<f64>) -> bool {
        if !z.iter().all(|v| v.is_finite()) {
            return false;
        }
        let innovation = z - &self.C * &self.x;
        let (K, P) = match &self.K_inf {
            Some(K) => (K.clone(), self.P.clone()),
            None => match kalman_gain_and_posterior(&self.P, &self.C, &self.Rn) {
                Some(kp) => kp,
                None => return false,
            },
        };
        let x = &self.x + K * innovation;
        if !x.iter().all(|v| v.is_finite()) || !P.iter().all(|v| v.is_finite()) {
            return false;
        }
        self.x = x;
        self.P = P;
        true
    }

    /// The estimate: the state, then the disturbance estimate when the spec models one.
    pub fn state(&self) -> &DVector<f64> {
        &self.x
    }

    /// The covariance (prior after `predict`, posterior after `update`; P∞ for the steady-state filter).
    pub fn covariance(&self) -> &DMatrix<f64> {
        &self.P
    }

    /// The gain the next update would use.
    pub fn gain(&self) -> Option<DMatrix<f64>> {
        match &self.K_inf {
            Some(K) => Some(K.clone()),
            None => kalman_gain_and_posterior(&self.P, &self.C, &self.Rn).map(|(K, _)| K),
        }
    }
}

/// One control cycle in the paper's order: filter update, MPC on the estimate, filter predict.
#[derive(Clone, Debug)]
pub struct Controller {
    /// The filter.
    pub kalman: Kalman,
    /// The MPC.
    pub mpc: Mpc,
}

impl Controller {
    /// A controller whose filter starts at x0.
    pub fn new(problem: &Problem, x0: DVector<f64>) -> Self {
        Controller {
            kalman: Kalman::new(problem, x0),
            mpc: Mpc::new(problem),
        }
    }

    /// Update with z, solve from the estimate, predict with the command; returns the command.
    pub fn step(&mut self, z: &DVector<f64>, xref: &[DVector<f64>]) -> DVector<f64> {
        self.kalman.update(z);
        let nx = self.mpc.qp().Fx.ncols();
        let estimate = self.kalman.state();
        let x = estimate.rows(0, nx).into_owned();
        let d = estimate.rows(nx, estimate.len() - nx).into_owned();
        let u = self.mpc.solve_with_disturbance(&x, &d, xref);
        self.kalman.predict(&u);
        u
    }
}
