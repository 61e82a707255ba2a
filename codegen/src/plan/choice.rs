//! `method = "auto"`, the default: the compiler lowers and certifies every method that can take the
//! spec, and keeps the cheapest one whose certificate shows it reaching `accuracy`.
//!
//! - `fgm` takes the input box only (no state, move or row constraints). Without `[mpc.region]` its count
//!   is `tolerance`'s a priori bound or the written one, and it is then the only candidate (the others
//!   are certified on a region); with a region it is sampled like the others.
//! - `ipm` takes every constraint and is always sampled on `[mpc.region]` (or on the state bounds).
//! - `active_set` takes the same and is sampled the same way (in f64: not weighed without f64 hardware);
//!   its cost per solve is its certified count of changes of the working set at the worst pass's cost,
//!   plus the offsets and the recovery of z: a bound, where the interior-point method's is what it always
//!   runs.
//! - `admm` takes the same and is sampled the same way, in the module's scalar, at a ρ tuned on part
//!   of that sample; its cost per solve adds its final residuals and infeasibility test.
//!
//! A candidate is excluded when its lowering or certificate fails (the finding is kept as the reason),
//! or when its sample shows it missing `accuracy` at a written count. Among the rest the lowest cost per
//! solve wins, in the cycles of its multiply-adds on the target ([`crate::plan::Solver::macs`], the
//! certificate's count of the emitted code: the chosen gradient form's for a first-order method, the
//! interior-point method's iterations and cold start, ADMM's iterations and final residuals).
//! FGM-only keys (a numeric `step`, `tolerance`) choose `fgm` before any of this (`mpc_spec`).

pub use crate::certify::evidence::Candidate;
use crate::lower;
use crate::lower::problem::Problem;
use mpc_spec::{Diagnostics, Iterations, Method, Spec};

/// The methods `auto` weighs, in the order a tie is broken.
///
/// ADMM is last: its certificate tunes ρ and samples hundreds to thousands of iterations per case (7 s
/// for the quadcopter, 50 s for paper-limits in the dev profile), and on f64 hardware the interior-point
/// method has been cheaper per solve on every shipped spec, so it is weighed only when no earlier
/// candidate can be used ([`crate::plan::Solver::not_weighed`]).
pub const CANDIDATES: &[Method] = &[Method::Fgm, Method::Ipm, Method::ActiveSet, Method::Admm];

/// The methods the previous release weighed: [`CANDIDATES`] without `active_set`. `mpcc check` says
/// when `auto`'s choice differs from theirs ([`previous_choice`]).
pub const PREVIOUS_CANDIDATES: &[Method] = &[Method::Fgm, Method::Ipm, Method::Admm];

/// What the previous release's `auto` chose among `candidates` (those of [`resolve`]): the cheapest
/// usable one of [`PREVIOUS_CANDIDATES`]; `None` where none was usable. The candidates' costs are the
/// same as the previous release's but for auto's price of the interior-point method's cold start.
pub fn previous_choice(candidates: &[Candidate]) -> Option<Method> {
    candidates
        .iter()
        .filter(|c| PREVIOUS_CANDIDATES.contains(&c.method))
        .filter(|c| c.unavailable.is_none() && c.reaches_accuracy != Some(false))
        .min_by(|a, b| a.cycles_per_solve.total_cmp(&b.cycles_per_solve))
        .map(|c| c.method)
}

/// The spec with its method resolved, and the problem lowered and certified with it: `spec` itself for
/// a written method, the cheapest candidate for `method = "auto"` (its [`Problem::candidates`] say what
/// was weighed). Fails with the findings of the candidate that fits the spec best when none can be used.
pub fn resolve(spec: &Spec) -> Result<(Spec, Problem), Diagnostics> {
    resolve_weighed(spec).map(|(s, p, _)| (s, p))
}

/// What [`resolve_weighed`] returns: the chosen spec and problem, and the other candidates.
pub type Weighed = (Spec, Problem, Vec<(Spec, Problem)>);

/// [`resolve`], with the other candidates `auto` lowered and certified beside the chosen one, each as its
/// own spec and problem (none for a written method): for a caller that needs a losing candidate's
/// certificate without paying for it twice.
pub fn resolve_weighed(spec: &Spec) -> Result<Weighed, Diagnostics> {
    if spec.mpc.method != Method::Auto {
        let mut problem = lower_and_certify(spec)?;
        problem.requested = spec.mpc.method_requested;
        return Ok((spec.clone(), problem, Vec::new()));
    }
    let constrained = !spec.mpc.constraints.is_empty();
    let mut candidates = Vec::new();
    let mut lowered: Vec<(Spec, Problem)> = Vec::new();
    let mut findings: Vec<(Method, Diagnostics)> = Vec::new();
    for &method in CANDIDATES {
        let mut s = spec.clone();
        s.mpc.method = method;
        let earlier_usable = candidates
            .iter()
            .any(|c: &Candidate| c.unavailable.is_none() && c.reaches_accuracy != Some(false));
        let excluded = super::of(method).not_weighed(spec, earlier_usable);
        if let Some(why) = excluded {
            candidates.push(unavailable(method, why));
            continue;
        }
        match lower_and_certify(&s).and_then(|p| super::plan(&s, &p).map(|plan| (p, plan))) {
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
    let at = lowered
        .iter()
        .position(|(s, _)| s.mpc.method == chosen)
        .expect("the chosen candidate was lowered");
    let (s, mut p) = lowered.remove(at);
    p.requested = Method::Auto;
    p.candidates = candidates;
    Ok((s, p, lowered))
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
    let (macs_per_iteration, _) = plan.solver.macs(p, plan);
    let iterations = plan.solver.iterations_per_step(qp);
    let macs_per_solve = plan.solver.macs_per_step(p, plan);
    let (certified, reaches_accuracy) = match (&qp.evidence, spec.mpc.iterations) {
        (Some(e), _) => ("sampled", Some(e.worst_needed <= e.iterations)),
        (None, Iterations::Auto) => ("a priori", None),
        (None, Iterations::Fixed(_)) => ("as written", None),
    };
    Candidate {
        method: spec.mpc.method,
        unavailable: None,
        iterations,
        macs_per_iteration,
        macs_per_solve,
        cycles_per_solve: macs_per_solve as f64
            * plan.solver.cycles_per_mac(
                super::machine::machine(spec.codegen.target),
                spec.codegen.scalar,
                qp,
            ),
        certified,
        reaches_accuracy,
        chosen: false,
    }
}

/// Lowers `spec`, whose method is not `auto`, ([`crate::lower::uncertified`]) and certifies its iteration count on a sample of
/// `[mpc.region]` ([`crate::certify::sampling::certify`]) where there is one to sample: always for the interior-point
/// method and for ADMM (its ρ tuned first on part of the same sample, [`crate::certify::sampling::tune_admm`]), and for a first-order method when `[mpc.region]` is written (its `iterations = "auto"` is
/// then at least the sample's need for `accuracy`, and at least what `tolerance` guarantees): the
/// problem every later phase works on.
fn lower_and_certify(spec: &Spec) -> Result<Problem, Diagnostics> {
    let mut problem = lower::uncertified(spec)?;
    let evidence = super::of(spec.mpc.method).certify(spec, &problem)?;
    if let Some(evidence) = evidence {
        problem.qp.iterations = evidence.iterations;
        problem.qp.evidence = Some(evidence);
    }
    Ok(problem)
}
