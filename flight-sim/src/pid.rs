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

    /// One cycle: the command for the position error `error`, the derivative term from the
    /// backward difference of the error.
    pub fn update(&mut self, error: &[f64; NU]) -> [f64; NU] {
        let mut rate = [0.0; NU];
        if let Some(p) = self.previous {
            for i in 0..NU {
                rate[i] = (error[i] - p[i]) / self.dt;
            }
        }
        self.update_with_rate(error, &rate)
    }

    /// One cycle with the error's rate of change given (e.g. `v_ref − v̂` from an estimator).
    pub fn update_with_rate(&mut self, error: &[f64; NU], rate: &[f64; NU]) -> [f64; NU] {
        let g = self.gains;
        let mut u = [0.0; NU];
        for i in 0..NU {
            self.integral[i] += error[i] * self.dt;
            let raw = g.kp * error[i] + g.ki * self.integral[i] + g.kd * rate[i];
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

/// Where a [`PidController`] takes the derivative of the error from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Derivative {
    /// Backward difference of the position error `p_ref − p̂` (the default: the textbook
    /// discrete PID the paper describes).
    #[default]
    Difference,
    /// The velocity error `v_ref − v̂` from the estimator (no differentiation of the estimate's
    /// measurement-driven jumps).
    Velocity,
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
    /// Where the derivative term comes from.
    pub derivative: Derivative,
    estimate: [f64; NX],
}

impl<E: Estimator> PidController<E> {
    /// The PID `pid` fed by `estimator`, derivative by [`Derivative::Difference`].
    pub fn new(pid: Pid, estimator: E) -> Self {
        let estimate = estimator.state();
        Self {
            pid,
            estimator,
            derivative: Derivative::Difference,
            estimate,
        }
    }

    /// The same controller with the derivative taken as `derivative` says.
    pub fn with_derivative(mut self, derivative: Derivative) -> Self {
        self.derivative = derivative;
        self
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
        let u = match self.derivative {
            Derivative::Difference => self.pid.update(&e),
            Derivative::Velocity => {
                let rate = [
                    r[3] - self.estimate[3],
                    r[4] - self.estimate[4],
                    r[5] - self.estimate[5],
                ];
                self.pid.update_with_rate(&e, &rate)
            }
        };
        self.estimator.predict(&u);
        u
    }

    fn estimate(&self) -> [f64; NX] {
        self.estimate
    }
    fn rejected_measurements(&self) -> usize {
        self.estimator.rejected_measurements()
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
        // A given rate replaces the difference: 34.2·0.01 + 8·0.01·DT + 23.4·(−0.1).
        let mut p = Pid::paper();
        let u = p.update_with_rate(&[0.01, 0.0, 0.0], &[-0.1, 0.0, 0.0]);
        assert!((u[0] - (0.342 + 0.08 * DT - 2.34)).abs() < 1e-12);
    }

    #[test]
    fn the_controller_uses_the_estimate_and_the_chosen_derivative() {
        use crate::{Hover, ModelEstimator};
        // Estimate at rest at the origin, reference at (1, 0, 0) with velocity 0: the first
        // command is P + I only either way; with a velocity reference the rate term shows.
        let est = ModelEstimator::new([0.0; 6]);
        let mut c = PidController::new(
            Pid::new(
                PidGains {
                    kp: 1.0,
                    ki: 0.0,
                    kd: 2.0,
                },
                [-9.0; 3],
                [9.0; 3],
                DT,
            ),
            est,
        );
        let u = c.step(0, &[0.0; 3], &Hover([1.0, 0.0, 0.0]));
        assert!((u[0] - 1.0).abs() < 1e-12);
        struct Moving;
        impl Reference for Moving {
            fn state_at(&self, _: f64) -> [f64; 6] {
                [0.0, 0.0, 0.0, 0.5, 0.0, 0.0]
            }
        }
        let mut c = PidController::new(
            Pid::new(
                PidGains {
                    kp: 1.0,
                    ki: 0.0,
                    kd: 2.0,
                },
                [-9.0; 3],
                [9.0; 3],
                DT,
            ),
            est,
        )
        .with_derivative(Derivative::Velocity);
        let u = c.step(0, &[0.0; 3], &Moving);
        assert!((u[0] - 1.0).abs() < 1e-12, "{u:?}");
    }
}
