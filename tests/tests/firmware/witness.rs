//! The dual active set's bound held against the boards (issue 33, item 3): the sampled certificate's
//! heaviest cold case of hover (`firmware-template/specs/hover-m4f.toml`, the active set in f32 on the
//! Cortex-M4F; `specs/hover.toml` with `target = "cortex-a9"`, in f64 on the Cortex-A9) flown as the
//! linear mode's first and only cycle (`scripts/firmware.sh --linear --cycles 1 --start X0 --reference
//! R`), a cold solve from a fresh controller, counted in instructions (the M4F's TIM2 ticks once an
//! instruction, the A9's global timer once every ten). The build's estimate of a cold solve
//! (`Certificate::cold_solve_macs` at the target's cycles per multiply-add, with the rest of the step,
//! over its cycles per instruction) must be at or above it and within 1.5× of it.

use super::*;

const HOVER_M4F: &str = "firmware-template/specs/hover-m4f.toml";

/// A parameter vector of the witness as the comma-separated list `--start`/`--reference` take.
fn listed(witness: &[(String, f64)], prefix: &str) -> String {
    let values: Vec<String> = witness
        .iter()
        .filter(|(name, _)| name.starts_with(prefix))
        .map(|(_, v)| format!("{v:e}"))
        .collect();
    values.join(",")
}

/// Flies `spec` (a path under the repository, or absolute) on `board` from its heaviest cold case and
/// returns the instructions the cycle took and the build's bound on a cold solve, in instructions.
fn heaviest_cold_case(board: Board, spec: &Path, name: &str) -> (f64, f64) {
    let src = std::fs::read_to_string(root().join(spec)).expect("the spec");
    let g = codegen::generate_from_source(&src, &Default::default()).expect("it builds");
    assert_eq!(g.problem.qp.method, mpc_spec::Method::ActiveSet);
    let e = g
        .certificate
        .sampled
        .as_ref()
        .expect("a sampled certificate");
    assert!(
        e.cold_witness
            .iter()
            .all(|(name, _)| name.starts_with("x0[") || name.starts_with("r[")),
        "θ is (x0, r): {:?}",
        e.cold_witness
    );
    let (start, reference) = (
        listed(&e.cold_witness, "x0["),
        listed(&e.cold_witness, "r["),
    );
    let spec = spec.to_str().expect("a UTF-8 path");
    let elf = build_with(
        board,
        Some(spec),
        name,
        Some(1),
        &[
            "--linear",
            &format!("--start={start}"),
            &format!("--reference={reference}"),
        ],
    );
    let (status, uart) = emulate(board, &elf);
    assert_eq!(status, Some(0), "{uart}");
    assert!(
        uart.contains("cycles from FIRMWARE_START to FIRMWARE_REFERENCE"),
        "{uart}"
    );
    let r = result_line(&uart).unwrap_or_else(|| panic!("no RESULT line:\n{uart}"));
    assert_calibrated(&r, board);
    assert_eq!(uint(&r, "cycles"), 1);
    let measured = (uint(&r, "ticks_max") * board.instructions_per_tick) as f64;
    // The estimate of a cold solve, in instructions.
    let step = &g.step;
    let cold = g.certificate.cold_solve_macs.expect("a step of two solves") as f64
        * step.solver_cycles_per_mac
        + (step.cycles - step.solver_cycles);
    (measured, cold / step.machine.cycles_per_instruction)
}

fn assert_within(measured: f64, bound: f64, what: &str) {
    println!(
        "{what}, heaviest cold case: {measured} instructions, bound {bound:.0} ({:.2}×)",
        bound / measured
    );
    assert!(
        measured <= bound && bound <= 1.5 * measured,
        "{what}: measured {measured} instructions against the bound {bound:.0}"
    );
}

#[test]
fn the_heaviest_cold_case_on_the_m4f_takes_at_most_the_bound_and_at_least_two_thirds_of_it() {
    let (measured, bound) = heaviest_cold_case(M4, Path::new(HOVER_M4F), "hover-witness");
    assert_within(measured, bound, "hover on the M4F");
}

#[test]
fn the_heaviest_cold_case_on_the_a9_takes_at_most_the_bound_and_at_least_two_thirds_of_it() {
    // specs/hover.toml with `target = "cortex-a9"`: f64, as scripts/witness.sh checks it.
    let src = std::fs::read_to_string(root().join("specs/hover.toml")).expect("specs/hover.toml");
    let a9 = src.replacen("\n[codegen]\n", "\n[codegen]\ntarget = \"cortex-a9\"\n", 1);
    assert_ne!(a9, src, "hover has a [codegen] table");
    let spec = Path::new(env!("CARGO_TARGET_TMPDIR")).join("hover-a9.toml");
    std::fs::write(&spec, a9).expect("writing the A9 variant");
    let (measured, bound) = heaviest_cold_case(ZYNQ, &spec, "hover-a9-witness");
    assert_within(measured, bound, "hover on the A9");
}
