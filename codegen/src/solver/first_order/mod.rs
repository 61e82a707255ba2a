//! The first-order methods: projected gradient and Nesterov's fast gradient method on the input box, one
//! file each behind [`Algorithm`], and the gradient forms ([`form`]) they share.
//!
//! An algorithm owns everything it decides: its parameters (the momentum for a step), the check that
//! the spec's step converges, its terms of the certificate (the a priori rate and the asymptotic
//! contraction), its f64 reference iteration (the one the oracle runs and the certificate's solver-loop
//! analysis unrolls), its cost per iteration, and the tokens of its state and of its iteration. The
//! gradient forms call it: a separate step after a gradient, or a per-row fragment that a fused pass
//! inlines.
//!
//! Adding a first-order algorithm is one file here, one [`mpc_spec::Method`] variant (with its spelling
//! in `mpc_spec::model`) and one arm in [`crate::plan::of`].
#![allow(non_snake_case)]

pub mod emit;
mod fgm;
pub mod form;
mod gradient;
pub mod method;
pub mod reference;
pub mod sampled;

pub use fgm::Fgm;
pub use gradient::Gradient;

use mpc_spec::Method;
use nalgebra::{DMatrix, DVector};
use proc_macro2::{Ident, Literal, TokenStream};
use std::fmt::Debug;

/// A bound Δ_k ≤ constant · factor^k · Δ_0 on the gap Δ_k = J(U_k) − J* of the box-constrained QP.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
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

/// What an algorithm runs with: the step, its momentum, and the Hessian's extreme eigenvalues.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Parameters {
    /// The step α.
    pub step: f64,
    /// The momentum β (zero without momentum).
    pub momentum: f64,
    /// μ = λmin(H).
    pub mu: f64,
    /// L = λmax(H).
    pub L: f64,
}

/// Whether the step is within 1/L, where the a priori bounds hold.
fn bounded_step(step: f64, L: f64) -> bool {
    step <= (1.0 / L) * (1.0 + 1e-12)
}

/// A point of the reference iteration: a plan, or for the solver-loop analysis a matrix whose columns
/// are plans (the iteration is linear there).
pub trait Point: Clone {
    /// self + β·(self − previous).
    fn extrapolate(&self, previous: &Self, beta: f64) -> Self;
}

impl Point for DVector<f64> {
    fn extrapolate(&self, previous: &Self, beta: f64) -> Self {
        self + (self - previous) * beta
    }
}

impl Point for DMatrix<f64> {
    fn extrapolate(&self, previous: &Self, beta: f64) -> Self {
        self + (self - previous) * beta
    }
}

/// The gradient step a reference iteration takes from a point: proj(y − α∇J(y)) for the oracle, the
/// unprojected step for the solver-loop analysis.
pub type StepFn<'a, V> = &'a dyn Fn(&V) -> V;

/// A solver algorithm of the condensed QP: min ½UᵀHU + fᵀU over the input box.
pub trait Algorithm: Debug + Sync {
    /// The spec's `method`.
    fn method(&self) -> Method;

    /// Its name in prose: "Nesterov's fast gradient method".
    fn title(&self) -> &'static str;

    /// Its short name in the target's report: "FGM".
    fn name(&self) -> &'static str;

    /// The momentum β for step α on a Hessian whose smallest eigenvalue is μ (zero without momentum).
    fn momentum(&self, step: f64, mu: f64) -> f64;

    /// `None` when the iteration converges with these parameters; else the rule the step breaks, as the error states it ("below 2/L = …").
    fn step_too_large(&self, p: &Parameters) -> Option<String>;

    /// The a priori rate; `None` where it has none (α > 1/L).
    fn rate(&self, p: &Parameters) -> Option<Rate>;

    /// The rate's form, for `mpcc check`: "≤ (1 − αμ)^k · Δ_0".
    fn bound_form(&self) -> &'static str;

    /// The asymptotic contraction of the error along an eigenvalue λ of H, constraints inactive.
    fn contraction_at(&self, p: &Parameters, lambda: f64) -> f64;

    /// `iterations` reference iterations in f64 from `start` (the oracle), `step` the projected step.
    fn reference(
        &self,
        p: &Parameters,
        start: DVector<f64>,
        iterations: usize,
        step: StepFn<DVector<f64>>,
    ) -> DVector<f64>;

    /// The same iterations on a matrix of plans with a linear step: the solver-loop analysis, which needs
    /// the iteration to be linear in the data while no constraint is active. `None` for an algorithm whose
    /// iteration is not (an interior-point method): its loop is then not certified this way.
    fn reference_linear(
        &self,
        p: &Parameters,
        start: DMatrix<f64>,
        iterations: usize,
        step: StepFn<DMatrix<f64>>,
    ) -> Option<DMatrix<f64>>;

    /// Multiply-adds of one iteration besides the gradient, for a plan of `entries` numbers.
    fn update_macs(&self, entries: usize) -> usize;

    /// The doc of the emitted `STEP`.
    fn step_doc(&self, p: &Parameters) -> String;

    /// The doc of the emitted `MOMENTUM`.
    fn momentum_doc(&self, p: &Parameters) -> String;

    /// The buffer the gradient is taken at: `y` (an extrapolated point) or `u`.
    fn point(&self) -> TokenStream;

    /// The solver loop around a separate gradient: its state, then `ITERATIONS` of `gradient_call` and
    /// the step. Starts from the warm start `u` and leaves the plan in `u`.
    /// `steps` names the plan's length ([`crate::emit::plan_steps`]).
    fn iterations(&self, gradient_call: &TokenStream, steps: &TokenStream) -> TokenStream;

    /// The step after a separate gradient `g`, in place over the plan.
    fn step_kernel(&self) -> TokenStream;

    /// The fused iteration's name.
    fn fused_name(&self) -> Ident;

    /// The fused iteration's parameters (plan buffers and f).
    fn fused_params(&self) -> TokenStream;

    /// The fused iteration's doc, for `macs` lane-wise multiply-adds of `lanes` lanes.
    fn fused_doc(&self, macs: usize, lanes: usize) -> String;

    /// The NEON fused iteration's doc.
    fn fused_neon_doc(&self) -> &'static str;

    /// The solver loop over fused iterations: two point buffers swapping roles, in pairs.
    fn fused_iterations(&self) -> TokenStream;

    /// The step of row `i` of a fused pass, `g` its gradient (a `[Real; LANES]`).
    fn fused_row(&self, i: &Literal, g: &Ident) -> TokenStream;

    /// The `core::arch::arm` intrinsics [`Self::fused_row_neon`] calls.
    fn fused_row_neon_intrinsics(&self) -> &'static [&'static str];

    /// The same with NEON intrinsics, `g` a `float32x4_t`.
    fn fused_row_neon(&self, i: &Literal, g: &Ident) -> TokenStream;
}
