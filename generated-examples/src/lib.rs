#![doc = include_str!("../README.md")]
#![no_std]

mpc_macros::mpc!(pub mod paper = "../specs/paper.toml");
mpc_macros::mpc!(pub mod paper_faithful = "../specs/paper-faithful.toml");
mpc_macros::mpc!(pub mod paper_initial = "../specs/paper-initial.toml");
mpc_macros::mpc!(pub mod paper_offset_free = "../specs/paper-offset-free.toml");
// The paper's controller with a speed limit and a geofence wall, on the dual active set (`auto`; issue 18).
mpc_macros::mpc!(pub mod paper_geofence = "../specs/paper-geofence.toml");
// A plant of your own: continuous time, tracked outputs, move suppression (docs/own-plant.md).
mpc_macros::mpc!(pub mod afti16 = "../specs/afti16.toml");

pub mod geofence;

/// `report::BYTES_STATE*` (the compiler's layout model, known before rustc runs) equal `size_of` of the
/// types on whatever target this crate is built for: checked by the compiler, so a build for the
/// Cortex-A9 or the Cortex-M4F (the firmware's) fails if they differ there.
macro_rules! state_sizes {
    ($($m:ident),*) => {$(
        const _: () = {
            use $m::{report, Controller, Kalman, Mpc};
            assert!(core::mem::size_of::<Mpc>() == report::BYTES_STATE_MPC);
            assert!(core::mem::size_of::<Kalman>() == report::BYTES_STATE_KALMAN);
            assert!(core::mem::size_of::<Controller>() == report::BYTES_STATE);
        };
    )*};
}

state_sizes!(
    paper,
    paper_faithful,
    paper_initial,
    paper_offset_free,
    paper_geofence,
    afti16
);
