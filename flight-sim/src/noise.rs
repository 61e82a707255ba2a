//! Seeded white Gaussian noise for the GPS and the acceleration channel.

use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// Noise levels (standard deviations), the defaults of the simulation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseConfig {
    /// GPS position noise per axis, m (default 0.3).
    pub gps_sigma: f64,
    /// Acceleration noise per axis, m/s² (default 0.5), added to the command each cycle.
    pub accel_sigma: f64,
}

impl NoiseConfig {
    /// GPS 0.3 m, acceleration 0.5 m/s².
    pub const DEFAULT: Self = Self {
        gps_sigma: 0.3,
        accel_sigma: 0.5,
    };
    /// No noise at all (step responses).
    pub const NONE: Self = Self {
        gps_sigma: 0.0,
        accel_sigma: 0.0,
    };
}

impl Default for NoiseConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Two independent ChaCha8 streams from one seed: stream 0 for the GPS, stream 1 for the
/// acceleration. Each draw is a standard normal scaled by the level, so the same seed gives the
/// same underlying draws whatever the levels (a level of 0 still draws).
#[derive(Clone, Debug)]
pub struct Noise {
    gps: ChaCha8Rng,
    accel: ChaCha8Rng,
    config: NoiseConfig,
}

impl Noise {
    /// Noise of the given levels from `seed`.
    pub fn new(seed: u64, config: NoiseConfig) -> Self {
        let mut gps = ChaCha8Rng::seed_from_u64(seed);
        gps.set_stream(0);
        let mut accel = ChaCha8Rng::seed_from_u64(seed);
        accel.set_stream(1);
        Self { gps, accel, config }
    }

    /// The levels.
    pub const fn config(&self) -> &NoiseConfig {
        &self.config
    }

    /// One GPS error vector, m.
    pub fn gps(&mut self) -> [f64; 3] {
        draw(&mut self.gps, self.config.gps_sigma)
    }

    /// One acceleration error vector, m/s².
    pub fn accel(&mut self) -> [f64; 3] {
        draw(&mut self.accel, self.config.accel_sigma)
    }
}

/// `K` independent standard normals from `rng`, scaled by `sigma`.
pub(crate) fn draw<const K: usize>(rng: &mut ChaCha8Rng, sigma: f64) -> [f64; K] {
    let mut out = [0.0; K];
    for o in &mut out {
        let n: f64 = StandardNormal.sample(rng);
        *o = sigma * n;
    }
    out
}
