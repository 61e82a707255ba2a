//! Compile tests of the `mpc!` macro: `tests/ui/pass` must build and run; every other folder of `tests/ui/` is a
//! family of bad specs, each case a compile error whose expected output (the rendered TOML snippet with its
//! line and column, on the macro's string literal) is the `.stderr` beside it.
//!
//! The `.stderr` files are generated, then reviewed: `TRYBUILD=overwrite cargo test -p mpc-macros --test
//! compiletest`. They match the stable toolchain this workspace is tested with (rustc 1.95), and
//! `file/missing.stderr` the default target directory (`$WORKSPACE/target`).

/// The families of compile-fail cases, one folder each.
const FAMILIES: &[&str] = &[
    "input",
    "file",
    "syntax",
    "unknown-key",
    "missing-key",
    "type",
    "dimension",
    "matrix",
    "definite",
    "bounds",
    "dt",
    "horizon",
    "iterations",
    "step",
    "stability",
    "linear",
    "sigma",
    "tolerance",
    "emission",
    "outputs",
    "moves",
    "time",
    "constraints",
];

#[test]
fn ui() {
    let t = trybuild::TestCases::new();
    t.pass("tests/ui/pass/*.rs");
    for family in FAMILIES {
        t.compile_fail(format!("tests/ui/{family}/*.rs"));
    }
}

#[test]
fn every_family_is_listed() {
    let ui = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("ui");
    for entry in std::fs::read_dir(ui).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        assert!(
            name == "pass" || FAMILIES.contains(&name.as_str()),
            "tests/ui/{name} is not in FAMILIES"
        );
    }
}
