// A spec file that does not exist. The path is relative to the calling crate's CARGO_MANIFEST_DIR, which
// for trybuild is its own crate under the target directory (`$WORKSPACE/target/tests/trybuild/...`).
mpc_macros::mpc!(mod controller = "specs/no-such-spec.toml");

fn main() {}
