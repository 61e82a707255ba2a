//! The PID baseline of the paper's Section 3.1.2.

use crate::estimator::Estimator;
use crate::fly::Controller;
use crate::model::{DT, NU, NX, NY};
use crate::reference::Reference;

/// PID gains, the same on each axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PidGains {
    /// Proportional gain, 1/s².
    pub kp: f64,
    /// Integral gain, 1/s³.
    pub ki: f64,
    /// Derivative gain, 1/s.
    pub kd: f64,
}

impl PidGains {
    /// kp = 34.2, ki = 8.0, kd = 23.4 (Section 3.1.2).
    pub const PAPER: Self = Self {
        kp: 34.2,
        ki: 8.0,
        kd: 23.4,
    };
}

/// A discrete PID per axis on the position error `e = p_ref − p̂`:
/// `u_k = kp e_k + ki Σ e_j dt + kd (e_k − e_{k−1}) / dt`, clamped to `[u_min, u_max]`
/// (the MPC's bounds). The textbook form the paper describes: a backward difference for the
/// derivative (zero on the first cycle), a rectangle-rule integral, no anti-windup and no
/// feed-forward.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pid {
    gains: PidGains,
    u_min: [f64; NU],
    u_max: [f64; NU],
    dt: f64,
    integral: [f64; NU],
    previous: Option<[f64; NU]>,
}

impl Pid {
    /// A PID with the given gains, bounds and period.
    pub const fn new(gains: PidGains, u_min: [f64; NU], u_max: [f64; NU], dt: f64) -> Self {
        Self {
            gains,
            u_min,
            u_max,
            dt,
            integral: [0.0; NU],
            previous: None,
        }
    }

    /// The paper's PID: [`PidGains::PAPER`], ±10 m/s², period [`DT`].
    pub const fn paper() -> Self {
        Self::new(PidGains::PAPER, [-10.0; NU], [10.0; NU], DT)
    }

    /// The gains.
    pub const fn gains(&self) -> &PidGains {
        &self.gains
    }

    /// One cycle: the command for the position error `error`.
    pub fn update(&mut self, error: &[f64; NU]) -> [f64; NU] {
        let g = self.gains;
        let mut u = [0.0; NU];
        for i in 0..NU {
            self.integral[i] += error[i] * self.dt;
            let derivative = match self.previous {
                Some(p) => (error[i] - p[i]) / self.dt,
                None => 0.0,
            };
            let raw = g.kp * error[i] + g.ki * self.integral[i] + g.kd * derivative;
            u[i] = raw.clamp(self.u_min[i], self.u_max[i]);
        }
        self.previous = Some(*error);
        u
    }

    /// Forgets the integral and the previous error.
    pub fn reset(&mut self) {
        self.integral = [0.0; NU];
        self.previous = None;
    }
}

/// The PID closed around an [`Estimator`], as in the paper's Fig. 3: update the filter with the
/// GPS position, apply the PID to the reference position minus the estimated position, and
/// predict the filter with the command.
#[derive(Clone, Debug)]
pub struct PidController<E> {
    /// The PID law.
    pub pid: Pid,
    /// The state estimator.
    pub estimator: E,
    estimate: [f64; NX],
}

impl<E: Estimator> PidController<E> {
    /// The PID `pid` fed by `estimator`.
    pub fn new(pid: Pid, estimator: E) -> Self {
        let estimate = estimator.state();
        Self {
            pid,
            estimator,
            estimate,
        }
    }
}

impl<E: Estimator> Controller for PidController<E> {
    fn step<R: Reference>(&mut self, k: usize, z: &[f64; NY], reference: &R) -> [f64; NU] {
        self.estimator.update(z);
        self.estimate = self.estimator.state();
        let r = reference.state(k);
        let e = [
            r[0] - self.estimate[0],
            r[1] - self.estimate[1],
            r[2] - self.estimate[2],
        ];
        let u = self.pid.update(&e);
        self.estimator.predict(&u);
        u
    }

    fn estimate(&self) -> [f64; NX] {
        self.estimate
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pid_terms_by_hand() {
        let mut pid = Pid::new(
            PidGains {
                kp: 2.0,
                ki: 10.0,
                kd: 0.5,
            },
            [-100.0; 3],
            [100.0; 3],
            0.1,
        );
        // First cycle: P + I, no derivative: 2·1 + 10·(1·0.1) = 3.
        assert_eq!(pid.update(&[1.0, 0.0, -1.0]), [3.0, 0.0, -3.0]);
        // Second: e = 2: P 4, I 10·0.3 = 3, D 0.5·(2−1)/0.1 = 5.
        let u = pid.update(&[2.0, 0.0, -2.0]);
        assert!((u[0] - 12.0).abs() < 1e-12 && (u[2] + 12.0).abs() < 1e-12);
        // Clamped to the bounds.
        let mut paper = Pid::paper();
        assert_eq!(paper.update(&[1.0, -1.0, 0.0]), [10.0, -10.0, 0.0]);
        paper.reset();
        assert_eq!(paper.update(&[0.0; 3]), [0.0; 3]);
    }
}
