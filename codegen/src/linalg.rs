//! Build-time linear algebra in f64 shared by the lowering, the certificate and the oracle: spectra,
//! Riccati and Lyapunov iterations, the Kalman gain, and the box projection every solver uses.
#![allow(non_snake_case)]

use mpc_spec::Matrix;
use nalgebra::{DMatrix, SymmetricEigen};

/// (λmin, λmax) of a symmetric matrix.
pub fn extreme_eigenvalues(M: &DMatrix<f64>) -> (f64, f64) {
    let eig = SymmetricEigen::new(M.clone()).eigenvalues;
    (eig.min(), eig.max())
}

/// The steady-state prior covariance and gain, by iterating the Riccati recursion from P0.
pub fn steady_state_filter(
    F: &DMatrix<f64>,
    C: &DMatrix<f64>,
    Qn: &DMatrix<f64>,
    Rn: &DMatrix<f64>,
    P0: &DMatrix<f64>,
) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
    let mut P = P0.clone();
    for _ in 0..1_000_000 {
        let (_, P_post) = kalman_gain_and_posterior(&P, C, Rn)?;
        let next = symmetrize(&(F * P_post * F.transpose() + Qn));
        let change = (&next - &P).amax();
        P = next;
        if !P.iter().all(|v| v.is_finite()) {
            return None;
        }
        if change <= 1e-15 * P.amax() {
            let (K, _) = kalman_gain_and_posterior(&P, C, Rn)?;
            return Some((P, K));
        }
    }
    None
}

/// One step of the gain sequence after a restart: the gain K_k and the inverse S_k⁻¹ of the innovation
/// covariance S_k = C P_k Cᵀ + R that the time-varying filter uses for its k-th reading.
#[derive(Clone, Debug, PartialEq)]
pub struct Gain {
    /// K_k = P_k Cᵀ S_k⁻¹.
    pub K: DMatrix<f64>,
    /// S_k⁻¹.
    pub S_inv: DMatrix<f64>,
}

/// The gains of the time-varying filter restarted with the posterior covariance P0 (as re-acquisition
/// restarts it) and fed every reading from then on: entry k − 1 is the gain of the k-th reading, whose
/// prior is P_k = F P⁺_{k−1} Fᵀ + Q with P⁺_0 = P0 (the oracle's time-varying arithmetic: Joseph form,
/// symmetrized). The sequence depends on no measurement, so it is a table.
///
/// It ends after the last reading for which K∞ would not do: where the posterior with K∞ instead of
/// K_k, P⁺_k + (K∞ − K_k) S_k (K∞ − K_k)ᵀ (the posterior is stationary in the gain), exceeds P⁺_k by
/// more than `tolerance` in some state's variance, or S∞ differs from S_k by more than `tolerance` in
/// some diagonal entry (the gate). The recursion runs until the prior is within 1e-9 of P∞ (it
/// converges as the steady-state gain's does), `max` entries at most.
pub fn restart_gains(
    model: (&DMatrix<f64>, &DMatrix<f64>),
    noise: (&DMatrix<f64>, &DMatrix<f64>),
    P0: &DMatrix<f64>,
    steady: (&DMatrix<f64>, &DMatrix<f64>),
    tolerance: f64,
    max: usize,
) -> Vec<Gain> {
    let ((F, C), (Qn, Rn), (K_inf, P_inf)) = (model, noise, steady);
    let S_inf = C * P_inf * C.transpose() + Rn;
    let mut gains = Vec::new();
    let mut needed = 0;
    let mut posterior = P0.clone();
    while gains.len() < max {
        let prior = symmetrize(&(F * &posterior * F.transpose() + Qn));
        if (&prior - P_inf).amax() <= 1e-9 * P_inf.amax() {
            break;
        }
        let S = C * &prior * C.transpose() + Rn;
        let (Some(S_inv), Some((K, next))) = (
            S.clone().cholesky().map(|c| c.inverse()),
            kalman_gain_and_posterior(&prior, C, Rn),
        ) else {
            break;
        };
        if !K.iter().chain(S_inv.iter()).all(|v| v.is_finite()) {
            break;
        }
        let dK = K_inf - &K;
        let excess = &dK * &S * dK.transpose();
        let costly = (0..excess.nrows()).any(|i| excess[(i, i)] > tolerance * next[(i, i)]);
        let gate =
            (0..S.nrows()).any(|i| (S_inf[(i, i)] - S[(i, i)]).abs() > tolerance * S[(i, i)]);
        gains.push(Gain { K, S_inv });
        if costly || gate {
            needed = gains.len();
        }
        posterior = next;
    }
    gains.truncate(needed);
    gains
}

/// The Moore-Penrose pseudo-inverse, singular values below ε·max(rows, cols) of M's largest entry taken
/// as zero (a tolerance relative to M's own scale); zeros if the SVD fails.
pub fn pseudo_inverse(M: &DMatrix<f64>) -> DMatrix<f64> {
    let scale = M.amax().max(f64::MIN_POSITIVE);
    M.clone()
        .pseudo_inverse(scale * f64::EPSILON * M.nrows().max(M.ncols()) as f64)
        .unwrap_or_else(|_| DMatrix::zeros(M.ncols(), M.nrows()))
}

/// The gain K = P Cᵀ (C P Cᵀ + R)⁻¹ and the Joseph-form posterior (I − KC) P (I − KC)ᵀ + K R Kᵀ.
pub fn kalman_gain_and_posterior(
    P: &DMatrix<f64>,
    C: &DMatrix<f64>,
    Rn: &DMatrix<f64>,
) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
    let PCt = P * C.transpose();
    let S = C * &PCt + Rn;
    let S_inv = S.cholesky()?.inverse();
    let K = PCt * S_inv;
    let I_KC = DMatrix::identity(P.nrows(), P.nrows()) - &K * C;
    let post = &I_KC * P * I_KC.transpose() + &K * Rn * K.transpose();
    Some((K, symmetrize(&post)))
}

/// (M + Mᵀ)/2: removes the rounding asymmetry of products that are symmetric in exact arithmetic.
pub fn symmetrize(M: &DMatrix<f64>) -> DMatrix<f64> {
    (M + M.transpose()) * 0.5
}

/// The projection onto [lo, hi] used everywhere, generated code and oracle alike: NaN maps to `lo`,
/// so the result is always finite and inside the box.
pub fn project(v: f64, lo: f64, hi: f64) -> f64 {
    let v = if v > lo { v } else { lo };
    if v < hi {
        v
    } else {
        hi
    }
}

/// A spec matrix as nalgebra's.
pub fn dense(m: &Matrix) -> DMatrix<f64> {
    DMatrix::from_row_slice(m.rows, m.cols, &m.data)
}

/// The largest modulus of the eigenvalues of a square matrix: from the real Schur form when its QR
/// iteration converges (nalgebra's unbounded `complex_eigenvalues` can loop forever on some matrices),
/// else by Gelfand's formula ρ = lim ‖Aᵏ‖^(1/k) with k = 2⁶⁰, squaring and rescaling.
pub fn spectral_radius(M: &DMatrix<f64>) -> f64 {
    if let Some(schur) = nalgebra::Schur::try_new(M.clone(), f64::EPSILON, 100_000) {
        return schur
            .complex_eigenvalues()
            .iter()
            .map(|c| c.norm())
            .fold(0.0, f64::max);
    }
    let mut A = M.clone();
    let mut log_scale = 0.0;
    for j in 0..60 {
        let norm = A.amax();
        if norm == 0.0 {
            return 0.0;
        }
        A /= norm;
        log_scale += norm.ln() / f64::powi(2.0, j);
        A = &A * &A;
    }
    (log_scale + A.amax().ln() / f64::powi(2.0, 60)).exp()
}

/// The LQR gain of the discrete algebraic Riccati equation, by iterating the Riccati difference equation.
pub fn lqr_gain(
    F: &DMatrix<f64>,
    G: &DMatrix<f64>,
    Q: &DMatrix<f64>,
    R: &DMatrix<f64>,
) -> Option<DMatrix<f64>> {
    let mut P = Q.clone();
    for _ in 0..1_000_000 {
        let GtP = G.transpose() * &P;
        let K = (R + &GtP * G).cholesky()?.solve(&(GtP * F));
        let next = Q + F.transpose() * &P * (F - G * &K);
        let next = (&next + next.transpose()) * 0.5;
        let change = (&next - &P).amax();
        P = next;
        if !P.iter().all(|v| v.is_finite()) {
            return None;
        }
        if change <= 1e-14 * P.amax() {
            let GtP = G.transpose() * &P;
            return (R + &GtP * G).cholesky().map(|c| c.solve(&(GtP * F)));
        }
    }
    None
}

/// P with Aᵀ P A − P = −I, by doubling (P ← P + Aᵀ P A, A ← A²); `None` unless ρ(A) < 1.
pub fn lyapunov_identity(A: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    if spectral_radius(A) >= 1.0 {
        return None;
    }
    let n = A.nrows();
    let mut P = DMatrix::identity(n, n);
    let mut Ak = A.clone();
    for _ in 0..64 {
        let next = &P + Ak.transpose() * &P * &Ak;
        let done = (&next - &P).amax() <= 1e-15 * next.amax();
        P = next;
        Ak = &Ak * &Ak;
        if done {
            break;
        }
    }
    Some((&P + P.transpose()) * 0.5)
}

/// A matrix as a fixed-size array of rows, the form `no_std` code takes (`flight_sim::LinearPlant`
/// from the lowered F, G and C). Panics when `M` is not R × C.
pub fn array<const R: usize, const C: usize>(M: &DMatrix<f64>) -> [[f64; C]; R] {
    assert_eq!(
        (M.nrows(), M.ncols()),
        (R, C),
        "the matrix is {}×{}, the array {R}×{C}",
        M.nrows(),
        M.ncols()
    );
    core::array::from_fn(|i| core::array::from_fn(|j| M[(i, j)]))
}

/// The stabilizing solution P of the discrete algebraic Riccati equation with a cross term S,
/// P = AᵀPA − (AᵀPB + S)(R + BᵀPB)⁻¹(BᵀPA + Sᵀ) + Q, for the cost Σ xᵀQx + 2xᵀSu + uᵀRu; R positive
/// definite. The cross term is removed by the change of input u = v − R⁻¹Sᵀx (Ā = A − BR⁻¹Sᵀ,
/// Q̄ = Q − SR⁻¹Sᵀ), and the plain equation in (Ā, B, Q̄, R) is solved by the structure-preserving
/// doubling algorithm (Chu, Fan, Lin and Wang, 2004): A₀ = Ā, G₀ = BR⁻¹Bᵀ, H₀ = Q̄, and
/// W = I + GₖHₖ, Aₖ₊₁ = AₖW⁻¹Aₖ, Gₖ₊₁ = Gₖ + AₖW⁻¹GₖAₖᵀ, Hₖ₊₁ = Hₖ + AₖᵀHₖW⁻¹Aₖ, where Hₖ is the
/// Riccati recursion's value after 2ᵏ steps and converges quadratically to P. `None` when R is not
/// positive definite, W is singular, or Hₖ does not settle within 100 doublings (a plant that is not
/// stabilizable, or Q̄ that does not detect an unstable mode).
pub fn dare(
    A: &DMatrix<f64>,
    B: &DMatrix<f64>,
    Q: &DMatrix<f64>,
    R: &DMatrix<f64>,
    S: &DMatrix<f64>,
) -> Option<DMatrix<f64>> {
    let n = A.nrows();
    let R_inv = R.clone().cholesky()?.inverse();
    let mut Ak = A - B * &R_inv * S.transpose();
    let mut G = symmetrize(&(B * &R_inv * B.transpose()));
    let mut H = symmetrize(&(Q - S * &R_inv * S.transpose()));
    let I = DMatrix::<f64>::identity(n, n);
    for _ in 0..100 {
        let W = (&I + &G * &H).lu();
        let W_inv_A = W.solve(&Ak)?;
        let W_inv_G = W.solve(&G)?;
        let next_H = symmetrize(&(&H + Ak.transpose() * &H * &W_inv_A));
        let next_G = symmetrize(&(&G + &Ak * W_inv_G * Ak.transpose()));
        let next_A = &Ak * W_inv_A;
        if !next_H.iter().chain(next_A.iter()).all(|v| v.is_finite()) {
            return None;
        }
        let change = (&next_H - &H).amax();
        H = next_H;
        G = next_G;
        Ak = next_A;
        if change <= 1e-14 * H.amax() {
            return Some(H);
        }
    }
    None
}
