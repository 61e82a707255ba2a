//! Sampling a continuous-time model exactly (`[model] time = "continuous"`): the plant with a zero-order
//! hold, the process noise by Van Loan's method. The one place where a continuous model becomes the
//! discrete one everything else (lowering, certificate, oracle, emitter) works with.
#![allow(non_snake_case)]

use crate::linalg::symmetrize;
use nalgebra::DMatrix;

/// The largest ‖A‖₁·dt sampled. nalgebra's Padé approximant forms up to the tenth power of the scaled
/// matrix: beyond about 1e30 that power overflows and the scaling count becomes infinite (a hang), so
/// such a model is refused before it is attempted. A physical plant is many orders of magnitude below.
pub const MAX_NORM_DT: f64 = 1e30;

/// Why a continuous model could not be sampled in f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NotFinite {
    /// ‖A‖₁·dt, the size of the exponent.
    pub norm_dt: f64,
}

/// ‖M‖₁, the largest column sum of |m_ij|.
fn one_norm(M: &DMatrix<f64>) -> f64 {
    M.column_iter()
        .map(|c| c.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// The largest |m_ij|, or 1 for a zero matrix: a scale to divide a linear input by.
fn scale_of(M: &DMatrix<f64>) -> f64 {
    let s = M.amax();
    if s > 0.0 {
        s
    } else {
        1.0
    }
}

fn finite(M: &DMatrix<f64>) -> bool {
    M.iter().all(|v| v.is_finite())
}

/// ‖A‖₁·dt, refused when not finite or above [`MAX_NORM_DT`].
fn exponent_size(A: &DMatrix<f64>, dt: f64) -> Result<f64, NotFinite> {
    let norm_dt = one_norm(A) * dt;
    if norm_dt.is_finite() && norm_dt <= MAX_NORM_DT {
        Ok(norm_dt)
    } else {
        Err(NotFinite { norm_dt })
    }
}

/// The zero-order-hold sampling of ẋ = A x + B u over `dt`: exp([[A, B], [0, 0]]·dt) = [[A_d, B_d], [0, I]],
/// A_d = e^{A dt}, B_d = ∫₀^dt e^{A s} ds·B. B_d is linear in B, so B enters scaled to unit size and the
/// exponential's accuracy depends on ‖A‖·dt alone.
pub fn zero_order_hold(
    A: &DMatrix<f64>,
    B: &DMatrix<f64>,
    dt: f64,
) -> Result<(DMatrix<f64>, DMatrix<f64>), NotFinite> {
    let norm_dt = exponent_size(A, dt)?;
    let (nx, nu) = (A.nrows(), B.ncols());
    let beta = scale_of(B);
    let mut M = DMatrix::zeros(nx + nu, nx + nu);
    M.view_mut((0, 0), (nx, nx)).copy_from(&(A * dt));
    M.view_mut((0, nx), (nx, nu)).copy_from(&(B * (dt / beta)));
    let E = M.exp();
    let Ad = E.view((0, 0), (nx, nx)).into_owned();
    let Bd = E.view((0, nx), (nx, nu)).into_owned() * beta;
    if finite(&Ad) && finite(&Bd) {
        Ok((Ad, Bd))
    } else {
        Err(NotFinite { norm_dt })
    }
}

/// The covariance Q_d = ∫₀^dt e^{A s} Q_c e^{Aᵀ s} ds that white noise of spectral density Q_c
/// (E[w(t) w(τ)ᵀ] = Q_c δ(t − τ)) accumulates over `dt`, symmetrized.
///
/// Van Loan's method: exp([[−A, Q_c], [0, Aᵀ]]·h) = [[·, F₁₂], [0, F₂₂]], Q_d(h) = F₂₂ᵀ F₁₂. Its e^{−A h}
/// grows as e^{|λ| h} for a stable mode (e^{1000}, an overflow, for λ = −1e3 and h = 1 s) and F₂₂ᵀ F₁₂
/// cancels that growth in rounding, so it is evaluated at h = dt/2^s with ‖A‖₁·h ≤ 1 and carried to dt by
/// the exact doubling Q_d(2h) = Q_d(h) + e^{A h} Q_d(h) e^{Aᵀ h}, a sum of positive semidefinite terms.
pub fn van_loan(A: &DMatrix<f64>, Qc: &DMatrix<f64>, dt: f64) -> Result<DMatrix<f64>, NotFinite> {
    let norm_dt = exponent_size(A, dt)?;
    let n = A.nrows();
    // Q_d is linear in Q_c: sampled at unit scale, scaled back at the end.
    let gamma = scale_of(Qc);
    let s = if norm_dt > 1.0 {
        norm_dt.log2().ceil() as i32
    } else {
        0
    };
    let h = dt / 2f64.powi(s);
    let mut M = DMatrix::zeros(2 * n, 2 * n);
    M.view_mut((0, 0), (n, n)).copy_from(&(A * -h));
    M.view_mut((0, n), (n, n)).copy_from(&(Qc * (h / gamma)));
    M.view_mut((n, n), (n, n)).copy_from(&(A.transpose() * h));
    let E = M.exp();
    let F12 = E.view((0, n), (n, n)).into_owned();
    let F22 = E.view((n, n), (n, n)).into_owned();
    let mut Q = symmetrize(&(F22.transpose() * F12));
    // e^{A h}, squared along with the doubling.
    let mut Phi = F22.transpose();
    for _ in 0..s {
        Q = symmetrize(&(&Q + &Phi * &Q * Phi.transpose()));
        Phi = &Phi * &Phi;
    }
    let Q = Q * gamma;
    if finite(&Q) {
        Ok(Q)
    } else {
        Err(NotFinite { norm_dt })
    }
}
