//! `mpcc` as a user runs it: pinned `--help` texts, `check` in both forms, the exit code and rendered error
//! of a bad spec, and `emit -o` writing only when the content changed.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// Runs `mpcc args` from the workspace root.
fn mpcc(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mpcc"))
        .args(args)
        .current_dir(workspace())
        .output()
        .expect("mpcc runs")
}

fn stdout(o: &Output) -> String {
    String::from_utf8(o.stdout.clone()).unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8(o.stderr.clone()).unwrap()
}

#[test]
fn help() {
    let o = mpcc(&["--help"]);
    assert!(o.status.success());
    assert_eq!(
        stdout(&o),
        "\
mpcc 0.1.0
The `mpc!` compiler on the command line: certificates of a controller spec, and its emitted module

Usage: mpcc <COMMAND>

Commands:
  check    Check a spec and print what the compiler proves about it: conditioning, rates, iteration bound, closed-loop stability, resources
  emit     Print the module `mpc!` generates from a spec, formatted as a person would read it
  dump-qp  Write the condensed QP of a spec and a closed loop's states as JSON, for other solvers (format `mpcc-qp/1`, peers/README.md)
  help     Print this message or the help of the given subcommand(s)

Options:
  -h, --help     Print help
  -V, --version  Print version
"
    );
}

#[test]
fn check_help() {
    let o = mpcc(&["check", "--help"]);
    assert!(o.status.success());
    assert_eq!(
        stdout(&o),
        "\
Check a spec and print what the compiler proves about it: conditioning, rates, iteration bound, closed-loop stability, resources

Usage: mpcc check [OPTIONS] <SPEC>

Arguments:
  <SPEC>  The TOML controller spec: a regular file of at most 1 MiB, or `-` for standard input

Options:
      --json             Print the certificate as JSON, under stable names
      --plot <FILE>      Draw the dual active-set method's cold iteration count over two parameters of `[mpc.region]` into FILE (SVG), every other parameter at the region's centre
      --plot-axes <A,B>  The two parameters of `--plot`, by name (`x0[0]`, `r[1]`, `u_prev[0]`, `d[0]`) or index into θ; default the first two states
  -h, --help             Print help
"
    );
}

#[test]
fn emit_help() {
    let o = mpcc(&["emit", "--help"]);
    assert!(o.status.success());
    assert_eq!(
        stdout(&o),
        "\
Print the module `mpc!` generates from a spec, formatted as a person would read it

Usage: mpcc emit [OPTIONS] <SPEC>

Arguments:
  <SPEC>  The TOML controller spec: a regular file of at most 1 MiB, or `-` for standard input; the module is named after its file stem (`controller` for `-`)

Options:
  -o, --output <FILE>    Write the module to FILE instead of printing it: a regular file only if its content changed, never the SPEC itself
      --c <DIR>          Write a crate that builds the controller as a C static library, and its header NAME.h, into DIR instead of printing the module (docs/c-api.md)
      --target <TRIPLE>  The rustc target triple of the C static library; by default the spec's `[codegen] target` (cortex-m4f: thumbv7em-none-eabihf, cortex-a9: armv7a-none-eabihf, host: the host)
  -h, --help             Print help
"
    );
}

#[test]
fn check_prints_the_papers_numbers() {
    let o = mpcc(&["check", "specs/paper.toml"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(
        out.starts_with("specs/paper.toml: fgm, horizon 15, 30 iterations"),
        "{out}"
    );
    for line in [
        "ρ(F − G·K_LQR)",
        "0.939055 (stable)",
        "4.61064",
        "142.441",
        "multiply-adds per control cycle",
    ] {
        assert!(out.contains(line), "`{line}` missing from\n{out}");
    }
    assert_eq!(stderr(&o), "");
}

#[test]
fn check_json_has_the_stable_names() {
    let o = mpcc(&["check", "specs/paper.toml", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("valid JSON");
    for name in [
        "lipschitz",
        "strong_convexity",
        "condition_number",
        "step",
        "momentum",
        "contraction",
        "iterations",
        "iterations_bound",
        "lqr.spectral_radius",
        "lqr.lyapunov_min",
        "lqr.lyapunov_max",
        "mpc.spectral_radius",
        "mpc.solver_spectral_radius",
        "macs_per_cycle",
        "bytes_constants",
        "bytes_state",
    ] {
        let value = name.split('.').fold(&v, |v, key| &v[key]);
        assert!(value.is_number(), "`{name}` is {value:?} in\n{v:#}");
    }
    let round = |name: &str, digits: i32| {
        let value = name.split('.').fold(&v, |v, key| &v[key]).as_f64().unwrap();
        (value * 10f64.powi(digits)).round() / 10f64.powi(digits)
    };
    assert_eq!(round("lqr.spectral_radius", 3), 0.939);
    assert_eq!(round("lqr.lyapunov_min", 2), 4.61);
    assert_eq!(round("lqr.lyapunov_max", 2), 142.44);
    assert_eq!(v["iterations"], 30);
    assert_eq!(v["warnings"], serde_json::json!([]));
    // No back-off, no key.
    assert!(v.get("backoff").is_none());
}

#[test]
fn check_prints_the_backoffs() {
    let o = mpcc(&["check", "specs/pendulum.toml"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with("x_min/x_max[2]"))
        .unwrap_or_else(|| panic!("no back-off line in\n{text}"));
    assert!(line.contains("= 3σ, σ = "), "{line}");
    let o = mpcc(&["check", "specs/pendulum.toml", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("valid JSON");
    let b = &v["backoff"][0];
    assert_eq!(b["row"], "x_min/x_max[2]");
    assert_eq!(b["z"], 3.0);
    let (margin, sigma) = (b["margin"].as_f64().unwrap(), b["sigma"].as_f64().unwrap());
    assert!(sigma > 0.0 && (margin - 3.0 * sigma).abs() <= 1e-15, "{b}");
}

#[test]
fn check_names_the_move_blocks() {
    let spec = "tests/specs/control-horizon/blocks-fgm.toml";
    let o = mpcc(&["check", spec]);
    assert!(o.status.success(), "{}", stderr(&o));
    let first = stdout(&o).lines().next().unwrap_or_default().to_string();
    assert!(first.contains(", move blocking [2, 3, 5],"), "{first}");
    let o = mpcc(&["check", "specs/pendulum.toml"]);
    let first = stdout(&o).lines().next().unwrap_or_default().to_string();
    assert!(first.contains(", control horizon 5,"), "{first}");
    let json = |spec: &str| -> serde_json::Value {
        let o = mpcc(&["check", spec, "--json"]);
        serde_json::from_slice(&o.stdout).expect("valid JSON")
    };
    assert_eq!(json(spec)["move_blocks"], serde_json::json!([2, 3, 5]));
    assert_eq!(
        json("specs/pendulum.toml")["move_blocks"],
        serde_json::json!([1, 1, 1, 1, 6])
    );
    assert!(json("specs/paper.toml").get("move_blocks").is_none());
}

/// `check --plot`: the active set's cold count over two parameters as SVG; every cell within the build's
/// cold cap (an independent check of it on the slice); the wrong method or axes are errors.
#[test]
fn check_plots_the_cold_count() {
    let dir = scratch("plot");
    let file = dir.join("pendulum.svg");
    let shown = file.to_str().unwrap();
    let pendulum_over = |axes: &str| {
        mpcc(&[
            "check",
            "specs/pendulum.toml",
            "--plot",
            shown,
            "--plot-axes",
            axes,
        ])
    };
    let o = pendulum_over("x0[0],2");
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let line = err
        .lines()
        .find(|l| l.starts_with("mpcc: drew "))
        .unwrap_or_else(|| panic!("no summary in\n{err}"));
    assert!(line.contains("over x0[0] × x0[2]"), "{line}");
    assert!(!line.contains("ABOVE"), "{line}");
    // "…: LO-HI changes of the working set, the cold cap CAP"
    let numbers = |s: &str| -> Vec<usize> {
        s.split(|c: char| !c.is_ascii_digit())
            .filter_map(|w| w.parse().ok())
            .collect()
    };
    let range = numbers(line.split("): ").nth(1).unwrap());
    let (hi, cap) = (range[1], range[2]);
    assert!(hi >= 1 && hi <= cap, "{line}");
    let svg = std::fs::read_to_string(&file).unwrap();
    assert!(
        svg.starts_with("<svg") && svg.contains("x0[2]"),
        "not the picture"
    );
    let o = mpcc(&["check", "specs/paper.toml", "--plot", shown]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("this spec is solved by `fgm`"),
        "{}",
        stderr(&o)
    );
    let o = pendulum_over("x0[0],x0[0]");
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("two different parameters"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn check_a_bad_spec_renders_the_macros_error_and_exits_1() {
    let dir = scratch("bad-spec");
    let spec = dir.join("typo.toml");
    let paper = std::fs::read_to_string(workspace().join("specs/paper.toml")).unwrap();
    std::fs::write(&spec, paper.replace("horizon = 15", "horizion = 15")).unwrap();
    let shown = spec.to_str().unwrap();
    let o = mpcc(&["check", shown]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(stdout(&o), "");
    let err = stderr(&o);
    let source = std::fs::read_to_string(&spec).unwrap();
    let diags = mpc_spec::load(&source).unwrap_err();
    let rendered = codegen::render::render(&diags, &source, shown);
    assert_eq!(
        err,
        format!(
            "{rendered}\n\nmpcc: invalid controller spec `{shown}`: {} error{}\n",
            diags.0.len(),
            if diags.0.len() == 1 { "" } else { "s" }
        )
    );
    assert!(err.contains("unknown key `horizion`"), "{err}");
    assert!(err.contains(&format!("--> {shown}:")), "{err}");
}

#[test]
fn a_missing_file_is_an_error_with_its_cause() {
    let o = mpcc(&["check", "specs/no-such-spec.toml"]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(
        stderr(&o),
        "mpcc: cannot read the spec `specs/no-such-spec.toml`\n\nCaused by:\n    No such file or directory (os error 2)\n"
    );
}

#[test]
fn emit_names_the_module_after_the_file_and_writes_only_changes() {
    let printed = mpcc(&["emit", "specs/paper-faithful.toml"]);
    assert!(printed.status.success(), "{}", stderr(&printed));
    let text = stdout(&printed);
    assert!(text.starts_with("// @generated by mpcc"), "{text}");
    assert!(text.contains("pub mod paper_faithful {"));
    assert!(text.contains("from `specs/paper-faithful.toml`"));
    assert!(
        !text.contains(&*workspace().to_string_lossy()),
        "no absolute path"
    );
    syn::parse_file(&text).expect("`mpcc emit` prints a valid Rust file");

    let out = scratch("emit").join("paper_faithful.rs");
    let _ = std::fs::remove_file(&out);
    let write = || {
        let o = mpcc(&[
            "emit",
            "specs/paper-faithful.toml",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(stdout(&o), "");
        std::fs::metadata(&out).unwrap().modified().unwrap()
    };
    let first = write();
    assert_eq!(std::fs::read_to_string(&out).unwrap(), text);
    std::thread::sleep(std::time::Duration::from_millis(20));
    assert_eq!(write(), first, "an unchanged file is not rewritten");
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn check_names_admm_s_rho_and_form() {
    let spec = "tests/specs/linear-admm-residual-f32.toml";
    let o = mpcc(&["check", spec, "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["sampled"]["admm_form"], "residual");
    assert!(v["sampled"]["rho"].as_f64().unwrap() > 0.0);
    let text = stdout(&mpcc(&["check", spec]));
    assert!(
        text.contains("ADMM's ρ (tuned on the sample), residual form"),
        "{text}"
    );
    // Another method has neither.
    let o = mpcc(&["check", "specs/paper.toml", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["sampled"].is_null() || v["sampled"]["admm_form"].is_null());
}

/// `mpcc check` prints the sections of the chosen method only: the gradient's emission for a first-order
/// method, the normal system for the interior-point method, the x-update for ADMM.
#[test]
fn check_prints_only_the_chosen_method_s_sections() {
    let sections = [
        "emission of the gradient",
        "normal system of the interior-point method",
        "x-update of ADMM",
    ];
    for (spec, own) in [
        ("specs/paper.toml", 0),
        ("tests/specs/linear-riccati.toml", 1),
        ("tests/specs/linear-admm-f64.toml", 2),
    ] {
        let o = mpcc(&["check", spec]);
        assert!(o.status.success(), "{}", stderr(&o));
        let text = stdout(&o);
        for (i, title) in sections.iter().enumerate() {
            assert_eq!(text.contains(title), i == own, "{spec}: {title}\n{text}");
        }
    }
}

#[test]
fn check_reports_the_disturbance_time_constant_of_an_offset_free_spec() {
    let o = mpcc(&["check", "specs/paper-offset-free.toml", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let tau = v["disturbance_time_constant"].as_f64().unwrap();
    assert!((tau - 1.42).abs() < 0.005, "{tau}");
    let o = mpcc(&["check", "specs/paper.toml", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["disturbance_time_constant"].is_null());
    let text = stdout(&mpcc(&["check", "specs/paper-offset-free.toml"]));
    assert!(text.contains("time constant, s"), "{text}");
}

#[test]
fn a_closed_pipe_ends_the_output_quietly() {
    use std::io::Read;
    let mut child = Command::new(env!("CARGO_BIN_EXE_mpcc"))
        .args(["emit", "specs/paper.toml"])
        .current_dir(workspace())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = [0u8; 64];
    child.stdout.take().unwrap().read_exact(&mut first).unwrap();
    // The read end is dropped here: the rest of the module goes to a closed pipe.
    let status = child.wait().unwrap();
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert!(status.success(), "{status}: {err}");
    assert_eq!(err, "");
}

#[test]
fn check_prints_warnings_and_succeeds() {
    let spec = scratch("warning").join("few-iterations.toml");
    let paper = std::fs::read_to_string(workspace().join("specs/paper.toml")).unwrap();
    std::fs::write(
        &spec,
        paper.replace("iterations = 30", "iterations = 5\ntolerance = 1e-6"),
    )
    .unwrap();
    let o = mpcc(&["check", spec.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.starts_with("warning: `iterations = 5` is below the"),
        "{err}"
    );
    assert!(
        stdout(&o).ends_with("1 warning (above)\n"),
        "{}",
        stdout(&o)
    );
    let o = mpcc(&["check", spec.to_str().unwrap(), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["warnings"].as_array().unwrap().len(), 1);
}

/// The three outputs of the certificate name the same numbers: every entry of `Certificate::fields` is
/// in the JSON under its key with its value, and on a line of `mpcc check` under its label (the `report`
/// module's constants are emitted from the same list; `tests/tests/report.rs` compares them).
#[test]
fn json_text_and_report_come_from_one_list_of_fields() {
    use codegen::certificate::Value;
    for spec in [
        "specs/paper.toml",
        "specs/paper-offset-free.toml",
        "specs/paper-initial.toml",
    ] {
        let source = std::fs::read_to_string(workspace().join(spec)).unwrap();
        let generated = codegen::generate_from_source(&source, &codegen::Opt::default()).unwrap();
        let json = mpcc(&["check", spec, "--json"]);
        let v: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
        let text = String::from_utf8(mpcc(&["check", spec]).stdout).unwrap();
        for field in generated.certificate.fields() {
            let at = field.json.split('.').fold(&v, |v, key| &v[key]);
            let expected = match field.value {
                Value::Real(x) | Value::MaybeReal(Some(x)) => serde_json::json!(x),
                Value::Count(n) | Value::MaybeCount(Some(n)) => serde_json::json!(n),
                Value::MaybeReal(None) | Value::MaybeCount(None) => serde_json::Value::Null,
            };
            assert_eq!(
                at, &expected,
                "{spec}: `{}` ({})",
                field.json, field.constant
            );
            let present = !matches!(
                field.value,
                Value::MaybeReal(None) | Value::MaybeCount(None)
            );
            if present || field.shown != codegen::certificate::Shown::IfPresent {
                assert!(
                    text.lines()
                        .any(|l| l.trim_start().starts_with(&field.label)),
                    "{spec}: no line `{}` in\n{text}",
                    field.label
                );
            }
        }
    }
}

// What `mpcc` reads and writes besides a plain spec and a plain output file: the spec as its own output,
// FIFOs, devices, standard input, and the size limit on a spec. Every run is watched, so that a
// regression to hanging fails the test instead of hanging CI.

use std::process::Stdio;
use std::time::{Duration, Instant};

/// How long a watched `mpcc` may run before it counts as hung (a run takes well under a second).
const WATCHDOG: Duration = Duration::from_secs(20);

/// The limit on a spec's size that `mpcc` states in `--help` and in its error.
const SPEC_SIZE_LIMIT: usize = 1 << 20;

/// Runs `mpcc args` from the workspace root with `stdin`, as `mpcc` does, but under a watchdog: after
/// `WATCHDOG` the process is killed and the test fails. Standard output and error are drained while it
/// runs, so that a full pipe cannot stall it.
fn mpcc_watched(args: &[&str], stdin: Stdio) -> Output {
    fn drain(mut pipe: impl std::io::Read + Send + 'static) -> std::thread::JoinHandle<Vec<u8>> {
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            pipe.read_to_end(&mut bytes).unwrap();
            bytes
        })
    }
    let mut child = Command::new(env!("CARGO_BIN_EXE_mpcc"))
        .args(args)
        .current_dir(workspace())
        .stdin(stdin)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("mpcc runs");
    let out = drain(child.stdout.take().unwrap());
    let err = drain(child.stderr.take().unwrap());
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > WATCHDOG {
            let _ = child.kill();
            let _ = child.wait();
            panic!("`mpcc {}` still ran after {WATCHDOG:?}", args.join(" "));
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    Output {
        status,
        stdout: out.join().unwrap(),
        stderr: err.join().unwrap(),
    }
}

/// Standard input from the file at `path`.
fn stdin_from(path: impl AsRef<Path>) -> Stdio {
    std::fs::File::open(path).unwrap().into()
}

/// Makes a FIFO at `path`, replacing what is there.
#[cfg(unix)]
fn mkfifo(path: &Path) {
    let _ = std::fs::remove_file(path);
    let status = Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo runs");
    assert!(status.success(), "mkfifo {}: {status}", path.display());
}

#[test]
fn emit_refuses_to_write_over_its_spec() {
    let dir = scratch("same-file");
    let spec = dir.join("paper.toml");
    let paper = std::fs::read(workspace().join("specs/paper.toml")).unwrap();
    std::fs::write(&spec, &paper).unwrap();
    let hard_link = dir.join("hard-link.toml");
    let _ = std::fs::remove_file(&hard_link);
    std::fs::hard_link(&spec, &hard_link).unwrap();
    let mut outputs = vec![spec.clone(), dir.join(".").join("paper.toml"), hard_link];
    #[cfg(unix)]
    {
        let symlink = dir.join("symlink.toml");
        let _ = std::fs::remove_file(&symlink);
        std::os::unix::fs::symlink(&spec, &symlink).unwrap();
        outputs.push(symlink);
    }
    let shown = spec.to_str().unwrap();
    for output in &outputs {
        let output = output.to_str().unwrap();
        let o = mpcc_watched(&["emit", shown, "-o", output], Stdio::null());
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert_eq!(stdout(&o), "");
        assert_eq!(
            stderr(&o),
            format!(
                "mpcc: refusing to write `{output}`: it is the same file as the spec `{shown}`\n"
            )
        );
        assert!(
            std::fs::read(&spec).unwrap() == paper,
            "`-o {output}` changed the spec"
        );
    }
}

#[cfg(unix)]
#[test]
fn a_fifo_as_the_spec_is_refused_without_opening_it() {
    let fifo = scratch("fifo-spec").join("pipe.toml");
    mkfifo(&fifo);
    let shown = fifo.to_str().unwrap();
    for command in ["check", "emit"] {
        let o = mpcc_watched(&[command, shown], Stdio::null());
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert_eq!(stdout(&o), "");
        assert_eq!(
            stderr(&o),
            format!(
                "mpcc: cannot read the spec `{shown}`\n\nCaused by:\n    it is a FIFO, not a regular file\n"
            )
        );
    }
}

/// `/dev/zero` never ends: as SPEC it is refused as a device, before it is read; as standard input it is
/// read up to the size limit and refused there.
#[cfg(unix)]
#[test]
fn dev_zero_is_refused_as_the_spec_and_on_standard_input() {
    let o = mpcc_watched(&["check", "/dev/zero"], Stdio::null());
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(
        stderr(&o),
        "mpcc: cannot read the spec `/dev/zero`\n\nCaused by:\n    it is a character device, not a regular file\n"
    );
    let o = mpcc_watched(&["check", "-"], stdin_from("/dev/zero"));
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(stdout(&o), "");
    assert_eq!(
        stderr(&o),
        "mpcc: cannot read the spec from standard input\n\nCaused by:\n    it is larger than the limit of 1 MiB (1048576 bytes)\n"
    );
}

#[test]
fn a_spec_over_the_size_limit_is_refused() {
    let dir = scratch("size-limit");
    // The paper's spec and a comment, to exactly the limit: accepted.
    let mut padded = std::fs::read(workspace().join("specs/paper.toml")).unwrap();
    padded.extend_from_slice(b"\n# ");
    padded.resize(SPEC_SIZE_LIMIT - 1, b'x');
    padded.push(b'\n');
    assert_eq!(padded.len(), SPEC_SIZE_LIMIT);
    let at = dir.join("at-the-limit.toml");
    std::fs::write(&at, &padded).unwrap();
    let at = at.to_str().unwrap();
    let o = mpcc_watched(&["check", at], Stdio::null());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).starts_with(&format!("{at}: fgm")),
        "{}",
        stdout(&o)
    );

    // One byte more: refused, from a file and from standard input.
    padded.push(b'\n');
    let over = dir.join("over-the-limit.toml");
    std::fs::write(&over, &padded).unwrap();
    let shown = over.to_str().unwrap();
    let o = mpcc_watched(&["check", shown], Stdio::null());
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(stdout(&o), "");
    assert_eq!(
        stderr(&o),
        format!(
            "mpcc: cannot read the spec `{shown}`\n\nCaused by:\n    it is larger than the limit of 1 MiB (1048576 bytes)\n"
        )
    );
    let o = mpcc_watched(&["emit", "-"], stdin_from(&over));
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(
        stderr(&o),
        "mpcc: cannot read the spec from standard input\n\nCaused by:\n    it is larger than the limit of 1 MiB (1048576 bytes)\n"
    );
}

#[test]
fn a_directory_or_a_spec_that_is_not_utf8_is_refused() {
    let dir = scratch("not-a-spec");
    let shown = dir.to_str().unwrap();
    let o = mpcc_watched(&["check", shown], Stdio::null());
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(
        stderr(&o),
        format!(
            "mpcc: cannot read the spec `{shown}`\n\nCaused by:\n    it is a directory, not a regular file\n"
        )
    );
    let latin1 = dir.join("latin1.toml");
    std::fs::write(&latin1, b"name = \"caf\xe9\"\n").unwrap();
    let shown = latin1.to_str().unwrap();
    let o = mpcc_watched(&["check", shown], Stdio::null());
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(
        stderr(&o),
        format!(
            "mpcc: cannot read the spec `{shown}`\n\nCaused by:\n    it is not UTF-8 text: invalid utf-8 sequence of 1 bytes from index 11\n"
        )
    );
}

#[test]
fn a_dash_reads_the_spec_from_standard_input() {
    let paper = workspace().join("specs/paper.toml");
    let o = mpcc_watched(&["check", "-"], stdin_from(&paper));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).starts_with("<stdin>: fgm, horizon 15, 30 iterations"),
        "{}",
        stdout(&o)
    );
    let o = mpcc_watched(&["emit", "-"], stdin_from(&paper));
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("pub mod controller {"), "{text}");
    assert!(text.contains("from `<stdin>`"), "{text}");
    syn::parse_file(&text).expect("a valid Rust file");
    // Diagnostics name standard input as `<stdin>`.
    let typo = scratch("stdin").join("typo.toml");
    let source = std::fs::read_to_string(&paper).unwrap();
    std::fs::write(&typo, source.replace("horizon = 15", "horizion = 15")).unwrap();
    let o = mpcc_watched(&["check", "-"], stdin_from(&typo));
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("--> <stdin>:"), "{err}");
    assert!(
        err.ends_with("mpcc: invalid controller spec `<stdin>`: 1 error\n"),
        "{err}"
    );
}

#[cfg(unix)]
#[test]
fn emit_to_dev_stdout_prints_the_module() {
    let printed = mpcc(&["emit", "specs/paper.toml"]);
    assert!(printed.status.success(), "{}", stderr(&printed));
    let o = mpcc_watched(
        &["emit", "specs/paper.toml", "-o", "/dev/stdout"],
        Stdio::null(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stderr(&o), "");
    assert!(o.stdout == printed.stdout, "{}", stdout(&o));
}

#[cfg(unix)]
#[test]
fn emit_writes_through_a_fifo() {
    let fifo = scratch("fifo-output").join("module.rs");
    mkfifo(&fifo);
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(fifo).unwrap())
    };
    let o = mpcc_watched(
        &["emit", "specs/paper.toml", "-o", fifo.to_str().unwrap()],
        Stdio::null(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), "");
    let printed = mpcc(&["emit", "specs/paper.toml"]);
    assert!(reader.join().unwrap() == printed.stdout);
}

#[cfg(target_os = "linux")]
#[test]
fn emit_to_dev_full_fails_with_no_space_left() {
    let o = mpcc_watched(
        &["emit", "specs/paper.toml", "-o", "/dev/full"],
        Stdio::null(),
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(stdout(&o), "");
    assert_eq!(
        stderr(&o),
        "mpcc: cannot write `/dev/full`\n\nCaused by:\n    No space left on device (os error 28)\n"
    );
}

/// `model.a`, `model.b`, `model.q`: the discrete matrices the controller was built from, the sampled ones
/// for a continuous-time spec, a double integrator's F, G and eq. 3's Q.
#[test]
fn check_json_reports_the_discrete_model() {
    let matrix = |v: &serde_json::Value| -> Vec<Vec<f64>> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|r| {
                r.as_array()
                    .unwrap()
                    .iter()
                    .map(|x| x.as_f64().unwrap())
                    .collect()
            })
            .collect()
    };
    let o = mpcc(&["check", "tests/specs/dc-motor-continuous.toml", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let m = &v["model"];
    assert_eq!(m["dt"].as_f64(), Some(0.05));
    let (a, b, q) = (matrix(&m["a"]), matrix(&m["b"]), matrix(&m["q"]));
    // ẋ = [[−10, 1], [−0.02, −2]] x + [0; 2] u over 0.05 s: the diagonal near e^{−0.5} and e^{−0.1}, the
    // input reaching ω through i within the period.
    assert!((a[0][0] - (-0.5f64).exp()).abs() < 1e-3, "{a:?}");
    assert!((a[1][1] - (-0.1f64).exp()).abs() < 1e-3, "{a:?}");
    assert!(
        b[0][0] > 0.0 && (b[1][0] - 2.0 * 0.05).abs() < 0.01,
        "{b:?}"
    );
    // Q_d ≈ Q_c·dt for a short period, below it for decaying modes.
    assert!(q[1][1] > 0.0 && q[1][1] < 0.1 * 0.05, "{q:?}");
    assert_eq!(q[0][1], q[1][0]);
    assert_eq!(matrix(&m["c"]), [[1.0, 0.0]]);

    let o = mpcc(&["check", "specs/paper.toml", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let (a, b) = (matrix(&v["model"]["a"]), matrix(&v["model"]["b"]));
    assert_eq!((a.len(), a[0].len(), b.len(), b[0].len()), (6, 6, 6, 3));
    assert_eq!(a[0][3], 0.0128);
    assert_eq!(b[3][0], 0.0128);
    assert_eq!(matrix(&v["model"]["q"]).len(), 6);
}

/// `emit --c DIR`: the crate's files, the header's exact size (the one the crate asserts), the target of a
/// cross build in `.cargo/config.toml`, removed again for the host; `--target` alone and an unwritable
/// DIR are errors that say what is wrong. Building and calling the library: `mpc-tests`' `c_api.rs`.
#[test]
fn emit_c_writes_the_crate_and_header() {
    let dir = workspace().join("target").join("mpcc-cli-c").join("paper");
    let _ = std::fs::remove_dir_all(&dir);
    let d = dir.to_str().unwrap();
    let o = mpcc(&[
        "emit",
        "specs/paper.toml",
        "--c",
        d,
        "--target",
        "thumbv7em-none-eabihf",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), dir.join("paper.h").to_str().unwrap());
    let header = std::fs::read_to_string(dir.join("paper.h")).unwrap();
    let lib = std::fs::read_to_string(dir.join("src/lib.rs")).unwrap();
    let size = header
        .lines()
        .find_map(|l| l.strip_prefix("#define PAPER_CONTROLLER_SIZE "))
        .expect("the header states the controller's size");
    assert!(size.parse::<usize>().unwrap() > 0);
    assert!(
        lib.contains(&format!("size_of::<Controller>() == {size}")),
        "lib.rs asserts another size than the header's {size}"
    );
    for name in [
        "paper_init",
        "paper_step",
        "paper_status",
        "paper_plan",
        "paper_reset",
    ] {
        assert!(
            header.contains(&format!(" {name}(")),
            "the header lacks {name}"
        );
        assert!(lib.contains(&format!("fn {name}(")), "lib.rs lacks {name}");
    }
    let cargo_toml = std::fs::read_to_string(dir.join("Cargo.toml")).unwrap();
    assert!(cargo_toml.contains("crate-type = [\"staticlib\"]"));
    let config = std::fs::read_to_string(dir.join(".cargo/config.toml")).unwrap();
    assert!(
        config.contains("target = \"thumbv7em-none-eabihf\""),
        "{config}"
    );
    assert!(dir.join("src/controller.rs").is_file());

    // paper.toml's target is the host: no config is left to cross-build.
    let o = mpcc(&["emit", "specs/paper.toml", "--c", d]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!dir.join(".cargo/config.toml").exists());

    let o = mpcc(&[
        "emit",
        "specs/paper.toml",
        "--target",
        "thumbv7em-none-eabihf",
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--c <DIR>"), "{}", stderr(&o));

    let file = dir.join("Cargo.toml");
    let o = mpcc(&["emit", "specs/paper.toml", "--c", file.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains(&format!("cannot write the C crate `{}`", file.display())),
        "{}",
        stderr(&o)
    );
}

#[test]
fn the_pendulum_fits_both_boards_with_the_active_set() {
    for (spec, scalar) in [
        ("tests/specs/pendulum/cortex-a9.toml", "f64"),
        ("tests/specs/pendulum/cortex-m4f.toml", "f32"),
    ] {
        let o = mpcc(&["check", spec, "--json"]);
        assert!(o.status.success(), "{spec}: {}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("valid JSON");
        assert_eq!(v["method"], "active_set", "{spec}");
        let step = &v["control_step"];
        let (cycles, period) = (
            step["cycles"].as_f64().unwrap(),
            step["period_cycles"].as_f64().unwrap(),
        );
        assert!(cycles < period, "{spec} ({scalar}): {step}");
    }
}

/// `dump-qp --witness` dumps one step at the sampled certificate's worst cold case: the state and the
/// constant reference that `check --json` names in `sampled.cold_witness`, with the step's exact
/// solution; a spec whose witness sets u₋₁ (the pendulum's move bounds) or without a sampled
/// certificate (the FGM's paper) is refused, naming why.
#[test]
fn dump_qp_witness_is_the_certificates_worst_cold_case() {
    let o = mpcc(&["check", "specs/quadcopter.toml", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let check: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let witness: Vec<(String, f64)> = check["sampled"]["cold_witness"]
        .as_array()
        .expect("the witness")
        .iter()
        .map(|p| (p[0].as_str().unwrap().to_owned(), p[1].as_f64().unwrap()))
        .collect();
    let o = mpcc(&["dump-qp", "specs/quadcopter.toml", "--witness"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let dump: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let steps = dump["steps"].as_array().unwrap();
    assert_eq!(steps.len(), 1);
    let nz = dump["nz"].as_u64().unwrap() as usize;
    let x0 = steps[0]["x0"].as_array().unwrap();
    let reference = dump["reference"].as_array().unwrap();
    assert_eq!(witness.len(), x0.len() + nz);
    for (name, v) in &witness {
        let (what, i) = name.trim_end_matches(']').split_once('[').unwrap();
        let i: usize = i.parse().unwrap();
        let dumped = match what {
            "x0" => &x0[i],
            "r" => &reference[i],
            _ => panic!("{name}"),
        };
        assert_eq!(dumped.as_f64().unwrap(), *v, "{name}");
    }
    assert!(!steps[0]["z_star"].as_array().unwrap().is_empty());

    let o = mpcc(&["dump-qp", "specs/pendulum.toml", "--witness"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("sets `u_prev[0]`"), "{}", stderr(&o));
    let o = mpcc(&["dump-qp", "specs/paper.toml", "--witness"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("no sampled certificate"),
        "{}",
        stderr(&o)
    );
    let o = mpcc(&["dump-qp", "specs/paper.toml", "--witness", "--steps", "3"]);
    assert!(!o.status.success(), "--witness conflicts with --steps");
}
