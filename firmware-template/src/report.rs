//! What the firmware prints: a header, a human-readable summary and the `RESULT {json}` line
//! that tests and scripts parse. Numbers are integers (micrometres, ticks): see `decimal`.

use flight_sim::Scenario;

use crate::board::{self, Serial};
use crate::console::Console;
use crate::spec::{hex, SCALAR, SPEC_FNV1A64};
use crate::stats::{micrometres, Errors, Ticks};
use crate::{ctrl, LOST_M, SPEC_PATH};

/// Everything a finished run reports.
pub struct Run<'a> {
    /// Seed and cycle count.
    pub scenario: &'a Scenario,
    /// Ticks per control cycle.
    pub ticks: &'a Ticks,
    /// Tracking errors.
    pub errors: &'a Errors,
    /// Instructions in the calibration loop.
    pub calib_instructions: u64,
    /// Global timer ticks the calibration loop took.
    pub calib_ticks: u64,
    /// Deepest use of the main stack over the whole run, bytes.
    pub stack_bytes: usize,
    /// Deepest use of the stack by one control cycle, below its caller's stack pointer, bytes.
    pub cycle_stack_bytes: usize,
    /// What the controller's `Status` reported over the run.
    pub status: &'a StatusCounts,
    /// A control cycle went deeper than the probe painted: `cycle_stack_bytes` is a lower bound.
    pub cycle_stack_overflowed: bool,
}

/// Prints what is about to fly.
pub fn header(out: &mut Serial, scenario: &Scenario) {
    out.str("firmware-template on ")
        .str(board::NAME)
        .str(" (")
        .str(board::CPU)
        .str(")\nspec ")
        .str(SPEC_PATH)
        .str(": ")
        .str(SCALAR)
        .str(", horizon ")
        .u64(ctrl::N as u64)
        .str(", ")
        .u64(ctrl::ITERATIONS as u64)
        .str(" iterations\nflying ")
        .u64(scenario.cycles as u64)
        .str(" cycles of 12.8 ms, seed ")
        .u64(scenario.seed)
        .str("\n");
}

/// Prints the summary and the RESULT line; returns whether the run passed its checks: every
/// cycle flown, errors finite and below `LOST_M`, the stack probe not overflowed.
pub fn result(out: &mut Serial, run: &Run) -> bool {
    let rmse = run.errors.rmse().map(micrometres);
    let max_abs = run.errors.max_abs().map(micrometres);
    let lost_um = micrometres(LOST_M).unwrap_or(0);
    let flown = run.ticks.count == run.scenario.cycles as u64;
    let ok = flown
        && !run.cycle_stack_overflowed
        && rmse.iter().all(Option::is_some)
        && max_abs.iter().all(|m| matches!(m, Some(m) if *m < lost_um));

    out.str("control cycle (Kalman update + MPC + Kalman predict), ")
        .str(board::TIMER)
        .str(": min ")
        .u64(run.ticks.min)
        .str(", mean ")
        .u64(run.ticks.mean())
        .str(", max ")
        .u64(run.ticks.max)
        .str("\ntracking error x/y/z, um: rmse ");
    axes(out, &rmse, "/");
    out.str(", max ");
    axes(out, &max_abs, "/");
    let st = run.status;
    out.str("\nstatus: ")
        .u64(st.rejected)
        .str(" measurements rejected (")
        .u64(st.gated)
        .str(" gated, ")
        .u64(st.stuck)
        .str(" stuck, ")
        .u64(st.non_finite)
        .str(" non-finite), ")
        .u64(st.reacquisitions)
        .str(" re-acquisitions, ")
        .u64(st.saturated)
        .str(" cycles with a saturated input, ")
        .u64(st.not_solved)
        .str(" cycles without a solve, ")
        .u64(st.fell_back)
        .str(" with the solver's fallback");
    out.str("\nstack used: ")
        .u64(run.stack_bytes as u64)
        .str(" bytes, of which a control cycle ")
        .u64(run.cycle_stack_bytes as u64)
        .str(if run.cycle_stack_overflowed {
            " or more (deeper than the probe painted)\n"
        } else {
            "\n"
        })
        .str(if ok { "flight OK\n" } else { "flight FAILED\n" });

    out.str("RESULT {\"spec\":\"")
        .str(SPEC_PATH)
        .str("\",\"spec_fnv1a64\":\"");
    hex(out, SPEC_FNV1A64, 16);
    out.str("\",\"board\":\"")
        .str(board::NAME)
        .str("\",\"scalar\":\"")
        .str(SCALAR)
        .str("\",\"nx\":")
        .u64(ctrl::NX as u64)
        .str(",\"nu\":")
        .u64(ctrl::NU as u64)
        .str(",\"horizon\":")
        .u64(ctrl::N as u64)
        .str(",\"iterations\":")
        .u64(ctrl::ITERATIONS as u64)
        .str(",\"seed\":")
        .u64(run.scenario.seed)
        .str(",\"cycles\":")
        .u64(run.ticks.count)
        .str(",\"ticks_min\":")
        .u64(run.ticks.min)
        .str(",\"ticks_mean\":")
        .u64(run.ticks.mean())
        .str(",\"ticks_max\":")
        .u64(run.ticks.max)
        .str(",\"ticks_total\":")
        .u64(run.ticks.sum)
        .str(",\"calib_instructions\":")
        .u64(run.calib_instructions)
        .str(",\"calib_ticks\":")
        .u64(run.calib_ticks)
        .str(",\"stack_bytes\":")
        .u64(run.stack_bytes as u64)
        .str(",\"cycle_stack_bytes\":")
        .u64(run.cycle_stack_bytes as u64)
        .str(",\"rejected\":")
        .u64(st.rejected)
        .str(",\"gated\":")
        .u64(st.gated)
        .str(",\"stuck\":")
        .u64(st.stuck)
        .str(",\"non_finite\":")
        .u64(st.non_finite)
        .str(",\"reacquisitions\":")
        .u64(st.reacquisitions)
        .str(",\"saturated_cycles\":")
        .u64(st.saturated)
        .str(",\"unsolved_cycles\":")
        .u64(st.not_solved)
        .str(",\"fallback_cycles\":")
        .u64(st.fell_back)
        .str(",\"rmse_um\":[");
    axes(out, &rmse, ",");
    out.str("],\"max_abs_error_um\":[");
    axes(out, &max_abs, ",");
    out.str("],\"ok\":")
        .str(if ok { "true" } else { "false" })
        .str("}\n");
    ok
}

/// Counts of what the generated controller's `Status` said, cycle by cycle.
#[derive(Default)]
pub struct StatusCounts {
    /// Measurements the filter did not fuse.
    pub rejected: u64,
    /// ... because they were outside the χ² gate.
    pub gated: u64,
    /// ... because the sensor repeated itself bit for bit.
    pub stuck: u64,
    /// ... because they were NaN or infinite.
    pub non_finite: u64,
    /// Re-acquisitions (the last status's count).
    pub reacquisitions: u64,
    /// Cycles whose command had an input at a bound.
    pub saturated: u64,
    /// Cycles whose command was the rest input (no estimate, or an invalid reference).
    pub not_solved: u64,
    /// Cycles whose command came from the solver's fallback (the interior-point method's or ADMM's
    /// shifted plan when a solve was not trusted; the first-order methods have none).
    pub fell_back: u64,
}

impl StatusCounts {
    /// Adds one cycle's status.
    pub fn add(&mut self, s: &ctrl::Status) {
        use ctrl::Measurement as M;
        let m = s.filter.measurement;
        self.rejected += u64::from(!m.accepted());
        self.gated += u64::from(m == M::Gated);
        self.stuck += u64::from(m == M::Stuck);
        self.non_finite += u64::from(m == M::NonFinite);
        self.reacquisitions = u64::from(s.filter.reacquisitions);
        self.saturated += u64::from(s.saturated.iter().any(|b| *b));
        self.not_solved += u64::from(s.command != ctrl::Command::Solved);
        self.fell_back += u64::from(s.fell_back());
    }
}

/// Three values joined by `sep`, `null` for a missing one.
fn axes(out: &mut Serial, v: &[Option<u64>; 3], sep: &str) {
    for (i, v) in v.iter().enumerate() {
        if i > 0 {
            out.str(sep);
        }
        match v {
            Some(v) => out.u64(*v),
            None => out.str("null"),
        };
    }
}
