//! The generic runtime solver: the same algorithms as the emitted code, written once over nalgebra
//! matrices built at run time, in f64. It is the oracle every generated controller is tested against
//! and the baseline the benchmarks compare with.
#![allow(non_snake_case)]

use crate::linalg::{kalman_gain_and_posterior, symmetrize, Gain};
use crate::lower::problem::{Problem, Qp, Screening};
use crate::solver::admm;
use crate::solver::first_order::reference as first_order;
use crate::solver::first_order::{Algorithm, Fgm};
use crate::solver::ipm::Step;
use crate::solver::stepping::{StepData, Stepping};
use mpc_spec::{FilterKind, Method};
use nalgebra::{DMatrix, DVector};

/// Fixed-iteration, warm-started MPC over the condensed QP.
#[derive(Clone, Debug)]
pub struct Mpc {
    qp: Qp,
    /// The last plan V (Nc·nu: the free inputs), stacked by step.
    plan: DVector<f64>,
    /// u₋₁, the last input returned (or set): what the first move Δu₀ is measured from.
    last: DVector<f64>,
    /// The method's state between steps (its warm start, last step, recovery).
    stepping: Stepping,
    /// Whether the last solve's reference lay outside the region's range ([`Qp::reach_reference`]).
    reference_beyond_region: bool,
}

impl Mpc {
    /// A cold controller: its first solve starts from the rest input, which is also its last input.
    pub fn new(problem: &Problem) -> Self {
        let qp = problem.qp.clone();
        let plan = qp.rest_plan();
        let last = qp.rest_input();
        Mpc {
            qp,
            plan,
            last,
            stepping: Stepping::cold(),
            reference_beyond_region: false,
        }
    }

    /// Whether an entry of the last constrained solve's reference lay outside `[mpc.region]`'s reference
    /// range (and was brought within the distance the region covers, [`Qp::reach_reference`]).
    pub fn reference_beyond_region(&self) -> bool {
        self.reference_beyond_region
    }

    /// ADMM's last step (its residuals, status and fallback); `None` before the first solve, after a
    /// reset, or for another method.
    pub fn admm_step(&self) -> Option<&admm::Step> {
        self.stepping.admm_step.as_ref()
    }

    /// The dual active-set method's last step (its outcome and fallback); `None` before the first solve,
    /// after a reset, or for another method.
    pub fn active_set_step(&self) -> Option<&crate::solver::active_set::mpc::Step> {
        self.stepping.active_set_step.as_ref()
    }

    /// The interior-point method's last step (its residuals, iterations and fallback); `None` before
    /// the first solve, after a reset, or for a first-order method.
    pub fn last_step(&self) -> Option<&Step> {
        self.stepping.last_step.as_ref()
    }

    /// The last input u₋₁ the moves are measured from.
    pub fn last_input(&self) -> &DVector<f64> {
        &self.last
    }

    /// Sets u₋₁, for a vehicle flown by something else before. A non-finite entry is refused (false).
    pub fn set_last_input(&mut self, u: &DVector<f64>) -> bool {
        let finite = u.iter().all(|v| v.is_finite());
        if finite {
            self.last = u.clone();
        }
        finite
    }

    /// The problem's QP.
    pub fn qp(&self) -> &Qp {
        &self.qp
    }

    /// The last plan, N·nu entries stacked by step (the held inputs of a control horizon expanded).
    pub fn plan(&self) -> DVector<f64> {
        self.qp.expand(&self.plan)
    }

    /// The last plan of the QP's variables: the Nc free inputs (N·nu entries without a control horizon).
    pub fn free_plan(&self) -> &DVector<f64> {
        &self.plan
    }

    /// Forgets the warm start and the last input.
    pub fn reset(&mut self) {
        self.plan = self.qp.rest_plan();
        self.last = self.qp.rest_input();
        self.stepping = Stepping::cold();
        self.reference_beyond_region = false;
    }

    /// The gradient map f = Fx·x0 − Fr·Xref + Fu·u₋₁ (eq. 10 with the moves), `xref[k]` the reference of
    /// predicted step k+1 (states, or outputs with `[mpc] outputs`).
    pub fn linear_term(&self, x0: &DVector<f64>, xref: &[DVector<f64>]) -> DVector<f64> {
        let Xref = stack(xref);
        &self.qp.Fx * x0 - &self.qp.Fr * Xref + &self.qp.Fu * &self.last
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
        let mut window = xref.to_vec();
        self.reference_beyond_region = self.qp.reach_reference(x0, &mut window);
        let f = self.linear_term(x0, &window) + &self.qp.Fd * d;
        let data = StepData {
            f: &f,
            x0,
            d,
            last: &self.last,
            plan: &self.plan,
        };
        self.plan = crate::plan::of(self.qp.method).oracle_step(&self.qp, &mut self.stepping, data);
        self.last = self.plan.rows(0, nu).into_owned();
        self.last.clone()
    }

    /// The previous plan shifted by one step, with the rest input appended (Algorithm 1, line 8).
    pub fn warm_start(&self) -> DVector<f64> {
        first_order::shifted(&self.qp, &self.plan)
    }
}

/// `iterations` steps of the spec's method from `start`, projecting onto the box after each: the
/// algorithm's reference iteration ([`crate::solver::first_order::Algorithm::reference`]).
pub fn iterate(qp: &Qp, f: &DVector<f64>, start: DVector<f64>, iterations: usize) -> DVector<f64> {
    // The constrained methods have their own step (`solve_with_disturbance`); FGM stands in for them here.
    let algorithm = crate::plan::of(qp.method).first_order().unwrap_or(&Fgm);
    first_order::iterate(algorithm, qp, f, start, iterations)
}

/// The exact minimiser of the box-constrained QP ½UᵀHU + fᵀU, by projected gradient with step 1/L run
/// until the KKT residual is below `tol` (relative to the gradient's scale) or `max_iterations` pass.
pub fn exact_solution(qp: &Qp, f: &DVector<f64>, tol: f64, max_iterations: usize) -> DVector<f64> {
    let mut fast = qp.clone();
    fast.method = Method::Fgm;
    fast.step = 1.0 / qp.L;
    fast.momentum = Fgm.momentum(fast.step, qp.mu);
    let mut u = qp.rest_plan();
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
    first_order::project_box(qp, v)
}

fn stack(xs: &[DVector<f64>]) -> DVector<f64> {
    DVector::from_iterator(
        xs.iter().map(|x| x.len()).sum(),
        xs.iter().flat_map(|x| x.iter().copied()),
    )
}

/// What the filter did with a reading: the emitted `Measurement` without its `NoneYet`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Measurement {
    /// Fused by the Kalman update.
    Accepted,
    /// Fused by re-acquisition (the estimate moved onto the measurement).
    Reacquired,
    /// A NaN or infinite entry.
    NonFinite,
    /// The normalized innovation squared exceeded the gate.
    Gated,
    /// Bit-identical to the readings before it for `stuck_cycles` cycles.
    Stuck,
    /// The update's arithmetic failed.
    Numerical,
}

impl Measurement {
    /// Whether the reading was fused.
    pub fn accepted(self) -> bool {
        matches!(self, Measurement::Accepted | Measurement::Reacquired)
    }
}

/// The linear Kalman filter: time-varying (Joseph-form update) or with the steady-state gain, with the
/// emitted filter's measurement screening (gate, stuck sensor, re-acquisition, disturbance bound).
#[derive(Clone, Debug)]
pub struct Kalman {
    F: DMatrix<f64>,
    G: DMatrix<f64>,
    C: DMatrix<f64>,
    Qn: DMatrix<f64>,
    Rn: DMatrix<f64>,
    P0: DMatrix<f64>,
    K_inf: Option<DMatrix<f64>>,
    S_inf_inv: DMatrix<f64>,
    /// The steady-state filter's gains after a re-acquisition (`Filter::restart`).
    restart: Vec<Gain>,
    /// Readings fused since the last re-acquisition, up to the restart table's length: the entry the
    /// next reading uses.
    fused: usize,
    C_pinv: DMatrix<f64>,
    screening: Screening,
    /// The disturbance bound [−u_max, −u_min], per input; empty without a disturbance model.
    d_bounds: Vec<(f64, f64)>,
    x: DVector<f64>,
    P: DMatrix<f64>,
    valid: bool,
    last: Option<DVector<f64>>,
    repeats: u32,
    gated: u32,
    /// Readings rejected in a row.
    pub consecutive_rejections: u32,
    /// Re-acquisitions, the first acquisition included.
    pub reacquisitions: u32,
    /// Whether the last fused update held the disturbance estimate at its bound.
    pub disturbance_clamped: bool,
}

impl Kalman {
    /// A filter at x0 (and a zero disturbance estimate) with the spec's initial covariance; without an
    /// estimate when x0 is not finite. `None` when the spec has no `[kalman]`.
    pub fn new(problem: &Problem, x0: DVector<f64>) -> Option<Self> {
        let f = problem.filter.as_ref()?;
        let valid = x0.iter().all(|v| v.is_finite());
        let x0 = DVector::from_iterator(
            x0.len() + f.nd,
            x0.iter()
                .map(|v| if valid { *v } else { 0.0 })
                .chain(std::iter::repeat_n(0.0, f.nd)),
        );
        let qp = &problem.qp;
        let d_bounds = if f.nd > 0 {
            qp.u_max
                .iter()
                .zip(qp.u_min.iter())
                .map(|(hi, lo)| (-hi, -lo))
                .collect()
        } else {
            Vec::new()
        };
        Some(Kalman {
            F: f.Fa.clone(),
            G: f.Ga.clone(),
            C: f.Ca.clone(),
            Qn: f.Qn.clone(),
            Rn: f.Rn.clone(),
            P0: f.P0.clone(),
            K_inf: (f.kind == FilterKind::SteadyState).then(|| f.K_inf.clone()),
            S_inf_inv: f.S_inf_inv.clone(),
            restart: f.restart.clone(),
            fused: f.restart.len(),
            C_pinv: f.C_pinv.clone(),
            screening: f.screening,
            d_bounds,
            P: if f.kind == FilterKind::SteadyState {
                f.P_inf.clone()
            } else {
                f.P0.clone()
            },
            x: x0,
            valid,
            last: None,
            repeats: 0,
            gated: 0,
            consecutive_rejections: 0,
            reacquisitions: 0,
            disturbance_clamped: false,
        })
    }

    /// x ← F x + G u; P ← F P Fᵀ + Q. A non-finite input, or a filter without an estimate, changes
    /// nothing.
    pub fn predict(&mut self, u: &DVector<f64>) {
        if !self.valid || !u.iter().all(|v| v.is_finite()) {
            return;
        }
        self.x = &self.F * &self.x + &self.G * u;
        if self.K_inf.is_none() {
            self.P = symmetrize(&(&self.F * &self.P * self.F.transpose() + &self.Qn));
        }
    }

    /// The measurement update after the screening; returns what was done with `z`.
    pub fn update(&mut self, z: &DVector<f64>) -> Measurement {
        let verdict = self.screen(z);
        if verdict.accepted() {
            self.consecutive_rejections = 0;
            self.gated = 0;
        } else {
            self.consecutive_rejections = self.consecutive_rejections.saturating_add(1);
        }
        verdict
    }

    fn screen(&mut self, z: &DVector<f64>) -> Measurement {
        if !z.iter().all(|v| v.is_finite()) {
            return Measurement::NonFinite;
        }
        let s = self.screening;
        let changing = match &self.last {
            Some(last) => last
                .iter()
                .zip(z.iter())
                .any(|(a, b)| a.to_bits() != b.to_bits()),
            None => true,
        };
        self.repeats = if changing {
            1
        } else {
            self.repeats.saturating_add(1)
        };
        self.last = Some(z.clone());
        if s.stuck_cycles.is_some_and(|n| self.repeats >= n) {
            return Measurement::Stuck;
        }
        if !self.valid {
            return self.reacquire(z);
        }
        let innovation = z - &self.C * &self.x;
        let restart = self.restart.get(self.fused);
        let S_inv = match (&self.K_inf, restart) {
            (Some(_), Some(g)) => g.S_inv.clone(),
            (Some(_), None) => self.S_inf_inv.clone(),
            (None, _) => match (&self.C * &self.P * self.C.transpose() + &self.Rn).cholesky() {
                Some(c) => c.inverse(),
                None => return Measurement::Numerical,
            },
        };
        if let Some(gate) = s.gate {
            let nis = innovation.dot(&(&S_inv * &innovation));
            // NaN is gated too.
            if nis.is_nan() || nis > gate {
                if changing {
                    self.gated = self.gated.saturating_add(1);
                }
                if self.gated >= s.reacquire_after {
                    return self.reacquire(z);
                }
                return Measurement::Gated;
            }
        }
        let (K, P) = match (&self.K_inf, restart) {
            (Some(_), Some(g)) => (g.K.clone(), self.P.clone()),
            (Some(K), None) => (K.clone(), self.P.clone()),
            (None, _) => match kalman_gain_and_posterior(&self.P, &self.C, &self.Rn) {
                Some(kp) => kp,
                None => return Measurement::Numerical,
            },
        };
        let mut x = &self.x + K * innovation;
        if !x.iter().all(|v| v.is_finite()) || !P.iter().all(|v| v.is_finite()) {
            return Measurement::Numerical;
        }
        let nx = x.len() - self.d_bounds.len();
        let mut clamped = false;
        for (v, (lo, hi)) in x.iter_mut().skip(nx).zip(&self.d_bounds) {
            let bounded = v.clamp(*lo, *hi);
            clamped |= bounded != *v;
            *v = bounded;
        }
        self.disturbance_clamped = clamped;
        self.x = x;
        self.P = P;
        self.fused = (self.fused + 1).min(self.restart.len());
        Measurement::Accepted
    }

    /// x ← x + C⁺ (z − C x); P ← P0 (time-varying), or the restart table from its start
    /// (steady-state).
    fn reacquire(&mut self, z: &DVector<f64>) -> Measurement {
        let x = &self.x + &self.C_pinv * (z - &self.C * &self.x);
        if !x.iter().all(|v| v.is_finite()) {
            return Measurement::Numerical;
        }
        self.x = x;
        if self.K_inf.is_none() {
            self.P = self.P0.clone();
        }
        self.fused = 0;
        self.gated = 0;
        self.valid = true;
        self.reacquisitions = self.reacquisitions.saturating_add(1);
        Measurement::Reacquired
    }

    /// Moves the estimate by `dx`: a perturbation where the emitted filter rounds what it stores
    /// (`codegen/tests/coordinates.rs` measures the controller's response to it).
    pub fn perturb(&mut self, dx: &DVector<f64>) {
        self.x += dx;
    }

    /// Whether the filter holds an estimate.
    pub fn has_estimate(&self) -> bool {
        self.valid
    }

    /// The estimate: the state, then the disturbance estimate when the spec models one.
    pub fn state(&self) -> &DVector<f64> {
        &self.x
    }

    /// The covariance (prior after `predict`, posterior after `update`; P∞ for the steady-state filter,
    /// its restart table included).
    pub fn covariance(&self) -> &DMatrix<f64> {
        &self.P
    }

    /// The gain the next update would use (an entry of the restart table after a re-acquisition of the
    /// steady-state filter).
    pub fn gain(&self) -> Option<DMatrix<f64>> {
        match (&self.K_inf, self.restart.get(self.fused)) {
            (Some(_), Some(g)) => Some(g.K.clone()),
            (Some(K), None) => Some(K.clone()),
            (None, _) => kalman_gain_and_posterior(&self.P, &self.C, &self.Rn).map(|(K, _)| K),
        }
    }
}

/// One control cycle in the paper's order: filter update, MPC on the estimate, filter predict; or,
/// without a filter, the MPC on the measured state.
#[derive(Clone, Debug)]
pub struct Controller {
    /// The filter; `None` for state feedback.
    pub kalman: Option<Kalman>,
    /// The MPC.
    pub mpc: Mpc,
}

impl Controller {
    /// A controller whose filter starts at x0 (ignored without a filter).
    pub fn new(problem: &Problem, x0: DVector<f64>) -> Self {
        Controller {
            kalman: Kalman::new(problem, x0),
            mpc: Mpc::new(problem),
        }
    }

    /// Update with z, solve from the estimate, predict with the command; returns the command (the rest
    /// input while the filter has no estimate). Without a filter z is the state.
    pub fn step(&mut self, z: &DVector<f64>, xref: &[DVector<f64>]) -> DVector<f64> {
        let Some(kalman) = self.kalman.as_mut() else {
            return self.mpc.solve(z, xref);
        };
        kalman.update(z);
        if !kalman.has_estimate() {
            self.mpc.reset();
            return self.mpc.qp().rest_input();
        }
        let nx = self.mpc.qp().Fx.ncols();
        let estimate = kalman.state();
        let x = estimate.rows(0, nx).into_owned();
        let d = estimate.rows(nx, estimate.len() - nx).into_owned();
        let u = self.mpc.solve_with_disturbance(&x, &d, xref);
        kalman.predict(&u);
        u
    }
}
