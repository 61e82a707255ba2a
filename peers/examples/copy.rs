//! Prints the active set's copy of a shipped spec that the replay builds (`build.rs`), for a board:
//! `cargo run --example copy -- PROBLEM zynq|netduinoplus2` (on the STM32F405 the f32 variant), so that
//! `scripts/witness.sh` certifies and dumps the very spec the firmware runs.
#[path = "../copies.rs"]
mod copies;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (Some(problem), Some(board)) = (args.get(1), args.get(2)) else {
        eprintln!("usage: copy PROBLEM zynq|netduinoplus2");
        std::process::exit(2);
    };
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let spec = root.join(format!("../specs/{problem}.toml"));
    let text = std::fs::read_to_string(&spec).unwrap_or_else(|e| panic!("{}: {e}", spec.display()));
    print!(
        "{}",
        copies::active_set(root, &text, board == "netduinoplus2")
    );
}
