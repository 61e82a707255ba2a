//! The condensed QP the interior-point method iterates on, and what the compiler reads off its
//! constant structure: [`InequalityQp`] and the MPC's instance of it ([`mpc_qp`]), its finite sides
//! ([`Layout`], stacked as G z ≤ h), the structure the emitted method visits ([`Sparsity`]) and the
//! multiply-adds of one iteration ([`macs_per_iteration`]). The Riccati form
//! ([`crate::solver::riccati`]) shares the counts; the method ([`super`]) uses both.
#![allow(non_snake_case)]

use crate::lower::problem::Qp;
use crate::solver::constrained::InequalityQp;
use nalgebra::{DMatrix, DVector};

/// [`macs_per_iteration`] of the MPC's QP: the condensed form's count.
pub fn condensed_macs_per_iteration(qp: &Qp) -> usize {
    macs_per_iteration(&structure_of(qp))
}

/// The parts of the condensed count of the MPC's QP, which the Riccati form shares but for the normal
/// matrix's forming, factorisation and solves.
pub(crate) fn mpc_counts(qp: &Qp) -> Counts {
    counts(&structure_of(qp))
}

/// The finite sides and the visited structure of the MPC's QP.
pub(crate) fn mpc_structure(qp: &Qp) -> (Layout, Sparsity) {
    let s = structure_of(qp);
    (Layout::of(&s), Sparsity::of(&s))
}

/// The MPC's QP with zero data: its structure, which is all the counts need.
pub(super) fn structure_of(qp: &Qp) -> InequalityQp {
    let n = qp.Nc * qp.u_min.len();
    mpc_qp(qp, &DVector::zeros(n), &DVector::zeros(qp.rows.len()))
}

/// Where the normal matrix H + Gᵀ·diag(d)·G can be nonzero, whatever the weights d: H's nonzeros, the
/// diagonal, and each row's outer product of its nonzero columns. Its [`crate::lower::structure::Envelope`]
/// is what the emitted factorisation visits.
pub fn normal_pattern(qp: &InequalityQp) -> DMatrix<bool> {
    let n = qp.n();
    let mut pattern = DMatrix::from_fn(n, n, |i, j| i == j || qp.H[(i, j)] != 0.0);
    for r in 0..qp.A.nrows() {
        let cols: Vec<usize> = (0..n).filter(|&c| qp.A[(r, c)] != 0.0).collect();
        for &a in &cols {
            for &b in &cols {
                pattern[(a, b)] = true;
            }
        }
    }
    pattern
}

/// The structure the emitted method visits, read off the QP's nonzeros (so it is the same for any
/// data): the unknowns reordered by the envelope of the normal matrix (independent axes become
/// diagonal blocks), per reordered row of H the span of columns that can be nonzero, and the rows
/// with a finite side, each once however many of its two sides are finite (a two-sided row's sides
/// are ±the same product, and their weights add up in the normal matrix).
#[derive(Clone, Debug)]
pub struct Sparsity {
    /// The ordering and the factor's envelope.
    pub envelope: crate::lower::structure::Envelope,
    /// Per position p, the positions [lo, hi) where row p of the reordered H can be nonzero.
    pub h_span: Vec<(usize, usize)>,
    /// The rows with a finite side, in the order of [`Layout::rows`]: the row's index in `A`.
    pub rows: Vec<usize>,
    /// Per side of [`Layout::rows`], its row's index in `rows`.
    pub side_row: Vec<usize>,
    /// Per entry of `rows`, its nonzero columns as positions, ascending.
    pub row_positions: Vec<Vec<usize>>,
}

impl Sparsity {
    /// The structure of `qp`.
    pub fn of(qp: &InequalityQp) -> Self {
        let n = qp.n();
        let envelope = crate::lower::structure::Envelope::of(&normal_pattern(qp));
        let h_span = (0..n)
            .map(|p| {
                let i = envelope.order[p];
                let cols: Vec<usize> = (0..n)
                    .filter(|&q| q == p || qp.H[(i, envelope.order[q])] != 0.0)
                    .collect();
                (cols[0], cols[cols.len() - 1] + 1)
            })
            .collect();
        let layout = Layout::of(qp);
        let mut rows: Vec<usize> = Vec::new();
        let mut side_row = Vec::new();
        for &(r, _) in &layout.rows {
            if rows.last() != Some(&r) {
                rows.push(r);
            }
            side_row.push(rows.len() - 1);
        }
        let row_positions = rows
            .iter()
            .map(|&r| {
                let mut cols: Vec<usize> = (0..n)
                    .filter(|&c| qp.A[(r, c)] != 0.0)
                    .map(|c| envelope.position[c])
                    .collect();
                cols.sort_unstable();
                cols
            })
            .collect();
        Sparsity {
            envelope,
            h_span,
            rows,
            side_row,
            row_positions,
        }
    }

    /// Multiply-adds of H·z over the spans.
    pub fn h_macs(&self) -> usize {
        self.h_span.iter().map(|(lo, hi)| hi - lo).sum()
    }

    /// Nonzeros of the distinct rows.
    pub fn row_nnz(&self) -> usize {
        self.row_positions.iter().map(Vec::len).sum()
    }
}

/// Iterative refinement steps of the corrector's direction (the predictor only sets
/// the centering and is not refined).
pub const REFINEMENT: usize = 1;

impl InequalityQp {
    /// The number of finite sides: the length of s and λ.
    pub fn sides(&self) -> usize {
        Sides::new(self).len()
    }
}

/// The finite sides as G z ≤ h: the box sides first (one ±1 entry each, kept as index and sign so the
/// normal matrix gains a diagonal), then the rows' sides (dense).
pub(super) struct Sides {
    /// Box side k: sign·z_index ≤ h_k.
    pub(super) boxed: Vec<(usize, f64)>,
    /// Row side k: sign·A_row·z ≤ h_(nb + k).
    pub(super) rows: Vec<(usize, f64)>,
    /// The rows' sides, ±A_r.
    pub(super) G: DMatrix<f64>,
    /// All right-hand sides, box sides first.
    pub(super) h: DVector<f64>,
}

/// Which sides of an [`InequalityQp`] are finite, in the order the method stacks them: per entry of z
/// its upper then its lower bound, then per row its upper then its lower side. Each side is an index
/// (of z or of the rows) and a sign (+1 upper, −1 lower); its right-hand side is sign·bound.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// Box sides: sign·z_index ≤ sign·bound.
    pub boxed: Vec<(usize, f64)>,
    /// Row sides: sign·A_row·z ≤ sign·bound.
    pub rows: Vec<(usize, f64)>,
}

impl Layout {
    /// The finite sides of `qp`.
    pub fn of(qp: &InequalityQp) -> Self {
        let mut boxed = Vec::new();
        for i in 0..qp.n() {
            if qp.z_max[i].is_finite() {
                boxed.push((i, 1.0));
            }
            if qp.z_min[i].is_finite() {
                boxed.push((i, -1.0));
            }
        }
        let mut rows = Vec::new();
        for r in 0..qp.A.nrows() {
            if qp.upper[r].is_finite() {
                rows.push((r, 1.0));
            }
            if qp.lower[r].is_finite() {
                rows.push((r, -1.0));
            }
        }
        Layout { boxed, rows }
    }
}

/// A side's right-hand side: sign·bound (the upper bound, or minus the lower one).
pub fn side_bound(sign: f64, lower: f64, upper: f64) -> f64 {
    if sign > 0.0 {
        upper
    } else {
        -lower
    }
}

impl Sides {
    pub(super) fn new(qp: &InequalityQp) -> Self {
        let n = qp.n();
        let layout = Layout::of(qp);
        let mut h: Vec<f64> = layout
            .boxed
            .iter()
            .map(|&(i, sign)| side_bound(sign, qp.z_min[i], qp.z_max[i]))
            .collect();
        let rows: Vec<_> = layout
            .rows
            .iter()
            .map(|&(r, sign)| {
                h.push(side_bound(sign, qp.lower[r], qp.upper[r]));
                qp.A.row(r) * sign
            })
            .collect();
        let G = if rows.is_empty() {
            DMatrix::zeros(0, n)
        } else {
            DMatrix::from_rows(&rows)
        };
        Sides {
            boxed: layout.boxed,
            rows: layout.rows,
            G,
            h: DVector::from_vec(h),
        }
    }

    pub(super) fn len(&self) -> usize {
        self.h.len()
    }

    /// G z.
    pub(super) fn mul(&self, z: &DVector<f64>) -> DVector<f64> {
        let nb = self.boxed.len();
        let mut out = DVector::zeros(self.len());
        for (k, (i, sign)) in self.boxed.iter().enumerate() {
            out[k] = sign * z[*i];
        }
        out.rows_mut(nb, self.G.nrows()).copy_from(&(&self.G * z));
        out
    }

    /// Gᵀ v.
    pub(super) fn tmul(&self, v: &DVector<f64>) -> DVector<f64> {
        let nb = self.boxed.len();
        let mut out = self.G.tr_mul(&v.rows(nb, self.G.nrows()));
        for (k, (i, sign)) in self.boxed.iter().enumerate() {
            out[*i] += sign * v[k];
        }
        out
    }

    /// H + Gᵀ diag(d) G.
    pub(super) fn normal(&self, H: &DMatrix<f64>, d: &DVector<f64>) -> DMatrix<f64> {
        let nb = self.boxed.len();
        let mut M = H.clone();
        for (k, (i, _)) in self.boxed.iter().enumerate() {
            M[(*i, *i)] += d[k];
        }
        let mut DG = self.G.clone();
        for (r, mut row) in DG.row_iter_mut().enumerate() {
            row *= d[nb + r];
        }
        M += self.G.tr_mul(&DG);
        M
    }
}

/// Multiply-adds of one iteration of the emitted method, by the calibration rule of issue 17 (a
/// product counts its multiplications, a factorisation its inner products) applied to what the
/// emitted code visits ([`Sparsity`]): the envelope, the spans of H, and each two-sided row once.
/// With one dense block this is the calibration's dense count (mat-vec n², Cholesky n³/6, forming
/// GᵀDG Σ_r nnz_r²/2):
/// - residuals: H z over the spans, G z and Gᵀλ (nnz of the distinct rows, plus a term per side);
/// - the normal matrix, Σ_r nnz_r(nnz_r + 1)/2 over the distinct rows, and its L·D·Lᵀ within the
///   envelope ([`crate::lower::structure::Envelope::ldl_macs`]);
/// - two directions (predictor, corrector), each a right-hand side Gᵀ(·), the triangular solves
///   within the envelope and G Δz;
/// - [`REFINEMENT`] steps of the corrector: H Δz, Gᵀ Δλ, a solve and G of its result;
/// - the element-wise work on s and λ, about 12 per side.
///
/// The cold start costs one more factorisation, of H + GᵀG, and one direction
/// (`ipm::mpc_cold_start_macs`).
pub fn macs_per_iteration(qp: &InequalityQp) -> usize {
    let c = counts(qp);
    c.residuals + c.normal + c.factor + 2 * c.direction + REFINEMENT * c.refinement + c.elementwise
}

/// The parts of [`macs_per_iteration`].
pub(crate) struct Counts {
    pub(crate) residuals: usize,
    pub(crate) normal: usize,
    pub(crate) factor: usize,
    /// One direction, its solve included.
    pub(crate) direction: usize,
    /// One refinement step, its solve included.
    pub(crate) refinement: usize,
    pub(crate) elementwise: usize,
    /// One solve with the factor.
    pub(crate) solve: usize,
    /// One product G·z or Gᵀ·v.
    pub(crate) g: usize,
}

pub(super) fn counts(qp: &InequalityQp) -> Counts {
    let layout = Layout::of(qp);
    let sparsity = Sparsity::of(qp);
    let (nb, ng) = (layout.boxed.len(), layout.rows.len());
    // G z and Gᵀ v: each distinct row once, then one signed term per side.
    let g = sparsity.row_nnz() + nb + ng;
    let solve = sparsity.envelope.solve_macs();
    let hz = sparsity.h_macs();
    let normal = sparsity
        .row_positions
        .iter()
        .map(|c| c.len() * (c.len() + 1) / 2)
        .sum::<usize>()
        + nb
        + ng;
    Counts {
        residuals: hz + 2 * g,
        normal,
        factor: sparsity.envelope.ldl_macs(),
        direction: 2 * g + solve,
        // H Δz, Gᵀ Δλ, a solve and G of its result.
        refinement: hz + 2 * g + solve,
        elementwise: 12 * (nb + ng),
        solve,
        g,
    }
}

/// The MPC's QP of one control step on z = (U, σ): ½zᵀ·blkdiag(H, diag(q_σ))·z + (f, w)ᵀz over the
/// input box and σ ≥ 0, with the rows of [`crate::lower::constraints`] shifted by their data `offset`
/// (Wx·x0 + Wd·d + Wu·u₋₁).
pub fn mpc_qp(qp: &Qp, f: &DVector<f64>, offset: &DVector<f64>) -> InequalityQp {
    let rows = &qp.rows;
    let (n, ns) = (f.len(), rows.slacks());
    let nu = qp.u_min.len();
    let nv = n + ns;
    let mut H = DMatrix::zeros(nv, nv);
    H.view_mut((0, 0), (n, n)).copy_from(&qp.H);
    for j in 0..ns {
        H[(n + j, n + j)] = rows.slack_quadratic[j];
    }
    let A = if rows.is_empty() {
        DMatrix::zeros(0, nv)
    } else {
        rows.A.clone()
    };
    InequalityQp {
        H,
        f: DVector::from_iterator(nv, f.iter().chain(rows.slack_weight.iter()).copied()),
        z_min: DVector::from_fn(nv, |i, _| if i < n { qp.u_min[i % nu] } else { 0.0 }),
        z_max: DVector::from_fn(nv, |i, _| {
            if i < n {
                qp.u_max[i % nu]
            } else {
                f64::INFINITY
            }
        }),
        A,
        lower: &rows.lower - offset,
        upper: &rows.upper - offset,
    }
}
