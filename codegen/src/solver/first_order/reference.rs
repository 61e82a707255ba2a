//! The first-order methods' f64 reference iteration on a lowered QP: what the oracle runs.

use super::Algorithm;
use crate::linalg::project;
use crate::lower::problem::Qp;
use nalgebra::DVector;

/// `v` projected onto the input box repeated over the plan's steps.
pub fn project_box(qp: &Qp, v: &DVector<f64>) -> DVector<f64> {
    let nu = qp.u_min.len();
    DVector::from_iterator(
        v.len(),
        v.iter()
            .enumerate()
            .map(|(i, x)| project(*x, qp.u_min[i % nu], qp.u_max[i % nu])),
    )
}

/// The plan shifted by one step, with the rest input appended (Algorithm 1, line 8): the warm start.
pub fn shifted(qp: &Qp, plan: &DVector<f64>) -> DVector<f64> {
    let nu = qp.u_min.len();
    let n = plan.len();
    let mut u = DVector::zeros(n);
    u.rows_mut(0, n - nu).copy_from(&plan.rows(nu, n - nu));
    u.rows_mut(n - nu, nu).copy_from(&qp.rest_input());
    u
}

/// `iterations` steps of `algorithm` from `start`, projecting onto the box after each: its reference
/// iteration ([`Algorithm::reference`]).
pub fn iterate(
    algorithm: &dyn Algorithm,
    qp: &Qp,
    f: &DVector<f64>,
    start: DVector<f64>,
    iterations: usize,
) -> DVector<f64> {
    let step = |y: &DVector<f64>| project_box(qp, &(y - (&qp.H * y + f) * qp.step));
    algorithm.reference(&qp.parameters(), start, iterations, &step)
}
