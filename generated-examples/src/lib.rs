//! User crates of `mpc!`: the shipped specs, each compiled into a controller module at `cargo build` time.
//! The library is `#![no_std]`, as a firmware crate would be.
#![no_std]

mpc_macros::mpc!(pub mod paper = "../specs/paper.toml");
mpc_macros::mpc!(pub mod paper_faithful = "../specs/paper-faithful.toml");
mpc_macros::mpc!(pub mod paper_initial = "../specs/paper-initial.toml");
mpc_macros::mpc!(pub mod paper_offset_free = "../specs/paper-offset-free.toml");
// The paper's controller with a speed limit and a geofence wall, on the interior-point method (issue 18).
mpc_macros::mpc!(pub mod paper_geofence = "../specs/paper-geofence.toml");
// A plant of your own: continuous time, tracked outputs, move suppression (README, "Your own plant").
mpc_macros::mpc!(pub mod afti16 = "../specs/afti16.toml");

pub mod geofence;
