//! Lowering a spec to the condensed QP and the filter (paper eqs. 2, 3, 9-16), all in f64.
//!
//! Everything here depends only on the spec, never on measurements: it is what `mpc!` computes at
//! `cargo build` time and bakes into the emitted module, and what the generic solver runs with.
#![allow(non_snake_case)]

pub mod backoff;
pub mod constraints;
pub mod discretize;
pub mod problem;
pub mod structure;

use self::discretize::NotFinite;
use crate::linalg::{
    dense, extreme_eigenvalues, pseudo_inverse, restart_gains, steady_state_filter, symmetrize,
};
use crate::numeric::Numeric;
use crate::solver::constrained::InequalityQp;
use crate::solver::first_order::Parameters;
use mpc_spec::{
    Diagnostic, Diagnostics, FilterKind, Iterations, KalmanNoise, Matrix, ModelKind, Spec, Step,
    TimeDomain, MAX_ITERATIONS,
};
use nalgebra::{DMatrix, DVector};

pub use crate::lower::problem::{Filter, ModelLanes, Problem, Qp, Reach, Screening};

/// The restart table ends after the last reading for which K∞ instead of the time-varying gain would
/// add more than this fraction to a state's posterior variance, or S∞ would differ from the innovation
/// covariance by more ([`restart_gains`]).
pub const RESTART_TOLERANCE: f64 = 0.01;

/// The restart table's longest length, readings.
pub const RESTART_MAX: usize = 1000;

/// The model's lane structure, if F, G, Q, Qf and R all have it.
fn model_lanes(
    F: &DMatrix<f64>,
    G: &DMatrix<f64>,
    Q: &DMatrix<f64>,
    Qf: &DMatrix<f64>,
    R: &DMatrix<f64>,
) -> Option<ModelLanes> {
    let nu = G.ncols();
    if nu < 2 || !F.nrows().is_multiple_of(nu) {
        return None;
    }
    let k = |M: &DMatrix<f64>| crate::lower::structure::kronecker_identity(M, nu).ok();
    Some(ModelLanes {
        F: k(F)?,
        G: k(G)?,
        Q: k(Q)?,
        Qf: k(Qf)?,
        R: k(R)?,
    })
}

/// Computes the QP, its solver's parameters and the filter of `spec`. Fails, with located diagnostics,
/// when a weight or covariance is not (semi)definite, the step makes the iteration diverge, the filter has
/// no steady state, or a number does not exist in the emitted scalar type. The interior-point method's
/// count is not certified yet ([`crate::lower()`] does it): `iterations = "auto"` is 0 here.
pub fn uncertified(spec: &Spec) -> Result<Problem, Diagnostics> {
    crate::certify::budget::before_lowering(spec)?;
    crate::certify::budget::before_constraints(spec)?;
    let mut diags = Diagnostics::default();
    let dt = spec.model.dt;
    if let ModelKind::DoubleIntegrator { .. } = spec.model.kind {
        check_dt(spec)?;
    }
    let (F, G, C) = plant(&spec.model.kind, dt)
        .map_err(|e| not_sampled(spec, "the zero-order-hold sampling e^{A·dt}", e))?;
    let (nx, nu) = (F.nrows(), G.ncols());
    // Without a filter the controller is given the state: the measurement is x itself.
    let C = if spec.kalman.is_some() {
        C
    } else {
        DMatrix::identity(nx, nx)
    };
    let ny = C.nrows();
    let m = &spec.mpc;
    let N = m.horizon;
    let weights = Weights::new(spec);
    weights.check(spec, &mut diags);
    let Weights {
        Cz,
        Q,
        Qf,
        Qr,
        Qfr,
        R,
        R_du,
    } = weights;
    if let ModelKind::Linear {
        a,
        b,
        time: TimeDomain::Continuous,
        ..
    } = &spec.model.kind
    {
        check_sampling(spec, a, b, &F, &G)?;
    }
    if !spec.mpc.constraints.is_empty() {
        check_rows_admit_a_stage(spec, &spec.mpc.constraints, false)?;
    }
    if let ModelKind::Linear { .. } = spec.model.kind {
        check_inputs_act(&G, spec.spans.get("model.b"), &mut diags);
        // A model whose powers overflow over the horizon is reported as that, not by the rank tests it
        // defeats.
        if check_growth(&F, &G, N, spec.spans.get("model.a"), &mut diags) {
            check_stabilizable(&F, &G, spec.spans.get("model.b"), &mut diags);
            if spec.kalman.is_some() {
                check_detectable(&F, &C, spec.spans.get("model.c"), &mut diags);
            }
        }
    }
    if !diags.is_empty() {
        return Err(diags.sorted());
    }
    let (Qf, Qfr) = if m.qf_lqr {
        let P = riccati_terminal(spec, &F, &G, &Q, &R, &R_du)?;
        let Qfr = match &Cz {
            Some(Cz) => &P * pseudo_inverse(Cz),
            None => P.clone(),
        };
        (P, Qfr)
    } else {
        (Qf, Qfr)
    };
    let condensed = condense(&F, &G, &Q, &R, &Qf, N);
    let Fr = condensed.reference_map(&Qr, &Qfr);
    let (H, Fu) = condensed.with_moves(&R_du);
    let (Sx, Su_full, Fx) = (condensed.Sx, condensed.Su, condensed.Fx);
    // A control horizon substitutes U = T·V (T the blocking matrix) into every term: the QP's variables
    // are the Nc free inputs.
    let Nc = m.control_horizon();
    let T = blocking(&m.blocks, nu);
    let Tt = T.transpose();
    let (H, Fu, Fx, Fr, Su) = if Nc < N {
        (
            symmetrize(&(&Tt * &H * &T)),
            &Tt * Fu,
            &Tt * Fx,
            &Tt * Fr,
            &Su_full * &T,
        )
    } else {
        (H, Fu, Fx, Fr, Su_full.clone())
    };
    // H out of range (or not finite) is the weights' doing: named before its eigenvalues, which it defeats.
    let hessian = Hessian {
        Su: &Su,
        Q: &Q,
        R: &R,
        R_du: &R_du,
        Qf: &Qf,
    };
    let scalar = Numeric(spec.codegen.scalar);
    if let Some(mut d) = out_of_range("the Hessian H", &H, scalar, None) {
        d.span = hessian.key(spec, scalar);
        return Err(d.into());
    }
    let (mu, L) = extreme_eigenvalues(&H);
    check_hessian(spec, &H, mu, L)?;
    check_soft_weights(spec, L)?;
    let (step, momentum, iterations) = solver_parameters(spec, mu, L, &mut diags);
    // `filter` reports why it is `None`, so `diags` is not empty then.
    let filter = match &spec.kalman {
        Some(kalman) => filter(spec, kalman, &F, &G, &C, &mut diags),
        None => None,
    };
    if !diags.is_empty() || (spec.kalman.is_some() && filter.is_none()) {
        return Err(diags.sorted());
    }
    let nd = filter.as_ref().map_or(0, |f| f.nd);
    let Fd = &H * DMatrix::from_fn(Nc * nu, nd, |i, j| if i % nu == j { 1.0 } else { 0.0 })
        + Fu.columns(0, nd);
    // The back-offs pull the bounds in before anything reads them; "<z>sigma" measures the filter's
    // steady-state error.
    let P_state = filter
        .as_ref()
        .map(|f| f.P_inf.view((0, 0), (nx, nx)).into_owned());
    let (constraints, backoff) = crate::lower::backoff::tighten(spec, P_state.as_ref())?;
    if !backoff.is_empty() {
        check_rows_admit_a_stage(spec, &constraints, true)?;
    }
    // The rows are lowered on U and keep their N slots; their coefficients on U become ones on V.
    let mut rows = crate::lower::constraints::lower(&constraints, &Sx, &Su_full, nu);
    if Nc < N {
        let slacks = rows.A.columns(N * nu, rows.slacks()).into_owned();
        let mut A = DMatrix::zeros(rows.len(), Nc * nu + slacks.ncols());
        A.columns_mut(0, Nc * nu)
            .copy_from(&(rows.A.columns(0, N * nu) * &T));
        A.columns_mut(Nc * nu, slacks.ncols()).copy_from(&slacks);
        rows.A = A;
    }
    let bound = |v: &[f64], i: usize, absent: f64| v.get(i).copied().unwrap_or(absent);
    let x_bounds = (
        (0..nx)
            .map(|i| bound(&constraints.x_min, i, f64::NEG_INFINITY))
            .collect(),
        (0..nx)
            .map(|i| bound(&constraints.x_max, i, f64::INFINITY))
            .collect(),
    );
    let qp = Qp {
        x_bounds,
        N,
        Nc,
        blocks: m.blocks.clone(),
        iterations,
        tolerance: m.tolerance,
        method: m.method,
        restart: m.restart,
        nz: Qr.ncols(),
        Cz,
        Q,
        R,
        R_du,
        Qf,
        Qr,
        Qfr,
        Sx,
        Su,
        H,
        Fd,
        Fx,
        Fr,
        Fu,
        L,
        mu,
        step,
        momentum,
        u_min: DVector::from_column_slice(&m.u_min),
        u_max: DVector::from_column_slice(&m.u_max),
        rows,
        backoff,
        accuracy: m.accuracy,
        evidence: None,
    };
    check_ranges(spec, &qp, filter.as_ref(), &F, &G)?;
    // The lane sweeps know the state weights only: outputs and moves take the scalar ones.
    let model_lanes = (qp.Cz.is_none() && m.r_du.is_none() && Nc == N)
        .then(|| model_lanes(&F, &G, &qp.Q, &qp.Qf, &qp.R))
        .flatten();
    Ok(Problem {
        nx,
        nu,
        ny,
        dt,
        qp,
        filter,
        F,
        G,
        C,
        scalar: spec.codegen.scalar,
        model_lanes,
        requested: spec.mpc.method_requested,
        candidates: Vec::new(),
    })
}

/// The double integrator's `dt` must give a discrete model that f64 resolves. Per axis the model moves
/// the state through its reachability matrix W = [G, FG] = [[Δt²/2, 3Δt²/2], [Δt, Δt]], whose condition
/// number is about 2/Δt for a small Δt and 2.5·Δt for a large one. The condensed Hessian (SuᵀQSu, Su made
/// of the blocks FᵏG) and the Kalman filter's Riccati recursion (which accumulates FᵏG·GᵀFᵏᵀ through the
/// noise) both work with W's Gram matrix, of condition κ(W)²: when κ(W)²·ε ≥ 1 that matrix is singular in
/// f64 (a Δt² that underflows next to Δt, or that swamps it), the states are not told apart and the
/// recursion never settles. That bounds Δt to about (3e-8, 3e7) in the spec's units.
fn check_dt(spec: &Spec) -> Result<(), Diagnostics> {
    let dt = spec.model.dt;
    let Ok((F, G, _)) = plant(&ModelKind::DoubleIntegrator { axes: 1 }, dt) else {
        unreachable!("the double integrator is sampled in closed form")
    };
    let mut W = DMatrix::zeros(2, 2);
    W.set_column(0, &G.column(0));
    W.set_column(1, &(&F * &G).column(0));
    let at = spec.spans.get("model.dt");
    let hint =
        "hint: write `dt` in seconds, the sampling time of the controller (the paper's is 0.0128)";
    if !W.iter().all(|v| v.is_finite()) {
        return Err(Diagnostic::new(
            format!(
                "`model.dt` = {} is too large for f64: the discrete model's Δt²/2 = {:e} overflows",
                short(dt),
                dt * dt / 2.0
            ),
            at,
        )
        .label("the model's input matrix G = [Δt²/2; Δt] is not finite")
        .note(hint)
        .into());
    }
    let sv = W.singular_values();
    let kappa = sv.max() / sv.min();
    if kappa.is_finite() && kappa * kappa * f64::EPSILON < 1.0 {
        return Ok(());
    }
    let what = if dt < 1.0 { "small" } else { "large" };
    Err(Diagnostic::new(
        format!(
            "`model.dt` = {} is too {what} for f64: the discrete model's reachability matrix [G, FG] has condition number {kappa:.3e}, and its Gram matrix, which the Hessian and the Kalman filter work with, κ² ≥ 1/ε = {:.3e}",
            short(dt),
            1.0 / f64::EPSILON
        ),
        at,
    )
    .label(format!(
        "Δt = {} and Δt²/2 = {} cannot both be resolved",
        short(dt),
        short(dt * dt / 2.0)
    ))
    .note(hint)
    .into())
}

/// A `linear` model's powers Fᵏ, k ≤ N, and the products with G that the prediction holds must stay
/// finite, and so must the Hessian's squares of them: ρ(F)^(2N)·max|G|² within f64's range (in logarithms,
/// so that nothing overflows here). Returns whether the model passed.
fn check_growth(
    F: &DMatrix<f64>,
    G: &DMatrix<f64>,
    N: usize,
    span: Option<mpc_spec::Span>,
    diags: &mut Diagnostics,
) -> bool {
    let Some(schur) = nalgebra::Schur::try_new(F.clone(), f64::EPSILON, 100_000) else {
        return true;
    };
    let rho = schur
        .complex_eigenvalues()
        .iter()
        .map(|c| c.norm())
        .fold(0.0, f64::max);
    let log_growth = 2.0 * (N as f64 * rho.ln() + G.amax().max(1.0).ln());
    if log_growth.is_nan() || log_growth < f64::MAX.ln() {
        return true;
    }
    diags.push(
        Diagnostic::new(
            format!(
                "`model.a` has a mode with |λ| = {rho:.3e}: over the horizon of {N} steps the prediction grows by |λ|^{N} ≈ 1e{:.0}, beyond f64's range",
                N as f64 * rho.log10()
            ),
            span,
        )
        .label("the powers of A in the condensed QP overflow")
        .note("hint: check the units and the entries of `a`; a sampled plant's modes are near 1, and a shorter horizon shrinks the growth"),
    );
    false
}

/// The parts of H = 2(Σₖ Su_kᵀ W_k Su_k + R_blk) (W_k = Q, and Qf at the last step), for naming the key
/// that makes H overflow.
struct Hessian<'a> {
    Su: &'a DMatrix<f64>,
    Q: &'a DMatrix<f64>,
    R: &'a DMatrix<f64>,
    R_du: &'a DMatrix<f64>,
    Qf: &'a DMatrix<f64>,
}

impl Hessian<'_> {
    /// The key to blame for an H beyond `scalar`'s range: `mpc.r` when 2R alone is; the terminal weight
    /// when its term 2·Su_Nᵀ Qf Su_N is and the stage terms are not; else the state weight `mpc.q`.
    fn key(&self, spec: &Spec, scalar: Numeric) -> Option<mpc_spec::Span> {
        let span = |key: &str| spec.spans.get(key);
        let beyond = |M: &DMatrix<f64>| {
            M.iter()
                .any(|v| !v.is_finite() || 2.0 * v.abs() > scalar.max())
        };
        if beyond(self.R) {
            return span("mpc.r");
        }
        // The moves' term 2DᵀR̄D holds 4·R_du on its diagonal.
        if beyond(&(self.R_du * 2.0)) {
            return span("mpc.r_du");
        }
        let nx = self.Q.nrows();
        let N = self.Su.nrows() / nx.max(1);
        if N > 0 {
            let last = self.Su.rows((N - 1) * nx, nx);
            let terminal = last.transpose() * self.Qf * last;
            let stage = (0..N).any(|k| {
                let rows = self.Su.rows(k * nx, nx);
                beyond(&(rows.transpose() * self.Q * rows))
            });
            if beyond(&terminal) && !stage {
                return span("mpc.qf").or(span("mpc.qf_scale")).or(span("mpc.q"));
            }
        }
        span("mpc.q").or(span("codegen.scalar"))
    }
}

/// `qf = "lqr"`: the terminal weight on x_N, the stabilizing solution of the discrete algebraic Riccati
/// equation of the plant (F, G) with the stage weights Q (on the state, C_zᵀWC_z with outputs) and R.
/// With move suppression (`r_du`) the stage cost is that of the plant augmented with the last input,
/// ξ = (x, u₋₁), input Δu: ξ⁺ = [[F, G], [0, I]] ξ + [G; I] Δu, cost xᵀQx + (u₋₁ + Δu)ᵀR(u₋₁ + Δu) +
/// ΔuᵀR_du Δu, that is Q_ξ = blkdiag(Q, R), cross term [0; R] and input weight R + R_du; its solution
/// P_ξ is the infinite-horizon cost of that problem, and the terminal weight is its state block P_xx
/// (the reduction: the cost-to-go of x_N with the last input's terms dropped, which the condensed QP,
/// whose terminal term weighs x_N alone, can hold).
pub fn riccati_terminal(
    spec: &Spec,
    F: &DMatrix<f64>,
    G: &DMatrix<f64>,
    Q: &DMatrix<f64>,
    R: &DMatrix<f64>,
    R_du: &DMatrix<f64>,
) -> Result<DMatrix<f64>, Diagnostics> {
    let (nx, nu) = (F.nrows(), G.ncols());
    let P = if spec.mpc.r_du.is_some() {
        let n = nx + nu;
        let mut A = DMatrix::zeros(n, n);
        A.view_mut((0, 0), (nx, nx)).copy_from(F);
        A.view_mut((0, nx), (nx, nu)).copy_from(G);
        A.view_mut((nx, nx), (nu, nu))
            .copy_from(&DMatrix::identity(nu, nu));
        let mut B = DMatrix::zeros(n, nu);
        B.view_mut((0, 0), (nx, nu)).copy_from(G);
        B.view_mut((nx, 0), (nu, nu))
            .copy_from(&DMatrix::identity(nu, nu));
        let mut Qa = DMatrix::zeros(n, n);
        Qa.view_mut((0, 0), (nx, nx)).copy_from(Q);
        Qa.view_mut((nx, nx), (nu, nu)).copy_from(R);
        let mut S = DMatrix::zeros(n, nu);
        S.view_mut((nx, 0), (nu, nu)).copy_from(R);
        crate::linalg::dare(&A, &B, &Qa, &(R + R_du), &S)
            .map(|P| symmetrize(&P.view((0, 0), (nx, nx)).into_owned()))
    } else {
        crate::linalg::dare(F, G, Q, R, &DMatrix::zeros(nx, nu))
    };
    P.filter(|P| P.iter().all(|v| v.is_finite()))
        .ok_or_else(|| {
            Diagnostic::new(
                "`qf = \"lqr\"`: the discrete algebraic Riccati equation has no stabilizing solution for this plant and these weights",
                spec.spans.get("mpc.qf"),
            )
            .label("the Riccati equation is solved here")
            .note("hint: every unstable mode must be reachable by the inputs and seen by `q` (through `outputs`); or write `qf` as a number, a list or a matrix")
            .into()
        })
}

/// The weights in the state space, from the spec's output weights.
struct Weights {
    Cz: Option<DMatrix<f64>>,
    Q: DMatrix<f64>,
    Qf: DMatrix<f64>,
    Qr: DMatrix<f64>,
    Qfr: DMatrix<f64>,
    R: DMatrix<f64>,
    R_du: DMatrix<f64>,
}

impl Weights {
    /// Q = C_zᵀ W C_z and Qr = C_zᵀ W for the output weight W (C_z = I without outputs), likewise the
    /// terminal ones, or Qf on the state and Qfr = Qf·C_z⁺.
    fn new(spec: &Spec) -> Self {
        let m = &spec.mpc;
        let nu = spec.nu();
        let (W, Wf) = (symmetric(&m.q), symmetric(&m.qf));
        let R = symmetric(&m.r);
        let R_du = m
            .r_du
            .as_ref()
            .map_or_else(|| DMatrix::zeros(nu, nu), symmetric);
        let Some(Cz) = m.outputs.as_ref().map(dense) else {
            return Weights {
                Cz: None,
                Qr: W.clone(),
                Qfr: Wf.clone(),
                Q: W,
                Qf: Wf,
                R,
                R_du,
            };
        };
        let Q = symmetrize(&(Cz.transpose() * &W * &Cz));
        let Qr = Cz.transpose() * &W;
        let (Qf, Qfr) = if m.qf_on_state {
            let Qfr = &Wf * pseudo_inverse(&Cz);
            (Wf, Qfr)
        } else {
            (
                symmetrize(&(Cz.transpose() * &Wf * &Cz)),
                Cz.transpose() * &Wf,
            )
        };
        Weights {
            Cz: Some(Cz),
            Q,
            Qf,
            Qr,
            Qfr,
            R,
            R_du,
        }
    }

    /// The written weights must be positive semidefinite, R positive definite unless the moves are
    /// weighted (then H's definiteness is checked by [`check_hessian`]).
    fn check(&self, spec: &Spec, diags: &mut Diagnostics) {
        let span = |key: &str| spec.spans.get(key);
        let m = &spec.mpc;
        check_definite(diags, &symmetric(&m.q), false, "`mpc.q`", span("mpc.q"));
        // Qf = k·Q or Q is definite exactly when Q is: check it only when it is written.
        if span("mpc.qf").is_some() && !m.qf_lqr {
            check_definite(diags, &symmetric(&m.qf), false, "`mpc.qf`", span("mpc.qf"));
        }
        check_definite(diags, &self.R, m.r_du.is_none(), "`mpc.r`", span("mpc.r"));
        if m.r_du.is_some() {
            check_definite(diags, &self.R_du, false, "`mpc.r_du`", span("mpc.r_du"));
        }
    }
}

/// The condensed QP of eqs. 9-13 before the references and the moves: Sx, Su, the state and input terms
/// of H, 2(Suᵀ Q_blk Su + R_blk), and Fx = 2 Suᵀ Q_blk Sx.
struct Condensed {
    Sx: DMatrix<f64>,
    Su: DMatrix<f64>,
    H: DMatrix<f64>,
    Fx: DMatrix<f64>,
    N: usize,
}

fn condense(
    F: &DMatrix<f64>,
    G: &DMatrix<f64>,
    Q: &DMatrix<f64>,
    R: &DMatrix<f64>,
    Qf: &DMatrix<f64>,
    N: usize,
) -> Condensed {
    let (nx, nu) = (F.nrows(), G.ncols());
    let (Sx, Su) = prediction_matrices(F, G, N);
    let SuT_Q = Su.transpose() * block_diagonal(N, Q, Qf);
    let H = &SuT_Q * &Su * 2.0 + block_diagonal(N, R, R) * 2.0;
    let Fx = &SuT_Q * &Sx * 2.0;
    debug_assert_eq!(H.nrows(), N * nu);
    debug_assert_eq!(Sx.ncols(), nx);
    Condensed { Sx, Su, H, Fx, N }
}

impl Condensed {
    /// Fr = 2 Suᵀ Qr_blk (the terminal block Qfr).
    fn reference_map(&self, Qr: &DMatrix<f64>, Qfr: &DMatrix<f64>) -> DMatrix<f64> {
        self.Su.transpose() * block_diagonal(self.N, Qr, Qfr) * 2.0
    }

    /// H with the moves' term 2 Dᵀ R_du_blk D, symmetrized, and Fu = −2 Dᵀ R_du_blk E: Σ_k Δu_kᵀ R_du Δu_k
    /// with Δu_0 = u_0 − u_{−1} is (DU − E u_{−1})ᵀ R_du_blk (DU − E u_{−1}).
    fn with_moves(&self, R_du: &DMatrix<f64>) -> (DMatrix<f64>, DMatrix<f64>) {
        let nu = R_du.nrows();
        let n = self.N * nu;
        let D = DMatrix::from_fn(n, n, |i, j| {
            if i == j {
                1.0
            } else if i == j + nu {
                -1.0
            } else {
                0.0
            }
        });
        let R_blk = block_diagonal(self.N, R_du, R_du);
        let H = symmetrize(&(&self.H + D.transpose() * &R_blk * &D * 2.0));
        let Fu = -(D.transpose() * R_blk.columns(0, nu)) * 2.0;
        (H, Fu)
    }
}

/// The blocking matrix T of the move blocks ((N·nu) × (Nc·nu), N the sum of the block lengths, Nc their
/// number): U = T·V holds u_k = v_j for every step k of block j (the identity for N blocks of one).
pub fn blocking(blocks: &[usize], nu: usize) -> DMatrix<f64> {
    let N: usize = blocks.iter().sum();
    let mut T = DMatrix::zeros(N * nu, blocks.len() * nu);
    for (k, j) in block_of_step(blocks).enumerate() {
        for i in 0..nu {
            T[(k * nu + i, j * nu + i)] = 1.0;
        }
    }
    T
}

/// The block of each step, in order: block j repeated `blocks[j]` times.
pub fn block_of_step(blocks: &[usize]) -> impl Iterator<Item = usize> + '_ {
    blocks
        .iter()
        .enumerate()
        .flat_map(|(j, &n)| std::iter::repeat_n(j, n))
}

/// N blocks on the diagonal: `stage` N − 1 times, then `last`.
pub(crate) fn block_diagonal(N: usize, stage: &DMatrix<f64>, last: &DMatrix<f64>) -> DMatrix<f64> {
    let (r, c) = stage.shape();
    let mut out = DMatrix::zeros(N * r, N * c);
    for k in 0..N {
        let w = if k + 1 == N { last } else { stage };
        out.view_mut((k * r, k * c), (r, c)).copy_from(w);
    }
    out
}

/// The algorithm's step α, momentum β and iteration count for Hessian eigenvalues in [μ, L]; a step the
/// algorithm diverges with, or `iterations = "auto"` without a bound, is reported.
fn solver_parameters(spec: &Spec, mu: f64, L: f64, diags: &mut Diagnostics) -> (f64, f64, usize) {
    let m = &spec.mpc;
    let span = |key: &str| spec.spans.get(key);
    // The interior-point method has no step; its count is fixed or certified by sampling.
    let Some(algorithm) = crate::solver::algorithm(m.method) else {
        let fixed = match m.iterations {
            Iterations::Fixed(n) => n,
            Iterations::Auto => 0,
        };
        return (1.0 / L, 0.0, fixed);
    };
    let step = match m.step {
        Step::Auto => 1.0 / L,
        Step::Fixed(alpha) => alpha,
    };
    let parameters = Parameters {
        step,
        momentum: algorithm.momentum(step, mu),
        mu,
        L,
    };
    if let Some(why) = algorithm.step_too_large(&parameters) {
        diags.push(
            Diagnostic::new(
                format!(
                    "`mpc.step` = {} is too large: it must be {why}",
                    short(step)
                ),
                span("mpc.step"),
            )
            .label("step too large")
            .note("hint: write `step = \"auto\"` for 1/L"),
        );
    }
    let iterations = match (m.iterations, m.tolerance, algorithm.rate(&parameters)) {
        (Iterations::Fixed(n), _, _) => n,
        (Iterations::Auto, Some(_), Some(bound)) if bound.factor >= 1.0 => {
            diags.push(
                Diagnostic::new(
                    format!("`mpc.step` = {step:e} is too small: 1 − αμ rounds to 1, so no count of iterations guarantees a decrease"),
                    span("mpc.step"),
                )
                .label("step too small")
                .note(format!("hint: write `step = \"auto\"` for 1/L = {:.6}", 1.0 / L)),
            );
            0
        }
        (Iterations::Auto, Some(tol), Some(bound)) => {
            let needed = bound.iterations_for(tol);
            if needed > MAX_ITERATIONS {
                diags.push(
                    Diagnostic::new(
                        format!("`iterations = \"auto\"` would need {needed} iterations for `tolerance = {tol:e}`, above the limit of {MAX_ITERATIONS}"),
                        span("mpc.iterations"),
                    )
                    .label(format!("the a priori bound's factor per iteration is {:.9}", bound.factor))
                    .note("hint: the Hessian is ill-conditioned for this algorithm: loosen `tolerance`, shorten the horizon, raise R, or write a fixed count and accept a weaker guarantee"),
                );
            }
            needed.min(MAX_ITERATIONS)
        }
        (Iterations::Auto, _, None) => {
            diags.push(
                Diagnostic::new(
                    "`iterations = \"auto\"` needs a step with an a priori bound",
                    span("mpc.iterations"),
                )
                .label("no bound for this step")
                .note(format!(
                    "hint: the bounds hold for α ≤ 1/L = {:.6}; write `step = \"auto\"`",
                    1.0 / L
                )),
            );
            0
        }
        // `auto` without `tolerance` was reported by mpc-spec.
        (Iterations::Auto, None, _) => 0,
    };
    (step, parameters.momentum, iterations)
}

/// The filter of `[kalman]`, its covariances checked; `None` when its Riccati recursion has no steady
/// state (reported by the caller once the other findings are in).
fn filter(
    spec: &Spec,
    kalman: &mpc_spec::Kalman,
    F: &DMatrix<f64>,
    G: &DMatrix<f64>,
    C: &DMatrix<f64>,
    diags: &mut Diagnostics,
) -> Option<Filter> {
    let span = |key: &str| spec.spans.get(key);
    let (nx, nu, ny) = (F.nrows(), G.ncols(), C.nrows());
    let (Qn, Rn) = match &kalman.noise {
        KalmanNoise::WhiteAcceleration {
            sigma_a,
            sigma_meas,
        } => (
            white_acceleration_noise(nx / 2, spec.model.dt, *sigma_a),
            DMatrix::from_diagonal(&DVector::from_iterator(
                ny,
                sigma_meas.iter().map(|s| s * s),
            )),
        ),
        KalmanNoise::Covariances { q, r } => (process_covariance(spec, q, diags)?, symmetric(r)),
    };
    let P0 = symmetric(&kalman.p0);
    let nd = kalman.disturbance.as_ref().map_or(0, |_| nu);
    let (Fa, Ga, Ca, Qn, P0) = augment(F, G, C, &Qn, &P0, kalman.disturbance.as_deref());
    if nd > 0 && !disturbance_detectable(F, G, C) {
        diags.push(
            Diagnostic::new(
                "the disturbance is not detectable: rank [I − F, −G; C, 0] is below nx + nd",
                span("kalman.disturbance"),
            )
            .label("the measurements cannot tell this disturbance from the state")
            .note("hint: an input disturbance per input channel needs at least as many independent measurements as inputs"),
        );
    }
    // Numbers the emitted filter holds must exist in its scalar type, and must be checked before the
    // Riccati recursion runs on them (an overflowing P0 otherwise ends in "no steady state").
    let process = span("kalman.q").or(span("kalman.sigma_a"));
    let measurement = span("kalman.r").or(span("kalman.sigma_meas"));
    let scalar = Numeric(spec.codegen.scalar);
    let mut in_range = true;
    for (what, M, at) in [
        ("the process noise Q", &Qn, process.clone()),
        ("the measurement noise R", &Rn, measurement.clone()),
        (
            "the initial covariance P0",
            &P0,
            span("kalman.p0").or(span("kalman")),
        ),
    ] {
        if let Some(d) = out_of_range(what, M, scalar, at) {
            diags.push(d);
            in_range = false;
        }
    }
    if !in_range {
        return None;
    }
    check_definite(
        diags,
        &Qn,
        false,
        "the process noise covariance (`kalman.q`)",
        span("kalman.q").or(span("kalman.sigma_a")),
    );
    check_definite(
        diags,
        &Rn,
        true,
        "the measurement noise covariance (`kalman.r`)",
        span("kalman.r").or(span("kalman.sigma_meas")),
    );
    check_definite(
        diags,
        &P0,
        true,
        "`kalman.p0`",
        span("kalman.p0").or(span("kalman")),
    );
    if !diags.is_empty() {
        return None;
    }
    // The recursion converges geometrically only if the process noise reaches every mode on the unit circle
    // (with (F, C) detectable, the standard condition is (F, Q^½) stabilizable; a mode with |λ| > 1 the
    // noise misses still settles, one with |λ| = 1 only as 1/k): an integrator without noise would run the
    // recursion's million steps and end in "no steady state". Checked here, at the noise's key.
    if let Some(lambda) = unreachable_mode_where(&Fa, &psd_sqrt(&Qn), |r| (r - 1.0).abs() <= 1e-9) {
        let mode = format!("λ = {} (|λ| = {:.6})", complex(lambda), lambda.norm());
        let message = match &kalman.noise {
            KalmanNoise::WhiteAcceleration { sigma_a, .. } => format!(
                "`kalman.sigma_a` = {} is too small: the process noise it gives (σ_a² = {}) does not reach the mode {mode} in f64, so the Kalman filter has no steady state",
                short(*sigma_a),
                short(sigma_a * sigma_a)
            ),
            KalmanNoise::Covariances { .. } => format!(
                "the Kalman filter has no steady state: the process noise does not reach the mode {mode}, so the Riccati recursion settles only as 1/k"
            ),
        };
        diags.push(
            Diagnostic::new(message, process.or(span("kalman")))
                .label("rank [F − λI, Q^½] is below nx at this eigenvalue")
                .note("hint: every integrator or marginally stable mode needs process noise that reaches it (a nonzero `q` on it or on a state that drives it)"),
        );
        return None;
    }
    let Some((P_inf, K_inf)) = steady_state_filter(&Fa, &Ca, &Qn, &Rn, &P0) else {
        diags.push(
            Diagnostic::new("the Kalman filter has no steady state: the Riccati recursion does not converge", process.or(span("kalman")))
                .note("hint: the measured outputs must make the model detectable, and the process noise must reach every unstable mode"),
        );
        return None;
    };
    let P_pattern = crate::lower::structure::covariance_pattern(&Fa, &Ca, &Qn, &Rn, &P0);
    let S_inf_inv = (&Ca * &P_inf * Ca.transpose() + &Rn)
        .try_inverse()
        .unwrap_or_else(|| DMatrix::zeros(ny, ny));
    // C has full row rank or a dependent measurement: the pseudo-inverse serves both.
    let C_pinv = pseudo_inverse(C).resize_vertically(nx + nd, 0.0);
    let restart = match kalman.filter {
        FilterKind::SteadyState => restart_gains(
            (&Fa, &Ca),
            (&Qn, &Rn),
            &P0,
            (&K_inf, &P_inf),
            RESTART_TOLERANCE,
            RESTART_MAX,
        ),
        FilterKind::TimeVarying => Vec::new(),
    };
    Some(Filter {
        nd,
        Fa,
        Ga,
        Ca,
        Qn,
        Rn,
        P0,
        kind: kalman.filter,
        P_inf,
        K_inf,
        P_pattern,
        screening: Screening::resolve(&kalman.screening, ny),
        C_pinv,
        S_inf_inv,
        restart,
    })
}

/// Every number the emitter writes must exist in the emitted scalar type.
fn check_ranges(
    spec: &Spec,
    qp: &Qp,
    filter: Option<&Filter>,
    F: &DMatrix<f64>,
    G: &DMatrix<f64>,
) -> Result<(), Diagnostics> {
    let span = |key: &str| spec.spans.get(key);
    let nu = G.ncols();
    let (u_min, u_max) = (
        DMatrix::from_iterator(1, nu, qp.u_min.iter().copied()),
        DMatrix::from_iterator(1, nu, qp.u_max.iter().copied()),
    );
    let step_matrix = DMatrix::from_element(1, 1, qp.step);
    // Q, R and P0 were checked by `filter`, before its Riccati recursion; H by `lower`, before its eigenvalues.
    let mut emitted: Vec<(&str, &str, &DMatrix<f64>)> = vec![
        ("the lower input bounds", "mpc.u_min", &u_min),
        ("the upper input bounds", "mpc.u_max", &u_max),
        ("the step", "mpc.step", &step_matrix),
        ("the gradient map Fx", "mpc.q", &qp.Fx),
        ("the gradient map Fr", "mpc.q", &qp.Fr),
        ("the last input's map Fu", "mpc.r_du", &qp.Fu),
        ("the disturbance map Fd", "mpc.q", &qp.Fd),
        ("the model F", "model", F),
        ("the model G", "model", G),
    ];
    if let Some(filter) = filter {
        emitted.push(("the steady-state covariance P∞", "kalman", &filter.P_inf));
        emitted.push(("the steady-state gain K∞", "kalman", &filter.K_inf));
    }
    let scalar = Numeric(spec.codegen.scalar);
    let mut diags = Diagnostics::default();
    for (what, key, M) in emitted {
        if let Some(d) = out_of_range(what, M, scalar, span(key).or(span("codegen.scalar"))) {
            diags.push(d);
        }
    }
    // Bounds apart in f64 must stay apart in the emitted type, or the input is fixed.
    for i in 0..nu {
        let (lo, hi) = (scalar.round(qp.u_min[i]), scalar.round(qp.u_max[i]));
        if qp.u_min[i] < qp.u_max[i] && lo >= hi {
            diags.push(
                Diagnostic::new(
                    format!(
                        "input {i}'s bounds [{:e}, {:e}] are one value in {}: the input could not move",
                        qp.u_min[i],
                        qp.u_max[i],
                        scalar.name()
                    ),
                    span("mpc.u_min"),
                )
                .label("the lower bound rounds to the upper one")
                .note("hint: rescale the input's units, or write `scalar = \"f64\"` in `[codegen]`"),
            );
        }
    }
    if diags.is_empty() {
        Ok(())
    } else {
        Err(diags.sorted())
    }
}

/// F, G and the measurement matrix C of the model, discrete: a continuous-time `linear` model is sampled
/// with a zero-order hold over `dt` ([`crate::lower::discretize`]).
#[allow(clippy::type_complexity)]
pub fn plant(
    kind: &ModelKind,
    dt: f64,
) -> Result<(DMatrix<f64>, DMatrix<f64>, DMatrix<f64>), NotFinite> {
    match kind {
        ModelKind::DoubleIntegrator { axes } => {
            let n = *axes;
            // Eq. 2: x = [positions; velocities], F = [I dt·I; 0 I], G = [dt²/2·I; dt·I], C = [I 0].
            let mut F = DMatrix::identity(2 * n, 2 * n);
            let mut G = DMatrix::zeros(2 * n, n);
            let mut C = DMatrix::zeros(n, 2 * n);
            for i in 0..n {
                F[(i, n + i)] = dt;
                G[(i, i)] = 0.5 * dt * dt;
                G[(n + i, i)] = dt;
                C[(i, i)] = 1.0;
            }
            Ok((F, G, C))
        }
        ModelKind::Linear {
            a,
            b,
            c,
            time: TimeDomain::Discrete,
        } => Ok((dense(a), dense(b), dense(c))),
        ModelKind::Linear {
            a,
            b,
            c,
            time: TimeDomain::Continuous,
        } => {
            let (F, G) = discretize::zero_order_hold(&dense(a), &dense(b), dt)?;
            Ok((F, G, dense(c)))
        }
    }
}

/// The error for a continuous model that f64 cannot sample, at `model.a`.
fn not_sampled(spec: &Spec, what: &str, e: NotFinite) -> Diagnostic {
    let why = if e.norm_dt.is_finite() && e.norm_dt <= discretize::MAX_NORM_DT {
        "a mode grows past f64's range within one period (Re λ·dt ≳ 709 for the plant, half that for its covariance)".to_string()
    } else {
        format!(
            "the exponent is beyond the {:e} it is computed for",
            discretize::MAX_NORM_DT
        )
    };
    Diagnostic::new(
        format!(
            "{what} of the continuous-time model is not finite in f64: ‖A‖₁·dt = {:.3e}, and {why}",
            e.norm_dt
        ),
        spec.spans.get("model.a").or(spec.spans.get("model.dt")),
    )
    .label("sampled over `dt` as e^{A·dt}")
    .note("hint: check the units of `a` (per second) and of `dt` (seconds); `time = \"continuous\"` takes ẋ = A x + B u, a sampled model is `time = \"discrete\"`")
}

/// The discrete process covariance of `[kalman] q`: as written for a discrete model; for a continuous one
/// `q` is the spectral density Q_c of white noise on ẋ, sampled over `dt` by Van Loan's method. `None`
/// (reported) when f64 cannot sample it.
fn process_covariance(spec: &Spec, q: &Matrix, diags: &mut Diagnostics) -> Option<DMatrix<f64>> {
    match &spec.model.kind {
        ModelKind::Linear {
            a,
            time: TimeDomain::Continuous,
            ..
        } => match discretize::van_loan(&dense(a), &symmetric(q), spec.model.dt) {
            Ok(Q) => Some(Q),
            Err(e) => {
                diags.push(not_sampled(spec, "the Van Loan sampling of `kalman.q`", e));
                None
            }
        },
        _ => Some(symmetric(q)),
    }
}

/// Eq. 3 for `axes` independent axes, with the symmetric Δt³/2 off-diagonal blocks of the
/// white-noise-acceleration model (the paper prints Δt⁴/4 in the upper right block, a typo: Q must be symmetric).
pub fn white_acceleration_noise(axes: usize, dt: f64, sigma_a: f64) -> DMatrix<f64> {
    let s2 = sigma_a * sigma_a;
    let mut Q = DMatrix::zeros(2 * axes, 2 * axes);
    for i in 0..axes {
        let (p, v) = (i, axes + i);
        Q[(p, p)] = s2 * dt.powi(4) / 4.0;
        Q[(p, v)] = s2 * dt.powi(3) / 2.0;
        Q[(v, p)] = s2 * dt.powi(3) / 2.0;
        Q[(v, v)] = s2 * dt * dt;
    }
    Q
}

/// The filter's model augmented with a constant input disturbance per input channel (x⁺ = F x + G (u + d),
/// d⁺ = d + w_d, w_d ~ N(0, diag(σ_d²))), or the plain model when `sigma_d` is `None`.
#[allow(clippy::type_complexity)]
pub fn augment(
    F: &DMatrix<f64>,
    G: &DMatrix<f64>,
    C: &DMatrix<f64>,
    Qn: &DMatrix<f64>,
    P0: &DMatrix<f64>,
    sigma_d: Option<&[f64]>,
) -> (
    DMatrix<f64>,
    DMatrix<f64>,
    DMatrix<f64>,
    DMatrix<f64>,
    DMatrix<f64>,
) {
    let Some(sigma_d) = sigma_d else {
        return (F.clone(), G.clone(), C.clone(), Qn.clone(), P0.clone());
    };
    let (nx, nu, ny, nd) = (F.nrows(), G.ncols(), C.nrows(), sigma_d.len());
    let na = nx + nd;
    let mut Fa = DMatrix::identity(na, na);
    Fa.view_mut((0, 0), (nx, nx)).copy_from(F);
    Fa.view_mut((0, nx), (nx, nd)).copy_from(G);
    let mut Ga = DMatrix::zeros(na, nu);
    Ga.view_mut((0, 0), (nx, nu)).copy_from(G);
    let mut Ca = DMatrix::zeros(ny, na);
    Ca.view_mut((0, 0), (ny, nx)).copy_from(C);
    let mut Qa = DMatrix::zeros(na, na);
    Qa.view_mut((0, 0), (nx, nx)).copy_from(Qn);
    let mut Pa = DMatrix::identity(na, na);
    Pa.view_mut((0, 0), (nx, nx)).copy_from(P0);
    for (j, s) in sigma_d.iter().enumerate() {
        Qa[(nx + j, nx + j)] = s * s;
    }
    (Fa, Ga, Ca, Qa, Pa)
}

/// The standard condition for estimating an input disturbance alongside the state:
/// rank [I − F, −G; C, 0] = nx + nd (with (F, C) detectable, which the Riccati recursion checks).
pub fn disturbance_detectable(F: &DMatrix<f64>, G: &DMatrix<f64>, C: &DMatrix<f64>) -> bool {
    let (nx, nd, ny) = (F.nrows(), G.ncols(), C.nrows());
    let mut M = DMatrix::zeros(nx + ny, nx + nd);
    M.view_mut((0, 0), (nx, nx))
        .copy_from(&(DMatrix::identity(nx, nx) - F));
    M.view_mut((0, nx), (nx, nd)).copy_from(&(-G));
    M.view_mut((nx, 0), (ny, nx)).copy_from(C);
    let sv = M.singular_values();
    let tol = sv.max() * (nx + nd).max(nx + ny) as f64 * f64::EPSILON * 1e3;
    sv.iter().filter(|s| **s > tol).count() == nx + nd
}

/// Sx (eq. 12) and Su (eq. 13) for horizon N.
pub fn prediction_matrices(
    F: &DMatrix<f64>,
    G: &DMatrix<f64>,
    N: usize,
) -> (DMatrix<f64>, DMatrix<f64>) {
    let (nx, nu) = (F.nrows(), G.ncols());
    let mut Sx = DMatrix::zeros(N * nx, nx);
    // F^k G for k = 0..N-1
    let mut FkG = Vec::with_capacity(N);
    let mut Fk = DMatrix::identity(nx, nx);
    for k in 0..N {
        FkG.push(&Fk * G);
        Fk = F * Fk;
        Sx.view_mut((k * nx, 0), (nx, nx)).copy_from(&Fk);
    }
    let mut Su = DMatrix::zeros(N * nx, N * nu);
    for row in 0..N {
        for col in 0..=row {
            Su.view_mut((row * nx, col * nu), (nx, nu))
                .copy_from(&FkG[row - col]);
        }
    }
    (Sx, Su)
}

/// Q, Qf and the noise covariances must be positive semidefinite, R and P0 positive definite. The test
/// is on the matrix scaled to a unit diagonal, D^(-1/2)·M·D^(-1/2), so that no entry hides a negative
/// eigenvalue of another's scale (entries 1e12 and 1 in one matrix): a negative or, for definiteness,
/// zero diagonal fails at once, a zero diagonal needs a zero row, and the scaled eigenvalues are held to
/// n·ε-sized rounding.
fn check_definite(
    diags: &mut Diagnostics,
    M: &DMatrix<f64>,
    strict: bool,
    name: &str,
    span: Option<mpc_spec::Span>,
) {
    let what = if strict {
        "positive definite"
    } else {
        "positive semidefinite"
    };
    if let Some(why) = not_definite(M, strict) {
        let (lo, _) = extreme_eigenvalues(M);
        diags.push(
            Diagnostic::new(
                format!("{name} must be {what}; its smallest eigenvalue is {lo:.4}"),
                span,
            )
            .label(format!("not {what}: {why}")),
        );
    }
}

/// Why `M` is not positive (semi)definite, if it is not.
fn not_definite(M: &DMatrix<f64>, strict: bool) -> Option<String> {
    let n = M.nrows();
    let d = M.diagonal();
    if let Some(i) = (0..n).find(|&i| d[i] < 0.0 || (strict && d[i] <= 0.0) || !d[i].is_finite()) {
        return Some(format!("diagonal entry {i} is {}", d[i]));
    }
    for i in (0..n).filter(|&i| d[i] == 0.0) {
        if let Some(j) = (0..n).find(|&j| M[(i, j)] != 0.0) {
            return Some(format!(
                "entry ({i}, {j}) is {} where diagonal entry {i} is zero",
                M[(i, j)]
            ));
        }
    }
    let s = DVector::from_iterator(
        n,
        d.iter()
            .map(|v| if *v > 0.0 { 1.0 / v.sqrt() } else { 0.0 }),
    );
    let scaled = DMatrix::from_fn(n, n, |i, j| M[(i, j)] * s[i] * s[j]);
    let (lo, _) = extreme_eigenvalues(&scaled);
    let tol = 1e-12 * (n as f64);
    let bad = if strict { lo <= tol } else { lo < -tol };
    bad.then(|| format!("scaled to a unit diagonal, its smallest eigenvalue is {lo:.3e}"))
}

/// The symmetric square root of a positive semidefinite matrix (negative rounding eigenvalues as zero).
fn psd_sqrt(M: &DMatrix<f64>) -> DMatrix<f64> {
    let eig = nalgebra::SymmetricEigen::new(M.clone());
    let root = eig.eigenvalues.map(|l| l.max(0.0).sqrt());
    &eig.eigenvectors * DMatrix::from_diagonal(&root) * eig.eigenvectors.transpose()
}

/// A mode of F with |λ| ≥ 1 that G cannot reach, by the Popov-Belevitch-Hautus test: rank [F − λI, G] < n.
fn unreachable_mode(F: &DMatrix<f64>, G: &DMatrix<f64>) -> Option<nalgebra::Complex<f64>> {
    unreachable_mode_where(F, G, |r| r >= 1.0 - 1e-9)
}

/// A mode of F whose modulus satisfies `modulus` that G cannot reach (rank [F − λI, G] < n).
fn unreachable_mode_where(
    F: &DMatrix<f64>,
    G: &DMatrix<f64>,
    modulus: impl Fn(f64) -> bool,
) -> Option<nalgebra::Complex<f64>> {
    use nalgebra::Complex;
    let n = F.nrows();
    let schur = nalgebra::Schur::try_new(F.clone(), f64::EPSILON, 100_000)?;
    let scale = F.amax().max(G.amax()).max(1.0);
    schur.complex_eigenvalues().iter().copied().find(|lambda| {
        if !modulus(lambda.norm()) {
            return false;
        }
        let M = DMatrix::from_fn(n, n + G.ncols(), |i, j| {
            if j < n {
                Complex::new(F[(i, j)], 0.0)
                    - if i == j {
                        *lambda
                    } else {
                        Complex::new(0.0, 0.0)
                    }
            } else {
                Complex::new(G[(i, j - n)], 0.0)
            }
        });
        // nalgebra's SVD panics on a NaN singular value (an overflowing F): such a plant is refused by
        // the range checks, not here.
        if !M.iter().all(|z| z.re.is_finite() && z.im.is_finite()) {
            return false;
        }
        nalgebra::SVD::try_new(M, false, false, f64::EPSILON, 10_000).is_some_and(|svd| {
            let sv = &svd.singular_values;
            sv.iter().all(|s| s.is_finite())
                && sv.iter().fold(f64::INFINITY, |m, s| m.min(*s)) <= 1e-10 * scale
        })
    })
}

/// The plant must be stabilizable: every mode with |λ| ≥ 1 reachable from the inputs.
fn check_stabilizable(
    F: &DMatrix<f64>,
    G: &DMatrix<f64>,
    span: Option<mpc_spec::Span>,
    diags: &mut Diagnostics,
) {
    if let Some(lambda) = unreachable_mode(F, G) {
        diags.push(
            Diagnostic::new(
                format!(
                    "the plant is not stabilizable: its mode λ = {} (|λ| = {:.6}) cannot be moved by the inputs",
                    complex(lambda),
                    lambda.norm()
                ),
                span,
            )
            .label("rank [F − λI, G] is below nx at this eigenvalue")
            .note("hint: every unstable or marginally stable mode must be reachable from an input (check `b`, and that it is not all zero)"),
        );
    }
}

/// Every input must move the state: a zero column of B is an input the controller would push in vain
/// (B = 0 makes every input so, stable plant or not).
fn check_inputs_act(G: &DMatrix<f64>, span: Option<mpc_spec::Span>, diags: &mut Diagnostics) {
    if let Some(j) = (0..G.ncols()).find(|&j| G.column(j).iter().all(|v| *v == 0.0)) {
        diags.push(
            Diagnostic::new(
                format!("input {j} moves nothing: column {j} of `model.b` is zero"),
                span,
            )
            .label("every input needs a nonzero column in `b`")
            .note("hint: remove the input, or give it the states it acts on"),
        );
    }
}

/// The measurements must see every mode with |λ| ≥ 1 (detectability of (F, C): stabilizability of
/// (Fᵀ, Cᵀ)), or the filter cannot estimate it.
fn check_detectable(
    F: &DMatrix<f64>,
    C: &DMatrix<f64>,
    span: Option<mpc_spec::Span>,
    diags: &mut Diagnostics,
) {
    if let Some(lambda) = unreachable_mode(&F.transpose(), &C.transpose()) {
        diags.push(
            Diagnostic::new(
                format!(
                    "the plant is not detectable: the measurements cannot see its mode λ = {} (|λ| = {:.6})",
                    complex(lambda),
                    lambda.norm()
                ),
                span,
            )
            .label("rank [F − λI; C] is below nx at this eigenvalue")
            .note("hint: every unstable or marginally stable mode must show in an output (check `c`)"),
        );
    }
}

/// A number as written in a spec: plainly in [1e-4, 1e6), else in scientific notation.
fn short(v: f64) -> String {
    if v == 0.0 || (1e-4..1e6).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// `a`, or `a ± bi`.
fn complex(z: nalgebra::Complex<f64>) -> String {
    if z.im.abs() < 1e-12 {
        format!("{:.6}", z.re)
    } else {
        format!(
            "{:.6} {} {:.6}i",
            z.re,
            if z.im < 0.0 { "−" } else { "+" },
            z.im.abs()
        )
    }
}

/// A continuous model sampled at `dt` must keep what the inputs do: a `dt` so small (or so large) that
/// the sampled F and G lose the inputs' effect to f64's range or rounding (Δt² underflows beside Δt, say)
/// makes the sampled plant look unstabilizable, or an input look inert, when the continuous one is
/// neither. That is `dt`'s doing, told apart from `b`'s by sampling the same model at its own time scale,
/// 1/‖A‖∞ (1 for A = 0), where no mode aliases (|ω|·dt ≤ 1 < π).
fn check_sampling(
    spec: &Spec,
    a: &Matrix,
    b: &Matrix,
    F: &DMatrix<f64>,
    G: &DMatrix<f64>,
) -> Result<(), Diagnostics> {
    let inert = |G: &DMatrix<f64>| (0..G.ncols()).any(|j| G.column(j).iter().all(|v| *v == 0.0));
    let lost = |F: &DMatrix<f64>, G: &DMatrix<f64>| inert(G) || unreachable_mode(F, G).is_some();
    if !lost(F, G) {
        return Ok(());
    }
    let A = dense(a);
    let norm = A
        .row_iter()
        .map(|r| r.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    let own = if norm > 0.0 && norm.is_finite() {
        1.0 / norm
    } else {
        1.0
    };
    let Ok((F_own, G_own)) = discretize::zero_order_hold(&A, &dense(b), own) else {
        return Ok(());
    };
    if lost(&F_own, &G_own) {
        // The continuous model itself: `b`'s finding, reported by the checks that follow.
        return Ok(());
    }
    let dt = spec.model.dt;
    let way = if dt < own { "small" } else { "large" };
    Err(Diagnostic::new(
        format!(
            "`model.dt` = {} is too {way} to sample the continuous model in f64: the sampled plant loses what the inputs do",
            short(dt)
        ),
        spec.spans.get("model.dt"),
    )
    .label(format!(
        "the model's own time scale, 1/‖A‖∞, is {}",
        short(own)
    ))
    .note("hint: at this `dt` the zero-order hold's G = ∫e^{A·s}ds·B underflows or rounds away beside F (the sampled plant looks unstabilizable, though the continuous one is not); write `dt` in seconds, the controller's sampling period")
    .into())
}

/// The hard rows must admit a stage at all: the rows of the hard `[[mpc.constraint]]` groups with `ax`
/// alone, and the hard state bounds, on one state x_k (k = 1 … N); the rows with an `au` within the
/// input box on (x_k, u_k), any state; and, for N ≥ 2, both on the same x_k (k = 1 … N−1). A set that
/// is empty for every state makes every QP infeasible whatever the region, and it is the rows' doing:
/// the group where it first empties, in the order written, is refused (the earlier ones and the bounds
/// are what it contradicts). Each set is tested by the interior-point method on min ½‖(x, u)‖².
/// `backed_off`: `c` holds the back-offs' tightened bounds, and the error says so.
fn check_rows_admit_a_stage(
    spec: &Spec,
    c: &mpc_spec::Constraints,
    backed_off: bool,
) -> Result<(), Diagnostics> {
    let (nx, nu) = (spec.model.kind.nx(), spec.model.kind.nu());
    let n = nx + nu;
    let hard_x = c.x_soft.is_none();
    let z_min = DVector::from_fn(n, |i, _| match i {
        i if i < nx && hard_x => c.x_min.get(i).copied().unwrap_or(f64::NEG_INFINITY),
        i if i < nx => f64::NEG_INFINITY,
        i => spec.mpc.u_min[i - nx],
    });
    let z_max = DVector::from_fn(n, |i, _| match i {
        i if i < nx && hard_x => c.x_max.get(i).copied().unwrap_or(f64::INFINITY),
        i if i < nx => f64::INFINITY,
        i => spec.mpc.u_max[i - nx],
    });
    // Rows of (x, u) in the order written, each tagged with its group and whether it has an `au`.
    let mut rows: Vec<(usize, bool, Vec<f64>, f64, f64)> = Vec::new();
    // `free_state`: the rows with an `au` hold at k = 0 too, where x_0 is data (any state).
    let admits = |rows: &[(usize, bool, Vec<f64>, f64, f64)], free_state: bool| -> bool {
        let (mut lo, mut hi) = (z_min.clone(), z_max.clone());
        if free_state {
            for i in 0..nx {
                lo[i] = f64::NEG_INFINITY;
                hi[i] = f64::INFINITY;
            }
        }
        let qp = InequalityQp {
            H: DMatrix::identity(n, n),
            f: DVector::zeros(n),
            z_min: lo,
            z_max: hi,
            A: DMatrix::from_fn(rows.len(), n, |r, j| rows[r].2[j]),
            lower: DVector::from_iterator(rows.len(), rows.iter().map(|r| r.3)),
            upper: DVector::from_iterator(rows.len(), rows.iter().map(|r| r.4)),
        };
        crate::solver::ipm::solve(&qp, 1e-9, 200).status
            != crate::solver::constrained::Status::Infeasible
    };
    for (g, group) in c.rows.iter().enumerate() {
        if group.soft.is_some() {
            continue;
        }
        for i in 0..group.lower.len() {
            let row: Vec<f64> = (0..nx)
                .map(|j| group.ax.get(i, j))
                .chain((0..nu).map(|j| group.au.get(i, j)))
                .collect();
            let with_input = (0..nu).any(|j| group.au.get(i, j) != 0.0);
            rows.push((g, with_input, row, group.lower[i], group.upper[i]));
        }
        let state: Vec<_> = rows.iter().filter(|r| !r.1).cloned().collect();
        let input: Vec<_> = rows.iter().filter(|r| r.1).cloned().collect();
        let (empty, at) = if !admits(&state, false) {
            (
                true,
                "on the state x_k (k = 1 … N) with the hard state bounds",
            )
        } else if !input.is_empty() && !admits(&input, true) {
            (true, "on (x_k, u_k) within the input box, for any state")
        } else if spec.mpc.horizon >= 2 && !input.is_empty() && !admits(&rows, false) {
            (
                true,
                "jointly on x_k and (x_k, u_k) at the stages k = 1 … N−1 where both hold",
            )
        } else {
            (false, "")
        };
        if empty {
            let earlier = if g == 0 {
                "its own rows".to_string()
            } else {
                "its rows with the earlier groups'".to_string()
            };
            return Err(Diagnostic::new(
                format!("the hard rows of `mpc.constraint[{g}]` admit no state: no stage can meet {earlier} and the bounds"),
                spec.spans
                    .get(&format!("mpc.constraint[{g}]"))
                    .or(spec.spans.get("mpc.constraint")),
            )
            .label(format!("empty {at}"))
            .note(if backed_off {
                "hint: the bounds admit a stage, but not once `x_backoff` and the groups' `backoff` pull them in; shrink the back-off, or make the group soft (`soft = 1e3`)"
            } else {
                "hint: every QP would be infeasible, from any state; check the signs and bounds of `lower` and `upper` against the other rows and `x_min`/`x_max`, or make the group soft (`soft = 1e3`)"
            })
            .into());
        }
    }
    Ok(())
}

/// A soft weight must constrain something and stay solvable in f64: below ε·λmax(H) a violation costs
/// less than the rounding of the cost's curvature (the bounds do nothing: `x_soft = 1e-310`); above
/// λmax(H)/(ε·SOFT_QUADRATIC) the slack's curvature spans more than 1/ε beside H's, and the exact
/// reference cannot solve the QP (`x_soft = 1e300` looked like hard rows without a plan).
fn check_soft_weights(spec: &Spec, L: f64) -> Result<(), Diagnostics> {
    let c = &spec.mpc.constraints;
    let floor = f64::EPSILON * L;
    let ceiling = L / (f64::EPSILON * crate::lower::constraints::SOFT_QUADRATIC);
    let weights = c
        .x_soft
        .map(|w| ("mpc.x_soft".to_string(), w))
        .into_iter()
        .chain(
            c.rows
                .iter()
                .enumerate()
                .filter_map(|(g, r)| r.soft.map(|w| (format!("mpc.constraint[{g}].soft"), w))),
        );
    let mut diags = Diagnostics::default();
    for (key, w) in weights {
        let (what, label, hint) = if w < floor {
            (
                "too small to constrain anything",
                format!("below ε·λmax(H) = {floor:.3e}: a violation costs less than the cost's rounding"),
                "hint: a soft bound's weight should exceed the cost's multipliers on it (`scripts/check_constrained_specs.py` prints them; `specs/paper-limits.toml` uses 1e5); remove the bounds if they are not meant to hold",
            )
        } else if w > ceiling {
            (
                "too large to solve in f64",
                format!("its slack's curvature {:.3e} is past λmax(H)/ε = {:.3e}", crate::lower::constraints::SOFT_QUADRATIC * w, L / f64::EPSILON),
                "hint: a weight this large means the bound is hard: remove the soft weight, or write one a few orders of magnitude above the cost's multipliers (`specs/paper-limits.toml` uses 1e5)",
            )
        } else {
            continue;
        };
        diags.push(
            Diagnostic::new(format!("`{key}` = {w:e} is {what}"), spec.spans.get(&key))
                .label(label)
                .note(hint),
        );
    }
    if diags.is_empty() {
        Ok(())
    } else {
        Err(diags.sorted())
    }
}

/// H must be positive definite in floating point: R > 0 makes it so in exact arithmetic, but a condition
/// number near 1/ε leaves its smallest eigenvalue in the rounding, where no iteration count means anything.
fn check_hessian(spec: &Spec, H: &DMatrix<f64>, mu: f64, L: f64) -> Result<(), Diagnostics> {
    let kappa = L / mu;
    let factorizes = H.clone().cholesky().is_some();
    if mu > 0.0 && factorizes && kappa * f64::EPSILON < 1.0 && kappa.is_finite() {
        return Ok(());
    }
    Err(Diagnostic::new(
        format!(
            "the Hessian H is numerically singular: λmin(H) = {mu:.3e}, λmax(H) = {L:.3e}, condition number {kappa:.3e} (at least 1/ε = {:.3e} in f64)",
            1.0 / f64::EPSILON
        ),
        spec.spans.get("mpc.r"),
    )
    .label(if spec.mpc.r_du.is_some() {
        "the input and move weights are too small against the state weights to keep H invertible"
    } else {
        "the input weight is too small against the state weights to keep H invertible"
    })
    .note(if spec.mpc.r_du.is_some() && extreme_eigenvalues(&symmetric(&spec.mpc.r)).0 <= 0.0 {
        "hint: with `r = 0` the moves' weight `r_du` must reach every input; raise `r` or `r_du`, or lower `q`/`qf`"
    } else {
        "hint: raise `r` (or `r_du`) or lower `q`/`qf`, or shorten the horizon"
    })
    .into())
}

/// The error for a matrix with an entry that is not finite or beyond the emitted scalar type's range.
fn out_of_range(
    what: &str,
    M: &DMatrix<f64>,
    scalar: Numeric,
    span: Option<mpc_spec::Span>,
) -> Option<Diagnostic> {
    let worst = M.iter().fold(
        0.0_f64,
        |a, v| if v.is_nan() { f64::NAN } else { a.max(v.abs()) },
    );
    (!worst.is_finite() || worst > scalar.max()).then(|| {
        Diagnostic::new(
            format!(
                "{what} would overflow {}: its largest magnitude is {worst:e}",
                scalar.name()
            ),
            span,
        )
        .label("out of range for the emitted scalar type")
        .note("hint: rescale the weights or units, or write `scalar = \"f64\"` in `[codegen]`")
    })
}

/// A spec's symmetric matrix, exactly symmetric: (A + Aᵀ)/2 (the spec allows rounding-sized asymmetry).
fn symmetric(m: &Matrix) -> DMatrix<f64> {
    symmetrize(&dense(m))
}
