//! The dual active-set method as the controller runs it: one control step on the MPC's QP, its
//! fallback and its warm start, the same in the oracle, the certificate and the emitted module.
//!
//! A step solves the QP of [`mpc_qp`] (relaxed where the controller is recovering, as the other
//! constrained methods do) from the previous step's working set, with at most the certified count of
//! changes of the working set. A solve that ends anywhere but at the optimum falls back: a truncated
//! dual iterate is not primal feasible, so its plan is not used; the plan is the previous one shifted by
//! one step with the rest input appended, projected onto the box ([`held_plan`]), and the next solve
//! starts cold. The warm start is the previous working set as it was, not shifted in time: on the shipped
//! specs it needs fewer changes at the median than the shifted set (`codegen/tests/active_set.rs`
//! prints both).
#![allow(non_snake_case)]

use super::{solve_in, Outcome, Prepared, Status as Ended, Tolerances, WorkingSet};
use crate::lower::problem::Qp;
use crate::solver::constrained::Fallback;
use crate::solver::ipm::{held_plan, mpc_qp, relaxed, violations};
use mpc_spec::Scalar;
use nalgebra::DVector;

/// The method's build-time data of `qp`: the QP's constant structure prepared (its f and sides do not
/// matter). `None` where a block of H is not positive definite, which lowering rules out.
pub fn prepare(qp: &Qp) -> Option<Prepared> {
    let n = qp.Nc * qp.u_min.len();
    let structure = mpc_qp(qp, &DVector::zeros(n), &DVector::zeros(qp.rows.len()));
    Prepared::new(&structure).ok()
}

/// One control step of the dual active-set method.
#[derive(Clone, Debug)]
pub struct Step {
    /// The plan U (N·nu), inside the input box.
    pub plan: DVector<f64>,
    /// The solve (its z includes the slacks).
    pub outcome: Outcome,
    /// Whether the plan is the solve's.
    pub fallback: Fallback,
}

impl Step {
    /// The next step's warm start: this step's working set where its plan is the optimum of the QP the
    /// certificate covers (not a relaxed one); a cold start otherwise.
    pub fn next_start(&self) -> Option<WorkingSet> {
        (self.fallback == Fallback::Solved).then(|| self.outcome.working_set.clone())
    }

    /// Whether the controller is recovering after this step: the hard rows admitted no plan, or the
    /// plan is a relaxed one.
    pub fn recovering(&self) -> bool {
        self.outcome.status == Ended::Infeasible || self.fallback == Fallback::Relaxed
    }
}

/// One control step: at most `count` changes of the working set from `start` (cold where `None` or
/// where the step relaxes) by the kernel in `scalar` (f32 as an f32 module runs it), then the plan, or
/// the held plan where the solve did not end at the optimum.
#[allow(clippy::too_many_arguments)]
pub fn control_step(
    qp: &Qp,
    prepared: &Prepared,
    f: &DVector<f64>,
    offset: &DVector<f64>,
    start: Option<&WorkingSet>,
    previous_plan: &DVector<f64>,
    count: usize,
    recovering: bool,
    scalar: Scalar,
) -> Step {
    let held = held_plan(qp, previous_plan);
    let relax = recovering && violations(qp, &held, offset).0 > qp.accuracy;
    let mut problem = mpc_qp(qp, f, offset);
    if relax {
        problem = relaxed(qp, problem, &held);
    }
    let start = if relax { None } else { start };
    let outcome = match prepared.offsets(&problem) {
        Ok(offsets) => solve_in(
            prepared,
            &offsets,
            start,
            count,
            &Tolerances::of(scalar),
            scalar,
        ),
        Err(_) => failed(problem.n()),
    };
    let n = f.len();
    let nu = qp.u_min.len();
    if outcome.status == Ended::Solved {
        let plan = DVector::from_fn(n, |i, _| {
            crate::linalg::project(outcome.z[i], qp.u_min[i % nu], qp.u_max[i % nu])
        });
        return Step {
            plan,
            outcome,
            fallback: if relax {
                Fallback::Relaxed
            } else {
                Fallback::Solved
            },
        };
    }
    Step {
        plan: held,
        outcome,
        fallback: Fallback::WarmStart,
    }
}

/// The outcome of data the kernel refuses (a non-finite f or side): a numerical failure.
fn failed(n: usize) -> Outcome {
    Outcome {
        status: Ended::NumericalFailure,
        z: DVector::from_element(n, f64::NAN),
        working_set: WorkingSet::default(),
        multipliers: Vec::new(),
        iterations: 0,
        block_iterations: Vec::new(),
        macs: Default::default(),
        per_pass: Vec::new(),
    }
}

/// Multiply-adds of the worst pass of the iteration (one change of the working set) over the blocks:
/// a scan of every constraint against a full working set, an addition to the factor, a removal, the
/// solve with the factor and the step.
pub fn macs_per_iteration(prepared: &Prepared) -> usize {
    prepared
        .blocks
        .iter()
        .map(|b| {
            let (n, nc) = (b.n() + 1, b.rows.len());
            nc * n + n * n / 2 + 2 * n + n * n + 5 * n + n * n + 2 * n
        })
        .max()
        .unwrap_or(0)
}

/// Multiply-adds of what runs once per solve: the offsets (two triangular solves and a sparse row per
/// constraint) and the recovery of z, per block.
pub fn macs_once(prepared: &Prepared) -> usize {
    prepared
        .blocks
        .iter()
        .map(|b| {
            let n = b.n();
            n * (n + 1) + b.coefficients.iter().map(|c| c.len() + 2).sum::<usize>() + n * (n + 1)
        })
        .sum()
}
