//! Planning: what the emitted solver is made of, decided once from the lowered problem. It resolves the
//! method to its [`Solver`] ([`of`], the one place that tells the methods apart) and the gradient form
//! ([`crate::solver::first_order::form`]): `emission = "auto"` becomes the cost model's choice, a forced
//! `lanes` is checked against H's structure, and nothing after this step sees `auto`.
//!
//! The folder also holds what planning weighs: `method = "auto"` ([`choice`]), the cost model of the
//! gradient forms ([`cost`]), and the target's machine ([`machine`]) and step cost ([`target`]).
#![allow(non_snake_case)]

pub mod choice;
pub mod cost;
pub mod machine;
mod resolve;
pub mod target;

pub use resolve::{of, plan};

use self::cost::Estimate;
use self::machine::Machine;
use crate::certify::evidence::Evidence;
use crate::emit::sections::Sections;
use crate::emit::tokens::Num;
use crate::lower::problem::{Problem, Qp};
use crate::solver::first_order::form::Form;
use crate::solver::first_order::Algorithm;
use crate::solver::stepping::{StepData, Stepping};
use mpc_spec::{Diagnostics, Emission, Method, Scalar, Spec};
use nalgebra::DVector;
use proc_macro2::TokenStream;
use std::fmt::Debug;

/// Multiply-adds of one ADMM kernel (C·x and Cᵀ·v: one per nonzero of A; K·b: NV² of the two triangular
/// solves; the stage-wise x-update: its program's terms) up to which it is written out, one statement per
/// output with the coefficients as literals and every index a constant; past it the kernel loops over
/// tables. At about 10 bytes a multiply-add this is at most ~160 KB of code per kernel.
pub const WRITE_OUT_BUDGET: usize = 16_384;

/// The solver the module is made of.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The method ([`of`] the spec's `method`).
    pub solver: &'static dyn Solver,
    /// How the gradient is emitted: the spec's forced choice, or the cost model's.
    pub form: Form,
    /// The cost model's estimate of every form, in the order of [`Emission`].
    pub estimates: Vec<Estimate>,
    /// The largest ADMM kernel written out statement by statement; past it, loops over tables
    /// ([`crate::Opt::write_out_budget`]).
    pub write_out_budget: usize,
}

impl Plan {
    /// The first-order algorithm, which the gradient form calls; `None` for a constrained method, which
    /// ignores the gradient form.
    pub fn algorithm(&self) -> Option<&'static dyn Algorithm> {
        self.solver.first_order()
    }

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

/// The fields of the emitted state types that depend on the method, each (size, alignment) in bytes:
/// every field is an array of f32, f64, u32 or bool, or a struct or one-byte enum of them, so a struct's
/// size is the sum of its fields' rounded up to its largest alignment (no field needs padding before it
/// once the fields are ordered by alignment, as `repr(Rust)` orders them), on the host, the Cortex-A9
/// and the Cortex-M4F alike (f64 is 8-aligned on all three; no field is a `usize`).
#[derive(Clone, Debug, PartialEq)]
pub struct StateFields {
    /// `Mpc`'s fields.
    pub mpc: Vec<(usize, usize)>,
    /// What the method adds to `Status` (the constrained methods' `SolverStatus`).
    pub status: Vec<(usize, usize)>,
}

/// The (size, alignment) of a struct of `fields` under the rule of [`StateFields`].
pub fn layout(fields: &[(usize, usize)]) -> (usize, usize) {
    let align = fields.iter().map(|f| f.1).max().unwrap_or(1);
    let sum: usize = fields.iter().map(|f| f.0).sum();
    (sum.div_ceil(align) * align, align)
}

/// A QP method: everything the phases would otherwise decide by matching on the spec's `method`, from its
/// name and cost to its certificate, its emission and its oracle step. One implementation per method
/// folder of [`crate::solver`]; [`of`] resolves a [`Method`] to it.
///
/// Adding a method is its folder (the algorithm, its sampled certificate, its emitter and this trait's
/// implementation), its [`Method`] variant and spelling in `mpc_spec`, one arm in [`of`], and its tests.
pub trait Solver: Debug + Sync {
    /// The spec's `method`.
    fn method(&self) -> Method;

    /// Its title in the module's docs: "Nesterov's fast gradient method".
    fn title(&self) -> &'static str;

    /// Its name in the target's report and in diagnostics: "the interior-point method", "ADMM (residual
    /// form)" (a tuned ADMM names its form).
    fn name(&self, qp: &Qp) -> &'static str;

    /// The first-order algorithm the gradient forms call; `None` for a constrained method.
    fn first_order(&self) -> Option<&'static dyn Algorithm> {
        None
    }

    /// Whether it computes in f64 whatever the module's scalar is (its tables are f64).
    fn widens(&self) -> bool {
        false
    }

    /// The scalar it computes in, in a module of `scalar`.
    fn scalar(&self, scalar: Scalar) -> Scalar {
        if self.widens() {
            Scalar::F64
        } else {
            scalar
        }
    }

    /// Estimated cycles per multiply-add of its iterations on `machine`, in a module of `scalar`.
    fn cycles_per_mac(&self, machine: &Machine, scalar: Scalar, qp: &Qp) -> f64;

    /// The most iterations one control step runs, which the cost model prices: the certified count,
    /// `qp.iterations`, unless a step may run more (the dual active set's warm solve and its cold
    /// restart).
    fn iterations_per_step(&self, qp: &Qp) -> usize {
        qp.iterations
    }

    /// Multiply-adds of one iteration, and of what runs once per solve besides the iterations (ADMM's final
    /// residuals and infeasibility test, the interior-point method's cold start).
    fn macs(&self, p: &Problem, plan: &Plan) -> (usize, usize);

    /// The multiply-adds the cost model prices for one control step's solve: its
    /// [`Solver::iterations_per_step`] at [`Solver::macs`]' per iteration, and the once-per-solve part
    /// (the dual active set prices its budgets of work instead).
    fn macs_per_step(&self, p: &Problem, plan: &Plan) -> usize {
        let (per_iteration, once) = self.macs(p, plan);
        self.iterations_per_step(&p.qp) * per_iteration + once
    }

    /// The part of [`Solver::macs_per_step`] a cold solve alone may spend, for a method whose step
    /// may hold two solves (the dual active set's warm solve and its cold restart); else `None`.
    fn macs_per_cold_solve(&self, _p: &Problem, _plan: &Plan) -> Option<usize> {
        None
    }

    /// Why `method = "auto"` does not weigh it for `spec`, given whether an earlier candidate can be used;
    /// `None`: it is weighed.
    fn not_weighed(&self, spec: &Spec, earlier_usable: bool) -> Option<String>;

    /// The evidence its iteration count rests on, measured on a sample of `[mpc.region]`; `None` where the
    /// count is a priori or as written.
    fn certify(&self, spec: &Spec, problem: &Problem) -> Result<Option<Evidence>, Diagnostics>;

    /// The a priori bound's form for `mpcc check`, given whether the certificate has a rate.
    fn bound_form(&self, rate: bool) -> String;

    /// The interior-point method's choice of normal system, for the certificate.
    fn normal_form(&self, _qp: &Qp) -> Option<crate::solver::riccati::Choice> {
        None
    }

    /// ADMM's choice of x-update structure, for the certificate.
    fn admm_structure(&self, _qp: &Qp) -> Option<crate::solver::admm::StructureChoice> {
        None
    }

    /// The module doc's line on the solver's shape.
    fn shape_doc(&self, p: &Problem, plan: &Plan) -> String;

    /// A line of the module's doc on how the method is emitted, after its shape; `None` for none.
    fn emission_note(&self) -> Option<&'static str> {
        None
    }

    /// Bytes of the largest constant table the module holds (clippy's `large_const_arrays`).
    fn largest_table(&self, p: &Problem) -> usize;

    /// Its public constants after `DT` (a first-order method's `STEP` and `MOMENTUM`).
    fn parameter_constants(&self, _p: &Problem, _num: Num) -> TokenStream {
        TokenStream::new()
    }

    /// Whether the module's skeleton writes `H` (the constrained methods' H carries the slacks: their
    /// emitters write it).
    fn skeleton_writes_h(&self) -> bool {
        false
    }

    /// Whether its kernels call the scalar `project` onto the input box.
    fn projects(&self) -> bool {
        true
    }

    /// The solver's name in the controller's docs where a solve can fall back; `None` where it cannot.
    fn fallback_name(&self) -> Option<&'static str> {
        None
    }

    /// The fields of its emitted `Mpc`, and those it adds to `Status`, as (size, alignment) in bytes: the
    /// layout model behind `report::BYTES_STATE*` ([`StateFields`]). The default is a first-order
    /// method's: the plan (one entry per plan lane of the gradient form) and, where the moves are
    /// weighted, the last input.
    fn state_fields(&self, p: &Problem, plan: &Plan) -> StateFields {
        let size = crate::numeric::Numeric(p.scalar).bytes();
        let mut mpc = vec![(p.qp.Nc * plan.plan_lanes(p) * size, size)];
        if p.has_moves() {
            mpc.push((p.nu * size, size));
        }
        StateFields {
            mpc,
            status: Vec::new(),
        }
    }

    /// `Mpc`: its type, kernels and tables.
    fn emit(&self, p: &Problem, plan: &Plan, num: Num) -> Sections;

    /// One step of the f64 oracle ([`crate::oracle::Mpc`]): the new plan, warm from the previous one and
    /// the method's `state`.
    fn oracle_step(&self, qp: &Qp, state: &mut Stepping, data: StepData) -> DVector<f64>;
}
