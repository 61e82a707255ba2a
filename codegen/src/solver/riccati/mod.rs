//! The Riccati form of the interior-point method's Newton system: the same iterates as the condensed
//! form of [`crate::solver::ipm`] (to rounding), the normal system solved stage by stage.
//!
//! With the states eliminated (x = Sx·x0 + Su·U), the normal system (H + Gᵀ·D·G)·ΔU = r of the condensed
//! method is the stationarity condition of an LQ problem over the stages: x_0 = 0,
//! x_{k+1} = A·x_k + B·u_k, minimise ½Σ_k (x_kᵀQ̃_k x_k + 2u_kᵀS̃_k x_k + u_kᵀR̃_k u_k) + ½x_NᵀQ̃_N x_N − rᵀU
//! with Q̃_k = 2Q + Σ w·ax·axᵀ (2Q_f at k = N), S̃_k = Σ w·au·axᵀ and R̃_k = 2R + D_box,k + Σ w·au·auᵀ over
//! the rows on stage k (a row's weight w the sum of its sides' λ/s). A backward Riccati recursion
//! factors it (per stage Re_k = R̃_k + BᵀP_{k+1}B, K_k = Re_k⁻¹(S̃_k + BᵀP_{k+1}A),
//! P_k = Q̃_k + AᵀP_{k+1}A − (S̃_k + BᵀP_{k+1}A)ᵀK_k), and a backward sweep of the linear term and a
//! forward rollout solve it, in O(N·(nx·nnz(A) + nx²·nu + …)) where the dense factorisation is
//! O((N·nu)³).
//!
//! The slacks of soft rows are shared by every stage, so they are not stage variables: with
//! z = (U, σ) the normal matrix is [M_uu M_uσ; M_σu M_σσ], M_uu in the Riccati form above, and the
//! slacks are eliminated by the Schur complement S = M_σσ − M_uσᵀ·M_uu⁻¹·M_uσ (one plan solve per slack
//! to form it, ns × ns).
//!
//! Built for the input box, state bounds and row groups (with or without `au`), hard or soft. Not
//! built, so that the condensed form is used ([`Stages::of`] says why): move bounds (a row on
//! u_k − u_{k−1}) and weighted moves (`r_du`): a stage would carry u_{k−1} as a state.
//!
//! The regularisation of a refused factorisation is the condensed one's, M + δ·I, which here is
//! R̃_k + δ·I at every stage and M_σσ + δ·I; δ is relative to the largest diagonal entry of the R̃_k
//! (the condensed form's: of M), so the two forms regularise alike but not identically.
#![allow(non_snake_case)]

pub mod emit;

use crate::lower::constraints::StageRow;
use crate::lower::problem::Qp;
use nalgebra::{DMatrix, DVector};

/// How a constrained method solves its linear system, condensed or stage by stage: the interior-point
/// method's normal system, ADMM's x-update ([`crate::solver::admm::Structure`]). The same iterates either way,
/// to rounding.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Form {
    /// On the condensed QP: L·D·Lᵀ of the normal matrix within its envelope, or ADMM's dense factor.
    Condensed,
    /// Stage by stage: the Riccati recursion ([`Stages`]), or ADMM's sweep with gains computed at
    /// build time.
    Riccati,
}

impl Form {
    /// Its name in `mpcc check`.
    pub fn name(self) -> &'static str {
        match self {
            Form::Condensed => "condensed",
            Form::Riccati => "riccati",
        }
    }
}

/// The cost model's choice of [`Form`], with both counts.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Choice {
    /// The form the method uses: the Riccati form where it is built for the problem and counts fewer
    /// multiply-adds per iteration.
    pub form: Form,
    /// Multiply-adds of one iteration in the condensed form.
    pub condensed_macs_per_iteration: usize,
    /// Multiply-adds of one iteration in the Riccati form; `None` where it is not built for the problem.
    pub riccati_macs_per_iteration: Option<usize>,
    /// Why the Riccati form is not built for the problem.
    pub riccati_unavailable: Option<String>,
}

impl Choice {
    /// The choice for `qp`.
    pub fn of(qp: &Qp) -> Self {
        let condensed = crate::solver::ipm::condensed::condensed_macs_per_iteration(qp);
        match Stages::of(qp) {
            Ok(stages) => {
                let riccati = stages.macs_per_iteration(qp);
                Choice {
                    form: if riccati < condensed {
                        Form::Riccati
                    } else {
                        Form::Condensed
                    },
                    condensed_macs_per_iteration: condensed,
                    riccati_macs_per_iteration: Some(riccati),
                    riccati_unavailable: None,
                }
            }
            Err(why) => Choice {
                form: Form::Condensed,
                condensed_macs_per_iteration: condensed,
                riccati_macs_per_iteration: None,
                riccati_unavailable: Some(why),
            },
        }
    }

    /// The chosen form's multiply-adds of one iteration.
    pub fn macs_per_iteration(&self) -> usize {
        match (self.form, self.riccati_macs_per_iteration) {
            (Form::Riccati, Some(m)) => m,
            _ => self.condensed_macs_per_iteration,
        }
    }
}

/// The stage-wise model of the condensed QP: the dynamics, the stage weights and the rows per slot.
#[derive(Clone, Debug)]
pub struct Stages {
    /// The horizon.
    pub N: usize,
    /// The dynamics x_{k+1} = A·x_k + B·u_k (nx × nx, nx × nu), the blocks of Sx and Su.
    pub A: DMatrix<f64>,
    /// See `A`.
    pub B: DMatrix<f64>,
    /// 2Q, the state Hessian of stages 1 … N−1.
    pub Q2: DMatrix<f64>,
    /// 2Q_f, the terminal state Hessian.
    pub Qf2: DMatrix<f64>,
    /// 2R, the input Hessian of every stage.
    pub R2: DMatrix<f64>,
    /// Each row of a slot on its stage's variables.
    pub rows: Vec<StageRow>,
    /// Each row of a slot's slack: (its index, the row's coefficient on it), `None` for a hard row.
    pub slack: Vec<Option<(usize, f64)>>,
    /// The slacks' quadratic weights q_σ (ns).
    pub slack_quadratic: DVector<f64>,
    /// The rows' coefficients on the plan U (m × N·nu), for the slacks' coupling.
    row_u: DMatrix<f64>,
}

/// The stage model must reproduce H and the rows to this, relative to their largest entry.
const REPRODUCED: f64 = 1e-10;

impl Stages {
    /// The stage model of `qp`, or why the Riccati form is not built for it.
    pub fn of(qp: &Qp) -> Result<Self, String> {
        let rows = &qp.rows;
        let mut not_built = Vec::new();
        if rows.stage.iter().any(Option::is_none) {
            not_built.push("move bounds couple u_k and u_{k−1}");
        }
        if qp.R_du.iter().any(|v| *v != 0.0) {
            not_built.push("`r_du` weights the moves, so a stage would carry u_{k−1} as a state");
        }
        if qp.blocked() {
            not_built.push("the move blocks hold one input over several stages");
        }
        if !not_built.is_empty() {
            return Err(format!("not built: {}", not_built.join("; ")));
        }
        let (nx, nu, N) = (qp.Sx.ncols(), qp.u_min.len(), qp.N);
        if N == 0 || qp.Sx.nrows() != N * nx || qp.Su.shape() != (N * nx, N * nu) {
            return Err("the prediction matrices are not stage-structured".into());
        }
        let stages = Stages {
            N,
            A: qp.Sx.rows(0, nx).into_owned(),
            B: qp.Su.view((0, 0), (nx, nu)).into_owned(),
            Q2: &qp.Q * 2.0,
            Qf2: &qp.Qf * 2.0,
            R2: &qp.R * 2.0,
            rows: rows.stage.iter().flatten().cloned().collect(),
            slack: (0..rows.per_slot)
                .map(|q| {
                    (0..rows.slacks())
                        .find(|&j| rows.A[(q, N * nu + j)] != 0.0)
                        .map(|j| (j, rows.A[(q, N * nu + j)]))
                })
                .collect(),
            slack_quadratic: rows.slack_quadratic.clone(),
            row_u: rows.A.columns(0, N * nu).into_owned(),
        };
        stages.reproduces(qp)?;
        Ok(stages)
    }

    fn nx(&self) -> usize {
        self.A.nrows()
    }

    fn nu(&self) -> usize {
        self.B.ncols()
    }

    /// Whether the model gives back H = 2(Σ_k Su_kᵀ Q_k Su_k + R_blk) and the rows' coefficients on U.
    fn reproduces(&self, qp: &Qp) -> Result<(), String> {
        let (nx, nu, N) = (self.nx(), self.nu(), self.N);
        let n = N * nu;
        let Su = |k: usize| qp.Su.rows((k - 1) * nx, nx);
        let mut H = DMatrix::zeros(n, n);
        for k in 1..=N {
            let Q = if k == N { &self.Qf2 } else { &self.Q2 };
            H += Su(k).transpose() * Q * Su(k);
        }
        for k in 0..N {
            let mut block = H.view_mut((k * nu, k * nu), (nu, nu));
            block += &self.R2;
        }
        let close = |a: &DMatrix<f64>, b: &DMatrix<f64>| {
            let scale = b.amax().max(f64::MIN_POSITIVE);
            (a - b).amax() <= REPRODUCED * scale
        };
        if !close(&H, &qp.H) {
            return Err("the stage weights do not reproduce the condensed Hessian".into());
        }
        let per_slot = qp.rows.per_slot;
        let m = qp.rows.len();
        if per_slot == 0 {
            return if m == 0 {
                Ok(())
            } else {
                Err("rows without slots".into())
            };
        }
        let mut A = DMatrix::zeros(m, n);
        for r in 0..m {
            let (j, row) = (r / per_slot, &self.rows[r % per_slot]);
            let k = j + row.lag;
            if k >= 1 {
                let on_U = row.ax.transpose() * Su(k);
                A.row_mut(r).copy_from(&on_U);
            }
            for c in 0..nu {
                A[(r, j * nu + c)] += row.au[c];
            }
        }
        if !close(&A, &qp.rows.A.columns(0, n).into_owned()) {
            return Err("the stage rows do not reproduce the condensed rows".into());
        }
        let ns = qp.rows.slacks();
        let slacks_reproduced = (0..m).all(|r| {
            (0..ns).all(|j| {
                let c = match self.slack[r % per_slot] {
                    Some((s, c)) if s == j => c,
                    _ => 0.0,
                };
                qp.rows.A[(r, n + j)] == c
            })
        });
        if !slacks_reproduced {
            return Err("the rows' slacks differ from slot to slot".into());
        }
        Ok(())
    }

    /// The stage Hessians for the weights `d` of the sides (box sides `boxed`, then row sides `rows`,
    /// as [`crate::solver::ipm::condensed::Layout`]) and the regularisation `delta` on every R̃_k:
    /// (Q̃_k for k = 0 … N, S̃_k and R̃_k for k = 0 … N−1).
    fn hessians(
        &self,
        boxed: &[(usize, f64)],
        rows: &[(usize, f64)],
        d: &DVector<f64>,
        delta: f64,
    ) -> StageHessians {
        let (nx, nu, N) = (self.nx(), self.nu(), self.N);
        let mut Q: Vec<DMatrix<f64>> = (0..=N)
            .map(|k| match k {
                0 => DMatrix::zeros(nx, nx),
                k if k == N => self.Qf2.clone(),
                _ => self.Q2.clone(),
            })
            .collect();
        let mut S = vec![DMatrix::zeros(nu, nx); N];
        let mut R: Vec<DMatrix<f64>> = (0..N)
            .map(|_| &self.R2 + DMatrix::identity(nu, nu) * delta)
            .collect();
        for (k, &(i, _)) in boxed.iter().enumerate() {
            // The slacks' floor σ ≥ 0 is the Schur complement's ([`Stages::factor`]).
            if i < N * nu {
                R[i / nu][(i % nu, i % nu)] += d[k];
            }
        }
        let per_slot = self.rows.len();
        for (side, &(r, _)) in rows.iter().enumerate() {
            let w = d[boxed.len() + side];
            let (j, row) = (r / per_slot, &self.rows[r % per_slot]);
            let k = j + row.lag;
            Q[k] += &row.ax * row.ax.transpose() * w;
            if row.lag == 0 {
                S[k] += &row.au * row.ax.transpose() * w;
                R[k] += &row.au * row.au.transpose() * w;
            }
        }
        StageHessians { Q, S, R }
    }

    /// The Riccati factor of H + Gᵀ·diag(d)·G + δ·I: `None` when a stage's Re_k is not positive
    /// definite (the normal matrix is not).
    pub fn factor(
        &self,
        boxed: &[(usize, f64)],
        rows: &[(usize, f64)],
        d: &DVector<f64>,
        delta: f64,
    ) -> Option<Factor> {
        let StageHessians { Q, S, R } = self.hessians(boxed, rows, d, delta);
        let (A, B, N) = (&self.A, &self.B, self.N);
        let mut P = Q[N].clone();
        let mut gains = vec![DMatrix::zeros(self.nu(), self.nx()); N];
        let mut pivots = Vec::with_capacity(N);
        for k in (0..N).rev() {
            let PB = &P * B;
            let Re = &R[k] + B.transpose() * &PB;
            let Se = &S[k] + PB.transpose() * A;
            let chol = Re.cholesky()?;
            let K = chol.solve(&Se);
            P = &Q[k] + A.transpose() * &P * A - Se.transpose() * &K;
            gains[k] = K;
            pivots.push(chol);
        }
        pivots.reverse();
        let mut f = Factor {
            A: A.clone(),
            B: B.clone(),
            gains,
            pivots,
            coupling: DMatrix::zeros(N * self.nu(), 0),
            schur: None,
        };
        let ns = self.slack_quadratic.len();
        if ns == 0 {
            return Some(f);
        }
        // The slacks' block and its coupling to the plan: M_σσ = diag(q_σ) + δ·I + the floor's and the
        // soft sides' weights, M_uσ = Σ_sides d·c·a_u (c the side's coefficient on its slack).
        let n = N * self.nu();
        let mut Mss = DMatrix::from_diagonal(&self.slack_quadratic.map(|q| q + delta));
        for (k, &(i, _)) in boxed.iter().enumerate() {
            if i >= n {
                Mss[(i - n, i - n)] += d[k];
            }
        }
        let mut Mus = DMatrix::zeros(n, ns);
        let per_slot = self.rows.len();
        for (side, &(r, _)) in rows.iter().enumerate() {
            if let Some((j, c)) = self.slack[r % per_slot] {
                let w = d[boxed.len() + side];
                Mss[(j, j)] += w * c * c;
                let mut col = Mus.column_mut(j);
                col += self.row_u.row(r).transpose() * (w * c);
            }
        }
        // Y = M_uu⁻¹·M_uσ, one Riccati solve per slack; S = M_σσ − M_uσᵀ·Y.
        let mut Y = DMatrix::zeros(n, ns);
        for j in 0..ns {
            Y.set_column(j, &f.solve_plan(&Mus.column(j).into_owned()));
        }
        let S = Mss - Mus.transpose() * &Y;
        f.schur = Some(S.cholesky()?);
        f.coupling = Y;
        Some(f)
    }

    /// The scale of the regularisation: 1 + the largest |diagonal entry| of the R̃_k for weights `d`.
    pub fn scale(&self, boxed: &[(usize, f64)], rows: &[(usize, f64)], d: &DVector<f64>) -> f64 {
        let h = self.hessians(boxed, rows, d, 0.0);
        1.0 + h
            .R
            .iter()
            .flat_map(|R| R.diagonal().iter().map(|v| v.abs()).collect::<Vec<_>>())
            .fold(0.0, f64::max)
    }

    /// Multiply-adds of one iteration in the Riccati form, by the rule of
    /// [`crate::solver::ipm::condensed::macs_per_iteration`]: the condensed form's residuals, right-hand sides,
    /// refinement and element-wise work, with the normal matrix's forming, factorisation and solves
    /// replaced by [`Stages::factor_macs`] and [`Stages::solve_macs`].
    pub fn macs_per_iteration(&self, qp: &Qp) -> usize {
        let c = crate::solver::ipm::condensed::mpc_counts(qp);
        let solves = 2 + crate::solver::ipm::condensed::REFINEMENT;
        c.residuals
            + self.factor_macs(qp)
            + solves * self.solve_macs()
            + (c.direction - c.solve) * 2
            + crate::solver::ipm::condensed::REFINEMENT * (c.refinement - c.solve)
            + c.elementwise
    }

    /// Multiply-adds of the cold start in the Riccati form (one factorisation, one direction).
    pub fn cold_start_macs(&self, qp: &Qp) -> usize {
        let c = crate::solver::ipm::condensed::mpc_counts(qp);
        c.residuals + self.factor_macs(qp) + c.direction - c.solve + self.solve_macs()
    }

    /// Nonzeros of A and B: the emitted recursion visits only them.
    pub fn nonzeros(&self) -> (usize, usize) {
        let nnz = |M: &DMatrix<f64>| M.iter().filter(|v| **v != 0.0).count();
        (nnz(&self.A), nnz(&self.B))
    }

    /// Multiply-adds of the emitted factorisation (`solver/riccati/emit.rs`): the stage Hessians (a
    /// weight per box side, nnz² per distinct row on its stage), then per stage k ≥ 1 P·A and Aᵀ(P·A)
    /// (nx·nnz(A) each), P·B (nx·nnz(B)), Bᵀ(P·B) (nu·nnz(B)), (P·B)ᵀA (nu·nnz(A)), L·D·Lᵀ of Re_k, the
    /// gain Re_k⁻¹·Se_k (nx·nu²) and Se_kᵀ·K_k (nx²·nu); stage 0 needs P·B, Re_0 and its L·D·Lᵀ only.
    pub fn factor_macs(&self, qp: &Qp) -> usize {
        let (nx, nu, N) = (self.nx(), self.nu(), self.N);
        let (a, b) = self.nonzeros();
        let (layout, sparsity) = crate::solver::ipm::condensed::mpc_structure(qp);
        let forming: usize = layout.boxed.len()
            + sparsity
                .rows
                .iter()
                .map(|&r| {
                    let row = &self.rows[r % self.rows.len()];
                    let n = row
                        .ax
                        .iter()
                        .chain(row.au.iter())
                        .filter(|v| **v != 0.0)
                        .count();
                    n * n
                })
                .sum::<usize>();
        let ldl = ldl_macs(nu);
        let stage = 2 * nx * a + nx * b + nu * b + nu * a + ldl + nx * nu * nu + nx * nx * nu;
        let first = nx * b + nu * b + ldl;
        // The slacks: per slack its sides' weights and Gᵀ of them (M_uσ's column), a plan solve (Y's
        // column); S = M_σσ − M_uσᵀ·Y and its L·D·Lᵀ.
        let ns = self.slack_quadratic.len();
        let g = crate::solver::ipm::condensed::mpc_counts(qp).g;
        let slacks = if ns == 0 {
            0
        } else {
            2 * layout.rows.len()
                + ns * (g + self.plan_solve_macs())
                + ns * ns * N * nu
                + ldl_macs(ns)
        };
        forming + (N - 1) * stage + first + slacks
    }

    /// Multiply-adds of one emitted solve: per stage Bᵀp, Aᵀp (the nonzeros), Kᵀe (nx·nu), Re⁻¹e
    /// (nu²), then K·x (nx·nu), A·x and B·u (the nonzeros); with slacks, their Schur complement's
    /// elimination.
    pub fn solve_macs(&self) -> usize {
        let ns = self.slack_quadratic.len();
        // With slacks: Yᵀ·r_u, S⁻¹(·) and Y·Δσ.
        self.plan_solve_macs() + 2 * ns * self.N * self.nu() + ns * ns
    }

    /// Multiply-adds of one solve with M_uu, on the plan.
    fn plan_solve_macs(&self) -> usize {
        let (nx, nu) = (self.nx(), self.nu());
        let (a, b) = self.nonzeros();
        self.N * (2 * a + 2 * b + 2 * nx * nu + nu * nu)
    }
}

/// Multiply-adds (and divisions) of the emitted L·D·Lᵀ of an n × n matrix: per column j, j products for
/// the pivot and j + 1 per later row.
pub fn ldl_macs(n: usize) -> usize {
    (0..n).map(|j| 2 * j + (n - 1 - j) * (j + 1)).sum()
}

/// The stage Hessians of [`Stages::hessians`].
struct StageHessians {
    Q: Vec<DMatrix<f64>>,
    S: Vec<DMatrix<f64>>,
    R: Vec<DMatrix<f64>>,
}

/// The Riccati factor: per stage the gain K_k = Re_k⁻¹·Se_k and Re_k's Cholesky factor; with slacks,
/// Y = M_uu⁻¹·M_uσ and the Cholesky factor of the Schur complement S = M_σσ − M_uσᵀ·Y.
#[derive(Clone, Debug)]
pub struct Factor {
    pub(crate) A: DMatrix<f64>,
    pub(crate) B: DMatrix<f64>,
    /// K_k per stage (nu × nx).
    pub(crate) gains: Vec<DMatrix<f64>>,
    /// Re_k's Cholesky factor per stage.
    pub(crate) pivots: Vec<nalgebra::Cholesky<f64, nalgebra::Dyn>>,
    /// Y = M_uu⁻¹·M_uσ (N·nu × ns).
    pub(crate) coupling: DMatrix<f64>,
    /// The Schur complement's Cholesky factor, with slacks.
    pub(crate) schur: Option<nalgebra::Cholesky<f64, nalgebra::Dyn>>,
}

impl Factor {
    /// The solution Δz = (ΔU, Δσ) of the normal system for the right-hand side r = (r_u, r_σ): with
    /// x = M_uu⁻¹·r_u ([`Factor::solve_plan`]), Δσ = S⁻¹·(r_σ − Yᵀ·r_u) and ΔU = x − Y·Δσ.
    pub fn solve(&self, r: &DVector<f64>) -> DVector<f64> {
        let n = self.coupling.nrows();
        let x = self.solve_plan(&r.rows(0, n).into_owned());
        let Some(schur) = &self.schur else {
            return x;
        };
        let ns = self.coupling.ncols();
        let ds = schur.solve(&(r.rows(n, ns) - self.coupling.tr_mul(&r.rows(0, n))));
        let du = x - &self.coupling * &ds;
        DVector::from_iterator(n + ns, du.iter().chain(ds.iter()).copied())
    }

    /// M_uu⁻¹·r for r on the plan (N·nu): a backward sweep of the cost-to-go's linear term p
    /// (e_k = Bᵀp_{k+1} − r_k, p_k = Aᵀp_{k+1} − K_kᵀe_k) and a forward rollout from x_0 = 0
    /// (u_k = −K_k·x_k − Re_k⁻¹e_k).
    pub fn solve_plan(&self, r: &DVector<f64>) -> DVector<f64> {
        let (nx, nu, N) = (self.A.nrows(), self.B.ncols(), self.gains.len());
        let mut p = DVector::zeros(nx);
        let mut e = vec![DVector::zeros(nu); N];
        for k in (0..N).rev() {
            let ek = self.B.tr_mul(&p) - r.rows(k * nu, nu);
            p = self.A.tr_mul(&p) - self.gains[k].tr_mul(&ek);
            e[k] = self.pivots[k].solve(&ek);
        }
        let mut x = DVector::zeros(nx);
        let mut u = DVector::zeros(N * nu);
        for (k, (K, ek)) in self.gains.iter().zip(&e).enumerate() {
            let uk = -(K * &x) - ek;
            x = &self.A * &x + &self.B * &uk;
            u.rows_mut(k * nu, nu).copy_from(&uk);
        }
        u
    }
}
