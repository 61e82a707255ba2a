//! The exact reference of the constrained QPs: Clarabel (pure Rust interior point) on a
//! `codegen::ipm::InequalityQp`, as `codegen::exact` runs it beside the interior-point method. Shared by
//! `codegen/tests/ipm.rs` and `tests/tests/constrained.rs` through `#[path]`.

use codegen::ipm::InequalityQp;
use nalgebra::DVector;

/// Clarabel's plan on the QP (its finite sides stacked as G z + s = h, s ≥ 0), at the tightest of
/// `codegen::exact::CLARABEL_TOLERANCES` it solves to.
pub fn clarabel(qp: &InequalityQp) -> DVector<f64> {
    match codegen::exact::clarabel(qp) {
        codegen::exact::Clarabel::Solved(r) => r.z,
        _ => panic!("Clarabel solved the QP to none of its tolerances"),
    }
}
