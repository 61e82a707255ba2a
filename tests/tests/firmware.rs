//! The firmware template on its emulated boards: the Zynq-7000 (Cortex-A9, issue 6) and the
//! STM32F405 (Cortex-M4F, QEMU's netduinoplus2, issue 9).
//!
//! Each (board, spec) is built once with `cargo +nightly` through `scripts/firmware.sh` (which also
//! installs qemu-system-arm and nightly's rust-src when they are missing) and flown once under QEMU
//! with `-icount shift=0`; the tests below read its `RESULT` line, its exit status and its ELF, and
//! fly the same loop on the host with the same generated module.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Mutex, OnceLock};

use flight_sim::{cast, fly, Controller, Reference, Scenario, Trajectory, NU, NX, NY};
use serde_json::Value;

mpc_macros::mpc!(mod paper = "../specs/paper.toml");
mpc_macros::mpc!(mod f64_n10 = "../firmware-template/specs/paper-f64-n10.toml");
mpc_macros::mpc!(mod limits = "../specs/paper-limits.toml");

/// The interior-point spec the Zynq flies in f64 on its VFP (issue 18).
const LIMITS_SPEC: &str = "specs/paper-limits.toml";
/// Its cycles in the tests: the first 10 s of the flight (`scripts/firmware.sh --cycles 782`; without
/// `--cycles` the script flies all of it). A cycle is a few million instructions.
const LIMITS_CYCLES: usize = 782;

/// Seconds allowed for one build (cold: core from source and the macro's dependencies).
const BUILD_TIMEOUT_S: u32 = 1800;
/// Seconds allowed for one emulated flight (10 to 40 s on a 2-core machine).
const RUN_TIMEOUT_S: u32 = 300;
/// Allowed spread of the ticks of one control cycle over a flight, relative to the mean, when the
/// scalar is done in hardware. Fixed iteration counts and branch-free matrix code make every cycle
/// the same length; only the box projections branch.
const TICK_SPREAD: f64 = 0.002;
/// The same for f64 on the Cortex-M4F, whose FPU is single precision: every f64 operation is a
/// call into compiler-builtins' software floating point, whose normalisation and rounding paths
/// depend on the operands (observed: 3.4% below and 1.6% above the mean).
const SOFT_FLOAT_TICK_SPREAD: f64 = 0.10;

/// An emulated board: how the script names it, how QEMU runs it, what its RESULT says.
#[derive(Clone, Copy, Debug)]
struct Board {
    /// `scripts/firmware.sh --board`.
    arg: &'static str,
    /// QEMU machine.
    machine: &'static str,
    /// `board` in RESULT and the boot banner.
    name: &'static str,
    /// Guest instructions per timer tick under `-icount shift=0`.
    instructions_per_tick: u64,
}

/// Zynq-7000: the Cortex-A9 global timer at prescaler 0 ticks once per 10 instructions.
const ZYNQ: Board = Board {
    arg: "zynq",
    machine: "xilinx-zynq-a9",
    name: "zynq-7000",
    instructions_per_tick: 10,
};

/// STM32F405: TIM2 at prescaler 0 ticks once per instruction.
const M4: Board = Board {
    arg: "netduinoplus2",
    machine: "netduinoplus2",
    name: "stm32f405",
    instructions_per_tick: 1,
};
/// Allowed difference between the firmware's and the host's errors, micrometres. f32 and f64
/// arithmetic is IEEE 754 on both machines (VFP without flush-to-zero; SSE2), rustc contracts
/// nothing into FMAs, and libm is the same Rust crate, so the two runs agree exactly (observed);
/// the margin covers a last-bit difference in a transcendental function (the noise sampler's
/// `exp`/`ln` may come from the host's C library through num-traits).
const AGREE_UM: u64 = 2;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// One firmware build and flight.
struct Flight {
    status: Option<i32>,
    uart: String,
    result: Value,
    /// A copy of the ELF that flew.
    elf: PathBuf,
}

/// The firmware's build directory and spec-override file are shared: one build at a time
/// (scripts/firmware.sh also takes a lock file, against other processes). The flight runs on a copy
/// of the ELF, outside the lock: one test's emulation (one core) overlaps the next one's build.
static FIRMWARE: Mutex<()> = Mutex::new(());

fn build_and_fly(board: Board, spec: Option<&str>, name: &str, cycles: Option<usize>) -> Flight {
    let elf = build(board, spec, name, cycles);
    let (status, uart) = emulate(board, &elf);
    let result =
        result_line(&uart).unwrap_or_else(|| panic!("no RESULT line from {name}:\n{uart}"));
    Flight {
        status,
        uart,
        result,
        elf,
    }
}

/// Builds the firmware for `board` with `spec` baked in and returns a copy of its ELF.
fn build(board: Board, spec: Option<&str>, name: &str, cycles: Option<usize>) -> PathBuf {
    build_with(board, spec, name, cycles, &[])
}

/// [`build`] with more options of scripts/firmware.sh (`--linear`).
fn build_with(
    board: Board,
    spec: Option<&str>,
    name: &str,
    cycles: Option<usize>,
    options: &[&str],
) -> PathBuf {
    let _guard = FIRMWARE.lock().unwrap_or_else(|e| e.into_inner());
    let root = root();
    let elf =
        Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("firmware-{}-{name}.elf", board.arg));
    let mut build = Command::new("timeout");
    build
        .arg(BUILD_TIMEOUT_S.to_string())
        .arg("bash")
        .arg(root.join("scripts/firmware.sh"))
        .args(["--board", board.arg, "--build-only", "--elf-out"])
        .arg(&elf)
        .args(cycles.map(|n| format!("--cycles={n}")))
        .args(options)
        .args(spec.map(|s| root.join(s)));
    let out = clean_env(&mut build)
        .output()
        .expect("running scripts/firmware.sh");
    assert!(
        out.status.success(),
        "building the firmware for {name} failed ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    elf
}

/// Runs an ELF on the board's QEMU machine exactly as the template's cargo runner does.
fn emulate(board: Board, elf: &Path) -> (Option<i32>, String) {
    let out = Command::new("timeout")
        .arg(RUN_TIMEOUT_S.to_string())
        .args([
            "qemu-system-arm",
            "-M",
            board.machine,
            "-nographic",
            "-monitor",
            "none",
        ])
        .args([
            "-semihosting-config",
            "enable=on,target=native",
            "-icount",
            "shift=0",
            "-kernel",
        ])
        .arg(elf)
        .output()
        .expect("running qemu-system-arm");
    assert_ne!(
        out.status.code(),
        Some(124),
        "the firmware did not finish within {RUN_TIMEOUT_S} s"
    );
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).replace('\r', ""),
    )
}

/// rustup exports the outer toolchain to children, which would override the template's
/// rust-toolchain.toml; outer RUSTFLAGS would replace its target flags.
fn clean_env(cmd: &mut Command) -> &mut Command {
    for var in [
        "RUSTUP_TOOLCHAIN",
        "RUSTFLAGS",
        "CARGO_ENCODED_RUSTFLAGS",
        "CARGO_TARGET_DIR",
        "CARGO_BUILD_TARGET",
    ] {
        cmd.env_remove(var);
    }
    cmd
}

fn result_line(uart: &str) -> Option<Value> {
    let json = uart.lines().rev().find_map(|l| l.strip_prefix("RESULT "))?;
    serde_json::from_str(json).ok()
}

fn paper_flight() -> &'static Flight {
    static F: OnceLock<Flight> = OnceLock::new();
    F.get_or_init(|| build_and_fly(ZYNQ, None, "paper", None))
}

fn f64_flight() -> &'static Flight {
    static F: OnceLock<Flight> = OnceLock::new();
    F.get_or_init(|| build_and_fly(ZYNQ, Some(F64_SPEC), "f64-n10", None))
}

fn m4_paper_flight() -> &'static Flight {
    static F: OnceLock<Flight> = OnceLock::new();
    F.get_or_init(|| build_and_fly(M4, None, "paper", None))
}

fn limits_flight() -> &'static Flight {
    static F: OnceLock<Flight> = OnceLock::new();
    F.get_or_init(|| build_and_fly(ZYNQ, Some(LIMITS_SPEC), "paper-limits", Some(LIMITS_CYCLES)))
}

fn m4_f64_flight() -> &'static Flight {
    static F: OnceLock<Flight> = OnceLock::new();
    F.get_or_init(|| build_and_fly(M4, Some(F64_SPEC), "f64-n10", None))
}

/// The second controller: f64, horizon 10, 20 iterations.
const F64_SPEC: &str = "firmware-template/specs/paper-f64-n10.toml";

fn uint(r: &Value, key: &str) -> u64 {
    r[key]
        .as_u64()
        .unwrap_or_else(|| panic!("RESULT has no integer `{key}`: {r}"))
}

fn axes(r: &Value, key: &str) -> [u64; 3] {
    let v: Vec<u64> = r[key]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(Value::as_u64)
        .collect();
    v.try_into()
        .unwrap_or_else(|_| panic!("RESULT has no three integers `{key}`: {r}"))
}

/// FNV-1a 64, as the firmware hashes its baked spec.
fn fnv1a64(bytes: &[u8]) -> String {
    let h = bytes.iter().fold(0xcbf2_9ce4_8422_2325_u64, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    });
    format!("{h:016x}")
}

/// The errors of a flight, accumulated exactly as the firmware's `stats::Errors`.
#[derive(Default)]
struct Errors {
    sum_sq: [f64; 3],
    max_abs: [f64; 3],
    count: u64,
}

impl Errors {
    fn add(&mut self, e: &[f64; 3]) {
        for ((s, m), &e) in self.sum_sq.iter_mut().zip(&mut self.max_abs).zip(e) {
            *s += e * e;
            let a = e.abs();
            if a > *m || a.is_nan() {
                *m = a;
            }
        }
        self.count += 1;
    }

    /// RMSE and largest absolute error per axis, micrometres rounded, as in RESULT.
    fn micrometres(&self) -> ([u64; 3], [u64; 3]) {
        let um = |x: f64| (x * 1e6 + 0.5) as u64;
        let n = self.count as f64;
        (
            self.sum_sq.map(|s| um((s / n).sqrt())),
            self.max_abs.map(um),
        )
    }
}

/// Flies the firmware's loop on the host: the generated `Controller::step` of module `$m` fed
/// with the GPS position and the reference window, the plant and noise from flight-sim. Returns the
/// errors in micrometres and the cycles that used the solver's fallback.
macro_rules! host_flight {
    ($m:ident, $seed:expr, $cycles:expr) => {{
        struct Baked($m::Controller, u64);
        impl Controller for Baked {
            fn step<R: Reference>(&mut self, k: usize, z: &[f64; NY], reference: &R) -> [f64; NU] {
                let xref = reference.window::<$m::Real, { $m::N }>(k);
                let z: [$m::Real; NY] = cast(z);
                let u = self.0.step(&z, &xref);
                self.1 += u64::from(self.0.status().fell_back());
                cast(&u)
            }
            fn estimate(&self) -> [f64; NX] {
                cast(self.0.kalman().state())
            }
        }
        let reference = Trajectory::paper();
        let mut controller = Baked($m::Controller::new(cast(&reference.start())), 0);
        let mut errors = Errors::default();
        fly(
            &mut controller,
            &reference,
            &Scenario::new($seed, $cycles),
            |s, _| errors.add(&s.error()),
        );
        (errors.micrometres(), controller.1)
    }};
}

/// The firmware booted on `board`, flew every cycle of the whole reference flight and passed its
/// checks.
fn assert_flew(f: &Flight, board: Board, spec: &str, scalar: &str, horizon: u64, iterations: u64) {
    assert_eq!(f.status, Some(0), "firmware exit status\n{}", f.uart);
    assert!(
        f.uart
            .starts_with(&format!("firmware-template on {} (", board.name)),
        "no boot banner:\n{}",
        f.uart
    );
    let r = &f.result;
    assert_eq!(r["ok"], Value::Bool(true), "{r}");
    assert_eq!(r["board"], board.name);
    let text = std::fs::read(root().join(spec)).expect("reading the spec");
    assert_eq!(
        r["spec_fnv1a64"],
        Value::String(fnv1a64(&text)),
        "the ELF holds another spec than {spec}"
    );
    assert_eq!(r["scalar"], scalar);
    assert_eq!((uint(r, "nx"), uint(r, "nu")), (6, 3));
    assert_eq!(
        (uint(r, "horizon"), uint(r, "iterations")),
        (horizon, iterations)
    );
    // Painted-stack high-water mark: some stack was used, well inside the Zynq's 256 KiB stack and
    // the STM32F405's 128 KiB of RAM.
    let stack = uint(r, "stack_bytes");
    assert!(stack > 256 && stack < 48 * 1024, "stack use {stack} B");
    // One control cycle's share, from the probe painted below the caller's stack pointer.
    let cycle = uint(r, "cycle_stack_bytes");
    assert!(
        cycle > 256 && cycle < stack,
        "control cycle stack {cycle} B of {stack} B"
    );
    let full = (Trajectory::paper().duration() / flight_sim::DT) as u64;
    assert_eq!(
        uint(r, "cycles"),
        full,
        "the firmware must fly the whole reference"
    );
}

/// Same tracking errors as the host run of the same spec, seed and cycle count.
fn assert_agrees(r: &Value, host: ([u64; 3], [u64; 3])) {
    for (key, host) in [("rmse_um", host.0), ("max_abs_error_um", host.1)] {
        let fw = axes(r, key);
        eprintln!("{} {key}: firmware {fw:?}, host {host:?}", r["spec"]);
        for axis in 0..3 {
            assert!(
                fw[axis].abs_diff(host[axis]) <= AGREE_UM,
                "{key}[{axis}]: firmware {} um, host {} um (tolerance {AGREE_UM} um)",
                fw[axis],
                host[axis]
            );
        }
    }
    // Paper-like accuracy, so that agreeing on a broken flight cannot pass.
    assert!(
        axes(r, "rmse_um").iter().all(|&e| e > 1_000 && e < 200_000),
        "{r}"
    );
}

/// Every control cycle takes the same number of ticks, to within `max_spread` of the mean.
fn assert_deterministic(r: &Value, max_spread: f64) {
    let (min, mean, max) = (
        uint(r, "ticks_min"),
        uint(r, "ticks_mean"),
        uint(r, "ticks_max"),
    );
    assert!(min > 0 && min <= mean && mean <= max, "{r}");
    let spread = (max - min) as f64 / mean as f64;
    assert!(
        spread <= max_spread,
        "ticks per control cycle vary by {:.3}% (min {min}, max {max})",
        spread * 100.0
    );
    let total = uint(r, "ticks_total");
    assert!(
        total.abs_diff(mean * uint(r, "cycles")) <= uint(r, "cycles"),
        "{r}"
    );
}

/// Symbols of core's panicking machinery in an ELF. The firmware links none, not even its
/// `#[panic_handler]` (`rust_begin_unwind`): with LTO core's panicking functions can be inlined
/// into their callers, leaving the handler as the only trace of a reachable panic.
fn panicking_symbols(elf: &Path) -> Vec<String> {
    let nm = llvm_nm();
    let out = Command::new(&nm)
        .arg("--demangle")
        .arg(elf)
        .output()
        .expect("running llvm-nm");
    assert!(
        out.status.success(),
        "llvm-nm failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let symbols = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        symbols.lines().any(|l| l.ends_with(" T main")),
        "llvm-nm read no `main` from {}",
        elf.display()
    );
    symbols
        .lines()
        .filter_map(|l| l.splitn(3, ' ').nth(2))
        .filter(|s| {
            s.contains("core::panicking")
                || s.contains("panic_bounds_check")
                || s.contains("unwrap_failed")
                || s.contains("expect_failed")
                || s.contains("slice_index")
                || s.contains("rust_begin_unwind")
        })
        .map(str::to_owned)
        .collect()
}

/// `llvm-nm` from the PATH, a versioned Debian one, or installed with Debian's `llvm`.
fn llvm_nm() -> String {
    let works = |n: &str| {
        Command::new(n)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    };
    let candidates = || {
        std::iter::once("llvm-nm".to_owned()).chain((14..=21).rev().map(|v| format!("llvm-nm-{v}")))
    };
    if let Some(n) = candidates().find(|n| works(n)) {
        return n;
    }
    let installed = Command::new("apt-get")
        .args(["install", "-y", "-qq", "llvm"])
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        installed && works("llvm-nm"),
        "llvm-nm is missing: apt-get install llvm"
    );
    "llvm-nm".to_owned()
}

/// Code and data sizes of an ELF, bytes: (.text, .rodata, .data, .bss).
fn sizes(elf: &Path) -> [u64; 4] {
    let out = Command::new(llvm_nm().replace("nm", "size"))
        .args(["-A", "-d"])
        .arg(elf)
        .output()
        .expect("running llvm-size");
    let text = String::from_utf8_lossy(&out.stdout);
    let size = |name: &str| {
        text.lines()
            .find_map(|l| {
                let mut f = l.split_whitespace();
                (f.next() == Some(name))
                    .then(|| f.next().and_then(|s| s.parse().ok()))
                    .flatten()
            })
            .unwrap_or(0)
    };
    [size(".text"), size(".rodata"), size(".data"), size(".bss")]
}

/// Checks the calibration loop of `r`: `calib_instructions` took `calib_ticks` timer ticks, with
/// `board.instructions_per_tick` instructions a tick.
fn assert_calibrated(r: &Value, board: Board) {
    let (instructions, ticks) = (uint(r, "calib_instructions"), uint(r, "calib_ticks"));
    assert_eq!(instructions, 2_000_000);
    // The loop plus the few instructions of the two timer reads.
    let measured = ticks * board.instructions_per_tick;
    assert!(
        measured >= instructions
            && measured <= instructions + 16.max(4 * board.instructions_per_tick),
        "{instructions} instructions took {ticks} ticks on {}",
        board.name
    );
}

/// Prints the figures BENCHMARKS.md quotes for a flight.
fn print_figures(f: &Flight, board: Board) {
    let [text, rodata, data, bss] = sizes(&f.elf);
    eprintln!(
        "{} on the emulated {}: {} instructions per control cycle (ticks {}..{}), \
         .text {text} B, .rodata {rodata} B, .data {data} B, .bss {bss} B, stack {} B \
         (a control cycle {} B)",
        f.result["spec"],
        board.name,
        uint(&f.result, "ticks_mean") * board.instructions_per_tick,
        uint(&f.result, "ticks_min"),
        uint(&f.result, "ticks_max"),
        uint(&f.result, "stack_bytes"),
        uint(&f.result, "cycle_stack_bytes"),
    );
}

#[test]
fn global_timer_ticks_once_per_ten_instructions() {
    let r = &paper_flight().result;
    assert_calibrated(r, ZYNQ);
    // The other build runs different code around the same loop: same count.
    let r64 = &f64_flight().result;
    assert!(
        uint(r64, "calib_ticks").abs_diff(uint(r, "calib_ticks")) <= 1,
        "{r64}"
    );
}

#[test]
fn paper_spec_flies_on_the_emulated_zynq() {
    let f = paper_flight();
    assert_flew(f, ZYNQ, "specs/paper.toml", "f32", 15, 30);
    assert_deterministic(&f.result, TICK_SPREAD);
    print_figures(f, ZYNQ);
}

#[test]
fn paper_spec_firmware_agrees_with_the_host() {
    let r = &paper_flight().result;
    let (host, _) = host_flight!(paper, uint(r, "seed"), uint(r, "cycles") as usize);
    assert_agrees(r, host);
}

#[test]
fn f64_spec_flies_and_agrees_with_the_host() {
    let f = f64_flight();
    assert_flew(f, ZYNQ, F64_SPEC, "f64", 10, 20);
    assert_deterministic(&f.result, TICK_SPREAD);
    let (host, _) = host_flight!(
        f64_n10,
        uint(&f.result, "seed"),
        uint(&f.result, "cycles") as usize
    );
    assert_agrees(&f.result, host);
    // Another controller, another cost: the binary really changed.
    assert_ne!(
        uint(&f.result, "ticks_mean"),
        uint(&paper_flight().result, "ticks_mean")
    );
}

#[test]
fn emulated_timing_is_repeatable() {
    for (board, f) in [(ZYNQ, f64_flight()), (M4, m4_paper_flight())] {
        let (status, uart) = emulate(board, &f.elf);
        assert_eq!(status, Some(0));
        let again = result_line(&uart).expect("RESULT line");
        for key in ["ticks_min", "ticks_max", "ticks_total", "calib_ticks"] {
            assert_eq!(
                uint(&again, key),
                uint(&f.result, key),
                "{key} differs between two runs of one ELF on {}",
                board.name
            );
        }
    }
}

#[test]
fn no_panicking_code_is_linked() {
    for f in [
        paper_flight(),
        f64_flight(),
        m4_paper_flight(),
        m4_f64_flight(),
    ] {
        let found = panicking_symbols(&f.elf);
        assert!(
            found.is_empty(),
            "{} links panicking code: {found:?}",
            f.elf.display()
        );
    }
}

#[test]
fn tim2_ticks_once_per_instruction() {
    let r = &m4_paper_flight().result;
    assert_calibrated(r, M4);
    let r64 = &m4_f64_flight().result;
    assert!(
        uint(r64, "calib_ticks").abs_diff(uint(r, "calib_ticks")) <= 2,
        "{r64}"
    );
}

#[test]
fn paper_spec_flies_on_the_emulated_cortex_m4() {
    let f = m4_paper_flight();
    assert_flew(f, M4, "specs/paper.toml", "f32", 15, 30);
    // f32 runs on the M4's FPU: every cycle as long as every other.
    assert_deterministic(&f.result, TICK_SPREAD);
    print_figures(f, M4);
    // The image fits the part: 1 MiB of flash, 128 KiB of SRAM (memory.x).
    let [text, rodata, data, bss] = sizes(&f.elf);
    assert!(text + rodata + data < 1 << 20 && data + bss < 128 << 10);
}

#[test]
fn paper_spec_cortex_m4_firmware_agrees_with_the_host() {
    let r = &m4_paper_flight().result;
    let (host, _) = host_flight!(paper, uint(r, "seed"), uint(r, "cycles") as usize);
    assert_agrees(r, host);
    // Both boards fly the very same loop: the same errors to the micrometre.
    let a9 = &paper_flight().result;
    for key in ["rmse_um", "max_abs_error_um"] {
        assert_eq!(
            axes(r, key),
            axes(a9, key),
            "{key}: Cortex-M4F vs Cortex-A9"
        );
    }
}

#[test]
fn f64_spec_flies_on_the_cortex_m4_in_software_floating_point() {
    let f = m4_f64_flight();
    assert_flew(f, M4, F64_SPEC, "f64", 10, 20);
    assert_deterministic(&f.result, SOFT_FLOAT_TICK_SPREAD);
    let (host, _) = host_flight!(
        f64_n10,
        uint(&f.result, "seed"),
        uint(&f.result, "cycles") as usize
    );
    assert_agrees(&f.result, host);
    print_figures(f, M4);
    // No double-precision FPU: the same controller costs many times the A9's instructions.
    let m4 = uint(&f.result, "ticks_mean") * M4.instructions_per_tick;
    let a9 = uint(&f64_flight().result, "ticks_mean") * ZYNQ.instructions_per_tick;
    assert!(
        m4 > 5 * a9,
        "f64 on the M4: {m4} instructions, on the A9: {a9}"
    );
}

#[test]
fn paper_limits_flies_on_the_zynq_in_f64_with_the_same_instructions_every_cycle() {
    let f = limits_flight();
    assert_eq!(f.status, Some(0), "firmware exit status\n{}", f.uart);
    let r = &f.result;
    assert_eq!(r["ok"], Value::Bool(true), "{r}");
    assert_eq!(r["board"], ZYNQ.name);
    let text = std::fs::read(root().join(LIMITS_SPEC)).expect("reading the spec");
    assert_eq!(r["spec_fnv1a64"], Value::String(fnv1a64(&text)));
    assert_eq!(r["scalar"], "f64");
    assert_eq!(
        (uint(r, "horizon"), uint(r, "iterations")),
        (limits::N as u64, limits::ITERATIONS as u64)
    );
    assert_eq!(uint(r, "cycles"), LIMITS_CYCLES as u64);
    // The emitted interior-point method's control flow does not depend on the data (a cold start and
    // every iteration on every solve, held points kept by selection, selects by bit masks that LLVM
    // cannot turn into branches): every cycle runs the same instructions. The timer counts one tick per
    // 10 instructions, so the same count reads as n or n + 1 ticks depending on where a cycle starts.
    let (min, max) = (uint(r, "ticks_min"), uint(r, "ticks_max"));
    assert!(
        max - min <= 1,
        "ticks per control cycle vary: {min}..{max} (more than the timer's quantisation)"
    );
    // The same flight on the host: the same errors and the same fallbacks.
    let (host, fallbacks) = host_flight!(limits, uint(r, "seed"), LIMITS_CYCLES);
    for (key, host) in [("rmse_um", host.0), ("max_abs_error_um", host.1)] {
        let fw = axes(r, key);
        eprintln!("paper-limits {key}: firmware {fw:?}, host {host:?}");
        for axis in 0..3 {
            assert!(
                fw[axis].abs_diff(host[axis]) <= AGREE_UM,
                "{key}[{axis}]: firmware {} um, host {} um",
                fw[axis],
                host[axis]
            );
        }
    }
    assert_eq!(uint(r, "fallback_cycles"), fallbacks, "{r}");
    // Millions of instructions a cycle (observed 3.47 M with the kernels written out, 9.75 M with loops
    // over the rows' runs, 12.2 M dense): it must fit the 12.8 ms period at 667 MHz with the 1.5 cycles
    // an instruction the compiler's estimate assumes on the A9 (codegen::target), 5.7 M instructions.
    let instructions = uint(r, "ticks_mean") * ZYNQ.instructions_per_tick;
    let budget = (limits::DT * 667e6 / 1.5) as u64;
    assert!(
        instructions > 1_000_000 && instructions <= budget,
        "{instructions} instructions a cycle, against {budget} that fit the period"
    );
    let stack = uint(r, "cycle_stack_bytes");
    assert!(
        stack > 8 * 1024 && stack < 192 * 1024,
        "control cycle stack {stack} B"
    );
    print_figures(f, ZYNQ);
}

/// The paper-limits firmware links no panicking code: every index of the emitted interior-point
/// method into its constant tables goes through a checked `get` with a select (`at`, `put`, `span`),
/// the indices the compiler can bound are plain, as in the first-order builds
/// (`no_panicking_code_is_linked`).
#[test]
fn paper_limits_firmware_links_no_panicking_code() {
    let f = limits_flight();
    let found = panicking_symbols(&f.elf);
    assert!(found.is_empty(), "links panicking code: {found:?}");
}

/// The linear mode: OSQP's quadcopter flown on its own model on the Cortex-M4F (issue 18.4).
#[path = "firmware/linear.rs"]
mod linear;

/// The dual active set's heaviest cold case on the Cortex-M4F against the build's bound (issue 33.3).
#[path = "firmware/witness.rs"]
mod witness;

/// The C firmware: the linear mode in C over the C API, linked with arm-none-eabi-gcc (issue 35.2).
#[path = "firmware/c.rs"]
mod c;
