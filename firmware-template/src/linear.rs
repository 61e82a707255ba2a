//! The linear mode (feature `linear`; scripts/firmware.sh turns it on for a spec whose model is
//! `type = "linear"`, or with `--linear`): the spec's own discrete model flown in closed loop under its
//! state-feedback controller, on the target itself.
//!
//! The plant is `flight_sim::LinearPlant` with the generated module's `F` and `G` (the spec's model
//! as the controller predicts it, its constants rounded once to `Real`), integrated in f64; the
//! controller measures the state exactly (the spec has no `[kalman]`: `Controller::step(&x, &xref)`).
//! With the `linear-filter` feature (scripts/firmware.sh sets it for a spec with a `[kalman]`, such as
//! `specs/paper.toml`) the controller measures the output `C x` of the module's `C` instead, through its
//! filter started at rest (`Controller::new(x0)`, `step(&z, &xref)`).
//! The loop is `flight_sim::fly_linear`, which the host test flies with the same generated module.
//! The scenario is OSQP's MPC example: from rest (x = 0) to the constant reference with state 2 at 1
//! (the quadcopter's yaw ψ = 1 rad) and every other state at 0, without noise. With the
//! `linear-outputs` feature (scripts/firmware.sh sets it for a spec with `[mpc] outputs`) the reference
//! is of the tracked outputs `C_z x` instead: the first at 1 (the pendulum's cart position), the others 0.
//!
//! Each `Controller::step` is timed with the board's timer and its stack probed exactly as in the
//! paper's loop (`main.rs`). Every command is printed as the bits of its `Real`s (`U k b0 b1 …`),
//! hashed into `RESULT` (`commands_fnv1a64`), so the host can check the firmware's sequence.

use core::hint::black_box;

use flight_sim::{
    cast, fly_linear, LinearController, LinearNoiseConfig, LinearPlant, LinearReference,
    LinearScenario, Setpoint,
};

use crate::board::{self, Serial};
use crate::console::Console;
use crate::spec::{fnv1a64, fnv1a64_byte, hex, SCALAR, SPEC_FNV1A64};
use crate::stats::Ticks;
use crate::{ctrl, out_of_line, parse_cycles, stack, timed_loop, CALIB_ITERS, SEED, SPEC_PATH};

const NX: usize = ctrl::NX;
const NU: usize = ctrl::NU;
/// What the controller measures: the state under state feedback, the output `C x` behind a filter.
#[cfg(not(feature = "linear-filter"))]
const NY: usize = NX;
#[cfg(feature = "linear-filter")]
const NY: usize = ctrl::NY;

/// Control cycles flown: `FIRMWARE_CYCLES` when set at build time (`scripts/firmware.sh --cycles N`),
/// else 100 (10 s of the quadcopter at its 0.1 s period: the yaw step settles within it).
pub const CYCLES: usize = match option_env!("FIRMWARE_CYCLES") {
    Some(n) => parse_cycles(n),
    None => 100,
};

/// The state the flight starts from: rest, unless `FIRMWARE_START` sets it (`scripts/firmware.sh
/// --start`, e.g. a certificate's heaviest cold case, whose first cycle is then that cold solve).
pub const START: [f64; NX] = [0.0; NX];

/// `FIRMWARE_START` and `FIRMWARE_REFERENCE` as written at build time, comma-separated.
const START_WRITTEN: Option<&str> = option_env!("FIRMWARE_START");
const REFERENCE_WRITTEN: Option<&str> = option_env!("FIRMWARE_REFERENCE");

/// `K` comma-separated numbers, or `None` if `text` is not that.
fn numbers<const K: usize>(text: &str) -> Option<[f64; K]> {
    let mut out = [0.0; K];
    let mut parts = text.split(',');
    for v in out.iter_mut() {
        *v = parts.next()?.trim().parse().ok()?;
    }
    parts.next().is_none().then_some(out)
}

/// The start and the reference of the flight: [`START`] and [`REFERENCE`], or as written at build
/// time; `Err` names a written value that is not NX (NR) numbers.
fn start_and_reference() -> Result<([f64; NX], [f64; NR]), &'static str> {
    let start = match START_WRITTEN {
        Some(text) => numbers(text).ok_or("FIRMWARE_START is not NX comma-separated numbers")?,
        None => START,
    };
    let reference = match REFERENCE_WRITTEN {
        Some(text) => numbers(text).ok_or("FIRMWARE_REFERENCE is not NR comma-separated numbers")?,
        None => REFERENCE,
    };
    Ok((start, reference))
}

/// What the reference is of: the state, or the tracked outputs `C_z x` of a spec with `outputs`.
#[cfg(not(feature = "linear-outputs"))]
const NR: usize = NX;
#[cfg(feature = "linear-outputs")]
const NR: usize = ctrl::NZ;

/// The reference: state 2 at 1 (OSQP's `xr`, a yaw of 1 rad), the others at 0; with outputs, the first
/// output at 1.
pub const REFERENCE: [f64; NR] = {
    let mut r = [0.0; NR];
    if cfg!(feature = "linear-outputs") {
        r[0] = 1.0;
    } else if NR > 2 {
        r[2] = 1.0;
    }
    r
};

/// What the reference says where it is, for the log.
const REFERENCE_NAME: &str = if cfg!(feature = "linear-outputs") {
    "output 0 = 1"
} else {
    "state 2 = 1"
};

/// The generated controller, with each call timed.
struct Timed<'t> {
    controller: ctrl::Controller,
    timer: &'t board::Timer,
    ticks: Ticks,
    stack: stack::CycleProbe,
    counts: Counts,
}

/// What the controller's `Status` said over the flight.
#[derive(Default)]
struct Counts {
    /// Cycles whose command was not solved from the state (`Command::Solved`).
    unsolved: u64,
    /// Cycles whose command came from the solver's fallback (`Status::fell_back`).
    fell_back: u64,
    /// Cycles with an input at a bound.
    saturated: u64,
}

impl LinearController<NU, NY, NR> for Timed<'_> {
    fn step<R: LinearReference<NR>>(&mut self, k: usize, x: &[f64; NY], r: &R) -> [f64; NU] {
        // The reference window and the conversion to the controller's scalar stay outside the
        // timed span, as in the paper's loop.
        let xref = r.window::<ctrl::Real, { ctrl::N }>(k, dt());
        let x: [ctrl::Real; NY] = cast(x);
        let painted = self.stack.paint();
        let t0 = self.timer.now();
        let controller = &mut self.controller;
        let u = black_box(out_of_line(|| {
            controller.step(black_box(&x), black_box(&xref))
        }));
        self.ticks.add(self.timer.since(t0));
        self.stack.measure(painted);
        let s = self.controller.status();
        self.counts.unsolved += u64::from(s.command != ctrl::Command::Solved);
        self.counts.fell_back += u64::from(s.fell_back());
        self.counts.saturated += u64::from(s.saturated.iter().any(|b| *b));
        cast(&u)
    }
}

/// The sampling period, s.
fn dt() -> f64 {
    cast::<ctrl::Real, f64, 1>(&[ctrl::DT])[0]
}

/// The model the controller predicts with, in f64: F, G, and what the controller measures, from
/// `start`.
fn plant(start: [f64; NX]) -> LinearPlant<NX, NU, NY> {
    LinearPlant::new(
        ctrl::F.map(|row| cast(&row)),
        ctrl::G.map(|row| cast(&row)),
        measured(),
        start,
    )
}

/// The identity, NX × NX: the reference is the state.
fn identity() -> [[f64; NX]; NX] {
    let mut c = [[0.0; NX]; NX];
    for (i, row) in c.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    c
}

/// The tracked quantities: the state, or the module's `C_z`.
#[cfg(not(feature = "linear-outputs"))]
fn tracked() -> [[f64; NX]; NR] {
    identity()
}

#[cfg(feature = "linear-outputs")]
fn tracked() -> [[f64; NX]; NR] {
    ctrl::CZ.map(|row| cast(&row))
}

/// The state measured exactly (C = I).
#[cfg(not(feature = "linear-filter"))]
fn measured() -> [[f64; NX]; NY] {
    identity()
}

/// The filter's measurement model, the module's `C`.
#[cfg(feature = "linear-filter")]
fn measured() -> [[f64; NX]; NY] {
    ctrl::C.map(|row| cast(&row))
}

/// A new controller: state feedback needs no start; a filter starts from the plant's state.
#[cfg(not(feature = "linear-filter"))]
fn controller(_start: &[f64; NX]) -> ctrl::Controller {
    ctrl::Controller::new()
}

#[cfg(feature = "linear-filter")]
fn controller(start: &[f64; NX]) -> ctrl::Controller {
    ctrl::Controller::new(cast(start))
}

/// A command's scalars as the raw bits of the controller's `Real` (f32 or f64, in a u64). The
/// command was widened from `Real` to f64 exactly, so narrowing it back is exact too.
fn bits(u: &[f64; NU]) -> [u64; NU] {
    u.map(|v| {
        if core::mem::size_of::<ctrl::Real>() == 4 {
            u64::from((v as f32).to_bits())
        } else {
            v.to_bits()
        }
    })
}

/// Flies the loop, prints the summary and `RESULT`, exits 0 if it passed its checks.
pub fn run() -> ! {
    let mut out = Serial::new();
    let (start, reference) = match start_and_reference() {
        Ok(written) => written,
        Err(why) => {
            out.str("firmware: ").str(why).str("\nflight FAILED\n");
            board::exit(1)
        }
    };
    let timer = board::Timer::start();
    let calib_ticks = timed_loop(&timer, CALIB_ITERS);
    let mut timed = Timed {
        controller: controller(&start),
        timer: &timer,
        ticks: Ticks::new(),
        stack: stack::CycleProbe::new(),
        counts: Counts::default(),
    };
    out.str("firmware-template on ")
        .str(board::NAME)
        .str(" (")
        .str(board::CPU)
        .str(")\nspec ")
        .str(SPEC_PATH)
        .str(if cfg!(feature = "linear-filter") {
            ": linear model, filter, "
        } else {
            ": linear model, state feedback, "
        })
        .str(SCALAR)
        .str(", horizon ")
        .u64(ctrl::N as u64)
        .str(", ")
        .u64(ctrl::ITERATIONS as u64)
        .str(" iterations, ")
        .u64(ctrl::report::MACS_PER_CYCLE as u64)
        .str(" multiply-adds a cycle\nflying ")
        .u64(CYCLES as u64)
        .str(if START_WRITTEN.is_some() {
            " cycles from FIRMWARE_START to "
        } else {
            " cycles from rest to "
        })
        .str(if REFERENCE_WRITTEN.is_some() {
            "FIRMWARE_REFERENCE"
        } else {
            REFERENCE_NAME
        })
        .str("\n");

    let mut plant = plant(start);
    let tracked = tracked();
    let scenario = LinearScenario {
        seed: SEED,
        cycles: CYCLES,
        dt: dt(),
        noise: LinearNoiseConfig::NONE,
    };
    let mut hash = fnv1a64(&[]);
    let mut finite = true;
    fly_linear(
        &mut plant,
        &mut timed,
        &Setpoint(reference),
        &tracked,
        &scenario,
        |_| [0.0; NU],
        |sample, _| {
            out.str("U ").u64(sample.k as u64);
            for b in bits(&sample.command) {
                out.str(" ");
                hex(&mut out, b, 2 * core::mem::size_of::<ctrl::Real>() as u32);
                for byte in b.to_le_bytes() {
                    hash = fnv1a64_byte(hash, byte);
                }
            }
            out.str("\n");
            finite &= sample.command.iter().all(|u| u.is_finite());
        },
    );
    let state = *plant.state();
    finite &= state.iter().all(|x| x.is_finite());

    let cycle_stack_overflowed = timed.stack.overflowed;
    let stack_bytes = stack::high_water().max(timed.stack.from_top);
    let n = &timed.counts;
    let ok =
        timed.ticks.count == CYCLES as u64 && !cycle_stack_overflowed && finite && n.unsolved == 0;
    let t = &timed.ticks;
    out.str("control cycle (MPC on the measured state), ")
        .str(board::TIMER)
        .str(": min ")
        .u64(t.min)
        .str(", mean ")
        .u64(t.mean())
        .str(", max ")
        .u64(t.max)
        .str("\nstatus: ")
        .u64(n.unsolved)
        .str(" cycles without a solve, ")
        .u64(n.fell_back)
        .str(" with the solver's fallback, ")
        .u64(n.saturated)
        .str(" with a saturated input\nfinal state 2, micro-units: ");
    signed(&mut out, state.get(2).copied().unwrap_or(0.0));
    out.str("\nstack used: ")
        .u64(stack_bytes as u64)
        .str(" bytes, of which a control cycle ")
        .u64(timed.stack.deepest as u64)
        .str(if cycle_stack_overflowed {
            " or more (deeper than the probe painted)\n"
        } else {
            "\n"
        })
        .str(if ok { "flight OK\n" } else { "flight FAILED\n" });

    out.str("RESULT {\"mode\":\"linear\",\"spec\":\"")
        .str(SPEC_PATH)
        .str("\",\"spec_fnv1a64\":\"");
    hex(&mut out, SPEC_FNV1A64, 16);
    out.str("\",\"board\":\"")
        .str(board::NAME)
        .str("\",\"scalar\":\"")
        .str(SCALAR)
        .str("\",\"nx\":")
        .u64(NX as u64)
        .str(",\"nu\":")
        .u64(NU as u64)
        .str(",\"horizon\":")
        .u64(ctrl::N as u64)
        .str(",\"iterations\":")
        .u64(ctrl::ITERATIONS as u64)
        .str(",\"macs_per_iteration\":")
        .u64(ctrl::report::MACS_PER_ITERATION as u64)
        .str(",\"macs_per_cycle\":")
        .u64(ctrl::report::MACS_PER_CYCLE as u64)
        .str(",\"cycles\":")
        .u64(t.count)
        .str(",\"ticks_min\":")
        .u64(t.min)
        .str(",\"ticks_mean\":")
        .u64(t.mean())
        .str(",\"ticks_max\":")
        .u64(t.max)
        .str(",\"ticks_total\":")
        .u64(t.sum)
        .str(",\"calib_instructions\":")
        .u64(2 * u64::from(CALIB_ITERS))
        .str(",\"calib_ticks\":")
        .u64(calib_ticks)
        .str(",\"stack_bytes\":")
        .u64(stack_bytes as u64)
        .str(",\"cycle_stack_bytes\":")
        .u64(timed.stack.deepest as u64)
        .str(",\"unsolved_cycles\":")
        .u64(n.unsolved)
        .str(",\"fallback_cycles\":")
        .u64(n.fell_back)
        .str(",\"saturated_cycles\":")
        .u64(n.saturated)
        .str(",\"commands_fnv1a64\":\"");
    hex(&mut out, hash, 16);
    out.str("\",\"final_state_micro\":[");
    for (i, x) in state.iter().enumerate() {
        if i > 0 {
            out.str(",");
        }
        signed(&mut out, *x);
    }
    out.str("],\"ok\":")
        .str(if ok { "true" } else { "false" })
        .str("}\n");
    board::exit(if ok { 0 } else { 1 })
}

/// `x` in millionths, rounded to an integer with its sign; `null` if not finite or too large.
fn signed(out: &mut Serial, x: f64) {
    let um = x * 1e6;
    if !(-1.8e19..1.8e19).contains(&um) {
        out.str("null");
        return;
    }
    if um < 0.0 {
        out.str("-").u64((-um + 0.5) as u64);
    } else {
        out.u64((um + 0.5) as u64);
    }
}
