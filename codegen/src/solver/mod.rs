//! The QP methods, one folder each: [`first_order`] (FGM and projected gradient, with their gradient
//! forms), [`ipm`] (the interior-point method) and [`admm`]; [`riccati`] is the stage-wise factorisation
//! that the interior-point method and ADMM share, [`constrained`] what else they share, and [`exact`]
//! the exact reference solves. [`active_set`] is the dual active-set method's f64 reference solver, not
//! yet a method a spec can choose.
#![allow(non_snake_case)]

pub mod active_set;
pub mod admm;
pub mod constrained;
pub mod exact;
pub mod first_order;
pub mod ipm;
pub mod riccati;
pub mod stepping;

pub use constrained::Status;
pub use first_order::{Algorithm, Fgm, Gradient, Parameters, Point, Rate, StepFn};

use mpc_spec::Method;

/// The first-order algorithm that `method` names ([`crate::plan::Solver::first_order`]); `None` for the
/// interior-point method ([`ipm`]) and ADMM ([`admm`]), which are not iterations on the box.
pub fn algorithm(method: Method) -> Option<&'static dyn Algorithm> {
    crate::plan::of(method).first_order()
}

/// Every first-order algorithm, in the order of [`Method`].
pub fn all() -> impl Iterator<Item = &'static dyn Algorithm> {
    Method::ALL.iter().filter_map(|m| algorithm(*m))
}
