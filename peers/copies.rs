//! The specs the replay builds beside the shipped ones, shared by `build.rs` (which compiles them) and
//! `examples/copy.rs` (which prints them, for `scripts/witness.sh` to certify and dump).
#![allow(dead_code)] // each includer uses part of it

use std::path::Path;

/// The active set's copy of a shipped spec `text` (in f32 on the Cortex-M4F with `m4`): [`with_method`]
/// with `"active_set"`, and for `paper`, which has no `[mpc.region]` (the FGM's), paper-limits' region
/// (the same model and input box), read from `root/../specs/paper-limits.toml`.
pub fn active_set(root: &Path, text: &str, m4: bool) -> String {
    let mut written = with_method(text, "active_set", m4);
    if !text.contains("[mpc.region]") {
        let limits = std::fs::read_to_string(root.join("../specs/paper-limits.toml"))
            .expect("specs/paper-limits.toml");
        written.push_str("\n# peers/build.rs: specs/paper-limits.toml's region.\n");
        written.push_str(&table(&limits, "[mpc.region]"));
    }
    written
}

/// The spec with `method` in place of its own (or after `[mpc]` where it has none, `auto`): the
/// `method` line rewritten, `iterations` certified (`"auto"`), and the first-order methods' keys
/// (`step`, `tolerance`) dropped (the FGM's `paper`). With `m4` (the active set on the Cortex-M4F, which
/// has no f64 hardware) it is the variant of `codegen/tests/m4f.rs`: `scalar = "f32"` and `target =
/// "cortex-m4f"`, with `clock_hz = 1e9` so that the period check does not refuse what the replay
/// measures. Everything else (model, weights, bounds, rows,
/// region) is the spec's.
pub fn with_method(text: &str, method: &str, m4: bool) -> String {
    let mut out =
        format!("# peers/build.rs: the spec with method = \"{method}\" in place of its own.\n");
    let line = format!("method = \"{method}\"\n");
    let has_method = has_method(text);
    let mut in_mpc = false;
    for text_line in text.lines() {
        let t = text_line.trim_start();
        if t.starts_with('[') {
            in_mpc = t.starts_with("[mpc]");
        }
        let key = t.split('=').next().unwrap_or("").trim();
        if m4 && key == "scalar" && t.starts_with("scalar") {
            // The replay counts instructions, which the clock does not change; a clock above the
            // STM32F405's keeps the build's period check (paper-limits: its estimate is 161 % of 12.8 ms)
            // from refusing what is to be measured.
            out.push_str("target = \"cortex-m4f\"\nclock_hz = 1e9\nscalar = \"f32\"\n");
            continue;
        }
        if in_mpc && t.contains('=') && !t.starts_with('#') {
            match key {
                "method" => {
                    out.push_str(&line);
                    continue;
                }
                "iterations" => {
                    out.push_str("iterations = \"auto\"\n");
                    continue;
                }
                "step" | "tolerance" => continue,
                _ => {}
            }
        }
        out.push_str(text_line);
        out.push('\n');
        if t.starts_with("[mpc]") && !has_method {
            out.push_str(&line);
        }
    }
    out
}

/// Whether the spec writes a `method` line (else `auto` chooses).
pub fn has_method(text: &str) -> bool {
    text.lines()
        .any(|l| l.trim_start().starts_with("method") && l.contains('='))
}

/// The table `header` of a spec's text, to the next table.
fn table(text: &str, header: &str) -> String {
    let mut out = String::new();
    let mut inside = false;
    for line in text.lines() {
        if line.trim_start().starts_with('[') {
            inside = line.trim_start().starts_with(header);
        }
        if inside {
            out.push_str(line);
            out.push('\n');
        }
    }
    out
}
