//! The constrained specs on the Cortex-M4F (issue 18.4): each of specs/quadcopter.toml, hover.toml and
//! paper-limits.toml with `[codegen] target = "cortex-m4f"`, `scalar = "f32"` and its `method` line
//! removed (`auto`). `auto` picks the dual active-set method in f32 for all three. The quadcopter and
//! hover fit their periods (hover was refused before it); paper-limits reaches its accuracy in f32 (its
//! soft rows, at a weight of 1e5, take the kernel's primal refinement and check) but its bound is just
//! over its 12.8 ms period. ADMM, which `auto` weighs beside it there (no f64 hardware), is taken from the
//! same build (its certificate is the one `method = "admm"` gets, and the slowest part of these tests):
//! the quadcopter's fits its period (flown by the firmware's linear mode,
//! firmware-template/specs/quadcopter-m4f.toml) and hover's is refused (its ADMM is cheaper in f32 in the
//! residual form), all with ADMM's x-update stage by stage.

use codegen::{generate_from_source, Opt};
use mpc_spec::{Diagnostic, Method};

const HOVER: &str = include_str!("../../specs/hover.toml");
const PAPER_LIMITS: &str = include_str!("../../specs/paper-limits.toml");
const PAPER_LIMITS_M4F: &str = include_str!("../../firmware-template/specs/paper-limits-m4f.toml");
const QUADCOPTER: &str = include_str!("../../specs/quadcopter.toml");
const QUADCOPTER_M4F: &str = include_str!("../../firmware-template/specs/quadcopter-m4f.toml");

/// `spec` on the Cortex-M4F in f32 with `method = "admm"`.
fn on_m4f_admm(spec: &str) -> String {
    on_m4f(spec).replacen("\n[mpc]\n", "\n[mpc]\nmethod = \"admm\"\n", 1)
}

/// `spec` on the Cortex-M4F in f32, its method left to `auto` (paper-limits' `method = "ipm"` removed).
fn on_m4f(spec: &str) -> String {
    assert!(spec.contains("\n[codegen]\nscalar = \"f64\"\n"));
    spec.replacen("\nmethod = \"ipm\"\n", "\n", 1).replacen(
        "\n[codegen]\nscalar = \"f64\"\n",
        "\n[codegen]\ntarget = \"cortex-m4f\"\nscalar = \"f32\"\n",
        1,
    )
}

/// The text of `source`'s line at the start of `span`.
fn line_at(source: &str, span: &std::ops::Range<usize>) -> String {
    let start = source[..span.start].rfind('\n').map_or(0, |i| i + 1);
    let end = source[span.start..]
        .find('\n')
        .map_or(source.len(), |i| span.start + i);
    source[start..end].to_string()
}

/// The solver's plan and the step's estimated cost of `p`, lowered from `spec`, as `generate` prices it
/// before its period check.
fn step_of(
    spec: &mpc_spec::Spec,
    p: &codegen::Problem,
) -> (codegen::Plan, codegen::target::StepCost) {
    let plan = codegen::plan(spec, p).unwrap();
    let (resources, _) = codegen::certificate::predicted(p, &plan);
    let step = codegen::target::StepCost::of(spec, p, &resources);
    (plan, step)
}

/// Where a refusal's `hint` prices `change` and its cycles, which must fit the period.
fn fitting_price(hint: &str, change: &str) -> (usize, f64) {
    let at = hint
        .find(&format!("{change} (about "))
        .unwrap_or_else(|| panic!("no price for {change} in: {hint}"));
    let rest = &hint[at + change.len() + " (about ".len()..];
    let cycles: f64 = rest.split(' ').next().unwrap().parse().unwrap();
    assert!(
        rest.split(';')
            .next()
            .unwrap()
            .ends_with("of the period: fits)"),
        "{change}: {rest}"
    );
    (at, cycles)
}

/// The one error the compiler gives for `src`.
fn refusal(src: &str) -> Diagnostic {
    let Err(diags) = generate_from_source(src, &Opt::default()) else {
        panic!("the spec must be refused");
    };
    let all: Vec<_> = diags.iter().cloned().collect();
    assert_eq!(all.len(), 1, "{all:?}");
    all.into_iter().next().unwrap()
}

/// Under `auto`, the dual active-set method in f32 (its certificate runs the f32 kernel against the f64
/// exact solutions): within `accuracy` and within hover's 50 ms period, where ADMM is not.
///
/// ADMM, weighed beside it (the M4F has no f64 hardware, so `auto` certifies it too; its candidate is
/// the spec with `method = "admm"`), is cheaper in f32 in the residual form (the direct form's rounded
/// factor biases its fixed point, which it then needs some 22,000 iterations to bring within
/// `accuracy`), with its x-update stage by stage, and is refused for its period: some 2,800 iterations
/// of 5,300 multiply-adds at 4 cycles each (6.0e7), against the 8.4e6 cycles of 50 ms at 168 MHz. Its
/// certificate is the one `auto` weighed, taken from the same build (it takes most of this test's time).
#[test]
fn hover_on_the_m4f_takes_the_active_set_in_f32_and_its_admm_is_refused_on_its_period() {
    let src = on_m4f(HOVER);
    let spec = mpc_spec::load(&src).unwrap();
    let (resolved, p, weighed) = codegen::choice::resolve_weighed(&spec).unwrap();
    assert_eq!(p.qp.method, Method::ActiveSet);
    assert_eq!(p.requested, Method::Auto);
    let e = p.qp.evidence.as_ref().expect("sampled");
    assert!(e.worst_needed <= e.iterations, "{e:?}");
    assert!(e.worst_error <= p.qp.accuracy, "{e:?}");
    let (_, step) = step_of(&resolved, &p);
    assert_eq!(step.solver_scalar, mpc_spec::Scalar::F32);
    let load = step.load().expect("the M4F has a clock");
    assert!(load < 1.0, "{load}");
    codegen::target::check_period(&resolved, &step).expect("within its period");
    // The previous release chose ADMM (and refused it for the period).
    assert_eq!(
        codegen::choice::previous_choice(&p.candidates),
        Some(Method::Admm)
    );

    // ADMM, as `auto` weighed it.
    let (admm_spec, admm) = weighed
        .iter()
        .find(|(_, q)| q.qp.method == Method::Admm)
        .expect("ADMM weighed");
    let e = admm.qp.evidence.as_ref().expect("sampled");
    assert_eq!(
        e.admm_form.expect("ADMM's form"),
        codegen::admm::Form::Residual
    );
    assert!(e.worst_needed <= e.iterations, "{e:?}");
    assert!(e.worst_error <= admm.qp.accuracy, "{e:?}");
    // The refusal, as `generate` gives it for `method = "admm"` (the same certificate).
    let (_, step) = step_of(admm_spec, admm);
    let d = codegen::target::check_period(admm_spec, &step).expect_err("over its period");
    assert!(
        d.message.starts_with("a control step needs about ")
            && d.message.contains(
                " cycles on the STM32F405's Cortex-M4F at 168 MHz, more than the 8.40e6 of its 50 ms period"
            ),
        "{}",
        d.message
    );
    assert!(step.cycles > 5.0 * 8.4e6, "{}", d.message);
    let settings = codegen::admm::certified_settings(&admm.qp).unwrap();
    assert_eq!(settings.structure(), codegen::admm::Structure::Riccati);
    assert_eq!(
        step.macs_per_iteration,
        codegen::admm::mpc_settings_macs_per_iteration(&admm.qp, &settings)
    );
    assert!(
        step.macs_per_iteration
            < codegen::admm::mpc_macs_per_iteration_in(&admm.qp, codegen::admm::Form::Residual) / 2
    );
    assert_eq!(
        line_at(&src, d.span.as_ref().expect("located")),
        "dt = 0.05"
    );
    // The count's label names the solver and its form.
    assert!(
        d.related[0]
            .1
            .contains(" iterations of ADMM (residual form), "),
        "{:?}",
        d.related
    );
}

/// Under `auto`, the dual active-set method in f32: its soft rows' multipliers reach the weight (1e5),
/// where the f32 kernel refines z on its working rows and checks the rows on z itself (a row violated
/// there, or a multiplier of the wrong sign after the refinement, restarts the block once), so its
/// certificate reaches `accuracy` (it did not before). Its step is then over the 12.8 ms period, and
/// refused (the build's hint prices `horizon = 7` to fit). The board agrees: the sample's heaviest cold
/// case (229 changes from a corner of the region) replayed on the emulated STM32F405
/// (`scripts/witness.sh --board netduinoplus2 paper-limits`) took 3,120,411 instructions, 145 % of the
/// period at one a cycle. The estimate of a cold solve (its budget of work) holds that measurement
/// within the 1.5×, and a step (a warm solve and the cold restart) stays above it.
#[test]
fn paper_limits_on_the_m4f_reaches_its_accuracy_in_f32_and_is_refused_over_its_period() {
    let src = on_m4f(PAPER_LIMITS);
    let spec = mpc_spec::load(&src).unwrap();
    let (resolved, p) = codegen::choice::resolve(&spec).unwrap();
    assert_eq!(p.qp.method, Method::ActiveSet);
    let e = p.qp.evidence.as_ref().expect("sampled");
    assert!(e.worst_needed <= e.iterations, "{e:?}");
    assert!(e.worst_error <= p.qp.accuracy, "{e:?}");
    assert!(e.worst_error <= 1e-4, "{e:?}");
    // The previous release chose ADMM.
    assert_eq!(
        codegen::choice::previous_choice(&p.candidates),
        Some(Method::Admm)
    );
    let (plan, step) = step_of(&resolved, &p);
    assert_eq!(step.solver_scalar, mpc_spec::Scalar::F32);
    let load = step.load().expect("the M4F has a clock");
    let measured = 3_120_411.0;
    let witness = measured / step.period_cycles.expect("a clock");
    assert!(load > witness, "{load} against the witness's {witness}");
    // The cold solve's estimate in instructions (one a cycle on the M4F) and the rest of the step.
    let cold = plan
        .solver
        .macs_per_cold_solve(&p, &plan)
        .expect("two solves a step") as f64
        * step.solver_cycles_per_mac
        + (step.cycles - step.solver_cycles);
    let bound = cold / step.machine.cycles_per_instruction;
    assert!(
        bound >= measured && bound <= 1.5 * measured,
        "a cold solve's bound {bound} against the board's {measured}"
    );
    // The refusal, as `generate` gives it (without its priced hint, which would certify every change
    // again: `a_refusal_prices_the_cheaper_changes` covers the hint).
    let d = codegen::target::check_period(&resolved, &step).expect_err("over its period");
    assert!(
        d.message.starts_with("a control step needs about ")
            && d.message
                .contains(" cycles on the STM32F405's Cortex-M4F at 168 MHz, more than the 2.15e6 of its 12.8 ms period"),
        "{}",
        d.message
    );
    assert_eq!(
        line_at(&src, d.span.as_ref().expect("located")),
        "dt = 0.0128"
    );
}

/// paper-limits on the M4F with `restart = "continue"`: a solve that runs out of its budget falls back
/// and the next step resumes from its working set instead of restarting cold, so every solve, cold or
/// warm, spends at most the warm budget (the sample's warm-started most plus its margin). The step is
/// one such solve, priced so, and fits the 12.8 ms period that the cold restart does not; the board's
/// heaviest cold case (3,120,411 instructions) is then more than a step allows: from that corner the
/// controller holds its plan for a few steps while the solve resumes (`tests/tests/active_set.rs`
/// resumes it on the host). `firmware-template/specs/paper-limits-m4f.toml` is this variant. Restarting
/// cold, the refusal's hint prices this change first.
#[test]
fn paper_limits_on_the_m4f_fits_its_period_when_a_solve_resumes_instead_of_restarting_cold() {
    let src = on_m4f(&PAPER_LIMITS.replacen(
        "\nmethod = \"ipm\"\n",
        "\nmethod = \"active_set\"\nrestart = \"continue\"\n",
        1,
    ));
    // The firmware's spec is this very variant, comments aside.
    let body = |s: &str| -> Vec<String> {
        s.lines()
            .filter(|l| !l.trim_start().starts_with('#') && !l.trim().is_empty())
            .map(str::to_owned)
            .collect()
    };
    assert_eq!(body(PAPER_LIMITS_M4F), body(&src));
    let spec = mpc_spec::load(&src).unwrap();
    assert_eq!(spec.mpc.restart, mpc_spec::Restart::Continue);
    let (resolved, p) = codegen::choice::resolve(&spec).unwrap();
    assert_eq!(p.qp.method, Method::ActiveSet);
    let caps = codegen::solver::active_set::mpc::Caps::of(&p.qp);
    assert!(caps.warm_work < caps.cold_work, "{caps:?}");
    assert_eq!(caps.of_solve(false), (caps.cold, caps.warm_work));
    assert_eq!(caps.of_solve(true), (caps.cold, caps.warm_work));
    let (plan, step) = step_of(&resolved, &p);
    // One solve a step: the step's solver is the cold solve's price, at the warm budget.
    let per_step = plan.solver.macs_per_step(&p, &plan);
    assert_eq!(Some(per_step), plan.solver.macs_per_cold_solve(&p, &plan));
    let load = step.load().expect("the M4F has a clock");
    assert!(load < 1.0, "{load}");
    codegen::target::check_period(&resolved, &step).expect("within its period");
    // The board's heaviest cold case would not fit one step: it resumes.
    let measured = 3_120_411.0;
    assert!(step.cycles < measured, "{} against {measured}", step.cycles);
    // Restarting cold, the same spec is refused over its period, and the refusal's hint names this
    // change first, at this step's price.
    let d = refusal(&src.replace("restart = \"continue\"", "restart = \"cold\""));
    assert!(d.message.contains("of its 12.8 ms period"), "{}", d.message);
    let hint = d.note.as_deref().expect("a hint");
    let (at, cycles) = fitting_price(hint, "`restart = \"continue\"`");
    assert_eq!(at, "hint: ".len(), "{hint}");
    assert!(
        (step.cycles - cycles).abs() <= 5e-3 * step.cycles,
        "{cycles} against {}",
        step.cycles
    );
}

/// The quadcopter on the M4F: `auto` takes the dual active set in f32, within its period, and ADMM in f32,
/// weighed beside it, also fits: `firmware-template/specs/quadcopter-m4f.toml` writes `method = "admm"` and
/// the firmware's linear mode flies it. ADMM's certificate is the one `auto` weighed (the same as the
/// written method's), taken from the same build.
#[test]
fn the_quadcopter_on_the_m4f_builds_with_admm_in_f32_within_its_period() {
    // The firmware's spec is this very variant, comments aside.
    let body = |s: &str| -> Vec<String> {
        s.lines()
            .filter(|l| !l.trim_start().starts_with('#') && !l.trim().is_empty())
            .map(str::to_owned)
            .collect()
    };
    assert_eq!(body(QUADCOPTER_M4F), body(&on_m4f_admm(QUADCOPTER)));
    let spec = mpc_spec::load(&on_m4f(QUADCOPTER)).unwrap();
    let (resolved, p, weighed) = codegen::choice::resolve_weighed(&spec).unwrap();
    // Under `auto` it is the dual active-set method in f32, within the period.
    assert_eq!(p.qp.method, Method::ActiveSet);
    let (_, step) = step_of(&resolved, &p);
    assert!(step.load().expect("a clock") < 1.0);
    // ADMM, by the stage-wise ADMM's own figure on the M4F (3.0 cycles a multiply-add, the emulated
    // board's 2.90 instructions rounded up; `tests/tests/firmware/linear.rs` checks it against the
    // flight): 53 %.
    let (admm_spec, admm) = weighed
        .iter()
        .find(|(_, q)| q.qp.method == Method::Admm)
        .expect("ADMM weighed");
    let (_, step) = step_of(admm_spec, admm);
    assert_eq!(step.solver_scalar, mpc_spec::Scalar::F32);
    assert_eq!(
        step.solver_cycles_per_mac,
        codegen::target::CORTEX_M4F.cycles_per_mac_admm_stages
    );
    let load = step.load().expect("the M4F has a clock");
    assert!(load > 0.5 && load < 1.0, "{load}");
    codegen::target::check_period(admm_spec, &step).expect("within its period");
}

/// A refusal prices the changes the compiler can build (issue 34, item 4): the published pendulum in
/// f64 on the M4F, where `auto` does not weigh the active set (no f64 hardware) and takes ADMM, over
/// its 10 ms period. The hint gives f32 and `method = "active_set"` with their cycles, both within the
/// period, each as the compiler builds it: the active set written explicitly builds and its step fits.
#[test]
fn a_refusal_prices_the_cheaper_changes() {
    let src = include_str!("../../tests/specs/pendulum/cortex-m4f.toml")
        .replace("scalar = \"f32\"", "scalar = \"f64\"");
    let d = refusal(&src);
    let hint = d.note.as_deref().expect("a hint");
    assert!(d.message.contains("of its 10 ms period"), "{}", d.message);
    assert!(
        d.related[0].1.contains(" iterations of ADMM"),
        "{:?}",
        d.related
    );
    let priced = |change: &str| fitting_price(hint, change).1;
    let f32_cycles = priced("`scalar = \"f32\"` in `[codegen]`");
    let active_set = priced("`method = \"active_set\"`");
    assert!(f32_cycles < active_set, "{hint}");
    // The active set as written: it builds, and its step is the price.
    let written = src.replace("[mpc]\n", "[mpc]\nmethod = \"active_set\"\n");
    let g = generate_from_source(&written, &Opt::default()).expect("fits");
    assert_eq!(g.problem.qp.method, Method::ActiveSet);
    // The hint prints three significant digits: within half a unit of the third (5e-3 relative at
    // worst, where the leading digit is 1).
    let relative = (g.step.cycles - active_set).abs() / g.step.cycles;
    assert!(relative <= 5e-3, "{} against {active_set}", g.step.cycles);
}
