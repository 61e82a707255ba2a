//! The interior-point method behind [`Solver`].
#![allow(non_snake_case)]

use super::{control_step, shifted_start};
use crate::certify::evidence::Evidence;
use crate::certify::sampling;
use crate::emit::sections::Sections;
use crate::emit::tokens::Num;
use crate::lower::problem::{Problem, Qp};
use crate::plan::machine::{machine, Machine};
use crate::plan::{Plan, Solver};
use crate::solver::constrained::{Fallback, Status};
use crate::solver::riccati;
use crate::solver::stepping::{StepData, Stepping};
use mpc_spec::{Diagnostics, Method, Scalar, Spec};
use nalgebra::DVector;

/// The fixed-iteration primal-dual interior-point method on the condensed QP, in f64.
#[derive(Debug)]
pub struct InteriorPoint;

/// The interior-point method.
pub static INTERIOR_POINT: InteriorPoint = InteriorPoint;

impl Solver for InteriorPoint {
    fn method(&self) -> Method {
        Method::Ipm
    }

    fn state_fields(&self, p: &Problem, _plan: &Plan) -> crate::plan::StateFields {
        // z [f64; NV], s and λ [f64; NSIDES]: the sides of the box and of the rows that are finite.
        let qp = &p.qp;
        let np = qp.Nc * p.nu;
        let structure =
            super::condensed::mpc_qp(qp, &DVector::zeros(np), &DVector::zeros(qp.rows.len()));
        let sides = super::condensed::Layout::of(&structure);
        let (nv, nsides) = (np + qp.rows.slacks(), sides.boxed.len() + sides.rows.len());
        crate::solver::constrained::state_fields(p, 8, &[(nv * 8, 8), (2 * nsides * 8, 8)])
    }

    fn title(&self) -> &'static str {
        super::TITLE
    }

    fn name(&self, _qp: &Qp) -> &'static str {
        "the interior-point method"
    }

    fn widens(&self) -> bool {
        true
    }

    fn cycles_per_mac(&self, machine: &Machine, _scalar: Scalar, _qp: &Qp) -> f64 {
        machine.cycles_per_mac_ipm
    }

    /// Its cold start runs once per solve: the emitted method computes it on every solve, so that its
    /// control flow does not depend on the data.
    fn macs(&self, p: &Problem, _plan: &Plan) -> (usize, usize) {
        (
            super::mpc_macs_per_iteration(&p.qp),
            super::mpc_cold_start_macs(&p.qp),
        )
    }

    fn not_weighed(&self, spec: &Spec, _earlier_usable: bool) -> Option<String> {
        (!machine(spec.codegen.target).f64_in_hardware).then(|| {
            format!(
                "computes in f64, which `target = \"{}\"` has no hardware for",
                spec.codegen.target.name()
            )
        })
    }

    fn certify(&self, spec: &Spec, problem: &Problem) -> Result<Option<Evidence>, Diagnostics> {
        sampling::certify(spec, problem, &super::sampled::InteriorPoint, 0).map(Some)
    }

    fn bound_form(&self, _rate: bool) -> String {
        "none: an interior-point method has no practical a priori bound (see the sampled evidence)"
            .to_string()
    }

    fn normal_form(&self, qp: &Qp) -> Option<riccati::Choice> {
        Some(riccati::Choice::of(qp))
    }

    fn shape_doc(&self, p: &Problem, _plan: &Plan) -> String {
        format!(
            " horizon {}, dense on the condensed QP in f64 with {} constraint rows.",
            p.qp.N,
            p.qp.rows.len()
        )
    }

    /// Its helpers that do not depend on the QP's shape (`helpers`, `newton_step`, `interior_point` in
    /// `emit.rs`, about 280 lines) are emitted into every module rather than shared from a runtime crate:
    /// a module stays one self-contained file, and firmware links only what its own module uses.
    fn emission_note(&self) -> Option<&'static str> {
        Some(" Its helpers that do not depend on the QP's shape are emitted into every such module, so that the module is self-contained and firmware links only what it uses.")
    }

    /// Its tables are f64: the largest is H (NV × NV) or FR.
    fn largest_table(&self, p: &Problem) -> usize {
        let nv = p.qp.Nc * p.nu + p.qp.rows.slacks();
        nv * nv.max(p.qp.N * p.qp.nz) * 8
    }

    fn projects(&self) -> bool {
        false
    }

    fn fallback_name(&self) -> Option<&'static str> {
        Some("interior-point method")
    }

    fn emit(&self, p: &Problem, _plan: &Plan, num: Num) -> Sections {
        super::emit::emit(p, num)
    }

    fn oracle_step(&self, qp: &Qp, state: &mut Stepping, data: StepData) -> DVector<f64> {
        let offset = qp.rows.offset(data.x0, data.d, data.last);
        let limits = qp.ipm_limits();
        let step = control_step(
            qp,
            data.f,
            &offset,
            &state.start,
            data.plan,
            qp.iterations,
            &limits,
            state.relax,
        );
        state.relax =
            step.result.status == Status::Infeasible || step.fallback == Fallback::Relaxed;
        state.start = shifted_start(qp, &step);
        let plan = step.plan.clone();
        state.last_step = Some(step);
        plan
    }
}
