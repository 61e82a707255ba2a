//! What the compiler knows of the machine a controller runs on, `[codegen] target`: whether it computes
//! f64 in hardware, its SIMD, its clock, and roughly what a multiply-add costs there in cycles. From these
//! it estimates the cycles of one control step ([`StepCost`]), refuses a step that cannot fit the sampling
//! period ([`check_period`]) and warns about an f64 scalar without f64 hardware ([`review`]).
//!
//! The target changes no emitted code. The NEON kernels are still chosen as before (`form::neon`: f32 in
//! one 4-lane register, compiled under `cfg(mpc_neon)` whatever the target), and the cost model's score
//! (`cost`) still counts 4-lane vectors on every target.
//!
//! # Where the figures come from
//! A multiply-add's cost is the instructions the emulated boards run per multiply-add of the compiler's
//! own count (`Resources::macs_per_cycle`, `mpcc check`), times cycles per instruction:
//!
//! | target | scalar | instructions per control cycle | multiply-adds | per multiply-add | cycles per instruction | cycles per multiply-add |
//! |---|---|---|---|---|---|---|
//! | cortex-a9 | f32 | 25,820 (`specs/paper.toml`, NEON lanes) | 31,671 | 0.82 | 1.5 | 1.2 |
//! | cortex-a9 | f64 | 36,950 (`firmware-template/specs/paper-f64-n10.toml`, lanes on the VFP) | 10,236 | 3.6 | 1.5 | 5.4 |
//! | cortex-m4f | f32 | 88,300 (`specs/paper.toml`) | 31,671 | 2.8 | 1 | 2.8 |
//! | cortex-m4f | f64 | 1,665,603 (`firmware-template/specs/paper-f64-n10.toml`, software floating point) | 10,236 | 163 | 1 | 163 |
//! | cortex-a9 | f64, interior-point method | 3,524,450 (`specs/paper-limits.toml`) | 514,480 | 6.85 | 1.5 | 10.3 |
//! | cortex-m4f | f64, interior-point method | not run (the method is refused there) | | | 1 | 311 |
//! | cortex-a9 | f32, ADMM | 13,333,810 (`firmware-template/specs/quadcopter-m4f.toml`, on the VFP) | 3,060,790 | 4.36 | 1.5 | 6.6 |
//! | cortex-m4f | f32, ADMM | 12,003,230 (`firmware-template/specs/quadcopter-m4f.toml`) | 3,060,790 | 3.92 | 1 | 4.0 |
//! | cortex-a9 | f32, ADMM, x-update stage by stage | 9,312,850 (`firmware-template/specs/quadcopter-m4f.toml`, on the VFP) | 2,942,646 | 3.16 | 1.5 | 4.8 |
//! | cortex-m4f | f32, ADMM, x-update stage by stage | 8,526,738 (`firmware-template/specs/quadcopter-m4f.toml`) | 2,942,646 | 2.90 | 1 | 3.0 |
//! | cortex-a9 | f64, dual active set | 2,799,410 (paper-limits' heaviest cold case, a cold solve) | 108,202 of the factor's loops (the work / 10) | 25.9 → 28.5 | 1.5 | 42.7 |
//! | cortex-m4f | f32, dual active set | 283,331 (paper's heaviest cold case, a cold solve) | 9,588 of the factor's loops (the work / 10) | 29.6 → 32.6 | 1 | 32.6 |
//!
//! The instruction counts are those of benchmarks/NOTES.md: "Runtime hardening" (both boards' `paper.toml` with
//! screening) and "Firmware (emulated Zynq-7000)" and "Firmware (emulated Cortex-M4F)" (the f64 rows). Under QEMU they are instructions, not cycles: the A9's 1.5 cycles
//! per instruction is benchmarks/NOTES.md's estimate from the A9's published NEON issue rates (section
//! "Emulated Cortex-A9", "Cycles, estimated"); a Cortex-M4 retires at most one instruction a cycle, so 1 is
//! a lower bound there (flash wait states and multi-cycle divides come on top). These are estimates to a
//! factor of about two, good enough to tell a step that fits its period from one that cannot. The
//! interior-point method's row is its own: besides its multiply-adds it divides, selects and checks per
//! side (`scripts/firmware.sh --cycles 30 specs/paper-limits.toml`, ticks × 10; benchmarks/NOTES.md, "The
//! interior-point method on the emulated Zynq"). The M4F's is the A9's ratio to plain f64 (10.3 / 5.4)
//! times the M4F's soft-float f64: derived, not measured, as the method is refused there. ADMM's rows
//! are its own too (`scripts/firmware.sh --cycles 100 [--board netduinoplus2]
//! firmware-template/specs/quadcopter-m4f.toml`; benchmarks/NOTES.md, "ADMM on the emulated Cortex-M4F"): its
//! products are written out, but every iteration also clamps and updates each row's z and y, which its
//! multiply-add count leaves out; rounded up. The condensed rows are from the firmware before ADMM's
//! x-update went stage by stage (commit 6fd3446); the stage-wise rows from after it, which the firmware
//! tests now check. ADMM in f64 is taken at its f32 figure where f64 is in
//! hardware (the same scalar instructions on the VFP) and scaled by the soft-float ratio where it is not
//! (derived, not measured). The dual active set's rows are the largest of four witnesses per board (paper,
//! paper-limits, quadcopter, hover: the sampled certificate's heaviest cold case replayed by
//! `scripts/witness.sh --board zynq|netduinoplus2`, instructions over the solve's work as the kernel
//! counts it, `solver::active_set::Macs::work`, in multiply-adds of the factor's loops), raised by 10 %,
//! so that the estimate of each witness's solve (its budget of work) is at or above the instructions it
//! took (BENCHMARKS.md, "The worst cold case on the boards"). The A9's f32 is taken as its f64 (the kernel
//! uses no NEON), and f64 without f64 hardware as the f32 figure plus the soft-float cost of one
//! multiply-add (a tenth of the work holds at most one; derived, not measured).

use crate::certify::certificate::Resources;
use crate::lower::problem::Problem;
use mpc_spec::{Diagnostic, Diagnostics, Scalar, Spec};

pub use super::machine::{machine, Machine, Simd, CORTEX_A9, CORTEX_M4F, HOST};

/// The estimated cost of one control step on the spec's target: the solver's iterations in the scalar the
/// method computes in, the rest of the cycle (filter, gradient map) in the module's scalar.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct StepCost {
    /// The machine.
    pub machine: Machine,
    /// The solver, in words (ADMM's form named where it is the residual one).
    pub solver: &'static str,
    /// The solver's iterations per step, at most ([`super::Solver::iterations_per_step`]).
    pub iterations: usize,
    /// Multiply-adds of one iteration.
    pub macs_per_iteration: usize,
    /// Multiply-adds of the solver (iterations × multiply-adds per iteration and the once-per-solve
    /// part; the dual active set's budgets of work, [`super::Solver::macs_per_step`]).
    pub solver_macs: usize,
    /// The scalar the solver computes in: f64 for the interior-point method, else the module's.
    pub solver_scalar: Scalar,
    /// Estimated cycles per multiply-add of the solver.
    pub solver_cycles_per_mac: f64,
    /// Multiply-adds of the rest of the control cycle (filter update and predict, gradient map).
    pub other_macs: usize,
    /// The module's scalar, which the rest runs in.
    pub scalar: Scalar,
    /// The estimated cycles of the solver's iterations.
    pub solver_cycles: f64,
    /// The estimated cycles of the whole control step.
    pub cycles: f64,
    /// The sampling period.
    pub dt: f64,
    /// The cycles in one sampling period at the nominal clock; `None` on the host.
    pub period_cycles: Option<f64>,
    /// The estimated cycles of the same step with `scalar = "f32"`, where the module's scalar is f64 and
    /// the solver would then compute in f32 (not the interior-point method, which computes in f64
    /// whatever the scalar): the same multiply-adds at f32's cycles per multiply-add.
    pub f32_cycles: Option<f64>,
}

impl StepCost {
    /// The cost of one control step of `p`, lowered from `spec`, whose resources are
    /// `r` (`certificate::predicted`).
    pub fn of(spec: &Spec, p: &Problem, r: &Resources) -> Self {
        let mut machine = *machine(spec.codegen.target);
        if let Some(hz) = spec.codegen.clock_hz {
            machine.clock_hz = Some(hz);
        }
        let solver = super::of(p.qp.method);
        let solver_scalar = solver.scalar(p.scalar);
        let iterations = solver.iterations_per_step(&p.qp);
        let solver_macs = r.macs_per_solve;
        let other_macs = r.macs_per_cycle.saturating_sub(solver_macs);
        let solver_cycles_per_mac = solver.cycles_per_mac(&machine, p.scalar, &p.qp);
        let solver_cycles = solver_macs as f64 * solver_cycles_per_mac;
        let f32_cycles = (p.scalar == Scalar::F64 && solver.scalar(Scalar::F32) == Scalar::F32)
            .then(|| {
                solver_macs as f64 * solver.cycles_per_mac(&machine, Scalar::F32, &p.qp)
                    + machine.cycles(other_macs, Scalar::F32)
            });
        StepCost {
            machine,
            solver: solver.name(&p.qp),
            iterations,
            macs_per_iteration: r.macs_per_iteration,
            solver_macs,
            solver_scalar,
            solver_cycles_per_mac,
            other_macs,
            scalar: p.scalar,
            solver_cycles,
            cycles: solver_cycles + machine.cycles(other_macs, p.scalar),
            dt: p.dt,
            period_cycles: machine.period_cycles(p.dt),
            f32_cycles,
        }
    }

    /// The cycles of a step whose solver spends `solver_macs` multiply-adds instead of the priced ones
    /// (one given solve: a witness, the exact partition's heaviest path), beside the rest of the step.
    pub fn cycles_with_solver(&self, solver_macs: usize) -> f64 {
        solver_macs as f64 * self.solver_cycles_per_mac + (self.cycles - self.solver_cycles)
    }

    /// The solver's work in words, where its budgets of work price it below its iterations at the worst
    /// one's multiply-adds (the dual active set, [`super::Solver::macs_per_step`]); `None` otherwise,
    /// where it is iterations × multiply-adds each.
    pub fn budgeted(&self) -> Option<String> {
        (self.solver_macs < self.iterations * self.macs_per_iteration).then(|| {
            format!(
                "at most {} iterations, priced by its budgets of work: {} multiply-adds of its factor's loops in {}",
                self.iterations,
                self.solver_macs,
                self.solver_scalar.name()
            )
        })
    }

    /// The share of the sampling period the step takes; `None` on the host.
    pub fn load(&self) -> Option<f64> {
        self.period_cycles.map(|period| self.cycles / period)
    }
}

/// `x` rounded to `digits` significant digits, written without an exponent where it has at most six
/// integer digits (trailing zeros after the point dropped): `significant(232.857142, 3)` is "233",
/// `significant(0.0123456, 3)` is "0.0123", `significant(12345.0, 3)` is "12300"; beyond, in scientific
/// notation ("1.23e7").
pub fn significant(x: f64, digits: usize) -> String {
    if !x.is_finite() || x == 0.0 {
        return format!("{x}");
    }
    let digits = digits.max(1);
    let magnitude = x.abs().log10().floor() as i32;
    if !(-6..6).contains(&magnitude) {
        return format!("{:.*e}", digits - 1, x);
    }
    let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
    // Integer digits beyond `digits` are rounded too (99950 → 100000).
    let excess = magnitude + 1 - digits as i32;
    let x = if excess > 0 {
        let unit = 10f64.powi(excess);
        (x / unit).round() * unit
    } else {
        x
    };
    let text = format!("{x:.decimals$}");
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    }
}

/// A change to a refused spec that the compiler priced by building it (`crate::generate` forms them):
/// what to write, and its estimated cycles a step, or why it has none (its lowering failed, or the
/// build's budget refused it: `codegen::budget`).
#[derive(Clone, Debug, PartialEq)]
pub struct Alternative {
    /// The change, as it would be written: "`method = \"active_set\"`".
    pub change: String,
    /// Its step's estimated cycles, or why it was not priced.
    pub cycles: Result<f64, String>,
}

/// Refuses a control step whose estimated cycles exceed the sampling period at the target's clock, with a
/// located error on `dt` that also points at `iterations` and `target`. The host has no fixed clock: no
/// refusal there. The hint prices `scalar = "f32"` from the cost; [`check_period_with`] adds the changes
/// the compiler built.
pub fn check_period(spec: &Spec, cost: &StepCost) -> Result<(), Diagnostic> {
    check_period_with(spec, cost, &[])
}

/// [`check_period`], the hint listing `alternatives` with their cycles against the period.
pub fn check_period_with(
    spec: &Spec,
    cost: &StepCost,
    alternatives: &[Alternative],
) -> Result<(), Diagnostic> {
    let Some(period) = cost.period_cycles else {
        return Ok(());
    };
    if cost.cycles <= period {
        return Ok(());
    }
    let m = &cost.machine;
    let mhz = m.clock_hz.unwrap_or_default() / 1e6;
    let span = |key: &str| spec.spans.get(key);
    Err(Diagnostic::new(
        format!(
            "a control step needs about {:.2e} cycles on {} at {mhz:.0} MHz, more than the {:.2e} of its {} ms period",
            cost.cycles,
            m.processor,
            period,
            cost.dt * 1e3
        ),
        span("model.dt"),
    )
    .label(format!(
        "{:.2e} cycles at {mhz:.0} MHz; the step takes {:.0} % of it",
        period,
        100.0 * cost.cycles / period
    ))
    .related(
        span("mpc.iterations"),
        match cost.budgeted() {
            Some(words) => format!("{}: {words}: {:.2e} cycles", cost.solver, cost.solver_cycles),
            None => format!(
                "{} iterations of {}, {} multiply-adds each, in {}: {:.2e} cycles",
                cost.iterations,
                cost.solver,
                cost.macs_per_iteration,
                cost.solver_scalar.name(),
                cost.solver_cycles
            ),
        },
    )
    .related(
        span("codegen.target"),
        format!(
            "about {} cycles per multiply-add of the solver in {} here",
            significant(cost.solver_cycles_per_mac, 3),
            cost.solver_scalar.name()
        ),
    )
    .note(format!(
        "hint: {}fewer iterations or a shorter horizon, a longer `dt`, or a faster target; the estimate is {} multiply-adds of the solver and {} of the filter and gradient map, at the cycles per multiply-add measured on the emulated {} (`codegen::target`)",
        cheaper(cost, alternatives),
        cost.solver_macs,
        cost.other_macs,
        m.target.name()
    )))
}

/// The cheaper changes the compiler prices itself, each with its estimated cycles against the period:
/// `scalar = "f32"` where the module is f64 and the solver would follow it, then `alternatives` (one
/// without a price says why).
fn cheaper(cost: &StepCost, alternatives: &[Alternative]) -> String {
    let Some(period) = cost.period_cycles else {
        return String::new();
    };
    let priced = |cycles: f64| {
        let fits = if cycles <= period {
            "fits"
        } else {
            "still over"
        };
        format!(
            "about {} cycles, {} % of the period: {fits}",
            significant(cycles, 3),
            significant(100.0 * cycles / period, 3)
        )
    };
    let mut out = String::new();
    if let Some(f32_cycles) = cost.f32_cycles {
        out += &format!(
            "`scalar = \"f32\"` in `[codegen]` ({}); ",
            priced(f32_cycles)
        );
    }
    for a in alternatives {
        let what = match &a.cycles {
            Ok(cycles) => priced(*cycles),
            Err(why) => format!("not priced: {why}"),
        };
        out += &format!("{} ({what}); ", a.change);
    }
    if out.is_empty() {
        out
    } else {
        out + "or "
    }
}

/// Findings about the target that do not stop the build: an f64 `scalar` on a target without f64 in
/// hardware builds and agrees with the host, but every f64 operation is a software routine.
pub fn review(spec: &Spec) -> Diagnostics {
    let mut warnings = Diagnostics::default();
    let m = machine(spec.codegen.target);
    if spec.codegen.scalar == Scalar::F64 && !m.f64_in_hardware {
        warnings.push(
            Diagnostic::new(
                format!(
                    "`scalar = \"f64\"` on `target = \"{}\"` runs in software floating point, about {:.0}× the cycles of f32",
                    m.target.name(),
                    m.cycles_per_mac_f64 / m.cycles_per_mac_f32
                ),
                spec.spans.get("codegen.scalar"),
            )
            .label("f64 has no hardware here")
            .related(spec.spans.get("codegen.target"), "a single-precision FPU")
            .note("hint: `scalar = \"f32\"` (the default) runs on the FPU; f64 there is for checking against the host"),
        );
    }
    warnings
}
