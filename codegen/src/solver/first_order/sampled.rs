//! The first-order methods in the sampled certificate ([`crate::certify::sampling`]).

use super::Algorithm;
use crate::certify::sampling::{plain_iterate, Iterate, Sampled, Stepped};
use crate::lower::problem::Qp;
use crate::solver::constrained::InequalityQp;
use nalgebra::DVector;

/// A first-order method on the input box ([`crate::solver::first_order::Algorithm`]): its reference iteration with
/// the spec's step, warm-started from the previous plan shifted with the rest input appended.
pub struct FirstOrder(pub &'static dyn Algorithm);

/// The most iterations a first-order case is run for when its count is measured.
pub const FIRST_ORDER_PROBE: usize = 20_000;

impl FirstOrder {
    /// `iterations` reference iterations from `start`, reporting every plan.
    fn run(
        &self,
        qp: &Qp,
        f: &DVector<f64>,
        start: &DVector<f64>,
        iterations: usize,
        observe: &mut dyn FnMut(&DVector<f64>),
    ) -> DVector<f64> {
        let nu = qp.u_min.len();
        let observe = std::cell::RefCell::new(observe);
        let step = |y: &DVector<f64>| {
            let stepped = y - (&qp.H * y + f) * qp.step;
            let u = DVector::from_fn(stepped.len(), |i, _| {
                crate::linalg::project(stepped[i], qp.u_min[i % nu], qp.u_max[i % nu])
            });
            (observe.borrow_mut())(&u);
            u
        };
        self.0
            .reference(&qp.parameters(), start.clone(), iterations, &step)
    }
}

impl Sampled for FirstOrder {
    type Start = DVector<f64>;

    fn title(&self) -> &'static str {
        self.0.title()
    }

    fn cold(&self, qp: &Qp) -> DVector<f64> {
        qp.rest_plan()
    }

    fn probe(&self) -> (usize, usize) {
        (64, FIRST_ORDER_PROBE)
    }

    fn trajectory(
        &self,
        qp: &Qp,
        problem: &InequalityQp,
        start: &DVector<f64>,
        iterations: usize,
    ) -> Vec<Iterate> {
        let mut out = vec![plain_iterate(start.clone())];
        self.run(qp, &problem.f, start, iterations, &mut |u| {
            out.push(plain_iterate(u.clone()))
        });
        out
    }

    fn control_step(
        &self,
        qp: &Qp,
        f: &DVector<f64>,
        _offset: &DVector<f64>,
        start: &DVector<f64>,
        _previous_plan: &DVector<f64>,
        count: usize,
    ) -> Stepped<DVector<f64>> {
        let plan = self.run(qp, f, start, count, &mut |_| {});
        let nu = qp.u_min.len();
        let mut next = plan.clone();
        let n = next.len();
        next.as_mut_slice().copy_within(nu.., 0);
        next.rows_mut(n - nu, nu).copy_from(&qp.rest_input());
        Stepped {
            iterate: plain_iterate(plan.clone()),
            plan,
            next,
            fell_back: false,
        }
    }

    fn macs_per_iteration(&self, qp: &Qp) -> usize {
        let n = qp.H.nrows();
        n * n + self.0.update_macs(n)
    }

    fn limits_residuals(&self) -> bool {
        false
    }
}
