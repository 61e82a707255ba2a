//! The certificates: the paper's stability figures, the a priori bound checked against real iterations,
//! `iterations = "auto"`, warnings and the unstable-loop error.
#![allow(non_snake_case)]

use codegen::certificate::{certify, review};
use codegen::oracle::{exact_solution, iterate};
use codegen::solver::algorithm;
use codegen::{generate_from_source, lower, plan, Opt};
use mpc_spec::load;
use nalgebra::DVector;

const PAPER: &str = include_str!("../../specs/paper.toml");
const FAITHFUL: &str = include_str!("../../specs/paper-faithful.toml");

/// The certificate of a spec's text.
fn certificate(src: &str) -> codegen::Certificate {
    let spec = load(src).unwrap();
    let p = lower(&spec).unwrap();
    certify(&p, &plan(&spec, &p).unwrap())
}

fn round(v: f64, digits: i32) -> f64 {
    let k = 10f64.powi(digits);
    (v * k).round() / k
}

/// Section 2.4.3: ρ(F − G·K) = 0.939, λmin(P) = 4.61, λmax(P) = 142.44.
#[test]
fn paper_stability_figures() {
    let c = certificate(PAPER);
    assert_eq!(round(c.lqr.spectral_radius, 3), 0.939);
    assert_eq!(round(c.lqr.lyapunov_min, 2), 4.61);
    assert_eq!(round(c.lqr.lyapunov_max, 2), 142.44);
    // The exactly solved MPC and the 30-iteration FGM close (numerically) the same loop.
    assert!(c.mpc.spectral_radius < 1.0);
    let solver = c.mpc.solver_spectral_radius.unwrap();
    assert!(
        (solver - c.mpc.spectral_radius).abs() < 1e-6,
        "{solver} vs {}",
        c.mpc.spectral_radius
    );
}

/// Algorithm 1 with α = 0.04 and 30 warm-started iterations is a different dynamic controller.
#[test]
fn paper_faithful_solver_loop_differs_from_the_mpc_gain() {
    let c = certificate(FAITHFUL);
    let solver = c.mpc.solver_spectral_radius.unwrap();
    assert!(
        (solver - c.mpc.spectral_radius).abs() > 1e-4,
        "{solver} vs {}",
        c.mpc.spectral_radius
    );
    assert!(solver < 1.0);
    // α = 0.04 is far below 1/L ≈ 0.49: thirty steps guarantee little, the `tolerance = 0.7` the spec
    // writes, where the default 1e-4 would need more than 700.
    assert!(c.rate.unwrap().iterations_for(1e-4) > 700);
    assert_eq!(c.tolerance, 0.7);
    assert!(c.iterations_bound.unwrap() <= 30);
    assert!(c.guaranteed_gap.unwrap() > 0.6 && c.guaranteed_gap.unwrap() <= 0.7);
}

#[test]
fn paper_conditioning_and_rates() {
    let c = certificate(PAPER);
    assert_eq!(c.step, 1.0 / c.lipschitz);
    let kappa = c.condition_number;
    assert!((c.rate.unwrap().factor - (1.0 - (1.0 / kappa).sqrt())).abs() < 1e-15);
    // The asymptotic contraction of constant-momentum FGM at α = 1/L is 1 − 1/√κ as well.
    assert!(
        (c.contraction - (1.0 - (1.0 / kappa).sqrt())).abs() < 1e-6,
        "{}",
        c.contraction
    );
    assert_eq!(c.iterations_bound, Some(21));
    assert!(c.guaranteed_gap.unwrap() < 1e-5);
}

/// The bound Δ_k ≤ C·ρᵏ·Δ_0 holds along real iterations from random starts in the box.
#[test]
fn a_priori_bound_holds_along_real_iterations() {
    for src in [
        PAPER,
        FAITHFUL,
        include_str!("../../specs/paper-initial.toml"),
    ] {
        let p = lower(&load(src).unwrap()).unwrap();
        let qp = &p.qp;
        let rate = algorithm(qp.method)
            .unwrap()
            .rate(&qp.parameters())
            .unwrap();
        let nz = qp.N * p.nu;
        let J = |U: &DVector<f64>, f: &DVector<f64>| 0.5 * U.dot(&(&qp.H * U)) + f.dot(U);
        let mut seed = 1u64;
        let mut uniform = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for trial in 0..40 {
            let scale = [0.1, 1.0, 10.0, 100.0][trial % 4];
            let f = DVector::from_fn(nz, |_, _| scale * 20.0 * uniform());
            let U0 = DVector::from_fn(nz, |i, _| {
                10.0 * uniform() * if i % 2 == 0 { 1.0 } else { 0.3 }
            });
            let exact = exact_solution(qp, &f, 1e-14, 200_000);
            let (J0, Jstar) = (J(&U0, &f), J(&exact, &f));
            for k in 1..=60 {
                // k iterations from U0 (stepping one at a time would drop FGM's momentum).
                let Uk = iterate(qp, &f, U0.clone(), k);
                let gap = J(&Uk, &f) - Jstar;
                let bound = rate.guaranteed(k) * (J0 - Jstar);
                assert!(
                    gap <= bound + 1e-9 * (1.0 + J0.abs()),
                    "k = {k}: gap {gap:e} above the bound {bound:e}"
                );
            }
        }
    }
}

#[test]
fn auto_iterations_are_the_bound() {
    let src = PAPER.replace("iterations = 30", "iterations = \"auto\"\ntolerance = 1e-6");
    let g = generate_from_source(&src, &Opt::default()).unwrap();
    let rate = g.certificate.rate.unwrap();
    let m = g.problem.qp.iterations;
    assert_eq!(Some(m), g.certificate.iterations_bound);
    assert!(rate.guaranteed(m) <= 1e-6 && rate.guaranteed(m - 1) > 1e-6);
    assert!(g
        .tokens
        .to_string()
        .contains(&format!("pub const ITERATIONS : usize = {m}")));
    let missing = PAPER.replace("iterations = 30", "iterations = \"auto\"");
    let diags = load(&missing).unwrap_err();
    assert_eq!(
        diags.iter().next().unwrap().message,
        "`iterations = \"auto\"` needs `tolerance` or `[mpc.region]`"
    );
}

#[test]
fn too_few_iterations_warn_or_fail_when_strict() {
    let src = FAITHFUL.replace("tolerance = 0.7", "tolerance = 1e-4");
    assert_ne!(src, FAITHFUL);
    let spec = load(&src).unwrap();
    let p = lower(&spec).unwrap();
    let c = certify(&p, &plan(&spec, &p).unwrap());
    let warnings = review(&spec, &c).unwrap();
    let w = warnings.iter().next().unwrap();
    assert!(
        w.message
            .starts_with("`iterations = 30` is below the 762 that guarantee `tolerance = 1e-4`"),
        "{}",
        w.message
    );
    assert_eq!(&src[w.span.clone().unwrap()], "30");
    let strict = load(&src.replace("tolerance = 1e-4", "tolerance = 1e-4\nstrict = true")).unwrap();
    assert!(review(&strict, &c).is_err());
}

#[test]
fn unstable_loops_are_errors_unless_accepted() {
    // An unstable open loop with a one-step horizon and a tiny state weight: the MPC barely acts.
    let src = r#"
[model]
type = "linear"
dt = 0.1
a = [[1.2]]
b = [[1.0]]
c = [[1.0]]
[mpc]
horizon = 1
iterations = 5
q = 0.001
r = 10
u_min = [-1]
u_max = [1]
[kalman]
q = 0.01
r = 0.1
"#;
    let diags = generate_from_source(src, &Opt::default()).unwrap_err();
    let msgs: Vec<_> = diags.iter().map(|d| d.message.clone()).collect();
    assert!(
        msgs.iter()
            .any(|m| m.starts_with("the closed loop is not stable: the unconstrained MPC loop")),
        "{msgs:?}"
    );
    assert!(
        !msgs.iter().any(|m| m.contains("LQR")),
        "the LQR of the stage weights stabilizes: {msgs:?}"
    );
    let accepted = src.replace("u_max = [1]", "u_max = [1]\naccept_unstable = true");
    assert!(generate_from_source(&accepted, &Opt::default()).is_ok());
}

#[test]
fn disturbance_models_are_checked_and_timed() {
    let src = include_str!("../../specs/paper-offset-free.toml");
    let g = generate_from_source(src, &Opt::default()).unwrap();
    let tau = g.certificate.disturbance_time_constant.unwrap();
    assert!((0.5..5.0).contains(&tau), "τ = {tau} s");
    assert_eq!(g.problem.nd(), 3);
    // Fd = H·(1_N ⊗ I).
    let qp = &g.problem.qp;
    for i in 0..45 {
        for j in 0..3 {
            let expected: f64 = (0..15).map(|k| qp.H[(i, 3 * k + j)]).sum();
            assert!((qp.Fd[(i, j)] - expected).abs() < 1e-12);
        }
    }
    // One measurement cannot separate two input disturbances from the state.
    let blind = r#"
[model]
type = "linear"
dt = 0.1
a = [[1, 0.1], [0, 1]]
b = [[0.005, 0.0], [0.1, 0.1]]
c = [[1, 0]]
[mpc]
horizon = 5
iterations = 10
q = [1, 0.1]
r = [0.1, 0.1]
u_min = [-1, -1]
u_max = [1, 1]
[kalman]
q = 0.001
r = 0.01
disturbance = 0.01
"#;
    let diags = generate_from_source(blind, &Opt::default()).unwrap_err();
    let d = diags.iter().next().unwrap();
    assert!(
        d.message.starts_with("the disturbance is not detectable"),
        "{}",
        d.message
    );
    assert_eq!(&blind[d.span.clone().unwrap()], "0.01");
}

/// The shipped Algorithm 1 spec without its `tolerance`: the default 1e-4 is the one its 30 iterations miss.
fn faithful_without_tolerance() -> String {
    let src: String = FAITHFUL
        .lines()
        .filter(|l| !l.starts_with("tolerance =") && !l.starts_with("# The a priori bound"))
        .map(|l| format!("{l}\n"))
        .collect();
    assert!(!src.contains("tolerance"), "{src}");
    src
}

#[test]
fn the_default_tolerance_warns_when_the_iterations_miss_it() {
    let src = faithful_without_tolerance();
    let g = generate_from_source(&src, &Opt::default()).unwrap();
    let w = g.warnings.iter().next().expect("a warning");
    assert!(
        w.message.starts_with(
            "`iterations = 30` is below the 762 that guarantee the default tolerance 1e-4 (no `tolerance` is written)"
        ),
        "{}",
        w.message
    );
    assert_eq!(&src[w.span.clone().unwrap()], "30");
    // The hint names the tolerance the 30 iterations meet; written, it silences the warning, and so does
    // the shipped spec, which writes it.
    let hint = w.note.clone().unwrap_or_default();
    let met = hint
        .split("`tolerance = ")
        .nth(1)
        .and_then(|rest| rest.split('`').next())
        .unwrap_or_else(|| panic!("no tolerance in the hint: {hint}"));
    let tol: f64 = met.parse().unwrap();
    let gap = g.certificate.guaranteed_gap.unwrap();
    assert!(tol >= gap && tol < 1.0, "{tol} for a gap of {gap}");
    let written = src.replace(
        "iterations = 30",
        &format!("iterations = 30\ntolerance = {met}"),
    );
    let g = generate_from_source(&written, &Opt::default()).unwrap();
    assert!(g.warnings.is_empty(), "{:?}", g.warnings);
    assert!(generate_from_source(FAITHFUL, &Opt::default())
        .unwrap()
        .warnings
        .is_empty());
    // `strict` makes the default's miss an error too.
    let strict = src.replace("iterations = 30", "iterations = 30\nstrict = true");
    assert!(generate_from_source(&strict, &Opt::default()).is_err());
}

#[test]
fn a_bound_that_cannot_decrease_is_an_error_at_the_step() {
    // 1 − αμ with α = 1e-300 rounds to 1: no count of iterations guarantees anything. The loop it closes is
    // the open-loop plant, accepted here so that the bound's error is the one reported.
    let src = faithful_without_tolerance()
        .replace("step = 0.04", "step = 1e-300")
        .replace(
            "u_max = [10, 10, 10]",
            "u_max = [10, 10, 10]\naccept_unstable = true",
        );
    let diags = generate_from_source(&src, &Opt::default()).unwrap_err();
    let d = diags.iter().next().unwrap();
    assert!(
        d.message
            .starts_with("the a priori bound guarantees no improvement at all"),
        "{}",
        d.message
    );
    assert_eq!(&src[d.span.clone().unwrap()], "1e-300");
}

#[test]
fn a_tolerance_below_the_arithmetic_warns_at_the_tolerance() {
    let src = PAPER.replace(
        "iterations = 30",
        "iterations = \"auto\"\ntolerance = 1e-300",
    );
    let g = generate_from_source(&src, &Opt::default()).unwrap();
    let w = g.warnings.iter().next().expect("a warning");
    assert!(
        w.message
            .starts_with("`mpc.tolerance` = 1e-300 is below what the arithmetic can resolve: the solver runs in f32"),
        "{}",
        w.message
    );
    assert_eq!(&src[w.span.clone().unwrap()], "1e-300");
    // The floor is ε·κ(H) of the emitted scalar: f32's is about 8e-7 on the paper's H, f64's about 1.5e-15.
    let kappa = g.certificate.condition_number;
    let floor = |tol: &str, scalar: &str| {
        let src = src
            .replace("tolerance = 1e-300", &format!("tolerance = {tol}"))
            .replace("scalar = \"f32\"", &format!("scalar = \"{scalar}\""));
        generate_from_source(&src, &Opt::default())
            .unwrap()
            .warnings
            .is_empty()
    };
    assert!(f32::EPSILON as f64 * kappa > 1e-6 / 2.0 && f32::EPSILON as f64 * kappa < 1e-6);
    assert!(floor("1e-6", "f32"));
    assert!(!floor("4e-7", "f32"));
    assert!(floor("4e-7", "f64"));
    assert!(!floor("1e-16", "f64"));
}
