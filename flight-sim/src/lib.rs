#![doc = include_str!("../README.md")]
#![no_std]
#![warn(missing_docs)]
// Per-axis loops index several arrays at once (state, input, gains); indices read as the maths.
#![allow(clippy::needless_range_loop)]

mod adapters;
mod estimator;
mod fly;
mod linear;
pub mod metrics;
mod model;
mod noise;
mod pid;
mod real;
mod reference;
pub mod wind;

pub use estimator::{Estimator, ModelEstimator};
pub use fly::{fly, fly_with, Controller, Disturbance, Sample, Scenario};
pub use linear::{
    fly_linear, lower_factor, LinearController, LinearNoise, LinearNoiseConfig, LinearPlant,
    LinearReference, LinearReport, LinearSample, LinearScenario, Setpoint,
};
pub use model::{Plant, DT, NU, NX, NY};
pub use noise::{Noise, NoiseConfig};
pub use pid::{Derivative, Pid, PidController, PidGains};
pub use real::{cast, Real};
pub use reference::{Hover, Reference, Step, Trajectory};
pub use wind::{DisturbanceModel, Dryden, Wind, WindConfig};
