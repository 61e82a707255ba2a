//! State, output and rate constraints solved by the fixed-iteration interior-point method, on the three
//! shipped constrained specs (`specs/paper-limits.toml`, and `specs/quadcopter.toml` and
//! `specs/hover.toml` as the copies `tests/specs/ipm/` with `method = "ipm"`: their `auto` picks the dual
//! active set, which `tests/tests/active_set.rs` holds to the same rules):
//! - the generated controller against the oracle (the same method over nalgebra), warm-started runs;
//! - every solve of the certified count against Clarabel, the exact reference: ≥ 50 cold cases that
//!   Clarabel solves (some saturating, some starting at 95 % of a bound) and a 200-step warm closed loop
//!   on the nominal model, within `accuracy` of the input span and of the rows' bounds;
//! - the fallback: infeasible hard rows, a truncated count and non-finite data give a finite command
//!   inside the input box and a status that says so.
#![allow(non_snake_case)]

use codegen::ipm::{violations, Fallback, InequalityQp};
use codegen::oracle;
use mpc_tests::harness::*;
use nalgebra::DVector;

#[allow(dead_code)]
#[path = "../benches/exact.rs"]
mod exact;

mpc_macros::mpc!(mod quadcopter = "specs/ipm/quadcopter.toml");
mpc_macros::mpc!(mod hover = "specs/ipm/hover.toml");
mpc_macros::mpc!(mod paper_limits = "../specs/paper-limits.toml");
mpc_macros::mpc!(mod linear_riccati = "specs/linear-riccati.toml");
mpc_macros::mpc!(mod linear_riccati_soft = "specs/linear-riccati-soft.toml");
// Three iterations, below what the region needs: the build warns (a deprecated item), as it should.
#[allow(deprecated)]
mod short {
    mpc_macros::mpc!(pub mod truncated = "specs/quadcopter-truncated.toml");
}
use short::truncated;

const QUADCOPTER: &str = include_str!("../specs/ipm/quadcopter.toml");
const HOVER: &str = include_str!("../specs/ipm/hover.toml");
const PAPER_LIMITS: &str = include_str!("../../specs/paper-limits.toml");
const LINEAR_RICCATI: &str = include_str!("../specs/linear-riccati.toml");
const LINEAR_RICCATI_SOFT: &str = include_str!("../specs/linear-riccati-soft.toml");

/// The copies are the shipped specs with one line, `method = "ipm"`, after `[mpc]` (and their title).
#[test]
fn the_ipm_copies_are_the_shipped_specs_with_the_method_line() {
    for (copy, shipped) in [
        (QUADCOPTER, include_str!("../../specs/quadcopter.toml")),
        (HOVER, include_str!("../../specs/hover.toml")),
    ] {
        let mut expected = String::new();
        for line in shipped.lines() {
            expected.push_str(line);
            expected.push('\n');
            if line.trim() == "[mpc]" {
                expected.push_str("method = \"ipm\"\n");
            }
        }
        let (title, body) = copy.split_once('\n').unwrap();
        assert!(
            title.starts_with("# tests/tests/constrained.rs: specs/"),
            "{title}"
        );
        assert_eq!(
            body, expected,
            "{title}: regenerate the copy from the shipped spec"
        );
        assert_eq!(
            problem(shipped).qp.method,
            mpc_spec::Method::ActiveSet,
            "{title}: `auto` no longer picks the active set; the copy is not needed"
        );
    }
}

/// Compares a generated MPC with the oracle over warm-started sequences from drawn states and
/// references (inside the region and 1.5× beyond); returns the worst plan difference over the span.
macro_rules! compare {
    ($module:ident, $p:expr) => {{
        use $module as m;
        let p = $p;
        let mut rng = rng(0x17);
        let mut worst: f64 = 0.0;
        let mut fallbacks = 0;
        for sequence in 0..12 {
            let mut generated = m::Mpc::new();
            let mut reference = oracle::Mpc::new(&p);
            let widen = if sequence % 3 == 2 { 1.5 } else { 1.0 };
            let mut c = draw(&p, &mut rng, widen);
            for _ in 0..8 {
                let u = reference.solve(&c.x0, &window(&p, &c.reference));
                let mut x0 = [0.0; m::NX];
                x0.copy_from_slice(c.x0.as_slice());
                let mut xref = [[0.0; m::NX]; m::N];
                for row in xref.iter_mut() {
                    row.copy_from_slice(c.reference.as_slice());
                }
                let v = generated.solve(&x0, &xref);
                for (j, v) in v.iter().enumerate() {
                    assert!(v.is_finite() && *v >= p.qp.u_min[j] && *v <= p.qp.u_max[j]);
                }
                let status = generated.solver_status();
                let step = reference.last_step().unwrap();
                assert_eq!(
                    status.fallback == m::Fallback::WarmStart,
                    step.fallback == Fallback::WarmStart,
                    "the generated and the oracle's fallback differ"
                );
                fallbacks += usize::from(step.fallback == Fallback::WarmStart);
                let plan: Vec<f64> = generated.plan().iter().flatten().copied().collect();
                for (i, (a, b)) in plan.iter().zip(reference.plan().iter()).enumerate() {
                    worst = worst.max((a - b).abs() / span(&p, i));
                }
                c.x0 = &p.F * &c.x0 + &p.G * &u;
            }
        }
        (worst, fallbacks)
    }};
}

#[test]
fn generated_interior_point_matches_the_oracle() {
    for (name, (worst, fallbacks)) in [
        ("quadcopter", compare!(quadcopter, problem(QUADCOPTER))),
        ("hover", compare!(hover, problem(HOVER))),
        (
            "paper-limits",
            compare!(paper_limits, problem(PAPER_LIMITS)),
        ),
    ] {
        println!("{name}: worst plan difference {worst:.3e} of the span, {fallbacks} fallbacks");
        // Both run the same iterations in f64; they differ in the factorisation (L·D·Lᵀ against
        // Cholesky) and the order of sums only.
        assert!(
            worst <= 1e-7,
            "{name}: {worst:e} of the span from the oracle"
        );
    }
}

/// Every solve of the oracle (which the generated code matches) within `accuracy` of Clarabel: cold
/// cases and a warm closed loop.
fn meets_the_accuracy(name: &str, text: &str) {
    let p = problem(text);
    let qp = &p.qp;
    let accuracy = qp.accuracy;
    let mut rng = rng(0xacc);
    let check = |mpc: &oracle::Mpc, problem: &InequalityQp, offset: &DVector<f64>, what: &str| {
        let exact = exact::clarabel(problem);
        let plan = mpc.plan();
        let error = (0..plan.len())
            .map(|i| (plan[i] - exact[i]).abs() / span(&p, i))
            .fold(0.0, f64::max);
        let (violation, _) = violations(qp, &plan, offset);
        assert!(
            error <= accuracy && violation <= accuracy,
            "{name} {what}: |U − U*|∞ = {error:e} of the span, violation {violation:e}"
        );
        error
    };
    // Cold: draws, and draws with one bounded state at 95 % of its bound.
    let (mut cold, mut near_bound, mut saturating, mut skipped) = (0, 0, 0, 0);
    let constraints = mpc_spec::load(text).unwrap().mpc.constraints;
    let bounds: Vec<(usize, f64)> = (0..p.nx)
        .flat_map(|i| {
            let lo = constraints.x_min.get(i).copied().filter(|b| b.is_finite());
            let hi = constraints.x_max.get(i).copied().filter(|b| b.is_finite());
            [lo.map(|b| (i, b)), hi.map(|b| (i, b))]
        })
        .flatten()
        .collect();
    let mut k = 0;
    while cold < 60 {
        k += 1;
        assert!(k < 600, "{name}: too few feasible cold cases");
        let mut c = draw(&p, &mut rng, 1.0);
        if k % 3 == 0 && !bounds.is_empty() {
            let (i, b) = bounds[k % bounds.len()];
            c.x0[i] = 0.95 * b;
            near_bound += 1;
        }
        let mut mpc = oracle::Mpc::new(&p);
        let (problem, offset) = qp_of(&p, &mpc, &c);
        let hard = codegen::ipm::solve(&problem, 1e-10, 200);
        if hard.status != codegen::ipm::Status::Converged {
            skipped += 1;
            continue;
        }
        mpc.solve(&c.x0, &window(&p, &c.reference));
        check(&mpc, &problem, &offset, "cold case");
        let u = mpc.plan();
        if (0..u.len())
            .any(|i| u[i] <= qp.u_min[i % p.nu] + 1e-9 || u[i] >= qp.u_max[i % p.nu] - 1e-9)
        {
            saturating += 1;
        }
        cold += 1;
    }
    // Warm: 200 steps on the nominal model towards a drawn reference, the reference changing every 50.
    let mut mpc = oracle::Mpc::new(&p);
    let mut c = draw(&p, &mut rng, 0.5);
    let mut worst: f64 = 0.0;
    for step in 0..200 {
        if step % 50 == 0 {
            c.reference = draw(&p, &mut rng, 0.5).reference;
        }
        let (problem, offset) = qp_of(&p, &mpc, &c);
        let u = mpc.solve(&c.x0, &window(&p, &c.reference));
        assert_eq!(mpc.last_step().unwrap().fallback, Fallback::Solved);
        worst = worst.max(check(&mpc, &problem, &offset, "warm step"));
        c.x0 = &p.F * &c.x0 + &p.G * &u;
    }
    println!(
        "{name}: {cold} cold cases ({near_bound} at 95 % of a bound, {saturating} saturating, {skipped} draws \
         without a solution skipped), 200 warm steps: worst {worst:.2e} of the span; {} iterations",
        qp.iterations
    );
    assert!(saturating > 0, "{name}: no saturating case");
}

/// The generated controller itself against Clarabel, for a spec without move bounds or weighted moves
/// (its QP does not depend on the last input): ≥ 50 cold cases that Clarabel solves (a third with a
/// bounded state at 95 % of its bound) and a 200-step warm closed loop on the nominal model, each plan
/// within `accuracy` of the input span and each hard row within `accuracy` of its bound.
macro_rules! generated_meets_the_accuracy {
    ($module:ident, $name:expr, $text:expr) => {{
        use $module as m;
        let (name, text) = ($name, $text);
        let p = problem(text);
        let qp = &p.qp;
        assert!(!p.has_moves(), "{name}: the QP would depend on the last input");
        assert!(qp.rows.stage.iter().all(Option::is_some), "{name}: move bounds");
        let accuracy = qp.accuracy;
        // The QP of a solve at (x0, reference): the oracle's, which Clarabel is given.
        let oracle = oracle::Mpc::new(&p);
        let solve = |generated: &mut m::Mpc, c: &Drawn, what: &str| -> (f64, Vec<f64>) {
            let (problem, offset) = qp_of(&p, &oracle, c);
            let exact = exact::clarabel(&problem);
            let mut x0 = [0.0; m::NX];
            x0.copy_from_slice(c.x0.as_slice());
            let mut xref = [[0.0; m::NX]; m::N];
            for row in xref.iter_mut() {
                row.copy_from_slice(c.reference.as_slice());
            }
            let u = generated.solve(&x0, &xref);
            assert_eq!(generated.solver_status().fallback, m::Fallback::Solved, "{name} {what}");
            let plan: Vec<f64> = generated.plan().iter().flatten().copied().collect();
            let error = (0..plan.len())
                .map(|i| (plan[i] - exact[i]).abs() / span(&p, i))
                .fold(0.0, f64::max);
            let (violation, _) = violations(qp, &DVector::from_column_slice(&plan), &offset);
            assert!(
                error <= accuracy && violation <= accuracy,
                "{name} {what}: |U − U*|∞ = {error:e} of the span, violation {violation:e}"
            );
            (error, u.to_vec())
        };
        let constraints = mpc_spec::load(text).unwrap().mpc.constraints;
        let bounds: Vec<(usize, f64)> = (0..p.nx)
            .flat_map(|i| {
                let lo = constraints.x_min.get(i).copied().filter(|b| b.is_finite());
                let hi = constraints.x_max.get(i).copied().filter(|b| b.is_finite());
                [lo.map(|b| (i, b)), hi.map(|b| (i, b))]
            })
            .flatten()
            .collect();
        let mut rng = rng(0x91cc);
        let (mut cold, mut near_bound, mut k, mut worst) = (0, 0, 0, 0.0_f64);
        while cold < 60 {
            k += 1;
            assert!(k < 600, "{name}: too few feasible cold cases");
            let mut c = draw(&p, &mut rng, 1.0);
            if k % 3 == 0 && !bounds.is_empty() {
                let (i, b) = bounds[k % bounds.len()];
                c.x0[i] = 0.95 * b;
            }
            let (problem, _) = qp_of(&p, &oracle, &c);
            if codegen::ipm::solve(&problem, 1e-10, 200).status != codegen::ipm::Status::Converged {
                continue;
            }
            near_bound += usize::from(k % 3 == 0);
            worst = worst.max(solve(&mut m::Mpc::new(), &c, "cold case").0);
            cold += 1;
        }
        let mut generated = m::Mpc::new();
        let mut c = draw(&p, &mut rng, 0.5);
        for step in 0..200 {
            if step % 50 == 0 {
                c.reference = draw(&p, &mut rng, 0.5).reference;
            }
            let (e, u) = solve(&mut generated, &c, "warm step");
            worst = worst.max(e);
            c.x0 = &p.F * &c.x0 + &p.G * DVector::from_vec(u);
        }
        println!(
            "{name} (generated): {cold} cold cases ({near_bound} at 95 % of a bound) and 200 warm steps \
             within {worst:.2e} of the span of Clarabel's solution"
        );
    }};
}

/// Hover's generated controller solves its normal system in the Riccati form (the cost model's choice)
/// and meets `accuracy` against Clarabel.
#[test]
fn generated_hover_in_the_riccati_form_meets_the_accuracy() {
    let p = problem(HOVER);
    assert_eq!(
        codegen::riccati::Choice::of(&p.qp).form,
        codegen::riccati::Form::Riccati
    );
    generated_meets_the_accuracy!(hover, "hover", HOVER);
}

/// The Riccati form with rows on (x_k, u_k) and on x_{k+1} alone (stage cross terms, which hover's
/// state bounds lack): the generated controller against the oracle and against Clarabel.
#[test]
fn generated_riccati_form_with_rows_matches_the_oracle_and_clarabel() {
    let p = problem(LINEAR_RICCATI);
    assert_eq!(
        codegen::riccati::Choice::of(&p.qp).form,
        codegen::riccati::Form::Riccati
    );
    let (worst, fallbacks) = compare!(linear_riccati, p);
    println!(
        "linear-riccati: worst plan difference {worst:.3e} of the span, {fallbacks} fallbacks"
    );
    assert!(worst <= 1e-7, "{worst:e} of the span from the oracle");
    generated_meets_the_accuracy!(linear_riccati, "linear-riccati", LINEAR_RICCATI);
}

/// The same with soft rows: the slacks' Schur complement in the Riccati form.
#[test]
fn generated_riccati_form_with_soft_rows_matches_the_oracle_and_clarabel() {
    let p = problem(LINEAR_RICCATI_SOFT);
    assert_eq!(p.qp.rows.slacks(), 3);
    assert_eq!(
        codegen::riccati::Choice::of(&p.qp).form,
        codegen::riccati::Form::Riccati
    );
    let (worst, fallbacks) = compare!(linear_riccati_soft, p);
    println!(
        "linear-riccati-soft: worst plan difference {worst:.3e} of the span, {fallbacks} fallbacks"
    );
    assert!(worst <= 1e-7, "{worst:e} of the span from the oracle");
    generated_meets_the_accuracy!(
        linear_riccati_soft,
        "linear-riccati-soft",
        LINEAR_RICCATI_SOFT
    );
}

#[test]
fn quadcopter_meets_the_accuracy() {
    meets_the_accuracy("quadcopter", QUADCOPTER);
}

#[test]
fn hover_meets_the_accuracy() {
    meets_the_accuracy("hover", HOVER);
}

#[test]
fn paper_limits_meets_the_accuracy() {
    meets_the_accuracy("paper-limits", PAPER_LIMITS);
}

/// The calibration's cost (issue 17: dense Mehrotra IPM, cold worst case, multiply-adds per solve) and
/// the cost model's count for the certified iterations: at most 1.5× for the three problems.
#[test]
fn cost_against_the_calibration() {
    for (name, text, calibrated) in [
        ("quadcopter", QUADCOPTER, 435_000),
        ("hover", HOVER, 1_700_000),
        ("paper-limits", PAPER_LIMITS, 434_000),
    ] {
        let p = problem(text);
        let per_solve = p.qp.iterations * codegen::ipm::mpc_macs_per_iteration(&p.qp);
        let ratio = per_solve as f64 / calibrated as f64;
        println!(
            "{name}: {} iterations, {per_solve} multiply-adds a solve, {ratio:.2}× the calibration",
            p.qp.iterations
        );
        assert!(ratio <= 1.5, "{name}: {ratio:.2}× the calibration");
    }
}

/// Infeasible hard rows, a truncated count and non-finite data: a finite command in the box, and a
/// status that says what happened.
#[test]
fn the_fallback_is_bounded_and_reported() {
    let p = problem(QUADCOPTER);
    // Falling at 6 m/s 2 m below the floor z ≥ −1: no thrust in the box keeps z ≥ −1.
    let mut x0 = [0.0; quadcopter::NX];
    x0[5] = -3.0;
    x0[11] = -6.0;
    let xref = [[0.0; quadcopter::NX]; quadcopter::N];
    let mut generated = quadcopter::Mpc::new();
    let mut reference = oracle::Mpc::new(&p);
    // The first solve finds the rows infeasible and falls back; the next ones solve the relaxed QP,
    // whose plan violates the floor (no thrust keeps it) and says so.
    for k in 0..3 {
        let u = generated.solve(&x0, &xref);
        let v = reference.solve(
            &DVector::from_column_slice(&x0),
            &window(&p, &DVector::zeros(p.nx)),
        );
        let status = generated.solver_status();
        let (expected, oracle) = if k == 0 {
            (quadcopter::Fallback::WarmStart, Fallback::WarmStart)
        } else {
            (quadcopter::Fallback::Relaxed, Fallback::Relaxed)
        };
        assert_eq!(status.fallback, expected, "{status:?}");
        assert_eq!(reference.last_step().unwrap().fallback, oracle);
        if k == 0 {
            assert!(status.infeasible || status.primal_residual > quadcopter::PRIMAL_LIMIT);
        } else {
            assert!(status.violation > 0.0, "{status:?}");
        }
        for (j, u) in u.iter().enumerate() {
            assert!(u.is_finite() && *u >= p.qp.u_min[j] && *u <= p.qp.u_max[j]);
            assert!((u - v[j]).abs() <= 1e-9);
        }
    }
    // A feasible state afterwards, from which the held plan meets the rows: the hard QP's plan, trusted.
    x0 = [0.0; quadcopter::NX];
    generated.solve(&x0, &xref);
    assert_eq!(
        generated.solver_status().fallback,
        quadcopter::Fallback::Solved
    );
    // Non-finite data: the rest input, the warm start reset.
    x0[3] = f64::NAN;
    assert_eq!(generated.solve(&x0, &xref), quadcopter::U_REST);
    let mut controller = quadcopter::Controller::new();
    assert_eq!(controller.step(&x0, &xref), quadcopter::U_REST);
    assert_eq!(
        controller.status().command,
        quadcopter::Command::InvalidState
    );
    // Three iterations (the sample needs more): the residuals exceed the certified limits on a case far
    // from rest, and the shifted previous plan is used instead, inside the box.
    let mut short = truncated::Mpc::new();
    let mut fell_back = 0;
    let mut rng = rng(3);
    for _ in 0..20 {
        let c = draw(&p, &mut rng, 1.0);
        let mut x0 = [0.0; truncated::NX];
        x0.copy_from_slice(c.x0.as_slice());
        let mut xref = [[0.0; truncated::NX]; truncated::N];
        for row in xref.iter_mut() {
            row.copy_from_slice(c.reference.as_slice());
        }
        let u = short.solve(&x0, &xref);
        for (j, u) in u.iter().enumerate() {
            assert!(u.is_finite() && *u >= p.qp.u_min[j] && *u <= p.qp.u_max[j]);
        }
        let status = short.solver_status();
        assert!(status.iterations <= 3);
        fell_back += usize::from(status.fallback == truncated::Fallback::WarmStart);
    }
    assert!(fell_back > 0, "three iterations never fell back");
}

/// Never inert (issue "constrained controllers you can trust in flight"): started outside its hard
/// bounds (φ = 1.5 against |φ| ≤ π/6, z = −50 against z ≥ −1), the quadcopter is back inside within 5 s
/// and stays inside; toward a reference 1e6 m away, the paper-limits vehicle flies at its 2 m/s speed
/// limit (within 5 %) from 5 s on, for 60 s. Noise-free, on each spec's own model.
#[test]
fn the_controller_recovers_from_outside_its_bounds_and_approaches_a_far_reference() {
    let spec = |text: &str| mpc_spec::load(text).expect("spec");
    let p = problem(QUADCOPTER);
    let dt = p.dt;
    for (axis, value) in [(0, 1.5), (5, -50.0)] {
        let mut x0 = vec![0.0; p.nx];
        x0[axis] = value;
        let mut generated = quadcopter::Mpc::new();
        let states = nominal_flight(&p, &x0, &vec![0.0; p.nx], (20.0 / dt) as usize, |x, w| {
            let x: [f64; quadcopter::NX] = std::array::from_fn(|i| x[i]);
            let w: [[f64; quadcopter::NX]; quadcopter::N] =
                std::array::from_fn(|k| std::array::from_fn(|i| w[k][i]));
            generated.solve(&x, &w).to_vec()
        });
        let from = inside_bounds_from(&spec(QUADCOPTER), &states);
        let seconds = from.map(|k| k as f64 * dt);
        println!("quadcopter from x[{axis}] = {value}: inside its bounds from {seconds:?} s on");
        assert!(
            seconds.is_some_and(|t| t <= 5.0),
            "x[{axis}] = {value}: inside from {seconds:?} s"
        );
    }
    let text = include_str!("../../specs/paper-limits.toml");
    let p = problem(text);
    let mut reference = vec![0.0; p.nx];
    reference[0] = 1e6;
    let mut generated = paper_limits::Mpc::new();
    let mut beyond = true;
    let steps = (65.0 / p.dt) as usize;
    let states = nominal_flight(&p, &vec![0.0; p.nx], &reference, steps, |x, w| {
        let x: [f64; paper_limits::NX] = std::array::from_fn(|i| x[i]);
        let w: [[f64; paper_limits::NX]; paper_limits::N] =
            std::array::from_fn(|k| std::array::from_fn(|i| w[k][i]));
        let u = generated.solve(&x, &w).to_vec();
        beyond &= generated.solver_status().reference_beyond_region;
        u
    });
    let from = (5.0 / p.dt) as usize;
    let (slowest, fastest) = states[from..]
        .iter()
        .map(|x| x[3])
        .fold((f64::INFINITY, 0.0_f64), |(a, b), v| (a.min(v), b.max(v)));
    println!("paper-limits toward x = 1e6 m: speed {slowest:.4} … {fastest:.4} m/s from 5 s on");
    assert!(
        beyond,
        "the status did not say the reference is beyond the region"
    );
    // Absolute coordinates beyond the stated range are flagged, never a plain `Solved`.
    let mut far = [0.0; paper_limits::NX];
    let window = [[0.0; paper_limits::NX]; paper_limits::N];
    let mut fresh = paper_limits::Mpc::new();
    fresh.solve(&far, &window);
    assert!(!fresh.solver_status().beyond_coordinate_range);
    far[0] = 2.0 * paper_limits::report::COORDINATE_RANGE_F64;
    fresh.solve(&far, &window);
    assert!(fresh.solver_status().beyond_coordinate_range);
    assert!(
        (slowest - 2.0).abs() <= 0.1 && (fastest - 2.0).abs() <= 0.1,
        "speed {slowest} … {fastest} m/s"
    );
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
        quadcopter,
        hover,
        paper_limits + Kalman,
        linear_riccati,
        linear_riccati_soft,
        truncated
    );
}
