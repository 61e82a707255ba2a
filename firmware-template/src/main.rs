//! Bare-metal firmware: the paper's closed loop with an `mpc!` controller baked in, on any of
//! the template's boards.
//!
//! The drone (plant, reference trajectory and seeded noise from `flight-sim`) is simulated on the
//! target itself, so the firmware flies exactly the loop the host simulation flies. Each control
//! cycle (Kalman update, MPC solve, Kalman predict: the generated `Controller::step`) is timed
//! with the board's timer. At the end the firmware prints a summary and one `RESULT {json}` line
//! on the board's serial port, and exits through semihosting: 0 if the flight passed its checks,
//! 1 if not, 10-17 on a CPU exception (each board's `rt::status`), 20 on a panic.
//!
//! The board is picked by the build target (build.rs sets `cfg(board)`): `armv7a-none-eabihf`
//! is the Zynq-7000 (`src/zynq/`), `thumbv7em-none-eabihf` the STM32F405 (`src/stm32f405/`).
//! Everything in this file, `report`, `stats`, `console` and `decimal` is shared.
//!
//! With the `linear` feature (scripts/firmware.sh sets it for a spec whose model is
//! `type = "linear"`) the firmware flies that spec's own linear model under its state-feedback
//! controller instead of the drone: `linear.rs`, with its own summary and `RESULT`.
#![no_std]
#![no_main]
// The generated controller's NEON kernels (cfg set by build.rs on the A9): arm's intrinsics are nightly-only.
#![cfg_attr(mpc_neon, feature(stdarch_arm_neon_intrinsics))]

#[cfg_attr(board = "zynq", path = "zynq/mod.rs")]
#[cfg_attr(board = "stm32f405", path = "stm32f405/mod.rs")]
mod board;
mod console;
mod decimal;
#[cfg(feature = "linear")]
mod linear;
#[cfg(not(feature = "linear"))]
mod report;
mod spec;
mod stack;
// The tracking errors are the drone's: the linear mode reports commands instead.
#[cfg_attr(feature = "linear", allow(dead_code))]
mod stats;

#[cfg(not(feature = "linear"))]
use core::hint::black_box;

#[cfg(not(feature = "linear"))]
use flight_sim::{cast, fly, Controller, Reference, Scenario, Trajectory, NU, NX, NY};

#[cfg(not(feature = "linear"))]
use stats::{Errors, Ticks};

// The spec baked in. `mpc!` takes a literal path (relative to this folder); scripts/firmware.sh
// writes any other spec to spec-override/spec.toml and turns on the `spec-override` feature.
#[cfg(not(feature = "spec-override"))]
macro_rules! spec_path {
    () => {
        "../specs/paper.toml"
    };
}
#[cfg(feature = "spec-override")]
macro_rules! spec_path {
    () => {
        "spec-override/spec.toml"
    };
}
#[cfg(not(feature = "spec-override"))]
mpc_macros::mpc!(pub mod ctrl = "../specs/paper.toml");
#[cfg(feature = "spec-override")]
mpc_macros::mpc!(pub mod ctrl = "spec-override/spec.toml");

/// Where the spec was read from, and its text (hashed into RESULT, so a test can tell which
/// spec a binary holds).
const SPEC_PATH: &str = spec_path!();
const SPEC_TEXT: &str = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/", spec_path!()));

/// Seed of the noise streams; the host test flies the same one.
const SEED: u64 = 1;
/// Control cycles flown (the paper's loop; `linear::CYCLES` for the linear one): the whole ~111 s reference flight at 12.8 ms per cycle, or the first
/// `FIRMWARE_CYCLES` of it when that is set at build time (`scripts/firmware.sh --cycles N`; the
/// tests fly 10 s of the interior-point specs, which cost a few million instructions a cycle).
#[cfg(not(feature = "linear"))]
const CYCLES: usize = match option_env!("FIRMWARE_CYCLES") {
    Some(n) => parse_cycles(n),
    None => FULL_FLIGHT,
};
const FULL_FLIGHT: usize = 8671;

/// `n` as a count of cycles, 1 to FULL_FLIGHT; anything else stops the build.
const fn parse_cycles(n: &str) -> usize {
    let b = n.as_bytes();
    let mut v = 0usize;
    let mut i = 0;
    while i < b.len() {
        assert!(b[i].is_ascii_digit(), "FIRMWARE_CYCLES must be a number of cycles");
        v = v * 10 + (b[i] - b'0') as usize;
        assert!(v <= FULL_FLIGHT, "FIRMWARE_CYCLES is more than the whole flight (8671)");
        i += 1;
    }
    assert!(v > 0, "FIRMWARE_CYCLES must be at least 1");
    v
}
/// A tracking error above this, m, on any axis means the controller lost the drone.
#[cfg(not(feature = "linear"))]
const LOST_M: f64 = 2.0;
/// Iterations of the timer calibration loop (2 instructions each).
const CALIB_ITERS: u32 = 1_000_000;

/// The generated controller, with each call timed.
#[cfg(not(feature = "linear"))]
struct Timed<'t> {
    controller: ctrl::Controller,
    timer: &'t board::Timer,
    ticks: Ticks,
    stack: stack::CycleProbe,
    status: report::StatusCounts,
}

#[cfg(not(feature = "linear"))]
impl Controller for Timed<'_> {
    fn step<R: Reference>(&mut self, k: usize, z: &[f64; NY], reference: &R) -> [f64; NU] {
        // Evaluating the reference and converting to the controller's scalar is the
        // simulation's work, not the controller's: it stays outside the timed span.
        let xref = reference.window::<ctrl::Real, { ctrl::N }>(k);
        let z: [ctrl::Real; NY] = cast(z);
        // Painting the stack for the probe is outside the timed span too.
        let painted = self.stack.paint();
        let t0 = self.timer.now();
        // black_box: the call must happen between the two reads of the timer.
        let controller = &mut self.controller;
        let u = black_box(out_of_line(|| controller.step(black_box(&z), black_box(&xref))));
        self.ticks.add(self.timer.since(t0));
        self.stack.measure(painted);
        self.status.add(self.controller.status());
        cast(&u)
    }

    fn estimate(&self) -> [f64; NX] {
        cast(self.controller.estimate())
    }
}

/// Calls `f` in a frame of its own: the stack probe measures below the caller's stack pointer,
/// and an inlined `Controller::step` would keep its variables in the caller's frame instead.
#[inline(never)]
fn out_of_line<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// Timer ticks taken by a loop of exactly `2 * iters` instructions (A32 or Thumb alike).
fn timed_loop(timer: &board::Timer, iters: u32) -> u64 {
    let t0 = timer.now();
    // SAFETY: a countdown loop on one register.
    unsafe {
        core::arch::asm!(
            "1:",
            "subs {n}, {n}, #1",
            "bne 1b",
            n = inout(reg) iters.max(1) => _,
            options(nomem, nostack),
        );
    }
    timer.since(t0)
}

#[cfg(not(feature = "linear"))]
#[no_mangle]
extern "C" fn main() -> ! {
    let mut serial = board::Serial::new();
    let timer = board::Timer::start();
    let calib_ticks = timed_loop(&timer, CALIB_ITERS);

    let reference = Trajectory::paper();
    let x0 = reference.start();
    let mut timed = Timed {
        controller: ctrl::Controller::new(cast(&x0)),
        timer: &timer,
        ticks: Ticks::new(),
        stack: stack::CycleProbe::new(),
        status: report::StatusCounts::default(),
    };
    let mut errors = Errors::new();
    let scenario = Scenario::new(SEED, CYCLES);
    report::header(&mut serial, &scenario);
    fly(&mut timed, &reference, &scenario, |sample, _| {
        errors.add(&sample.error())
    });

    let ok = report::result(
        &mut serial,
        &report::Run {
            scenario: &scenario,
            ticks: &timed.ticks,
            errors: &errors,
            calib_instructions: 2 * u64::from(CALIB_ITERS),
            calib_ticks,
            stack_bytes: stack::high_water().max(timed.stack.from_top),
            cycle_stack_bytes: timed.stack.deepest,
            cycle_stack_overflowed: timed.stack.overflowed,
            status: &timed.status,
        },
    );
    board::exit(if ok { 0 } else { 1 })
}

/// The linear mode's entry: `linear::run`.
#[cfg(feature = "linear")]
#[no_mangle]
extern "C" fn main() -> ! {
    linear::run()
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    board::exit(20)
}
