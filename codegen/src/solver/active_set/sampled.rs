//! The dual active-set method in the sampled certificate ([`crate::certify::sampling`]): a case needs
//! the changes of the working set its solve makes to reach the optimum; before that its iterate is a
//! dual one, which the controller does not use (it falls back), so it counts as failed.

use super::mpc::{control_step, macs_per_iteration, Caps};
use super::{solve_in, Prepared, Status, Tolerances, WorkingSet};
use crate::certify::sampling::{plain_iterate, Iterate, Sampled, Stepped};
use crate::lower::problem::Qp;
use crate::solver::constrained::InequalityQp;
use mpc_spec::Scalar;
use nalgebra::DVector;

/// Changes of the working set a case is first run for, and at most.
pub const PROBE: (usize, usize) = (64, 2048);

/// The dual active-set method of `qp`, prepared once for the sample, in the module's scalar: an f32
/// module's kernel runs in f32 here, so its solutions are checked against the f64 exact ones.
pub struct ActiveSet {
    prepared: Prepared,
    scalar: Scalar,
    /// The exact cold count where the certificate has one (else 0): the cold restart's cap is at least it.
    exact_cold: usize,
}

impl ActiveSet {
    /// The method on `prepared`, the QP's structure, run in `scalar`, its cold restarts capped at no
    /// less than `exact_cold` (the exact count, or 0).
    pub fn new(prepared: Prepared, scalar: Scalar, exact_cold: usize) -> Self {
        ActiveSet {
            prepared,
            scalar,
            exact_cold,
        }
    }
}

impl Sampled for ActiveSet {
    type Start = Option<WorkingSet>;

    fn title(&self) -> &'static str {
        super::TITLE
    }

    fn cold(&self, _qp: &Qp) -> Option<WorkingSet> {
        None
    }

    fn probe(&self) -> (usize, usize) {
        PROBE
    }

    /// One solve: the iterates before its last change are dual iterates (failed), those after it the
    /// optimum.
    fn trajectory(
        &self,
        _qp: &Qp,
        problem: &InequalityQp,
        start: &Option<WorkingSet>,
        iterations: usize,
    ) -> Vec<Iterate> {
        let failed = || Iterate {
            failed: true,
            ..plain_iterate(DVector::zeros(problem.n()))
        };
        let Ok(offsets) = self.prepared.offsets(problem) else {
            return vec![failed()];
        };
        let out = solve_in(
            &self.prepared,
            &offsets,
            start.as_ref(),
            iterations,
            &Tolerances::of(self.scalar),
            self.scalar,
        );
        let reached = if out.status == Status::Solved {
            out.iterations
        } else {
            iterations + 1
        };
        let work = out.macs.work();
        (0..=iterations)
            .map(|k| {
                let iterate = if k < reached {
                    failed()
                } else {
                    plain_iterate(out.z.clone())
                };
                Iterate { work, ..iterate }
            })
            .collect()
    }

    fn control_step(
        &self,
        qp: &Qp,
        f: &DVector<f64>,
        offset: &DVector<f64>,
        start: &Option<WorkingSet>,
        previous_plan: &DVector<f64>,
        count: usize,
    ) -> Stepped<Option<WorkingSet>> {
        let step = control_step(
            qp,
            &self.prepared,
            f,
            offset,
            start.as_ref(),
            previous_plan,
            Caps::with(count, self.exact_cold),
            false,
            self.scalar,
        );
        let iterate = if step.outcome.status == Status::Solved {
            plain_iterate(step.outcome.z.clone())
        } else {
            Iterate {
                failed: true,
                ..plain_iterate(step.outcome.z.clone())
            }
        };
        Stepped {
            iterate,
            next: step.next_start(),
            fell_back: step.fallback != crate::solver::constrained::Fallback::Solved,
            plan: step.plan,
        }
    }

    fn macs_per_iteration(&self, _qp: &Qp) -> usize {
        macs_per_iteration(&self.prepared)
    }

    fn limits_residuals(&self) -> bool {
        false
    }
}
