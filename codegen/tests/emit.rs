//! The emitted module: valid Rust, readable, `core`-only and free of panicking constructs; a golden file
//! pins the whole output of a small spec (rewritten on mismatch, then failing, so the change shows in git).

use codegen::{generate_from_source, Opt};

fn emitted(src: &str) -> String {
    let generated = generate_from_source(src, &Opt::default()).unwrap();
    // Every emission parses as a Rust file.
    syn::parse2::<syn::File>(generated.tokens.clone()).expect("the emitter generates valid Rust");
    generated.pretty()
}

#[test]
fn golden_tiny_module() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/tiny");
    let src = std::fs::read_to_string(format!("{dir}/spec.toml")).unwrap();
    let actual = emitted(&src);
    let path = format!("{dir}/expected.rs");
    let expected = std::fs::read_to_string(&path).unwrap_or_default();
    if actual != expected {
        std::fs::write(&path, &actual).unwrap();
        panic!("{path} was out of date and has been rewritten: review the diff and commit it");
    }
}

#[test]
fn emitted_code_uses_core_only_and_cannot_panic() {
    for spec in [
        include_str!("../../specs/paper.toml"),
        include_str!("../../specs/paper-faithful.toml"),
        include_str!("../../specs/paper-initial.toml"),
        include_str!("fixtures/tiny/spec.toml"),
    ] {
        // Code only: doc comments may speak of `xref[k]`.
        let code: String = emitted(spec)
            .lines()
            .filter(|l| !l.trim_start().starts_with("//"))
            .collect::<Vec<_>>()
            .join("\n");
        for forbidden in [
            "std::",
            "alloc",
            "Vec",
            "Box",
            "unwrap",
            "expect(",
            "panic",
            "unreachable",
            "assert",
            "[..",
            "..]",
            "as usize",
        ] {
            assert!(
                !code.contains(forbidden),
                "emitted code contains `{forbidden}`"
            );
        }
        // Only constant indices: every `[` that follows an identifier holds a literal.
        let bytes = code.as_bytes();
        for (i, c) in bytes.iter().enumerate() {
            if *c == b'['
                && i > 0
                && (bytes[i - 1].is_ascii_alphanumeric()
                    || bytes[i - 1] == b']'
                    || bytes[i - 1] == b'_')
            {
                let close = code[i..].find(']').unwrap() + i;
                let index = &code[i + 1..close];
                assert!(
                    index.chars().all(|c| c.is_ascii_digit()),
                    "non-constant index `{index}`"
                );
            }
        }
    }
}

#[test]
fn zeros_of_the_hessian_are_skipped() {
    let code = emitted(include_str!(
        "../../tests/specs/emission/paper-unrolled.toml"
    ));
    let start = code.find("fn gradient(").unwrap();
    let end = start + code[start..].find("\n    }\n").unwrap();
    let gradient = &code[start..end];
    // 675 nonzeros of H: one product each (none of them is exactly ±1).
    assert_eq!(gradient.matches(" * y[").count(), 675);
    assert!(code.contains("unrolled over the 675 nonzeros of H"));
}

#[test]
fn the_paper_runs_its_three_axes_in_lanes_of_one_table() {
    let code = emitted(include_str!("../../specs/paper.toml"));
    assert!(code.contains("pub const EMISSION: &str = \"lanes\";"));
    assert!(code.contains("pub const LANES: usize = 4;"));
    // One 15 × 15 table for all three axes, and the portable iteration beside the NEON one.
    assert_eq!(code.matches("pub const H_AXIS: [[Real; N]; N]").count(), 1);
    assert_eq!(code.matches("fn fast_gradient_iteration(").count(), 2);
    assert!(code.contains("vmlaq_lane_f32"));
    // The gradient is fused into the iteration: no `g` buffer, no separate step.
    assert!(!code.contains("fn gradient("));
    assert!(!code.contains("fn fast_gradient_step("));
    // The NEON kernel only exists where the firmware asks for it; the host compiles the portable one.
    assert!(
        code.contains("#[cfg(all(mpc_neon, target_arch = \"arm\", target_feature = \"neon\"))]")
    );
    assert!(code
        .contains("#[cfg(not(all(mpc_neon, target_arch = \"arm\", target_feature = \"neon\")))]"));
}

#[test]
fn the_matrix_free_form_has_no_hessian_product() {
    let code = emitted(include_str!(
        "../../tests/specs/emission/paper-matrix-free.toml"
    ));
    assert!(!code.contains("fn gradient("));
    assert!(code.contains("fn adjoint_gradient("));
    assert!(code.contains("adjoint_gradient(&y, x0, xref, &mut g);"));
}
