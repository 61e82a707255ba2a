//! The AFTI-16 aircraft of `specs/afti16.toml` (continuous time, open-loop unstable) in closed loop on
//! `flight_sim::fly_linear`: the generated controller commands the elevator and the flaperon to hold the
//! angle of attack at 0° and take the pitch angle from 0° to 10° at t = 1 s, with the spec's own
//! measurement and process noise. Prints the response every 0.5 s and the step metrics of both outputs,
//! and exits non-zero unless the pitch angle settles within 2 % of its 10° step and the commands stay
//! inside ±25°.

use codegen::linalg::array;
use flight_sim::{fly_linear, lower_factor, LinearNoiseConfig, LinearPlant, LinearScenario};
use generated_examples::afti16::{self, CZ, DT, NU, NX, NY, NZ};

flight_sim::linear_mpc_controller!(struct Aircraft(afti16), filter, NZ);

fn main() {
    // The plant in f64 from the spec: the compiler's own zero-order-hold sampling and Van Loan covariance.
    let spec = mpc_spec::load(include_str!("../../../specs/afti16.toml")).expect("the spec loads");
    let p = codegen::lower(&spec).expect("the spec lowers");
    let filter = p.filter.as_ref().expect("the spec has a filter");
    let mut plant =
        LinearPlant::<NX, NU, NY>::new(array(&p.F), array(&p.G), array(&p.C), [0.0; NX]);
    let scenario = LinearScenario {
        seed: 1,
        cycles: (10.0 / DT) as usize,
        dt: DT,
        noise: LinearNoiseConfig {
            process_factor: Some(lower_factor(&array(&filter.Qn)).expect("Q_d is a covariance")),
            measurement_sigma: core::array::from_fn(|i| filter.Rn[(i, i)].sqrt()),
        },
    };
    // Angle of attack held at 0°, pitch angle 0° → 10° at t = 1 s.
    let reference = |t: f64| -> [f64; NZ] { [0.0, if t < 1.0 { 0.0 } else { 10.0 }] };
    let mut aircraft = Aircraft::new(&[0.0; NX]);
    let mut worst_command = 0.0_f64;
    println!("   t [s]   attack [°]   pitch [°]   elevator [°]   flaperon [°]");
    let report = fly_linear(
        &mut plant,
        &mut aircraft,
        &reference,
        &CZ,
        &scenario,
        |_| [0.0; NU],
        |s, _| {
            worst_command = s.command.iter().fold(worst_command, |w, u| w.max(u.abs()));
            if s.k % 10 == 0 {
                println!(
                    "{:8.2} {:12.3} {:11.3} {:14.3} {:14.3}",
                    s.t, s.tracked[0], s.tracked[1], s.command[0], s.command[1]
                );
            }
        },
    );
    let pitch = report.step[1];
    let seconds = |t: Option<f64>| t.map_or("never".to_string(), |t| format!("{t:.2} s"));
    println!();
    println!(
        "pitch (times from t = 0): rise {}, overshoot {:.1} %, settling within 2 % {}; attack: max |error| {:.3}°",
        seconds(pitch.rise_time),
        pitch.overshoot_pct,
        seconds(pitch.settling_time),
        report.table2.max_abs_error[0]
    );
    println!(
        "largest command {worst_command:.2}° (limit 25°), rejected readings {}",
        report.rejected_measurements
    );
    // The step is measured from t = 0; the reference moves at t = 1 s.
    let settled = pitch.settling_time.is_some_and(|t| t < 10.0);
    if !settled || worst_command > 25.0 {
        eprintln!("afti16: the pitch angle did not settle, or a command left the box");
        std::process::exit(1);
    }
}
