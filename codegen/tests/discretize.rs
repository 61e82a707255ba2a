//! The sampling of continuous-time models (`[model] time = "continuous"`) against independent methods: a
//! Taylor series with scaling and squaring (nalgebra's `exp` is a Padé approximant), closed forms where
//! they exist (the double integrator, an integrator chain, a symmetric A's covariance integral).
#![allow(non_snake_case)]

use codegen::discretize::{van_loan, zero_order_hold, NotFinite};
use codegen::lower::{plant, white_acceleration_noise};
use mpc_spec::{Matrix, ModelKind, TimeDomain};
use nalgebra::{DMatrix, DVector};

/// A deterministic stream of numbers in [−1, 1) (xorshift64*): the tests need no statistics.
struct Numbers(u64);

impl Numbers {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let bits = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11;
        bits as f64 / (1u64 << 52) as f64 - 1.0
    }

    fn matrix(&mut self, r: usize, c: usize) -> DMatrix<f64> {
        DMatrix::from_fn(r, c, |_, _| self.next())
    }
}

fn one_norm(M: &DMatrix<f64>) -> f64 {
    M.column_iter()
        .map(|c| c.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// e^M by a Taylor series on M/2^s, ‖M/2^s‖₁ ≤ 1/2, summed until the terms stop changing the sum, then
/// squared s times.
fn exp_taylor(M: &DMatrix<f64>) -> DMatrix<f64> {
    let norm = one_norm(M);
    let s = if norm > 0.5 {
        (norm / 0.5).log2().ceil() as i32
    } else {
        0
    };
    let X = M / 2f64.powi(s);
    let n = M.nrows();
    let mut sum = DMatrix::identity(n, n);
    let mut term = DMatrix::identity(n, n);
    for k in 1..60 {
        term = &term * &X / k as f64;
        sum += &term;
        if one_norm(&term) <= f64::EPSILON * 1e-3 * one_norm(&sum) {
            break;
        }
    }
    for _ in 0..s {
        sum = &sum * &sum;
    }
    sum
}

/// A_d and B_d from the Taylor exponential of [[A, B], [0, 0]]·dt.
fn zoh_taylor(A: &DMatrix<f64>, B: &DMatrix<f64>, dt: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let (nx, nu) = (A.nrows(), B.ncols());
    let mut M = DMatrix::zeros(nx + nu, nx + nu);
    M.view_mut((0, 0), (nx, nx)).copy_from(&(A * dt));
    M.view_mut((0, nx), (nx, nu)).copy_from(&(B * dt));
    let E = exp_taylor(&M);
    (
        E.view((0, 0), (nx, nx)).into_owned(),
        E.view((0, nx), (nx, nu)).into_owned(),
    )
}

/// The sampling agrees with the Taylor series to 1e-12 of ‖e^{A dt}‖ (and of ‖B_d‖).
fn agrees_with_taylor(what: &str, A: &DMatrix<f64>, B: &DMatrix<f64>, dt: f64) {
    let (Ad, Bd) = zero_order_hold(A, B, dt).expect("finite");
    let (At, Bt) = zoh_taylor(A, B, dt);
    let ea = (&Ad - &At).norm() / At.norm();
    let eb = (&Bd - &Bt).norm() / Bt.norm();
    assert!(ea <= 1e-12, "{what}: A_d differs by {ea:e} of ‖e^(A dt)‖");
    assert!(eb <= 1e-12, "{what}: B_d differs by {eb:e} of ‖B_d‖");
}

#[test]
fn stiff_model_agrees_with_a_taylor_series_and_its_eigendecomposition() {
    // Eigenvalues −1e3 … −1e-2 in a skewed (non-orthogonal, κ(V) = 6.9) basis; dt = 0.01: e^{−10} next
    // to e^{−1e-4}.
    let mut rng = Numbers(0x5eed_0001);
    let lambda = [-1e3, -1e2, -10.0, -1.0, -0.1, -1e-2];
    let V = DMatrix::identity(6, 6) + rng.matrix(6, 6) * 0.3;
    let Vi = V.clone().try_inverse().unwrap();
    let diagonal = |f: &dyn Fn(f64) -> f64| {
        DMatrix::from_diagonal(&DVector::from_iterator(6, lambda.iter().map(|l| f(*l))))
    };
    let A = &V * diagonal(&|l| l) * &Vi;
    let B = rng.matrix(6, 2);
    agrees_with_taylor("stiff", &A, &B, 0.01);
    // Over long periods (‖A‖·dt in the thousands, the fast modes decayed to nothing) the Taylor series
    // needs 13 squarings, each doubling its own error (3e-12 of the eigendecomposition's at dt = 2 s, where
    // the Padé approximant is within 6e-14): the reference is then the eigendecomposition,
    // e^{A dt} = V e^{Λ dt} V⁻¹ and B_d = V Λ⁻¹(e^{Λ dt} − I) V⁻¹ B, which does not square.
    for dt in [0.01, 0.5, 2.0] {
        let (Ad, Bd) = zero_order_hold(&A, &B, dt).unwrap();
        let Ae = &V * diagonal(&|l| (l * dt).exp()) * &Vi;
        let Be = &V * diagonal(&|l| (l * dt).exp_m1() / l) * &Vi * &B;
        let ea = (&Ad - &Ae).norm() / Ae.norm();
        let eb = (&Bd - &Be).norm() / Be.norm();
        assert!(
            ea <= 1e-12,
            "dt = {dt}: A_d differs by {ea:e} of ‖e^(A dt)‖"
        );
        assert!(eb <= 1e-12, "dt = {dt}: B_d differs by {eb:e} of ‖B_d‖");
    }
}

#[test]
fn marginally_stable_models_agree_with_a_taylor_series_and_closed_forms() {
    // An undamped oscillator: e^{A dt} is the rotation by ω·dt.
    let w = 2.0 * std::f64::consts::PI * 3.0;
    let A = DMatrix::from_row_slice(2, 2, &[0.0, w, -w, 0.0]);
    let B = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
    let dt = 0.1;
    agrees_with_taylor("oscillator", &A, &B, dt);
    let (Ad, Bd) = zero_order_hold(&A, &B, dt).unwrap();
    let (c, s) = ((w * dt).cos(), (w * dt).sin());
    let rotation = DMatrix::from_row_slice(2, 2, &[c, s, -s, c]);
    assert!((&Ad - rotation).norm() <= 1e-14);
    // ∫₀^dt e^{A τ} dτ·B = [(1 − cos ωdt)/ω; sin ωdt/ω].
    let exact = DMatrix::from_row_slice(2, 1, &[(1.0 - c) / w, s / w]);
    assert!((&Bd - exact).norm() <= 1e-15, "{Bd}");

    // A chain of four integrators: e^{N dt} = Σ (N dt)^k/k! ends at k = 3, and B_d = [dt⁴/24, dt³/6, dt²/2, dt].
    let mut N = DMatrix::zeros(4, 4);
    for i in 0..3 {
        N[(i, i + 1)] = 1.0;
    }
    let B = DMatrix::from_row_slice(4, 1, &[0.0, 0.0, 0.0, 1.0]);
    let dt = 0.7;
    agrees_with_taylor("integrator chain", &N, &B, dt);
    let (Ad, Bd) = zero_order_hold(&N, &B, dt).unwrap();
    let exact = DMatrix::from_fn(4, 4, |i, j| {
        if j >= i {
            dt.powi((j - i) as i32) / (1..=(j - i)).product::<usize>() as f64
        } else {
            0.0
        }
    });
    assert!((&Ad - exact).norm() <= 1e-15 * Ad.norm(), "{Ad}");
    let exact_b = DMatrix::from_row_slice(
        4,
        1,
        &[dt.powi(4) / 24.0, dt.powi(3) / 6.0, dt * dt / 2.0, dt],
    );
    assert!((&Bd - exact_b).norm() <= 1e-15, "{Bd}");
}

#[test]
fn random_12x12_agrees_with_a_taylor_series() {
    let mut rng = Numbers(0x5eed_0012);
    for (seed_dt, dt) in [(0, 0.05), (1, 0.5), (2, 2.0)] {
        let A = rng.matrix(12, 12);
        let B = rng.matrix(12, 3);
        agrees_with_taylor(&format!("random {seed_dt}, dt = {dt}"), &A, &B, dt);
    }
}

/// Eq. 2 with a zero-order hold: the continuous double integrator sampled gives F = [[1, dt], [0, 1]],
/// G = [dt²/2; dt], the matrices the compiler writes for `type = "double_integrator"`.
#[test]
fn the_double_integrator_is_its_own_zero_order_hold() {
    for dt in [0.0128, 0.3, 5.0] {
        let A = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
        let B = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let (Ad, Bd) = zero_order_hold(&A, &B, dt).unwrap();
        let F = DMatrix::from_row_slice(2, 2, &[1.0, dt, 0.0, 1.0]);
        let G = DMatrix::from_row_slice(2, 1, &[dt * dt / 2.0, dt]);
        assert!((&Ad - &F).amax() <= 1e-15 * dt.max(1.0), "dt = {dt}: {Ad}");
        assert!(
            (&Bd - &G).amax() <= 1e-15 * (dt * dt).max(1.0),
            "dt = {dt}: {Bd}"
        );
        // Through `lower::plant`, the one place the lowering takes its model from.
        let linear = ModelKind::Linear {
            a: Matrix::from_rows(&[vec![0.0, 1.0], vec![0.0, 0.0]]),
            b: Matrix::from_rows(&[vec![0.0], vec![1.0]]),
            c: Matrix::from_rows(&[vec![1.0, 0.0]]),
            time: TimeDomain::Continuous,
        };
        let (Fl, Gl, Cl) = plant(&linear, dt).unwrap();
        let (Fd, Gd, Cd) = plant(&ModelKind::DoubleIntegrator { axes: 1 }, dt).unwrap();
        assert!((&Fl - &Fd).amax() <= 1e-15 * dt.max(1.0));
        assert!((&Gl - &Gd).amax() <= 1e-15 * (dt * dt).max(1.0));
        assert_eq!(Cl, Cd);

        // White acceleration noise of density σ²: Q_d = σ²[[dt³/3, dt²/2], [dt²/2, dt]].
        let sigma2 = 0.15f64.powi(2);
        let Qc = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, 0.0, sigma2]);
        let Qd = van_loan(&A, &Qc, dt).unwrap();
        let exact =
            DMatrix::from_row_slice(2, 2, &[dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt])
                * sigma2;
        assert!(
            (&Qd - &exact).norm() <= 1e-14 * exact.norm(),
            "dt = {dt}: {Qd} vs {exact}"
        );
        // Eq. 3 (`[kalman] sigma_a`) is another convention: an acceleration constant over each period, of
        // variance σ², Q = σ² G Gᵀ = σ²[[dt⁴/4, dt³/2], [dt³/2, dt²]]; σ_a is per sample, not a density.
        let eq3 = white_acceleration_noise(1, dt, 0.15);
        assert!((&eq3 - &G * G.transpose() * sigma2).amax() <= 1e-15 * eq3.amax());
        assert!((&eq3 - &Qd).amax() > 1e-3 * eq3.amax());
    }
}

/// For a symmetric A = U Λ Uᵀ the covariance integral has a closed form in the eigenbasis:
/// (UᵀQ_dU)_ij = (UᵀQ_cU)_ij·(e^{(λi+λj)dt} − 1)/(λi + λj).
#[test]
fn van_loan_agrees_with_the_closed_form_on_stiff_symmetric_models() {
    let mut rng = Numbers(0x5eed_0003);
    let U = rng.matrix(5, 5).qr().q();
    let lambda = [-1e3, -30.0, -1.0, -1e-2, 0.0];
    let A = &U * DMatrix::from_diagonal(&DVector::from_column_slice(&lambda)) * U.transpose();
    let L = rng.matrix(5, 5);
    let Qc = &L * L.transpose();
    // dt = 1 s: the direct Van Loan exponential would hold e^{1000}.
    for dt in [0.01, 1.0] {
        let Qd = van_loan(&A, &Qc, dt).unwrap();
        let Qt = U.transpose() * &Qc * &U;
        let inner = DMatrix::from_fn(5, 5, |i, j| {
            let s = lambda[i] + lambda[j];
            let integral = if s == 0.0 { dt } else { (s * dt).exp_m1() / s };
            Qt[(i, j)] * integral
        });
        let exact = &U * inner * U.transpose();
        let e = (&Qd - &exact).norm() / exact.norm();
        assert!(e <= 1e-12, "dt = {dt}: Q_d differs by {e:e}");
        assert_eq!(Qd, Qd.transpose());
    }
}

#[test]
fn unsampleable_models_are_refused() {
    let B = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
    // A mode e^{1000}: overflows.
    let A = DMatrix::from_row_slice(2, 2, &[1000.0, 0.0, 0.0, -1.0]);
    assert!(
        matches!(zero_order_hold(&A, &B, 1.0), Err(NotFinite { norm_dt }) if norm_dt == 1000.0)
    );
    // e^{500} is finite, its covariance's e^{1000} is not.
    assert!(zero_order_hold(&A, &B, 0.5).is_ok());
    assert!(van_loan(&A, &DMatrix::identity(2, 2), 0.5).is_err());
    // An exponent too large to attempt (the Padé scaling would not terminate).
    let A = DMatrix::from_row_slice(2, 2, &[-1e200, 0.0, 0.0, -1.0]);
    assert!(zero_order_hold(&A, &B, 1.0).is_err());
}
