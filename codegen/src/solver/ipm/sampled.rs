//! The interior-point method in the sampled certificate ([`crate::certify::sampling`]).

use super::{
    chosen_stages, control_step, mpc_macs_per_iteration, shifted_start, Fallback, InequalityQp,
    IpmResult, Start, Status,
};
use crate::certify::evidence::Limits;
use crate::certify::sampling::{Iterate, Sampled, Stepped, MAX_PROBE};
use crate::lower::problem::Qp;
use nalgebra::DVector;

/// The interior-point method ([`crate::solver::ipm`]): Mehrotra from the shifted (z, s, λ).
pub struct InteriorPoint;

impl Sampled for InteriorPoint {
    type Start = Start;

    fn title(&self) -> &'static str {
        "the interior-point method"
    }

    fn cold(&self, _qp: &Qp) -> Start {
        Start::Cold
    }

    fn probe(&self) -> (usize, usize) {
        (MAX_PROBE, MAX_PROBE)
    }

    fn trajectory(
        &self,
        qp: &Qp,
        problem: &InequalityQp,
        start: &Start,
        iterations: usize,
    ) -> Vec<Iterate> {
        // In the form the emitted method uses (the same iterates to rounding).
        crate::solver::ipm::trajectory_in(problem, start, iterations, chosen_stages(qp).as_ref())
            .into_iter()
            .map(|r| interior_iterate(&r))
            .collect()
    }

    fn control_step(
        &self,
        qp: &Qp,
        f: &DVector<f64>,
        offset: &DVector<f64>,
        start: &Start,
        previous_plan: &DVector<f64>,
        count: usize,
    ) -> Stepped<Start> {
        // The sequences end where the hard rows admit no plan, so a sampled step never relaxes them.
        let step = control_step(
            qp,
            f,
            offset,
            start,
            previous_plan,
            count,
            &Limits::NONE,
            false,
        );
        Stepped {
            iterate: interior_iterate(&step.result),
            next: shifted_start(qp, &step),
            fell_back: step.fallback != Fallback::Solved,
            plan: step.plan,
        }
    }

    fn macs_per_iteration(&self, qp: &Qp) -> usize {
        mpc_macs_per_iteration(qp)
    }

    fn limits_residuals(&self) -> bool {
        true
    }
}

fn interior_iterate(r: &IpmResult) -> Iterate {
    Iterate {
        z: r.z.clone(),
        primal: r.primal_residual,
        dual: r.dual_residual,
        gap: r.relative_gap,
        failed: r.status == Status::NumericalFailure,
        work: 0,
    }
}
