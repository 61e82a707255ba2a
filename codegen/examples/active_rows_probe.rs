//! `cargo run --release -p codegen --example active_rows_probe -- SPEC [DRAWS]`: which constraints the dual
//! active-set method's optimum ever holds active over `[mpc.region]` (issue 33, rows pruned by proof): the
//! kernel run cold on DRAWS parameters (default 16,384; every fourth a corner of the whole parameter box,
//! the others uniform), counting the bounds and rows of A found in a final working set. A row never seen
//! is a candidate for pruning, not a proof; it also prints how many rows interval arithmetic proves
//! redundant over the box (no plan within the bounds violates them at any parameter), which is one.
mod probe;

use codegen::solver::active_set::{solve, Row};
use rand::{Rng, SeedableRng};
use std::collections::BTreeSet;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let draws: usize = args.get(2).map_or(1 << 14, |s| s.parse().expect("DRAWS"));
    // No LP: only the parameters each block depends on.
    let (p, prepared, count) = probe::setup(&args[1]);
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
        redundant_rows(&p, parameters)
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

/// Rows of A that no plan within the bounds can violate anywhere in the parameter box (interval
/// arithmetic over the bounds and the sides' slopes in θ): a proof that the row can be dropped there.
fn redundant_rows(
    p: &codegen::Problem,
    parameters: &codegen::solver::active_set::exact::Parameters,
) -> usize {
    let centre = parameters.centre();
    let q0 = parameters.qp(p, &centre);
    let m = q0.A.nrows();
    let n = q0.A.ncols();
    let np = centre.len();
    let unit: Vec<_> = (0..np)
        .map(|j| {
            let mut t = centre.clone();
            t[j] = parameters.hi[j];
            parameters.qp(p, &t)
        })
        .collect();
    let bounds_move = unit
        .iter()
        .any(|q| (0..n).any(|i| q.z_min[i] != q0.z_min[i] || q.z_max[i] != q0.z_max[i]));
    if bounds_move {
        println!("bounds move with θ");
        return 0;
    }
    let mut redundant = 0;
    for r in 0..m {
        let (mut lo, mut hi) = (0.0f64, 0.0f64);
        for j in 0..n {
            let a = q0.A[(r, j)];
            if a == 0.0 {
                continue;
            }
            let (x, y) = (a * q0.z_min[j], a * q0.z_max[j]);
            lo += x.min(y);
            hi += x.max(y);
        }
        // sides: min over θ of upper, max of lower
        let mut up = q0.upper[r];
        let mut low = q0.lower[r];
        for u in &unit {
            up -= (u.upper[r] - q0.upper[r]).abs();
            low += (u.lower[r] - q0.lower[r]).abs();
        }
        let up_ok = !q0.upper[r].is_finite() || hi <= up;
        let lo_ok = !q0.lower[r].is_finite() || lo >= low;
        if up_ok && lo_ok {
            redundant += 1;
        }
    }
    redundant
}
