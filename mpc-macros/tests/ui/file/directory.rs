// A directory where the spec file should be: refused from its metadata, before it is opened.
mpc_macros::mpc!(mod controller = ".");

fn main() {}
