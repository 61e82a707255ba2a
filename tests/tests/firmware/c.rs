//! The C firmware (issue 35.2): firmware-template's linear mode written in C (firmware-template/c/)
//! over the C API of `specs/paper.toml` (f32, a filter in front of the fast gradient method), its
//! static library built for thumbv7em-none-eabihf (the STM32F405) and armv7a-none-eabihf (the
//! Zynq-7000, with its NEON kernels) and linked with arm-none-eabi-gcc and newlib by
//! scripts/c-firmware.sh, flown on each emulated board beside the Rust firmware built with
//! `scripts/firmware.sh --linear` from the same spec, and the same loop on the host.
//!
//! Without arm-none-eabi-gcc, newlib or qemu-system-arm the script fails and so does the test: CI
//! installs them (.ci/run).

use super::*;
use flight_sim::{
    fly_linear, LinearController, LinearNoiseConfig, LinearPlant, LinearReference, LinearScenario,
    Setpoint,
};

const PAPER: &str = "specs/paper.toml";
/// The linear mode's default flight: 1.28 s of the step of state 2 (z) to 1 m.
const CYCLES: usize = 100;
/// The Rust firmware's RESULT fields the C firmware does not print: it has no stack probe.
const RUST_ONLY: [&str; 2] = ["stack_bytes", "cycle_stack_bytes"];
/// Fields that may differ: the spec's path (the Rust firmware bakes a copy), and the timing.
const MAY_DIFFER: [&str; 6] = [
    "spec",
    "ticks_min",
    "ticks_mean",
    "ticks_max",
    "ticks_total",
    "calib_ticks",
];

/// The Rust firmware's linear mode on `board`: 100 cycles unless told otherwise, the build of
/// `scripts/firmware.sh --board BOARD --linear specs/paper.toml`.
fn rust_linear(board: Board) -> Flight {
    let elf = build_with(board, Some(PAPER), "paper-linear", None, &["--linear"]);
    fly_elf(board, elf, "the Rust firmware, linear mode")
}

fn rust_flight() -> &'static Flight {
    static F: OnceLock<Flight> = OnceLock::new();
    F.get_or_init(|| rust_linear(M4))
}

fn c_flight() -> &'static Flight {
    static F: OnceLock<Flight> = OnceLock::new();
    F.get_or_init(|| fly_elf(M4, build_c(M4, PAPER, "paper", CYCLES), "the C firmware"))
}

fn zynq_rust_flight() -> &'static Flight {
    static F: OnceLock<Flight> = OnceLock::new();
    F.get_or_init(|| rust_linear(ZYNQ))
}

fn zynq_c_flight() -> &'static Flight {
    static F: OnceLock<Flight> = OnceLock::new();
    F.get_or_init(|| {
        let elf = build_c(ZYNQ, PAPER, "paper", CYCLES);
        fly_elf(ZYNQ, elf, "the C firmware on the Zynq")
    })
}

fn fly_elf(board: Board, elf: PathBuf, what: &str) -> Flight {
    let (status, uart) = emulate(board, &elf);
    let result =
        result_line(&uart).unwrap_or_else(|| panic!("no RESULT line from {what}:\n{uart}"));
    Flight {
        status,
        uart,
        result,
        elf,
    }
}

/// Writes the C crate of `spec` for `board`'s target (as `mpcc emit SPEC --c DIR --target TRIPLE`) and
/// builds the C firmware over it with scripts/c-firmware.sh.
fn build_c(board: Board, spec: &str, name: &str, cycles: usize) -> PathBuf {
    let triple = if board.arg == ZYNQ.arg {
        "armv7a-none-eabihf"
    } else {
        "thumbv7em-none-eabihf"
    };
    let root = root();
    let source = std::fs::read_to_string(root.join(spec)).expect("the spec is readable");
    let opt = codegen::Opt::new(name, "pub", codegen::Origin::Named(spec.into()));
    let generated = codegen::generate_from_source(&source, &opt)
        .unwrap_or_else(|d| panic!("{spec} does not compile: {d:?}"));
    let tmp = Path::new(env!("CARGO_TARGET_TMPDIR")).join("c-firmware");
    let dir = tmp.join(board.arg).join(name);
    codegen::c_api::write_crate(&dir, &generated, spec, Some(triple))
        .unwrap_or_else(|why| panic!("cannot write the C crate of {spec}: {why}"));
    let elf = tmp.join(format!("{}-{name}.elf", board.arg));
    let mut build = Command::new("timeout");
    build
        .arg(BUILD_TIMEOUT_S.to_string())
        .arg("bash")
        .arg(root.join("scripts/c-firmware.sh"))
        .args(["--board", board.arg, "--build-only", "--crate"])
        .arg(&dir)
        .arg("--elf-out")
        .arg(&elf)
        .arg(format!("--cycles={cycles}"))
        .arg(root.join(spec));
    let out = clean_env(&mut build)
        .output()
        .expect("running scripts/c-firmware.sh");
    assert!(
        out.status.success(),
        "building the C firmware for {spec} failed ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    elf
}

/// The `U k bits…` lines of a flight.
fn command_lines(uart: &str) -> Vec<&str> {
    uart.lines().filter(|l| l.starts_with("U ")).collect()
}

/// The controller fed the exact measurement `C x`, as linear.rs's `Timed` with `linear-filter`.
struct Host(paper::Controller);

impl LinearController<{ paper::NU }, { paper::NY }, { paper::NX }> for Host {
    fn step<R: LinearReference<{ paper::NX }>>(
        &mut self,
        k: usize,
        z: &[f64; paper::NY],
        r: &R,
    ) -> [f64; paper::NU] {
        let xref = r.window::<paper::Real, { paper::N }>(k, f64::from(paper::DT));
        cast(&self.0.step(&cast(z), &xref))
    }
}

/// The linear loop on the host with the same generated module: `commands_fnv1a64` as the
/// firmwares hash it (the bits of each f32 command widened to 8 little-endian bytes).
fn host_commands_hash(cycles: usize) -> String {
    let mut identity = [[0.0; paper::NX]; paper::NX];
    for (i, row) in identity.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    let mut plant = LinearPlant::<{ paper::NX }, { paper::NU }, { paper::NY }>::new(
        paper::F.map(|row| cast(&row)),
        paper::G.map(|row| cast(&row)),
        paper::C.map(|row| cast(&row)),
        [0.0; paper::NX],
    );
    let mut reference = [0.0; paper::NX];
    reference[2] = 1.0;
    let scenario = LinearScenario {
        seed: 1,
        cycles,
        dt: f64::from(paper::DT),
        noise: LinearNoiseConfig::NONE,
    };
    let mut bytes = Vec::new();
    fly_linear(
        &mut plant,
        &mut Host(paper::Controller::new([0.0; paper::NX])),
        &Setpoint(reference),
        &identity,
        &scenario,
        |_| [0.0; paper::NU],
        |s, _| {
            for u in s.command {
                bytes.extend_from_slice(&u64::from((u as f32).to_bits()).to_le_bytes());
            }
        },
    );
    fnv1a64(&bytes)
}

#[test]
fn c_firmware_flies_the_linear_mode_with_the_rust_firmwares_commands() {
    let (rust, c) = (rust_flight(), c_flight());
    for (what, f) in [("Rust", rust), ("C", c)] {
        assert_eq!(f.status, Some(0), "{what} firmware exit status\n{}", f.uart);
        assert_eq!(f.result["ok"], Value::Bool(true), "{what}: {}", f.result);
        assert_eq!(f.result["mode"], "linear", "{what}");
        assert_calibrated(&f.result, M4);
    }
    let (r, cr) = (&rust.result, &c.result);
    let text = std::fs::read(root().join(PAPER)).expect("reading the spec");
    assert_eq!(cr["spec_fnv1a64"], Value::String(fnv1a64(&text)));
    assert_eq!(cr["spec"], PAPER);
    assert_eq!(cr["language"], "c");
    assert_eq!(uint(cr, "cycles"), CYCLES as u64);

    // The same fields, the same values but for the path and the timing.
    let fields = |v: &Value| -> Vec<String> {
        let mut k: Vec<String> = v
            .as_object()
            .expect("RESULT is an object")
            .keys()
            .cloned()
            .collect();
        k.sort();
        k
    };
    let mut expected: Vec<String> = fields(r)
        .into_iter()
        .filter(|k| !RUST_ONLY.contains(&k.as_str()))
        .chain(["language".to_owned()])
        .collect();
    expected.sort();
    assert_eq!(fields(cr), expected, "RESULT fields: Rust {r}\nC {cr}");
    for k in fields(r) {
        if !RUST_ONLY.contains(&k.as_str()) && !MAY_DIFFER.contains(&k.as_str()) {
            assert_eq!(cr[&k], r[&k], "`{k}`: C {cr}\nRust {r}");
        }
    }
    // Every command bit for bit, not only their hash, and the host's hash of the same loop.
    assert_eq!(command_lines(&c.uart), command_lines(&rust.uart));
    assert_eq!(command_lines(&c.uart).len(), CYCLES);
    assert_eq!(
        cr["commands_fnv1a64"],
        Value::String(host_commands_hash(CYCLES))
    );
    // The flight went somewhere: z near its reference of 1 m (final_state_micro[2]).
    let z = cr["final_state_micro"][2].as_f64().expect("final z");
    assert!((900_000.0..1_100_000.0).contains(&z), "{cr}");

    // The C loop times NAME_step, the Rust one Controller::step: the same code but for the C API's
    // pointer checks. Instructions, not time: TIM2 ticks once per instruction under -icount, and every
    // cycle runs the same instructions (fixed iterations, branch-free but for the projections).
    assert_deterministic(cr, TICK_SPREAD);
    let (tc, tr) = (uint(cr, "ticks_mean"), uint(r, "ticks_mean"));
    let ratio = tc as f64 / tr as f64;
    eprintln!(
        "specs/paper.toml, linear mode, {CYCLES} cycles on the emulated STM32F405: C {tc}, Rust {tr} \
         instructions a control cycle (C/Rust {ratio:.4})"
    );
    assert!(
        (0.99..=1.01).contains(&ratio),
        "C {tc} against Rust {tr} instructions a cycle"
    );
    print_figures(rust, M4);
}

/// The same C over the C API on the Zynq-7000: firmware-template/c/zynq.S (rt.rs's startup in
/// assembly), zynq.c and zynq.ld, the library built with the A9's NEON kernels. The same commands
/// as the STM32F405's C flight and the host's loop (f32 is IEEE on both VFPs), and the Rust
/// firmware's instructions a cycle on the same board within 1 %.
#[test]
fn c_firmware_flies_on_the_zynq_with_the_same_commands() {
    let (c, rust, m4) = (zynq_c_flight(), zynq_rust_flight(), c_flight());
    for (what, f) in [("C", c), ("Rust", rust)] {
        assert_eq!(f.status, Some(0), "{what} firmware exit status\n{}", f.uart);
        assert_eq!(f.result["ok"], Value::Bool(true), "{what}: {}", f.result);
        assert_calibrated(&f.result, ZYNQ);
    }
    let (cr, r) = (&c.result, &rust.result);
    assert_eq!(cr["board"], ZYNQ.name);
    assert_eq!(cr["language"], "c");
    for k in [
        "commands_fnv1a64",
        "final_state_micro",
        "saturated_cycles",
        "cycles",
    ] {
        assert_eq!(
            cr[k], m4.result[k],
            "`{k}`: Zynq {cr}\nSTM32F405 {}",
            m4.result
        );
        assert_eq!(cr[k], r[k], "`{k}`: C {cr}\nRust {r}");
    }
    assert_eq!(command_lines(&c.uart), command_lines(&m4.uart));
    assert_eq!(
        cr["commands_fnv1a64"],
        Value::String(host_commands_hash(CYCLES))
    );
    assert_deterministic(cr, TICK_SPREAD);
    let (tc, tr) = (uint(cr, "ticks_mean"), uint(r, "ticks_mean"));
    let ratio = tc as f64 / tr as f64;
    eprintln!(
        "specs/paper.toml, linear mode, {CYCLES} cycles on the emulated Zynq-7000: C {tc}, Rust {tr} \
         global timer ticks a control cycle (C/Rust {ratio:.4})"
    );
    assert!(
        (0.99..=1.01).contains(&ratio),
        "C {tc} against Rust {tr} ticks a cycle: the library without its NEON kernels?"
    );
}
