//! ADMM's x-update solved stage by stage (the Riccati structure of issue 18, item 2): the same x̃ and
//! z̃ = C·x̃ as the condensed form's two triangular solves with the factor of M = P + σI + CᵀRC and its
//! product with C, to rounding, in O(N·(nnz(A) + nnz(B) + nx·nu + nu²)) instead of O((N·nu)²).
//!
//! M is the normal matrix the interior-point method's Riccati form factors ([`Stages::factor`]) with
//! every row's weight its penalty ρ_i and the regularisation σ, so the factor is computed once, at build
//! time: per stage the gain K_k and Re_k's Cholesky factor, and with slacks Y = M_uu⁻¹·M_uσ and the Schur
//! complement's factor. One solve of M·x̃ = b with b = σx − q + Cᵀw (w = Rz − y) is then
//!
//! - the linear terms: r_j = b_j + Σ w·a_u over slot j's rows, g_k = Σ w·a_x over the rows on x_k (the
//!   rows' share of Cᵀw, which the condensed form multiplies through Su);
//! - a backward sweep p_N = −g_N, e_k = Bᵀp_{k+1} − r_k, d_k = Re_k⁻¹e_k, p_k = Aᵀp_{k+1} − K_kᵀe_k − g_k;
//! - a forward rollout from x_0 = 0: u_k = −K_k·x_k − d_k, x_{k+1} = A·x_k + B·u_k, each row evaluated on
//!   its stage's (x, u) as it passes (z̃'s rows without the condensed A·x̃);
//! - with slacks: σ̃ = S⁻¹(b_σ + Σ c·w − Σ ρ·c·v) (v the rows at the rollout, so Yᵀ·r is M_uσᵀ·U_p
//!   without the condensed right-hand side), U = U_p − Y·σ̃, and the rows v − (A_U·Y)·σ̃ + c·σ̃.
//!
//! The solve is built as a [`Program`]: a list of statements `slot = (base + Σ c·slot)·scale` over one
//! scratch array, in f64 here. [`Kernel`] runs it in the module's scalar and the emitter writes the same
//! statements out (or as tables), so that the emitted solver and the reference agree to the bit.
//!
//! Built where the interior-point method's Riccati form is ([`Stages::of`]: no move bounds, no `r_du`)
//! and for the direct form of the x-update; the residual form stays condensed.
#![allow(non_snake_case)]

use super::{Real, Settings};
use crate::lower::problem::Qp;
use crate::solver::riccati::Stages;
use nalgebra::DMatrix;

/// How ADMM solves its x-update: two triangular solves with the dense factor of the condensed M and C·x̃
/// through A's nonzeros ([`Structure::Condensed`]), or the stage-wise sweep of this module's [`Program`]
/// ([`Structure::Riccati`]). The same choice as the interior-point method's normal system, under one name.
pub use crate::solver::riccati::Form as Structure;

/// One statement: `slots[out] = (slots[base] + Σ c·slots[i]) · scale`, the terms added in order.
#[derive(Clone, Debug, PartialEq)]
pub struct Statement {
    /// The slot written.
    pub out: usize,
    /// The slot the sum starts from ([`ZERO_SLOT`] for 0).
    pub base: usize,
    /// (coefficient, slot), added left to right.
    pub terms: Vec<(f64, usize)>,
    /// A factor applied last (1/L_ii of a triangular solve).
    pub scale: Option<f64>,
}

/// The slot that is always 0.
pub const ZERO_SLOT: usize = 0;

/// The stage-wise x-update as straight-line statements over a scratch array of [`Program::slots`]
/// entries: the iterate's x, z, y and the data's q in, x̃ out at [`Program::x_at`] and z̃'s general rows
/// at [`Program::z_at`] (z̃'s box rows are x̃).
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    /// Scratch entries.
    pub slots: usize,
    /// Unknowns (N·nu + ns).
    pub nv: usize,
    /// General rows.
    pub m: usize,
    /// The first slot of x (nv).
    pub x_in: usize,
    /// The first slot of z (nv + m).
    pub z_in: usize,
    /// The first slot of y (nv + m).
    pub y_in: usize,
    /// The first slot of q (nv).
    pub q_in: usize,
    /// The first slot of x̃ (nv).
    pub x_at: usize,
    /// The first slot of z̃'s general rows (m).
    pub z_at: usize,
    /// The statements, in order.
    pub statements: Vec<Statement>,
}

impl Program {
    /// Multiply-adds of one run: a term each, and a multiplication per scale.
    pub fn macs(&self) -> usize {
        self.statements
            .iter()
            .map(|s| s.terms.len() + usize::from(s.scale.is_some()))
            .sum()
    }

    /// Terms over all statements.
    pub fn terms(&self) -> usize {
        self.statements.iter().map(|s| s.terms.len()).sum()
    }
}

/// Builds a [`Program`]: allocates slots and records statements, dropping terms on the zero slot and
/// exact-zero coefficients (both add an exact zero).
struct Builder {
    slots: usize,
    statements: Vec<Statement>,
}

impl Builder {
    fn alloc(&mut self, n: usize) -> usize {
        let at = self.slots;
        self.slots += n;
        at
    }

    /// A statement into a new slot; a sum with no terms and no scale is its base (no statement).
    fn value(&mut self, base: usize, terms: Vec<(f64, usize)>, scale: Option<f64>) -> usize {
        let terms: Vec<(f64, usize)> = terms
            .into_iter()
            .filter(|&(c, i)| c != 0.0 && i != ZERO_SLOT)
            .collect();
        if terms.is_empty() && scale.is_none() {
            return base;
        }
        let out = self.alloc(1);
        self.statements.push(Statement {
            out,
            base,
            terms,
            scale,
        });
        out
    }

    /// A statement into the given slot (always written).
    fn write(&mut self, out: usize, base: usize, terms: Vec<(f64, usize)>, scale: Option<f64>) {
        let terms = terms
            .into_iter()
            .filter(|&(c, i)| c != 0.0 && i != ZERO_SLOT)
            .collect();
        self.statements.push(Statement {
            out,
            base,
            terms,
            scale,
        });
    }

    /// L⁻ᵀL⁻¹·e for a lower Cholesky factor L, e in `e` (slots), the result in `out` (or new slots).
    fn cholesky_solve(&mut self, L: &DMatrix<f64>, e: &[usize], out: Option<usize>) -> Vec<usize> {
        let n = e.len();
        let mut y = vec![ZERO_SLOT; n];
        for i in 0..n {
            let terms = (0..i).map(|l| (-L[(i, l)], y[l])).collect();
            y[i] = self.value(e[i], terms, Some(1.0 / L[(i, i)]));
        }
        let mut x = vec![ZERO_SLOT; n];
        for i in (0..n).rev() {
            let terms = (i + 1..n).map(|l| (-L[(l, i)], x[l])).collect();
            match out {
                Some(at) => {
                    self.write(at + i, y[i], terms, Some(1.0 / L[(i, i)]));
                    x[i] = at + i;
                }
                None => x[i] = self.value(y[i], terms, Some(1.0 / L[(i, i)])),
            }
        }
        x
    }
}

/// The stage model and its factor, for building a [`Program`].
struct Sweep<'a> {
    stages: &'a Stages,
    factor: crate::solver::riccati::Factor,
    nx: usize,
    nu: usize,
    N: usize,
    per_slot: usize,
    m: usize,
    ns: usize,
    /// ρ of the general rows.
    rho_rows: nalgebra::DVector<f64>,
    /// A_U·Y (m × ns): the rows' share of the slacks' correction.
    row_coupling: DMatrix<f64>,
}

impl Sweep<'_> {
    /// ρ·c of a row with slack coefficient c: its share of M_uσ.
    fn rho_c(&self, row: usize, c: f64) -> f64 {
        self.rho_rows[row] * c
    }

    /// The states x_1 … x_N of the plan in `u` (slots, N·nu) rolled out from x_0 = 0 (slot per entry;
    /// element 0 is x_0, all zero).
    fn rollout(&self, b: &mut Builder, u: &[usize]) -> Vec<Vec<usize>> {
        let mut states = vec![vec![ZERO_SLOT; self.nx]];
        for k in 0..self.N {
            let next = self.next_state(b, &states[k], u, k);
            states.push(next);
        }
        states
    }

    /// x_{k+1} = A·x_k + B·u_k (slots) for the plan in `u`.
    fn next_state(&self, b: &mut Builder, x: &[usize], u: &[usize], k: usize) -> Vec<usize> {
        let (nx, nu) = (self.nx, self.nu);
        let (A, B) = (&self.factor.A, &self.factor.B);
        (0..nx)
            .map(|i| {
                let mut terms: Vec<(f64, usize)> = (0..nx).map(|l| (A[(i, l)], x[l])).collect();
                terms.extend((0..nu).map(|c| (B[(i, c)], u[k * nu + c])));
                b.value(ZERO_SLOT, terms, None)
            })
            .collect()
    }

    /// Row `q` of slot `j` on the states and the plan (its slack left out): ax·x_{j+lag} + au·u_j.
    fn row_terms(
        &self,
        states: &[Vec<usize>],
        u: &[usize],
        j: usize,
        q: usize,
    ) -> Vec<(f64, usize)> {
        let row = &self.stages.rows[q];
        let x = &states[j + row.lag];
        let mut terms: Vec<(f64, usize)> = (0..self.nx).map(|i| (row.ax[i], x[i])).collect();
        if row.lag == 0 {
            terms.extend((0..self.nu).map(|c| (row.au[c], u[j * self.nu + c])));
        }
        terms
    }

    /// M⁻¹·(rhs + the rows' Cᵀw + `state_terms`): `rhs` on the unknowns (N·nu, then ns), `w` on the
    /// rows (m), `state_terms[k][i]` more terms of the linear term on x_k (k = 1 … N). Returns the
    /// solution's slots (nv) and the rows at it (m, their slacks included), written into `out` = (x̃'s
    /// first slot, the rows' first slot) when given.
    fn solve(
        &self,
        b: &mut Builder,
        rhs: &[usize],
        w: &[usize],
        state_terms: &[Vec<Vec<(f64, usize)>>],
        out: Option<(usize, usize)>,
    ) -> Result<(Vec<usize>, Vec<usize>), String> {
        let (nx, nu, N, per_slot, m, ns) =
            (self.nx, self.nu, self.N, self.per_slot, self.m, self.ns);
        let np = N * nu;
        let rows = &self.stages.rows;
        let (A, B) = (&self.factor.A, &self.factor.B);
        // The linear terms: r_j on the inputs, g_k on the states (k = 1 … N; x_0 = 0 has none).
        let r: Vec<usize> = (0..np)
            .map(|i| {
                let (j, c) = (i / nu, i % nu);
                let terms = (0..per_slot)
                    .map(|q| (rows[q].au[c], w[j * per_slot + q]))
                    .collect();
                b.value(rhs[i], terms, None)
            })
            .collect();
        let mut g = vec![vec![ZERO_SLOT; nx]; N + 1];
        for (k, gk) in g.iter_mut().enumerate().skip(1) {
            for (i, gki) in gk.iter_mut().enumerate() {
                let mut terms: Vec<(f64, usize)> = (0..N)
                    .flat_map(|j| (0..per_slot).map(move |q| (j, q)))
                    .filter(|&(j, q)| j + rows[q].lag == k)
                    .map(|(j, q)| (rows[q].ax[i], w[j * per_slot + q]))
                    .collect();
                if let Some(more) = state_terms.get(k).and_then(|t| t.get(i)) {
                    terms.extend(more.iter().copied());
                }
                *gki = b.value(ZERO_SLOT, terms, None);
            }
        }
        // The backward sweep: d_k = Re_k⁻¹e_k for the rollout.
        let mut p: Vec<usize> = (0..nx)
            .map(|i| b.value(ZERO_SLOT, vec![(-1.0, g[N][i])], None))
            .collect();
        let mut d = vec![Vec::new(); N];
        for k in (0..N).rev() {
            let e: Vec<usize> = (0..nu)
                .map(|c| {
                    let mut terms: Vec<(f64, usize)> = (0..nx).map(|i| (B[(i, c)], p[i])).collect();
                    terms.push((-1.0, r[k * nu + c]));
                    b.value(ZERO_SLOT, terms, None)
                })
                .collect();
            d[k] = b.cholesky_solve(&self.factor.pivots[k].l(), &e, None);
            if k > 0 {
                let K = &self.factor.gains[k];
                p = (0..nx)
                    .map(|i| {
                        let mut terms: Vec<(f64, usize)> =
                            (0..nx).map(|l| (A[(l, i)], p[l])).collect();
                        terms.extend((0..nu).map(|c| (-K[(c, i)], e[c])));
                        terms.push((-1.0, g[k][i]));
                        b.value(ZERO_SLOT, terms, None)
                    })
                    .collect();
            }
        }
        // The forward rollout, each row evaluated on its stage as it passes. Without slacks the plan
        // and the rows are the solution's; with them, U_p and v before the slacks' correction.
        let (u_out, v_out) = match out {
            Some(at) if ns == 0 => at,
            _ => (b.alloc(np), b.alloc(m)),
        };
        let mut states = vec![vec![ZERO_SLOT; nx]];
        let u: Vec<usize> = (0..np).map(|i| u_out + i).collect();
        let lagged = rows.iter().any(|r| r.lag == 1);
        for k in 0..N {
            let K = &self.factor.gains[k];
            for c in 0..nu {
                let mut terms: Vec<(f64, usize)> =
                    (0..nx).map(|i| (-K[(c, i)], states[k][i])).collect();
                terms.push((-1.0, d[k][c]));
                b.write(u[k * nu + c], ZERO_SLOT, terms, None);
            }
            if k + 1 < N || lagged {
                let next = self.next_state(b, &states[k], &u, k);
                states.push(next);
            }
            for q in 0..per_slot {
                let terms = self.row_terms(&states, &u, k, q);
                b.write(v_out + k * per_slot + q, ZERO_SLOT, terms, None);
            }
        }
        if ns == 0 {
            return Ok((
                (0..np).map(|i| u_out + i).collect(),
                (0..m).map(|r| v_out + r).collect(),
            ));
        }
        // σ̃ = S⁻¹(r_σ + Σ c·w − Σ ρ·c·v), then U = U_p − Y·σ̃ and the rows v − (A_U·Y)·σ̃ + c·σ̃.
        let t: Vec<usize> = (0..ns)
            .map(|s| {
                let terms = (0..m)
                    .filter_map(|row| match self.stages.slack[row % per_slot] {
                        Some((j, c)) if j == s => {
                            Some([(c, w[row]), (-self.rho_c(row, c), v_out + row)])
                        }
                        _ => None,
                    })
                    .flatten()
                    .collect();
                b.value(rhs[np + s], terms, None)
            })
            .collect();
        let schur = self
            .factor
            .schur
            .as_ref()
            .ok_or("the slacks' Schur complement")?;
        let (x_out, z_out) = match out {
            Some(at) => at,
            None => (b.alloc(np + ns), b.alloc(m)),
        };
        let sigma = b.cholesky_solve(&schur.l(), &t, Some(x_out + np));
        let Y = &self.factor.coupling;
        for i in 0..np {
            let terms = (0..ns).map(|s| (-Y[(i, s)], sigma[s])).collect();
            b.write(x_out + i, u_out + i, terms, None);
        }
        for row in 0..m {
            let own = self.stages.slack[row % per_slot];
            let terms = (0..ns)
                .map(|s| {
                    let c = match own {
                        Some((j, c)) if j == s => c,
                        _ => 0.0,
                    };
                    (c - self.row_coupling[(row, s)], sigma[s])
                })
                .collect();
            b.write(z_out + row, v_out + row, terms, None);
        }
        Ok((
            (0..np + ns).map(|i| x_out + i).collect(),
            (0..m).map(|r| z_out + r).collect(),
        ))
    }
}

/// Why the stage-wise x-update is not built for `qp`, or its [`Program`] for `settings`.
pub fn program(qp: &Qp, settings: &Settings) -> Result<Program, String> {
    let stages = Stages::of(qp)?;
    let (nx, nu, N) = (stages.A.nrows(), stages.B.ncols(), stages.N);
    let np = N * nu;
    let ns = qp.rows.slacks();
    let nv = np + ns;
    let per_slot = stages.rows.len();
    let m = qp.rows.len();
    if stages
        .rows
        .iter()
        .any(|r| r.lag > 1 || (r.lag > 0 && r.au.iter().any(|v| *v != 0.0)))
    {
        return Err("a row couples an input with a later state".into());
    }
    let rho = &settings.rho;
    if rho.len() != nv + m {
        return Err("the penalties do not fit the problem".into());
    }
    let boxed: Vec<(usize, f64)> = (0..nv).map(|i| (i, 1.0)).collect();
    let sides: Vec<(usize, f64)> = (0..m).map(|r| (r, 1.0)).collect();
    let factor = stages
        .factor(&boxed, &sides, rho, settings.sigma)
        .ok_or("M = P + σI + CᵀRC has no stage-wise factor")?;
    let row_coupling = if ns > 0 {
        qp.rows.A.columns(0, np) * &factor.coupling
    } else {
        DMatrix::zeros(m, 0)
    };
    let sweep = Sweep {
        stages: &stages,
        factor,
        nx,
        nu,
        N,
        per_slot,
        m,
        ns,
        rho_rows: rho.rows(nv, m).into_owned(),
        row_coupling,
    };
    let mut b = Builder {
        slots: 1,
        statements: Vec::new(),
    };
    let x_in = b.alloc(nv);
    let z_in = b.alloc(nv + m);
    let y_in = b.alloc(nv + m);
    let q_in = b.alloc(nv);
    let x_at = b.alloc(nv);
    let z_at = b.alloc(m);
    match settings.form {
        super::Form::Direct => {
            // w = Rz − y on every row of C; the unknowns' right-hand side σx − q + w.
            let w: Vec<usize> = (0..nv + m)
                .map(|i| b.value(ZERO_SLOT, vec![(rho[i], z_in + i), (-1.0, y_in + i)], None))
                .collect();
            let rhs: Vec<usize> = (0..nv)
                .map(|i| {
                    let terms = vec![(settings.sigma, x_in + i), (-1.0, q_in + i), (1.0, w[i])];
                    b.value(ZERO_SLOT, terms, None)
                })
                .collect();
            sweep.solve(&mut b, &rhs, &w[nv..], &[], Some((x_at, z_at)))?;
        }
        super::Form::Residual => {
            // C x's rows from a rollout of x, whose states also give P x = Suᵀ·Q̃·X + 2R·U.
            let u: Vec<usize> = (x_in..x_in + np).collect();
            let states = sweep.rollout(&mut b, &u);
            let cx: Vec<usize> = (0..m)
                .map(|row| {
                    let (j, q) = (row / per_slot, row % per_slot);
                    let mut terms = sweep.row_terms(&states, &u, j, q);
                    if let Some((s, c)) = stages.slack[q] {
                        terms.push((c, x_in + np + s));
                    }
                    b.value(ZERO_SLOT, terms, None)
                })
                .collect();
            // w = R(z − Cx) − y.
            let w: Vec<usize> = (0..nv + m)
                .map(|i| {
                    let c = if i < nv { x_in + i } else { cx[i - nv] };
                    let terms = vec![(rho[i], z_in + i), (-rho[i], c), (-1.0, y_in + i)];
                    b.value(ZERO_SLOT, terms, None)
                })
                .collect();
            // The residual's unknowns part w − q − (2R·u_j, q_σ·σ); its states part −Q̃_k·x_k joins g_k.
            let rhs: Vec<usize> = (0..nv)
                .map(|i| {
                    let mut terms = vec![(1.0, w[i]), (-1.0, q_in + i)];
                    if i < np {
                        let (j, c) = (i / nu, i % nu);
                        terms.extend((0..nu).map(|l| (-stages.R2[(c, l)], x_in + j * nu + l)));
                    } else {
                        terms.push((-stages.slack_quadratic[i - np], x_in + i));
                    }
                    b.value(ZERO_SLOT, terms, None)
                })
                .collect();
            let state_terms: Vec<Vec<Vec<(f64, usize)>>> = (0..=N)
                .map(|k| {
                    let Q = if k == N { &stages.Qf2 } else { &stages.Q2 };
                    (0..nx)
                        .map(|i| (0..nx).map(|l| (-Q[(i, l)], states[k][l])).collect())
                        .collect()
                })
                .collect();
            let (d, rows_d) = sweep.solve(&mut b, &rhs, &w[nv..], &state_terms, None)?;
            // x̃ = x + d, z̃ = Cx + C·d.
            for (i, di) in d.iter().enumerate() {
                b.write(x_at + i, x_in + i, vec![(1.0, *di)], None);
            }
            for (row, (c, r)) in cx.iter().zip(&rows_d).enumerate() {
                b.write(z_at + row, *c, vec![(1.0, *r)], None);
            }
        }
    }
    Ok(Program {
        slots: b.slots,
        nv,
        m,
        x_in,
        z_in,
        y_in,
        q_in,
        x_at,
        z_at,
        statements: b.statements,
    })
}

/// A [`Program`] in compressed rows, the form the emitted loop reads ([`crate::emit`]'s `STAGE_*` tables)
/// and `Kernel` runs: statement k is `s[out[k]] = (s[base[k]] + Σ coefficient[t]·s[slot[t]]` over
/// `t ∈ start[k]..start[k + 1]`) · `scale[k]`, scale 1 where the statement has none (exact).
#[derive(Clone, Debug, PartialEq)]
pub struct Tables {
    /// The slot each statement writes.
    pub out: Vec<usize>,
    /// The slot each statement's sum starts from.
    pub base: Vec<usize>,
    /// Each statement's first term (one more entry than statements).
    pub start: Vec<usize>,
    /// Each term's slot.
    pub slot: Vec<usize>,
    /// Each term's coefficient.
    pub coefficient: Vec<f64>,
    /// Each statement's final factor.
    pub scale: Vec<f64>,
}

impl Program {
    /// The statements in compressed rows.
    pub fn tables(&self) -> Tables {
        let mut t = Tables {
            out: Vec::with_capacity(self.statements.len()),
            base: Vec::with_capacity(self.statements.len()),
            start: vec![0],
            slot: Vec::with_capacity(self.terms()),
            coefficient: Vec::with_capacity(self.terms()),
            scale: Vec::with_capacity(self.statements.len()),
        };
        for st in &self.statements {
            t.out.push(st.out);
            t.base.push(st.base);
            for &(c, i) in &st.terms {
                t.slot.push(i);
                t.coefficient.push(c);
            }
            t.start.push(t.slot.len());
            t.scale.push(st.scale.unwrap_or(1.0));
        }
        t
    }
}

/// A [`Program`] in the scalar T: its [`Tables`], the coefficients and scales rounded.
#[derive(Clone, Debug)]
pub struct Kernel<T> {
    program: Program,
    tables: Tables,
    coefficient: Vec<T>,
    scale: Vec<T>,
}

impl<T: Real> Kernel<T> {
    /// `program` rounded to T.
    pub fn new(program: &Program) -> Self {
        let tables = program.tables();
        Kernel {
            coefficient: tables.coefficient.iter().map(|c| T::of(*c)).collect(),
            scale: tables.scale.iter().map(|c| T::of(*c)).collect(),
            tables,
            program: program.clone(),
        }
    }

    /// x̃ (nv) and z̃'s general rows (m) at the iterate (x, z, y) with the linear term q: the emitted
    /// loop over the tables, statement by statement (the written-out statements round alike: a scale of
    /// 1 is exact).
    pub fn solve(&self, x: &[T], z: &[T], y: &[T], q: &[T]) -> (Vec<T>, Vec<T>) {
        let (p, t) = (&self.program, &self.tables);
        let mut s = vec![T::ZERO; p.slots];
        s[p.x_in..p.x_in + p.nv].copy_from_slice(x);
        s[p.z_in..p.z_in + p.nv + p.m].copy_from_slice(z);
        s[p.y_in..p.y_in + p.nv + p.m].copy_from_slice(y);
        s[p.q_in..p.q_in + p.nv].copy_from_slice(q);
        for k in 0..t.out.len() {
            let mut v = s[t.base[k]];
            for term in t.start[k]..t.start[k + 1] {
                v = v + self.coefficient[term] * s[t.slot[term]];
            }
            s[t.out[k]] = v * self.scale[k];
        }
        (
            s[p.x_at..p.x_at + p.nv].to_vec(),
            s[p.z_at..p.z_at + p.m].to_vec(),
        )
    }
}
