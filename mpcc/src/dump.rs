//! `mpcc dump-qp`: the condensed QP of a spec and a closed loop's states, for other solvers (issue 19).
//!
//! The output is one JSON object, `"format": "mpcc-qp/1"`, documented in `peers/README.md`. The QP of
//! one control step is, on z = (U, σ) (the plan U, N·nu entries stacked by step, then the ns slacks):
//!
//! ```text
//! min ½ zᵀ H z + fᵀ z   s.t.  z_min ≤ z ≤ z_max,   lower − o ≤ A z ≤ upper − o
//! f = (F_x·x0 − F_r·r + F_u·u₋₁,  w_σ),   o = W_x·x0 + W_u·u₋₁
//! ```
//!
//! with r the reference window (N entries of nz, stacked) and u₋₁ the last input: `codegen::ipm::mpc_qp`
//! exactly. Infinite bounds are written `null`. Each step also carries its exact solution z* (the
//! interior-point method run to 1e-10, Clarabel where it does not converge: `codegen::exact::exact`).
#![allow(non_snake_case)]

use codegen::ipm::{self, mpc_qp};
use codegen::oracle;
use codegen::Problem;
use nalgebra::{DMatrix, DVector};
use serde_json::{json, Value};

/// The tolerance of the exact solutions (relative residuals, gap and complementarity).
pub(crate) use codegen::exact::EXACT_TOLERANCE;

/// What the states of the dump are.
pub(crate) enum States {
    /// `steps` states of the oracle's closed loop on the nominal model x⁺ = F x + G u, from `x0`.
    ClosedLoop { x0: Vec<f64>, steps: usize },
    /// Given states, replayed in order.
    Given(Vec<Vec<f64>>),
}

/// Parses a list of numbers separated by commas or white space (`inf`, `-inf` allowed).
pub(crate) fn numbers(text: &str) -> Result<Vec<f64>, String> {
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<f64>().map_err(|e| format!("`{s}`: {e}")))
        .collect()
}

/// Reads a states file: one state per line (numbers as in [`numbers`]), `#` starts a comment.
pub(crate) fn read_states(text: &str) -> Result<Vec<Vec<f64>>, String> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i, l.split('#').next().unwrap_or("")))
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| numbers(l).map_err(|e| format!("line {}: {e}", i + 1)))
        .collect()
}

/// The state and constant reference of the sampled certificate's worst cold case
/// (`Evidence::cold_witness`). The dump replays a state under a constant reference from the
/// controller's own last input, so a witness that also sets u₋₁ or a disturbance cannot be replayed.
pub(crate) fn witness(
    p: &Problem,
    sampled: Option<&codegen::evidence::Evidence>,
) -> Result<(Vec<f64>, Vec<f64>), String> {
    let Some(e) = sampled.filter(|e| !e.cold_witness.is_empty()) else {
        return Err(
            "`--witness`: the spec's method has no sampled certificate (a constrained method on `[mpc.region]`)"
                .to_string(),
        );
    };
    let mut x0 = vec![0.0; p.nx];
    let mut reference = vec![0.0; p.qp.nz];
    for (name, v) in &e.cold_witness {
        let index = |prefix: &str| {
            name.strip_prefix(prefix)
                .and_then(|rest| rest.strip_suffix(']'))
                .and_then(|i| i.parse::<usize>().ok())
        };
        match (index("x0["), index("r[")) {
            (Some(i), _) if i < x0.len() => x0[i] = *v,
            (_, Some(i)) if i < reference.len() => reference[i] = *v,
            _ => {
                return Err(format!(
                    "`--witness`: the worst cold case sets `{name}` = {v}, which a dump cannot replay (it carries x0 and a constant reference, with the controller's own last input)"
                ))
            }
        }
    }
    Ok((x0, reference))
}

fn matrix(M: &DMatrix<f64>) -> Value {
    Value::Array(
        (0..M.nrows())
            .map(|i| json!(M.row(i).iter().collect::<Vec<_>>()))
            .collect(),
    )
}

fn vector(v: &DVector<f64>) -> Value {
    json!(v.iter().collect::<Vec<_>>())
}

/// The dump of `p` over `states` with the constant reference `reference` (nz entries, every step of
/// the window). Errors name the wrong length.
pub(crate) fn dump(
    spec: &str,
    p: &Problem,
    states: &States,
    reference: &[f64],
) -> Result<Value, String> {
    let qp = &p.qp;
    let (nx, nu, N, nz) = (p.nx, p.nu, qp.N, qp.nz);
    if reference.len() != nz {
        return Err(format!(
            "`--reference` has {} entries, the spec tracks nz = {nz}",
            reference.len()
        ));
    }
    let check = |x: &[f64], what: &str| {
        if x.len() == nx {
            Ok(())
        } else {
            Err(format!(
                "{what} has {} entries, the spec has nx = {nx}",
                x.len()
            ))
        }
    };
    let r = DVector::from_column_slice(reference);
    let window = vec![r; N];
    let mut mpc = oracle::Mpc::new(p);
    let mut steps = Vec::new();
    let mut x = match states {
        States::ClosedLoop { x0, .. } => {
            check(x0, "`--x0`")?;
            DVector::from_column_slice(x0)
        }
        States::Given(_) => DVector::zeros(nx),
    };
    let count = match states {
        States::ClosedLoop { steps, .. } => *steps,
        States::Given(s) => s.len(),
    };
    let no_disturbance = DVector::zeros(0);
    let mut worst_residual = 0.0_f64;
    for k in 0..count {
        if let States::Given(s) = states {
            check(&s[k], &format!("state {} of `--states`", k + 1))?;
            x = DVector::from_column_slice(&s[k]);
        }
        let last = mpc.last_input().clone();
        let f = mpc.linear_term(&x, &window);
        let offset = qp.rows.offset(&x, &no_disturbance, &last);
        let exact = codegen::exact::exact(&mpc_qp(qp, &f, &offset));
        if exact.status != ipm::Status::Converged {
            return Err(format!(
                "step {k}: the exact solve ended {:?}",
                exact.status
            ));
        }
        worst_residual = worst_residual.max(exact.primal_residual.max(exact.dual_residual));
        steps.push(json!({
            "x0": vector(&x),
            "u_last": vector(&last),
            "z_star": vector(&exact.z),
        }));
        let u = mpc.solve(&x, &window);
        x = &p.F * &x + &p.G * u;
    }
    let reference_window: Vec<f64> = (0..N).flat_map(|_| reference.iter().copied()).collect();
    // The QP's data-free parts: mpc_qp at f = 0 and offset 0.
    let base = mpc_qp(qp, &DVector::zeros(N * nu), &DVector::zeros(qp.rows.len()));
    let ns = qp.rows.slacks();
    Ok(json!({
        "format": "mpcc-qp/1",
        "spec": spec,
        "method": format!("{:?}", qp.method).to_lowercase(),
        "nx": nx, "nu": nu, "N": N, "nz": nz, "ns": ns,
        "n": base.n(), "m": base.A.nrows(),
        "H": matrix(&base.H),
        "F_x": matrix(&qp.Fx),
        "F_r": matrix(&qp.Fr),
        "F_u": matrix(&qp.Fu),
        "w_slack": vector(&qp.rows.slack_weight),
        "z_min": vector(&base.z_min),
        "z_max": vector(&base.z_max),
        "A": matrix(&base.A),
        "lower": vector(&qp.rows.lower),
        "upper": vector(&qp.rows.upper),
        "W_x": matrix(&qp.rows.Wx),
        "W_u": matrix(&qp.rows.Wu),
        "reference": reference_window,
        "exact_tolerance": EXACT_TOLERANCE,
        "exact_worst_residual": worst_residual,
        "steps": steps,
    }))
}
