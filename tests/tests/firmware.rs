//! The firmware template on the emulated Zynq-7000 (issue 6).
//!
//! Each spec is built once with `cargo +nightly` through `scripts/firmware.sh` (which also installs
//! qemu-system-arm and nightly's rust-src when they are missing) and flown once under QEMU with
//! `-icount shift=0`; the tests below read its `RESULT` line, its exit status and its ELF, and fly
//! the same loop on the host with the same generated module.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Mutex, OnceLock};

use flight_sim::{cast, fly, Controller, Reference, Scenario, Trajectory, NU, NX, NY};
use serde_json::Value;

mpc_macros::mpc!(mod paper = "../specs/paper.toml");
mpc_macros::mpc!(mod f64_n10 = "../firmware-template/specs/paper-f64-n10.toml");

/// Seconds allowed for one build (cold: core from source and the macro's dependencies).
const BUILD_TIMEOUT_S: u32 = 1800;
/// Seconds allowed for one emulated flight (about 10 s on a 2-core machine).
const RUN_TIMEOUT_S: u32 = 300;
/// The global timer advances one tick per this many instructions under `-icount shift=0`.
const INSTRUCTIONS_PER_TICK: u64 = 10;
/// Allowed spread of the ticks of one control cycle over a flight, relative to the mean.
/// Fixed iteration counts and branch-free matrix code make every cycle the same length; only the
/// box projections branch.
const TICK_SPREAD: f64 = 0.002;
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
/// (scripts/firmware.sh also takes a lock file, against other processes).
static FIRMWARE: Mutex<()> = Mutex::new(());

fn build_and_fly(spec: Option<&str>, name: &str) -> Flight {
    let _guard = FIRMWARE.lock().unwrap_or_else(|e| e.into_inner());
    let root = root();
    let elf = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("firmware-{name}.elf"));
    let mut build = Command::new("timeout");
    build
        .arg(BUILD_TIMEOUT_S.to_string())
        .arg("bash")
        .arg(root.join("scripts/firmware.sh"))
        .args(["--build-only", "--elf-out"])
        .arg(&elf)
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
    let (status, uart) = emulate(&elf);
    let result =
        result_line(&uart).unwrap_or_else(|| panic!("no RESULT line from {name}:\n{uart}"));
    Flight {
        status,
        uart,
        result,
        elf,
    }
}

/// Runs an ELF on QEMU's xilinx-zynq-a9 exactly as the template's cargo runner does.
fn emulate(elf: &Path) -> (Option<i32>, String) {
    let out = Command::new("timeout")
        .arg(RUN_TIMEOUT_S.to_string())
        .args([
            "qemu-system-arm",
            "-M",
            "xilinx-zynq-a9",
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
    F.get_or_init(|| build_and_fly(None, "paper"))
}

fn f64_flight() -> &'static Flight {
    static F: OnceLock<Flight> = OnceLock::new();
    F.get_or_init(|| {
        build_and_fly(
            Some("firmware-template/specs/paper-f64-n10.toml"),
            "f64-n10",
        )
    })
}

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
/// with the GPS position and the reference window, the plant and noise from flight-sim.
macro_rules! host_flight {
    ($m:ident, $seed:expr, $cycles:expr) => {{
        struct Baked($m::Controller);
        impl Controller for Baked {
            fn step<R: Reference>(&mut self, k: usize, z: &[f64; NY], reference: &R) -> [f64; NU] {
                let xref = reference.window::<$m::Real, { $m::N }>(k);
                let z: [$m::Real; NY] = cast(z);
                cast(&self.0.step(&z, &xref))
            }
            fn estimate(&self) -> [f64; NX] {
                cast(self.0.kalman().state())
            }
        }
        let reference = Trajectory::paper();
        let mut controller = Baked($m::Controller::new(cast(&reference.start())));
        let mut errors = Errors::default();
        fly(
            &mut controller,
            &reference,
            &Scenario::new($seed, $cycles),
            |s, _| errors.add(&s.error()),
        );
        errors.micrometres()
    }};
}

/// The firmware booted, flew every cycle of the whole reference flight and passed its checks.
fn assert_flew(f: &Flight, spec: &str, scalar: &str, horizon: u64, iterations: u64) {
    assert_eq!(f.status, Some(0), "firmware exit status\n{}", f.uart);
    assert!(
        f.uart.starts_with("firmware-template on zynq-7000"),
        "no boot banner:\n{}",
        f.uart
    );
    let r = &f.result;
    assert_eq!(r["ok"], Value::Bool(true), "{r}");
    assert_eq!(r["board"], "zynq-7000");
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
    // Painted-stack high-water mark: some stack was used, well inside the 64 KiB of memory.x.
    let stack = uint(r, "stack_bytes");
    assert!(stack > 256 && stack < 48 * 1024, "stack use {stack} B");
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

/// Every control cycle takes the same number of ticks, to within TICK_SPREAD.
fn assert_deterministic(r: &Value) {
    let (min, mean, max) = (
        uint(r, "ticks_min"),
        uint(r, "ticks_mean"),
        uint(r, "ticks_max"),
    );
    assert!(min > 0 && min <= mean && mean <= max, "{r}");
    let spread = (max - min) as f64 / mean as f64;
    assert!(
        spread <= TICK_SPREAD,
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

#[test]
fn global_timer_ticks_once_per_ten_instructions() {
    let r = &paper_flight().result;
    let (instructions, ticks) = (uint(r, "calib_instructions"), uint(r, "calib_ticks"));
    assert_eq!(instructions, 2_000_000);
    // The loop plus the few instructions of the two timer reads, one tick = 10 instructions.
    let measured = ticks * INSTRUCTIONS_PER_TICK;
    assert!(
        measured >= instructions && measured <= instructions + 4 * INSTRUCTIONS_PER_TICK,
        "{instructions} instructions took {ticks} ticks"
    );
    // The other build runs different code around the same loop: same count.
    let r64 = &f64_flight().result;
    assert!(uint(r64, "calib_ticks").abs_diff(ticks) <= 1, "{r64}");
}

#[test]
fn paper_spec_flies_on_the_emulated_zynq() {
    let f = paper_flight();
    assert_flew(f, "specs/paper.toml", "f32", 15, 30);
    assert_deterministic(&f.result);
    let ticks = uint(&f.result, "ticks_mean");
    let [text, rodata, data, bss] = sizes(&f.elf);
    eprintln!(
        "paper.toml on the emulated Cortex-A9: {} instructions per control cycle (ticks {}..{}), \
         .text {text} B, .rodata {rodata} B, .data {data} B, .bss {bss} B",
        ticks * INSTRUCTIONS_PER_TICK,
        uint(&f.result, "ticks_min"),
        uint(&f.result, "ticks_max"),
    );
}

#[test]
fn paper_spec_firmware_agrees_with_the_host() {
    let r = &paper_flight().result;
    let host = host_flight!(paper, uint(r, "seed"), uint(r, "cycles") as usize);
    assert_agrees(r, host);
}

#[test]
fn f64_spec_flies_and_agrees_with_the_host() {
    let f = f64_flight();
    assert_flew(
        f,
        "firmware-template/specs/paper-f64-n10.toml",
        "f64",
        10,
        20,
    );
    assert_deterministic(&f.result);
    let host = host_flight!(
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
    let f = f64_flight();
    let (status, uart) = emulate(&f.elf);
    assert_eq!(status, Some(0));
    let again = result_line(&uart).expect("RESULT line");
    for key in ["ticks_min", "ticks_max", "ticks_total", "calib_ticks"] {
        assert_eq!(
            uint(&again, key),
            uint(&f.result, key),
            "{key} differs between two runs of one ELF"
        );
    }
}

#[test]
fn no_panicking_code_is_linked() {
    for f in [paper_flight(), f64_flight()] {
        let found = panicking_symbols(&f.elf);
        assert!(
            found.is_empty(),
            "{} links panicking code: {found:?}",
            f.elf.display()
        );
    }
}
