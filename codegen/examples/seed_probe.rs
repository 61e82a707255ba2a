//! `cargo run --release -p codegen --example seed_probe -- SPEC [GRID] [DRAWS]`: issue 33's "seed the cold
//! solve with a working set precomputed at build time", measured before it is built. Per block, the
//! optimal working set at each point of a GRID^p grid over the block's p parameters (default 3) is
//! tabulated; DRAWS cold cases (default 2,000; every fourth at a corner of the parameter box, the others
//! uniform) are solved by the kernel cold and from the table's set at the nearest grid point, the two
//! optima checked equal, and the worst and mean changes and work of each printed with the table's size
//! (BENCHMARKS.md, "Seeding the cold solve").
mod probe;

use codegen::solver::active_set::{solve, WorkingSet};
use rand::{Rng, SeedableRng};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let g: usize = args.get(2).map_or(3, |s| s.parse().unwrap());
    let draws: usize = args.get(3).map_or(2000, |s| s.parse().unwrap());
    // No LP: only the parameters each block depends on.
    let (p, prepared, count, _) = probe::setup(&args[1]);
    let par = &count.parameters;
    let nb = count.blocks.len();
    // Per block, the seed table over its parameters.
    let cell = |theta: &[f64], used: &[usize]| -> usize {
        let mut idx = 0;
        for &j in used.iter().rev() {
            let (lo, hi) = (par.lo[j], par.hi[j]);
            let t = if hi > lo {
                (theta[j] - lo) / (hi - lo)
            } else {
                0.5
            };
            let i = ((t * (g - 1) as f64).round().max(0.0) as usize).min(g - 1);
            idx = idx * g + i;
        }
        idx
    };
    for (b, block) in count.blocks.iter().enumerate() {
        let cells = (g as f64).powi(block.parameters.len() as i32);
        if cells > 1e5 {
            println!(
                "block {b} has {} parameters: a grid of {g} a parameter is {cells:.1e} cells, not tabulated",
                block.parameters.len()
            );
            return;
        }
    }
    let mut tables: Vec<Vec<WorkingSet>> = Vec::new();
    for b in 0..nb {
        let used = &count.blocks[b].parameters;
        let cells = g.pow(used.len() as u32);
        let mut table = Vec::new();
        for c in 0..cells {
            let mut theta = par.centre();
            let mut rest = c;
            for &j in used {
                let i = rest % g;
                rest /= g;
                theta[j] = par.lo[j] + (par.hi[j] - par.lo[j]) * i as f64 / (g - 1) as f64;
            }
            let off = prepared.offsets(&par.qp(&p, &theta)).unwrap();
            let o = solve(&prepared, &off, None, 100_000);
            // keep only this block's entries
            let set = o.working_set.filter_map(|a| {
                let idx = match a.row {
                    codegen::solver::active_set::Row::Bound(i) => i,
                    codegen::solver::active_set::Row::General(r) => prepared.n + r,
                };
                (prepared.place[idx].map(|(bb, _)| bb) == Some(b)).then_some(a)
            });
            table.push(set);
        }
        tables.push(table);
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let (mut cold_w, mut seed_w, mut cold_k, mut seed_k) = (0usize, 0usize, 0usize, 0usize);
    let (mut cold_sum, mut seed_sum) = (0usize, 0usize);
    for k in 0..draws {
        let theta: Vec<f64> = (0..par.len())
            .map(|j| {
                let (lo, hi) = (par.lo[j], par.hi[j]);
                if hi <= lo {
                    lo
                } else if k % 4 == 0 {
                    if rng.gen_bool(0.5) {
                        lo
                    } else {
                        hi
                    }
                } else {
                    rng.gen_range(lo..hi)
                }
            })
            .collect();
        let off = prepared.offsets(&par.qp(&p, &theta)).unwrap();
        let cold = solve(&prepared, &off, None, 100_000);
        let mut seed = WorkingSet::default();
        for b in 0..nb {
            seed.0.extend(
                tables[b][cell(&theta, &count.blocks[b].parameters)]
                    .0
                    .iter()
                    .copied(),
            );
        }
        let seeded = solve(&prepared, &off, Some(&seed), 100_000);
        assert!((&cold.z - &seeded.z).amax() < 1e-6, "different optimum");
        cold_w = cold_w.max(cold.macs.work());
        seed_w = seed_w.max(seeded.macs.work());
        cold_k = cold_k.max(cold.iterations);
        seed_k = seed_k.max(seeded.iterations);
        cold_sum += cold.macs.work();
        seed_sum += seeded.macs.work();
    }
    println!("grid {g}: cold worst {cold_k} changes, work {cold_w} (mean {}); seeded worst {seed_k} changes, work {seed_w} (mean {}); table entries {}",
        cold_sum / draws, seed_sum / draws, tables.iter().map(|t| t.iter().map(|s| s.0.len()).sum::<usize>()).sum::<usize>());
}
