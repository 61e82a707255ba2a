//! The trade-off of `[kalman] disturbance` on the paper's flight: for each value, the mean over
//! seeds 1-10 (default noise) of the RMSE without wind, the Y RMSE during the paper's gust (from
//! 3 s after onset) and during the wind scenario, and the command's smoothness and variance, next
//! to the plain MPC of `specs/paper.toml`.

use flight_sim::metrics::{gust, Tracking};
use flight_sim::{
    fly_with, Controller, Disturbance, Dryden, Scenario, Trajectory, Wind, WindConfig, DT,
};

mpc_macros::mpc!(mod plain = "../../../specs/paper.toml");
mpc_macros::mpc!(mod d0_0025 = "specs/d0_0025.toml");
mpc_macros::mpc!(mod d0_005 = "specs/d0_005.toml");
mpc_macros::mpc!(mod d0_01 = "specs/d0_01.toml");
mpc_macros::mpc!(mod d0_02 = "specs/d0_02.toml");
mpc_macros::mpc!(mod d0_04 = "specs/d0_04.toml");
flight_sim::mpc_controller!(struct Plain(self::plain));
flight_sim::mpc_controller!(struct D1(self::d0_0025), disturbance);
flight_sim::mpc_controller!(struct D2(self::d0_005), disturbance);
flight_sim::mpc_controller!(struct D3(self::d0_01), disturbance);
flight_sim::mpc_controller!(struct D4(self::d0_02), disturbance);
flight_sim::mpc_controller!(struct D5(self::d0_04), disturbance);

const SEEDS: u64 = 10;

fn row<C: Controller>(make: &dyn Fn() -> C, name: &str, tau: Option<f64>) {
    let r = Trajectory::paper();
    let n = SEEDS as f64;
    let (mut rmse, mut smooth, mut var, mut held, mut wind) =
        ([0.0; 3], [0.0; 3], [0.0; 3], 0.0, 0.0);
    for seed in 1..=SEEDS {
        let calm = Scenario::new(seed, Scenario::cycles_for(111.0));
        let run = |s: &Scenario, w: WindConfig| {
            let mut m = Tracking::new(DT);
            let mut y = Vec::with_capacity(s.cycles);
            fly_with(&mut make(), &r, s, &mut Wind::new(seed, w), |x, _| {
                m.push(x.t, &x.error(), &x.command);
                y.push(x.error()[1]);
            });
            (m.finish(), y)
        };
        let (t, y_calm) = run(&calm, WindConfig::NONE);
        let gusty = Scenario {
            disturbance: Disturbance::GUST,
            ..calm
        };
        let (_, y_gust) = run(&gusty, WindConfig::NONE);
        let d = Dryden::DEFAULT;
        let (_, y_wind) = run(&calm, d.config());
        for i in 0..3 {
            rmse[i] += t.rmse[i] / n;
            smooth[i] += t.smoothness[i] / n;
            var[i] += t.variance[i] / n;
        }
        let g = Disturbance::GUST;
        held += gust(DT, &y_gust, &y_calm, g.start, g.end).rmse_y_during / n;
        wind += gust(DT, &y_wind, &y_calm, d.start, d.end).rmse_y_during / n;
    }
    println!(
        "| {name} | {} | [{:.3}, {:.3}, {:.3}] | {held:.3} | {wind:.3} | [{:.1}, {:.1}, {:.1}] | [{:.2}, {:.2}, {:.2}] |",
        tau.map_or("—".into(), |t| format!("{t:.2}")),
        rmse[0], rmse[1], rmse[2], smooth[0], smooth[1], smooth[2], var[0], var[1], var[2]
    );
}

fn main() {
    let x0 = Trajectory::paper().start();
    println!("Seeds 1-{SEEDS}, GPS σ = 0.3 m, acceleration noise σ = 0.5 m/s², flight 111 s; means over the seeds.\n");
    println!("| `disturbance` (m/s² per step) | τ of the estimate (s) | RMSE without wind [x, y, z] (m) | Y RMSE during the gust (m) | Y RMSE in the wind (m) | smoothness (m/s³) | control variance ((m/s²)²) |");
    println!("|---|---|---|---|---|---|---|");
    row(&|| Plain::new(&x0), "none (`paper.toml`)", None);
    row(&|| D1::new(&x0), "0.0025", d0_0025::report::DISTURBANCE_TIME_CONSTANT);
    row(&|| D2::new(&x0), "0.005", d0_005::report::DISTURBANCE_TIME_CONSTANT);
    row(&|| D3::new(&x0), "0.01 (shipped)", d0_01::report::DISTURBANCE_TIME_CONSTANT);
    row(&|| D4::new(&x0), "0.02", d0_02::report::DISTURBANCE_TIME_CONSTANT);
    row(&|| D5::new(&x0), "0.04", d0_04::report::DISTURBANCE_TIME_CONSTANT);
}
