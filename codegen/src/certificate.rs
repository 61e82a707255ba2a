//! What the compiler proves about a controller, computed at compile time from the lowered problem:
//! the QP's conditioning and the solver's rates, an a priori iteration bound, the nominal stability of
//! the paper (Section 2.4.3) and of the MPC itself, and the emitted code's resources.
//!
//! # The a priori bound
//! With the gap Δ_k = J(U_k) − J* of the box-constrained QP and a step α ≤ 1/L:
//! - projected gradient (Algorithm 1): Δ_k ≤ (1 − αμ)^k · Δ_0 (the proximal-PL rate of Karimi, Nutini and
//!   Schmidt 2016, with 1/α ≥ L as the smoothness constant);
//! - fast gradient with constant momentum β = (1 − √(αμ))/(1 + √(αμ)): Δ_k ≤ 2(1 − √(αμ))^k · Δ_0
//!   (Nesterov's constant step scheme, Δ_k ≤ (1 − √(αμ))^k (Δ_0 + μ/2‖U_0 − U*‖²), and μ/2‖U_0 − U*‖² ≤ Δ_0
//!   by strong convexity at the constrained optimum).
//!
//! Both hold for any start inside the box, warm or cold. Steps above 1/L have no such bound (they may still
//! converge: see [`Certificate::contraction`]).
#![allow(non_snake_case)]

use crate::emit::tokens::Num;
use crate::lower::{extreme_eigenvalues, Problem};
use mpc_spec::{Diagnostic, Diagnostics, Emission, FilterKind, Iterations, Method, Spec};
use nalgebra::DMatrix;

/// The tolerance the report uses when the spec gives none.
pub const DEFAULT_TOLERANCE: f64 = 1e-4;

/// Above this many decision variables the solver's closed loop (an (nx + N·nu)-dimensional linear system
/// built by unrolling every iteration) is not formed at compile time.
pub const MAX_SOLVER_ANALYSIS_SIZE: usize = 300;

/// A bound Δ_k ≤ constant · factor^k · Δ_0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rate {
    /// The constant in front (1 for the gradient method, 2 for the fast gradient method).
    pub constant: f64,
    /// The factor per iteration.
    pub factor: f64,
}

impl Rate {
    /// The smallest k ≥ 1 with constant · factor^k ≤ tol.
    pub fn iterations_for(&self, tol: f64) -> usize {
        if self.factor <= 0.0 {
            return 1;
        }
        let k = ((tol / self.constant).ln() / self.factor.ln()).ceil();
        if k.is_finite() {
            k.max(1.0) as usize
        } else {
            usize::MAX
        }
    }

    /// What k iterations guarantee: Δ_k / Δ_0 ≤ this (capped at 1: no iteration makes the gap worse
    /// in these bounds' sense).
    pub fn guaranteed(&self, k: usize) -> f64 {
        (self.constant * self.factor.powf(k as f64)).min(1.0)
    }
}

/// The a priori rate of `method` with step α on a QP with Hessian eigenvalues in [μ, L]; `None` for α > 1/L.
pub fn a_priori_rate(method: Method, step: f64, mu: f64, L: f64) -> Option<Rate> {
    if step > (1.0 / L) * (1.0 + 1e-12) {
        return None;
    }
    let am = (step * mu).min(1.0);
    Some(match method {
        Method::Gradient => Rate {
            constant: 1.0,
            factor: 1.0 - am,
        },
        Method::Fgm => Rate {
            constant: 2.0,
            factor: 1.0 - am.sqrt(),
        },
    })
}

/// The paper's nominal stability check: an LQR gain from the stage weights and its closed loop.
#[derive(Clone, Debug)]
pub struct Lqr {
    /// K of the discrete algebraic Riccati equation with Q and R (nu × nx).
    pub gain: DMatrix<f64>,
    /// ρ(F − G·K).
    pub spectral_radius: f64,
    /// λmin of P solving (F − GK)ᵀ P (F − GK) − P = −I (NaN when the loop is unstable).
    pub lyapunov_min: f64,
    /// λmax of that P.
    pub lyapunov_max: f64,
}

/// The MPC's own closed loops, constraints inactive and references zero.
#[derive(Clone, Debug)]
pub struct MpcLoop {
    /// The unconstrained receding-horizon gain: the first block of H⁻¹·Fx, so u = −K·x (nu × nx).
    pub gain: DMatrix<f64>,
    /// ρ(F − G·K) for that gain: the loop an exactly solved MPC closes.
    pub spectral_radius: f64,
    /// ρ of the loop the fixed-iteration, warm-started solver actually closes, a linear system in the
    /// state and the previous plan; `None` for problems above [`MAX_SOLVER_ANALYSIS_SIZE`] decision variables.
    pub solver_spectral_radius: Option<f64>,
}

/// The emitted code's cost.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Resources {
    /// Multiply-adds of one solver iteration.
    pub macs_per_iteration: usize,
    /// Multiply-adds of one control cycle (filter update and predict, gradient map, every iteration).
    pub macs_per_cycle: usize,
    /// Bytes of the nonzero coefficients inlined into the code (±1 become additions and cost nothing).
    pub bytes_constants: usize,
    /// Bytes of `Mpc` (the plan).
    pub bytes_state_mpc: usize,
    /// Bytes of `Kalman` (the estimate, and the covariance for the time-varying filter).
    pub bytes_state_kalman: usize,
    /// Bytes of `Controller`: everything carried between control cycles.
    pub bytes_state: usize,
}

/// Everything the compiler proves and counts about one controller.
#[derive(Clone, Debug)]
pub struct Certificate {
    /// L = λmax(H).
    pub lipschitz: f64,
    /// μ = λmin(H).
    pub strong_convexity: f64,
    /// L/μ.
    pub condition_number: f64,
    /// The step α.
    pub step: f64,
    /// The momentum β (0 for the gradient method).
    pub momentum: f64,
    /// The asymptotic contraction of the error per iteration, constraints inactive: max over the
    /// eigenvalues λ of H of |1 − αλ| (gradient) or of the spectral radius of the 2 × 2 momentum
    /// recursion (fast gradient). Below 1 exactly when the iteration converges.
    pub contraction: f64,
    /// The iterations per control step.
    pub iterations: usize,
    /// The relative suboptimality of the bound (the spec's `tolerance`, or [`DEFAULT_TOLERANCE`]).
    pub tolerance: f64,
    /// The a priori rate, if the step has one.
    pub rate: Option<Rate>,
    /// The iterations the bound needs for `tolerance`.
    pub iterations_bound: Option<usize>,
    /// What `iterations` guarantee: Δ_m/Δ_0 ≤ this.
    pub guaranteed_gap: Option<f64>,
    /// The paper's LQR check.
    pub lqr: Lqr,
    /// The MPC's own loops.
    pub mpc: MpcLoop,
    /// Costs.
    pub resources: Resources,
    /// How the gradient is emitted.
    pub emission: Emission,
    /// The cost model's estimate of every emission choice ([`crate::cost`]).
    pub estimates: Vec<crate::cost::Estimate>,
    /// The disturbance estimate's time constant in seconds, with `[kalman] disturbance`: −Δt / ln ρ of the
    /// steady-state estimation error dynamics F_a(I − K∞C_a), whose slowest mode is the disturbance's.
    pub disturbance_time_constant: Option<f64>,
}

/// The rules that need the certificate: an unstable closed loop is an error unless the spec sets
/// `accept_unstable`; fixed iterations below what the spec's `tolerance` needs are a warning, or an error
/// with `strict`. Returns the warnings.
pub fn review(spec: &Spec, c: &Certificate) -> Result<Diagnostics, Diagnostics> {
    let (mut errors, mut warnings) = (Diagnostics::default(), Diagnostics::default());
    // One finding per cause: the solver's loop is only reported when the exactly solved MPC is stable.
    let unstable = |rho: f64| rho.is_nan() || rho >= 1.0;
    let mut loops = vec![(
        "the LQR loop of the stage weights, ρ(F − G·K_LQR),",
        c.lqr.spectral_radius,
    )];
    if unstable(c.mpc.spectral_radius) {
        loops.push((
            "the unconstrained MPC loop, ρ(F − G·K_MPC),",
            c.mpc.spectral_radius,
        ));
    } else if let Some(rho) = c.mpc.solver_spectral_radius {
        loops.push(("the loop of the fixed-iteration, warm-started solver", rho));
    }
    if !spec.mpc.accept_unstable {
        for (what, rho) in loops {
            if unstable(rho) {
                errors.push(
                    Diagnostic::new(
                        format!("the closed loop is not stable: {what} has spectral radius {rho:.6}"),
                        spec.spans.get("mpc"),
                    )
                    .label("controller defined here")
                    .note("hint: raise the weights, the horizon or the iterations, or set `accept_unstable = true` in `[mpc]` to build it anyway"),
                );
            }
        }
    }
    if let (Iterations::Fixed(m), Some(tol), Some(needed)) =
        (spec.mpc.iterations, spec.mpc.tolerance, c.iterations_bound)
    {
        if m < needed {
            let gap = c.guaranteed_gap.unwrap_or(1.0);
            let d = Diagnostic::new(
                format!("`iterations = {m}` is below the {needed} that guarantee `tolerance = {tol:e}`: the bound only guarantees (J(U_{m}) − J*)/(J(U_0) − J*) ≤ {gap:.3e}"),
                spec.spans.get("mpc.iterations"),
            )
            .label(format!("the a priori bound needs {needed}"))
            .note("hint: write `iterations = \"auto\"`, raise the count, or loosen `tolerance`");
            if spec.mpc.strict {
                errors.push(d);
            } else {
                warnings.push(d);
            }
        }
    }
    if errors.is_empty() {
        Ok(warnings)
    } else {
        Err(errors.sorted())
    }
}

/// Computes the certificate of a lowered problem.
pub fn certify(p: &Problem) -> Certificate {
    let qp = &p.qp;
    let rate = a_priori_rate(qp.method, qp.step, qp.mu, qp.L);
    let tolerance = qp.tolerance.unwrap_or(DEFAULT_TOLERANCE);
    let estimates = crate::cost::estimates(p);
    Certificate {
        lipschitz: qp.L,
        strong_convexity: qp.mu,
        condition_number: qp.L / qp.mu,
        step: qp.step,
        momentum: qp.momentum,
        contraction: contraction(p),
        iterations: qp.iterations,
        tolerance,
        rate,
        iterations_bound: rate.map(|r| r.iterations_for(tolerance)),
        guaranteed_gap: rate.map(|r| r.guaranteed(qp.iterations)),
        lqr: lqr(p),
        mpc: mpc_loop(p),
        resources: resources(p, &estimates),
        emission: p.emission,
        estimates,
        disturbance_time_constant: (p.filter.nd > 0).then(|| {
            let f = &p.filter;
            let na = p.nx + f.nd;
            let error = &f.Fa * (DMatrix::identity(na, na) - &f.K_inf * &f.Ca);
            -p.dt / spectral_radius(&error).ln()
        }),
    }
}

fn contraction(p: &Problem) -> f64 {
    let qp = &p.qp;
    let eig = nalgebra::SymmetricEigen::new(qp.H.clone()).eigenvalues;
    eig.iter()
        .map(|lambda| {
            let a = 1.0 - qp.step * lambda;
            match qp.method {
                Method::Gradient => a.abs(),
                Method::Fgm => {
                    let b = qp.momentum;
                    let M = DMatrix::from_row_slice(2, 2, &[(1.0 + b) * a, -b * a, 1.0, 0.0]);
                    spectral_radius(&M)
                }
            }
        })
        .fold(0.0, f64::max)
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

fn lqr(p: &Problem) -> Lqr {
    let nan = || Lqr {
        gain: DMatrix::from_element(p.nu, p.nx, f64::NAN),
        spectral_radius: f64::NAN,
        lyapunov_min: f64::NAN,
        lyapunov_max: f64::NAN,
    };
    let Some(K) = lqr_gain(&p.F, &p.G, &p.qp.Q, &p.qp.R) else {
        return nan();
    };
    let Fcl = &p.F - &p.G * &K;
    let rho = spectral_radius(&Fcl);
    let (lmin, lmax) =
        lyapunov_identity(&Fcl).map_or((f64::NAN, f64::NAN), |P| extreme_eigenvalues(&P));
    Lqr {
        gain: K,
        spectral_radius: rho,
        lyapunov_min: lmin,
        lyapunov_max: lmax,
    }
}

fn mpc_loop(p: &Problem) -> MpcLoop {
    let qp = &p.qp;
    let (nx, nu) = (p.nx, p.nu);
    let nz = qp.N * nu;
    let H_inv =
        qp.H.clone()
            .cholesky()
            .expect("H is positive definite")
            .inverse();
    let K = (&H_inv * &qp.Fx).rows(0, nu).into_owned();
    let spectral = spectral_radius(&(&p.F - &p.G * &K));
    let solver = (nz <= MAX_SOLVER_ANALYSIS_SIZE).then(|| {
        // The plan after m iterations is linear in z = [x; U_prev]: U_m = M·z. Build M by running the
        // solver on matrices (columns = unit directions of z), references zero and bounds inactive.
        let dim = nx + nz;
        let mut shift = DMatrix::zeros(nz, dim);
        for i in 0..nz - nu {
            shift[(i, nx + nu + i)] = 1.0;
        }
        let mut f = DMatrix::zeros(nz, dim);
        f.view_mut((0, 0), (nz, nx)).copy_from(&qp.Fx);
        let mut U = shift.clone();
        let mut Y = shift;
        for _ in 0..qp.iterations {
            let next = &Y - (&qp.H * &Y + &f) * qp.step;
            Y = match qp.method {
                Method::Gradient => next.clone(),
                Method::Fgm => &next + (&next - &U) * qp.momentum,
            };
            U = next;
        }
        let mut A = DMatrix::zeros(dim, dim);
        let x_next = &p.G * U.rows(0, nu);
        A.view_mut((0, 0), (nx, dim)).copy_from(&x_next);
        let F_block = A.view((0, 0), (nx, nx)) + &p.F;
        A.view_mut((0, 0), (nx, nx)).copy_from(&F_block);
        A.view_mut((nx, 0), (nz, dim)).copy_from(&U);
        spectral_radius(&A)
    });
    MpcLoop {
        gain: K,
        spectral_radius: spectral,
        solver_spectral_radius: solver,
    }
}

fn resources(p: &Problem, estimates: &[crate::cost::Estimate]) -> Resources {
    let num = Num(p.scalar);
    let nnz = |M: &DMatrix<f64>| num.nonzeros(M);
    let coefficients = |M: &DMatrix<f64>| {
        M.iter()
            .filter(|v| num.round(**v) != 0.0 && num.round(v.abs()) != 1.0)
            .count()
    };
    let qp = &p.qp;
    let f = &p.filter;
    // The filter works on (x, d): na = nx + nd states.
    let (na, ny) = (p.nx + f.nd, p.ny);
    let chosen = estimates
        .iter()
        .find(|e| e.emission == p.emission)
        .expect("the problem's emission is one of the estimated choices");
    let per_iteration = chosen.macs + crate::cost::update_macs(p);
    // f: unrolled over Fx, Fr and Fd, or one pass of the matrix-free sweeps (f = ∇J(0)).
    let (gradient_map, gradient_map_constants) = match p.emission {
        Emission::Unrolled => (
            nnz(&qp.Fx) + nnz(&qp.Fr) + nnz(&qp.Fd),
            coefficients(&qp.H)
                + coefficients(&qp.Fx)
                + coefficients(&qp.Fr)
                + coefficients(&qp.Fd),
        ),
        _ => {
            let sweep = estimates
                .iter()
                .find(|e| e.emission == Emission::MatrixFree)
                .map_or(0, |e| e.macs);
            let tables = chosen.table_bytes / num.bytes();
            let model = coefficients(&p.F)
                + coefficients(&p.G)
                + coefficients(&qp.Q)
                + coefficients(&qp.Qf)
                + coefficients(&qp.R);
            (sweep, tables + model)
        }
    };
    let (F, G, C) = (&f.Fa, &f.Ga, &f.Ca);
    let predict_state = nnz(&F.rows(0, p.nx).into_owned()) + nnz(G);
    let mut filter_constants = coefficients(F) + coefficients(G) + coefficients(C);
    let filter = match f.kind {
        FilterKind::SteadyState => {
            filter_constants += coefficients(&f.K_inf);
            predict_state + nnz(C) + nnz(&f.K_inf)
        }
        FilterKind::TimeVarying => {
            filter_constants += coefficients(&f.Qn) + coefficients(&f.Rn);
            // Every product over the entries that can be nonzero (the covariance's structural pattern),
            // as the emitter unrolls them: F·P·Fᵀ; P·Cᵀ, C·P·Cᵀ, the ny × ny inverse, K, the
            // correction, I − K·C, (I − KC)·P·(I − KC)ᵀ and K·R·Kᵀ.
            use crate::structure::{
                pattern, pattern_inverse, pattern_product as times, pattern_product_macs as macs,
            };
            let (P, Fp, Cp, Rp) = (&f.P_pattern, pattern(F), pattern(C), pattern(&f.Rn));
            let FP = times(&Fp, P);
            let PCt = times(P, &Cp.transpose());
            let S_inv = pattern_inverse(&times(&Cp, &PCt));
            let K = times(&PCt, &S_inv);
            let A = times(&K, &Cp);
            let AP = times(&A, P);
            let KR = times(&K, &Rp);
            let innovation = DMatrix::from_element(ny, 1, true);
            predict_state
                + macs(&Fp, P)
                + macs(&FP, &Fp.transpose())
                + macs(P, &Cp.transpose())
                + macs(&Cp, &PCt)
                + ny * ny * ny
                + macs(&PCt, &S_inv)
                + macs(&K, &innovation)
                + na * nnz(C)
                + macs(&A, P)
                + macs(&AP, &A.transpose())
                + macs(&K, &Rp)
                + macs(&KR, &K.transpose())
        }
    };
    let size = num.bytes();
    let bytes_state_mpc = qp.N * crate::cost::plan_lanes(p) * size;
    let bytes_state_kalman = match f.kind {
        FilterKind::SteadyState => na * size,
        FilterKind::TimeVarying => (na + na * na) * size,
    };
    Resources {
        macs_per_iteration: per_iteration,
        macs_per_cycle: qp.iterations * per_iteration + gradient_map + filter,
        bytes_constants: (gradient_map_constants + filter_constants) * size,
        bytes_state_mpc,
        bytes_state_kalman,
        bytes_state: bytes_state_mpc + bytes_state_kalman,
    }
}
