//! Planning: what the emitted solver is made of, decided once from the lowered problem. It resolves the
//! algorithm ([`crate::solver`]) and the gradient form ([`crate::form`]): `emission = "auto"` becomes the
//! cost model's choice, a forced `lanes` is checked against H's structure, and nothing after this step
//! sees `auto`.
#![allow(non_snake_case)]

use crate::cost::{self, Estimate};
use crate::form::{
    self, lanes::Lanes, matrix_free::MatrixFree, table::Table, unrolled::Unrolled, Form,
};
use crate::problem::Problem;
use crate::solver::{self, Algorithm};
use crate::structure::{kronecker_identity, NotKronecker};
use mpc_spec::{Diagnostic, Diagnostics, Emission, Span, Spec};

/// Multiply-adds of one ADMM kernel (C·x and Cᵀ·v: one per nonzero of A; K·b: NV² of the two triangular
/// solves; the stage-wise x-update: its program's terms) up to which it is written out, one statement per
/// output with the coefficients as literals and every index a constant; past it the kernel loops over
/// tables. At about 10 bytes a multiply-add this is at most ~160 KB of code per kernel.
pub const WRITE_OUT_BUDGET: usize = 16_384;

/// The solver the module is made of.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The first-order algorithm (the spec's `method`); `None` for the interior-point method, which
    /// ignores the gradient form.
    pub algorithm: Option<&'static dyn Algorithm>,
    /// How the gradient is emitted: the spec's forced choice, or the cost model's.
    pub form: Form,
    /// The cost model's estimate of every form, in the order of [`Emission`].
    pub estimates: Vec<Estimate>,
    /// The largest ADMM kernel written out statement by statement; past it, loops over tables
    /// ([`crate::Opt::write_out_budget`]).
    pub write_out_budget: usize,
}

impl Plan {
    /// The chosen form's `[codegen] emission`.
    pub fn emission(&self) -> Emission {
        self.form.emission()
    }

    /// Entries per plan step in the emitted code.
    pub fn plan_lanes(&self, p: &Problem) -> usize {
        self.form.gradient().plan_lanes(p)
    }

    /// The chosen form's estimate.
    pub fn estimate(&self) -> &Estimate {
        let emission = self.emission();
        self.estimates
            .iter()
            .find(|e| e.emission == emission)
            .unwrap_or(&self.estimates[0])
    }
}

/// Plans the solver of `p`, lowered from `spec`. Fails when `emission = "lanes"` is forced on an H
/// without the lane structure, naming the entry that breaks it.
pub fn plan(spec: &Spec, p: &Problem) -> Result<Plan, Diagnostics> {
    let H_axis = kronecker_identity(&p.qp.H, p.nu);
    let estimates = form::estimates(p, H_axis.as_ref().ok());
    let emission = match spec.codegen.emission {
        Emission::Auto => cost::choose(&estimates),
        forced => forced,
    };
    let form = match (emission, H_axis) {
        (Emission::Lanes, Ok(H_axis)) => Form::Lanes(Lanes { H_axis }),
        (Emission::Lanes, Err(e)) => {
            return Err(no_lanes(&e, p.nu, spec.spans.get("codegen.emission")).into())
        }
        (Emission::Unrolled, _) => Form::Unrolled(Unrolled),
        (Emission::MatrixFree, _) => Form::MatrixFree(MatrixFree),
        (Emission::Table | Emission::Auto, _) => Form::Table(Table),
    };
    Ok(Plan {
        algorithm: solver::algorithm(p.qp.method),
        form,
        estimates,
        write_out_budget: WRITE_OUT_BUDGET,
    })
}

/// The located error for `emission = "lanes"` on an H without the lane structure, naming the entry.
fn no_lanes(e: &NotKronecker, nu: usize, span: Option<Span>) -> Diagnostic {
    let (r, c) = e.entry;
    let label = if r % nu == c % nu {
        format!(
            "H[{r}][{c}] = {:.6e}: input {}'s weight between steps {} and {} differs from input 0's ({:.6e})",
            e.value,
            r % nu,
            r / nu,
            c / nu,
            e.expected
        )
    } else {
        format!(
            "H[{r}][{c}] = {:.6e} couples input {} at step {} with input {} at step {}",
            e.value,
            r % nu,
            r / nu,
            c % nu,
            c / nu
        )
    };
    Diagnostic::new(
        format!("`emission = \"lanes\"` needs H = H_axis ⊗ I_{nu}, and this H is not one"),
        span,
    )
    .label(label)
    .note("hint: the lanes need independent inputs with equal weights and dynamics; write `emission = \"auto\"` to let the compiler choose")
}
