//! Output tracking, move suppression and state feedback without a filter (`[mpc] outputs`, `r_du`, no
//! `[kalman]`), on the two-mass benchmark of `specs/two-mass-*.toml`: the generated code against the
//! oracle, the converged plan against Clarabel, and the closed loops the keys promise.
#![allow(non_snake_case)]

use codegen::oracle;
use mpc_tests::harness::*;
use nalgebra::DVector;
use rand::Rng;

// The established solvers of the benchmarks, shared: Clarabel is the exact box-QP solution here.
#[allow(dead_code)]
#[path = "../benches/baselines.rs"]
mod baselines;

mpc_macros::mpc!(mod outputs = "specs/two-mass-outputs.toml");
mpc_macros::mpc!(mod filtered = "specs/two-mass-filtered.toml");
mpc_macros::mpc!(mod outputs_unrolled = "specs/emission/two-mass-outputs-unrolled.toml");
mpc_macros::mpc!(mod outputs_matrix_free = "specs/emission/two-mass-outputs-matrix-free.toml");
mpc_macros::mpc!(mod filtered_unrolled = "specs/emission/two-mass-filtered-unrolled.toml");
mpc_macros::mpc!(mod filtered_matrix_free = "specs/emission/two-mass-filtered-matrix-free.toml");

fn outputs_problem() -> codegen::Problem {
    problem(include_str!("../specs/two-mass-outputs.toml"))
}

fn filtered_problem() -> codegen::Problem {
    problem(include_str!("../specs/two-mass-filtered.toml"))
}

/// The generated MPC and the oracle over warm-started runs from random states, output references and
/// last inputs (set on both), saturating and not; returns the worst plan difference over the error scale
/// of `mpc_error_scale` with the last input's term.
fn compare<M>(
    p: &codegen::Problem,
    eps: f64,
    round: impl Fn(f64) -> f64,
    mut generated: M,
    mut solve: impl FnMut(&mut M, &[f64], &[f64], &[Vec<f64>]) -> Vec<f64>,
    set_last: impl Fn(&mut M, &[f64]) -> bool,
    plan: impl Fn(&M) -> Vec<f64>,
) -> f64 {
    let qp = &p.qp;
    let (nx, nu, nz, nd, N) = (p.nx, p.nu, qp.nz, p.nd(), qp.N);
    let mut rng = rng(0x5eed);
    let mut reference = oracle::Mpc::new(p);
    let u_abs = qp.u_min.amax().max(qp.u_max.amax());
    let mut worst: f64 = 0.0;
    let mut saturated = 0;
    for run in 0..40 {
        let scale = [0.01, 0.3, 3.0, 30.0][run % 4];
        let last = DVector::from_fn(nu, |_, _| round(rng.gen_range(-1.0..=1.0)));
        assert!(reference.set_last_input(&last));
        assert!(set_last(&mut generated, last.as_slice()));
        let mut x = random_vector(&mut rng, nx, scale);
        let d = random_vector(&mut rng, nd, 0.1).map(&round);
        for _ in 0..10 {
            let x0 = x.map(&round);
            let refs: Vec<DVector<f64>> = (0..N)
                .map(|_| random_vector(&mut rng, nz, scale).map(&round))
                .collect();
            let rows: Vec<Vec<f64>> = refs.iter().map(|r| r.iter().copied().collect()).collect();
            let u = reference.solve_with_disturbance(&x0, &d, &refs);
            let v = solve(&mut generated, x0.as_slice(), d.as_slice(), &rows);
            for (j, u) in v.iter().enumerate() {
                assert!(u.is_finite() && *u >= qp.u_min[j] && *u <= qp.u_max[j]);
            }
            let diff = max_difference(&plan(&generated), reference.plan().iter());
            let r_abs = refs.iter().map(|r| r.amax()).fold(0.0, f64::max);
            let scale = mpc_error_scale(qp, eps, x0.amax(), r_abs, d.amax());
            worst = worst.max(diff / scale);
            if eps < 1e-10 {
                assert!(diff <= 1e-9 * u_abs, "f64 difference {diff:e}");
            }
            if v.iter().any(|u| u.abs() >= u_abs) {
                saturated += 1;
            }
            x = &p.F * &x + &p.G * &u;
        }
    }
    assert!(saturated > 20, "only {saturated} saturated solves");
    worst
}

/// [`compare`] for a state-feedback module in f64.
macro_rules! compare_outputs {
    ($m:ident) => {
        compare(
            &outputs_problem(),
            f64::EPSILON,
            |v| v,
            $m::Mpc::new(),
            |m, x, _, refs| {
                let x: [f64; $m::NX] = core::array::from_fn(|i| x[i]);
                let r: [[f64; $m::NZ]; $m::N] =
                    core::array::from_fn(|k| core::array::from_fn(|i| refs[k][i]));
                m.solve(&x, &r).to_vec()
            },
            |m, u| m.set_last_input(&[u[0]]),
            |m| m.plan().iter().flatten().copied().collect(),
        )
    };
}

/// [`compare`] for an offset-free module in f32.
macro_rules! compare_filtered {
    ($m:ident) => {
        compare(
            &filtered_problem(),
            f32::EPSILON as f64,
            |v| v as f32 as f64,
            $m::Mpc::new(),
            |m, x, d, refs| {
                let x: [f32; $m::NX] = core::array::from_fn(|i| x[i] as f32);
                let d: [f32; $m::ND] = core::array::from_fn(|i| d[i] as f32);
                let r: [[f32; $m::NZ]; $m::N] =
                    core::array::from_fn(|k| core::array::from_fn(|i| refs[k][i] as f32));
                m.solve_with_disturbance(&x, &d, &r)
                    .iter()
                    .map(|v| *v as f64)
                    .collect()
            },
            |m, u| m.set_last_input(&[u[0] as f32]),
            |m| m.plan().iter().flatten().map(|v| *v as f64).collect(),
        )
    };
}

#[test]
fn generated_mpc_with_outputs_and_moves_matches_the_oracle_in_every_emission() {
    assert_eq!(outputs::EMISSION, "table");
    assert_eq!(filtered::EMISSION, "table");
    let runs = [
        ("outputs (table)", compare_outputs!(outputs)),
        ("outputs (unrolled)", compare_outputs!(outputs_unrolled)),
        (
            "outputs (matrix_free)",
            compare_outputs!(outputs_matrix_free),
        ),
        ("filtered (table)", compare_filtered!(filtered)),
        ("filtered (unrolled)", compare_filtered!(filtered_unrolled)),
        (
            "filtered (matrix_free)",
            compare_filtered!(filtered_matrix_free),
        ),
    ];
    for (name, worst) in runs {
        println!("{name}: worst error {worst:.3} × ε·scale/μ");
        assert!(worst <= 4.0, "{name}: {worst} × the error scale");
    }
}

/// The generated plan from a cold start meets the certificate's guarantee against the exact minimiser:
/// J(U) − J* ≤ guaranteed gap · (J(U₀) − J*), J* from Clarabel.
#[test]
fn converged_plan_meets_its_guarantee_against_clarabel() {
    let p = outputs_problem();
    let qp = &p.qp;
    let mut rng = rng(7);
    let mut clarabel = baselines::Clarabel::new(qp);
    let J = |U: &DVector<f64>, f: &DVector<f64>| 0.5 * U.dot(&(&qp.H * U)) + f.dot(U);
    // The guarantee the module states in its report.
    let gap = outputs::report::GUARANTEED_GAP.expect("FGM at 1/L has a rate");
    for _ in 0..20 {
        let x0 = random_vector(&mut rng, p.nx, 2.0);
        let refs: Vec<DVector<f64>> = (0..qp.N).map(|_| random_vector(&mut rng, 1, 1.0)).collect();
        let last = random_vector(&mut rng, 1, 1.0);
        let mut mpc = outputs::Mpc::new();
        assert!(mpc.set_last_input(&[last[0]]));
        let x: [f64; 4] = core::array::from_fn(|i| x0[i]);
        let r: [[f64; 1]; outputs::N] = core::array::from_fn(|k| [refs[k][0]]);
        mpc.solve(&x, &r);
        let U = DVector::from_iterator(qp.N, mpc.plan().iter().map(|u| u[0]));
        let mut o = oracle::Mpc::new(&p);
        o.set_last_input(&last);
        let f = o.linear_term(&x0, &refs);
        let exact = DVector::from_column_slice(clarabel.solve(f.as_slice()));
        let start = DVector::from_element(qp.N, qp.rest_input()[0]);
        let (J_star, J_start, J_plan) = (J(&exact, &f), J(&start, &f), J(&U, &f));
        // Clarabel's own accuracy (1e-8 relative) is the slack.
        let slack = 1e-7 * (1.0 + J_star.abs());
        assert!(
            J_plan - J_star <= gap * (J_start - J_star) + slack,
            "gap {:e} of {:e} allowed",
            J_plan - J_star,
            gap * (J_start - J_star)
        );
    }
}

/// State feedback: the controller takes the measured state, tracks the output with no offset (no input
/// weight), says when the state is unusable and recovers at once.
#[test]
fn state_feedback_tracks_the_output_and_reports_a_bad_state() {
    let p = outputs_problem();
    let mut c = outputs::Controller::new();
    assert_eq!(c.status().command, outputs::Command::NoneYet);
    let mut x = DVector::zeros(4);
    let target = [[0.5]; outputs::N];
    for k in 0..600 {
        let state: [f64; 4] = core::array::from_fn(|i| x[i]);
        let u = if k == 300 {
            // One unusable reading: the rest input, reported, and the next cycle solves again.
            let u = c.step(&[f64::NAN, 0.0, 0.0, 0.0], &target);
            assert_eq!(c.status().command, outputs::Command::InvalidState);
            assert_eq!(u, outputs::U_REST);
            assert_eq!(c.mpc().last_input(), &outputs::U_REST);
            u
        } else {
            let u = c.step(&state, &target);
            assert_eq!(c.status().command, outputs::Command::Solved);
            assert_eq!(
                c.mpc().last_input(),
                &u,
                "the last input is the command returned"
            );
            u
        };
        x = &p.F * &x + &p.G * DVector::from_column_slice(&u);
    }
    assert!(
        (x[1] - 0.5).abs() < 1e-3,
        "mass 2 at {} after 60 s, the reference is 0.5",
        x[1]
    );
    // A non-finite last input is refused; reset brings back the rest input.
    assert!(!c.set_last_input(&[f64::INFINITY]));
    assert!(c.set_last_input(&[0.25]));
    assert_eq!(c.mpc().last_input(), &[0.25]);
    c.reset();
    assert_eq!(c.mpc().last_input(), &outputs::U_REST);
}

/// Output tracking with the offset-free filter: a constant input disturbance on the plant, the position
/// of mass 2 measured only, and the output still reaches its reference.
#[test]
fn offset_free_output_tracking_cancels_an_input_disturbance() {
    let p = filtered_problem();
    let mut c = filtered::Controller::new([0.0; 4]);
    let mut x = DVector::zeros(4);
    let target = [[0.5_f32]; filtered::N];
    let disturbance = 0.2;
    for _ in 0..1500 {
        let z = [x[1] as f32];
        let u = c.step(&z, &target);
        let applied = DVector::from_element(1, u[0] as f64 + disturbance);
        x = &p.F * &x + &p.G * applied;
    }
    assert_eq!(c.status().command, filtered::Command::Solved);
    assert!(
        (x[1] - 0.5).abs() < 1e-3,
        "mass 2 at {} after 150 s, the reference is 0.5",
        x[1]
    );
    let d = c.kalman().disturbance()[0] as f64;
    assert!((d - disturbance).abs() < 1e-2, "disturbance estimate {d}");
}
