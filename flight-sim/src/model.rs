//! The drone model of the paper's eq. 1-2: three decoupled double integrators.

/// Control period of the paper, s (Section 2.2).
pub const DT: f64 = 0.0128;
/// State dimension: `[px, py, pz, vx, vy, vz]`.
pub const NX: usize = 6;
/// Input dimension: `[ax, ay, az]`, m/s².
pub const NU: usize = 3;
/// Measurement dimension: GPS positions `[px, py, pz]`.
pub const NY: usize = 3;

/// The simulated drone: `x_{k+1} = F x_k + G a_k` (eq. 2), exact for an acceleration held
/// constant over the cycle, in `f64`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plant {
    x: [f64; NX],
    dt: f64,
}

impl Plant {
    /// A plant at state `x0` with the paper's period [`DT`].
    pub const fn new(x0: [f64; NX]) -> Self {
        Self::with_dt(x0, DT)
    }

    /// A plant at state `x0` with period `dt`.
    pub const fn with_dt(x0: [f64; NX], dt: f64) -> Self {
        Self { x: x0, dt }
    }

    /// The true state `[px, py, pz, vx, vy, vz]`.
    pub const fn state(&self) -> &[f64; NX] {
        &self.x
    }

    /// The true position.
    pub fn position(&self) -> [f64; 3] {
        [self.x[0], self.x[1], self.x[2]]
    }

    /// Advances one period under the total acceleration `a` (command + noise + disturbance).
    pub fn step(&mut self, a: &[f64; NU]) {
        let dt = self.dt;
        for i in 0..3 {
            self.x[i] += dt * self.x[i + 3] + 0.5 * dt * dt * a[i];
            self.x[i + 3] += dt * a[i];
        }
    }
}
