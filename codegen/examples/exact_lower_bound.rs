//! `cargo run --release -p codegen --example exact_lower_bound -- SPEC DRAWS [BLOCK]`: a lower bound on
//! the number of regions of the exact count's partition of block BLOCK (default 0), independent of the
//! partition: the kernel run cold on DRAWS parameters drawn uniformly over the block's parameters (the
//! others at the centre), counting the distinct (changes of the working set, final working set) pairs. Two
//! parameters with different pairs lie in different regions, so the partition has at least as many regions
//! as pairs seen (BENCHMARKS.md, "The exact count"). It prints the count at every power of two, and the
//! most changes seen.
mod probe;

use codegen::solver::active_set::solve;
use rand::{Rng, SeedableRng};
use std::collections::HashSet;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let draws: usize = args.get(2).map_or(1 << 16, |s| s.parse().expect("DRAWS"));
    let block: usize = args.get(3).map_or(0, |s| s.parse().expect("BLOCK"));
    // No LP: only the parameters each block depends on.
    let (p, prepared, count, _) = probe::setup(&args[1]);
    let parameters = &count.parameters;
    let used = &count.blocks[block].parameters;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let mut seen: HashSet<(usize, Vec<String>)> = HashSet::new();
    let mut worst = 0;
    for k in 1..=draws {
        let mut theta = parameters.centre();
        for &j in used {
            let (lo, hi) = (parameters.lo[j], parameters.hi[j]);
            if lo < hi {
                theta[j] = rng.gen_range(lo..hi);
            }
        }
        let offsets = prepared
            .offsets(&parameters.qp(&p, &theta))
            .expect("finite offsets");
        let outcome = solve(&prepared, &offsets, None, 100_000);
        // The other blocks' parameters are fixed, so the whole final set tells this block's apart.
        let mut set: Vec<String> = outcome
            .working_set
            .0
            .iter()
            .map(|a| format!("{a:?}"))
            .collect();
        set.sort();
        let changes = outcome.block_iterations[block];
        worst = worst.max(changes);
        seen.insert((changes, set));
        if k.is_power_of_two() && k >= 1024 {
            println!(
                "{k} draws: {} distinct pairs, most changes {worst}",
                seen.len()
            );
        }
    }
    println!(
        "block {block} ({} parameters): at least {} regions; most changes seen {worst}",
        used.len(),
        seen.len()
    );
}
