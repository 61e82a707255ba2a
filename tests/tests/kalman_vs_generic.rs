//! The generated Kalman filters against the generic one, and the steady-state gain against the limit of
//! the time-varying filter.
//!
//! Tolerance. Each cycle rounds the estimate at about ε·(|x| + |z|); the filter's error dynamics
//! x̃⁺ = F(I − KC)x̃ forget such errors at the rate ρ = ρ(F(I − K∞C)) < 1, so they add up to at most
//!     k · ε · (|x|max + |z|max) / (1 − ρ)
//! We assert k = `K_FILTER` (observed maxima are printed by `--nocapture`); in f64 also 1e-9 relative.
#![allow(non_snake_case)]

use codegen::oracle;
use mpc_tests::generated::*;
use mpc_tests::harness::*;
use nalgebra::{DMatrix, DVector};
use rand::Rng;
use rand_distr::StandardNormal;

/// A standard normal sample.
fn normal(rng: &mut impl Rng) -> f64 {
    rng.sample(StandardNormal)
}

/// The generated filter against the oracle on `steps` noisy readings; from `x0` = 0, or from no estimate
/// (a NaN `x0`: the first reading is acquired, and a steady-state filter runs its restart table).
fn compare_filter<G: Generated>(seed: u64, steps: usize, acquire: bool) -> f64 {
    let p = G::problem();
    let (nx, nu, ny) = (p.nx, p.nu, p.ny);
    let mut rng = rng(seed);
    let eps = G::epsilon();
    let filter = p.filter.as_ref().expect("the spec has a filter");
    let closed = &p.F * (DMatrix::identity(nx, nx) - &filter.K_inf * &p.C);
    let rho = spectral_radius(&closed);
    assert!(
        rho < 1.0,
        "the filter's error dynamics are unstable: ρ = {rho}"
    );
    let mut x = random_vector(&mut rng, nx, 1.0);
    let x0 = DVector::from_element(nx, if acquire { f64::NAN } else { 0.0 });
    let mut oracle = oracle::Kalman::new(&p, x0.clone()).expect("the spec has a filter");
    let mut generated = G::kalman_new(x0.as_slice());
    let sigma_z: Vec<f64> = (0..ny).map(|i| filter.Rn[(i, i)].sqrt()).collect();
    let sigma_w: Vec<f64> = (0..nx).map(|i| filter.Qn[(i, i)].sqrt()).collect();
    let (mut x_abs, mut z_abs, mut worst, mut worst_abs) = (0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64);
    for _ in 0..steps {
        let z = (&p.C * &x
            + DVector::from_iterator(ny, sigma_z.iter().map(|s| s * normal(&mut rng))))
        .map(G::round);
        // The same verdict (the start can be outside the gate of a filter whose P0 is small).
        assert_eq!(
            oracle.update(&z).accepted(),
            G::kalman_update(&mut generated, z.as_slice())
        );
        let u = DVector::from_iterator(
            nu,
            (0..nu).map(|j| rng.gen_range(p.qp.u_min[j]..=p.qp.u_max[j])),
        )
        .map(G::round);
        oracle.predict(&u);
        G::kalman_predict(&mut generated, u.as_slice());
        x = &p.F * &x
            + &p.G * &u
            + DVector::from_iterator(nx, sigma_w.iter().map(|s| s * normal(&mut rng)));
        x_abs = x_abs.max(oracle.state().amax());
        z_abs = z_abs.max(z.amax());
        let diff = G::kalman_state(&generated)
            .iter()
            .zip(oracle.state().iter())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        worst_abs = worst_abs.max(diff);
        worst = worst.max(diff / (eps * (x_abs + z_abs) / (1.0 - rho)));
    }
    if eps < 1e-10 {
        assert!(
            worst_abs <= 1e-9 * (x_abs + z_abs),
            "f64 filter differs by {worst_abs:e}"
        );
    }
    println!(
        "{}: worst filter error {worst:.3} × ε·scale/(1 − ρ), ρ = {rho:.5}",
        G::SPEC
    );
    worst
}

macro_rules! filter_tests {
    ($($test:ident: $g:ty $(, $acquire:ident)?;)*) => {
        $(
            #[test]
            fn $test() {
                let acquire = false $(|| stringify!($acquire) == "acquire")?;
                let worst = compare_filter::<$g>(0xf117 + stringify!($test).len() as u64, 1000, acquire);
                assert!(worst <= K_FILTER, "error {worst} × the scale exceeds k = {K_FILTER}");
            }
        )*
    };
}

filter_tests! {
    kalman_paper: paper;                       // f32, time-varying
    kalman_paper_f64: paper_f64;               // f64, steady-state
    kalman_horizon40: horizon40;               // f32, steady-state
    kalman_asymmetric_gradient: asymmetric_gradient; // f64, time-varying, diagonal P0
    kalman_full_q: full_q;                     // f32, time-varying, full P0
    kalman_linear_f64: linear_f64;             // f64, time-varying, full covariances
    kalman_linear_f32: linear_f32;             // f32, steady-state
    // From no estimate: the acquisition, then (steady-state) the restart table's gains.
    kalman_paper_acquired: paper, acquire;
    kalman_paper_f64_acquired: paper_f64, acquire;
    kalman_horizon40_acquired: horizon40, acquire;
    kalman_linear_f32_acquired: linear_f32, acquire;
    // The augmented filters (state and disturbance) are compared in `offset_free.rs`.
}

/// The time-varying filter's gain converges to the steady-state gain solved at compile time.
#[test]
fn steady_state_gain_is_the_limit_of_the_time_varying_filter() {
    for problem in [paper::problem(), linear_f64::problem(), full_q::problem()] {
        let mut filter = oracle::Kalman::new(
            &{
                let mut p = problem.clone();
                let f = p.filter.as_mut().expect("the spec has a filter");
                f.kind = mpc_spec::FilterKind::TimeVarying;
                // The same zero reading every cycle: no stuck-sensor rule.
                f.screening.stuck_cycles = None;
                p
            },
            DVector::zeros(problem.nx),
        )
        .expect("the spec has a filter");
        let steady = problem.filter.as_ref().expect("the spec has a filter");
        let z = DVector::zeros(problem.ny);
        let u = DVector::zeros(problem.nu);
        for _ in 0..20_000 {
            filter.update(&z);
            filter.predict(&u);
        }
        let gain = filter
            .gain()
            .expect("positive definite innovation covariance");
        let diff = (&gain - &steady.K_inf).amax();
        assert!(
            diff <= 1e-9 * steady.K_inf.amax(),
            "gain differs from K∞ by {diff:e}"
        );
        let p_diff = (filter.covariance() - &steady.P_inf).amax();
        assert!(
            p_diff <= 1e-9 * steady.P_inf.amax(),
            "covariance differs from P∞ by {p_diff:e}"
        );
    }
}

/// After a re-acquisition the steady-state filter is the time-varying filter restarted at P0: the same
/// gains and estimates (to rounding) while its restart table lasts, and from then on K∞, within
/// `RESTART_TOLERANCE` of the time-varying filter's gain.
#[test]
fn the_steady_state_restart_is_the_time_varying_filter_from_p0() {
    for problem in [paper_f64::problem(), offset_free_f64::problem()] {
        let steady = problem.filter.as_ref().expect("the spec has a filter");
        let cycles = steady.restart.len();
        assert!(cycles > 0, "no restart table");
        let mut varying = problem.clone();
        varying.filter.as_mut().expect("a filter").kind = mpc_spec::FilterKind::TimeVarying;
        let nan = DVector::from_element(problem.nx, f64::NAN);
        let mut a = oracle::Kalman::new(&problem, nan.clone()).expect("a filter");
        let mut b = oracle::Kalman::new(&varying, nan).expect("a filter");
        let mut rng = rng(3);
        let mut x = DVector::<f64>::zeros(problem.nx);
        x[0] = 5.0;
        let (mut gain_gap, mut state_gap, mut x_abs) = (0.0_f64, 0.0_f64, 0.0_f64);
        for k in 0..cycles + 1 {
            let (ga, gb) = (a.gain().expect("a gain"), b.gain().expect("a gain"));
            if k > 0 {
                // The k-th reading after the acquisition (k = 0 is the acquisition itself).
                gain_gap = gain_gap.max((&ga - &gb).amax());
            }
            let z = (&problem.C * &x).map(|v| v + 0.3 * normal(&mut rng));
            assert_eq!(a.update(&z), b.update(&z), "reading {k}");
            let u = DVector::from_iterator(
                problem.nu,
                (0..problem.nu).map(|_| rng.gen_range(-1.0..1.0)),
            );
            a.predict(&u);
            b.predict(&u);
            x = &problem.F * &x + &problem.G * &u;
            x_abs = x_abs.max(b.state().amax());
            state_gap = state_gap.max((a.state() - b.state()).amax());
        }
        let scale = steady.K_inf.amax();
        assert!(
            gain_gap <= 1e-12 * scale,
            "the restart's gains differ by {gain_gap:e}"
        );
        assert!(
            state_gap <= 1e-12 * x_abs,
            "the estimates differ by {state_gap:e}"
        );
        // The table used up: K∞, which from here on costs less than the tolerance in variance.
        assert_eq!(a.gain(), Some(steady.K_inf.clone()));
        let (K, P) = (b.gain().expect("a gain"), b.covariance().clone());
        let S = &steady.Ca * &P * steady.Ca.transpose() + &steady.Rn;
        let dK = &steady.K_inf - &K;
        let excess = &dK * &S * dK.transpose();
        let posterior = &P - &K * &S * K.transpose();
        for i in 0..excess.nrows() {
            assert!(
                excess[(i, i)] <= codegen::lower::RESTART_TOLERANCE * posterior[(i, i)],
                "K∞ after {cycles} readings adds {:e} of variance to state {i}",
                excess[(i, i)] / posterior[(i, i)]
            );
        }
    }
}

/// The generated time-varying filter, run long enough, estimates like the steady-state filter.
#[test]
fn generated_time_varying_filter_approaches_the_steady_state_one() {
    // paper (f32, time-varying) against the same model with K∞ in f64, on the same noisy data.
    let p = paper::problem();
    let mut rng = rng(7);
    let mut time_varying = <paper as Generated>::kalman_new(&[0.0; 6]);
    let mut steady = <paper_f64 as Generated>::kalman_new(&[0.0; 6]);
    let mut x = DVector::<f64>::zeros(6);
    let mut late_gap: f64 = 0.0;
    for k in 0..4000 {
        let z: Vec<f64> = (0..3).map(|i| x[i] + 0.3 * normal(&mut rng)).collect();
        paper::kalman_update(&mut time_varying, &z);
        paper_f64::kalman_update(&mut steady, &z);
        let u: Vec<f64> = (0..3).map(|_| rng.gen_range(-1.0..1.0)).collect();
        paper::kalman_predict(&mut time_varying, &u);
        paper_f64::kalman_predict(&mut steady, &u);
        x = &p.F * &x + &p.G * DVector::from_column_slice(&u);
        if k >= 3000 {
            let a = paper::kalman_state(&time_varying);
            let b = paper_f64::kalman_state(&steady);
            late_gap = late_gap.max(
                a.iter()
                    .zip(&b)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max),
            );
        }
    }
    // 3000 cycles = 38 s: the gains agree to far better than the 0.3 m noise; what remains is f32 rounding.
    assert!(
        late_gap < 1e-3,
        "the filters still differ by {late_gap} m after 38 s"
    );
}

/// A non-finite measurement is rejected, counted, and changes nothing else.
#[test]
fn non_finite_measurement_is_rejected() {
    use mpc_tests::paper::Measurement;
    let mut k = mpc_tests::paper::Kalman::new([1.0, 2.0, 3.0, 0.0, 0.0, 0.0]);
    k.predict(&[1.0, 0.0, -1.0]);
    let before = k.clone();
    for (n, bad) in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY]
        .into_iter()
        .enumerate()
    {
        assert_eq!(k.update(&[0.0, bad, 0.0]), Measurement::NonFinite);
        assert_eq!(
            (k.state(), k.covariance()),
            (before.state(), before.covariance())
        );
        assert_eq!(k.status().consecutive_rejections, n as u32 + 1);
        assert_eq!(k.status().cycles_since_accepted, n as u32 + 1);
    }
    assert_eq!(k.update(&[1.0, 2.0, 3.0]), Measurement::Accepted);
    assert_ne!(k.state(), before.state());
    assert_eq!(k.status().consecutive_rejections, 0);
    let mut s = mpc_tests::paper_f64::Kalman::new([0.0; 6]);
    assert!(!s.update(&[f64::NAN, 0.0, 0.0]).accepted());
    assert_eq!(s.state(), &[0.0; 6]);
}
