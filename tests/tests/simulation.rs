//! The paper's closed loop (issue 5): the generated MPCs and the PID flying `flight_sim`'s plant;
//! the offset-free MPC in the gust and in wind (issue 8).
//!
//! Short flights over a few fixed seeds, asserting only what holds with a wide margin on every
//! seed: ratios between controllers, never absolute figures. The full comparison, with its
//! findings, is the `paper` binary of `generated-examples` (see `generated-examples/SIMULATION.md`).

use flight_sim::metrics::{gust, gust_settling, StepResponse, Tracking, SETTLE_BAND};
use flight_sim::{
    fly, fly_with, Controller, Disturbance, DisturbanceModel, Dryden, NoiseConfig, Pid,
    PidController, Reference, Scenario, Step, Trajectory, Wind, DT,
};

mpc_macros::mpc!(mod paper = "../specs/paper.toml");
mpc_macros::mpc!(mod paper_faithful = "../specs/paper-faithful.toml");

flight_sim::mpc_controller!(struct PaperMpc(self::paper));
flight_sim::mpc_controller!(struct FaithfulMpc(self::paper_faithful));
flight_sim::generated_kalman!(struct PaperKalman(self::paper));
// `specs/paper-offset-free.toml`, as the library of this crate already generates it.
use mpc_tests::offset_free;
flight_sim::mpc_controller!(struct OffsetFreeMpc(self::offset_free), disturbance);

/// Seeds of the noisy flights.
const SEEDS: [u64; 3] = [1, 2, 3];
/// 40 s of the reference flight: take-off and climb, the square with its four sharp corners, the
/// climbing diagonal and its reversal.
const FLIGHT_S: f64 = 40.0;

fn pid(x0: &[f64; 6]) -> PidController<PaperKalman> {
    PidController::new(Pid::paper(), PaperKalman::new(x0))
}

/// Table 2 of `controller` on `reference` under `scenario`, and the Y errors per cycle.
fn flown<C: Controller, R: Reference>(
    controller: C,
    reference: &R,
    scenario: &Scenario,
) -> (flight_sim::metrics::Table2, Vec<f64>) {
    flown_with(
        controller,
        reference,
        scenario,
        &mut Disturbance::NONE.clone(),
    )
}

/// As [`flown`], with the disturbance model `extra` (a wind) added.
fn flown_with<C: Controller, R: Reference>(
    mut controller: C,
    reference: &R,
    scenario: &Scenario,
    extra: &mut dyn DisturbanceModel,
) -> (flight_sim::metrics::Table2, Vec<f64>) {
    let mut m = Tracking::new(DT);
    let mut y = Vec::with_capacity(scenario.cycles);
    fly_with(&mut controller, reference, scenario, extra, |s, _| {
        m.push(s.t, &s.error(), &s.command);
        y.push(s.error()[1]);
    });
    (m.finish(), y)
}

#[test]
fn without_noise_both_mpcs_track_far_better_than_the_pid_on_every_axis() {
    let r = Trajectory::paper();
    let x0 = r.start();
    let s = Scenario {
        noise: NoiseConfig::NONE,
        ..Scenario::new(0, Scenario::cycles_for(FLIGHT_S))
    };
    let (p, _) = flown(pid(&x0), &r, &s);
    let (m, _) = flown(PaperMpc::new(&x0), &r, &s);
    let (f, _) = flown(FaithfulMpc::new(&x0), &r, &s);
    for axis in 0..3 {
        for (name, t) in [("mpc", m), ("mpc-faithful", f)] {
            let ratio = t.rmse[axis] / p.rmse[axis];
            assert!(ratio < 0.5, "{name} / pid RMSE on axis {axis}: {ratio}");
            let ratio = t.max_abs_error[axis] / p.max_abs_error[axis];
            assert!(
                ratio < 0.8,
                "{name} / pid max error on axis {axis}: {ratio}"
            );
        }
    }
}

#[test]
fn with_noise_the_mpc_beats_the_pid_where_the_trajectory_turns() {
    // On x and y (the square's corners and the reversal) the MPC's preview wins on every seed
    // (seeds 1-40 seen: RMSE ratio at most 0.85, max-error ratio at most 0.80).
    // On z the reference is smooth and the error is the filter's noise-driven error, where the
    // PID's large derivative gain does as well or better: no order is asserted there (a finding
    // reported in SIMULATION.md, not a property).
    let r = Trajectory::paper();
    let x0 = r.start();
    for seed in SEEDS {
        let s = Scenario::new(seed, Scenario::cycles_for(FLIGHT_S));
        let (p, _) = flown(pid(&x0), &r, &s);
        let (m, _) = flown(PaperMpc::new(&x0), &r, &s);
        for axis in 0..2 {
            let ratio = m.rmse[axis] / p.rmse[axis];
            assert!(
                ratio < 0.9,
                "seed {seed}, axis {axis}: mpc / pid RMSE {ratio}"
            );
            let ratio = m.max_abs_error[axis] / p.max_abs_error[axis];
            assert!(
                ratio < 0.8,
                "seed {seed}, axis {axis}: mpc / pid max error {ratio}"
            );
        }
        // Every figure is finite and the command stays in its bounds.
        for axis in 0..3 {
            assert!(m.rmse[axis].is_finite() && p.rmse[axis].is_finite());
        }
    }
}

#[test]
fn the_gust_stays_bounded_and_the_mpc_recovers() {
    let r = Trajectory::paper();
    let x0 = r.start();
    for seed in SEEDS {
        let calm = Scenario::new(seed, Scenario::cycles_for(55.0));
        let gusty = Scenario {
            disturbance: Disturbance::GUST,
            ..calm
        };
        let (calm_t, y_calm) = flown(PaperMpc::new(&x0), &r, &calm);
        let (gust_t, y_gust) = flown(PaperMpc::new(&x0), &r, &gusty);
        let g = gust(
            DT,
            &y_gust,
            &y_calm,
            Disturbance::GUST.start,
            Disturbance::GUST.end,
        );
        // Bounded: a constant 0.6 m/s² push moves the drone by metres, not by 0.5·a·t² = 67 m.
        assert!(
            gust_t.max_abs_error[1] < 5.0,
            "seed {seed}: {}",
            gust_t.max_abs_error[1]
        );
        // The gust is felt: the Y error while it blows is well above the calm error ...
        assert!(g.rmse_y_during > 3.0 * calm_t.rmse[1], "seed {seed}: {g:?}");
        // ... and it dies out within 10 s of the gust's end, back to the calm level (seeds 1-40
        // seen: recovery at most 7.2 s, error after recovery at most 1.8 times the calm one).
        let recovery = g.recovery_time.expect("recovers");
        assert!(recovery < 10.0, "seed {seed}: {recovery}");
        assert!(
            g.rmse_y_after.unwrap() < 2.0 * calm_t.rmse[1],
            "seed {seed}: {g:?}"
        );
        // X and Z do not feel a Y gust beyond the noise.
        for axis in [0, 2] {
            let ratio = gust_t.rmse[axis] / calm_t.rmse[axis];
            assert!(
                (0.8..1.25).contains(&ratio),
                "seed {seed}, axis {axis}: {ratio}"
            );
        }
    }
}

#[test]
fn step_responses_settle_and_the_mpc_overshoots_less() {
    let s = Step::paper();
    let x0 = s.state(0);
    let scenario = Scenario {
        noise: NoiseConfig::NONE,
        ..Scenario::new(0, Scenario::cycles_for(s.at + 20.0))
    };
    let metrics = |c: &mut dyn FnMut(&mut [StepResponse; 3])| {
        let mut r: [StepResponse; 3] =
            core::array::from_fn(|i| StepResponse::new(s.origin[i], s.size[i], s.at));
        c(&mut r);
        r.map(|r| r.finish())
    };
    let mpc = metrics(&mut |r| {
        fly(&mut PaperMpc::new(&x0), &s, &scenario, |x, _| {
            for (i, r) in r.iter_mut().enumerate() {
                r.push(x.t, x.state[i]);
            }
        });
    });
    let pid = metrics(&mut |r| {
        fly(&mut pid(&x0), &s, &scenario, |x, _| {
            for (i, r) in r.iter_mut().enumerate() {
                r.push(x.t, x.state[i]);
            }
        });
    });
    for axis in 0..3 {
        let (m, p) = (mpc[axis], pid[axis]);
        assert!(
            m.settling_time.is_some() && p.settling_time.is_some(),
            "{m:?} {p:?}"
        );
        assert!(
            m.overshoot_pct < p.overshoot_pct,
            "axis {axis}: {m:?} vs {p:?}"
        );
        assert!(
            m.settling_time < p.settling_time,
            "axis {axis}: {m:?} vs {p:?}"
        );
        assert!(m.rise_time < p.rise_time, "axis {axis}: {m:?} vs {p:?}");
    }
}

#[test]
fn the_offset_free_adapter_steps_exactly_as_the_generated_controller() {
    // `mpc_controller!(…, disturbance)` hands the filter's disturbance estimate to the MPC as the
    // module's `Controller::step` does: the same bits on a 20 s flight through the gust.
    let r = Trajectory::paper();
    let x0 = r.start();
    let mut adapter = OffsetFreeMpc::new(&x0);
    let mut generated = offset_free::Controller::new(flight_sim::cast(&x0));
    let s = Scenario {
        disturbance: Disturbance {
            accel: [0.0, 0.6, 0.0],
            start: 5.0,
            end: 20.0,
        },
        ..Scenario::new(5, Scenario::cycles_for(20.0))
    };
    let mut estimate_moved = false;
    fly(&mut adapter, &r, &s, |sample, a| {
        let z: [offset_free::Real; 3] = flight_sim::cast(&sample.measurement);
        let xref = r.window::<offset_free::Real, { offset_free::N }>(sample.k);
        let u = generated.step(&z, &xref);
        assert_eq!(
            flight_sim::cast::<_, f64, 3>(&u),
            sample.command,
            "cycle {}",
            sample.k
        );
        assert_eq!(a.last_disturbance(), generated.kalman().disturbance());
        estimate_moved |= a.last_disturbance()[1] > 0.3;
    });
    assert!(estimate_moved, "the estimate found the push on Y");
}

#[test]
fn the_offset_free_mpc_holds_the_reference_in_the_gust() {
    // The paper's gust (0.6 m/s² on Y from 20 s to 35 s) on the flight with the default noise: the
    // plain MPC holds about 1.5 m, the offset-free one stays at its noise level (seeds 1-50 of the
    // `paper` binary: 1.495 ± 0.040 m against 0.064 ± 0.009 m). Asserted with a wide margin: a
    // tenth of the plain MPC's error, and under 0.1 m, on every seed; the effect of the gust back
    // under 0.1 m while it still blows, which the plain MPC never manages.
    let r = Trajectory::paper();
    let x0 = r.start();
    let g = Disturbance::GUST;
    let mut calm_ms = [0.0; 2];
    for seed in SEEDS {
        let calm = Scenario::new(seed, Scenario::cycles_for(45.0));
        let gusty = Scenario {
            disturbance: g,
            ..calm
        };
        let (plain_calm, plain_y_calm) = flown(PaperMpc::new(&x0), &r, &calm);
        let (_, plain_y_gust) = flown(PaperMpc::new(&x0), &r, &gusty);
        let (free_calm, free_y_calm) = flown(OffsetFreeMpc::new(&x0), &r, &calm);
        let (_, free_y_gust) = flown(OffsetFreeMpc::new(&x0), &r, &gusty);
        let plain = gust(DT, &plain_y_gust, &plain_y_calm, g.start, g.end);
        let free = gust(DT, &free_y_gust, &free_y_calm, g.start, g.end);
        assert!(
            free.rmse_y_during < 0.1 * plain.rmse_y_during && free.rmse_y_during < 0.1,
            "seed {seed}: offset-free {} m, plain {} m",
            free.rmse_y_during,
            plain.rmse_y_during
        );
        let plain = gust_settling(
            DT,
            &plain_y_gust,
            &plain_y_calm,
            g.start,
            g.end,
            SETTLE_BAND,
        );
        let free = gust_settling(DT, &free_y_gust, &free_y_calm, g.start, g.end, SETTLE_BAND);
        assert_eq!(plain.settle_after_onset, None, "seed {seed}: {plain:?}");
        // The disturbance estimate's time constant is 1.42 s: back under 0.1 m within 5 s (2.7 s).
        let onset = free.settle_after_onset.expect("settles during the gust");
        let end = free.settle_after_end.expect("settles after the gust");
        assert!(onset < 5.0 && end < 5.0, "seed {seed}: {free:?}");
        assert!(free.max_effect < 0.5 * plain.max_effect, "seed {seed}");
        for axis in 0..3 {
            calm_ms[0] += plain_calm.rmse[axis].powi(2);
            calm_ms[1] += free_calm.rmse[axis].powi(2);
        }
    }
    // Without wind it tracks no worse than the plain MPC (the budget: 1.1 times), on the
    // RMS over the seeds and axes: one seed and axis of a 45 s record is too noisy a figure (seeds
    // 1-40: from 0.6 to 1.25 times; over the three axes at most 1.08 times; the `paper` binary's
    // 111 s flights over 50 seeds: 0.83-0.85 times on every axis).
    let ratio = (calm_ms[1] / calm_ms[0]).sqrt();
    assert!(
        ratio <= 1.1,
        "offset-free / plain RMSE without wind: {ratio}"
    );
}

#[test]
fn the_offset_free_mpc_rides_out_the_wind() {
    // The wind scenario (6 m/s with Dryden-like turbulence from 20 s): over 20-45 s the plain MPC's
    // X and Y errors are held by the mean push and the slow gusts, the offset-free MPC's are not
    // (seeds 1-50 of the `paper` binary over 23-80 s: about 1 m against 0.065 m).
    let r = Trajectory::paper();
    let x0 = r.start();
    let config = Dryden::DEFAULT.config();
    for seed in SEEDS {
        let s = Scenario::new(seed, Scenario::cycles_for(45.0));
        let (plain, _) = flown_with(PaperMpc::new(&x0), &r, &s, &mut Wind::new(seed, config));
        let (free, _) = flown_with(
            OffsetFreeMpc::new(&x0),
            &r,
            &s,
            &mut Wind::new(seed, config),
        );
        for axis in 0..2 {
            let ratio = free.rmse[axis] / plain.rmse[axis];
            assert!(ratio < 0.3, "seed {seed}, axis {axis}: {ratio}");
        }
        assert!(free.rmse.iter().all(|e| *e < 0.1), "seed {seed}: {free:?}");
    }
}

#[test]
fn the_wind_is_what_its_documentation_says() {
    // The push the plant feels, as `fly_with` reports it (no noise, no control): zero outside the
    // window, and inside it the documented mean plus turbulence of the documented intensity. The
    // slow horizontal turbulence (τ = 11.2 s) needs long records: the mean and standard deviation
    // over 64 windows of 1000 s each (64 seeds), within 10 % of σ and of the mean.
    let long = Dryden {
        start: 0.0,
        end: f64::INFINITY,
        ..Dryden::DEFAULT
    };
    let c = long.config();
    struct Idle;
    impl Controller for Idle {
        fn step<R: Reference>(&mut self, _: usize, _: &[f64; 3], _: &R) -> [f64; 3] {
            [0.0; 3]
        }
        fn estimate(&self) -> [f64; 6] {
            [0.0; 6]
        }
    }
    let (mut sum, mut sum_sq, mut n) = ([0.0; 3], [0.0; 3], 0.0);
    for seed in 0..64 {
        let s = Scenario {
            noise: NoiseConfig::NONE,
            ..Scenario::new(seed, Scenario::cycles_for(1000.0))
        };
        fly_with(
            &mut Idle,
            &flight_sim::Hover([0.0; 3]),
            &s,
            &mut Wind::new(seed, c),
            |x, _| {
                for i in 0..3 {
                    sum[i] += x.disturbance[i];
                    sum_sq[i] += x.disturbance[i] * x.disturbance[i];
                }
                n += 1.0;
            },
        );
    }
    for i in 0..3 {
        let mean = sum[i] / n;
        let sigma = (sum_sq[i] / n - mean * mean).sqrt();
        println!(
            "axis {i}: mean {mean:.4} (stated {}), σ {sigma:.4} (stated {:.4})",
            c.mean[i], c.sigma[i]
        );
        assert!(
            (mean - c.mean[i]).abs() < 0.1 * c.sigma[i].max(c.mean[i].abs()),
            "axis {i}: mean {mean}"
        );
        assert!(
            (sigma / c.sigma[i] - 1.0).abs() < 0.1,
            "axis {i}: σ {sigma} vs {}",
            c.sigma[i]
        );
    }
    // The window: nothing before the onset or from the end on.
    let short = Dryden::DEFAULT;
    let s = Scenario {
        noise: NoiseConfig::NONE,
        ..Scenario::new(1, Scenario::cycles_for(short.end + 1.0))
    };
    fly_with(
        &mut Idle,
        &flight_sim::Hover([0.0; 3]),
        &s,
        &mut Wind::new(1, short.config()),
        |x, _| {
            let blows = x.t >= short.start && x.t < short.end;
            assert_eq!(x.disturbance == [0.0; 3], !blows, "t = {}", x.t);
        },
    );
}
