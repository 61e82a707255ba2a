//! The C API of generated controllers (issue 35): `codegen::c_api::write_crate`, what `mpcc emit --c`
//! writes, built as a static library with cargo and called from C programs built with `cc`.
//!
//! - Replay: the Rust controller flies 1,000 cycles of a closed loop over its own model with noisy
//!   measurements and changing references; the measurements and references are recorded and replayed by
//!   the C program `tests/c/replay.c` through the C API. The commands, status codes and final plan agree
//!   bit for bit, on `specs/paper.toml` (f32, a filter), `specs/quadcopter.toml` (constrained, f64,
//!   state feedback) and `tests/specs/quadcopter-admm-f32.toml` (state feedback, ADMM, f32). The C++
//!   program `tests/c/replay.cpp` replays the same through `NAME.hpp` (its class and `std::array`
//!   overloads) with the same result.
//! - `tests/c/two_controllers.c` links two controllers into one program.
//! - The header lists every public field of `Status`, `SolverStatus` and `FilterStatus`, read here from
//!   the emitted module independently of `codegen::c_api`.
//!
//! The crates are written and built under `target/c-api/` of the workspace, so a rerun is incremental.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

mpc_macros::mpc!(mod paper = "../specs/paper.toml");
mpc_macros::mpc!(mod quadcopter = "../specs/quadcopter.toml");
mpc_macros::mpc!(mod quadcopter_admm_f32 = "specs/quadcopter-admm-f32.toml");

/// Cycles of the replayed flight.
const CYCLES: usize = 1000;
/// Cycles between two references.
const REFERENCE_EVERY: usize = 200;

/// The workspace.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Where the C crates, their builds and the C programs go.
fn work() -> PathBuf {
    root().join("target").join("c-api")
}

/// A controller's C crate, built.
#[derive(Clone)]
struct Built {
    /// The crate's directory, which holds the header `NAME.h`.
    dir: PathBuf,
    /// `libNAME.a`.
    lib: PathBuf,
    /// The emitted module, as `src/controller.rs` holds it.
    module: String,
}

/// The crates built by this run, by module name: each spec is compiled and built once.
static BUILT: Mutex<Vec<(String, Built)>> = Mutex::new(Vec::new());

/// Writes the C crate of `spec` (relative to the workspace) as module `name` and builds its static
/// library for the host. One build at a time: the two cores are better spent on one cargo.
fn build(spec: &str, name: &str) -> Built {
    let mut built = BUILT.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, b)) = built.iter().find(|(n, _)| n == name) {
        return b.clone();
    }
    let source = std::fs::read_to_string(root().join(spec)).expect("the spec is readable");
    let opt = codegen::Opt::new(name, "pub", codegen::Origin::Named(spec.into()));
    let generated = codegen::generate_from_source(&source, &opt)
        .unwrap_or_else(|d| panic!("{spec} does not compile: {d:?}"));
    let dir = work().join("crates").join(name);
    codegen::c_api::write_crate(&dir, &generated, spec, None)
        .unwrap_or_else(|why| panic!("cannot write the C crate of {spec}: {why}"));
    let target_dir = work().join("build");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let out = Command::new(cargo)
        .args(["build", "--release", "--quiet", "--manifest-path"])
        .arg(dir.join("Cargo.toml"))
        .arg("--target-dir")
        .arg(&target_dir)
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "the C crate of {spec} does not build:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lib = target_dir.join("release").join(format!("lib{name}.a"));
    assert!(lib.is_file(), "cargo built no `{}`", lib.display());
    let b = Built {
        dir,
        lib,
        module: generated.pretty(),
    };
    built.push((name.into(), b.clone()));
    b
}

/// The language a program of `tests/c/` is compiled as.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Lang {
    /// `cc -std=c11`.
    C,
    /// `c++ -x c++ -std=c++17`: the header's C++ branch (`extern "C"`, `alignas`, `static_assert`).
    Cpp,
}

/// Compiles and links a C program with `cc` in strict C11 (the header's static asserts run here).
fn cc(exe: &Path, source: &str, includes: &[&Path], defines: &[String], libs: &[&Path]) {
    compile(Lang::C, exe, source, includes, defines, libs);
}

/// Compiles and links a program of `tests/c/` as `lang`, warnings as errors.
fn compile(
    lang: Lang,
    exe: &Path,
    source: &str,
    includes: &[&Path],
    defines: &[String],
    libs: &[&Path],
) {
    let (var, default, std) = match lang {
        Lang::C => ("CC", "cc", &["-std=c11"][..]),
        Lang::Cpp => ("CXX", "c++", &["-x", "c++", "-std=c++17"][..]),
    };
    let mut cmd = Command::new(std::env::var_os(var).unwrap_or_else(|| default.into()));
    cmd.args(std)
        .args(["-O2", "-Wall", "-Wextra", "-Werror", "-pedantic", "-o"])
        .arg(exe)
        .arg(root().join("tests").join("c").join(source));
    for i in includes {
        cmd.arg("-I").arg(i);
    }
    // `-x none`: the libraries that follow are not C++ source.
    cmd.args(defines).args(["-x", "none"]).args(libs);
    let out = cmd.output().expect("the C compiler runs");
    assert!(
        out.status.success(),
        "{default} ({lang:?}) {source} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The bits of a float in hex, as `replay.c` prints and reads them.
trait Bits: Copy {
    fn hex(self) -> String;
    fn from_f64(x: f64) -> Self;
    fn to_f64(self) -> f64;
}

impl Bits for f32 {
    fn hex(self) -> String {
        format!("{:08x}", self.to_bits())
    }
    fn from_f64(x: f64) -> Self {
        x as f32
    }
    fn to_f64(self) -> f64 {
        self.into()
    }
}

impl Bits for f64 {
    fn hex(self) -> String {
        format!("{:016x}", self.to_bits())
    }
    fn from_f64(x: f64) -> Self {
        x
    }
    fn to_f64(self) -> f64 {
        self
    }
}

/// A recorded flight: `replay.c`'s standard input and the output the Rust controller gives on it.
struct Flight {
    input: String,
    expected: Vec<String>,
    /// The largest |u| commanded: the flight must exercise the controller.
    largest_command: f64,
    /// Distinct status codes seen.
    codes: Vec<i32>,
}

/// Flies the Rust controller of module `$m` over its own model `F`, `G` for CYCLES cycles, recording
/// what `replay.c` needs. `$kind` is `filter` (the controller measures `z = C x`, `new(x0)`) or
/// `state` (it measures `x`, `new()`).
macro_rules! fly {
    ($m:ident, $kind:ident) => {{
        use $m::{Controller, Real, F, G, N, NU, NX};
        let mut rng = ChaCha8Rng::seed_from_u64(35);
        let mut input = format!("{CYCLES}\n");
        let mut expected = Vec::new();
        let mut ctl = fly!(@new $kind, input);
        let mut x = [0.0f64; NX];
        let mut r = [0.0 as Real; NX];
        let (mut largest_command, mut codes) = (0.0f64, Vec::new());
        for k in 0..CYCLES {
            if k % REFERENCE_EVERY == 0 {
                r = core::array::from_fn(|_| Real::from_f64(rng.gen_range(-0.3..0.3)));
            }
            let xref = [r; N];
            let measured = fly!(@measure $kind, $m, x, rng);
            for v in measured.iter().chain(xref.iter().flatten()) {
                input.push_str(&v.hex());
                input.push(' ');
            }
            input.push('\n');
            let u = ctl.step(&measured, &xref);
            let code = ctl.status().command as i32;
            if !codes.contains(&code) {
                codes.push(code);
            }
            let mut line = format!("step {code}");
            for v in u {
                let _ = write!(line, " {}", v.hex());
                largest_command = largest_command.max(v.to_f64().abs());
            }
            expected.push(line);
            let mut next = [0.0f64; NX];
            for i in 0..NX {
                next[i] = (0..NX).map(|j| F[i][j].to_f64() * x[j]).sum::<f64>()
                    + (0..NU).map(|j| G[i][j].to_f64() * u[j].to_f64()).sum::<f64>();
            }
            x = next;
        }
        let mut plan = String::from("plan");
        for v in ctl.mpc().plan().iter().flatten() {
            let _ = write!(plan, " {}", v.hex());
        }
        expected.push(plan);
        Flight { input, expected, largest_command, codes }
    }};
    (@new filter, $input:ident) => {{
        let x0 = [0.0 as Real; NX];
        for v in x0 {
            $input.push_str(&v.hex());
            $input.push(' ');
        }
        $input.push('\n');
        Controller::new(x0)
    }};
    (@new state, $input:ident) => {
        Controller::new()
    };
    (@measure filter, $m:ident, $x:ident, $rng:ident) => {{
        let c = $m::C;
        let z: [Real; $m::NY] = core::array::from_fn(|i| {
            let y: f64 = (0..NX).map(|j| c[i][j].to_f64() * $x[j]).sum();
            Real::from_f64(y + $rng.gen_range(-0.01..0.01))
        });
        z
    }};
    (@measure state, $m:ident, $x:ident, $rng:ident) => {{
        let z: [Real; NX] = core::array::from_fn(|i| Real::from_f64($x[i] + $rng.gen_range(-0.01..0.01)));
        z
    }};
}

/// Runs the replay program `exe` on `flight`'s recording and checks it prints the Rust output bit for bit.
fn check_replay(exe: &Path, name: &str, lang: &str, flight: &Flight) {
    let mut child = Command::new(exe)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the replay program runs");
    let input = flight.input.clone();
    let mut stdin = child.stdin.take().expect("piped stdin");
    let writer = std::thread::spawn(move || {
        use std::io::Write;
        stdin.write_all(input.as_bytes())
    });
    let out = child.wait_with_output().expect("the replay program ends");
    writer
        .join()
        .expect("the writer ends")
        .expect("stdin takes the recording");
    assert!(
        out.status.success(),
        "{lang} replay of {name} failed ({}): {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).expect("ASCII output");
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines.len(),
        flight.expected.len(),
        "{lang} replay of {name} printed {} lines for {CYCLES} cycles and a plan",
        lines.len()
    );
    for (k, (c, rust)) in lines.iter().zip(&flight.expected).enumerate() {
        assert_eq!(
            *c, rust,
            "{name}: {lang} and Rust differ at line {k} (cycle {k}, or the plan)"
        );
    }
}

/// Builds `replay.c`, and `replay.cpp` over the C++ header, against the controller `name` of `spec` and
/// checks both return `flight`'s output bit for bit.
fn replay(spec: &str, name: &str, measured: &str, takes_x0: bool, flight: Flight) {
    let Built { dir, lib, .. } = build(spec, name);
    let up = name.to_uppercase();
    let exe = work().join(format!("replay-{name}"));
    let defines = [
        format!("-DCTL={name}"),
        format!("-DHEADER=\"{name}.h\""),
        format!("-DNX={up}_NX"),
        format!("-DNU={up}_NU"),
        format!("-DN={up}_N"),
        format!("-DNM={up}_{measured}"),
        format!("-DTAKES_X0={}", i32::from(takes_x0)),
    ];
    cc(&exe, "replay.c", &[&dir], &defines, &[&lib]);
    check_replay(&exe, name, "C", &flight);
    // The same through the C++ header's class and std::array overloads.
    let exe = work().join(format!("replay-cpp-{name}"));
    let measured_ty = if measured == "NY" {
        "Measurement"
    } else {
        "State"
    };
    let defines = [
        format!("-DCTL={name}"),
        format!("-DHEADER=\"{name}.hpp\""),
        format!("-DTAKES_X0={}", i32::from(takes_x0)),
        format!("-DMEASURED={measured_ty}"),
    ];
    compile(Lang::Cpp, &exe, "replay.cpp", &[&dir], &defines, &[&lib]);
    check_replay(&exe, name, "C++", &flight);
    // The comparison means something only if the flight moved the controller.
    assert!(
        flight.largest_command > 1e-3,
        "{name}: the flight commanded nothing (largest |u| {})",
        flight.largest_command
    );
    println!(
        "{name}: {CYCLES} cycles bit for bit, largest |u| {:.3}, status codes {:?}",
        flight.largest_command, flight.codes
    );
}

#[test]
fn paper_f32_replays_bit_for_bit() {
    replay("specs/paper.toml", "paper", "NY", true, fly!(paper, filter));
}

#[test]
fn quadcopter_f64_replays_bit_for_bit() {
    replay(
        "specs/quadcopter.toml",
        "quadcopter",
        "NX",
        false,
        fly!(quadcopter, state),
    );
}

#[test]
fn state_feedback_admm_f32_replays_bit_for_bit() {
    replay(
        "tests/specs/quadcopter-admm-f32.toml",
        "quadcopter_admm_f32",
        "NX",
        false,
        fly!(quadcopter_admm_f32, state),
    );
}

/// In C, and as C++ (the header's C++ branch).
#[test]
fn two_controllers_link_into_one_program() {
    for lang in [Lang::C, Lang::Cpp] {
        two_controllers(lang);
    }
}

fn two_controllers(lang: Lang) {
    let paper_c = build("specs/paper.toml", "paper");
    let quad_c = build("specs/quadcopter.toml", "quadcopter");
    let exe = work().join(format!("two-controllers-{lang:?}"));
    compile(
        lang,
        &exe,
        "two_controllers.c",
        &[&paper_c.dir, &quad_c.dir],
        &[],
        &[&paper_c.lib, &quad_c.lib],
    );
    let out = Command::new(&exe).output().expect("the program runs");
    assert!(
        out.status.success(),
        "two-controllers failed: {}",
        out.status
    );
    let text = String::from_utf8(out.stdout).expect("ASCII output");

    let mut p = paper::Controller::new([0.0; paper::NX]);
    let pu = p.step(&[0.25, -0.5, 1.0], &[[0.0; paper::NX]; paper::N]);
    let mut x = [0.0; quadcopter::NX];
    x[0] = 0.1;
    x[1] = -0.1;
    let mut q = quadcopter::Controller::new();
    let qu = q.step(&x, &[[0.0; quadcopter::NX]; quadcopter::N]);
    let mut expected = format!("paper {}", p.status().command as i32);
    for v in pu {
        let _ = write!(expected, " {}", v.hex());
    }
    let _ = write!(expected, "\nquadcopter {}", q.status().command as i32);
    for v in qu {
        let _ = write!(expected, " {}", v.hex());
    }
    expected.push('\n');
    assert_eq!(text, expected);
}

/// The public fields of the struct `name` in the emitted `module`, read with `syn`.
fn rust_fields(module: &str, name: &str) -> Vec<String> {
    let file = syn::parse_file(module).expect("the module parses");
    let Some(syn::Item::Mod(m)) = file.items.first() else {
        panic!("the emitted file holds no module");
    };
    let items = &m.content.as_ref().expect("a module body").1;
    let Some(syn::Item::Struct(s)) = items
        .iter()
        .find(|i| matches!(i, syn::Item::Struct(s) if s.ident == name))
    else {
        panic!("module {} has no struct {name}", m.ident);
    };
    s.fields
        .iter()
        .filter(|f| matches!(f.vis, syn::Visibility::Public(_)))
        .map(|f| f.ident.as_ref().expect("named fields").to_string())
        .collect()
}

/// The body of `typedef struct TAG { ... }` in `header`.
fn c_struct<'a>(header: &'a str, tag: &str) -> &'a str {
    let open = format!("typedef struct {tag} {{");
    let start = header
        .find(&open)
        .unwrap_or_else(|| panic!("the header has no `{open}`"))
        + open.len();
    let end = start + header[start..].find("\n}").expect("the struct closes");
    &header[start..end]
}

#[test]
fn header_has_every_status_field() {
    for (spec, module, structs) in [
        (
            "specs/quadcopter.toml",
            "quadcopter",
            &["Status", "SolverStatus"][..],
        ),
        ("specs/paper.toml", "paper", &["Status", "FilterStatus"][..]),
    ] {
        let built = build(spec, module);
        let header = std::fs::read_to_string(built.dir.join(format!("{module}.h")))
            .expect("the header exists");
        for name in structs {
            let fields = rust_fields(&built.module, name);
            assert!(!fields.is_empty(), "{spec}: {name} has no public field");
            let tag = format!("{module}_{}", snake(name));
            let body = c_struct(&header, &tag);
            for f in &fields {
                let declared = body
                    .lines()
                    .map(str::trim)
                    .filter(|l| !l.starts_with("/*") && !l.starts_with('*'))
                    .any(|l| l.ends_with(&format!(" {f};")) || l.contains(&format!(" {f}[")));
                assert!(
                    declared,
                    "{module}.h: `{tag}` has no field `{f}` of the Rust {name}"
                );
            }
        }
    }
}

fn snake(name: &str) -> String {
    let mut out = String::new();
    for (i, c) in name.chars().enumerate() {
        if c.is_ascii_uppercase() && i > 0 {
            out.push('_');
        }
        out.push(c.to_ascii_lowercase());
    }
    out
}
