//! `mpcc check`: the certificate of a spec, for people and as JSON.
//!
//! The JSON names are stable: later features add keys, never rename them. A name with a dot in the
//! documentation (`lqr.spectral_radius`) is a nested object. A number that does not exist (the Lyapunov
//! solution of an unstable loop, the bound of a step above 1/L) is `null`.

use codegen::certificate::{Certificate, DEFAULT_TOLERANCE};
use codegen::Generated;
use mpc_spec::Method;
use serde_json::{json, Value};
use std::fmt::Write;

/// The certificate as JSON, pretty-printed, with a final newline.
pub(crate) fn json(shown: &str, g: &Generated) -> String {
    let c = &g.certificate;
    let r = &c.resources;
    let p = &g.problem;
    let value = json!({
        "spec": shown,
        "method": method_name(p.qp.method),
        "horizon": p.qp.N,
        "nx": p.nx,
        "nu": p.nu,
        "ny": p.ny,
        "lipschitz": c.lipschitz,
        "strong_convexity": c.strong_convexity,
        "condition_number": c.condition_number,
        "step": c.step,
        "momentum": c.momentum,
        "contraction": c.contraction,
        "iterations": c.iterations,
        "iterations_bound": c.iterations_bound,
        "tolerance": c.tolerance,
        "guaranteed_gap": c.guaranteed_gap,
        "rate": c.rate.map(|rate| json!({ "constant": rate.constant, "factor": rate.factor })),
        "lqr": {
            "spectral_radius": c.lqr.spectral_radius,
            "lyapunov_min": c.lqr.lyapunov_min,
            "lyapunov_max": c.lqr.lyapunov_max,
        },
        "mpc": {
            "spectral_radius": c.mpc.spectral_radius,
            "solver_spectral_radius": c.mpc.solver_spectral_radius,
        },
        "disturbance_time_constant": c.disturbance_time_constant,
        "macs_per_iteration": r.macs_per_iteration,
        "macs_per_cycle": r.macs_per_cycle,
        "bytes_constants": r.bytes_constants,
        "bytes_state": r.bytes_state,
        "bytes_state_mpc": r.bytes_state_mpc,
        "bytes_state_kalman": r.bytes_state_kalman,
        "emission": c.emission.name(),
        "emission_estimates": c.estimates.iter().map(|e| json!({
            "emission": e.emission.name(),
            "unavailable": e.unavailable,
            "score": e.score,
            "macs_per_iteration": e.macs,
            "code_bytes": e.code_bytes,
            "table_bytes": e.table_bytes,
        })).collect::<Vec<_>>(),
        "warnings": g.warnings.iter().map(|w| Value::from(w.message.clone())).collect::<Vec<_>>(),
    });
    let mut out = serde_json::to_string_pretty(&value).expect("a JSON value serializes");
    out.push('\n');
    out
}

/// The certificate for people: sections of one quantity a line, its symbol and its value.
pub(crate) fn text(shown: &str, g: &Generated) -> String {
    let c = &g.certificate;
    let p = &g.problem;
    let r = &c.resources;
    let method = method_name(p.qp.method);
    let bound = match c.rate {
        Some(rate) => {
            let form = match p.qp.method {
                Method::Gradient => "≤ (1 − αμ)^k · Δ_0",
                Method::Fgm => "≤ 2·(1 − √(αμ))^k · Δ_0",
            };
            let tolerance = if p.qp.tolerance.is_some() {
                "(spec)"
            } else if c.tolerance == DEFAULT_TOLERANCE {
                "(default)"
            } else {
                ""
            };
            vec![
                ("gap Δ_k = J(U_k) − J*".to_string(), form.to_string()),
                ("factor per iteration".into(), num(rate.factor)),
                (
                    "tolerance on Δ_k/Δ_0".into(),
                    format!("{:e} {tolerance}", c.tolerance),
                ),
                (
                    "iterations the bound needs".into(),
                    c.iterations_bound.map_or("-".into(), |k| k.to_string()),
                ),
                (
                    format!("what {} iterations guarantee", c.iterations),
                    c.guaranteed_gap.map_or("-".into(), |gap| {
                        format!("Δ_{}/Δ_0 ≤ {}", c.iterations, num(gap))
                    }),
                ),
            ]
        }
        None => vec![(
            "bound".to_string(),
            "none: the step is above 1/L (see the contraction)".to_string(),
        )],
    };
    let mut sections: Vec<(&str, Vec<(String, String)>)> = vec![
        (
            "QP (condensed Hessian H)",
            vec![
                ("L = λmax(H)".into(), num(c.lipschitz)),
                ("μ = λmin(H)".into(), num(c.strong_convexity)),
                ("condition number L/μ".into(), num(c.condition_number)),
            ],
        ),
        (
            "solver",
            vec![
                (
                    "step α".into(),
                    format!("{} (= {}/L)", num(c.step), num(c.step * c.lipschitz)),
                ),
                ("momentum β".into(), num(c.momentum)),
                ("contraction per iteration".into(), contraction(c)),
            ],
        ),
        ("a priori bound (any start inside the box)", bound),
        (
            "nominal stability: LQR of Q and R (paper, 2.4.3)",
            vec![
                ("ρ(F − G·K_LQR)".into(), stability(c.lqr.spectral_radius)),
                (
                    "λmin(P), P from (F − GK)ᵀP(F − GK) − P = −I".into(),
                    num(c.lqr.lyapunov_min),
                ),
                ("λmax(P)".into(), num(c.lqr.lyapunov_max)),
            ],
        ),
        (
            "MPC closed loops (constraints inactive)",
            vec![
                (
                    "ρ(F − G·K_MPC), QP solved exactly".into(),
                    stability(c.mpc.spectral_radius),
                ),
                (
                    "ρ of the fixed-iteration warm-started solver".into(),
                    c.mpc
                        .solver_spectral_radius
                        .map_or("not computed (problem too large)".into(), stability),
                ),
            ],
        ),
        (
            "resources",
            vec![
                (
                    "multiply-adds per iteration".into(),
                    r.macs_per_iteration.to_string(),
                ),
                (
                    "multiply-adds per control cycle".into(),
                    r.macs_per_cycle.to_string(),
                ),
                ("bytes of constants".into(), r.bytes_constants.to_string()),
                (
                    "bytes of state (Controller)".into(),
                    format!(
                        "{} (Mpc {}, Kalman {})",
                        r.bytes_state, r.bytes_state_mpc, r.bytes_state_kalman
                    ),
                ),
            ],
        ),
    ];
    sections.push((
        "emission of the gradient (cost model; force with [codegen] emission)",
        emission_lines(c),
    ));
    if let Some(tau) = c.disturbance_time_constant {
        sections.insert(
            5,
            (
                "offset-free: the input disturbance estimate",
                vec![("time constant, s".into(), num(tau))],
            ),
        );
    }
    let width = sections
        .iter()
        .flat_map(|(_, lines)| lines.iter().map(|(what, _)| what.chars().count()))
        .max()
        .unwrap_or(0);
    let mut out = format!(
        "{shown}: {method}, horizon {}, {} iterations, nx = {}, nu = {}, ny = {}\n",
        p.qp.N, c.iterations, p.nx, p.nu, p.ny
    );
    for (title, lines) in sections {
        let _ = write!(out, "\n{title}\n");
        for (what, value) in lines {
            // Pad by characters, not bytes: the symbols are not ASCII.
            let pad = width - what.chars().count();
            let _ = writeln!(out, "  {what}{:pad$}  {value}", "");
        }
    }
    if !g.warnings.is_empty() {
        let n = g.warnings.0.len();
        let _ = writeln!(
            out,
            "\n{n} warning{} (above)",
            if n == 1 { "" } else { "s" }
        );
    }
    out
}

fn method_name(m: Method) -> &'static str {
    match m {
        Method::Fgm => "fgm",
        Method::Gradient => "gradient",
    }
}

fn contraction(c: &Certificate) -> String {
    let verdict = if c.contraction < 1.0 {
        "converges"
    } else {
        "does not converge"
    };
    format!("{} ({verdict})", num(c.contraction))
}

fn stability(rho: f64) -> String {
    let verdict = if rho < 1.0 { "stable" } else { "not stable" };
    format!("{} ({verdict})", num(rho))
}

/// Six significant digits, in scientific notation outside [1e-3, 1e6); `NaN` as `-`.
fn num(v: f64) -> String {
    if v.is_nan() {
        return "-".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e6).contains(&a) {
        return format!("{v:.5e}");
    }
    let decimals = (5 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// One line per emission choice: the score, the work and the code, and which one was taken.
fn emission_lines(c: &codegen::Certificate) -> Vec<(String, String)> {
    c.estimates
        .iter()
        .map(|e| {
            let what = format!(
                "{}{}",
                e.emission.name(),
                if e.emission == c.emission {
                    " (chosen)"
                } else {
                    ""
                }
            );
            let value = match &e.unavailable {
                Some(why) => format!("unavailable: {why}"),
                None => format!(
                    "score {:.0}, {} multiply-adds/iteration, code ≈ {} B{}, tables {} B",
                    e.score,
                    e.macs,
                    e.code_bytes,
                    if e.code_bytes > codegen::cost::CODE_BUDGET {
                        " (over budget)"
                    } else {
                        ""
                    },
                    e.table_bytes
                ),
            };
            (what, value)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::num;

    #[test]
    fn six_significant_digits() {
        assert_eq!(num(0.9390124), "0.939012");
        assert_eq!(num(142.4412), "142.441");
        assert_eq!(num(4.0), "4");
        assert_eq!(num(123456.7), "123457");
        assert_eq!(num(1.5e-5), "1.50000e-5");
        assert_eq!(num(f64::NAN), "-");
    }
}
