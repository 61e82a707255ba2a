//! The emitted modules compiled as plain source, so that rustc and clippy see every line (clippy skips
//! most of a macro's output): the checked-in `generated-examples/generated/*.rs` and one module per
//! algorithm × gradient form that they do not cover (and ADMM in f32 and f64). A scratch crate holds them with `#![deny(dead_code)]`
//! and no allow of its own; `cargo clippy -- -D warnings` must pass on the host (the portable kernels) and
//! for `armv7a-none-eabihf` with `--cfg mpc_neon` (the Zynq's NEON kernels, nightly with `-Zbuild-std`, as
//! the firmware builds them).

use codegen::{generate_from_source, Opt, Origin};
use std::path::{Path, PathBuf};
use std::process::Command;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// A two-input linear plant whose inputs are weighted differently: no lane structure, nu = 2.
const LINEAR: &str = r#"
[model]
type = "linear"
dt = 0.1
a = [[1, 0.1, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.1], [0, 0, 0, 0.9]]
b = [[0.005, 0], [0.1, 0], [0, 0.005], [0, 0.1]]
c = [[1, 0, 0, 0], [0, 0, 1, 0]]
[mpc]
horizon = 8
iterations = 20
method = "fgm"
q = [10, 1, 5, 1]
r = [0.1, 0.3]
u_min = [-1, -2]
u_max = [1, 0.5]
[kalman]
q = [[0.01, 0, 0, 0], [0, 0.01, 0, 0], [0, 0, 0.01, 0], [0, 0, 0, 0.01]]
r = [[0.04, 0], [0, 0.04]]
filter = "time_varying"
[codegen]
scalar = "f32"
"#;

/// `spec` with its method, emission, filter and scalar replaced.
fn variant(spec: &str, method: &str, emission: &str, filter: &str, scalar: &str) -> String {
    spec.replace("method = \"fgm\"", &format!("method = \"{method}\""))
        .replace(
            "scalar = \"f32\"",
            &format!("scalar = \"{scalar}\"\nemission = \"{emission}\""),
        )
        .replace(
            "filter = \"time_varying\"",
            &format!("filter = \"{filter}\""),
        )
}

/// Module name and spec text of every variant the checked-in files leave out.
fn variants() -> Vec<(String, String)> {
    let read = |name: &str| std::fs::read_to_string(workspace().join("specs").join(name)).unwrap();
    let (paper, offset_free) = (read("paper.toml"), read("paper-offset-free.toml"));
    let mut out = Vec::new();
    let mut add = |name: &str, spec: &str, method, emission, filter, scalar| {
        let text = variant(spec, method, emission, filter, scalar);
        assert_ne!(&text, spec, "{name}: the spec's lines were not found");
        out.push((name.replace('-', "_"), text));
    };
    for emission in ["unrolled", "table", "matrix_free"] {
        add(
            &format!("paper_fgm_{emission}"),
            &paper,
            "fgm",
            emission,
            "time_varying",
            "f32",
        );
        add(
            &format!("offset_free_{emission}"),
            &offset_free,
            "fgm",
            emission,
            "time_varying",
            "f32",
        );
    }
    for emission in ["lanes", "matrix_free", "unrolled"] {
        add(
            &format!("paper_gradient_{emission}"),
            &paper,
            "gradient",
            emission,
            "time_varying",
            "f32",
        );
    }
    add(
        "paper_steady_state_f64",
        &paper,
        "fgm",
        "lanes",
        "steady_state",
        "f64",
    );
    for emission in ["unrolled", "table", "matrix_free"] {
        add(
            &format!("linear_fgm_{emission}"),
            LINEAR,
            "fgm",
            emission,
            "time_varying",
            "f32",
        );
        add(
            &format!("linear_gradient_{emission}"),
            LINEAR,
            "gradient",
            emission,
            "steady_state",
            "f64",
        );
    }
    // Output tracking, weighted moves and state feedback without a filter, in every emission.
    let tests =
        |name: &str| std::fs::read_to_string(workspace().join("tests/specs").join(name)).unwrap();
    for (base, file, scalar) in [
        ("state_feedback", "two-mass-outputs.toml", "f64"),
        ("outputs_moves_filtered", "two-mass-filtered.toml", "f32"),
    ] {
        let spec = tests(file);
        for emission in ["unrolled", "table", "matrix_free"] {
            let line = format!("scalar = \"{scalar}\"");
            let text = spec.replace(&line, &format!("{line}\nemission = \"{emission}\""));
            assert_ne!(text, spec, "{file}: no `{line}`");
            out.push((format!("{base}_{emission}"), text));
        }
    }
    // The interior-point method with an f32 API and filter (the method itself runs in f64), with move
    // bounds, a soft row group and an offset-free filter, which the checked-in constrained specs lack.
    let limits = read("paper-limits.toml").replace("scalar = \"f64\"", "scalar = \"f32\"");
    let rows = limits.replace(
        "x_soft = 1e5",
        "x_soft = 1e5\ndu_min = [-4, -4, -4]\ndu_max = [4, 4, 4]\n\n[[mpc.constraint]]\nax = [[1, 1, 0, 0, 0, 0]]\nupper = [30]\nsoft = 1e3",
    );
    assert_ne!(rows, limits, "paper-limits.toml: no `x_soft = 1e5`");
    let offset_free = rows.replace("[kalman]", "[kalman]\ndisturbance = [0.05, 0.05, 0.05]");
    assert_ne!(offset_free, rows, "paper-limits.toml: no `[kalman]`");
    out.push(("interior_f32_rows".to_string(), rows));
    out.push(("interior_f32_offset_free".to_string(), offset_free));
    // The interior-point method in the Riccati form of its normal system, with rows on (x_k, u_k) and
    // on x_{k+1} alone, in both scalars of the API (hover's checked-in module has state bounds only).
    let riccati = tests("linear-riccati.toml");
    let riccati_f32 = riccati.replace("scalar = \"f64\"", "scalar = \"f32\"");
    assert_ne!(
        riccati_f32, riccati,
        "linear-riccati.toml: no `scalar = \"f64\"`"
    );
    out.push(("riccati_f64_rows".to_string(), riccati));
    out.push(("riccati_f32_rows".to_string(), riccati_f32));
    out.push((
        "riccati_soft_rows".to_string(),
        tests("linear-riccati-soft.toml"),
    ));
    // ADMM in both scalars on a small plant with every kind of row, weighted moves and a disturbance
    // model (certified in seconds).
    for scalar in ["f32", "f64"] {
        out.push((
            format!("admm_{scalar}_rows"),
            tests(&format!("linear-admm-{scalar}.toml")),
        ));
    }
    // Its x-update in residual form (no σ in the right-hand side, P·x in the iteration).
    out.push((
        "admm_residual_rows".to_string(),
        tests("linear-admm-residual-f32.toml"),
    ));
    // The x-update stage by stage (OSQP's quadcopter: no move rows), in residual form.
    let quadcopter = tests("quadcopter-admm-f32.toml");
    let residual = quadcopter.replace(
        "method = \"admm\"\n",
        "method = \"admm\"\nadmm_form = \"residual\"\n",
    );
    assert_ne!(
        residual, quadcopter,
        "quadcopter-admm-f32.toml: no `method = \"admm\"`"
    );
    out.push(("admm_stages_residual".to_string(), residual));
    // The dual active-set method: every kind of row, weighted moves and a disturbance model (f64), and
    // the quadcopter in an f32 module (the method widens), blocks and a zero-free row set.
    out.push((
        "active_set_rows".to_string(),
        tests("active-set/linear.toml"),
    ));
    out.push((
        "active_set_f32".to_string(),
        tests("active-set/quadcopter-f32.toml"),
    ));
    out.push((
        "active_set_blocks".to_string(),
        tests("active-set/paper-limits.toml"),
    ));
    out
}

/// Variants emitted with every ADMM kernel as a loop over tables (`Opt::write_out_budget` 0), which no
/// shipped size reaches: the stage-wise x-update's statements in compressed rows, C·x and Cᵀ·v.
fn table_variants() -> Vec<(String, String)> {
    let text =
        std::fs::read_to_string(workspace().join("tests/specs/quadcopter-admm-f64.toml")).unwrap();
    vec![("admm_stages_tables".to_string(), text)]
}

/// Writes the scratch crate: the checked-in files by path, the variants emitted here.
fn scratch_crate() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("generated-lint");
    let src = dir.join("src");
    std::fs::create_dir_all(&src).unwrap();
    std::fs::write(
        dir.join("Cargo.toml"),
        "[package]\nname = \"generated-lint\"\nversion = \"0.0.0\"\nedition = \"2021\"\npublish = false\n\n\
         [lints.rust]\nunexpected_cfgs = { level = \"warn\", check-cfg = [\"cfg(mpc_neon)\"] }\n\n\
         [lib]\npath = \"src/lib.rs\"\n\n# Not a member of the project's workspace.\n[workspace]\n",
    )
    .unwrap();
    let mut lib = String::from(
        "#![no_std]\n#![cfg_attr(mpc_neon, feature(stdarch_arm_neon_intrinsics))]\n#![deny(dead_code)]\n\n",
    );
    let generated = workspace().join("generated-examples/generated");
    let mut files: Vec<_> = std::fs::read_dir(&generated)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "rs"))
        .collect();
    files.sort();
    assert!(files.len() >= 4, "the checked-in modules: {files:?}");
    for file in &files {
        let stem = file
            .file_stem()
            .unwrap()
            .to_str()
            .unwrap()
            .replace('-', "_");
        lib += &format!(
            "#[path = {:?}]\npub mod checked_in_{stem};\n",
            file.display().to_string()
        );
    }
    let budgets: Vec<(String, String, usize)> = variants()
        .into_iter()
        .map(|(name, spec)| (name, spec, codegen::emit::WRITE_OUT_BUDGET))
        .chain(
            table_variants()
                .into_iter()
                .map(|(name, spec)| (name, spec, 0)),
        )
        .collect();
    // Emitted on every core: each certificate is seconds of build-time sampling.
    let next = std::sync::atomic::AtomicUsize::new(0);
    let workers = std::thread::available_parallelism().map_or(1, |n| n.get());
    std::thread::scope(|s| {
        for _ in 0..workers {
            s.spawn(|| loop {
                let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some((name, spec, write_out_budget)) = budgets.get(k) else {
                    break;
                };
                let mut opt = Opt::new(name, "pub", Origin::Named(format!("{name}.toml")));
                opt.write_out_budget = *write_out_budget;
                let module = generate_from_source(spec, &opt)
                    .unwrap_or_else(|e| panic!("{name}: {e:?}"))
                    .pretty();
                // Rewritten only when changed, so that an unchanged module is not rebuilt.
                let file = src.join(format!("{name}_rs.rs"));
                if std::fs::read_to_string(&file).ok().as_deref() != Some(&module) {
                    std::fs::write(&file, module).unwrap();
                }
            });
        }
    });
    for (name, _, _) in &budgets {
        lib += &format!("pub mod {name}_rs;\n");
    }
    if std::fs::read_to_string(src.join("lib.rs")).ok().as_deref() != Some(&lib) {
        std::fs::write(src.join("lib.rs"), lib).unwrap();
    }
    dir
}

/// `cargo [+toolchain] clippy` on the scratch crate with every warning an error, in its own target
/// directory `target/<build>` (so that two can run at once).
fn clippy(dir: &Path, build: &str, toolchain: Option<&str>, target_args: &[&str], rustflags: &str) {
    let mut command = Command::new("cargo");
    // The outer `cargo test`'s settings must not leak into the inner build.
    for var in [
        "RUSTUP_TOOLCHAIN",
        "RUSTFLAGS",
        "CARGO_TARGET_DIR",
        "CARGO_BUILD_TARGET",
        "CARGO_ENCODED_RUSTFLAGS",
    ] {
        command.env_remove(var);
    }
    if let Some(toolchain) = toolchain {
        command.arg(format!("+{toolchain}"));
    }
    let o = command
        .args(["clippy", "--quiet", "--lib", "--target-dir"])
        .arg(dir.join("target").join(build))
        .args(target_args)
        .args(["--", "-D", "warnings", "-D", "dead_code"])
        .env("RUSTFLAGS", rustflags)
        .current_dir(dir)
        .output()
        .expect("cargo runs");
    assert!(
        o.status.success(),
        "cargo {} clippy {target_args:?} on {}:\n{}",
        toolchain.unwrap_or(""),
        dir.display(),
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn emitted_modules_have_no_dead_code_and_pass_clippy_on_the_host_and_the_a9() {
    let dir = scratch_crate();
    // Side by side: each is one crate's check, mostly on one core.
    std::thread::scope(|s| {
        s.spawn(|| clippy(&dir, "host", None, &[], ""));
        clippy(
            &dir,
            "a9",
            Some("nightly"),
            &["--target", "armv7a-none-eabihf", "-Zbuild-std=core"],
            "--cfg mpc_neon -C target-cpu=cortex-a9 -C target-feature=+neon,+vfp3",
        );
    });
}
