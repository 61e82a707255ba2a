//! The generated `report` submodule against the library's certificate and against the compiled types.

use mpc_tests::generated::*;
use mpc_tests::harness::Generated;

macro_rules! state_sizes {
    ($($m:ident),*) => {$({
        use mpc_tests::$m::{report, Controller, Kalman, Mpc};
        assert_eq!(core::mem::size_of::<Mpc>(), report::BYTES_STATE_MPC, stringify!($m));
        assert_eq!(core::mem::size_of::<Kalman>(), report::BYTES_STATE_KALMAN, stringify!($m));
        assert_eq!(core::mem::size_of::<Controller>(), report::BYTES_STATE, stringify!($m));
    })*};
}

#[test]
fn state_bytes_are_the_types_sizes() {
    state_sizes!(
        paper,
        paper_faithful,
        paper_initial,
        paper_f64,
        horizon1_f64,
        horizon40,
        asymmetric_gradient,
        full_q,
        linear_f64,
        linear_f32
    );
}

/// `Mpc` and `Controller` (and `Kalman`, where there is a filter) against `report::BYTES_STATE*`, in
/// modules declared in the test file itself.
macro_rules! state_sizes_of {
    ($($m:ident $(+ $kalman:ident)?),*) => {$({
        use $m::{report, Controller, Mpc};
        assert_eq!(core::mem::size_of::<Mpc>(), report::BYTES_STATE_MPC, "{} Mpc", stringify!($m));
        assert_eq!(core::mem::size_of::<Controller>(), report::BYTES_STATE, "{} Controller", stringify!($m));
        $(assert_eq!(core::mem::size_of::<$m::$kalman>(), report::BYTES_STATE_KALMAN, stringify!($m));)?
    })*};
}

// The interior-point method without a filter, with the moves weighted (the last input kept), in f64; and
// with a filter in a module whose `Real` is f32.
// One input: the emitted `% NU` is `% 1`, which clippy's `modulo_one` denies (an emitter lint for NU = 1).
#[allow(clippy::modulo_one)]
mod single_input {
    mpc_macros::mpc!(pub mod pendulum = "specs/pendulum-lqr.toml");
}
use single_input::pendulum;
mpc_macros::mpc!(mod limits_f32 = "specs/paper-limits-f32.toml");

#[test]
fn state_bytes_are_the_types_sizes_for_the_interior_point_method() {
    state_sizes_of!(pendulum, limits_f32 + Kalman);
    assert_eq!(pendulum::report::BYTES_STATE_KALMAN, 0);
}

#[test]
fn report_constants_are_the_certificate() {
    let (spec, p) = (paper::spec(), paper::problem());
    let c = codegen::certify(&p, &codegen::plan(&spec, &p).unwrap());
    use mpc_tests::paper::report;
    assert_eq!(report::LIPSCHITZ, c.lipschitz);
    assert_eq!(report::CONDITION_NUMBER, c.condition_number);
    assert_eq!(report::LQR_SPECTRAL_RADIUS, c.lqr.spectral_radius);
    assert_eq!(report::LQR_LYAPUNOV_MIN, c.lqr.lyapunov_min);
    assert_eq!(report::LQR_LYAPUNOV_MAX, c.lqr.lyapunov_max);
    assert_eq!(
        report::MPC_SOLVER_SPECTRAL_RADIUS,
        c.mpc.solver_spectral_radius
    );
    assert_eq!(report::ITERATIONS_BOUND, c.iterations_bound);
    assert_eq!(report::MACS_PER_CYCLE, c.resources.macs_per_cycle);
    assert_eq!(report::ITERATIONS, mpc_tests::paper::ITERATIONS);
    assert_eq!(report::STEP as f32, mpc_tests::paper::STEP);
}
