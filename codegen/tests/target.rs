//! `[codegen] target` in the compiler (`codegen::target`): the estimate of one control step's cycles,
//! the refusal of a step that does not fit its sampling period at the target's clock, and the warning for
//! an f64 scalar without f64 hardware.

use codegen::target::{self, StepCost};
use codegen::{generate_from_source, Opt};
use mpc_spec::{Scalar, Target};
use std::path::Path;

const PAPER: &str = include_str!("../../specs/paper.toml");
const F64_N10: &str = include_str!("../../firmware-template/specs/paper-f64-n10.toml");

/// `spec` with `line` added to its `[codegen]` table.
fn with_codegen(spec: &str, line: &str) -> String {
    assert!(spec.contains("\n[codegen]\n"), "no `[codegen]` table");
    spec.replacen("\n[codegen]\n", &format!("\n[codegen]\n{line}\n"), 1)
}

/// `spec` with the line starting `key =` replaced by `key = value`.
fn with_line(spec: &str, key: &str, value: &str) -> String {
    let mut found = false;
    let out: Vec<String> = spec
        .lines()
        .map(|l| {
            if l.starts_with(&format!("{key} =")) && !found {
                found = true;
                format!("{key} = {value}")
            } else {
                l.to_string()
            }
        })
        .collect();
    assert!(found, "no `{key} =` line");
    out.join("\n") + "\n"
}

/// The line and text of `source` at the start of `span`.
fn line_at(source: &str, span: &std::ops::Range<usize>) -> String {
    source[..span.end].rsplit('\n').next().unwrap().to_string()
}

/// The paper's controller asked for 1000 iterations at N = 60 on the Cortex-M4F: 1.5e7 multiply-adds a
/// step, about 20 times what 12.8 ms at 168 MHz hold.
fn too_slow() -> String {
    let spec = with_line(PAPER, "horizon", "60");
    let spec = with_line(&spec, "iterations", "1000");
    with_codegen(&spec, "target = \"cortex-m4f\"")
}

#[test]
fn a_step_longer_than_its_period_is_refused_on_dt() {
    let src = too_slow();
    let diags = generate_from_source(&src, &Opt::default()).unwrap_err();
    assert_eq!(diags.iter().count(), 1);
    let d = diags.iter().next().unwrap();
    assert!(
        d.message.starts_with("a control step needs about ")
            && d.message
                .contains("on the STM32F405's Cortex-M4F at 168 MHz")
            && d.message.contains("of its 12.8 ms period"),
        "{}",
        d.message
    );
    assert_eq!(line_at(&src, d.span.as_ref().unwrap()), "dt = 0.0128");
    // It also points at the iterations and the target, with the numbers.
    let related: Vec<String> = d.related.iter().map(|(s, _)| line_at(&src, s)).collect();
    assert_eq!(related, ["iterations = 1000", "target = \"cortex-m4f\""]);
    assert!(
        d.related[0].1.starts_with("1000 iterations of "),
        "{:?}",
        d.related
    );
    // The same spec on the host (no fixed clock) and on the faster A9 builds.
    let host = src.replace("target = \"cortex-m4f\"", "target = \"host\"");
    let g = generate_from_source(&host, &Opt::default()).unwrap();
    assert_eq!(g.step.period_cycles, None);
    assert_eq!(g.step.load(), None);
}

#[test]
fn the_estimate_is_the_multiply_adds_at_the_targets_cycles() {
    let g = generate_from_source(
        &with_codegen(PAPER, "target = \"cortex-m4f\""),
        &Opt::default(),
    )
    .unwrap();
    let s = &g.step;
    let r = &g.certificate.resources;
    assert_eq!(s.machine, target::CORTEX_M4F);
    assert_eq!(
        (s.iterations, s.solver_scalar, s.scalar),
        (30, Scalar::F32, Scalar::F32)
    );
    assert_eq!(s.solver_macs, 30 * r.macs_per_iteration);
    assert_eq!(s.solver_macs + s.other_macs, r.macs_per_cycle);
    let per_mac = target::CORTEX_M4F.cycles_per_mac_f32;
    // (The two parts rounded apart.)
    let expected = r.macs_per_cycle as f64 * per_mac;
    assert!(
        (s.cycles - expected).abs() <= 1e-12 * expected,
        "{} against {expected}",
        s.cycles
    );
    assert_eq!(s.period_cycles, Some(168e6 * 0.0128));
    // The paper's controller takes a few per cent of the period there (BENCHMARKS.md: 88,300
    // instructions, which is where the figure comes from).
    let load = s.load().unwrap();
    assert!(load > 0.01 && load < 0.1, "{load}");
    assert_eq!(target::machine(Target::CortexA9).clock_hz, Some(667e6));
    assert_eq!(target::machine(Target::Host).clock_hz, None);
}

/// Every shipped spec builds on its own target, and on every other target that can run its method, with
/// its step inside the period.
#[test]
fn no_shipped_spec_is_refused() {
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let mut specs: Vec<_> = std::fs::read_dir(workspace.join("specs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    specs.push(workspace.join("firmware-template/specs/paper-f64-n10.toml"));
    assert!(specs.len() >= 8, "{specs:?}");
    for path in specs {
        let source = std::fs::read_to_string(&path).unwrap();
        let spec = mpc_spec::load(&source).unwrap();
        let g = generate_from_source(&source, &Opt::default())
            .unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
        // The target changes nothing the compiler lowers or plans: the same problem costed elsewhere.
        for t in Target::ALL {
            let m = target::machine(*t);
            if g.plan.algorithm().is_none() && !m.f64_in_hardware {
                continue;
            }
            let mut on = spec.clone();
            on.codegen.target = *t;
            let cost = StepCost::of(&on, &g.problem, &g.certificate.resources);
            // paper.toml and its variants in f64 on the M4F's soft float do not fit: only f32 there.
            if !m.f64_in_hardware && spec.codegen.scalar == Scalar::F64 {
                continue;
            }
            assert!(
                target::check_period(&on, &cost).is_ok(),
                "{} on {}: {:.3e} cycles against {:?}",
                path.display(),
                t.name(),
                cost.cycles,
                cost.period_cycles
            );
            if let Some(load) = cost.load() {
                eprintln!(
                    "{} on {}: {:.1} % of the period",
                    path.display(),
                    t.name(),
                    100.0 * load
                );
            }
        }
    }
}

#[test]
fn f64_without_f64_hardware_is_a_warning() {
    let src = with_codegen(F64_N10, "target = \"cortex-m4f\"");
    let g = generate_from_source(&src, &Opt::default()).unwrap();
    let w: Vec<_> = g
        .warnings
        .iter()
        .filter(|w| w.message.contains("software floating point"))
        .collect();
    assert_eq!(w.len(), 1, "{:?}", g.warnings);
    assert_eq!(
        line_at(&src, w[0].span.as_ref().unwrap()),
        "scalar = \"f64\""
    );
    assert!(w[0]
        .message
        .starts_with("`scalar = \"f64\"` on `target = \"cortex-m4f\"`"));
    // It fits the period (1.7e6 of 2.15e6 cycles: BENCHMARKS.md's 1,665,603 instructions).
    assert!(g.step.load().unwrap() < 1.0);
    // Not on a target with f64 hardware, nor in f32.
    for other in [
        with_codegen(F64_N10, "target = \"cortex-a9\""),
        F64_N10.to_string(),
        with_codegen(
            &F64_N10.replace("scalar = \"f64\"", "scalar = \"f32\""),
            "target = \"cortex-m4f\"",
        ),
    ] {
        let g = generate_from_source(&other, &Opt::default()).unwrap();
        assert!(g.warnings.is_empty(), "{:?}", g.warnings);
    }
}

/// `[codegen] clock_hz` replaces the target's default clock in the period check.
#[test]
fn the_clock_key_sets_the_period() {
    let src = with_codegen(PAPER, "target = \"cortex-m4f\"\nclock_hz = 84e6");
    let g = generate_from_source(&src, &Opt::default()).unwrap();
    assert_eq!(g.step.period_cycles, Some(84e6 * 0.0128));
    assert_eq!(g.step.machine.clock_hz, Some(84e6));
    // The step 20 times too long at 168 MHz fits at 10 GHz, and the refusal names the written clock.
    let fast = with_codegen(&too_slow(), "clock_hz = 10e9");
    assert!(generate_from_source(&fast, &Opt::default()).is_ok());
    let slow = with_codegen(&too_slow(), "clock_hz = 100e6");
    let diags = generate_from_source(&slow, &Opt::default()).unwrap_err();
    let d = diags.iter().next().unwrap();
    assert!(d.message.contains("at 100 MHz"), "{}", d.message);
}

/// The refusal of an f64 step on the Cortex-M4F names `scalar = "f32"` with the cycles the f32 build
/// has (checked by building it), and prints the cycles per multiply-add to three significant digits.
#[test]
fn the_period_refusal_prices_f32() {
    let src = with_codegen(F64_N10, "target = \"cortex-m4f\"");
    let src = with_line(&src, "iterations", "400");
    let diags = generate_from_source(&src, &Opt::default()).unwrap_err();
    let d = diags.iter().next().unwrap();
    let note = d.note.clone().unwrap();
    let f32 = with_line(&src, "scalar", "\"f32\"");
    let g = generate_from_source(&f32, &Opt::default()).unwrap();
    let cycles = target::significant(g.step.cycles, 3);
    let share = target::significant(100.0 * g.step.load().unwrap(), 3);
    assert!(
        note.starts_with(&format!(
            "hint: `scalar = \"f32\"` in `[codegen]` (about {cycles} cycles, {share} % of the period: fits); "
        )),
        "{note}"
    );
    assert!(
        d.related[1]
            .1
            .starts_with("about 163 cycles per multiply-add"),
        "{:?}",
        d.related
    );
    // An f32 spec has no such line.
    let diags = generate_from_source(&too_slow(), &Opt::default()).unwrap_err();
    let note = diags.iter().next().unwrap().note.clone().unwrap();
    assert!(!note.contains("scalar"), "{note}");
}

#[test]
fn figures_are_rounded_to_significant_digits() {
    assert_eq!(target::significant(232.857_142_857_142_86, 3), "233");
    assert_eq!(target::significant(2.8, 3), "2.8");
    assert_eq!(target::significant(3.0, 3), "3");
    assert_eq!(target::significant(0.012_345_6, 3), "0.0123");
    assert_eq!(target::significant(1_234_567.0, 3), "1.23e6");
    assert_eq!(target::significant(99_950.0, 3), "100000");
    assert_eq!(target::significant(12_345.0, 3), "12300");
}
