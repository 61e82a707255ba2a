//! Host replay of every dumped problem through DAQP and the generated solvers (the spec's own method and
//! the active set): DAQP's iterations per
//! solve and each side's |U − U*|∞ against the exact solution (`mpcc dump-qp`'s z*), as a table.
//! Exits 1 if a DAQP solve did not end optimal.
//!
//! `scripts/peers.sh accuracy` (= `cd peers && cargo run --release --bin accuracy`)

use peers::{for_each_problem, replay_daqp, Outcome, Timing};
use std::time::Instant;

/// Nanoseconds per solve.
struct Clock;

impl Timing for Clock {
    fn time(&mut self, solve: &mut dyn FnMut()) -> u64 {
        let t0 = Instant::now();
        solve();
        t0.elapsed().as_nanos() as u64
    }
}

fn row(problem: &str, solver: &str, o: &Outcome) {
    let [i0, i50, i99, i100] = o.iteration_quantiles();
    let [t0, t50, t99, t100] = o.tick_quantiles();
    let [_, f50, _, f100] = o.form_quantiles();
    let (e50, e100) = o.error_median_max();
    println!(
        "| {problem} | {solver} | {} | {i0} / {i50} / {i99} / {i100} | {:.1} / {:.1} / {:.1} / {:.1} | {:.2} / {:.2} | {e50:.1e} / {e100:.1e} | {} |",
        o.count,
        t0 as f64 / 1e3,
        t50 as f64 / 1e3,
        t99 as f64 / 1e3,
        t100 as f64 / 1e3,
        f50 as f64 / 1e3,
        f100 as f64 / 1e3,
        o.failures
    );
}

fn main() {
    println!("| problem | solver | solves | iterations (min / median / p99 / max) | µs per solve, one pass (min / median / p99 / max) | of which forming f and the bounds (median / max) | \\|U − U*\\|∞ (median / max) | not optimal |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut failed = false;
    for_each_problem!(p => {
        #[cfg(feature = "ours")]
        {
            let mut ours = Outcome::new();
            p::ours(&mut Clock, &mut ours);
            row(p::NAME, "generated", &ours);
        }
        #[cfg(feature = "active_set")]
        {
            let mut ours = Outcome::new();
            p::active_set(&mut Clock, &mut ours);
            row(p::NAME, "generated active set", &ours);
        }
        let mut daqp = Outcome::new();
        if replay_daqp(&p::data(), &mut Clock, &mut daqp).is_none() {
            println!("| {} | DAQP | setup failed | | | | | |", p::NAME);
            failed = true;
        } else {
            row(p::NAME, "DAQP (hot start)", &daqp);
            failed |= daqp.failures > 0;
        }
    });
    std::process::exit(i32::from(failed));
}
