// A device that never ends: refused from its metadata, before a byte is read (it used to read without
// bound and take the build down).
mpc_macros::mpc!(mod controller = "/dev/zero");

fn main() {}
