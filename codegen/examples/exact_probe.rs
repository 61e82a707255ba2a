//! `cargo run --release -p codegen --example exact_probe -- SPEC LPS`: the exact count's partition of
//! SPEC per block within LPS feasibility LPs per block, with its time (BENCHMARKS.md, "The exact count").
//! `DIMENSION=d` skips blocks of more than d coordinates; `SEPARATE=1` partitions over the parameters
//! apart, without combining those that act in parallel.
use codegen::solver::active_set::exact::{exact_count, Limits};
use codegen::solver::active_set::mpc::prepare;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let src = std::fs::read_to_string(&args[1]).expect("the spec");
    let lps: usize = args.get(2).map_or(200_000, |s| s.parse().expect("LPS"));
    let spec = mpc_spec::load(&src).expect("a valid spec");
    let p = codegen::lower(&spec).expect("lowers");
    let region = codegen::sampling::resolve_region(&spec, &p, "probe").expect("a region");
    let prepared = prepare(&p.qp).expect("prepared");
    let count = exact_count(
        &p,
        &prepared,
        &region,
        Limits {
            lps,
            dimension: std::env::var("DIMENSION").map_or(64, |d| d.parse().expect("DIMENSION")),
            combine: std::env::var("SEPARATE").is_err(),
        },
    );
    for (b, c) in count.blocks.iter().enumerate() {
        println!(
            "block {b}: {} parameters in {} coordinates ({}), {} regions ({} cycling, radius ≤ {:.1e}), worst {}, {} LPs ({} left to Clarabel), {:.2} s, complete {}",
            c.parameters.len(),
            c.coordinates.len(),
            c.coordinates
                .iter()
                .map(|k| k.name(&count.parameters.names))
                .collect::<Vec<_>>()
                .join(", "),
            c.pieces.len(),
            c.cycling,
            c.cycling_radius,
            c.worst,
            c.lps,
            c.lp_fallbacks,
            c.seconds,
            c.complete
        );
    }
    if std::env::var("CYCLES").is_ok() {
        for c in &count.blocks {
            for q in c
                .pieces
                .iter()
                .filter(|q| q.end == codegen::solver::active_set::exact::End::Cycles)
            {
                let theta = count.parameters.theta(&c.coordinates, &q.centre);
                let qp = count.parameters.qp(&p, &theta);
                let o = codegen::solver::active_set::solve(
                    &prepared,
                    &prepared.offsets(&qp).unwrap(),
                    None,
                    10_000,
                );
                println!(
                    "cycling at {:?} r {:.1e} after {}: kernel {:?} {:?}",
                    q.centre, q.radius, q.iterations, o.status, o.block_iterations
                );
            }
        }
    }
    println!(
        "total {:.2} s, worst {}, complete {}",
        count.seconds, count.worst, count.complete
    );
}
