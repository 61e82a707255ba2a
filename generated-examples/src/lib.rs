#![doc = include_str!("../README.md")]
#![no_std]

mpc_macros::mpc!(pub mod paper = "../specs/paper.toml");
mpc_macros::mpc!(pub mod paper_faithful = "../specs/paper-faithful.toml");
mpc_macros::mpc!(pub mod paper_initial = "../specs/paper-initial.toml");
mpc_macros::mpc!(pub mod paper_offset_free = "../specs/paper-offset-free.toml");
// The paper's controller with a speed limit and a geofence wall, on the interior-point method (issue 18).
mpc_macros::mpc!(pub mod paper_geofence = "../specs/paper-geofence.toml");
// A plant of your own: continuous time, tracked outputs, move suppression (docs/own-plant.md).
mpc_macros::mpc!(pub mod afti16 = "../specs/afti16.toml");

pub mod geofence;
