//! The coordinate range the compiler states (`report::COORDINATE_RANGE_F32`, `codegen::coordinates`),
//! flown: the generated f32 controller of `specs/paper.toml` and the f64 oracle read the same noise-free
//! readings and references of a vehicle flying a Lissajous curve whose positions are all shifted by X, and
//! their commands are compared at every cycle. The oracle's commands fly the plant, so both see one
//! trajectory; the oracle's own rounding (ε = 2⁻⁵³) is five orders of magnitude below the f32 error here.

use codegen::oracle;
use mpc_tests::harness::Generated;
use mpc_tests::paper::{self, report, Real, N, NX};
use nalgebra::DVector;

/// Cycles flown: 25.6 s, several periods of every axis.
const CYCLES: usize = 2000;

/// The reference state (positions shifted by `x`, velocities) at time t: 2 m Lissajous axes with periods
/// 7, 9 and 11 s, so the readings change every cycle (a stuck sensor would be rejected) in every axis at once.
fn reference(t: f64, x: f64) -> [f64; 6] {
    let mut r = [0.0; 6];
    for axis in 0..3 {
        let w = 2.0 * std::f64::consts::PI / [7.0, 9.0, 11.0][axis];
        let phase = axis as f64;
        r[axis] = x + 2.0 * (w * t + phase).sin();
        r[axis + 3] = 2.0 * w * (w * t + phase).cos();
    }
    r
}

/// The worst |u_f32 − u_f64| over the flight at offset `x`.
fn worst_command_error(x: f64) -> f64 {
    let problem = <mpc_tests::generated::paper as Generated>::problem();
    let dt = problem.dt;
    let mut state = DVector::from_row_slice(&reference(0.0, x));
    let mut exact = oracle::Controller::new(&problem, state.clone());
    let mut f32_controller = paper::Controller::new(core::array::from_fn(|i| state[i] as Real));
    let mut worst: f64 = 0.0;
    for k in 0..CYCLES {
        let z = (&problem.C * &state).into_owned();
        let window: Vec<[f64; 6]> = (1..=N).map(|j| reference((k + j) as f64 * dt, x)).collect();
        let xref: Vec<DVector<f64>> = window.iter().map(|r| DVector::from_row_slice(r)).collect();
        let u = exact.step(&z, &xref);
        let z32: [Real; 3] = core::array::from_fn(|i| z[i] as Real);
        let xref32: [[Real; NX]; N] =
            core::array::from_fn(|j| core::array::from_fn(|i| window[j][i] as Real));
        let u32 = f32_controller.step(&z32, &xref32);
        assert!(
            f32_controller.status().filter.measurement.accepted(),
            "cycle {k} at {x:e}"
        );
        for i in 0..3 {
            worst = worst.max((u32[i] as f64 - u[i]).abs());
        }
        state = &problem.F * &state + &problem.G * &u;
    }
    worst
}

/// Below the stated range the command stays within the stated accuracy; ten times above it, it does not
/// (the worst case over rounding signs is within a factor of ten of a flight).
#[test]
fn f32_keeps_the_stated_accuracy_within_the_stated_range_and_not_far_beyond() {
    let (range, accuracy) = (report::COORDINATE_RANGE_F32, report::COMMAND_ACCURACY);
    for x in [0.0, 0.5 * range, range, 10.0 * range, 100.0 * range] {
        println!(
            "|x| = {x:.3e}: worst |u_f32 − u_f64| = {:.3e} (accuracy {accuracy})",
            worst_command_error(x)
        );
    }
    let inside = worst_command_error(0.5 * range);
    assert!(
        inside <= accuracy,
        "at X_max/2 = {}: {inside} > {accuracy}",
        0.5 * range
    );
    let outside = worst_command_error(10.0 * range);
    assert!(
        outside > accuracy,
        "at 10·X_max = {}: {outside} ≤ {accuracy}",
        10.0 * range
    );
}
