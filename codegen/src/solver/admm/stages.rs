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
use crate::lower::Qp;
use crate::solver::riccati::Stages;
use nalgebra::DMatrix;

/// How ADMM solves its x-update: the same iterates either way, to rounding.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Structure {
    /// Two triangular solves with the dense factor of the condensed M, and C·x̃ through A's nonzeros.
    Condensed,
    /// The stage-wise sweep of this module's [`Program`].
    Riccati,
}

impl Structure {
    /// Its name in `mpcc check`.
    pub fn name(self) -> &'static str {
        match self {
            Structure::Condensed => "condensed",
            Structure::Riccati => "riccati",
        }
    }
}

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

/// The stage-wise solve as straight-line statements over a scratch array of [`Program::slots`] entries:
/// b (the unknowns' right-hand side σx − q + w_box) at [`Program::b_at`], the rows' w at
/// [`Program::w_at`]; x̃ ends at [`Program::x_at`] and z̃'s rows at [`Program::z_at`].
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    /// Scratch entries.
    pub slots: usize,
    /// Unknowns (N·nu + ns).
    pub nv: usize,
    /// General rows.
    pub m: usize,
    /// The first slot of b (nv).
    pub b_at: usize,
    /// The first slot of the rows' w (m).
    pub w_at: usize,
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

/// Why the stage-wise x-update is not built for `qp`, or its [`Program`] for `settings` (direct form).
pub fn program(qp: &Qp, settings: &Settings) -> Result<Program, String> {
    if settings.form != super::Form::Direct {
        return Err("the residual form's x-update is built condensed only".into());
    }
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
    if settings.rho.len() != nv + m {
        return Err("the penalties do not fit the problem".into());
    }
    let boxed: Vec<(usize, f64)> = (0..nv).map(|i| (i, 1.0)).collect();
    let rows: Vec<(usize, f64)> = (0..m).map(|r| (r, 1.0)).collect();
    let factor = stages
        .factor(&boxed, &rows, &settings.rho, settings.sigma)
        .ok_or("M = P + σI + CᵀRC has no stage-wise factor")?;
    let (A, B) = (&factor.A, &factor.B);
    let mut b = Builder {
        slots: 1,
        statements: Vec::new(),
    };
    let b_at = b.alloc(nv);
    let w_at = b.alloc(m);
    let x_at = b.alloc(nv);
    let z_at = b.alloc(m);
    let w = |j: usize, q: usize| w_at + j * per_slot + q;
    // The linear terms: r_j on the inputs, g_k on the states (k = 1 … N; x_0 = 0 has none).
    let mut r = vec![ZERO_SLOT; np];
    for j in 0..N {
        for c in 0..nu {
            let terms = (0..per_slot)
                .map(|q| (stages.rows[q].au[c], w(j, q)))
                .collect();
            r[j * nu + c] = b.value(b_at + j * nu + c, terms, None);
        }
    }
    let mut g = vec![vec![ZERO_SLOT; nx]; N + 1];
    for (k, gk) in g.iter_mut().enumerate().skip(1) {
        for (i, gki) in gk.iter_mut().enumerate() {
            let terms = (0..N)
                .flat_map(|j| (0..per_slot).map(move |q| (j, q)))
                .filter(|&(j, q)| j + stages.rows[q].lag == k)
                .map(|(j, q)| (stages.rows[q].ax[i], w(j, q)))
                .collect();
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
        let L = factor.pivots[k].l();
        d[k] = b.cholesky_solve(&L, &e, None);
        if k > 0 {
            let K = &factor.gains[k];
            p = (0..nx)
                .map(|i| {
                    let mut terms: Vec<(f64, usize)> = (0..nx).map(|l| (A[(l, i)], p[l])).collect();
                    terms.extend((0..nu).map(|c| (-K[(c, i)], e[c])));
                    terms.push((-1.0, g[k][i]));
                    b.value(ZERO_SLOT, terms, None)
                })
                .collect();
        }
    }
    // The forward rollout, each row evaluated on its stage as it passes. Without slacks U and the rows
    // are x̃'s and z̃'s; with them, U_p and v before the slacks' correction.
    let (u_out, v_out) = if ns == 0 {
        (x_at, z_at)
    } else {
        (b.alloc(np), b.alloc(m))
    };
    let mut x = vec![ZERO_SLOT; nx];
    for k in 0..N {
        let K = &factor.gains[k];
        let u: Vec<usize> = (0..nu)
            .map(|c| {
                let mut terms: Vec<(f64, usize)> = (0..nx).map(|i| (-K[(c, i)], x[i])).collect();
                terms.push((-1.0, d[k][c]));
                b.write(u_out + k * nu + c, ZERO_SLOT, terms, None);
                u_out + k * nu + c
            })
            .collect();
        for (q, row) in stages.rows.iter().enumerate().filter(|(_, r)| r.lag == 0) {
            let mut terms: Vec<(f64, usize)> = (0..nx).map(|i| (row.ax[i], x[i])).collect();
            terms.extend((0..nu).map(|c| (row.au[c], u[c])));
            b.write(v_out + k * per_slot + q, ZERO_SLOT, terms, None);
        }
        let lagged = stages.rows.iter().any(|r| r.lag == 1);
        if k + 1 < N || lagged {
            x = (0..nx)
                .map(|i| {
                    let mut terms: Vec<(f64, usize)> = (0..nx).map(|l| (A[(i, l)], x[l])).collect();
                    terms.extend((0..nu).map(|c| (B[(i, c)], u[c])));
                    b.value(ZERO_SLOT, terms, None)
                })
                .collect();
        }
        for (q, row) in stages.rows.iter().enumerate().filter(|(_, r)| r.lag == 1) {
            let terms = (0..nx).map(|i| (row.ax[i], x[i])).collect();
            b.write(v_out + k * per_slot + q, ZERO_SLOT, terms, None);
        }
    }
    if ns > 0 {
        // σ̃ = S⁻¹(b_σ + Σ c·w − Σ ρ·c·v), then U = U_p − Y·σ̃ and the rows v − (A_U·Y)·σ̃ + c·σ̃.
        let t: Vec<usize> = (0..ns)
            .map(|s| {
                let terms = (0..m)
                    .filter_map(|row| match stages.slack[row % per_slot] {
                        Some((j, c)) if j == s => {
                            Some([(c, w_at + row), (-settings.rho[nv + row] * c, v_out + row)])
                        }
                        _ => None,
                    })
                    .flatten()
                    .collect();
                b.value(b_at + np + s, terms, None)
            })
            .collect();
        let schur = factor
            .schur
            .as_ref()
            .ok_or("the slacks' Schur complement")?;
        let sigma = b.cholesky_solve(&schur.l(), &t, Some(x_at + np));
        let Y = &factor.coupling;
        for i in 0..np {
            let terms = (0..ns).map(|s| (-Y[(i, s)], sigma[s])).collect();
            b.write(x_at + i, u_out + i, terms, None);
        }
        let AY = qp.rows.A.columns(0, np) * Y;
        for row in 0..m {
            let own = stages.slack[row % per_slot];
            let terms = (0..ns)
                .map(|s| {
                    let c = match own {
                        Some((j, c)) if j == s => c,
                        _ => 0.0,
                    };
                    (c - AY[(row, s)], sigma[s])
                })
                .collect();
            b.write(z_at + row, v_out + row, terms, None);
        }
    }
    Ok(Program {
        slots: b.slots,
        nv,
        m,
        b_at,
        w_at,
        x_at,
        z_at,
        statements: b.statements,
    })
}

/// A [`Program`] in the scalar T: its coefficients rounded.
#[derive(Clone, Debug)]
pub struct Kernel<T> {
    program: Program,
    coefficients: Vec<Vec<T>>,
    scales: Vec<Option<T>>,
}

impl<T: Real> Kernel<T> {
    /// `program` rounded to T.
    pub fn new(program: &Program) -> Self {
        Kernel {
            coefficients: program
                .statements
                .iter()
                .map(|s| s.terms.iter().map(|(c, _)| T::of(*c)).collect())
                .collect(),
            scales: program
                .statements
                .iter()
                .map(|s| s.scale.map(T::of))
                .collect(),
            program: program.clone(),
        }
    }

    /// x̃ (nv) and z̃'s general rows (m) for the unknowns' right-hand side `b` (σx − q + w_box) and the
    /// rows' `w` (Rz − y on the general rows).
    pub fn solve(&self, b: &[T], w: &[T]) -> (Vec<T>, Vec<T>) {
        let p = &self.program;
        let mut s = vec![T::ZERO; p.slots];
        s[p.b_at..p.b_at + p.nv].copy_from_slice(b);
        s[p.w_at..p.w_at + p.m].copy_from_slice(w);
        for ((st, coefficients), scale) in p
            .statements
            .iter()
            .zip(&self.coefficients)
            .zip(&self.scales)
        {
            let mut v = s[st.base];
            for ((_, i), c) in st.terms.iter().zip(coefficients) {
                v = v + *c * s[*i];
            }
            if let Some(scale) = scale {
                v = v * *scale;
            }
            s[st.out] = v;
        }
        (
            s[p.x_at..p.x_at + p.nv].to_vec(),
            s[p.z_at..p.z_at + p.m].to_vec(),
        )
    }
}
