//! The dual active-set method behind [`Solver`].
#![allow(non_snake_case)]

use super::mpc::{
    control_step, macs_checks_in, macs_once, macs_per_iteration, prepare, Caps, SolveWork,
};
use crate::certify::evidence::{Evidence, Exact};
use crate::certify::sampling;
use crate::emit::sections::Sections;
use crate::emit::tokens::Num;
use crate::lower::problem::{Problem, Qp};
use crate::plan::machine::{machine, Machine};
use crate::plan::{Plan, Solver};
use crate::solver::stepping::{StepData, Stepping};
use mpc_spec::{Certificate, Diagnostic, Diagnostics, Method, Scalar, Spec};
use nalgebra::DVector;
use std::sync::Arc;

/// `work(caps, solve)` of `p`'s [`Caps`] and [`SolveWork`], in multiply-adds of the factor's loops
/// (the work's tenths over ten).
fn priced(p: &Problem, work: impl Fn(Caps, SolveWork) -> usize) -> usize {
    use super::kernel64::WORK_MULTIPLY_ADD;
    prepare(&p.qp).map_or(0, |prepared| {
        work(Caps::of(&p.qp), SolveWork::of(&prepared, p.scalar)).div_ceil(WORK_MULTIPLY_ADD)
    })
}

/// Multiply-adds once per solve: the offsets and the recovery of z, and in f32 the primal refinement,
/// the check on z and its restart.
fn once_per_solve(p: &Problem, prepared: &super::Prepared) -> usize {
    macs_once(prepared) + macs_checks_in(prepared, p.scalar)
}

/// The exact count `x` against the sample's cold cases, which draw the same parameters (x₀ in the
/// region, a constant reference, u₋₁ and d in their boxes): in f64, a cold case needing more than the
/// exact count is a case the partition got wrong, so the count is not trusted and the caps are the
/// sample's. (An f32 kernel may take other branches near the regions' boundaries: not compared.)
fn checked_by_sample(mut x: Exact, sampled_cold_worst: usize, scalar: Scalar) -> Exact {
    if x.complete && scalar == Scalar::F64 && sampled_cold_worst > x.cold_worst {
        x.complete = false;
        x.note = Some(format!(
            "a sampled cold case needed {sampled_cold_worst} changes, above the exact count of {}: the partition is not trusted",
            x.cold_worst
        ));
    }
    x
}

/// The dual active-set method (Goldfarb and Idnani's, as DAQP) on the condensed QP, in the module's
/// scalar, with its factor, Gram matrix and blocks computed at build time.
#[derive(Debug)]
pub struct ActiveSet;

/// The dual active-set method.
pub static ACTIVE_SET: ActiveSet = ActiveSet;

impl Solver for ActiveSet {
    fn method(&self) -> Method {
        Method::ActiveSet
    }

    fn title(&self) -> &'static str {
        super::TITLE
    }

    fn name(&self, _qp: &Qp) -> &'static str {
        super::TITLE
    }

    /// The machine's figure, measured on the emulated boards at the certificates' heaviest cold cases
    /// ([`Machine::cycles_per_mac_active_set`], per multiply-add of the factor's loops: a tenth of the
    /// work). In f64 without f64 hardware, plus what software floating point adds to one multiply-add:
    /// a tenth of the work holds at most one (the scan's column update weighs one tenth; the factor's
    /// multiply-add ten, a scanned row with its handful of float operations 45), the rest of its
    /// instructions being integer work. Not measured on a board: such a spec is not weighed by `auto`
    /// ([`Solver::not_weighed`]).
    fn cycles_per_mac(&self, machine: &Machine, scalar: Scalar, _qp: &Qp) -> f64 {
        let soft_float = match scalar {
            Scalar::F64 if !machine.f64_in_hardware => {
                machine.cycles_per_mac_f64 - machine.cycles_per_mac_f32
            }
            _ => 0.0,
        };
        machine.cycles_per_mac_active_set + soft_float
    }

    /// A warm solve that runs out restarts cold: `WARM_ITERATIONS + COLD_ITERATIONS`.
    fn iterations_per_step(&self, qp: &Qp) -> usize {
        Caps::of(qp).per_step()
    }

    /// The worst pass of the iteration (a scan of every constraint against a full working set, a change
    /// of the factor, its solve), and the offsets and recovery of z once per solve (in f32 with the
    /// primal refinement, the check on z and its restart).
    fn macs(&self, p: &Problem, _plan: &Plan) -> (usize, usize) {
        prepare(&p.qp).map_or((0, 0), |prepared| {
            (macs_per_iteration(&prepared), once_per_solve(p, &prepared))
        })
    }

    /// The step's work ([`Caps::work_per_step`]: per solve the lesser of its budget of work plus a pass
    /// and its changes at the worst pass, and the work after the budget's last test), in multiply-adds
    /// of the factor's loops (the work's tenths over ten).
    fn macs_per_step(&self, p: &Problem, _plan: &Plan) -> usize {
        priced(p, |caps, solve| caps.work_per_step(solve))
    }

    /// The cold solve's part of [`Solver::macs_per_step`].
    fn macs_per_cold_solve(&self, p: &Problem, _plan: &Plan) -> Option<usize> {
        Some(priced(p, |caps, solve| caps.work_per_cold_solve(solve)))
    }

    /// In f64 without f64 hardware it would run in software floating point.
    fn not_weighed(&self, spec: &Spec, _earlier_usable: bool) -> Option<String> {
        (spec.codegen.scalar == Scalar::F64 && !machine(spec.codegen.target).f64_in_hardware).then(|| {
            format!(
                "computes in `scalar = \"f64\"`, which `target = \"{}\"` has no hardware for (`scalar = \"f32\"` runs it in f32)",
                spec.codegen.target.name()
            )
        })
    }

    fn certify(&self, spec: &Spec, problem: &Problem) -> Result<Option<Evidence>, Diagnostics> {
        let not_definite = || {
            Diagnostics::from(Diagnostic::new(
                "the dual active-set method needs a positive definite Hessian, and a block of this one is not",
                spec.spans.get("mpc.method"),
            ))
        };
        prepare(&problem.qp).ok_or_else(not_definite)?;
        // The rows that cannot bind over the region go last in their blocks, scanned only where a
        // solve's data fail that proof; the exact count and the sample run the method so.
        let region = sampling::resolve_region(spec, problem, super::TITLE)?;
        let slack_rows = super::slack_rows::slack_rows(problem, &region);
        let prepared =
            super::mpc::prepare_with(&problem.qp, &slack_rows).ok_or_else(not_definite)?;
        // The exact cold count first: the sample's warm steps restart cold with it as their cap.
        let exact = match spec.mpc.region.certificate {
            Certificate::Exact => Some(super::exact::certify(
                problem,
                &prepared,
                &region,
                super::exact::Limits::of(&spec.mpc.region),
            )),
            Certificate::Sampled => None,
        };
        let exact_cold = exact
            .as_ref()
            .filter(|x| x.complete)
            .map_or(0, |x| x.cold_worst);
        let method = super::sampled::ActiveSet::new(prepared, problem.scalar, exact_cold);
        let mut evidence = sampling::certify(spec, problem, &method, 0)?;
        evidence.exact = exact.map(|x| checked_by_sample(x, evidence.cold_worst, problem.scalar));
        evidence.slack_rows = slack_rows;
        Ok(Some(evidence))
    }

    fn bound_form(&self, _rate: bool) -> String {
        "none: the count is the exact cold count over the region where the certificate is exact, else sampled"
            .to_string()
    }

    fn shape_doc(&self, p: &Problem, _plan: &Plan) -> String {
        let blocks = prepare(&p.qp).map_or(0, |prepared| prepared.blocks.len());
        format!(
            " horizon {}, dual active-set on the condensed QP in {}, in {blocks} independent block(s), with {} constraint rows.",
            p.qp.N,
            crate::numeric::Numeric(p.scalar).name(),
            p.qp.rows.len()
        )
    }

    /// Its tables are `Real`: the largest is a block's Gram matrix or Z, or FR.
    fn largest_table(&self, p: &Problem) -> usize {
        let fr = p.qp.Nc * p.nu * p.qp.N * p.qp.nz;
        let block = prepare(&p.qp).map_or(0, |prepared| {
            prepared
                .blocks
                .iter()
                .map(|b| b.packed.gram.len().max(b.packed.z_cols.len()))
                .max()
                .unwrap_or(0)
        });
        block.max(fr) * crate::numeric::Numeric(p.scalar).bytes()
    }

    /// The warm start (the blocks' working sets and their lengths), the kernel's `Storage`, a struct of
    /// its own (the working set, its multipliers and factor, CAP = the largest block's unknowns + 1, and
    /// per constraint of the largest block its marks, slack and scaled sides), and the solve's `Data`.
    fn state_fields(&self, p: &Problem, _plan: &Plan) -> crate::plan::StateFields {
        let real = crate::numeric::Numeric(p.scalar).bytes();
        let index = std::mem::size_of::<u32>();
        let Some(prepared) = prepare(&p.qp) else {
            return crate::solver::constrained::state_fields(p, real, &[]);
        };
        let n_max = prepared.blocks.iter().map(|b| b.n()).max().unwrap_or(0);
        let nc_max = prepared
            .blocks
            .iter()
            .map(|b| b.rows.len())
            .max()
            .unwrap_or(0);
        let cap = n_max + 1;
        let storage = crate::plan::layout(&[
            (cap * index, index),
            (cap, 1),
            (6 * cap * real, real),
            (cap * cap * real, real),
            (2 * nc_max, 1),
            (3 * nc_max * real, real),
            (n_max * real, real),
        ]);
        // `Data`: θ, f, the sides, the rows' offsets, z and the held plan.
        let (np, ng) = (p.qp.N * p.nu, p.qp.rows.len());
        let nv = np + p.qp.rows.slacks();
        let reals = super::emit::theta_len(p) + nv + 2 * (nv + ng) + ng + nv + np;
        let data = (reals * real, real);
        crate::solver::constrained::state_fields(
            p,
            real,
            &[
                (prepared.warm_len() * index, index),
                (prepared.blocks.len() * index, index),
                storage,
                data,
            ],
        )
    }

    fn skeleton_writes_h(&self) -> bool {
        false
    }

    fn projects(&self) -> bool {
        false
    }

    fn fallback_name(&self) -> Option<&'static str> {
        Some("dual active-set method")
    }

    fn emit(&self, p: &Problem, _plan: &Plan, num: Num) -> Sections {
        super::emit::emit(p, num)
    }

    fn oracle_step(&self, qp: &Qp, state: &mut Stepping, data: StepData) -> DVector<f64> {
        if state.active_set_prepared.is_none() {
            state.active_set_prepared = prepare(qp).map(Arc::new);
        }
        let Some(prepared) = state.active_set_prepared.clone() else {
            return crate::solver::ipm::held_plan(qp, data.plan);
        };
        let offset = qp.rows.offset(data.x0, data.d, data.last);
        let step = control_step(
            qp,
            &prepared,
            data.f,
            &offset,
            state.active_set_start.as_ref(),
            data.plan,
            Caps::of(qp),
            state.relax,
            Scalar::F64,
        );
        state.relax = step.recovering();
        state.active_set_start = step.next_start();
        let plan = step.plan.clone();
        state.active_set_step = Some(step);
        plan
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exact(cold_worst: usize) -> Exact {
        Exact {
            complete: true,
            note: None,
            parameters: 2,
            block_parameters: vec![vec!["x0[0]".into(), "x0[1]".into()]],
            regions: 10,
            infeasible_regions: 0,
            cycling_regions: 0,
            cycling_radius: 0.0,
            lps: 100,
            cold_worst,
            block_worst: vec![cold_worst],
            witness: Vec::new(),
            cold_work: None,
            work_witness: Vec::new(),
            path_mismatches: 0,
            seconds: 0.0,
        }
    }

    #[test]
    fn a_sampled_case_above_the_exact_count_distrusts_it_in_f64() {
        let kept = checked_by_sample(exact(7), 7, Scalar::F64);
        assert!(kept.complete && kept.note.is_none());
        let distrusted = checked_by_sample(exact(7), 8, Scalar::F64);
        assert!(!distrusted.complete);
        assert!(distrusted
            .note
            .unwrap()
            .contains("needed 8 changes, above the exact count of 7"));
        // An f32 kernel's branches near the boundaries may differ: not compared.
        assert!(checked_by_sample(exact(7), 8, Scalar::F32).complete);
    }
}
