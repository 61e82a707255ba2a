//! Coordinates the emitted scalar can carry: the largest magnitude X of the absolute coordinates (a
//! drone's positions) for which rounding keeps the first command u₀ within a stated accuracy of the
//! exact-arithmetic command, derived from the matrices and the unit roundoff u (2⁻²⁴ for f32, 2⁻⁵³ for
//! f64). The generated code works in absolute coordinates; this is what the compiler states instead.
//!
//! # The model (first order)
//! A stored number of magnitude X carries up to u·X of rounding; numbers of order 1 (velocities, inputs,
//! the disturbance) are taken as exact. "The exact-arithmetic command" is what the same controller computes
//! in exact arithmetic from the same readings and references. Per unit of u·X, elementwise:
//! - **inputs as stored**: each reading zⱼ, (|C|·s)ⱼ, and each reference entry, s (the caller's conversion
//!   to the scalar); s is 1 on the absolute states, 0 elsewhere;
//! - **the filter**: the update x + K·e adds the estimate last (one rounding per absolute state), the
//!   predict F·x + G·u sums row i left to right (nnz(row i) − 1 additions, plus one per coefficient other
//!   than ±1 on an absolute state, each at (|F|·s)ᵢ), the predicted measurement C·x likewise; the innovation
//!   z − C·x of two nearby numbers is exact (Sterbenz). These errors persist: the estimate error follows the
//!   controller's own loop with the readings fixed, A = (I − K∞C)(F − G·M), M the first nu rows of
//!   H⁻¹·[Fx Fd] (u₀ = −M·x̂ + ...), K∞ the steady-state gain (the time-varying filter's limit); when that
//!   loop is not strictly stable (the offset-free controller's integral action puts an eigenvalue at 1,
//!   and a controller may be unstable on its own) the estimation error dynamics (I − K∞C)F that a closed
//!   loop sees are used instead. Each injection is weighted by the ℓ1 norm of its impulse
//!   response to u₀, Σⱼ |M·Aʲ·B| (B the injection's input matrix: I, I − K∞C, K∞);
//! - **the gradient map**: unrolled, f = Fx·x0 − Fr·Xref (+ Fd·d) has terms of order ‖Fx‖·X that cancel, so
//!   its rounding is about |Fx|·s + |Fr|·(1 ⊗ s), one rounding per term (the partial sums, bounded by the
//!   same, are not counted again), mapped by the first nu rows of |H⁻¹|; the sweep forms (`table`,
//!   `lanes`, `matrix_free`) compute f from the predicted states xₖ = F·xₖ₋₁ (+ G·vₖ for `matrix_free`'s
//!   iterations), which accumulate the predict's rounding over the horizon (δxₖ = |F|·δxₖ₋₁ + ι), mapped by
//!   |H⁻¹·Fr|. The fixed-iteration, warm-started solver's map is taken as the exact H⁻¹: right for a
//!   solver that converges (the paper: the impulse responses of the oracle's real iteration give the same g
//!   to 4 digits, `codegen/tests/coordinates.rs`), conservative for the under-converged `paper-initial`
//!   (744 measured, 1112 stated). A command error also enters the filter's predict through G.
//!
//! The sum is g, the worst ‖δu₀‖∞ per unit of u·X, and X_max = accuracy·min(u_max − u_min)/(u·g). Worst
//! case over the signs of every rounding: real runs, whose roundings partly cancel, stay below it.
//!
//! # Which coordinates are absolute
//! Those the plant can hold at any value while it sits still with the input at rest: the states touched by
//! the null space of F − I (the double integrator's positions). A plant without such a direction has no
//! natural large coordinate; then every state is counted, which states the range for states of magnitude X.
#![allow(non_snake_case)]

use crate::lower::problem::Problem;
use crate::numeric::Numeric;
use mpc_spec::{Emission, Scalar};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// The command accuracy the range is stated for: 1 % of the smallest input span.
pub const DEFAULT_ACCURACY: f64 = 0.01;

/// Impulse responses are summed until their terms fall below this fraction of the sum.
const TAIL: f64 = 1e-12;

/// Multiply-adds the ℓ1 sums may spend; past it, the rest of each sum is bounded by its last term
/// times ρ/(1 − ρ), ρ the loop's spectral radius.
const BUDGET: f64 = 1e8;

/// What rounding of absolute coordinates costs the first command, and the range it allows.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CoordinateRange {
    /// The states counted as absolute coordinates (indices into x).
    pub states: Vec<usize>,
    /// The accuracy, as a fraction of the smallest input span.
    pub accuracy: f64,
    /// The accuracy in the inputs' units: accuracy·min(u_max − u_min).
    pub command_accuracy: f64,
    /// g: the worst first-order ‖δu₀‖∞ per unit of u·X, and its parts.
    pub sensitivity: Sensitivity,
    /// X_max in f32 (u = 2⁻²⁴).
    pub f32: f64,
    /// X_max in f64 (u = 2⁻⁵³).
    pub f64: f64,
}

/// g and its parts, per unit of u·X (the worst input of each part; the total is of the sum, so it may be
/// less than the sum of the parts).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Sensitivity {
    /// The whole: ‖δu₀‖∞ per unit of u·X.
    pub total: f64,
    /// From the readings as stored and the filter's estimate (update, predict, innovation).
    pub filter: f64,
    /// From the references as stored.
    pub reference: f64,
    /// From the gradient map's arithmetic.
    pub gradient: f64,
}

impl CoordinateRange {
    /// X_max of the scalar type.
    pub fn of(&self, scalar: Scalar) -> f64 {
        match scalar {
            Scalar::F32 => self.f32,
            Scalar::F64 => self.f64,
        }
    }

    /// How the states are named: `x[0..3]`, or a list.
    pub fn names(&self) -> String {
        let s = &self.states;
        match s.as_slice() {
            [] => "x".into(),
            [one] => format!("x[{one}]"),
            [first, .., last] if last - first + 1 == s.len() => format!("x[{first}..{}]", last + 1),
            _ => s
                .iter()
                .map(|i| format!("x[{i}]"))
                .collect::<Vec<_>>()
                .join(", "),
        }
    }
}

/// The unit roundoff of a scalar type: half its machine epsilon.
pub fn unit_roundoff(scalar: Scalar) -> f64 {
    Numeric(scalar).epsilon() / 2.0
}

/// The states the plant can hold at any value with the input at rest: those touched by the null space of
/// F − I; every state when that null space is trivial.
pub fn absolute_states(F: &DMatrix<f64>) -> Vec<usize> {
    let n = F.nrows();
    let svd = (F - DMatrix::identity(n, n)).svd(false, true);
    let scale = F.amax().max(1.0);
    let mut touched = vec![false; n];
    if let Some(v_t) = &svd.v_t {
        for (k, sigma) in svd.singular_values.iter().enumerate() {
            if *sigma <= 1e-9 * scale {
                for (i, t) in touched.iter_mut().enumerate() {
                    *t |= v_t[(k, i)].abs() > 1e-9;
                }
            }
        }
    }
    let states: Vec<usize> = (0..n).filter(|i| touched[*i]).collect();
    if states.is_empty() {
        (0..n).collect()
    } else {
        states
    }
}

/// Roundings of magnitude (|M|·s)ᵢ when row i of `M` (with the extra columns `more`) is summed left to
/// right: nnz − 1 additions, plus one per coefficient other than ±1 on an absolute state. Per unit of u·X.
fn row_roundings(
    M: &DMatrix<f64>,
    more: Option<&DMatrix<f64>>,
    s: &DVector<f64>,
    num: Numeric,
) -> DVector<f64> {
    let magnitude = M.abs() * s;
    DVector::from_fn(M.nrows(), |i, _| {
        let nonzero = |v: f64| num.round(v) != 0.0;
        let terms = M.row(i).iter().filter(|v| nonzero(**v)).count()
            + more.map_or(0, |G| G.row(i).iter().filter(|v| nonzero(**v)).count());
        let scaled = M
            .row(i)
            .iter()
            .zip(s.iter())
            .filter(|(v, s)| **s != 0.0 && nonzero(**v) && num.round(v.abs()) != 1.0)
            .count();
        (terms.saturating_sub(1) + scaled) as f64 * magnitude[i]
    })
}

/// The first `rows` rows of H⁻¹·M (H is positive definite: `lower` refuses it otherwise; NaN if not).
fn first_rows_of_solve(H: &DMatrix<f64>, M: &DMatrix<f64>, rows: usize) -> DMatrix<f64> {
    match H.clone().cholesky() {
        Some(c) => c.solve(M).rows(0, rows).into_owned(),
        None => DMatrix::from_element(rows, M.ncols(), f64::NAN),
    }
}

/// The roundings one control cycle injects, per unit of u·X: the worst magnitude of each entry.
#[derive(Clone, Debug, PartialEq)]
pub struct Injections {
    /// The states counted as absolute coordinates.
    pub states: Vec<usize>,
    /// Into the filter's estimate (x, d) as the update stores it.
    pub update: DVector<f64>,
    /// Into the estimate as the predict stores it.
    pub predict: DVector<f64>,
    /// Into the innovation: the reading as stored and the predicted measurement C·x.
    pub measured: DVector<f64>,
    /// Into u₀ directly from the references as stored (through H⁻¹·Fr).
    pub reference: DVector<f64>,
    /// Into u₀ directly from the gradient map's arithmetic.
    pub gradient: DVector<f64>,
    /// The map from the estimate (x, d) to u₀, the first nu rows of H⁻¹·[Fx Fd] (u₀ = −M·x̂ + ...).
    pub M: DMatrix<f64>,
}

/// Where and how much the controller of `p`, with the gradient form `emission`, rounds per cycle.
pub fn injections(p: &Problem, emission: Emission) -> Injections {
    let num = Numeric(p.scalar);
    let qp = &p.qp;
    let nd = p.nd();
    let (nx, nu, na, N, nz) = (p.nx, p.nu, p.nx + nd, qp.N, qp.nz);
    let states = absolute_states(&p.F);
    let s = DVector::from_fn(nx, |i, _| if states.contains(&i) { 1.0 } else { 0.0 });
    let s_a = DVector::from_fn(na, |i, _| if i < nx { s[i] } else { 0.0 });
    // A tracked output's magnitude: |C_z|·s of the absolute states it sums (s itself without outputs).
    let s_z = qp.Cz.as_ref().map_or_else(|| s.clone(), |Cz| Cz.abs() * &s);
    let s_ref = DVector::from_fn(N * nz, |i, _| s_z[i % nz]);

    // The maps to u₀: M from the estimate (x, d), Mr from the stacked references (also the predicted
    // states' map in the sweeps), Mf from f.
    let nv = qp.Nc * nu;
    let mut Fxd = DMatrix::zeros(nv, na);
    Fxd.view_mut((0, 0), (nv, nx)).copy_from(&qp.Fx);
    if nd > 0 {
        Fxd.view_mut((0, nx), (nv, nd)).copy_from(&qp.Fd);
    }
    let M = first_rows_of_solve(&qp.H, &Fxd, nu);
    let Mr = first_rows_of_solve(&qp.H, &qp.Fr, nu);

    let reference = Mr.abs() * &s_ref;
    let gradient = match emission {
        Emission::Unrolled => {
            let Mf = first_rows_of_solve(&qp.H, &DMatrix::identity(nv, nv), nu);
            Mf.abs() * (qp.Fx.abs() * &s + qp.Fr.abs() * &s_ref)
        }
        _ => {
            let G = (emission == Emission::MatrixFree).then_some(&p.G);
            let step = row_roundings(&p.F, G, &s, num);
            let mut dx = DVector::zeros(nx);
            let mut stacked = DVector::zeros(N * nx);
            for k in 0..N {
                dx = p.F.abs() * dx + &step;
                stacked.rows_mut(k * nx, nx).copy_from(&dx);
            }
            // The predicted states reach f through 2 Suᵀ Q_blk: Fr itself without outputs.
            let states_map = if qp.Cz.is_some() {
                let Q_blk = crate::lower::block_diagonal(N, &qp.Q, &qp.Qf);
                first_rows_of_solve(&qp.H, &(qp.Su.transpose() * Q_blk * 2.0), nu)
            } else {
                Mr.clone()
            };
            states_map.abs() * stacked
        }
    };
    // Without a filter the measured state is read as stored, and nothing persists.
    let (predict, measured) = match &p.filter {
        Some(f) => (
            row_roundings(&f.Fa, Some(&f.Ga), &s_a, num),
            f.Ca.abs() * &s_a + row_roundings(&f.Ca, None, &s_a, num),
        ),
        None => (DVector::zeros(na), DVector::zeros(p.ny)),
    };
    Injections {
        states,
        predict,
        measured,
        update: s_a,
        reference,
        gradient,
        M,
    }
}

/// The loop an estimate error follows with the readings fixed: (I − K∞C)(F − G·M) when it is stable,
/// else the estimation error dynamics (I − K∞C)F.
pub fn error_loop(
    f: &crate::lower::problem::Filter,
    p: &Problem,
    M: &DMatrix<f64>,
) -> DMatrix<f64> {
    let na = p.nx + f.nd;
    let I_KC = DMatrix::identity(na, na) - &f.K_inf * &f.Ca;
    let own = &I_KC * (&f.Fa - &f.Ga * M);
    if crate::linalg::spectral_radius(&own) < 1.0 {
        own
    } else {
        I_KC * &f.Fa
    }
}

/// The range of `p` for the gradient form `emission`, at `accuracy` (a fraction of the smallest span).
pub fn coordinate_range(p: &Problem, emission: Emission, accuracy: f64) -> CoordinateRange {
    let (nu, na) = (p.nu, p.nx + p.nd());
    let inj = injections(p, emission);
    // Without a filter the measured state's rounding reaches u₀ once, through M, and nothing persists:
    // the sums below stop after their first term (A = 0).
    let (K, I_KC, A, into_filter) = match &p.filter {
        Some(f) => {
            let I_KC = DMatrix::identity(na, na) - &f.K_inf * &f.Ca;
            let into_filter = &I_KC * &f.Ga;
            (f.K_inf.clone(), I_KC, error_loop(f, p, &inj.M), into_filter)
        }
        None => (
            DMatrix::zeros(na, p.ny),
            DMatrix::zeros(na, na),
            DMatrix::zeros(na, na),
            DMatrix::zeros(na, nu),
        ),
    };
    let K = &K;
    // Σⱼ |M·Aʲ·B| for each injection's input matrix B; a command error is u₀'s own (I) and then enters
    // the predict through G.
    let (mut S_upd, mut S_pred, mut S_meas, mut S_cmd) = (
        DMatrix::zeros(nu, na),
        DMatrix::zeros(nu, na),
        DMatrix::zeros(nu, p.ny),
        DMatrix::identity(nu, nu),
    );
    let mut T = inj.M.clone();
    let per_step = (nu * na * (2 * na + p.ny + nu)) as f64;
    let steps = (BUDGET / per_step).clamp(1.0, 1e6) as usize;
    let mut weight = 1.0;
    for step in 0..=steps {
        if step == steps {
            // Cut by the budget: the terms left shrink at most like ρʲ (first order in the tail).
            let rho = crate::linalg::spectral_radius(&A);
            weight = if rho < 1.0 {
                rho / (1.0 - rho)
            } else {
                f64::MAX
            };
        }
        S_upd += T.abs() * weight;
        S_pred += (&T * &I_KC).abs() * weight;
        S_meas += (&T * K).abs() * weight;
        S_cmd += (&T * &into_filter).abs() * weight;
        T = &T * &A;
        let tail = T.amax();
        if step == steps || tail.is_nan() || tail <= TAIL * S_upd.amax() {
            break;
        }
    }
    let filter = &S_upd * &inj.update + &S_pred * &inj.predict + &S_meas * &inj.measured;
    let total = &filter + &S_cmd * (&inj.reference + &inj.gradient);
    let g = total.amax();
    let command_accuracy = accuracy
        * p.qp
            .u_max
            .iter()
            .zip(p.qp.u_min.iter())
            .map(|(hi, lo)| hi - lo)
            .fold(f64::INFINITY, f64::min);
    let range = |scalar| command_accuracy / (unit_roundoff(scalar) * g);
    CoordinateRange {
        states: inj.states,
        accuracy,
        command_accuracy,
        sensitivity: Sensitivity {
            total: g,
            filter: filter.amax(),
            reference: (&S_cmd * &inj.reference).amax(),
            gradient: (&S_cmd * &inj.gradient).amax(),
        },
        f32: range(Scalar::F32),
        f64: range(Scalar::F64),
    }
}
