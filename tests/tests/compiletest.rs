//! Compile tests of the `mpc!` macro: `ui/pass` must build and run.
#[test]
fn ui() {
    let t = trybuild::TestCases::new();
    t.pass("ui/pass/*.rs");
}
