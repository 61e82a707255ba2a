//! `[codegen] target`: spelled like the other enums, `host` by default, and the one cross-key rule it
//! brings in the spec: a method that computes in f64 needs f64 in hardware.

use mpc_spec::*;

const PAPER: &str = include_str!("../../specs/paper.toml");
const LIMITS: &str = include_str!("../../specs/paper-limits.toml");

/// `spec` with `line` added to its `[codegen]` table (the last table of every shipped spec).
fn with_codegen(spec: &str, line: &str) -> String {
    assert!(spec.contains("\n[codegen]\n"), "no `[codegen]` table");
    spec.replacen("\n[codegen]\n", &format!("\n[codegen]\n{line}\n"), 1)
}

/// The 1-based line that starts with `start` (not a comment mentioning it).
fn line_of(src: &str, start: &str) -> usize {
    src.lines()
        .position(|l| l.starts_with(start))
        .expect("needle")
        + 1
}

#[test]
fn the_target_is_the_host_unless_written() {
    assert_eq!(load(PAPER).unwrap().codegen.target, Target::Host);
    for (written, target) in [
        ("host", Target::Host),
        ("cortex-a9", Target::CortexA9),
        ("cortex-m4f", Target::CortexM4f),
    ] {
        let src = with_codegen(PAPER, &format!("target = \"{written}\""));
        let spec = load(&src).unwrap();
        assert_eq!(spec.codegen.target, target);
        assert_eq!(target.name(), written);
        // Located, for the compiler's diagnostics.
        let span = spec.spans.get("codegen.target").unwrap();
        assert_eq!(&src[span], format!("\"{written}\""));
    }
    assert_eq!(Target::NAMES, keys::TARGETS);
    assert!(Target::CortexA9.has_f64() && Target::Host.has_f64());
    assert!(!Target::CortexM4f.has_f64());
}

#[test]
fn a_misspelled_target_gets_a_suggestion() {
    let src = with_codegen(PAPER, "target = \"cortex-m4\"");
    let diags = load(&src).unwrap_err();
    let d = diags.iter().next().unwrap();
    assert_eq!(
        d.message,
        "unknown value \"cortex-m4\" for `codegen.target`"
    );
    assert_eq!(
        d.note.as_deref(),
        Some(
            "hint: did you mean `cortex-m4f`? (expected one of `host`, `cortex-a9`, `cortex-m4f`)"
        )
    );
    assert_eq!(d.line_col(&src), Some((line_of(&src, "target = "), 10)));
    assert_eq!(diags.iter().count(), 1);

    // Far from every spelling: the list alone.
    let diags = load(&with_codegen(PAPER, "target = \"riscv\"")).unwrap_err();
    assert_eq!(
        diags.iter().next().unwrap().note.as_deref(),
        Some("hint: expected one of `host`, `cortex-a9`, `cortex-m4f`")
    );
    // Not a string.
    let diags = load(&with_codegen(PAPER, "target = 4")).unwrap_err();
    assert_eq!(
        diags.iter().next().unwrap().message,
        "`codegen.target` must be a string, found integer"
    );
    // The key itself misspelled.
    let diags = load(&with_codegen(PAPER, "taget = \"cortex-a9\"")).unwrap_err();
    let d = diags.iter().next().unwrap();
    assert_eq!(d.message, "unknown key `taget` in `[codegen]`");
    assert_eq!(d.note.as_deref(), Some("hint: did you mean `target`?"));
}

#[test]
fn the_interior_point_method_needs_f64_in_hardware() {
    let src = with_codegen(LIMITS, "target = \"cortex-m4f\"");
    let diags = load(&src).unwrap_err();
    let d = diags.iter().next().unwrap();
    assert_eq!(
        d.message,
        "`method = \"ipm\"` computes in f64, which `target = \"cortex-m4f\"` has no hardware for"
    );
    // On `method`, with the target as the other place it involves.
    assert_eq!(
        d.line_col(&src),
        Some((line_of(&src, "method = \"ipm\""), 10))
    );
    assert_eq!(d.related.len(), 1);
    assert_eq!(&src[d.related[0].0.clone()], "\"cortex-m4f\"");
    let note = d.note.as_deref().unwrap();
    assert!(note.contains("`method = \"fgm\"`") && note.contains("`target = \"cortex-a9\"`"));
    assert_eq!(diags.iter().count(), 1);

    // The same spec on a target with f64 hardware, or with the f32 API: the method still runs in f64.
    for target in ["cortex-a9", "host"] {
        load(&with_codegen(LIMITS, &format!("target = \"{target}\""))).unwrap();
    }
    let f32_api = with_codegen(
        &LIMITS.replace("scalar = \"f64\"", "scalar = \"f32\""),
        "target = \"cortex-m4f\"",
    );
    assert!(load(&f32_api).is_err());
    // A first-order method on the M4F is fine, in either scalar (f64 is the compiler's warning).
    load(&with_codegen(PAPER, "target = \"cortex-m4f\"")).unwrap();
    load(&with_codegen(
        &PAPER.replacen("scalar = \"f32\"", "scalar = \"f64\"", 1),
        "target = \"cortex-m4f\"",
    ))
    .unwrap();
}

/// `clock_hz`: the target's clock, positive and finite, only with a target.
#[test]
fn the_clock_is_a_positive_number_with_a_target() {
    assert_eq!(load(PAPER).unwrap().codegen.clock_hz, None);
    let src = with_codegen(PAPER, "target = \"cortex-m4f\"\nclock_hz = 84e6");
    assert_eq!(load(&src).unwrap().codegen.clock_hz, Some(84e6));
    for (bad, message) in [
        ("0", "`codegen.clock_hz` must be positive, found 0"),
        (
            "-1e6",
            "`codegen.clock_hz` must be positive, found -1000000",
        ),
        ("inf", "`codegen.clock_hz` must be a finite number"),
        (
            "\"fast\"",
            "`codegen.clock_hz` must be a number, found string",
        ),
    ] {
        let src = with_codegen(PAPER, &format!("target = \"cortex-a9\"\nclock_hz = {bad}"));
        let diags = load(&src).unwrap_err();
        let d = diags.iter().next().unwrap();
        assert_eq!(d.message, message);
        assert_eq!(d.line_col(&src).unwrap().0, line_of(&src, "clock_hz = "));
    }
    let src = with_codegen(PAPER, "clock_hz = 1e9");
    let diags = load(&src).unwrap_err();
    let d = diags.iter().next().unwrap();
    assert!(
        d.message.starts_with("`clock_hz` needs a `target`"),
        "{}",
        d.message
    );
    assert_eq!(d.line_col(&src).unwrap().0, line_of(&src, "clock_hz = "));
    assert!(d
        .note
        .as_deref()
        .unwrap()
        .contains("target = \"cortex-m4f\""));
}
