use codegen::solver::active_set::exact::{exact_count, Limits};
use codegen::solver::active_set::{mpc::prepare, solve, Row};
use rand::{Rng, SeedableRng};
use std::collections::BTreeSet;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let src = std::fs::read_to_string(&args[1]).expect("the spec");
    let draws: usize = args.get(2).map_or(1 << 14, |s| s.parse().expect("DRAWS"));
    let spec = mpc_spec::load(&src).expect("a valid spec");
    let p = codegen::lower(&spec).expect("lowers");
    let region = codegen::sampling::resolve_region(&spec, &p, "probe").expect("a region");
    let prepared = prepare(&p.qp).expect("prepared");
    let count = exact_count(&p, &prepared, &region, Limits { lps: 0, dimension: 64 });
    let parameters = &count.parameters;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let mut rows = BTreeSet::new();
    let mut bounds = BTreeSet::new();
    for k in 0..draws {
        let mut theta = parameters.centre();
        for j in 0..theta.len() {
            let (lo, hi) = (parameters.lo[j], parameters.hi[j]);
            if lo < hi {
                theta[j] = if k % 4 == 0 { if rng.gen_bool(0.5) { lo } else { hi } } else { rng.gen_range(lo..hi) };
            }
        }
        let offsets = prepared.offsets(&parameters.qp(&p, &theta)).expect("finite offsets");
        let outcome = solve(&prepared, &offsets, None, 100_000);
        for a in &outcome.working_set.0 {
            match a.row { Row::General(r) => { rows.insert(r); } Row::Bound(i) => { bounds.insert(i); } }
        }
    }
    println!("n {} m {}: bounds ever active {} , rows ever active {} of {}", prepared.n, prepared.m, bounds.len(), rows.len(), prepared.m);
}
