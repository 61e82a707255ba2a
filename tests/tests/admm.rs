//! `method = "admm"`: generated ADMM controllers (`tests/specs/quadcopter-admm-{f64,f32}.toml`, the
//! shipped quadcopter with its method and scalar changed, and `tests/specs/linear-admm-{f64,f32}.toml`,
//! a small plant with soft state bounds, move bounds, a row group, weighted moves and a disturbance
//! model):
//! - f64 against the oracle (`codegen::admm::control_step::<f64>` at the certified ρ), warm-started runs
//!   inside the region and 1.5× beyond: the same iterations in the same order, so they differ by
//!   rounding only (≤ 1e-9 of the span);
//! - f32 against the f64 oracle inside the region: both are certified within `accuracy` of the exact
//!   solution there (the f32 certificate runs the f32 iteration), so they are within 2·accuracy of each
//!   other (the triangle inequality; the observed figure is printed);
//! - every generated solve, f64 and f32, within `accuracy` of Clarabel on cold draws and a warm closed
//!   loop inside the region;
//! - the x-update in residual form (`tests/specs/linear-admm-residual-{f64,f32}.toml`, the linear plant
//!   with `admm_form = "residual"`): the same checks;
//! - the fallback: infeasible hard rows and data that overflow f32 give a finite command inside the input
//!   box and a status that says so; non-finite data the rest input.
#![allow(non_snake_case)]

use codegen::ipm::{violations, Fallback};
use codegen::oracle;
use mpc_tests::harness::*;
use nalgebra::DVector;

#[allow(dead_code)]
#[path = "../benches/exact.rs"]
mod exact;

mpc_macros::mpc!(mod quadcopter64 = "specs/quadcopter-admm-f64.toml");
// The same spec with every ADMM kernel as a loop over tables (build.rs).
include!(concat!(env!("OUT_DIR"), "/quadcopter_tables.rs"));
mpc_macros::mpc!(mod quadcopter32 = "specs/quadcopter-admm-f32.toml");
mpc_macros::mpc!(mod linear64 = "specs/linear-admm-f64.toml");
mpc_macros::mpc!(mod linear32 = "specs/linear-admm-f32.toml");
mpc_macros::mpc!(mod residual64 = "specs/linear-admm-residual-f64.toml");
mpc_macros::mpc!(mod residual32 = "specs/linear-admm-residual-f32.toml");

const QUADCOPTER64: &str = include_str!("../specs/quadcopter-admm-f64.toml");
const QUADCOPTER32: &str = include_str!("../specs/quadcopter-admm-f32.toml");
const LINEAR64: &str = include_str!("../specs/linear-admm-f64.toml");
const LINEAR32: &str = include_str!("../specs/linear-admm-f32.toml");
const RESIDUAL64: &str = include_str!("../specs/linear-admm-residual-f64.toml");
const RESIDUAL32: &str = include_str!("../specs/linear-admm-residual-f32.toml");

fn accuracy(text: &str) -> f64 {
    mpc_spec::load(text).unwrap().mpc.accuracy
}

/// What a run of a generated controller against the oracle and Clarabel showed.
#[derive(Default, Debug)]
struct Seen {
    /// Worst |U_generated − U_oracle|∞ over the span.
    oracle: f64,
    /// Worst |U_generated − U*|∞ over the span (U* Clarabel's), and the worst hard-row violation.
    exact: f64,
    violation: f64,
    solves: usize,
    /// Fallbacks where the QP has a solution.
    fallbacks: usize,
    /// Solves whose QP has none (hard rows that cannot be met): each a reported fallback.
    infeasible: usize,
}

/// Runs a generated module (`$m`, scalar `$real`) beside the oracle over `sequences` warm-started
/// sequences of `steps` from states drawn in the region widened by `widen`, comparing with Clarabel too
/// when `clarabel` (inside the region only).
macro_rules! run {
    ($m:ident, $p:expr, $seed:expr, $sequences:expr, $steps:expr, $widen:expr, $clarabel:expr) => {{
        use $m as m;
        let p = $p;
        let mut rng = rng($seed);
        let mut seen = Seen::default();
        for _ in 0..$sequences {
            let mut generated = m::Mpc::new();
            let mut reference = oracle::Mpc::new(&p);
            let mut c = draw(&p, &mut rng, $widen);
            for _ in 0..$steps {
                let (problem, offset) = qp_of(&p, &reference, &c);
                let u = reference.solve(&c.x0, &window(&p, &c.reference));
                let x0: [m::Real; m::NX] = std::array::from_fn(|i| c.x0[i] as m::Real);
                let row: [m::Real; m::NX] = std::array::from_fn(|i| c.reference[i] as m::Real);
                let v = generated.solve(&x0, &[row; m::N]);
                // The box as the module holds it (U_MIN, U_MAX rounded to Real).
                for (j, v) in v.iter().enumerate() {
                    assert!(
                        v.is_finite() && *v >= m::U_MIN[j] && *v <= m::U_MAX[j],
                        "{v} outside the box"
                    );
                }
                let status = generated.solver_status();
                let step = reference.admm_step().unwrap();
                assert_eq!(
                    status.fallback == m::Fallback::WarmStart,
                    step.fallback == Fallback::WarmStart,
                    "the generated and the oracle's fallback differ: {status:?}"
                );
                // The exact IPM says whether the QP has a solution at all: the region can hold states
                // from which a hard row cannot be met (the linear plant's x₁ + x₃ ≤ 3 on its box
                // [−2, 2]²). There the right answer is the fallback, with the infeasibility reported.
                let exact_status = if $clarabel {
                    codegen::ipm::solve(&problem, 1e-10, 200).status
                } else {
                    codegen::ipm::Status::Converged
                };
                let fell_back = status.fallback == m::Fallback::WarmStart;
                match exact_status {
                    codegen::ipm::Status::Converged => seen.fallbacks += usize::from(fell_back),
                    codegen::ipm::Status::Infeasible => {
                        // Said by the fallback, or, once a solve found the rows infeasible, by the
                        // relaxed plan's violation of them.
                        let relaxed =
                            status.fallback == m::Fallback::Relaxed && status.violation > 0.0;
                        assert!(
                            relaxed
                                || fell_back
                                    && (status.infeasible
                                        || status.primal_residual > m::PRIMAL_LIMIT),
                            "an infeasible QP solved without a word: {status:?}"
                        );
                        seen.infeasible += 1;
                    }
                    other => panic!("the exact IPM ended {other:?} at x0 = {}", c.x0),
                }
                let plan: Vec<f64> = generated
                    .plan()
                    .iter()
                    .flatten()
                    .map(|v| *v as f64)
                    .collect();
                for (i, (a, b)) in plan.iter().zip(reference.plan().iter()).enumerate() {
                    seen.oracle = seen.oracle.max((a - b).abs() / span(&p, i));
                }
                // A relaxed plan (the step after the rows were found infeasible, the held plan still
                // violating them) solves the relaxed QP, not this one, and says so.
                let relaxed = status.fallback == m::Fallback::Relaxed;
                if $clarabel && exact_status == codegen::ipm::Status::Converged && !relaxed {
                    let exact = exact::clarabel(&problem);
                    let U = DVector::from_vec(plan.clone());
                    for i in 0..plan.len() {
                        seen.exact = seen.exact.max((plan[i] - exact[i]).abs() / span(&p, i));
                    }
                    seen.violation = seen.violation.max(violations(&p.qp, &U, &offset).0);
                }
                seen.solves += 1;
                c.x0 = &p.F * &c.x0 + &p.G * &u;
            }
        }
        seen
    }};
}

/// f64: the generated module and the oracle run the same iterations; rounding apart, one plan.
#[test]
fn generated_f64_matches_the_oracle() {
    for (name, seen) in [
        (
            "quadcopter",
            run!(quadcopter64, problem(QUADCOPTER64), 0x17, 6, 6, 1.5, false),
        ),
        (
            "quadcopter, kernels as loops over tables",
            run!(
                quadcopter_tables,
                problem(QUADCOPTER64),
                0x17,
                6,
                6,
                1.5,
                false
            ),
        ),
        (
            "linear",
            run!(linear64, problem(LINEAR64), 0x17, 8, 10, 1.5, false),
        ),
        (
            "linear, residual form",
            run!(residual64, problem(RESIDUAL64), 0x17, 8, 10, 1.5, false),
        ),
    ] {
        println!("{name} f64: {seen:?}");
        // The loops read the very tables the reference runs (`admm::Program::tables`): to the bit.
        assert!(
            !name.contains("tables") || seen.oracle == 0.0,
            "{name}: {:e} of the span from the oracle",
            seen.oracle
        );
        assert!(
            seen.oracle <= 1e-9,
            "{name}: {:e} of the span from the oracle",
            seen.oracle
        );
    }
}

/// Every generated solve within `accuracy` of Clarabel, f64 and f32, and f32 within 2·accuracy of the
/// f64 oracle (both within `accuracy` of U*), on warm closed loops inside the region.
/// Solves whose QP has no solution are left out of the accuracy (the fallback is then the answer, and
/// the run checks that it is reported as infeasible).
#[test]
fn generated_solves_meet_the_accuracy() {
    let cases = [
        (
            "quadcopter f64",
            run!(quadcopter64, problem(QUADCOPTER64), 0xacc, 4, 10, 1.0, true),
            accuracy(QUADCOPTER64),
        ),
        (
            "quadcopter f32",
            run!(quadcopter32, problem(QUADCOPTER32), 0xacc, 4, 10, 1.0, true),
            accuracy(QUADCOPTER32),
        ),
        (
            "linear f64",
            run!(linear64, problem(LINEAR64), 0xacc, 8, 10, 1.0, true),
            accuracy(LINEAR64),
        ),
        (
            "linear f32",
            run!(linear32, problem(LINEAR32), 0xacc, 8, 10, 1.0, true),
            accuracy(LINEAR32),
        ),
        (
            "linear f64, residual form",
            run!(residual64, problem(RESIDUAL64), 0xacc, 8, 10, 1.0, true),
            accuracy(RESIDUAL64),
        ),
        (
            "linear f32, residual form",
            run!(residual32, problem(RESIDUAL32), 0xacc, 8, 10, 1.0, true),
            accuracy(RESIDUAL32),
        ),
    ];
    for (name, seen, accuracy) in cases {
        println!("{name}: {seen:?}");
        assert_eq!(
            seen.fallbacks, 0,
            "{name}: a solve of a feasible QP inside the region fell back"
        );
        assert!(
            seen.infeasible < seen.solves / 2,
            "{name}: {} of {} QPs infeasible: the test's draws no longer test the solver",
            seen.infeasible,
            seen.solves
        );
        assert!(
            seen.exact <= accuracy && seen.violation <= accuracy,
            "{name}: |U − U*|∞ = {:e} of the span, violation {:e}",
            seen.exact,
            seen.violation
        );
        assert!(
            seen.oracle <= 2.0 * accuracy,
            "{name}: {:e} from the oracle",
            seen.oracle
        );
    }
}

/// Infeasible hard rows (falling below the floor), data that overflow f32 and non-finite data: a finite
/// command inside the box and a status that says what happened.
#[test]
fn the_fallback_is_bounded_and_reported() {
    macro_rules! falls_back {
        ($m:ident, $p:expr) => {{
            use $m as m;
            let p = $p;
            let inside = |u: &[m::Real; m::NU]| {
                u.iter()
                    .enumerate()
                    .all(|(j, v)| v.is_finite() && *v >= m::U_MIN[j] && *v <= m::U_MAX[j])
            };
            let mut x0 = [0.0; m::NX];
            x0[5] = -3.0;
            x0[11] = -6.0;
            let xref = [[0.0; m::NX]; m::N];
            let mut generated = m::Mpc::new();
            let mut reference = oracle::Mpc::new(&p);
            // The first solve finds the rows infeasible and falls back; the next ones solve the
            // relaxed QP, whose plan violates the floor (no input keeps it) and says so.
            for k in 0..3 {
                let u = generated.solve(&x0, &xref);
                let v = reference.solve(
                    &DVector::from_iterator(m::NX, x0.iter().map(|v| *v as f64)),
                    &window(&p, &DVector::zeros(p.nx)),
                );
                let status = generated.solver_status();
                let expected = if k == 0 {
                    Fallback::WarmStart
                } else {
                    Fallback::Relaxed
                };
                assert_eq!(reference.admm_step().unwrap().fallback, expected);
                if k == 0 {
                    assert_eq!(status.fallback, m::Fallback::WarmStart, "{status:?}");
                    assert!(
                        status.infeasible || status.primal_residual > m::PRIMAL_LIMIT,
                        "{status:?}"
                    );
                } else {
                    assert_eq!(status.fallback, m::Fallback::Relaxed, "{status:?}");
                    assert!(status.violation > 0.0, "{status:?}");
                }
                assert!(inside(&u));
                for (a, b) in u.iter().zip(v.iter()) {
                    assert!((*a as f64 - b).abs() <= 1e-6 * (p.qp.u_max[0] - p.qp.u_min[0]));
                }
            }
            // A feasible state afterwards, from which the held plan meets the rows: the hard QP's
            // plan, trusted.
            x0 = [0.0; m::NX];
            generated.solve(&x0, &xref);
            assert_eq!(generated.solver_status().fallback, m::Fallback::Solved);
            // Finite data whose products overflow: a numerical failure, in the box.
            x0[6] = m::Real::MAX / 2.0;
            x0[7] = -m::Real::MAX / 2.0;
            let u = generated.solve(&x0, &xref);
            let status = *generated.solver_status();
            assert!(
                status.numerical_failure && status.fallback == m::Fallback::WarmStart,
                "{status:?}"
            );
            assert!(inside(&u));
            // Non-finite data: the rest input, the warm start reset; the controller says why.
            x0[3] = m::Real::NAN;
            assert_eq!(generated.solve(&x0, &xref), m::U_REST);
            let mut controller = m::Controller::new();
            assert_eq!(controller.step(&x0, &xref), m::U_REST);
            assert_eq!(controller.status().command, m::Command::InvalidState);
            x0 = [0.0; m::NX];
            controller.step(&x0, &xref);
            assert_eq!(controller.status().solver.fallback, m::Fallback::Solved);
            status
        }};
    }
    println!(
        "f64 overflow: {:?}",
        falls_back!(quadcopter64, problem(QUADCOPTER64))
    );
    println!(
        "f32 overflow: {:?}",
        falls_back!(quadcopter32, problem(QUADCOPTER32))
    );
}

/// Never inert, with ADMM: started outside its hard bounds (φ = 1.5 against |φ| ≤ π/6, z = −50 against
/// z ≥ −1), the quadcopter is back inside within 5 s and stays inside (noise-free, on its own model).
#[test]
fn the_controller_recovers_from_outside_its_bounds() {
    let p = problem(QUADCOPTER64);
    let dt = p.dt;
    for (axis, value) in [(0, 1.5), (5, -50.0)] {
        let mut x0 = vec![0.0; p.nx];
        x0[axis] = value;
        let mut generated = quadcopter64::Mpc::new();
        let states = nominal_flight(&p, &x0, &vec![0.0; p.nx], (20.0 / dt) as usize, |x, w| {
            let x: [f64; quadcopter64::NX] = std::array::from_fn(|i| x[i]);
            let w: [[f64; quadcopter64::NX]; quadcopter64::N] =
                std::array::from_fn(|k| std::array::from_fn(|i| w[k][i]));
            generated.solve(&x, &w).to_vec()
        });
        let spec = mpc_spec::load(QUADCOPTER64).expect("spec");
        let seconds = inside_bounds_from(&spec, &states).map(|k| k as f64 * dt);
        println!(
            "ADMM quadcopter from x[{axis}] = {value}: inside its bounds from {seconds:?} s on"
        );
        assert!(
            seconds.is_some_and(|t| t <= 5.0),
            "x[{axis}] = {value}: inside from {seconds:?} s"
        );
    }
}

/// `report::BYTES_STATE*`, the compiler's layout model, against `size_of` of the types on the host.
#[test]
fn state_bytes_are_the_types_sizes() {
    macro_rules! sizes {
        ($($m:ident $(+ $kalman:ident)?),*) => {$({
            use $m::{report, Controller, Mpc};
            assert_eq!(core::mem::size_of::<Mpc>(), report::BYTES_STATE_MPC, "{} Mpc", stringify!($m));
            assert_eq!(core::mem::size_of::<Controller>(), report::BYTES_STATE, "{} Controller", stringify!($m));
            $(assert_eq!(core::mem::size_of::<$m::$kalman>(), report::BYTES_STATE_KALMAN, stringify!($m));)?
        })*};
    }
    sizes!(
        quadcopter64,
        quadcopter32,
        linear64 + Kalman,
        linear32 + Kalman,
        residual64 + Kalman,
        residual32 + Kalman
    );
}
