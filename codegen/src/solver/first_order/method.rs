//! The first-order methods behind [`Solver`]: one implementation over [`Algorithm`], which the gradient
//! forms call.
#![allow(non_snake_case)]

use super::reference::{iterate, shifted};
use super::{Algorithm, Fgm, Gradient};
use crate::certify::evidence::Evidence;
use crate::certify::sampling;
use crate::emit::sections::Sections;
use crate::emit::tokens::Num;
use crate::lower::problem::{Problem, Qp};
use crate::numeric::Numeric;
use crate::plan::machine::Machine;
use crate::plan::{Plan, Solver};
use crate::solver::stepping::{StepData, Stepping};
use mpc_spec::{Diagnostics, Iterations, Method, Scalar, Spec};
use nalgebra::DVector;
use proc_macro2::TokenStream;
use quote::quote;

/// A first-order method on the input box: its algorithm, and the gradient form the plan chose.
#[derive(Debug)]
pub struct FirstOrder(pub &'static dyn Algorithm);

/// Nesterov's fast gradient method.
pub static FGM: FirstOrder = FirstOrder(&Fgm);

/// Projected gradient.
pub static GRADIENT: FirstOrder = FirstOrder(&Gradient);

impl Solver for FirstOrder {
    fn method(&self) -> Method {
        self.0.method()
    }

    fn title(&self) -> &'static str {
        self.0.title()
    }

    fn name(&self, _qp: &Qp) -> &'static str {
        self.0.name()
    }

    fn first_order(&self) -> Option<&'static dyn Algorithm> {
        Some(self.0)
    }

    fn cycles_per_mac(&self, machine: &Machine, scalar: Scalar, _qp: &Qp) -> f64 {
        machine.cycles_per_mac(scalar)
    }

    fn macs(&self, p: &Problem, plan: &Plan) -> (usize, usize) {
        let plan_entries = p.qp.Nc * plan.plan_lanes(p);
        (plan.estimate().macs + self.0.update_macs(plan_entries), 0)
    }

    fn not_weighed(&self, spec: &Spec, _earlier_usable: bool) -> Option<String> {
        (!spec.mpc.constraints.is_empty())
            .then(|| "solves the input box only, and the spec has constraints".to_string())
    }

    /// Sampled only where `[mpc.region]` is written: its `iterations = "auto"` is then at least the
    /// sample's need for `accuracy`, and at least what `tolerance` guarantees.
    fn certify(&self, spec: &Spec, problem: &Problem) -> Result<Option<Evidence>, Diagnostics> {
        if spec.spans.get("mpc.region").is_none() {
            return Ok(None);
        }
        // The a priori count of `tolerance` (zero without one) is the floor of `auto`.
        let floor = match spec.mpc.iterations {
            Iterations::Auto => problem.qp.iterations,
            Iterations::Fixed(_) => 0,
        };
        sampling::certify(spec, problem, &super::sampled::FirstOrder(self.0), floor).map(Some)
    }

    fn bound_form(&self, rate: bool) -> String {
        if rate {
            self.0.bound_form().to_string()
        } else {
            "none: the step is above 1/L (see the contraction)".to_string()
        }
    }

    fn shape_doc(&self, p: &Problem, plan: &Plan) -> String {
        format!(
            " horizon {}, gradient form `{}` ([`EMISSION`]).",
            p.qp.N,
            plan.emission().name()
        )
    }

    fn largest_table(&self, p: &Problem) -> usize {
        let (nz, nr, na) = (p.qp.Nc * p.nu, p.qp.N * p.qp.nz.max(p.nx), p.nx + p.nd());
        nz.max(na) * nz.max(nr).max(na) * Numeric(p.scalar).bytes()
    }

    fn parameter_constants(&self, p: &Problem, num: Num) -> TokenStream {
        let qp = &p.qp;
        let (step, momentum) = (num.lit(qp.step), num.lit(qp.momentum));
        let step_doc = self.0.step_doc(&qp.parameters());
        let momentum_doc = self.0.momentum_doc(&qp.parameters());
        quote! {
            #[doc = #step_doc]
            pub const STEP: Real = #step;
            #[doc = #momentum_doc]
            pub const MOMENTUM: Real = #momentum;
        }
    }

    fn skeleton_writes_h(&self) -> bool {
        true
    }

    fn emit(&self, p: &Problem, plan: &Plan, num: Num) -> Sections {
        super::emit::emit(p, plan, self.0, num)
    }

    fn oracle_step(&self, qp: &Qp, _state: &mut Stepping, data: StepData) -> DVector<f64> {
        iterate(self.0, qp, data.f, shifted(qp, data.plan), qp.iterations)
    }
}
