//! Host time per solve, DAQP against the generated solver on the same dumped QPs, each replaying its
//! problem's 100 closed-loop states in order (warm/hot-started from the previous solve; the replay
//! restarts cold after the last state).
//!
//! `scripts/peers.sh bench -- --warm-up-time 1 --measurement-time 3`
//! (= `cd peers && cargo bench --bench peers -- ...`)

use criterion::{criterion_group, criterion_main, Criterion};
use peers::{for_each_problem, replay_daqp, Outcome, Timing};
use std::time::{Duration, Instant};

/// Sums the time of the solves alone (DAQP's setup, the conversions and the accuracy check outside).
struct Summed(Duration);

impl Timing for Summed {
    fn time(&mut self, solve: &mut dyn FnMut()) -> u64 {
        let t0 = Instant::now();
        solve();
        self.0 += t0.elapsed();
        0
    }
}

fn peers(c: &mut Criterion) {
    for_each_problem!(p => {
        let mut group = c.benchmark_group(p::NAME);
        // One "element" is one solve: criterion's throughput line is then solves per second.
        group.throughput(criterion::Throughput::Elements(p::STEPS as u64));
        group.bench_function("generated", |b| {
            b.iter_custom(|iters| {
                let mut clock = Summed(Duration::ZERO);
                for _ in 0..iters {
                    p::ours(&mut clock, &mut Outcome::new());
                }
                clock.0
            })
        });
        group.bench_function("daqp", |b| {
            b.iter_custom(|iters| {
                let mut clock = Summed(Duration::ZERO);
                for _ in 0..iters {
                    replay_daqp(&p::data(), &mut clock, &mut Outcome::new()).expect("DAQP sets up");
                }
                clock.0
            })
        });
        group.finish();
    });
}

criterion_group!(benches, peers);
criterion_main!(benches);
