//! `method = "auto"`, the default: the compiler lowers and certifies every method that can take the
//! spec, and keeps the cheapest one whose certificate shows it reaching `accuracy`.
//!
//! - `fgm` takes the input box only (no state, move or row constraints). Without `[mpc.region]` its count
//!   is `tolerance`'s a priori bound or the written one, and it is then the only candidate (the others
//!   are certified on a region); with a region it is sampled like the others.
//! - `ipm` takes every constraint and is always sampled on `[mpc.region]` (or on the state bounds).
//!
//! A candidate is excluded when its lowering or certificate fails (the finding is kept as the reason),
//! or when its sample shows it missing `accuracy` at a written count. Among the rest the lowest cost per
//! solve wins, in multiply-adds (the cost model's count of the emitted code: the chosen gradient form's
//! for a first-order method, [`crate::ipm::mpc_macs_per_iteration`] for the interior-point method).
//! FGM-only keys (a numeric `step`, `tolerance`) choose `fgm` before any of this (`mpc_spec`).

pub use crate::evidence::Candidate;
use crate::lower::Problem;
use mpc_spec::{Diagnostics, Iterations, Method, Spec};

/// The methods `auto` weighs, in the order a tie is broken.
pub const CANDIDATES: &[Method] = &[Method::Fgm, Method::Ipm];

/// The spec with its method resolved, and the problem lowered and certified with it: `spec` itself for
/// a written method, the cheapest candidate for `method = "auto"` (its [`Problem::candidates`] say what
/// was weighed). Fails with the findings of the candidate that fits the spec best when none can be used.
pub fn resolve(spec: &Spec) -> Result<(Spec, Problem), Diagnostics> {
    if spec.mpc.method != Method::Auto {
        let mut problem = crate::certified(spec)?;
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
            _ => None,
        };
        if let Some(why) = excluded {
            candidates.push(unavailable(method, why));
            continue;
        }
        match crate::certified(&s).and_then(|p| crate::plan(&s, &p).map(|plan| (p, plan))) {
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
        .min_by_key(|(_, c)| c.macs_per_solve)
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
        certified: "",
        reaches_accuracy: None,
        chosen: false,
    }
}

fn candidate(spec: &Spec, p: &Problem, plan: &crate::Plan) -> Candidate {
    let qp = &p.qp;
    let macs_per_iteration = match plan.algorithm {
        Some(algorithm) => plan.estimate().macs + algorithm.update_macs(qp.H.nrows()),
        None => crate::ipm::mpc_macs_per_iteration(qp),
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
        macs_per_solve: qp.iterations * macs_per_iteration,
        certified,
        reaches_accuracy,
        chosen: false,
    }
}
