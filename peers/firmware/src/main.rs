//! The peers replay on firmware-template's boards: every dumped problem (`peers/data/`, baked in by
//! the `peers` crate) solved step by step by the generated solver and by DAQP, each solve timed by the
//! board's timer and its stack measured by the template's probe, with one `RESULT {json}` line per
//! solver and problem on the serial port (and one with solver `none` for the replay without a solver,
//! which every image runs so that `run.sh --sizes` subtracts it). Exit status 0 if every DAQP solve ended optimal, 1 if not,
//! 2 if DAQP could not be set up (out of heap), 20 on a panic, the board's statuses on an exception.
//!
//! The board modules, the stack probe and the console are firmware-template's own files, compiled
//! here by `#[path]` (nothing of the template is changed): the same startup, timer, calibration and
//! stack measurement as its flight.
#![no_std]
#![no_main]

#[cfg_attr(board = "zynq", path = "../../../firmware-template/src/zynq/mod.rs")]
#[cfg_attr(
    board = "stm32f405",
    path = "../../../firmware-template/src/stm32f405/mod.rs"
)]
mod board;
#[path = "../../../firmware-template/src/console.rs"]
mod console;
#[path = "../../../firmware-template/src/decimal.rs"]
mod decimal;
// DAQP's `malloc`; its bookkeeping is read by `run_daqp` only.
#[cfg_attr(not(feature = "daqp"), allow(dead_code))]
mod heap;
// The template's probe; its whole-run `high_water` is not used here.
#[allow(dead_code)]
#[path = "../../../firmware-template/src/stack.rs"]
mod stack;

use console::Console;
use peers::{Outcome, Timing};

/// Iterations of the timer calibration loop (2 instructions each), as in the template.
const CALIB_ITERS: u32 = 1_000_000;

/// The board's timer and the template's stack probe around each solve.
struct Probe<'t> {
    timer: &'t board::Timer,
    stack: stack::CycleProbe,
}

impl Timing for Probe<'_> {
    fn time(&mut self, solve: &mut dyn FnMut()) -> u64 {
        let painted = self.stack.paint();
        let t0 = self.timer.now();
        solve();
        let ticks = self.timer.since(t0);
        self.stack.measure(painted);
        ticks
    }
}

/// Timer ticks taken by a loop of exactly `2 * iters` instructions (the template's calibration).
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

/// `x` in units of 1e-15, rounded, saturating (no float formatting on the target).
fn femto(x: f64) -> u64 {
    let v = x * 1e15 + 0.5;
    if v.is_nan() || v >= 1.8e19 {
        u64::MAX
    } else if v < 0.0 {
        0
    } else {
        v as u64
    }
}

/// One `RESULT` line: instructions per solve (ticks scaled by the calibration; DAQP's also of
/// forming f and the bounds alone), iterations, accuracy in 1e-15, the deepest stack of a solve, the
/// state kept between solves (ours: the generated `Mpc`; DAQP: its heap), the QP data DAQP reads.
fn result(
    serial: &mut board::Serial,
    problem: &str,
    solver: &str,
    o: &Outcome,
    stack: &stack::CycleProbe,
    data_bytes: usize,
    calib: (u64, u64),
) {
    let q = o.tick_quantiles();
    let it = o.iteration_quantiles();
    let (e50, e100) = o.error_median_max();
    let instructions = |ticks: u64| (ticks * calib.0 + calib.1 / 2) / calib.1.max(1);
    serial.str("RESULT {\"board\":\"").str(board::NAME);
    serial.str("\",\"problem\":\"").str(problem);
    serial.str("\",\"solver\":\"").str(solver);
    serial.str("\",\"solves\":").u64(o.count as u64);
    serial.str(",\"not_optimal\":").u64(o.failures as u64);
    for (name, v) in ["min", "median", "p99", "max"].iter().zip(q) {
        serial
            .str(",\"instructions_")
            .str(name)
            .str("\":")
            .u64(instructions(v));
    }
    for (name, v) in ["min", "median", "p99", "max"]
        .iter()
        .zip(o.form_quantiles())
    {
        serial
            .str(",\"form_instructions_")
            .str(name)
            .str("\":")
            .u64(instructions(v));
    }
    for (name, v) in ["min", "median", "p99", "max"].iter().zip(it) {
        serial
            .str(",\"iterations_")
            .str(name)
            .str("\":")
            .u64(u64::from(v));
    }
    serial.str(",\"error_median_fp\":").u64(femto(e50));
    serial.str(",\"error_max_fp\":").u64(femto(e100));
    serial
        .str(",\"solve_stack_bytes\":")
        .u64(stack.deepest as u64);
    serial
        .str(",\"solve_stack_overflowed\":")
        .u64(u64::from(stack.overflowed));
    serial.str(",\"state_bytes\":").u64(o.state_bytes as u64);
    serial.str(",\"data_bytes\":").u64(data_bytes as u64);
    serial.str(",\"calib_instructions\":").u64(calib.0);
    serial.str(",\"calib_ticks\":").u64(calib.1);
    serial.str("}\n");
}

/// A generated solver on one problem (`replay` is the problem's `ours` or `active_set`, reported as
/// `solver`), in a frame of its own, with a `SOLVES` line of its instructions and iterations per solve.
#[cfg(any(feature = "ours", feature = "active_set"))]
#[inline(never)]
fn run_ours(
    serial: &mut board::Serial,
    timer: &board::Timer,
    calib: (u64, u64),
    name: &str,
    solver: &str,
    replay: impl FnOnce(&mut Probe<'_>, &mut Outcome),
) {
    let mut probe = Probe {
        timer,
        stack: stack::CycleProbe::new(),
    };
    let mut o = Outcome::new();
    replay(&mut probe, &mut o);
    result(serial, name, solver, &o, &probe.stack, 0, calib);
    solves(serial, name, solver, &o, calib);
}

/// One `SOLVES` line: each solve's instructions and iterations, in order (for the instructions per
/// multiply-add of `peers/examples/macs.rs`).
#[cfg(any(feature = "ours", feature = "active_set"))]
fn solves(serial: &mut board::Serial, problem: &str, solver: &str, o: &Outcome, calib: (u64, u64)) {
    let instructions = |ticks: u64| (ticks * calib.0 + calib.1 / 2) / calib.1.max(1);
    serial.str("SOLVES {\"problem\":\"").str(problem);
    serial.str("\",\"solver\":\"").str(solver);
    serial.str("\",\"instructions\":[");
    for (k, &t) in o.ticks[..o.count].iter().enumerate() {
        if k > 0 {
            serial.str(",");
        }
        serial.u64(instructions(t));
    }
    serial.str("],\"iterations\":[");
    for (k, &i) in o.iterations[..o.count].iter().enumerate() {
        if k > 0 {
            serial.str(",");
        }
        serial.u64(u64::from(i));
    }
    serial.str("]}\n");
}

/// The replay without a solver (`baseline`), in every image whatever its features, so that
/// `run.sh --sizes` subtracts the replay's own code and data: a `RESULT` line with solver `none`.
#[inline(never)]
fn run_baseline(
    serial: &mut board::Serial,
    timer: &board::Timer,
    calib: (u64, u64),
    name: &str,
    replay: impl FnOnce(&mut Probe<'_>, &mut Outcome),
) {
    let mut probe = Probe {
        timer,
        stack: stack::CycleProbe::new(),
    };
    let mut o = Outcome::new();
    replay(&mut probe, &mut o);
    result(serial, name, "none", &o, &probe.stack, 0, calib);
}

/// DAQP on one problem, in a frame of its own: 0 if every solve ended optimal, 1 if not, 2 if it
/// could not be set up.
#[cfg(feature = "daqp")]
#[inline(never)]
fn run_daqp(
    serial: &mut board::Serial,
    timer: &board::Timer,
    calib: (u64, u64),
    data: &peers::Data,
) -> u32 {
    let mut probe = Probe {
        timer,
        stack: stack::CycleProbe::new(),
    };
    let mut o = Outcome::new();
    heap::reset();
    if peers::replay_daqp(data, &mut probe, &mut o).is_none() {
        serial.str("DAQP setup failed on ").str(data.name).str("\n");
        return 2;
    }
    o.state_bytes = heap::high_water();
    let bytes = data.daqp_data_bytes();
    result(serial, data.name, "daqp", &o, &probe.stack, bytes, calib);
    u32::from(o.failures > 0)
}

#[no_mangle]
extern "C" fn main() -> ! {
    let mut serial = board::Serial::new();
    let timer = board::Timer::start();
    let calib = (2 * u64::from(CALIB_ITERS), timed_loop(&timer, CALIB_ITERS));
    serial
        .str("peers: ")
        .str(board::NAME)
        .str(" (")
        .str(board::CPU)
        .str("), ");
    serial.str(board::TIMER).str("\n");
    let mut status = 0;
    peers::for_each_problem!(p => {
        run_baseline(&mut serial, &timer, calib, p::NAME, |t, o| p::baseline(t, o));
        #[cfg(feature = "ours")]
        run_ours(&mut serial, &timer, calib, p::NAME, "generated", |t, o| p::ours(t, o));
        #[cfg(feature = "active_set")]
        run_ours(&mut serial, &timer, calib, p::NAME, "active_set", |t, o| p::active_set(t, o));
        #[cfg(feature = "daqp")]
        {
            status = status.max(run_daqp(&mut serial, &timer, calib, &p::data()));
        }
    });
    let _ = &mut status;
    board::exit(status)
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    board::exit(20)
}
