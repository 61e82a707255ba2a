//! Every generated controller against the generic runtime solver (the oracle) on the same spec file:
//! thousands of random states and references, saturating and not, over warm-started multi-step runs.
//!
//! Tolerance. Both sides run the same iteration; they differ by rounding only. One iteration commits an
//! error of about ε·(‖Fx‖·|x0| + ‖Fr‖·|Xref| + ‖H‖·|U|) in the gradient (the terms of f = Fx·x0 − Fr·Xref
//! cancel, so the error scales with the terms, not with f), and the iteration damps errors at the rate
//! of the problem's strong convexity μ, so the error in U is bounded by
//!     k · ε · (‖Fx‖∞·|x0|∞ + ‖Fr‖∞·|Xref|∞ + ‖H‖∞·|U|max) / μ
//! with ε the machine epsilon of the generated scalar, ‖·‖∞ the induced infinity norm, |U|max the largest
//! bound. We assert k = 4 for every spec (observed maxima are printed by `--nocapture`). In f64 the
//! difference must also stay below 1e-9 relative to the input range.
#![allow(non_snake_case)]

use codegen::oracle;
use mpc_tests::generated::*;
use mpc_tests::harness::*;
use nalgebra::DVector;

const K_MPC: f64 = 4.0;

/// The largest error, in units of the tolerance's scale, over `runs` × `steps` warm-started solves.
fn compare_mpc<G: Generated>(seed: u64, runs: usize, steps: usize) -> f64 {
    let p = G::problem();
    let qp = &p.qp;
    let (nx, nu, N) = (p.nx, p.nu, qp.N);
    let mut rng = rng(seed);
    let mut oracle = oracle::Mpc::new(&p);
    let mut generated = G::mpc_new();
    let eps = G::epsilon();
    let u_abs = qp.u_min.amax().max(qp.u_max.amax());
    let round = |v: &DVector<f64>| v.map(G::round);
    let mut worst: f64 = 0.0;
    let (mut saturated, mut interior) = (0, 0);
    for run in 0..runs {
        // From a whisper to far outside the box's reach, so that some runs saturate every input.
        let scale = [0.01, 0.3, 3.0, 30.0][run % 4];
        oracle.reset();
        G::mpc_reset(&mut generated);
        let mut x = random_vector(&mut rng, nx, scale);
        let center = random_vector(&mut rng, nx, scale);
        for _ in 0..steps {
            let x0 = round(&x);
            let xref: Vec<DVector<f64>> = (0..N)
                .map(|_| round(&(&center + random_vector(&mut rng, nx, 0.1 * scale))))
                .collect();
            let xref_vec: Vec<Vec<f64>> =
                xref.iter().map(|r| r.iter().copied().collect()).collect();
            let u_oracle = oracle.solve(&x0, &xref);
            let u_generated = G::mpc_solve(&mut generated, x0.as_slice(), &xref_vec);
            for (j, u) in u_generated.iter().enumerate() {
                assert!(
                    u.is_finite() && *u >= qp.u_min[j] && *u <= qp.u_max[j],
                    "{u} outside the box"
                );
            }
            let plan = G::mpc_plan(&generated);
            let at_bound = |i: usize, u: f64| {
                u == G::round(qp.u_min[i % nu]) || u == G::round(qp.u_max[i % nu])
            };
            if plan.iter().enumerate().any(|(i, u)| at_bound(i, *u)) {
                saturated += 1;
            }
            if plan.iter().enumerate().any(|(i, u)| !at_bound(i, *u)) {
                interior += 1;
            }
            let x_abs = x0.amax();
            let r_abs = xref.iter().map(|r| r.amax()).fold(0.0, f64::max);
            let scale = mpc_error_scale(qp, eps, x_abs, r_abs, 0.0);
            let diff = plan
                .iter()
                .zip(oracle.plan().iter())
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            worst = worst.max(diff / scale);
            if eps < 1e-10 {
                assert!(
                    diff <= 1e-9 * u_abs.max(1.0),
                    "f64 difference {diff:e} above 1e-9 relative"
                );
            }
            // The plant moves with the oracle's command plus a disturbance, and the references drift.
            x = &p.F * &x + &p.G * u_oracle + random_vector(&mut rng, nx, 0.01 * scale);
        }
    }
    assert!(
        saturated > runs * steps / 10,
        "too few saturated solves ({saturated}) to exercise the box"
    );
    assert!(
        interior > runs * steps / 10,
        "too few solves with inactive bounds ({interior})"
    );
    println!(
        "{}: worst error {:.3} × ε·scale/μ ({} solves, {saturated} with an active bound)",
        G::SPEC,
        worst,
        runs * steps
    );
    worst
}

macro_rules! mpc_tests {
    ($($test:ident: $g:ty,)*) => {
        $(
            #[test]
            fn $test() {
                let worst = compare_mpc::<$g>(0x5eed ^ stringify!($test).len() as u64, 100, 10);
                assert!(worst <= K_MPC, "error {worst} × the scale exceeds k = {K_MPC}");
            }
        )*
    };
}

mpc_tests! {
    mpc_paper: paper,
    mpc_paper_faithful: paper_faithful,
    mpc_paper_initial: paper_initial,
    mpc_paper_f64: paper_f64,
    mpc_horizon1_f64: horizon1_f64,
    mpc_horizon40: horizon40,
    mpc_asymmetric_gradient: asymmetric_gradient,
    mpc_full_q: full_q,
    mpc_linear_f64: linear_f64,
    mpc_linear_f32: linear_f32,
    mpc_offset_free_without_estimate: offset_free,
    // Every emission choice ([codegen] emission) on the same specs.
    mpc_paper_unrolled: paper_unrolled,
    mpc_paper_table: paper_table,
    mpc_paper_matrix_free: paper_matrix_free,
    mpc_paper_f64_table: paper_f64_table,
    mpc_paper_f64_matrix_free: paper_f64_matrix_free,
    mpc_full_q_unrolled: full_q_unrolled,
    mpc_full_q_matrix_free: full_q_matrix_free,
    mpc_horizon40_unrolled: horizon40_unrolled,
    mpc_horizon40_matrix_free: horizon40_matrix_free,
    mpc_linear_f64_unrolled: linear_f64_unrolled,
    mpc_linear_f64_matrix_free: linear_f64_matrix_free,
}

/// The modules above cover every emission: `auto` chose lanes or a table, the key forced the rest.
#[test]
fn every_emission_is_covered() {
    use mpc_tests as m;
    let chosen = [
        ("paper", m::paper::EMISSION, "lanes"),
        ("paper_f64", m::paper_f64::EMISSION, "lanes"),
        ("full_q", m::full_q::EMISSION, "table"),
        ("paper_unrolled", m::paper_unrolled::EMISSION, "unrolled"),
        ("paper_table", m::paper_table::EMISSION, "table"),
        (
            "paper_matrix_free",
            m::paper_matrix_free::EMISSION,
            "matrix_free",
        ),
        ("full_q_unrolled", m::full_q_unrolled::EMISSION, "unrolled"),
        ("offset_free", m::offset_free::EMISSION, "lanes"),
        (
            "offset_free_matrix_free",
            m::offset_free_matrix_free::EMISSION,
            "matrix_free",
        ),
    ];
    for (name, got, want) in chosen {
        assert_eq!(got, want, "{name}");
    }
}
