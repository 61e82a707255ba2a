//! ADMM behind [`Solver`].
#![allow(non_snake_case)]

use super::{certified_settings, control_step, mpc_settings, shifted_start, structure, tuning};
use super::{Form, Structure, StructureChoice, Tuned};
use crate::certify::evidence::{self, Evidence};
use crate::certify::{budget, sampling};
use crate::emit::sections::Sections;
use crate::emit::tokens::Num;
use crate::lower::problem::{Problem, Qp};
use crate::numeric::Numeric;
use crate::plan::machine::{machine, Machine};
use crate::plan::{Plan, Solver};
use crate::solver::constrained::Fallback;
use crate::solver::constrained::Status;
use crate::solver::stepping::{StepData, Stepping};
use mpc_spec::{Diagnostics, Method, Scalar, Spec};
use nalgebra::DVector;

/// ADMM (OSQP's operator splitting) on the condensed QP, at a ρ tuned at build time, in the module's scalar.
#[derive(Debug)]
pub struct Admm;

/// ADMM.
pub static ADMM: Admm = Admm;

impl Solver for Admm {
    fn method(&self) -> Method {
        Method::Admm
    }

    fn state_fields(&self, p: &Problem, _plan: &Plan) -> crate::plan::StateFields {
        // x [Real; NV], z and y [Real; NC], NC = NV + the rows; the plan in `Real`.
        let qp = &p.qp;
        let real = crate::numeric::Numeric(p.scalar).bytes();
        let nv = qp.Nc * p.nu + qp.rows.slacks();
        let nc = nv + qp.rows.len();
        crate::solver::constrained::state_fields(
            p,
            real,
            &[(nv * real, real), (2 * nc * real, real)],
        )
    }

    fn title(&self) -> &'static str {
        super::TITLE
    }

    fn name(&self, qp: &Qp) -> &'static str {
        match tuning(qp).map(|t| t.form) {
            Some(Form::Residual) => "ADMM (residual form)",
            _ => "ADMM",
        }
    }

    /// Its own figures, condensed or stage by stage; in f64 without f64 hardware, scaled by the
    /// soft-float ratio.
    fn cycles_per_mac(&self, machine: &Machine, scalar: Scalar, qp: &Qp) -> f64 {
        let admm = match structure(qp) {
            Structure::Condensed => machine.cycles_per_mac_admm,
            Structure::Riccati => machine.cycles_per_mac_admm_stages,
        };
        if scalar == Scalar::F64 && !machine.f64_in_hardware {
            admm * machine.cycles_per_mac_f64 / machine.cycles_per_mac_f32
        } else {
            admm
        }
    }

    /// Its final residuals and infeasibility test run once per solve.
    fn macs(&self, p: &Problem, _plan: &Plan) -> (usize, usize) {
        (
            super::mpc_macs_per_iteration(&p.qp),
            super::mpc_residual_macs(&p.qp),
        )
    }

    /// Where f64 is in hardware the interior-point method is the cheaper constrained method on every
    /// shipped spec (docs/methods.md, "ADMM"), and ADMM's certificate costs seconds of build time.
    fn not_weighed(&self, spec: &Spec, earlier_usable: bool) -> Option<String> {
        (earlier_usable && machine(spec.codegen.target).f64_in_hardware).then(|| {
            "not weighed: an earlier candidate reaches `accuracy` on a target with f64 hardware, and ADMM's certificate costs seconds of build time (write `method = \"admm\"` to force it)".to_string()
        })
    }

    /// ρ measured on part of the sample (in f64, where the forms agree), then the whole sample at that ρ
    /// in the written form; without one, the direct form in f64. In f32 the direct form's rounded factor
    /// biases its fixed point, which on an ill-conditioned H costs many iterations or misses `accuracy`:
    /// the residual form first, then the direct one run at most as long as it could be cheaper, and the
    /// cheaper of the two is kept. Each attempt counts the earlier ones' multiply-adds against the
    /// build's budget.
    fn certify(&self, spec: &Spec, problem: &Problem) -> Result<Option<Evidence>, Diagnostics> {
        let (rho, tuning_macs) = super::sampled::tune_admm(spec, problem)?;
        let method = |form, spent| super::sampled::Admm::new(problem, Tuned { rho, form }, spent);
        let certify =
            |method: &super::sampled::Admm| sampling::certify_metered(spec, problem, method, 0);
        // What a pass spent on its exact references, which its meter does not count: one exact solve a
        // case, at the budget's price.
        let (cold, warm) = sampling::sample_cases(spec, problem.nx);
        let exact = (cold + warm) as f64 * budget::exact_macs(&problem.qp);
        let cost = |method: &super::sampled::Admm, e: &Evidence| {
            e.iterations as f64 * sampling::Sampled::macs_per_iteration(method, &problem.qp) as f64
        };
        let evidence = match spec.mpc.admm_form {
            Some(form) => certify(&method(form, tuning_macs)).map_err(|(d, _)| d)?,
            None if problem.scalar == Scalar::F64 => {
                certify(&method(Form::Direct, tuning_macs)).map_err(|(d, _)| d)?
            }
            None => {
                let residual = method(Form::Residual, tuning_macs);
                match certify(&residual) {
                    Ok(e) => {
                        let direct = method(Form::Direct, e.sample_macs + exact);
                        let per_iteration =
                            sampling::Sampled::macs_per_iteration(&direct, &problem.qp).max(1);
                        let most = (cost(&residual, &e) / per_iteration as f64) as usize;
                        let direct = direct.at_most(most);
                        match certify(&direct) {
                            Ok(d) if cost(&direct, &d) < cost(&residual, &e) => d,
                            Ok(d) => evidence::Evidence {
                                sample_macs: d.sample_macs,
                                ..e
                            },
                            Err((_, spent)) => evidence::Evidence {
                                sample_macs: spent,
                                ..e
                            },
                        }
                    }
                    Err((_, spent)) => {
                        certify(&method(Form::Direct, spent + exact)).map_err(|(d, _)| d)?
                    }
                }
            }
        };
        Ok(Some(evidence))
    }

    fn bound_form(&self, _rate: bool) -> String {
        "none: ADMM's bound is on its residuals, not on |U − U*|∞ (see the sampled evidence)"
            .to_string()
    }

    fn admm_structure(&self, qp: &Qp) -> Option<StructureChoice> {
        tuning(qp).map(|t| StructureChoice::of(qp, &mpc_settings(qp, t.rho).in_form(t.form)))
    }

    fn shape_doc(&self, p: &Problem, _plan: &Plan) -> String {
        format!(
            " horizon {}, in {} with {} constraint rows.",
            p.qp.N,
            Numeric(p.scalar).name(),
            p.qp.rows.len()
        )
    }

    /// Its tables are `Real`: the largest is H (NV × NV) or FR.
    fn largest_table(&self, p: &Problem) -> usize {
        let nv = p.qp.Nc * p.nu + p.qp.rows.slacks();
        nv * nv.max(p.qp.N * p.qp.nz) * Numeric(p.scalar).bytes()
    }

    fn fallback_name(&self) -> Option<&'static str> {
        Some("ADMM")
    }

    fn emit(&self, p: &Problem, plan: &Plan, num: Num) -> Sections {
        super::emit::emit(p, num, plan.write_out_budget)
    }

    /// The certified ρ and residual limits, the iteration in f64 (the emitted f64 module's).
    fn oracle_step(&self, qp: &Qp, state: &mut Stepping, data: StepData) -> DVector<f64> {
        let offset = qp.rows.offset(data.x0, data.d, data.last);
        let limits = qp.ipm_limits();
        let settings =
            certified_settings(qp).expect("an ADMM problem is certified before it is run");
        let step = control_step::<f64>(
            qp,
            &settings,
            data.f,
            &offset,
            &state.admm_start,
            data.plan,
            qp.iterations,
            &limits,
            state.relax,
        );
        state.relax =
            step.result.status == Status::Infeasible || step.fallback == Fallback::Relaxed;
        state.admm_start = shifted_start(qp, &step);
        let plan = step.plan.clone();
        state.admm_step = Some(step);
        plan
    }
}
