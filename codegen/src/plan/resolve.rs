//! Resolving the spec's method to its [`Solver`], and planning the solver.
#![allow(non_snake_case)]

use super::cost;
use super::{Plan, Solver, WRITE_OUT_BUDGET};
use crate::lower::problem::Problem;
use crate::lower::structure::{kronecker_identity, NotKronecker};
use crate::solver::active_set::method::ACTIVE_SET;
use crate::solver::admm::method::ADMM;
use crate::solver::first_order::form::{
    self, lanes::Lanes, matrix_free::MatrixFree, table::Table, unrolled::Unrolled, Form,
};
use crate::solver::first_order::method::{FGM, GRADIENT};
use crate::solver::ipm::method::INTERIOR_POINT;
use mpc_spec::{Diagnostic, Diagnostics, Emission, Method, Span, Spec};

/// The method `method` names: the one place the methods are told apart. `auto` is resolved before any
/// phase asks ([`super::choice`]); it stands for FGM here, the method of a spec without constraints.
pub fn of(method: Method) -> &'static dyn Solver {
    match method {
        Method::Fgm | Method::Auto => &FGM,
        Method::Gradient => &GRADIENT,
        Method::Ipm => &INTERIOR_POINT,
        Method::Admm => &ADMM,
        Method::ActiveSet => &ACTIVE_SET,
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
    if let (Emission::Lanes | Emission::MatrixFree, Some(why)) =
        (emission, form::per_step_refusal(p))
    {
        return Err(Diagnostic::new(
            format!("`emission = \"{}\"` is not built under a control horizon or move blocking", emission.name()),
            spec.spans.get("codegen.emission"),
        )
        .label(why)
        .note("hint: write `emission = \"table\"`, `\"unrolled\"` or `\"auto\"`, or leave out `mpc.control_horizon` (`mpc.move_blocking`)")
        .into());
    }
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
        solver: of(p.qp.method),
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
