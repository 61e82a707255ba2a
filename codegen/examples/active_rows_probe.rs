//! `cargo run --release -p codegen --example active_rows_probe -- SPEC [DRAWS]`: which constraints the dual
//! active-set method's optimum ever holds active over `[mpc.region]` (issue 33, rows pruned by proof): the
//! kernel run cold on DRAWS parameters (default 16,384; every fourth a corner of the whole parameter box,
//! the others uniform), counting the bounds and rows of A found in a final working set. A row never seen
//! is a candidate for pruning, not a proof; it also prints how many rows the build's proof drops
//! (`codegen::solver::active_set::slack_rows`: no plan within the bounds violates them anywhere in the box).
mod probe;

use codegen::solver::active_set::{solve, Row};
use rand::{Rng, SeedableRng};
use std::collections::BTreeSet;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let draws: usize = args.get(2).map_or(1 << 14, |s| s.parse().expect("DRAWS"));
    // No LP: only the parameters each block depends on.
    let (p, prepared, count, region) = probe::setup(&args[1]);
    let parameters = &count.parameters;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let mut rows = BTreeSet::new();
    let mut bounds = BTreeSet::new();
    for k in 0..draws {
        let mut theta = parameters.centre();
        for (j, t) in theta.iter_mut().enumerate() {
            let (lo, hi) = (parameters.lo[j], parameters.hi[j]);
            if lo < hi {
                *t = if k % 4 == 0 {
                    if rng.gen_bool(0.5) {
                        lo
                    } else {
                        hi
                    }
                } else {
                    rng.gen_range(lo..hi)
                };
            }
        }
        let offsets = prepared
            .offsets(&parameters.qp(&p, &theta))
            .expect("finite offsets");
        let outcome = solve(&prepared, &offsets, None, 100_000);
        for a in &outcome.working_set.0 {
            match a.row {
                Row::General(r) => {
                    rows.insert(r);
                }
                Row::Bound(i) => {
                    bounds.insert(i);
                }
            }
        }
    }
    println!(
        "rows redundant by intervals over the box: {}",
        codegen::solver::active_set::slack_rows::slack_rows(&p, &region).len()
    );
    println!(
        "n {} m {}: bounds ever active {} , rows ever active {} of {}",
        prepared.n,
        prepared.m,
        bounds.len(),
        rows.len(),
        prepared.m
    );
}
