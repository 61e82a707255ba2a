//! A closed loop around any discrete linear plant: x⁺ = A x + B (u + d) + w, y = C x + v.
//!
//! The matrices are the sampled ones: for a spec with `time = "continuous"` take the zero-order-hold
//! matrices the compiler computed (`mpcc check --json` prints them as `model.a`, `model.b`), with which
//! the plant is integrated exactly between samples for an input held over each period. The metrics are
//! the drone's ([`Tracking`], [`StepResponse`]), over the `NR` quantities the reference gives.

use crate::metrics::{StepMetrics, StepResponse, Table2, Tracking};
use crate::noise::draw;
use crate::real::{cast, Real};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

/// A discrete linear plant x⁺ = A x + B u + w, y = C x, in `f64`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearPlant<const NX: usize, const NU: usize, const NY: usize> {
    /// A, NX × NX.
    pub a: [[f64; NX]; NX],
    /// B, NX × NU.
    pub b: [[f64; NU]; NX],
    /// C, NY × NX.
    pub c: [[f64; NX]; NY],
    x: [f64; NX],
}

impl<const NX: usize, const NU: usize, const NY: usize> LinearPlant<NX, NU, NY> {
    /// The plant of the discrete matrices `a`, `b`, `c` at state `x0`.
    pub const fn new(
        a: [[f64; NX]; NX],
        b: [[f64; NU]; NX],
        c: [[f64; NX]; NY],
        x0: [f64; NX],
    ) -> Self {
        Self { a, b, c, x: x0 }
    }

    /// The true state.
    pub const fn state(&self) -> &[f64; NX] {
        &self.x
    }

    /// The noise-free output C x.
    pub fn output(&self) -> [f64; NY] {
        product(&self.c, &self.x)
    }

    /// Advances one period under the input `u` (everything that enters through B) and the process
    /// noise `w`: x ← A x + B u + w.
    pub fn step(&mut self, u: &[f64; NU], w: &[f64; NX]) {
        let ax = product(&self.a, &self.x);
        let bu = product(&self.b, u);
        for i in 0..NX {
            self.x[i] = ax[i] + bu[i] + w[i];
        }
    }
}

/// M·v for a row-major M.
fn product<const R: usize, const K: usize>(m: &[[f64; K]; R], v: &[f64; K]) -> [f64; R] {
    let mut out = [0.0; R];
    for (o, row) in out.iter_mut().zip(m) {
        *o = row.iter().zip(v).map(|(a, b)| a * b).sum();
    }
    out
}

/// The lower-triangular factor L of a positive semidefinite covariance Q = L Lᵀ (Cholesky, a pivot
/// within rounding of zero taken as zero, as a state the noise does not reach), for
/// [`LinearNoiseConfig::process_factor`]; `None` for a matrix that is not symmetric positive
/// semidefinite.
pub fn lower_factor<const N: usize>(q: &[[f64; N]; N]) -> Option<[[f64; N]; N]> {
    let scale = (0..N).map(|i| q[i][i].abs()).fold(0.0, f64::max);
    let tolerance = scale * 1e-12;
    let mut l = [[0.0; N]; N];
    for j in 0..N {
        for i in 0..j {
            if (q[i][j] - q[j][i]).abs() > tolerance {
                return None;
            }
        }
        let pivot = q[j][j] - (0..j).map(|k| l[j][k] * l[j][k]).sum::<f64>();
        if pivot < -tolerance {
            return None;
        }
        if pivot <= tolerance {
            // A direction without noise: its column is zero, and the rows below must not need it.
            for i in j + 1..N {
                let rest = q[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>();
                if rest.abs() > tolerance {
                    return None;
                }
            }
            continue;
        }
        let d = libm::sqrt(pivot);
        l[j][j] = d;
        for i in j + 1..N {
            l[i][j] = (q[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>()) / d;
        }
    }
    Some(l)
}

/// The noise of a linear run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearNoiseConfig<const NX: usize, const NY: usize> {
    /// The lower-triangular factor L of the discrete process covariance Q_d = L Lᵀ ([`lower_factor`]):
    /// w = L n, n standard normal; `None`: no process noise.
    pub process_factor: Option<[[f64; NX]; NX]>,
    /// The measurement noise standard deviation of each output.
    pub measurement_sigma: [f64; NY],
}

impl<const NX: usize, const NY: usize> LinearNoiseConfig<NX, NY> {
    /// No noise at all.
    pub const NONE: Self = Self {
        process_factor: None,
        measurement_sigma: [0.0; NY],
    };
}

/// Two independent ChaCha8 streams from one seed, as the drone's [`Noise`](crate::Noise): stream 0
/// for the measurement, stream 1 for the process. Every cycle draws both whatever the levels, so the
/// same seed meets the same draws.
#[derive(Clone, Debug)]
pub struct LinearNoise<const NX: usize, const NY: usize> {
    measurement: ChaCha8Rng,
    process: ChaCha8Rng,
    config: LinearNoiseConfig<NX, NY>,
}

impl<const NX: usize, const NY: usize> LinearNoise<NX, NY> {
    /// Noise of `config` from `seed`.
    pub fn new(seed: u64, config: LinearNoiseConfig<NX, NY>) -> Self {
        let mut measurement = ChaCha8Rng::seed_from_u64(seed);
        measurement.set_stream(0);
        let mut process = ChaCha8Rng::seed_from_u64(seed);
        process.set_stream(1);
        Self {
            measurement,
            process,
            config,
        }
    }

    /// One measurement error vector.
    pub fn measurement(&mut self) -> [f64; NY] {
        let mut v: [f64; NY] = draw(&mut self.measurement, 1.0);
        for (v, s) in v.iter_mut().zip(&self.config.measurement_sigma) {
            *v *= s;
        }
        v
    }

    /// One process noise vector L·n.
    pub fn process(&mut self) -> [f64; NX] {
        let n: [f64; NX] = draw(&mut self.process, 1.0);
        match &self.config.process_factor {
            Some(l) => product(l, &n),
            None => [0.0; NX],
        }
    }
}

/// The `NR` quantities a linear run tracks, for every time.
pub trait LinearReference<const NR: usize> {
    /// The reference at time `t` (s).
    fn at(&self, t: f64) -> [f64; NR];

    /// The N-step window an MPC needs at cycle `k` of period `dt`: `window[j]` is the reference at
    /// cycle `k + 1 + j` (that of the predicted step j + 1), in the controller's scalar `T`.
    fn window<T: Real, const N: usize>(&self, k: usize, dt: f64) -> [[T; NR]; N] {
        let mut w = [[T::default(); NR]; N];
        for (j, row) in w.iter_mut().enumerate() {
            *row = cast(&self.at((k + 1 + j) as f64 * dt));
        }
        w
    }
}

impl<const NR: usize, F: Fn(f64) -> [f64; NR]> LinearReference<NR> for F {
    fn at(&self, t: f64) -> [f64; NR] {
        self(t)
    }
}

/// A constant reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setpoint<const NR: usize>(pub [f64; NR]);

impl<const NR: usize> LinearReference<NR> for Setpoint<NR> {
    fn at(&self, _t: f64) -> [f64; NR] {
        self.0
    }
}

/// A controller flown by [`fly_linear`]: from a measurement to a command.
pub trait LinearController<const NU: usize, const NY: usize, const NR: usize> {
    /// One control cycle at cycle `k`: the measurement `y` and the reference (the controller reads what
    /// it needs, e.g. [`LinearReference::window`]); returns the command.
    fn step<R: LinearReference<NR>>(&mut self, k: usize, y: &[f64; NY], reference: &R)
        -> [f64; NU];

    /// The measurements the controller's filter has rejected so far (0 for one that cannot tell).
    fn rejected_measurements(&self) -> usize {
        0
    }
}

/// What a linear run does besides the plant, the controller and the reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearScenario<const NX: usize, const NY: usize> {
    /// Seed of the noise streams.
    pub seed: u64,
    /// Number of control cycles.
    pub cycles: usize,
    /// The sampling period, s (the plant's matrices are sampled over it).
    pub dt: f64,
    /// Noise levels.
    pub noise: LinearNoiseConfig<NX, NY>,
}

/// One cycle of a linear run, as [`fly_linear`] reports it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearSample<const NX: usize, const NU: usize, const NY: usize, const NR: usize> {
    /// Cycle index.
    pub k: usize,
    /// Time `k·dt`, s.
    pub t: f64,
    /// True state at the start of the cycle.
    pub state: [f64; NX],
    /// The tracked quantities Z x of that state.
    pub tracked: [f64; NR],
    /// The reference at this cycle.
    pub reference: [f64; NR],
    /// The measurement handed to the controller.
    pub measurement: [f64; NY],
    /// The command returned by the controller.
    pub command: [f64; NU],
    /// The input disturbance added to the command over this cycle.
    pub disturbance: [f64; NU],
}

impl<const NX: usize, const NU: usize, const NY: usize, const NR: usize>
    LinearSample<NX, NU, NY, NR>
{
    /// Tracking error Z x − r.
    pub fn error(&self) -> [f64; NR] {
        let mut e = self.tracked;
        for (e, r) in e.iter_mut().zip(&self.reference) {
            *e -= r;
        }
        e
    }
}

/// The metrics of a linear run: the drone's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearReport<const NU: usize, const NR: usize> {
    /// Table 2 over the tracked quantities and the commands.
    pub table2: Table2<NR, NU>,
    /// Table 3 of each tracked quantity, for the step from its value at the start to the reference at
    /// the last cycle, from t = 0 (all `None` and 0 for a quantity whose reference ends where it
    /// started).
    pub step: [StepMetrics; NR],
    /// The measurements the controller rejected.
    pub rejected_measurements: usize,
}

/// Flies `controller` on `plant` along `reference` for `scenario.cycles` cycles, tracking the
/// quantities `tracked`·x (NR × NX: the identity for a state reference), and calls `observe` after
/// each cycle with the cycle and the controller. `disturbance(t)` is added to the command at time `t`
/// (`|_| [0.0; NU]` for none, `|_| d` for a constant one). The plant is left at its final state.
///
/// Each cycle `k`: the sensor measures C x + v; the controller returns a command u; the plant advances
/// one period under u + d(t) and the process noise w. The noise depends only on the seed and the
/// cycle, never on the controller.
pub fn fly_linear<const NX: usize, const NU: usize, const NY: usize, const NR: usize, C, R, D, F>(
    plant: &mut LinearPlant<NX, NU, NY>,
    controller: &mut C,
    reference: &R,
    tracked: &[[f64; NX]; NR],
    scenario: &LinearScenario<NX, NY>,
    mut disturbance: D,
    mut observe: F,
) -> LinearReport<NU, NR>
where
    C: LinearController<NU, NY, NR>,
    R: LinearReference<NR>,
    D: FnMut(f64) -> [f64; NU],
    F: FnMut(&LinearSample<NX, NU, NY, NR>, &C),
{
    let dt = scenario.dt;
    let mut noise = LinearNoise::new(scenario.seed, scenario.noise);
    let mut tracking = Tracking::<NR, NU>::new(dt);
    let start = product(tracked, plant.state());
    let end = reference.at(scenario.cycles.saturating_sub(1) as f64 * dt);
    let mut steps: [StepResponse; NR] =
        core::array::from_fn(|i| StepResponse::new(start[i], end[i] - start[i], 0.0));
    for k in 0..scenario.cycles {
        let t = k as f64 * dt;
        let mut y = plant.output();
        for (y, v) in y.iter_mut().zip(noise.measurement()) {
            *y += v;
        }
        let command = controller.step(k, &y, reference);
        let d = disturbance(t);
        let w = noise.process();
        let sample = LinearSample {
            k,
            t,
            state: *plant.state(),
            tracked: product(tracked, plant.state()),
            reference: reference.at(t),
            measurement: y,
            command,
            disturbance: d,
        };
        tracking.push(t, &sample.error(), &command);
        for (s, z) in steps.iter_mut().zip(&sample.tracked) {
            s.push(t, *z);
        }
        let mut u = command;
        for (u, d) in u.iter_mut().zip(&d) {
            *u += d;
        }
        plant.step(&u, &w);
        observe(&sample, controller);
    }
    LinearReport {
        table2: tracking.finish(),
        step: core::array::from_fn(|i| steps[i].finish()),
        rejected_measurements: controller.rejected_measurements(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// x⁺ = 0.5 x + u, y = x.
    fn scalar() -> LinearPlant<1, 1, 1> {
        LinearPlant::new([[0.5]], [[1.0]], [[1.0]], [0.0])
    }

    /// u = the reference's next value minus half the measurement: deadbeat on a noise-free plant.
    struct Deadbeat;
    impl LinearController<1, 1, 1> for Deadbeat {
        fn step<R: LinearReference<1>>(&mut self, k: usize, y: &[f64; 1], r: &R) -> [f64; 1] {
            let next: [[f64; 1]; 1] = r.window(k, 0.1);
            [next[0][0] - 0.5 * y[0]]
        }
    }

    #[test]
    fn a_deadbeat_loop_tracks_from_the_first_step_and_the_disturbance_enters_through_b() {
        let mut p = scalar();
        let s = LinearScenario {
            seed: 1,
            cycles: 20,
            dt: 0.1,
            noise: LinearNoiseConfig::NONE,
        };
        let report = fly_linear(
            &mut p,
            &mut Deadbeat,
            &Setpoint([2.0]),
            &[[1.0]],
            &s,
            |_| [0.0],
            |x, _| {
                if x.k > 0 {
                    assert_eq!(x.error(), [0.0]);
                }
            },
        );
        assert_eq!(p.state(), &[2.0]);
        // The only error is the first cycle's 2 of 20: RMS √(4/20), max 2; the response enters the 2 %
        // band on the segment from 0 (t = 0) to 2 (t = 0.1 s), at 98 % of it (interpolated).
        assert!((report.table2.rmse[0] - libm::sqrt(0.2)).abs() < 1e-15);
        assert_eq!(report.table2.max_abs_error, [2.0]);
        assert!((report.step[0].settling_time.unwrap() - 0.098).abs() < 1e-15);
        // The command moves once, by 1 after the first cycle: smoothness 1/(19·0.1).
        assert!((report.table2.smoothness[0] - 1.0 / 1.9).abs() < 1e-12);
        // A constant disturbance of 1 that the controller does not see: x⁺ = 0.5x + (2 − 0.5x) + 1 = 3.
        let mut p = scalar();
        fly_linear(
            &mut p,
            &mut Deadbeat,
            &Setpoint([2.0]),
            &[[1.0]],
            &s,
            |_| [1.0],
            |_, _| {},
        );
        assert_eq!(p.state(), &[3.0]);
    }

    #[test]
    fn noise_has_the_covariance_of_its_factor() {
        let q = [[4.0, 1.2], [1.2, 1.0]];
        let l = lower_factor(&q).unwrap();
        assert_eq!(l[0][1], 0.0);
        let config = LinearNoiseConfig {
            process_factor: Some(l),
            measurement_sigma: [0.3],
        };
        let mut n = LinearNoise::<2, 1>::new(7, config);
        let m = 40_000;
        let (mut c, mut v) = ([[0.0; 2]; 2], 0.0);
        for _ in 0..m {
            let w = n.process();
            for i in 0..2 {
                for j in 0..2 {
                    c[i][j] += w[i] * w[j] / m as f64;
                }
            }
            v += n.measurement()[0].powi(2) / m as f64;
        }
        // Sample covariances of 40,000 draws: within 3 % of the entries' scale.
        for i in 0..2 {
            for j in 0..2 {
                assert!((c[i][j] - q[i][j]).abs() < 0.03 * 4.0, "{c:?}");
            }
        }
        assert!((v - 0.09).abs() < 0.03 * 0.09, "{v}");
        // Semidefinite: a state without noise; indefinite and asymmetric: refused.
        let l = lower_factor(&[[0.0, 0.0], [0.0, 2.0]]).unwrap();
        assert_eq!(l, [[0.0, 0.0], [0.0, libm::sqrt(2.0)]]);
        assert_eq!(lower_factor(&[[1.0, 2.0], [2.0, 1.0]]), None);
        assert_eq!(lower_factor(&[[1.0, 0.5], [0.0, 1.0]]), None);
    }
}
