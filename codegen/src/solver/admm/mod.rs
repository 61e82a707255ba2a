//! ADMM for the constrained MPC QP, the method for targets without f64 hardware (issue 18, item 2).
//!
//! The operator splitting of OSQP (B. Stellato, G. Banjac, P. Goulart, A. Bemporad, S. Boyd, "OSQP:
//! an operator splitting solver for quadratic programs", Math. Prog. Comp. 12, 2020, Algorithm 1) on
//! the same problem the interior-point method solves ([`crate::solver::constrained::InequalityQp`], built by
//! [`crate::solver::ipm::mpc_qp`]): minimise ½xᵀPx + qᵀx subject to l ≤ C x ≤ u with C = [I; A], the box
//! z_min ≤ x ≤ z_max as C's identity rows and the general rows A after them. One iteration, with R =
//! diag(ρ) one penalty per row of C and K = (P + σI + CᵀRC)⁻¹ factored once at build time (M = L Lᵀ):
//!
//! - x̃ = K (σx − q + Cᵀ(Rz − y)), z̃ = C x̃ (the direct [`Form`]; the residual form computes the
//!   same x̃ as x + K (CᵀR(z − Cx) − (Px + q + Cᵀy)), whose fixed point K's rounding does not move);
//! - x ← α x̃ + (1 − α) x;
//! - z ← Π\[l,u\](α z̃ + (1 − α) z + R⁻¹y);
//! - y ← y + R(α z̃ + (1 − α) z_old − z).
//!
//! Measured on the shipped specs (`tests/admm.rs`): ρ = 10-32 times the rows' curvature, 281
//! (quadcopter) and 464 (paper-limits) iterations on the tuning sample, and the same counts in f32
//! (per case at most 1.01× f64's). In f32 the hover QP (κ(H) = 2.8e4) does not keep its accuracy: the
//! rounding noise of each iteration accumulates in the slow modes to 4e-4 … 1.3e-3 of the span.
//!
//! The x-update is dense on the condensed QP, or stage by stage ([`Structure`], `admm/stages.rs`: the
//! same x̃ from Riccati gains computed at build time), whichever [`StructureChoice`] counts cheaper. Dense,
//! L is an n × n triangular table (K·b is two triangular solves, n²
//! multiply-adds like a mat-vec, and backward stable in f32 where the rounded inverse is not) and A is
//! applied through its structural nonzeros. Unlike the interior-point method it needs no factorisation at run time, so it keeps its
//! f64 iteration counts in f32 (issue 17's calibration; `tests/admm.rs` measures it): the iteration is
//! written once over [`Real`] and runs in f32 or f64.
//!
//! ρ is **measured**, not derived: [`tune_rho`] runs the iteration on a sample of problems with their
//! exact solutions and picks the ρ that needs the fewest iterations on the worst of them. The
//! calibration found the rule ρ = √(λmin λmax) 3-100× off once state rows exist, and a ρ 10× off
//! costing 4-11× the iterations; [`tune_rho`]'s grid prints the same picture on the shipped specs
//! (`cargo test -p codegen --test admm -- --nocapture`). Each row's penalty is ρ times the row's
//! curvature [`row_scales`], so one number serves rows of different units.
#![allow(non_snake_case)]

use crate::certify::evidence::Limits;
use crate::lower::problem::Qp;
use crate::solver::constrained::InequalityQp;
use crate::solver::ipm::{self, IpmResult, Layout};
use nalgebra::{DMatrix, DVector};
use std::fmt::Debug;
use std::ops::{Add, Div, Mul, Neg, Sub};
use std::sync::Arc;

pub mod emit;
mod emit_stages;
pub mod method;
pub mod sampled;
mod stages;
pub use stages::{program as stages_program, Program, Statement, Structure, Tables, ZERO_SLOT};

/// Its name in prose.
pub const TITLE: &str = "ADMM (OSQP's operator splitting on the condensed QP)";

/// OSQP's over-relaxation α.
pub const ALPHA: f64 = 1.6;

/// The proximal weight σ relative to the mean of H's diagonal: small, so that K exists for a
/// semidefinite H without moving the iterates.
pub const SIGMA: f64 = 1e-6;

/// OSQP's primal infeasibility tolerance ε_pinf (§3.4).
pub const INFEASIBILITY_TOLERANCE: f64 = 1e-4;

/// The scalar the iteration runs in: f32 or f64.
pub trait Real:
    Copy
    + PartialOrd
    + Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// 0.
    const ZERO: Self;
    /// The value nearest to `v`.
    fn of(v: f64) -> Self;
    /// As f64 (exact).
    fn wide(self) -> f64;
    /// |self|.
    fn abs(self) -> Self;
    /// Whether finite.
    fn finite(self) -> bool;
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    fn of(v: f64) -> Self {
        v
    }
    fn wide(self) -> f64 {
        self
    }
    fn abs(self) -> Self {
        f64::abs(self)
    }
    fn finite(self) -> bool {
        self.is_finite()
    }
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    fn of(v: f64) -> Self {
        v as f32
    }
    fn wide(self) -> f64 {
        self as f64
    }
    fn abs(self) -> Self {
        f32::abs(self)
    }
    fn finite(self) -> bool {
        self.is_finite()
    }
}

/// v clamped to [lo, hi] (NaN stays NaN: the residuals then say so).
fn clamp<T: Real>(v: T, lo: T, hi: T) -> T {
    if v < lo {
        lo
    } else if v > hi {
        hi
    } else {
        v
    }
}

/// How x̃ is computed: directly, x̃ = K·(σx − q + Cᵀ(Rz − y)), or from the x-update's KKT residual,
/// x̃ = x + K·(CᵀR(z − Cx) − (Px + q + Cᵀy)). The same iterates in exact arithmetic; they differ in
/// what the rounding of the factor does. The factor rounded to the module's scalar is the exact factor
/// of P + E + σI + CᵀRC with ‖E‖ ≈ ε‖CᵀRC‖, so the direct form's fixed point solves the QP with P + E:
/// a bias, which f32 makes visible on an ill-conditioned H (hover, κ(H) = 2.8e4). The residual form's
/// bracket is zero at a fixed point whatever K's rounding, for one product with P and one with C more
/// an iteration ([`macs_per_iteration`]).
pub use mpc_spec::AdmmForm as Form;

/// The method's parameters: one penalty per row of C (the n box rows, then the general rows), σ, α and
/// the form of the x-update.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// ρ_i per row of C = [I; A].
    pub rho: DVector<f64>,
    /// σ.
    pub sigma: f64,
    /// α.
    pub alpha: f64,
    /// How x̃ is computed.
    pub form: Form,
    /// The stage-wise x-update ([`Structure::Riccati`]), or `None` for the condensed one.
    pub stages: Option<Arc<Program>>,
}

/// Each row's curvature: the objective's curvature along the row, 1/(c_i P⁻¹ c_iᵀ) (the inverse of
/// the dual Hessian C P⁻¹ Cᵀ's diagonal, its Jacobi scaling). A row's penalty is ρ times it, so that
/// one ρ fits rows of different units (an input, a speed, an angle). Falls back to H's diagonal where
/// H is singular.
pub fn row_scales(qp: &InequalityQp) -> DVector<f64> {
    let n = qp.n();
    let m = qp.A.nrows();
    let sigma = sigma_of(qp);
    let mut P = qp.H.clone();
    for i in 0..n {
        P[(i, i)] += sigma;
    }
    let Some(chol) = P.clone().cholesky() else {
        return DVector::from_fn(n + m, |i, _| {
            if i < n {
                P[(i, i)]
            } else {
                let a = qp.A.row(i - n);
                (0..n).map(|j| a[j] * a[j] * P[(j, j)]).sum::<f64>() / a.norm_squared().powi(2)
            }
        });
    };
    let Pinv = chol.inverse();
    DVector::from_fn(n + m, |i, _| {
        if i < n {
            1.0 / Pinv[(i, i)]
        } else {
            let a = qp.A.row(i - n).transpose();
            1.0 / a.dot(&(&Pinv * &a))
        }
    })
}

/// σ for `qp`: [`SIGMA`] times the mean of H's diagonal.
pub fn sigma_of(qp: &InequalityQp) -> f64 {
    let n = qp.n().max(1);
    SIGMA * (0..qp.n()).map(|i| qp.H[(i, i)].abs()).sum::<f64>() / n as f64
}

impl Settings {
    /// ρ times [`row_scales`] on every row, [`sigma_of`], [`ALPHA`], the direct form.
    pub fn scaled(qp: &InequalityQp, rho: f64) -> Self {
        Settings {
            rho: row_scales(qp) * rho,
            sigma: sigma_of(qp),
            alpha: ALPHA,
            form: Form::Direct,
            stages: None,
        }
    }

    /// The same settings with the x-update in `form` (condensed).
    pub fn in_form(self, form: Form) -> Self {
        Settings {
            form,
            stages: None,
            ..self
        }
    }

    /// How the x-update is solved.
    pub fn structure(&self) -> Structure {
        match self.stages {
            Some(_) => Structure::Riccati,
            None => Structure::Condensed,
        }
    }
}

/// The iteration's data in the scalar T: K, P, A's nonzeros, the bounds of C's rows, the penalties.
#[derive(Clone, Debug)]
pub struct Operator<T> {
    /// Unknowns n.
    pub n: usize,
    /// The lower Cholesky factor L of K⁻¹ = P + σI + CᵀRC, row-major n × n (zero above the diagonal);
    /// empty with the stage-wise x-update.
    /// The factor, not K itself: a factor rounded to f32 is the exact factor of a matrix within
    /// ε·‖M‖ of M, where a rounded inverse is the inverse of one within ε·κ(M)·‖M‖, which moved the
    /// f32 iteration's fixed point by 1 % of the span on the hover QP (κ(H) = 2.8e4; `tests/admm.rs`).
    pub L: Vec<T>,
    /// 1 / L_ii.
    pub L_inv: Vec<T>,
    /// P, row-major n × n (for the dual residual).
    pub P: Vec<T>,
    /// The general rows' nonzeros, (column, value) per row.
    pub A: Vec<Vec<(usize, T)>>,
    /// q (n).
    pub q: Vec<T>,
    /// Lower bounds of C's rows (n + m), −∞ where absent.
    pub lower: Vec<T>,
    /// Upper bounds of C's rows.
    pub upper: Vec<T>,
    /// ρ per row of C.
    pub rho: Vec<T>,
    /// 1/ρ per row of C.
    pub rho_inv: Vec<T>,
    /// σ.
    pub sigma: T,
    /// α.
    pub alpha: T,
    /// How x̃ is computed.
    pub form: Form,
    /// The stage-wise x-update in T (`None`: the condensed one with L).
    pub stages: Option<stages::Kernel<T>>,
}

/// The lower Cholesky factor L of M = P + σI + CᵀRC (M = L Lᵀ) in f64, `None` when M is not positive
/// definite.
pub fn factor(qp: &InequalityQp, s: &Settings) -> Option<DMatrix<f64>> {
    let n = qp.n();
    let m = qp.A.nrows();
    let mut M = qp.H.clone();
    for i in 0..n {
        M[(i, i)] += s.sigma + s.rho[i];
    }
    let RA = DMatrix::from_fn(m, n, |r, j| s.rho[n + r] * qp.A[(r, j)]);
    M += qp.A.tr_mul(&RA);
    M.cholesky().map(|c| c.l())
}

impl<T: Real> Operator<T> {
    /// The data of `qp` with `settings`, rounded to T; `None` for inconsistent settings or a K that
    /// does not exist.
    pub fn new(qp: &InequalityQp, settings: &Settings) -> Option<Self> {
        let n = qp.n();
        let m = qp.A.nrows();
        if settings.rho.len() != n + m || settings.rho.iter().any(|r| r.is_nan() || *r <= 0.0) {
            return None;
        }
        let L = match settings.stages {
            Some(_) => DMatrix::zeros(0, 0),
            None => factor(qp, settings)?,
        };
        Some(Self::with_factor(qp, settings, &L))
    }

    /// As [`Operator::new`] with the factor L given (it depends on H, A and the settings only, not on
    /// the data; unused, and may be empty, with the stage-wise x-update).
    pub fn with_factor(qp: &InequalityQp, settings: &Settings, L: &DMatrix<f64>) -> Self {
        let n = qp.n();
        let m = qp.A.nrows();
        let table = |M: &DMatrix<f64>| {
            (0..M.nrows() * M.ncols())
                .map(|k| T::of(M[(k / n, k % n)]))
                .collect::<Vec<T>>()
        };
        Operator {
            n,
            L: table(L),
            L_inv: (0..L.nrows()).map(|i| T::of(1.0 / L[(i, i)])).collect(),
            P: table(&qp.H),
            A: (0..m)
                .map(|r| {
                    (0..n)
                        .filter(|&j| qp.A[(r, j)] != 0.0)
                        .map(|j| (j, T::of(qp.A[(r, j)])))
                        .collect()
                })
                .collect(),
            q: qp.f.iter().map(|v| T::of(*v)).collect(),
            lower: qp
                .z_min
                .iter()
                .chain(&qp.lower)
                .map(|v| T::of(*v))
                .collect(),
            upper: qp
                .z_max
                .iter()
                .chain(&qp.upper)
                .map(|v| T::of(*v))
                .collect(),
            rho: settings.rho.iter().map(|v| T::of(*v)).collect(),
            rho_inv: settings.rho.iter().map(|v| T::of(1.0 / v)).collect(),
            sigma: T::of(settings.sigma),
            alpha: T::of(settings.alpha),
            form: settings.form,
            stages: settings.stages.as_deref().map(stages::Kernel::new),
        }
    }

    /// Rows of C.
    fn rows(&self) -> usize {
        self.lower.len()
    }

    /// C x.
    fn C(&self, x: &[T]) -> Vec<T> {
        let mut out = x.to_vec();
        out.extend(
            self.A
                .iter()
                .map(|row| row.iter().fold(T::ZERO, |acc, (j, a)| acc + *a * x[*j])),
        );
        out
    }

    /// Cᵀ v.
    fn Ct(&self, v: &[T]) -> Vec<T> {
        let n = self.n;
        let mut out = v[..n].to_vec();
        for (r, row) in self.A.iter().enumerate() {
            for (j, a) in row {
                out[*j] = out[*j] + *a * v[n + r];
            }
        }
        out
    }

    /// K b = L⁻ᵀ L⁻¹ b: the forward substitution, then the backward one (n² multiply-adds).
    pub fn solve(&self, mut b: Vec<T>) -> Vec<T> {
        if self.L.len() != self.n * self.n {
            return vec![T::of(f64::NAN); self.n];
        }
        let n = self.n;
        for i in 0..n {
            let row = &self.L[i * n..i * n + i];
            let s = row
                .iter()
                .zip(&b[..i])
                .fold(b[i], |acc, (l, w)| acc - *l * *w);
            b[i] = s * self.L_inv[i];
        }
        for i in (0..n).rev() {
            let s = (i + 1..n).fold(b[i], |acc, j| acc - self.L[j * n + i] * b[j]);
            b[i] = s * self.L_inv[i];
        }
        b
    }

    /// P x, each row summed from zero in column order.
    fn P(&self, x: &[T]) -> Vec<T> {
        let n = self.n;
        (0..n)
            .map(|i| {
                self.P[i * n..(i + 1) * n]
                    .iter()
                    .zip(x)
                    .fold(T::ZERO, |acc, (a, b)| acc + *a * *b)
            })
            .collect()
    }

    /// x̃, the solution of (P + σI + CᵀRC) x̃ = σx − q + Cᵀ(Rz − y), in the settings' form and
    /// structure, and z̃ = C x̃.
    fn x_tilde(&self, p: &Iterate<T>) -> (Vec<T>, Vec<T>) {
        let n = self.n;
        if let Some(kernel) = &self.stages {
            let (xt, rows) = kernel.solve(&p.x, &p.z, &p.y, &self.q);
            let mut zt = xt.clone();
            zt.extend(rows);
            return (xt, zt);
        }
        let xt = match self.form {
            Form::Direct => {
                // x̃ = K (σx − q + Cᵀ(Rz − y)).
                let w: Vec<T> = (0..self.rows())
                    .map(|i| self.rho[i] * p.z[i] - p.y[i])
                    .collect();
                let ctw = self.Ct(&w);
                let rhs: Vec<T> = (0..n)
                    .map(|i| self.sigma * p.x[i] - self.q[i] + ctw[i])
                    .collect();
                self.solve(rhs)
            }
            Form::Residual => {
                // x̃ = x + K (Cᵀ(R(z − Cx) − y) − (Px + q)).
                let cx = self.C(&p.x);
                let w: Vec<T> = (0..self.rows())
                    .map(|i| self.rho[i] * (p.z[i] - cx[i]) - p.y[i])
                    .collect();
                let ctw = self.Ct(&w);
                let px = self.P(&p.x);
                let r: Vec<T> = (0..n).map(|i| ctw[i] - (px[i] + self.q[i])).collect();
                let d = self.solve(r);
                p.x.iter().zip(&d).map(|(x, d)| *x + *d).collect()
            }
        };
        let zt = self.C(&xt);
        (xt, zt)
    }

    /// One iteration of OSQP's Algorithm 1 on (x, z, y).
    pub fn iterate(&self, p: &mut Iterate<T>) {
        let one = T::of(1.0);
        let (xt, zt) = self.x_tilde(p);
        let (a, b) = (self.alpha, one - self.alpha);
        for (x, t) in p.x.iter_mut().zip(&xt) {
            *x = a * *t + b * *x;
        }
        for (i, t) in zt.iter().enumerate() {
            let relaxed = a * *t + b * p.z[i];
            let z = clamp(
                relaxed + self.rho_inv[i] * p.y[i],
                self.lower[i],
                self.upper[i],
            );
            let y = p.y[i] + self.rho[i] * (relaxed - z);
            p.dy[i] = y - p.y[i];
            p.y[i] = y;
            p.z[i] = z;
        }
    }

    /// The relative residuals at p: ‖Cx − z‖∞ / (1 + max(‖Cx‖∞, ‖z‖∞)) and
    /// ‖Px + q + Cᵀy‖∞ / (1 + max(‖Px‖∞, ‖q‖∞, ‖Cᵀy‖∞)), in f64 from T's values.
    pub fn residuals(&self, p: &Iterate<T>) -> (f64, f64, f64) {
        let n = self.n;
        let amax = |v: &[T]| v.iter().fold(0.0_f64, |m, x| m.max(x.wide().abs()));
        let cx = self.C(&p.x);
        let primal: Vec<T> = cx.iter().zip(&p.z).map(|(a, b)| *a - *b).collect();
        let px = self.P(&p.x);
        let cty = self.Ct(&p.y);
        let dual: Vec<T> = (0..n).map(|i| px[i] + self.q[i] + cty[i]).collect();
        let nan = |v: &[T]| v.iter().any(|x| !x.finite());
        if nan(&primal) || nan(&dual) {
            return (f64::INFINITY, f64::INFINITY, f64::INFINITY);
        }
        // The duality gap xᵀPx + qᵀx + yᵀz (y is in the normal cone of the bounds at z, so yᵀz is the
        // support function of [l, u] at y, infinite sides included), in f64 over the iterate's values.
        let (mut curvature, mut linear, mut support) = (0.0_f64, 0.0_f64, 0.0_f64);
        for ((px, q), x) in px.iter().zip(&self.q).zip(&p.x) {
            curvature += px.wide() * x.wide();
            linear += q.wide() * x.wide();
        }
        for (y, z) in p.y.iter().zip(&p.z) {
            support += y.wide() * z.wide();
        }
        (
            amax(&primal) / (1.0 + amax(&cx).max(amax(&p.z))),
            amax(&dual) / (1.0 + amax(&px).max(amax(&self.q)).max(amax(&cty))),
            ipm::relative_gap(
                (curvature + linear + support).abs(),
                0.5 * curvature + linear,
            ),
        )
    }

    /// OSQP's primal infeasibility test (§3.4) on the last change of y: δy projected on the polar of
    /// the bounds' recession cone, δy ≠ 0, ‖Cᵀδy‖∞ ≤ ε‖δy‖∞ and uᵀδy₊ + lᵀδy₋ ≤ −ε‖δy‖∞.
    pub fn infeasible(&self, p: &Iterate<T>) -> bool {
        let dy: Vec<T> = (0..self.rows())
            .map(|i| {
                let (lo, hi, d) = (self.lower[i].wide(), self.upper[i].wide(), p.dy[i]);
                match (lo.is_finite(), hi.is_finite()) {
                    (false, false) => T::ZERO,
                    (true, false) => clamp(d, -T::of(f64::INFINITY), T::ZERO),
                    (false, true) => clamp(d, T::ZERO, T::of(f64::INFINITY)),
                    (true, true) => d,
                }
            })
            .collect();
        let norm = dy.iter().fold(0.0_f64, |m, v| m.max(v.wide().abs()));
        if norm.is_nan() || norm <= INFEASIBILITY_TOLERANCE {
            return false;
        }
        let support: f64 = (0..self.rows())
            .map(|i| {
                let d = dy[i].wide();
                if d > 0.0 {
                    self.upper[i].wide() * d
                } else if d < 0.0 {
                    self.lower[i].wide() * d
                } else {
                    0.0
                }
            })
            .sum();
        let ct = self.Ct(&dy);
        let ctn = ct.iter().fold(0.0_f64, |m, v| m.max(v.wide().abs()));
        support <= -INFEASIBILITY_TOLERANCE * norm && ctn <= INFEASIBILITY_TOLERANCE * norm
    }

    /// The iterate a start gives (`None` when its sizes do not fit).
    pub fn start(&self, start: &Start) -> Option<Iterate<T>> {
        let rows = self.rows();
        let (x, z, y) = match start {
            Start::Cold => {
                let x = vec![T::ZERO; self.n];
                let z = self
                    .C(&x)
                    .iter()
                    .enumerate()
                    .map(|(i, v)| clamp(*v, self.lower[i], self.upper[i]))
                    .collect();
                (x, z, vec![T::ZERO; rows])
            }
            Start::Warm { x, z, y } => {
                if x.len() != self.n || z.len() != rows || y.len() != rows {
                    return None;
                }
                let t = |v: &DVector<f64>| v.iter().map(|a| T::of(*a)).collect::<Vec<T>>();
                (t(x), t(z), t(y))
            }
        };
        Some(Iterate {
            x,
            z,
            y,
            dy: vec![T::ZERO; rows],
        })
    }
}

/// The iteration's state in T.
#[derive(Clone, Debug)]
pub struct Iterate<T> {
    /// x (n).
    pub x: Vec<T>,
    /// z (rows of C).
    pub z: Vec<T>,
    /// y (rows of C).
    pub y: Vec<T>,
    /// The last change of y (for the infeasibility test).
    pub dy: Vec<T>,
}

/// Where the iteration starts.
#[derive(Clone, Debug)]
pub enum Start {
    /// x = 0, z = Π(C·0), y = 0.
    Cold,
    /// A previous (x, z, y), e.g. [`shifted_start`]'s.
    Warm {
        /// x (n).
        x: DVector<f64>,
        /// z (n + m).
        z: DVector<f64>,
        /// y (n + m).
        y: DVector<f64>,
    },
}

/// How a solve ended: the constrained methods' shared status.
pub use crate::solver::constrained::Status;

/// One iterate, in f64 whatever it was computed in.
#[derive(Clone, Debug)]
pub struct AdmmResult {
    /// x (n): the plan and the slacks.
    pub x: DVector<f64>,
    /// z (n + m).
    pub z: DVector<f64>,
    /// y (n + m).
    pub y: DVector<f64>,
    /// Iterations run.
    pub iterations: usize,
    /// ‖Cx − z‖∞ / (1 + max(‖Cx‖∞, ‖z‖∞)).
    pub primal_residual: f64,
    /// ‖Px + q + Cᵀy‖∞ / (1 + max(‖Px‖∞, ‖q‖∞, ‖Cᵀy‖∞)).
    pub dual_residual: f64,
    /// The duality gap |xᵀPx + qᵀx + yᵀz| relative to max(1, |½xᵀPx + qᵀx|).
    pub gap: f64,
    /// How it ended.
    pub status: Status,
}

fn result<T: Real>(op: &Operator<T>, p: &Iterate<T>, k: usize, status: Status) -> AdmmResult {
    let wide = |v: &[T]| DVector::from_iterator(v.len(), v.iter().map(|a| a.wide()));
    let (primal, dual, gap) = op.residuals(p);
    let status = if !(primal.is_finite() && dual.is_finite() && gap.is_finite()) {
        Status::NumericalFailure
    } else {
        status
    };
    AdmmResult {
        x: wide(&p.x),
        z: wide(&p.z),
        y: wide(&p.y),
        iterations: k,
        primal_residual: primal,
        dual_residual: dual,
        gap,
        status,
    }
}

fn failure(qp: &InequalityQp, iterations: usize) -> AdmmResult {
    let rows = qp.n() + qp.A.nrows();
    AdmmResult {
        x: DVector::zeros(qp.n()),
        z: DVector::zeros(rows),
        y: DVector::zeros(rows),
        iterations,
        primal_residual: f64::INFINITY,
        dual_residual: f64::INFINITY,
        gap: f64::INFINITY,
        status: Status::NumericalFailure,
    }
}

/// Exactly `iterations` iterations in T (no early exit, as the emitted solver); the status says whether
/// the last one is finite and whether the rows were found infeasible.
pub fn solve_fixed<T: Real>(
    qp: &InequalityQp,
    settings: &Settings,
    start: &Start,
    iterations: usize,
) -> AdmmResult {
    let Some(op) = Operator::<T>::new(qp, settings) else {
        return failure(qp, 0);
    };
    run(&op, start, iterations, &mut |_, _| false).unwrap_or_else(|| failure(qp, 0))
}

/// Iterates until both relative residuals are at most `tolerance` (checked every iteration), at most
/// `max_iterations`, in f64.
pub fn solve(
    qp: &InequalityQp,
    settings: &Settings,
    start: &Start,
    tolerance: f64,
    max_iterations: usize,
) -> AdmmResult {
    let Some(op) = Operator::<f64>::new(qp, settings) else {
        return failure(qp, 0);
    };
    let mut last = None;
    let r = run(&op, start, max_iterations, &mut |p, k| {
        let (a, b, _) = op.residuals(p);
        let done = a <= tolerance && b <= tolerance;
        if done {
            last = Some(result(&op, p, k, Status::Converged));
        }
        done
    });
    last.or(r).unwrap_or_else(|| failure(qp, 0))
}

/// Runs from `start`; `stop(iterate, k)` after each iteration may end the run early.
fn run<T: Real>(
    op: &Operator<T>,
    start: &Start,
    iterations: usize,
    stop: &mut dyn FnMut(&Iterate<T>, usize) -> bool,
) -> Option<AdmmResult> {
    let mut p = op.start(start)?;
    for k in 0..iterations {
        op.iterate(&mut p);
        if stop(&p, k + 1) {
            return Some(result(op, &p, k + 1, Status::Converged));
        }
    }
    let status = if iterations > 0 && op.infeasible(&p) {
        Status::Infeasible
    } else {
        Status::IterationLimit
    };
    Some(result(op, &p, iterations, status))
}

/// Every iterate from `start`, in T: element k is what `solve_fixed::<T>(qp, settings, start, k)`
/// returns (element 0 the start). Empty when the operator cannot be built.
pub fn trajectory<T: Real>(
    qp: &InequalityQp,
    settings: &Settings,
    start: &Start,
    iterations: usize,
) -> Vec<AdmmResult> {
    let Some(op) = Operator::<T>::new(qp, settings) else {
        return Vec::new();
    };
    let Some(mut p) = op.start(start) else {
        return Vec::new();
    };
    let mut out = vec![result(&op, &p, 0, Status::IterationLimit)];
    for k in 0..iterations {
        op.iterate(&mut p);
        let status = if op.infeasible(&p) {
            Status::Infeasible
        } else {
            Status::IterationLimit
        };
        out.push(result(&op, &p, k + 1, status));
    }
    out
}

/// The multipliers y of C's rows from the interior-point method's side multipliers (y_i = λ_upper −
/// λ_lower): the exact dual a warm start can carry.
pub fn duals_from_ipm(qp: &InequalityQp, r: &IpmResult) -> DVector<f64> {
    let n = qp.n();
    let layout = Layout::of(qp);
    let mut y = DVector::zeros(n + qp.A.nrows());
    if r.lambda.len() != layout.boxed.len() + layout.rows.len() {
        return y;
    }
    for (k, (i, sign)) in layout.boxed.iter().enumerate() {
        y[*i] += sign * r.lambda[k];
    }
    let nb = layout.boxed.len();
    for (k, (row, sign)) in layout.rows.iter().enumerate() {
        y[n + row] += sign * r.lambda[nb + k];
    }
    y
}

/// Multiply-adds of one iteration by the calibration rule of issue 17 (mat-vec n², sparse products
/// their nonzeros, a few per element): K·rhs n², Cᵀ(·) and C x̃ nnz(A) each, about 3 per unknown
/// (rhs, x) and 5 per row of C (the relaxation, the projection, y). The final residuals (once a solve)
/// are not included: [`residual_macs`]. K·rhs is the two triangular solves with L, n² together. The
/// residual form adds P x (n²) and C x (nnz(A), and one per row of C for z − Cx).
pub fn macs_per_iteration(qp: &InequalityQp, form: Form) -> usize {
    let n = qp.n();
    let nnz = qp.A.iter().filter(|v| **v != 0.0).count();
    let direct = n * n + 2 * nnz + 3 * n + 5 * (n + qp.A.nrows());
    match form {
        Form::Direct => direct,
        Form::Residual => direct + n * n + nnz + n + qp.A.nrows(),
    }
}

/// Multiply-adds of the final residuals and the infeasibility test: P x (n²), C x, Cᵀy and Cᵀδy.
pub fn residual_macs(qp: &InequalityQp) -> usize {
    let n = qp.n();
    let nnz = qp.A.iter().filter(|v| **v != 0.0).count();
    n * n + 3 * nnz + 4 * (n + qp.A.nrows())
}

/// [`macs_per_iteration`] with the x-update in the settings' structure: the stage-wise [`Program`]'s
/// multiply-adds replace K·rhs and the products with C and Cᵀ.
pub fn settings_macs_per_iteration(qp: &InequalityQp, settings: &Settings) -> usize {
    match &settings.stages {
        Some(program) => staged_macs_per_iteration(qp, program),
        None => macs_per_iteration(qp, settings.form),
    }
}

/// [`macs_per_iteration`] with the stage-wise x-update `program`: the program computes w and the
/// right-hand side; the relaxation, the projection and y are left.
fn staged_macs_per_iteration(qp: &InequalityQp, program: &Program) -> usize {
    program.macs() + qp.n() + 4 * (qp.n() + qp.A.nrows())
}

/// [`settings_macs_per_iteration`] of the MPC's QP.
pub fn mpc_settings_macs_per_iteration(qp: &Qp, settings: &Settings) -> usize {
    settings_macs_per_iteration(&zero_data(qp), settings)
}

/// [`macs_per_iteration`] of the MPC's QP ([`ipm::mpc_qp`]), whose structure does not depend on the
/// data, in the form and structure its certificate chose (condensed and direct before it is
/// certified).
pub fn mpc_macs_per_iteration(qp: &Qp) -> usize {
    match certified_settings(qp) {
        Some(settings) => settings_macs_per_iteration(&zero_data(qp), &settings),
        None => mpc_macs_per_iteration_in(qp, Form::Direct),
    }
}

/// [`macs_per_iteration`] of the MPC's QP in `form`.
pub fn mpc_macs_per_iteration_in(qp: &Qp, form: Form) -> usize {
    macs_per_iteration(&zero_data(qp), form)
}

/// [`residual_macs`] of the MPC's QP: once a solve.
pub fn mpc_residual_macs(qp: &Qp) -> usize {
    residual_macs(&zero_data(qp))
}

/// The MPC's QP with zero data (its structure).
fn zero_data(qp: &Qp) -> InequalityQp {
    let n = qp.Nc * qp.u_min.len();
    ipm::mpc_qp(qp, &DVector::zeros(n), &DVector::zeros(qp.rows.len()))
}

/// How a control step made its plan.
pub use crate::solver::constrained::Fallback;

/// One ADMM control step: the plan and what happened.
#[derive(Clone, Debug)]
pub struct Step {
    /// The plan U (N·nu), inside the input box.
    pub plan: DVector<f64>,
    /// The solve (its x includes the slacks).
    pub result: AdmmResult,
    /// Whether the plan is the solve's.
    pub fallback: Fallback,
}

/// The warm start of the next step: the solve's (x, z, y) shifted by one slot (the plan's and the box
/// rows' last step and the rows' last slot repeated, the slacks kept, the rest input appended to x and
/// to the box part of z), or `Cold` after a fallback.
pub fn shifted_start(qp: &Qp, previous: &Step) -> Start {
    let r = &previous.result;
    if previous.fallback != Fallback::Solved {
        return Start::Cold;
    }
    shift(qp, &r.x, &r.z, &r.y)
}

/// (x, z, y) shifted by one slot ([`shifted_start`]).
pub fn shift(qp: &Qp, x: &DVector<f64>, z: &DVector<f64>, y: &DVector<f64>) -> Start {
    let nu = qp.u_min.len();
    let n = qp.Nc * nu;
    let nv = n + qp.rows.slacks();
    let per_slot = qp.rows.per_slot;
    let rest = qp.rest_input();
    let shift_all = |v: &DVector<f64>, rest: Option<&DVector<f64>>| {
        let mut out = v.clone();
        shift_blocks(&mut out.as_mut_slice()[..n], nu);
        if let Some(rest) = rest {
            out.rows_mut(n - nu, nu).copy_from(rest);
        }
        if out.len() > nv {
            shift_blocks(&mut out.as_mut_slice()[nv..], per_slot);
        }
        out
    };
    Start::Warm {
        x: shift_all(x, Some(&rest)),
        z: shift_all(z, Some(&rest)),
        y: shift_all(y, None),
    }
}

/// Moves every block of `width` up by one, the last block kept.
fn shift_blocks(v: &mut [f64], width: usize) {
    if width == 0 || v.len() <= width {
        return;
    }
    v.copy_within(width.., 0);
}

/// One control step in T: `iterations` from `start`, then the plan projected onto the box, or the
/// fallback to `previous_plan` shifted (rest input appended) when the iterate is not finite, the rows
/// were found infeasible, or the residuals end above `limits`.
#[allow(clippy::too_many_arguments)]
pub fn control_step<T: Real>(
    qp: &Qp,
    settings: &Settings,
    f: &DVector<f64>,
    offset: &DVector<f64>,
    start: &Start,
    previous_plan: &DVector<f64>,
    iterations: usize,
    limits: &Limits,
    recovering: bool,
) -> Step {
    let held = ipm::held_plan(qp, previous_plan);
    let relax = recovering && ipm::violations(qp, &held, offset).0 > qp.accuracy;
    let mut problem = ipm::mpc_qp(qp, f, offset);
    if relax {
        problem = ipm::relaxed(qp, problem, &held);
    }
    let result = solve_fixed::<T>(&problem, settings, start, iterations);
    let n = f.len();
    let trusted = matches!(result.status, Status::IterationLimit | Status::Converged)
        && result.primal_residual <= limits.primal
        && result.dual_residual <= limits.dual
        && result.gap <= limits.gap;
    let nu = qp.u_min.len();
    if trusted {
        return Step {
            plan: DVector::from_fn(n, |i, _| {
                crate::linalg::project(result.x[i], qp.u_min[i % nu], qp.u_max[i % nu])
            }),
            result,
            fallback: if relax {
                Fallback::Relaxed
            } else {
                Fallback::Solved
            },
        };
    }
    Step {
        plan: held,
        result,
        fallback: Fallback::WarmStart,
    }
}

/// A problem ρ is tuned on: the QP, its exact solution, where the iteration starts, and how its
/// accuracy is judged.
#[derive(Clone, Debug)]
pub struct Case {
    /// The QP.
    pub qp: InequalityQp,
    /// Its exact solution (n).
    pub exact: DVector<f64>,
    /// Where the iteration starts.
    pub start: Start,
    /// The plan's entries (the first `span.len()` of x) and their spans u_max − u_min.
    pub span: DVector<f64>,
}

impl Case {
    /// |U − U*|∞ / span, and the worst violation of a hard row (no slack) by the projected plan
    /// (slacks zero), relative to max(1, |bound|).
    pub fn accuracy_of(&self, x: &DVector<f64>) -> (f64, f64) {
        let qp = &self.qp;
        let n = self.span.len();
        if x.len() != qp.n() || x.iter().any(|v| !v.is_finite()) {
            return (f64::INFINITY, f64::INFINITY);
        }
        let U = DVector::from_fn(qp.n(), |i, _| {
            if i < n {
                crate::linalg::project(x[i], qp.z_min[i], qp.z_max[i])
            } else {
                0.0
            }
        });
        let error = (0..n)
            .map(|i| (U[i] - self.exact[i]).abs() / self.span[i])
            .fold(0.0, f64::max);
        let mut violation: f64 = 0.0;
        for r in 0..qp.A.nrows() {
            let row = qp.A.row(r);
            if (n..qp.n()).any(|j| row[j] != 0.0) {
                continue;
            }
            let a = row.transpose().dot(&U);
            if qp.upper[r].is_finite() {
                violation = violation.max((a - qp.upper[r]) / qp.upper[r].abs().max(1.0));
            }
            if qp.lower[r].is_finite() {
                violation = violation.max((qp.lower[r] - a) / qp.lower[r].abs().max(1.0));
            }
        }
        (error, violation)
    }

    /// The iterations the case needs in T with `settings`: the first k from which every iterate meets
    /// `accuracy`, observed until the error has stayed below half of it for as many iterations again
    /// as it took to get there (at least 20); `None` when that does not happen within `cap`.
    pub fn needed<T: Real>(&self, settings: &Settings, accuracy: f64, cap: usize) -> Option<usize> {
        self.needed_counted::<T>(settings, accuracy, cap, &mut 0)
    }

    /// [`Case::needed`], adding the iterations it ran to `run` (the build's budget counts them).
    pub fn needed_counted<T: Real>(
        &self,
        settings: &Settings,
        accuracy: f64,
        cap: usize,
        run: &mut usize,
    ) -> Option<usize> {
        let op = Operator::<T>::new(&self.qp, settings)?;
        let mut p = op.start(&self.start)?;
        let wide = |v: &[T]| DVector::from_iterator(v.len(), v.iter().map(|a| a.wide()));
        let mut last_bad = 0;
        let mut settled_since: Option<usize> = None;
        for k in 0..=cap {
            if k > 0 {
                op.iterate(&mut p);
                *run += 1;
            }
            let (e, v) = self.accuracy_of(&wide(&p.x));
            if !(e <= accuracy && v <= accuracy) {
                last_bad = k;
            }
            if e <= 0.5 * accuracy && v <= 0.5 * accuracy {
                let since = *settled_since.get_or_insert(k);
                if k - since >= since.max(20) {
                    return Some((last_bad + 1).max(1));
                }
            } else {
                settled_since = None;
            }
        }
        None
    }
}

/// What [`tune_rho`] measured.
#[derive(Clone, Debug)]
pub struct Tuning {
    /// The chosen ρ (each row's penalty is ρ times [`row_scales`]).
    pub rho: f64,
    /// The worst count over the cases at `rho`.
    pub worst: usize,
    /// Every ρ tried with its worst count (`None`: some case missed within the cap).
    pub grid: Vec<(f64, Option<usize>)>,
    /// Iterations run over every trial and case (the search's cost).
    pub iterations_run: usize,
}

/// ρ measured on `cases`: the worst iteration count (in f64, [`Case::needed`]) over a log-spaced grid
/// 10⁻⁴ … 10⁴ (decades), then refined twice around the best (factors √10, then 10^¼). A candidate stops
/// being run once a case needs more than the best so far, so the search costs little more than the
/// winner's runs. `settings(qp, ρ)` gives the settings of a ρ ([`Settings::scaled`]); `cap` bounds a run.
pub fn tune_rho(
    cases: &[Case],
    settings: &(dyn Fn(&InequalityQp, f64) -> Settings + Sync),
    accuracy: f64,
    cap: usize,
) -> Option<Tuning> {
    tune_rho_within(cases, settings, accuracy, cap, usize::MAX).ok()
}

/// Why [`tune_rho_within`] found no ρ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Untuned {
    /// No ρ of the grid reaches `accuracy` within the cap on every case.
    NoRho,
    /// The search would have run past its most iterations (it had run this many when it stopped).
    OverBudget(usize),
}

/// [`tune_rho`] within `most` iterations over all cases and trials: no trial starts that could run
/// past it (each case runs at most as long as the budget left shares out), so the search spends at
/// most `most` iterations, and says so when it stops short.
pub fn tune_rho_within(
    cases: &[Case],
    settings: &(dyn Fn(&InequalityQp, f64) -> Settings + Sync),
    accuracy: f64,
    cap: usize,
    most: usize,
) -> Result<Tuning, Untuned> {
    let mut grid: Vec<(f64, Option<usize>)> = Vec::new();
    let mut best: Option<(f64, usize)> = None;
    let mut iterations_run = 0;
    let mut over = false;
    let mut trial = |rho: f64,
                     grid: &mut Vec<(f64, Option<usize>)>,
                     best: &mut Option<(f64, usize)>| {
        // A count is known once the error has stayed settled for as long again ([`Case::needed`]),
        // so a candidate that may beat the best count w runs up to about 2w.
        let limit = best.map_or(cap, |(_, w)| w.min(cap));
        let run = best.map_or(cap, |(_, w)| (2 * w + 20).min(cap));
        // Each case runs at most its share of what the budget leaves; a case that misses when its
        // share, not the cap, stopped it may be the budget's doing, and the search then says so.
        let share = most.saturating_sub(iterations_run) / cases.len().max(1);
        let truncated = share < run;
        let (limit, run) = (limit.min(share), run.min(share));
        let mut worst = 0;
        // The cases on every core; their iterations are counted in order up to the first that
        // misses, as a loop over them would.
        let runs = crate::certify::parallel::until_failure(
            cases,
            |c| {
                let mut iterations = 0;
                let k =
                    c.needed_counted::<f64>(&settings(&c.qp, rho), accuracy, run, &mut iterations);
                (k.filter(|&k| k <= limit), iterations)
            },
            |(k, _)| k.is_none(),
        );
        for (k, iterations) in runs {
            iterations_run += iterations;
            match k {
                Some(k) => worst = worst.max(k),
                None => {
                    grid.push((rho, None));
                    over |= truncated;
                    return;
                }
            }
        }
        grid.push((rho, Some(worst)));
        if best.is_none_or(|(_, w)| worst < w) {
            *best = Some((rho, worst));
        }
    };
    for e in -4..=4 {
        trial(10f64.powi(e), &mut grid, &mut best);
    }
    for factor in [10f64.sqrt(), 10f64.powf(0.25)] {
        let Some((centre, _)) = best else { break };
        for rho in [centre / factor, centre * factor] {
            trial(rho, &mut grid, &mut best);
        }
    }
    if over {
        return Err(Untuned::OverBudget(iterations_run));
    }
    let (rho, worst) = best.ok_or(Untuned::NoRho)?;
    Ok(Tuning {
        rho,
        worst,
        grid,
        iterations_run,
    })
}

/// The settings of the MPC's QP at penalty `rho` ([`Settings::scaled`] on its structure: the row
/// scales depend on H and the rows, not on the data).
pub fn mpc_settings(qp: &Qp, rho: f64) -> Settings {
    Settings::scaled(&zero_data(qp), rho)
}

/// What the certificate of an ADMM problem chose (`None` before it is certified, or for another
/// method).
pub fn tuning(qp: &Qp) -> Option<Tuned> {
    let e = qp.evidence.as_ref()?;
    Some(Tuned {
        rho: e.rho?,
        form: e.admm_form?,
    })
}

/// ADMM's build-time choices, which the emitter and the oracle run with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tuned {
    /// The penalty ρ ([`tune_rho`]).
    pub rho: f64,
    /// The x-update's form.
    pub form: Form,
}

/// The settings a certified ADMM problem runs with: [`tuned_settings`] of what its certificate chose
/// (`None` before it is certified, or for another method).
pub fn certified_settings(qp: &Qp) -> Option<Settings> {
    Some(tuned_settings(qp, tuning(qp)?))
}

/// The structure of a certified ADMM problem's x-update (condensed for another method).
pub fn structure(qp: &Qp) -> Structure {
    certified_settings(qp).map_or(Structure::Condensed, |s| s.structure())
}

/// [`mpc_settings`] at `tuned`'s ρ in its form, the x-update in the structure [`StructureChoice`]
/// picks.
pub fn tuned_settings(qp: &Qp, tuned: Tuned) -> Settings {
    let settings = mpc_settings(qp, tuned.rho).in_form(tuned.form);
    let choice = StructureChoice::of(qp, &settings);
    Settings {
        stages: choice.program.map(Arc::new),
        ..settings
    }
}

/// The cost model's choice of the x-update's [`Structure`], with both counts.
#[derive(Clone, Debug, serde::Serialize)]
pub struct StructureChoice {
    /// The structure used: the stage-wise one where it is built for the problem and counts fewer
    /// multiply-adds an iteration.
    pub structure: Structure,
    /// Multiply-adds of one iteration, condensed.
    pub condensed_macs_per_iteration: usize,
    /// Multiply-adds of one iteration, stage-wise (`None` where it is not built).
    pub riccati_macs_per_iteration: Option<usize>,
    /// Why the stage-wise x-update is not built for the problem.
    pub riccati_unavailable: Option<String>,
    /// The stage-wise program, where chosen.
    #[serde(skip)]
    pub program: Option<Program>,
}

impl StructureChoice {
    /// The choice for `qp` with `settings` (their ρ, σ and form; their structure is ignored).
    pub fn of(qp: &Qp, settings: &Settings) -> Self {
        let structure_qp = zero_data(qp);
        let condensed = Settings {
            stages: None,
            ..settings.clone()
        };
        let condensed_macs = settings_macs_per_iteration(&structure_qp, &condensed);
        match stages::program(qp, settings) {
            Ok(program) => {
                let riccati = staged_macs_per_iteration(&structure_qp, &program);
                let chosen = riccati < condensed_macs;
                StructureChoice {
                    structure: if chosen {
                        Structure::Riccati
                    } else {
                        Structure::Condensed
                    },
                    condensed_macs_per_iteration: condensed_macs,
                    riccati_macs_per_iteration: Some(riccati),
                    riccati_unavailable: None,
                    program: chosen.then_some(program),
                }
            }
            Err(why) => StructureChoice {
                structure: Structure::Condensed,
                condensed_macs_per_iteration: condensed_macs,
                riccati_macs_per_iteration: None,
                riccati_unavailable: Some(why),
                program: None,
            },
        }
    }
}
