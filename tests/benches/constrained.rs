//! The interior-point method on the constrained specs (issue 17; the quadcopter and hover as their copies
//! `tests/specs/ipm/`, since their `auto` picks the dual active set), per solve on the host: the generated
//! controller, the oracle (the same method over nalgebra) and Clarabel on the same QPs, over the states of
//! a warm closed loop on the nominal model (recorded once, replayed for every solver).
//!
//! `cargo bench -p mpc-tests --bench constrained -- --warm-up-time 1 --measurement-time 3`
#![allow(non_snake_case)]

use codegen::ipm::mpc_qp;
use codegen::oracle;
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use nalgebra::DVector;

#[allow(dead_code)]
#[path = "exact.rs"]
mod exact;

mpc_macros::mpc!(mod quadcopter = "specs/ipm/quadcopter.toml");
mpc_macros::mpc!(mod hover = "specs/ipm/hover.toml");
mpc_macros::mpc!(mod paper_limits = "../specs/paper-limits.toml");

/// 100 states of the oracle's closed loop on the nominal model, from `x0` towards `reference`.
fn trajectory(p: &codegen::Problem, x0: &[f64], reference: &[f64]) -> Vec<DVector<f64>> {
    let mut mpc = oracle::Mpc::new(p);
    let r = DVector::from_column_slice(reference);
    let window = vec![r; p.qp.N];
    let mut x = DVector::from_column_slice(x0);
    let mut out = Vec::new();
    for _ in 0..100 {
        out.push(x.clone());
        let u = mpc.solve(&x, &window);
        x = &p.F * &x + &p.G * u;
    }
    out
}

macro_rules! bench_spec {
    ($c:expr, $name:literal, $module:ident, $text:expr, $x0:expr, $reference:expr) => {{
        use $module as m;
        let p = codegen::lower(&mpc_spec::load($text).unwrap()).unwrap();
        let states = trajectory(&p, &$x0, &$reference);
        let mut xref = [[0.0; m::NX]; m::N];
        for row in xref.iter_mut() {
            row.copy_from_slice(&$reference);
        }
        let inputs: Vec<[f64; m::NX]> = states
            .iter()
            .map(|x| {
                let mut a = [0.0; m::NX];
                a.copy_from_slice(x.as_slice());
                a
            })
            .collect();
        let mut group = $c.benchmark_group($name);
        group.bench_function("generated (warm loop)", |b| {
            let mut mpc = m::Mpc::new();
            let mut i = 0;
            b.iter(|| {
                let u = mpc.solve(black_box(&inputs[i % inputs.len()]), &xref);
                i += 1;
                if i % inputs.len() == 0 {
                    mpc.reset();
                }
                u
            })
        });
        let window = vec![DVector::from_column_slice(&$reference); p.qp.N];
        group.bench_function("oracle (warm loop)", |b| {
            let mut mpc = oracle::Mpc::new(&p);
            let mut i = 0;
            b.iter(|| {
                let u = mpc.solve(black_box(&states[i % states.len()]), &window);
                i += 1;
                if i % states.len() == 0 {
                    mpc.reset();
                }
                u
            })
        });
        let mpc = oracle::Mpc::new(&p);
        let qps: Vec<_> = states
            .iter()
            .map(|x| {
                let f = mpc.linear_term(x, &window);
                let offset = p.qp.rows.offset(x, &DVector::zeros(0), mpc.last_input());
                mpc_qp(&p.qp, &f, &offset)
            })
            .collect();
        group.bench_function("clarabel (cold, to 1e-13)", |b| {
            let mut i = 0;
            b.iter(|| {
                let z = exact::clarabel(black_box(&qps[i % qps.len()]));
                i += 1;
                z
            })
        });
        group.finish();
    }};
}

fn constrained(c: &mut Criterion) {
    let mut quad_ref = [0.0; 12];
    quad_ref[2] = 1.0;
    bench_spec!(
        c,
        "quadcopter",
        quadcopter,
        include_str!("../specs/ipm/quadcopter.toml"),
        [0.0; 12],
        quad_ref
    );
    let mut hover_x0 = [0.0; 12];
    hover_x0[1] = 1.0;
    hover_x0[3] = 0.2;
    hover_x0[6] = 0.1;
    let mut hover_ref = [0.0; 12];
    hover_ref[2] = 2.0;
    bench_spec!(
        c,
        "hover",
        hover,
        include_str!("../specs/ipm/hover.toml"),
        hover_x0,
        hover_ref
    );
    bench_spec!(
        c,
        "paper-limits",
        paper_limits,
        include_str!("../../specs/paper-limits.toml"),
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [3.0, 2.0, 1.0, 0.0, 0.0, 0.0]
    );
}

criterion_group!(benches, constrained);
criterion_main!(benches);
