//! One closed-loop run: the loop shared by the host simulation and the firmware.

use crate::model::{Plant, DT, NU, NX, NY};
use crate::noise::{Noise, NoiseConfig};
use crate::reference::Reference;
use crate::wind::DisturbanceModel;

/// A controller flown by [`fly`]: from a GPS position to an acceleration command.
pub trait Controller {
    /// One control cycle at cycle `k` (time `k·DT`): the GPS position `z` and the reference
    /// (the controller reads what it needs: the current reference or the N-step window); returns
    /// the commanded acceleration, m/s².
    fn step<R: Reference>(&mut self, k: usize, z: &[f64; NY], reference: &R) -> [f64; NU];

    /// The state estimate the last command was computed from.
    fn estimate(&self) -> [f64; NX];

    /// The measurements the controller's filter has rejected so far (0 for one that cannot tell).
    fn rejected_measurements(&self) -> usize {
        0
    }
}

impl<C: Controller + ?Sized> Controller for &mut C {
    fn step<R: Reference>(&mut self, k: usize, z: &[f64; NY], reference: &R) -> [f64; NU] {
        (**self).step(k, z, reference)
    }
    fn estimate(&self) -> [f64; NX] {
        (**self).estimate()
    }
    fn rejected_measurements(&self) -> usize {
        (**self).rejected_measurements()
    }
}

/// An acceleration added to the plant's input on `[start, end)`: the gust of Section 3.2.4.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disturbance {
    /// Added acceleration per axis, m/s².
    pub accel: [f64; 3],
    /// Onset, s.
    pub start: f64,
    /// End (exclusive), s.
    pub end: f64,
}

impl Disturbance {
    /// No disturbance.
    pub const NONE: Self = Self {
        accel: [0.0; 3],
        start: 0.0,
        end: 0.0,
    };

    /// The paper's gust: 0.6 m/s² on the Y axis from t = 20 s to 35 s.
    pub const GUST: Self = Self {
        accel: [0.0, 0.6, 0.0],
        start: 20.0,
        end: 35.0,
    };

    /// The added acceleration at time `t`.
    pub fn at(&self, t: f64) -> [f64; 3] {
        if t >= self.start && t < self.end {
            self.accel
        } else {
            [0.0; 3]
        }
    }
}

/// What a run does besides the controller and the reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scenario {
    /// Seed of the noise streams.
    pub seed: u64,
    /// Number of control cycles.
    pub cycles: usize,
    /// Noise levels.
    pub noise: NoiseConfig,
    /// Added disturbance.
    pub disturbance: Disturbance,
}

impl Scenario {
    /// `cycles` cycles with the default noise and no disturbance.
    pub const fn new(seed: u64, cycles: usize) -> Self {
        Self {
            seed,
            cycles,
            noise: NoiseConfig::DEFAULT,
            disturbance: Disturbance::NONE,
        }
    }

    /// The number of cycles in `seconds` of flight (rounded down).
    pub fn cycles_for(seconds: f64) -> usize {
        let c = seconds / DT;
        if c > 0.0 {
            c as usize
        } else {
            0
        }
    }
}

/// One cycle of a run, as [`fly`] reports it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Cycle index.
    pub k: usize,
    /// Time `k·DT`, s.
    pub t: f64,
    /// True state at the start of the cycle.
    pub state: [f64; NX],
    /// Reference state at this cycle.
    pub reference: [f64; NX],
    /// GPS measurement handed to the controller.
    pub measurement: [f64; NY],
    /// Command returned by the controller.
    pub command: [f64; NU],
    /// Acceleration noise added to the command over this cycle.
    pub accel_noise: [f64; NU],
    /// Disturbance added over this cycle.
    pub disturbance: [f64; NU],
}

impl Sample {
    /// Tracking error `p − p_ref` per axis, m.
    pub fn error(&self) -> [f64; 3] {
        [
            self.state[0] - self.reference[0],
            self.state[1] - self.reference[1],
            self.state[2] - self.reference[2],
        ]
    }
}

/// Flies `controller` along `reference` for `scenario.cycles` cycles, starting at rest-state
/// `reference.state(0)` (build the controller's filter at that state too), and calls `observe`
/// after each cycle with the cycle and the controller. Returns the plant at the end.
///
/// Each cycle `k`: the GPS measures the true position plus noise; the controller returns a
/// command; the plant advances one period under command + acceleration noise + disturbance.
/// The noise draws depend only on the seed and the cycle, never on the controller, so two
/// controllers flown with the same seed meet the same noise.
pub fn fly<C, R, F>(controller: &mut C, reference: &R, scenario: &Scenario, observe: F) -> Plant
where
    C: Controller,
    R: Reference,
    F: FnMut(&Sample, &C),
{
    let mut none = Disturbance::NONE;
    fly_with(controller, reference, scenario, &mut none, observe)
}

/// As [`fly`], with a time-varying disturbance model (a [`Wind`](crate::Wind), say) added to
/// `scenario.disturbance`: the plant's input each cycle is command + acceleration noise +
/// `scenario.disturbance` + `extra`, and [`Sample::disturbance`] reports the sum of the last two.
/// `extra` is called once per cycle, in order.
pub fn fly_with<C, R, D, F>(
    controller: &mut C,
    reference: &R,
    scenario: &Scenario,
    extra: &mut D,
    mut observe: F,
) -> Plant
where
    C: Controller,
    R: Reference,
    D: DisturbanceModel + ?Sized,
    F: FnMut(&Sample, &C),
{
    let mut plant = Plant::new(reference.state(0));
    let mut noise = Noise::new(scenario.seed, scenario.noise);
    for k in 0..scenario.cycles {
        let t = k as f64 * DT;
        let p = plant.position();
        let v = noise.gps();
        let z = [p[0] + v[0], p[1] + v[1], p[2] + v[2]];
        let command = controller.step(k, &z, reference);
        let w = noise.accel();
        let step = scenario.disturbance.at(t);
        let wind = extra.accel(t);
        let d = [step[0] + wind[0], step[1] + wind[1], step[2] + wind[2]];
        let sample = Sample {
            k,
            t,
            state: *plant.state(),
            reference: reference.state(k),
            measurement: z,
            command,
            accel_noise: w,
            disturbance: d,
        };
        plant.step(&[
            command[0] + w[0] + d[0],
            command[1] + w[1] + d[1],
            command[2] + w[2] + d[2],
        ]);
        observe(&sample, controller);
    }
    plant
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Hover, ModelEstimator, Pid, PidController, Trajectory};

    #[test]
    fn same_seed_same_flight_and_noise_is_independent_of_the_controller() {
        let r = Trajectory::paper();
        let s = Scenario::new(3, 800);
        let run = |seed| {
            let mut c = PidController::new(Pid::paper(), ModelEstimator::new(r.start()));
            let mut last = [0.0; 3];
            let mut zs = [[0.0; 3]; 800];
            fly(&mut c, &r, &Scenario { seed, ..s }, |x, _| {
                last = x.command;
                zs[x.k] = [x.measurement[0] - x.state[0], x.accel_noise[1], 0.0];
            });
            (last, zs)
        };
        let (a, za) = run(3);
        let (b, zb) = run(3);
        let (c, _) = run(4);
        assert_eq!(a, b);
        assert_eq!(za, zb);
        assert_ne!(a, c);
        // A different controller (hover reference) meets the very same noise.
        let mut h = PidController::new(Pid::paper(), ModelEstimator::new([0.0; 6]));
        fly(&mut h, &Hover([0.0; 3]), &s, |x, _| {
            assert_eq!(x.measurement[0] - x.state[0], za[x.k][0]);
            assert_eq!(x.accel_noise[1], za[x.k][1]);
        });
    }

    #[test]
    fn noise_levels_are_what_they_say() {
        let mut n = Noise::new(11, NoiseConfig::DEFAULT);
        let (mut sg, mut sa) = (0.0, 0.0);
        let m = 20_000;
        for _ in 0..m {
            sg += n.gps().iter().map(|v| v * v).sum::<f64>();
            sa += n.accel().iter().map(|v| v * v).sum::<f64>();
        }
        let (g, a) = (
            libm::sqrt(sg / (3 * m) as f64),
            libm::sqrt(sa / (3 * m) as f64),
        );
        assert!((g - 0.3).abs() < 0.01, "{g}");
        assert!((a - 0.5).abs() < 0.015, "{a}");
    }

    #[test]
    fn the_disturbance_reaches_the_plant() {
        // No noise, no control: the gust alone moves the drone by a·T²/2 along Y.
        struct Idle;
        impl Controller for Idle {
            fn step<R: Reference>(&mut self, _: usize, _: &[f64; 3], _: &R) -> [f64; 3] {
                [0.0; 3]
            }
            fn estimate(&self) -> [f64; 6] {
                [0.0; 6]
            }
        }
        let s = Scenario {
            noise: NoiseConfig::NONE,
            disturbance: Disturbance {
                accel: [0.0, 1.0, 0.0],
                start: 0.0,
                end: 1.0,
            },
            ..Scenario::new(0, Scenario::cycles_for(1.0 + 1e-9))
        };
        let end = fly(&mut Idle, &Hover([0.0; 3]), &s, |_, _| {});
        let t = s.cycles as f64 * DT;
        assert!((end.state()[1] - 0.5 * t * t).abs() < 1e-9);
        assert_eq!(end.state()[0], 0.0);
    }
}
