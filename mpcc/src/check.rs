//! `mpcc check`: the certificate of a spec, for people and as JSON.
//!
//! The JSON names are stable: later features add keys, never rename them. A name with a dot in the
//! documentation (`lqr.spectral_radius`) is a nested object. A number that does not exist (the Lyapunov
//! solution of an unstable loop, the bound of a step above 1/L) is `null`.

use codegen::certificate::{Certificate, Shown, Value, DEFAULT_TOLERANCE};
use codegen::Generated;
use serde::Serialize;
use std::fmt::Write;

/// The JSON document: the spec's name and shape, the certificate's fields (flattened), the warnings.
#[derive(Serialize)]
struct Check<'a> {
    spec: &'a str,
    method: mpc_spec::Method,
    /// `[codegen] target`.
    target: mpc_spec::Target,
    /// The estimated cycles of one control step on the target, against its sampling period.
    control_step: &'a codegen::target::StepCost,
    horizon: usize,
    /// The move blocks' lengths in steps (one free input each, summing to `horizon`); absent without a
    /// control horizon or move blocking.
    #[serde(skip_serializing_if = "Option::is_none")]
    move_blocks: Option<&'a [usize]>,
    nx: usize,
    nu: usize,
    ny: usize,
    /// Tracked outputs: the rows of `[mpc] outputs`, else nx.
    nz: usize,
    /// Whether the spec has `[kalman]`; without, the controller takes the measured state (ny = nx).
    filter: bool,
    /// Whether the moves Δu are weighted (`[mpc] r_du`).
    moves: bool,
    model: Model,
    /// The back-offs (`x_backoff`, a group's `backoff`), one per tightened bound; absent without.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    backoff: Vec<Backoff>,
    #[serde(flatten)]
    certificate: &'a Certificate,
    warnings: Vec<&'a str>,
}

/// The discrete model the controller was built from, row by row: for a continuous-time spec the sampled
/// matrices, for a double integrator its F, G and eq. 3's Q.
#[derive(Serialize)]
struct Model {
    dt: f64,
    a: Vec<Vec<f64>>,
    b: Vec<Vec<f64>>,
    c: Vec<Vec<f64>>,
    /// The filter's process covariance of the state (without the disturbance's), when there is a filter.
    #[serde(skip_serializing_if = "Option::is_none")]
    q: Option<Vec<Vec<f64>>>,
}

/// One bound pulled in by a back-off.
#[derive(Serialize)]
struct Backoff {
    /// The spec's name of the bound: `x_min/x_max[1]`, `constraint[0] row 0`.
    row: String,
    /// The margin, in the bound's units.
    margin: f64,
    /// For `"<z>sigma"`: z, and σ = √(a·P∞·aᵀ) of the filter's steady-state error along the row.
    #[serde(skip_serializing_if = "Option::is_none")]
    z: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    sigma: Option<f64>,
}

/// The `rows` × `cols` matrix whose entry (i, j) is `at(i, j)`, as a list of rows.
fn rows(rows: usize, cols: usize, at: impl Fn(usize, usize) -> f64) -> Vec<Vec<f64>> {
    (0..rows)
        .map(|i| (0..cols).map(|j| at(i, j)).collect())
        .collect()
}

impl Model {
    fn of(p: &codegen::Problem) -> Self {
        let (nx, nu, ny) = (p.nx, p.nu, p.ny);
        Model {
            dt: p.dt,
            a: rows(nx, nx, |i, j| p.F[(i, j)]),
            b: rows(nx, nu, |i, j| p.G[(i, j)]),
            c: rows(ny, nx, |i, j| p.C[(i, j)]),
            q: p.filter.as_ref().map(|f| rows(nx, nx, |i, j| f.Qn[(i, j)])),
        }
    }
}

/// The exact count's lines beyond its numbers: what it covers, per block its parameters and worst, the
/// witness, and why it fell back.
fn exact_lines(x: &codegen::evidence::Exact, lines: &mut Vec<(String, String)>) {
    let status = if x.complete {
        "complete: proved for every x0 in the region, constant reference in its box, u₋₁ and d in theirs".to_string()
    } else {
        format!(
            "incomplete, the count is the sample's: {}",
            x.note.as_deref().unwrap_or("the budget ran out")
        )
    };
    lines.insert(0, ("partition".to_string(), status));
    for (b, (names, worst)) in x.block_parameters.iter().zip(&x.block_worst).enumerate() {
        lines.push((
            format!("block {b}: parameters, worst"),
            format!("{} ({}), {worst}", names.join(", "), names.len()),
        ));
    }
    if x.complete {
        lines.push((
            "witness (every block at its worst)".to_string(),
            named(&x.witness),
        ));
    }
    if x.complete && !x.work_witness.is_empty() {
        lines.push((
            "the heaviest path's witness".to_string(),
            named(&x.work_witness),
        ));
    }
    if x.path_mismatches > 0 {
        lines.push((
            "centres the kernel solved off their region's path".to_string(),
            format!(
                "{} of {} (a decision within the kernel's tolerances, which the partition takes as zero: f32's are wider; their work is the kernel's own)",
                x.path_mismatches, x.regions
            ),
        ));
    }
    lines.push((
        "a reference window varying over the horizon".to_string(),
        "covered by the sample only".to_string(),
    ));
}

/// A parameter by name: `x0[0] = 1.0000, r[0] = -2.5000`.
fn named(theta: &[(String, f64)]) -> String {
    theta
        .iter()
        .map(|(name, v)| format!("{name} = {v:.4}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The certificate as JSON, pretty-printed, with a final newline.
pub(crate) fn json(shown: &str, g: &Generated) -> String {
    let p = &g.problem;
    let check = Check {
        spec: shown,
        method: p.qp.method,
        target: g.step.machine.target,
        control_step: &g.step,
        horizon: p.qp.N,
        move_blocks: p.qp.blocked().then_some(&p.qp.blocks[..]),
        nx: p.nx,
        nu: p.nu,
        ny: p.ny,
        nz: p.qp.nz,
        filter: p.filter.is_some(),
        moves: p.has_moves(),
        model: Model::of(p),
        backoff: p
            .qp
            .backoff
            .iter()
            .map(|m| Backoff {
                row: m.kind.name(),
                margin: m.margin,
                z: m.sigmas.map(|s| s.0),
                sigma: m.sigmas.map(|s| s.1),
            })
            .collect(),
        certificate: &g.certificate,
        warnings: g.warnings.iter().map(|w| w.message.as_str()).collect(),
    };
    let mut out = serde_json::to_string_pretty(&check).expect("the certificate serializes");
    out.push('\n');
    out
}

/// The certificate for people: sections of one quantity a line, its symbol and its value, in the order of
/// [`Certificate::fields`] (the `report` module's constants).
pub(crate) fn text(shown: &str, g: &Generated) -> String {
    let c = &g.certificate;
    let p = &g.problem;
    let mut sections: Vec<(&str, Vec<(String, String)>)> = Vec::new();
    for field in c.fields() {
        let absent = matches!(
            field.value,
            Value::MaybeReal(None) | Value::MaybeCount(None)
        );
        if matches!(field.shown, Shown::IfPresent | Shown::Seconds) && absent {
            continue;
        }
        if sections
            .last()
            .is_none_or(|(title, _)| *title != field.section)
        {
            sections.push((field.section, Vec::new()));
        }
        let value = match (field.shown, field.value) {
            (Shown::Step, Value::Real(step)) => {
                format!("{} (= {}/L)", num(step), num(step * c.lipschitz))
            }
            (Shown::Convergence, Value::Real(v)) => contraction(v),
            (Shown::Stability, Value::Real(rho) | Value::MaybeReal(Some(rho))) => stability(rho),
            (Shown::Stability, _) => "not computed (problem too large)".into(),
            (Shown::Tolerance, Value::Real(tol)) => {
                let source = if p.qp.tolerance.is_some() {
                    " (spec)"
                } else if tol == DEFAULT_TOLERANCE {
                    " (default)"
                } else {
                    ""
                };
                format!("{tol:e}{source}")
            }
            (Shown::Bytes, Value::Real(bytes)) => codegen::budget::size(bytes),
            (Shown::Seconds, Value::Real(seconds) | Value::MaybeReal(Some(seconds))) => {
                format!("{seconds:.1} s")
            }
            (Shown::Range, Value::Real(x)) => {
                format!("for |{}| ≤ {x:.1e}", c.coordinate_range.names())
            }
            (Shown::Gap, Value::MaybeReal(Some(gap))) => {
                format!("Δ_{m}/Δ_0 ≤ {}", num(gap), m = c.iterations)
            }
            (_, value) => plain(value),
        };
        if let Some((_, lines)) = sections.last_mut() {
            lines.push((field.label, value));
        }
    }
    // The bound's form opens its section.
    let form = g.plan.solver.bound_form(c.rate.is_some());
    if let Some((_, lines)) = sections
        .iter_mut()
        .find(|(title, _)| *title == codegen::certificate::section::BOUND)
    {
        lines.insert(0, ("gap Δ_k = J(U_k) − J*".to_string(), form));
    }
    if let Some(e) = c.sampled.as_ref().filter(|e| !e.cold_witness.is_empty()) {
        if let Some((_, lines)) = sections
            .iter_mut()
            .find(|(title, _)| *title == codegen::certificate::section::SAMPLED)
        {
            let at = lines
                .iter()
                .position(|(label, _)| label == "iterations needed cold: worst")
                .map_or(lines.len(), |i| i + 1);
            lines.insert(
                at,
                (
                    "the heaviest cold case (`mpcc dump-qp --witness`)".to_string(),
                    named(&e.cold_witness),
                ),
            );
        }
    }
    if let Some((_, lines)) = sections
        .iter_mut()
        .find(|(title, _)| *title == codegen::certificate::section::EXACT)
    {
        if let Some(x) = &c.exact {
            exact_lines(x, lines);
        }
        let slack = c.sampled.as_ref().map_or(0, |e| e.slack_rows.len());
        if slack > 0 {
            lines.push((
                "rows of A that cannot bind over the region".to_string(),
                format!(
                    "{slack} of {} (not scanned where a solve's data keep the proof: `sampled.slack_rows`)",
                    g.problem.qp.rows.len()
                ),
            ));
        }
    }
    if !c.candidates.is_empty() {
        sections.insert(
            0,
            (
                "method = \"auto\": the candidates (cheapest that reaches `accuracy`; force with [mpc] method)",
                candidate_lines(c),
            ),
        );
    }
    if !p.qp.backoff.is_empty() {
        sections.push((
            "back-off: bounds pulled in by the margin (x_backoff, backoff)",
            p.qp.backoff
                .iter()
                .map(|m| {
                    let how = m.sigmas.map_or(String::new(), |(z, sigma)| {
                        format!(
                            " = {z}σ, σ = {} of the filter's steady-state error",
                            num(sigma)
                        )
                    });
                    (m.kind.name(), format!("{}{how}", num(m.margin)))
                })
                .collect(),
        ));
    }
    if let Some(choice) = &c.normal_form {
        sections.push((
            "normal system of the interior-point method (cost model: the cheaper form that is built)",
            normal_form_lines(choice),
        ));
    }
    if let Some(choice) = &c.admm_structure {
        sections.push((
            "x-update of ADMM (cost model: the cheaper structure that is built)",
            structure_lines(choice),
        ));
    }
    // Only the first-order methods run the gradient form: a constrained method ignores it.
    if g.plan.algorithm().is_some() {
        sections.push((
            "emission of the gradient (cost model; force with [codegen] emission)",
            emission_lines(c),
        ));
    }
    let mut target = target_lines(&g.step);
    // The exact partition's heaviest path, priced alone: the bound over the region's paths. Not where
    // a solve resumes at the next step (`restart = "continue"`): there a step stops at the warm budget.
    let heaviest_path = c
        .exact
        .as_ref()
        .filter(|x| x.complete && c.restart != Some(mpc_spec::Restart::Continue))
        .and_then(|x| x.cold_work);
    if let (Some(work), Some(_)) = (heaviest_path, g.step.period_cycles) {
        let cycles = g.step.cycles_with_solver(work.div_ceil(10));
        target.push((
            "a step whose solve is the exact count's heaviest path".to_string(),
            format!(
                "{cycles:.3e} cycles ({:.3e} instructions): the bound over the region's paths, cold",
                cycles / g.step.machine.cycles_per_instruction
            ),
        ));
    }
    sections.push(("target (estimated cycles; [codegen] target)", target));
    let width = sections
        .iter()
        .flat_map(|(_, lines)| lines.iter().map(|(what, _)| what.chars().count()))
        .max()
        .unwrap_or(0);
    let mut method = if p.requested == mpc_spec::Method::Auto {
        format!("{} (auto)", p.qp.method.name())
    } else {
        p.qp.method.name().to_string()
    };
    if p.qp.method == mpc_spec::Method::ActiveSet && p.qp.restart == mpc_spec::Restart::Continue {
        method += " resuming where a solve runs out (restart = \"continue\")";
    }
    let mut out = format!(
        "{shown}: {method}, horizon {}, {} iterations, nx = {}, nu = {}, ny = {}",
        p.qp.N, c.iterations, p.nx, p.nu, p.ny
    );
    if p.qp.blocked() {
        if p.qp.held_tail() {
            let _ = write!(out, ", control horizon {}", p.qp.Nc);
        } else {
            let _ = write!(out, ", move blocking {:?}", p.qp.blocks);
        }
    }
    if p.qp.Cz.is_some() {
        let _ = write!(out, ", nz = {} tracked outputs", p.qp.nz);
    }
    if p.has_moves() {
        out.push_str(", moves weighted");
    }
    if p.filter.is_none() {
        out.push_str(", state feedback (no filter)");
    }
    out.push('\n');
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

/// One line per candidate of `method = "auto"`: its count, how it is certified and its cost, or why it
/// could not be used.
fn candidate_lines(c: &Certificate) -> Vec<(String, String)> {
    let chosen = c.candidates.iter().find(|k| k.chosen).map(|k| k.method);
    let previous = codegen::choice::previous_choice(&c.candidates);
    let changed = match (chosen, previous) {
        (Some(now), Some(before)) if now != before => Some((
            "changed since the previous release".to_string(),
            format!(
                "it chose `{}`, without `{}` to weigh: the commands differ (docs/methods.md, \"Migrating\"); write `method = \"{}\"` to keep them",
                before.name(),
                now.name(),
                before.name()
            ),
        )),
        _ => None,
    };
    c.candidates
        .iter()
        .map(|k| {
            let what = format!(
                "{}{}",
                k.method.name(),
                if k.chosen { " (chosen)" } else { "" }
            );
            let value = match &k.unavailable {
                Some(why) => format!("unavailable: {why}"),
                None => {
                    let reach = match k.reaches_accuracy {
                        Some(true) => ", reaches `accuracy` on the sample",
                        Some(false) => ", misses `accuracy` on the sample",
                        None => "",
                    };
                    let at_worst = k.iterations * k.macs_per_iteration;
                    if k.macs_per_solve < at_worst {
                        // The dual active set: its budgets of work bind before its changes do.
                        format!(
                            "{} iterations ({}{reach}) at most, priced by its budgets of work: {} multiply-adds of its factor's loops a solve ({} × {} = {at_worst} at the worst pass)",
                            k.iterations, k.certified, k.macs_per_solve, k.iterations, k.macs_per_iteration
                        )
                    } else {
                        // What runs once per solve besides the iterations (a cold start, final residuals).
                        let once = k.macs_per_solve - at_worst;
                        let once = if once > 0 {
                            format!(" + {once} once")
                        } else {
                            String::new()
                        };
                        format!(
                            "{} iterations ({}{reach}) × {}{once} = {} multiply-adds a solve",
                            k.iterations, k.certified, k.macs_per_iteration, k.macs_per_solve
                        )
                    }
                }
            };
            (what, value)
        })
        .chain(changed)
        .collect()
}

/// A value as a plain number, `-` where it is absent.
fn plain(value: Value) -> String {
    match value {
        Value::Real(v) | Value::MaybeReal(Some(v)) => num(v),
        Value::Count(n) | Value::MaybeCount(Some(n)) => n.to_string(),
        Value::MaybeReal(None) | Value::MaybeCount(None) => "-".into(),
    }
}

fn contraction(contraction: f64) -> String {
    let verdict = if contraction < 1.0 {
        "converges"
    } else {
        "does not converge"
    };
    format!("{} ({verdict})", num(contraction))
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

/// The target, and one control step's estimated cycles against the sampling period.
fn target_lines(step: &codegen::target::StepCost) -> Vec<(String, String)> {
    let m = &step.machine;
    let mut features = vec![if m.f64_in_hardware {
        "f64 in hardware"
    } else {
        "single-precision FPU (f64 in software)"
    }];
    if m.simd == codegen::target::Simd::Neon {
        features.push("NEON");
    }
    let clock = m.clock_hz.map_or("no fixed clock".to_string(), |hz| {
        format!("{:.0} MHz", hz / 1e6)
    });
    let solver = step.budgeted().unwrap_or_else(|| {
        format!(
            "{} iterations × {} multiply-adds in {}",
            step.iterations,
            step.macs_per_iteration,
            step.solver_scalar.name(),
        )
    });
    let (cost, period) = match (step.period_cycles, step.load()) {
        (Some(cycles), Some(load)) => (
            format!(
                "{:.3e} cycles ({:.3e} instructions at {} cycles each), of which the solver {:.3e} ({solver}, {} cycles each)",
                step.cycles,
                step.cycles / m.cycles_per_instruction,
                codegen::target::significant(m.cycles_per_instruction, 3),
                step.solver_cycles,
                codegen::target::significant(step.solver_cycles_per_mac, 3)
            ),
            format!(
                "{} ms = {:.3e} cycles at {clock}: the step takes {:.1} %",
                num(step.dt * 1e3),
                cycles,
                100.0 * load
            ),
        ),
        _ => (
            format!(
                "{} multiply-adds, of which the solver {} ({solver})",
                step.solver_macs + step.other_macs,
                step.solver_macs
            ),
            format!(
                "{} ms; the host has no fixed clock, so no cycle estimate (write `target` for one)",
                num(step.dt * 1e3)
            ),
        ),
    };
    vec![
        (
            "target".to_string(),
            format!(
                "{}: {}, {clock}, {}",
                m.target.name(),
                m.processor,
                features.join(", ")
            ),
        ),
        ("control step".to_string(), cost),
        ("sampling period".to_string(), period),
    ]
}

/// One line per form of the interior-point method's normal system: its multiply-adds per iteration, or
/// why it is not built for the problem, and which one is used.
fn normal_form_lines(choice: &codegen::riccati::Choice) -> Vec<(String, String)> {
    condensed_or_riccati_lines(
        choice.form,
        (
            choice.condensed_macs_per_iteration,
            "L·D·Lᵀ of H + Gᵀ·diag(λ/s)·G within its envelope",
        ),
        (
            choice.riccati_macs_per_iteration,
            choice.riccati_unavailable.as_deref(),
            "stage-wise Riccati recursion",
        ),
    )
}

/// One line per structure of ADMM's x-update: its multiply-adds per iteration, or why it is not built
/// for the problem, and which one is used.
fn structure_lines(choice: &codegen::admm::StructureChoice) -> Vec<(String, String)> {
    condensed_or_riccati_lines(
        choice.structure,
        (
            choice.condensed_macs_per_iteration,
            "two triangular solves with the dense factor",
        ),
        (
            choice.riccati_macs_per_iteration,
            choice.riccati_unavailable.as_deref(),
            "Riccati sweep with gains computed at build time",
        ),
    )
}

/// The two lines of a choice between a condensed and a Riccati (stage-wise) form: each one's
/// multiply-adds per iteration and how it spends them, the Riccati form's unavailability where it is not
/// built, and "(chosen)" beside the one used.
fn condensed_or_riccati_lines(
    chosen: codegen::riccati::Form,
    (condensed_macs, condensed_how): (usize, &str),
    (riccati_macs, riccati_unavailable, riccati_how): (Option<usize>, Option<&str>, &str),
) -> Vec<(String, String)> {
    use codegen::riccati::Form;
    let name = |form: Form| {
        let mark = if form == chosen { " (chosen)" } else { "" };
        format!("{}{mark}", form.name())
    };
    let riccati = match (riccati_unavailable, riccati_macs) {
        (Some(why), Some(macs)) => format!("{macs} multiply-adds/iteration, unavailable: {why}"),
        (Some(why), None) => format!("unavailable: {why}"),
        (None, Some(macs)) => format!("{macs} multiply-adds/iteration ({riccati_how})"),
        (None, None) => "unavailable".to_string(),
    };
    vec![
        (
            name(Form::Condensed),
            format!("{condensed_macs} multiply-adds/iteration ({condensed_how})"),
        ),
        (name(Form::Riccati), riccati),
    ]
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
