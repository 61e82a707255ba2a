//! The gradient forms: how ∇J = H·U + f is emitted, one file each behind [`GradientForm`].
//!
//! - [`unrolled`]: one multiply-add per nonzero of H, each coefficient inlined.
//! - [`table`]: a loop over H as a constant table, column by column.
//! - [`lanes`]: H = H_axis ⊗ I; the inputs run side by side in SIMD lanes over one N × N table, one fused
//!   pass per iteration (gradient row, then the algorithm's step for that row).
//! - [`matrix_free`]: no H; a forward sweep of the dynamics and a backward adjoint sweep, O(N).
//!
//! The target's SIMD lives in [`neon`]. Each form also gives its estimate to the cost model
//! ([`crate::plan::cost`]); [`crate::plan()`] chooses one.
#![allow(non_snake_case)]

pub mod lanes;
pub mod matrix_free;
pub mod neon;
pub mod table;
pub mod unrolled;

use crate::emit::tokens::Num;
use crate::lower::problem::Problem;
use crate::numeric::Numeric;
use crate::plan::cost::Estimate;
use crate::solver::first_order::Algorithm;
use mpc_spec::Emission;
use nalgebra::DMatrix;
use proc_macro2::TokenStream;
use quote::quote;

/// A gradient form, resolved: never `auto`, and `lanes` carries its table.
#[derive(Clone, Debug)]
pub enum Form {
    /// [`unrolled::Unrolled`].
    Unrolled(unrolled::Unrolled),
    /// [`table::Table`].
    Table(table::Table),
    /// [`lanes::Lanes`].
    Lanes(lanes::Lanes),
    /// [`matrix_free::MatrixFree`].
    MatrixFree(matrix_free::MatrixFree),
}

impl Form {
    /// The form behind its trait.
    pub fn gradient(&self) -> &dyn GradientForm {
        match self {
            Form::Unrolled(f) => f,
            Form::Table(f) => f,
            Form::Lanes(f) => f,
            Form::MatrixFree(f) => f,
        }
    }

    /// Its spelling in `[codegen] emission`.
    pub fn emission(&self) -> Emission {
        self.gradient().emission()
    }
}

/// How one gradient form computes f and ∇J, and what it costs.
pub trait GradientForm {
    /// Its `[codegen] emission`.
    fn emission(&self) -> Emission;

    /// Entries per plan step in the emitted code: the NU inputs, or padded SIMD lanes.
    fn plan_lanes(&self, p: &Problem) -> usize {
        p.nu
    }

    /// The kernels of the gradient (and of f).
    fn kernels(&self, p: &Problem, algorithm: &dyn Algorithm, num: Num) -> TokenStream;

    /// The constant tables the kernels read, besides the module's `H`.
    fn tables(&self, _p: &Problem, _num: Num) -> TokenStream {
        quote!()
    }

    /// The statements before the iterations: f from `x0`, `xref` (and `d`).
    fn prepare(&self, p: &Problem) -> TokenStream;

    /// The statement that writes ∇J at the algorithm's point into `g`.
    fn gradient_call(&self, p: &Problem, algorithm: &dyn Algorithm) -> TokenStream;

    /// The solver loop: the algorithm's, around this form's gradient.
    fn iterations(&self, p: &Problem, algorithm: &dyn Algorithm) -> TokenStream {
        algorithm.iterations(
            &self.gradient_call(p, algorithm),
            &crate::emit::plan_steps(p),
        )
    }

    /// Whether the emitted code has NEON kernels (under `cfg(mpc_neon)`): by default, where the sweeps
    /// that compute f run in lanes.
    fn uses_neon(&self, p: &Problem) -> bool {
        matrix_free::uses_neon(p, self.plan_lanes(p))
    }

    /// Whether the algorithm's separate step kernel is used (a fused form inlines its own).
    fn separate_step(&self) -> bool {
        true
    }

    /// Multiply-adds of f per control cycle and the coefficients it inlines or tabulates: by default one
    /// pass of the matrix-free sweeps (f = ∇J(0)) and the chosen form's tables.
    fn gradient_map(&self, p: &Problem, estimates: &[Estimate]) -> (usize, usize) {
        let num = Numeric(p.scalar);
        let sweep = estimates
            .iter()
            .find(|e| e.emission == Emission::MatrixFree)
            .map_or(0, |e| e.macs);
        let tables = estimates
            .iter()
            .find(|e| e.emission == self.emission())
            .map_or(0, |e| e.table_bytes / num.bytes());
        let qp = &p.qp;
        let model = [&p.F, &p.G, &qp.Q, &qp.Qf, &qp.R]
            .iter()
            .map(|M| num.coefficients(M))
            .sum::<usize>();
        (sweep, tables + model)
    }
}

/// Every form's estimate, in the order of [`Emission`]; `H_axis` when H = H_axis ⊗ I.
pub fn estimates(p: &Problem, H_axis: Option<&DMatrix<f64>>) -> Vec<Estimate> {
    let mut estimates = vec![
        unrolled::estimate(p),
        table::estimate(p),
        lanes::estimate(p, H_axis),
        matrix_free::estimate(p),
    ];
    if let Some(why) = per_step_refusal(p) {
        for e in estimates.iter_mut() {
            if matches!(e.emission, Emission::Lanes | Emission::MatrixFree) {
                e.unavailable = Some(why.clone());
            }
        }
    }
    estimates
}

/// Why the forms that run over the N steps one input each (`lanes`, `matrix_free`) are not built: a
/// control horizon or move blocking, whose plan holds fewer blocks than steps. `None` where they are.
pub fn per_step_refusal(p: &Problem) -> Option<String> {
    p.qp.blocked().then(|| {
        format!(
            "{}: the plan holds {} inputs for N = {} steps",
            p.qp.blocking_written(),
            p.qp.Nc,
            p.qp.N
        )
    })
}

/// Lanes of the `lanes` form: the input's components padded to a power of two, so that three axes fill
/// one 4-lane register.
pub fn lane_count(nu: usize) -> usize {
    nu.next_power_of_two()
}

/// The arguments f depends on besides `x0` and `xref`: `d,` with a disturbance estimate, `last,` (the last
/// input u₋₁) with weighted moves.
pub(crate) fn linear_args(p: &Problem) -> TokenStream {
    let d = (p.nd() > 0).then(|| quote!(d,));
    let last = p.has_moves().then(|| quote!(last,));
    quote!(#d #last)
}

/// The parameters of [`linear_args`]: `d: &[Real; ND],`, `last: &[Real; NU],`.
pub(crate) fn linear_params(p: &Problem) -> TokenStream {
    let d = (p.nd() > 0).then(|| quote!(d: &[Real; ND],));
    let last = p.has_moves().then(|| quote!(last: &[Real; NU],));
    quote!(#d #last)
}

/// The columns of a reference window row: `NZ` with `[mpc] outputs`, else `NX`.
pub(crate) fn reference_row(p: &Problem) -> TokenStream {
    if p.qp.Cz.is_some() {
        quote!(NZ)
    } else {
        quote!(NX)
    }
}
