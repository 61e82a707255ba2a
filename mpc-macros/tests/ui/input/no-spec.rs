// The macro's own input: a module name with neither `= "path"` nor `{ "spec" }`.
mpc_macros::mpc!(mod controller);

fn main() {}
