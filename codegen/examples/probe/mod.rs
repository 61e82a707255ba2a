//! What the probes share: a spec read from a file, lowered, and its QP prepared for the dual active-set
//! kernel, with each block's parameters (the exact count's setup without its LPs).
use codegen::evidence::Region;
use codegen::solver::active_set::exact::{exact_count, ExactCount, Limits};
use codegen::solver::active_set::{mpc::prepare, Prepared};

/// The spec at `path`, lowered; its QP prepared; the exact count run without an LP, which gives θ's
/// box and the parameters each block depends on; and its region.
pub fn setup(path: &str) -> (codegen::Problem, Prepared, ExactCount, Region) {
    let src = std::fs::read_to_string(path).expect("the spec");
    let spec = mpc_spec::load(&src).expect("a valid spec");
    let p = codegen::lower(&spec).expect("lowers");
    let region = codegen::sampling::resolve_region(&spec, &p, "probe").expect("a region");
    let prepared = prepare(&p.qp).expect("prepared");
    let count = exact_count(
        &p,
        &prepared,
        &region,
        Limits {
            lps: 0,
            dimension: 64,
            combine: true,
        },
    );
    (p, prepared, count, region)
}
