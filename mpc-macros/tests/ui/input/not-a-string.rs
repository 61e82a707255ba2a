// The macro's own input: the spec must be a string literal.
mpc_macros::mpc!(mod controller { horizon = 10 });

fn main() {}
