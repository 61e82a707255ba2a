//! Emits `specs/quadcopter-admm-f64.toml` with every ADMM kernel as a loop over tables
//! (`Opt::write_out_budget` 0) into `$OUT_DIR/quadcopter_tables.rs`, for `tests/admm.rs`: no shipped size
//! reaches the write-out budget, and the loops must run the reference's statements to the bit too.

fn main() {
    let spec_path = "specs/quadcopter-admm-f64.toml";
    println!("cargo:rerun-if-changed={spec_path}");
    println!("cargo:rerun-if-changed=build.rs");
    let text = std::fs::read_to_string(spec_path).expect("the spec");
    let mut opt = codegen::Opt::new(
        "quadcopter_tables",
        "pub",
        codegen::Origin::Named(spec_path.to_string()),
    );
    opt.write_out_budget = 0;
    let generated =
        codegen::generate_from_source(&text, &opt).unwrap_or_else(|e| panic!("{spec_path}: {e:?}"));
    let out = std::path::Path::new(&std::env::var("OUT_DIR").expect("OUT_DIR"))
        .join("quadcopter_tables.rs");
    std::fs::write(out, generated.tokens.to_string()).expect("OUT_DIR is writable");
}
