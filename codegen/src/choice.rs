//! `method = "auto"`, the default: the compiler lowers and certifies every method that can take the
//! spec, and keeps the cheapest one whose certificate shows it reaching `accuracy`.
//!
//! - `fgm` takes the input box only (no state, move or row constraints). Without `[mpc.region]` its count
//!   is `tolerance`'s a priori bound or the written one, and it is then the only candidate (the others
//!   are certified on a region); with a region it is sampled like the others.
//! - `ipm` takes every constraint and is always sampled on `[mpc.region]` (or on the state bounds).
//! - `admm` takes the same and is sampled the same way, in the module's scalar, at a ρ tuned on part
//!   of that sample; its cost per solve adds its final residuals and infeasibility test.
//!
//! A candidate is excluded when its lowering or certificate fails (the finding is kept as the reason),
//! or when its sample shows it missing `accuracy` at a written count. Among the rest the lowest cost per
//! solve wins, in multiply-adds (the cost model's count of the emitted code: the chosen gradient form's
//! for a first-order method, [`crate::ipm::mpc_macs_per_iteration`] for the interior-point method,
//! [`crate::admm::mpc_macs_per_iteration`] plus [`crate::admm::mpc_residual_macs`] for ADMM).
//! FGM-only keys (a numeric `step`, `tolerance`) choose `fgm` before any of this (`mpc_spec`).

pub use crate::evidence::Candidate;
use crate::problem::Problem;
use crate::{admm, budget, evidence, lower, sampling, solver};
use mpc_spec::{Diagnostics, Iterations, Method, Spec};

/// The methods `auto` weighs, in the order a tie is broken.
///
/// ADMM is last: its certificate tunes ρ and samples hundreds to thousands of iterations per case (7 s
/// for the quadcopter, 50 s for paper-limits in the dev profile), and on f64 hardware the interior-point
/// method has been cheaper per solve on every shipped spec, so it is weighed only when no earlier
/// candidate can be used (`not_weighed`).
pub const CANDIDATES: &[Method] = &[Method::Fgm, Method::Ipm, Method::Admm];

/// Why `auto` does not weigh `method` for `spec`, given whether an earlier candidate can be used
/// (`None`: it is weighed). A method not weighed is listed as unavailable with the reason.
///
/// On a target without f64 hardware the interior-point method is not a candidate and ADMM (in the
/// module's scalar) always is.
fn not_weighed(spec: &Spec, method: Method, earlier_usable: bool) -> Option<String> {
    let machine = crate::target::machine(spec.codegen.target);
    match method {
        Method::Ipm if !machine.f64_in_hardware => Some(format!(
            "computes in f64, which `target = \"{}\"` has no hardware for",
            spec.codegen.target.name()
        )),
        // Where f64 is in hardware the interior-point method is the cheaper constrained method on every
        // shipped spec (README, "ADMM"), and ADMM's certificate costs seconds of build time.
        Method::Admm if earlier_usable && machine.f64_in_hardware => Some(
            "not weighed: an earlier candidate reaches `accuracy` on a target with f64 hardware, and ADMM's certificate costs seconds of build time (write `method = \"admm\"` to force it)".to_string(),
        ),
        _ => None,
    }
}

/// The spec with its method resolved, and the problem lowered and certified with it: `spec` itself for
/// a written method, the cheapest candidate for `method = "auto"` (its [`Problem::candidates`] say what
/// was weighed). Fails with the findings of the candidate that fits the spec best when none can be used.
pub fn resolve(spec: &Spec) -> Result<(Spec, Problem), Diagnostics> {
    if spec.mpc.method != Method::Auto {
        let mut problem = lower_and_certify(spec)?;
        problem.requested = spec.mpc.method_requested;
        return Ok((spec.clone(), problem));
    }
    let constrained = !spec.mpc.constraints.is_empty();
    let mut candidates = Vec::new();
    let mut lowered: Vec<(Spec, Problem)> = Vec::new();
    let mut findings: Vec<(Method, Diagnostics)> = Vec::new();
    for &method in CANDIDATES {
        let mut s = spec.clone();
        s.mpc.method = method;
        let excluded = match method {
            Method::Fgm if constrained => {
                Some("solves the input box only, and the spec has constraints".to_string())
            }
            _ => {
                let earlier_usable = candidates.iter().any(|c: &Candidate| {
                    c.unavailable.is_none() && c.reaches_accuracy != Some(false)
                });
                not_weighed(spec, method, earlier_usable)
            }
        };
        if let Some(why) = excluded {
            candidates.push(unavailable(method, why));
            continue;
        }
        match lower_and_certify(&s).and_then(|p| crate::plan::plan(&s, &p).map(|plan| (p, plan))) {
            Ok((p, plan)) => {
                candidates.push(candidate(&s, &p, &plan));
                lowered.push((s, p));
            }
            Err(d) => {
                let why = d
                    .iter()
                    .next()
                    .map_or_else(|| "failed".to_string(), |d| d.message.clone());
                candidates.push(unavailable(method, why));
                findings.push((method, d));
            }
        }
    }
    let best = candidates
        .iter()
        .enumerate()
        .filter(|(_, c)| c.unavailable.is_none() && c.reaches_accuracy != Some(false))
        .min_by(|(_, a), (_, b)| a.cycles_per_solve.total_cmp(&b.cycles_per_solve))
        .map(|(i, c)| (i, c.method));
    let Some((index, chosen)) = best else {
        // None can be used: the findings of the method the spec needs (`ipm` for constraints).
        let preferred = if constrained {
            Method::Ipm
        } else {
            Method::Fgm
        };
        let d = findings
            .iter()
            .find(|(m, _)| *m == preferred)
            .or(findings.first())
            .map(|(_, d)| d.clone());
        return Err(d.unwrap_or_else(|| {
            mpc_spec::Diagnostic::new(
                "`method = \"auto\"` found no method that reaches `accuracy` on `[mpc.region]`",
                spec.spans.get("mpc.method").or(spec.spans.get("mpc.accuracy")),
            )
            .note("hint: loosen `accuracy`, raise `iterations` (or write `\"auto\"`), or narrow `[mpc.region]`")
            .into()
        }));
    };
    candidates[index].chosen = true;
    let (s, mut p) = lowered
        .into_iter()
        .find(|(s, _)| s.mpc.method == chosen)
        .expect("the chosen candidate was lowered");
    p.requested = Method::Auto;
    p.candidates = candidates;
    Ok((s, p))
}

fn unavailable(method: Method, why: String) -> Candidate {
    Candidate {
        method,
        unavailable: Some(why),
        iterations: 0,
        macs_per_iteration: 0,
        macs_per_solve: 0,
        cycles_per_solve: f64::INFINITY,
        certified: "",
        reaches_accuracy: None,
        chosen: false,
    }
}

fn candidate(spec: &Spec, p: &Problem, plan: &crate::Plan) -> Candidate {
    let qp = &p.qp;
    let (macs_per_iteration, once) = match (plan.algorithm, qp.method) {
        (Some(algorithm), _) => (
            plan.estimate().macs + algorithm.update_macs(qp.H.nrows()),
            0,
        ),
        (None, Method::Admm) => (
            crate::admm::mpc_macs_per_iteration(qp),
            crate::admm::mpc_residual_macs(qp),
        ),
        (None, _) => (crate::ipm::mpc_macs_per_iteration(qp), 0),
    };
    let (certified, reaches_accuracy) = match (&qp.evidence, spec.mpc.iterations) {
        (Some(e), _) => ("sampled", Some(e.worst_needed <= e.iterations)),
        (None, Iterations::Auto) => ("a priori", None),
        (None, Iterations::Fixed(_)) => ("as written", None),
    };
    Candidate {
        method: spec.mpc.method,
        unavailable: None,
        iterations: qp.iterations,
        macs_per_iteration,
        macs_per_solve: qp.iterations * macs_per_iteration + once,
        cycles_per_solve: (qp.iterations * macs_per_iteration + once) as f64
            * crate::target::machine(spec.codegen.target).solver_cycles_per_mac(
                spec.mpc.method,
                spec.codegen.scalar,
                crate::admm::structure(qp),
            ),
        certified,
        reaches_accuracy,
        chosen: false,
    }
}

/// Lowers `spec`, whose method is not `auto`, ([`crate::lower::uncertified`]) and certifies its iteration count on a sample of
/// `[mpc.region]` ([`crate::sampling::certify`]) where there is one to sample: always for the interior-point
/// method and for ADMM (its ρ tuned first on part of the same sample, [`crate::sampling::tune_admm`]), and for a first-order method when `[mpc.region]` is written (its `iterations = "auto"` is
/// then at least the sample's need for `accuracy`, and at least what `tolerance` guarantees): the
/// problem every later phase works on.
fn lower_and_certify(spec: &Spec) -> Result<Problem, Diagnostics> {
    let mut problem = lower::uncertified(spec)?;
    let evidence = match (spec.mpc.method, solver::algorithm(spec.mpc.method)) {
        (mpc_spec::Method::Admm, _) => {
            // ρ measured on part of the sample (in f64, where the forms agree), then the whole sample
            // at that ρ in the written form; without one, the direct form in f64. In f32 the direct
            // form's rounded factor biases its fixed point, which on an ill-conditioned H costs many
            // iterations or misses `accuracy`: the residual form first, then the direct one run at
            // most as long as it could be cheaper, and the cheaper of the two is kept. Each attempt
            // counts the earlier ones' multiply-adds against the build's budget.
            let (rho, tuning_macs) = sampling::tune_admm(spec, &problem)?;
            let method =
                |form, spent| sampling::Admm::new(&problem, admm::Tuned { rho, form }, spent);
            let certify =
                |method: &sampling::Admm| sampling::certify_metered(spec, &problem, method, 0);
            // What a pass spent on its exact references, which its meter does not count: one
            // exact solve a case, at the budget's price.
            let (cold, warm) = sampling::sample_cases(spec, problem.nx);
            let exact = (cold + warm) as f64 * budget::exact_macs(&problem.qp);
            let cost = |method: &sampling::Admm, e: &evidence::Evidence| {
                e.iterations as f64
                    * sampling::Sampled::macs_per_iteration(method, &problem.qp) as f64
            };
            match spec.mpc.admm_form {
                Some(form) => Some(certify(&method(form, tuning_macs)).map_err(|(d, _)| d)?),
                None if problem.scalar == mpc_spec::Scalar::F64 => {
                    Some(certify(&method(admm::Form::Direct, tuning_macs)).map_err(|(d, _)| d)?)
                }
                None => {
                    let residual = method(admm::Form::Residual, tuning_macs);
                    match certify(&residual) {
                        Ok(e) => {
                            let direct = method(admm::Form::Direct, e.sample_macs + exact);
                            let per_iteration =
                                sampling::Sampled::macs_per_iteration(&direct, &problem.qp).max(1);
                            let most = (cost(&residual, &e) / per_iteration as f64) as usize;
                            let direct = direct.at_most(most);
                            match certify(&direct) {
                                Ok(d) if cost(&direct, &d) < cost(&residual, &e) => Some(d),
                                Ok(d) => Some(evidence::Evidence {
                                    sample_macs: d.sample_macs,
                                    ..e
                                }),
                                Err((_, spent)) => Some(evidence::Evidence {
                                    sample_macs: spent,
                                    ..e
                                }),
                            }
                        }
                        Err((_, spent)) => Some(
                            certify(&method(admm::Form::Direct, spent + exact))
                                .map_err(|(d, _)| d)?,
                        ),
                    }
                }
            }
        }
        (_, None) => Some(sampling::certify(
            spec,
            &problem,
            &sampling::InteriorPoint,
            0,
        )?),
        (_, Some(algorithm)) if spec.spans.get("mpc.region").is_some() => {
            // The a priori count of `tolerance` (zero without one) is the floor of `auto`.
            let floor = match spec.mpc.iterations {
                mpc_spec::Iterations::Auto => problem.qp.iterations,
                mpc_spec::Iterations::Fixed(_) => 0,
            };
            Some(sampling::certify(
                spec,
                &problem,
                &sampling::FirstOrder(algorithm),
                floor,
            )?)
        }
        (_, Some(_)) => None,
    };
    if let Some(evidence) = evidence {
        problem.qp.iterations = evidence.iterations;
        problem.qp.evidence = Some(evidence);
    }
    Ok(problem)
}
