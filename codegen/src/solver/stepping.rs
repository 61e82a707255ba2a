//! The oracle's state between control steps and the data of one step, which every method's
//! [`crate::plan::Solver::oracle_step`] takes.

use crate::solver::active_set;
use crate::solver::admm;
use crate::solver::ipm;
use nalgebra::DVector;

/// What the f64 oracle keeps between control steps for the method it runs; each method reads and writes
/// its own fields (a first-order method none: its warm start is the plan).
#[derive(Clone, Debug)]
pub struct Stepping {
    /// The interior-point method's warm start.
    pub start: ipm::Start,
    /// The interior-point method's last step: its solve and fallback.
    pub last_step: Option<ipm::Step>,
    /// ADMM's warm start.
    pub admm_start: admm::Start,
    /// ADMM's last step.
    pub admm_step: Option<admm::Step>,
    /// The dual active-set method's warm start: the last working set.
    pub active_set_start: Option<active_set::WorkingSet>,
    /// The dual active-set method's last step.
    pub active_set_step: Option<active_set::mpc::Step>,
    /// The dual active-set method's build-time data, prepared on its first step.
    pub active_set_prepared: Option<std::sync::Arc<active_set::Prepared>>,
    /// Whether the controller is recovering from infeasible hard rows ([`ipm::recovering_after`]).
    pub relax: bool,
}

impl Stepping {
    /// The state of a cold controller.
    pub fn cold() -> Self {
        Stepping {
            start: ipm::Start::Cold,
            last_step: None,
            admm_start: admm::Start::Cold,
            admm_step: None,
            active_set_start: None,
            active_set_step: None,
            active_set_prepared: None,
            relax: false,
        }
    }
}

/// One control step's data: the QP's linear term, and what the rows' offsets are formed from.
#[derive(Clone, Copy, Debug)]
pub struct StepData<'a> {
    /// The linear term f (the reference already brought within reach).
    pub f: &'a DVector<f64>,
    /// The current state.
    pub x0: &'a DVector<f64>,
    /// The estimated input disturbance (empty without a disturbance model).
    pub d: &'a DVector<f64>,
    /// The last input u₋₁.
    pub last: &'a DVector<f64>,
    /// The previous plan, N·nu entries stacked by step.
    pub plan: &'a DVector<f64>,
}
