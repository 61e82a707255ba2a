//! Per-solve and per-cycle time of the generated controllers against the generic runtime solver, on the
//! paper's problem and a horizon sweep. `cargo bench -p mpc-tests --bench solvers`; figures in BENCHMARKS.md.

use codegen::oracle;
use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use nalgebra::DVector;
use rand::Rng;

mpc_macros::mpc!(mod n5 = "benches/specs/paper-n5.toml");
mpc_macros::mpc!(mod n15 = "../specs/paper.toml");
mpc_macros::mpc!(mod n15_f64 = "benches/specs/paper-f64.toml");
mpc_macros::mpc!(mod n30 = "benches/specs/paper-n30.toml");
mpc_macros::mpc!(mod n60 = "benches/specs/paper-n60.toml");
mpc_macros::mpc!(mod n100 = "benches/specs/paper-n100.toml");

/// 64 hover-like situations: offsets up to 2 m and 1 m/s, references drifting around the origin.
fn situations(n: usize) -> Vec<([f64; 6], Vec<[f64; 6]>)> {
    let mut rng = mpc_tests::harness::rng(42);
    (0..64)
        .map(|_| {
            let x0: [f64; 6] =
                core::array::from_fn(|i| rng.gen_range(-1.0..1.0) * if i < 3 { 2.0 } else { 1.0 });
            let r: [f64; 6] =
                core::array::from_fn(|i| if i < 3 { rng.gen_range(-0.5..0.5) } else { 0.0 });
            (x0, vec![r; n])
        })
        .collect()
}

fn problem(path: &str) -> codegen::Problem {
    let src = std::fs::read_to_string(format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))).unwrap();
    codegen::lower(&mpc_spec::load(&src).unwrap()).unwrap()
}

macro_rules! bench_generated {
    ($group:expr, $m:ident, $label:expr, $real:ty) => {{
        use $m::{Mpc, N};
        let cases: Vec<([$real; 6], [[$real; 6]; N])> = situations(N)
            .into_iter()
            .map(|(x, r)| {
                (
                    x.map(|v| v as $real),
                    core::array::from_fn(|k| r[k].map(|v| v as $real)),
                )
            })
            .collect();
        let mut mpc = Mpc::new();
        let mut i = 0;
        $group.bench_function(BenchmarkId::new($label, N), |b| {
            b.iter(|| {
                let (x0, xref) = &cases[i % cases.len()];
                i += 1;
                black_box(mpc.solve(black_box(x0), black_box(xref)))
            })
        });
    }};
}

fn bench_oracle(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    path: &str,
) {
    let p = problem(path);
    let n = p.qp.N;
    let cases: Vec<(DVector<f64>, Vec<DVector<f64>>)> = situations(n)
        .into_iter()
        .map(|(x, r)| {
            (
                DVector::from_row_slice(&x),
                r.iter().map(|v| DVector::from_row_slice(v)).collect(),
            )
        })
        .collect();
    let mut mpc = oracle::Mpc::new(&p);
    let mut i = 0;
    group.bench_function(BenchmarkId::new("generic f64", n), |b| {
        b.iter(|| {
            let (x0, xref) = &cases[i % cases.len()];
            i += 1;
            black_box(mpc.solve(black_box(x0), black_box(xref)))
        })
    });
}

fn solve(c: &mut Criterion) {
    let mut group = c.benchmark_group("solve");
    bench_generated!(group, n5, "generated f32", f32);
    bench_generated!(group, n15, "generated f32", f32);
    bench_generated!(group, n15_f64, "generated f64", f64);
    bench_generated!(group, n30, "generated f32", f32);
    bench_generated!(group, n60, "generated f32", f32);
    bench_generated!(group, n100, "generated f32", f32);
    for path in [
        "benches/specs/paper-n5.toml",
        "../specs/paper.toml",
        "benches/specs/paper-n30.toml",
        "benches/specs/paper-n60.toml",
        "benches/specs/paper-n100.toml",
    ] {
        bench_oracle(&mut group, path);
    }
    group.finish();
}

/// The whole control cycle (filter update, MPC, filter predict) of the paper's spec.
fn cycle(c: &mut Criterion) {
    let mut group = c.benchmark_group("cycle");
    let cases = situations(15);
    let mut generated = n15::Controller::new([0.0; 6]);
    let mut i = 0;
    group.bench_function("generated f32", |b| {
        b.iter(|| {
            let (x, r) = &cases[i % cases.len()];
            i += 1;
            let z = [x[0] as f32, x[1] as f32, x[2] as f32];
            let xref: [[f32; 6]; 15] = core::array::from_fn(|k| r[k].map(|v| v as f32));
            black_box(generated.step(black_box(&z), black_box(&xref)))
        })
    });
    let p = problem("../specs/paper.toml");
    let mut generic = oracle::Controller::new(&p, DVector::zeros(6));
    let dcases: Vec<(DVector<f64>, Vec<DVector<f64>>)> = cases
        .iter()
        .map(|(x, r)| {
            (
                DVector::from_row_slice(&x[..3]),
                r.iter().map(|v| DVector::from_row_slice(v)).collect(),
            )
        })
        .collect();
    group.bench_function("generic f64", |b| {
        b.iter(|| {
            let (z, xref) = &dcases[i % dcases.len()];
            i += 1;
            black_box(generic.step(black_box(z), black_box(xref)))
        })
    });
    group.finish();
}

criterion_group!(benches, solve, cycle);
criterion_main!(benches);
