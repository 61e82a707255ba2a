//! One control step of the generated `specs/paper.toml` controller (f32) and of `tests/specs/paper-f64.toml`
//! on normal data and on data that would make the arithmetic subnormal, side by side: the timing hazard
//! the flush where data enters removes. Also a gated outlier and a dropout, which take the short paths.
//!
//! `cargo bench -p mpc-tests --bench inputs`

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use flight_sim::{Reference, Trajectory};

macro_rules! bench_inputs {
    ($c:expr, $m:ident, $label:literal) => {{
        use mpc_tests::$m::{Controller, Real, N};
        let r = Trajectory::paper();
        let k0 = 2000;
        let x0: [Real; 6] = flight_sim::cast(&r.state(k0));
        let xref = r.window::<Real, { N }>(k0);
        let normal: [Real; 3] = [x0[0] + 0.1, x0[1] - 0.05, x0[2] + 0.02];
        let sub = Real::MIN_POSITIVE / 4.0;
        let tiny = Real::MIN_POSITIVE * 64.0;
        let cases: [(&str, [Real; 3], [[Real; 6]; N], [Real; 6]); 5] = [
            ("normal", normal, xref, x0),
            (
                "subnormal z, x0 and xref",
                [sub; 3],
                [[sub; 6]; N],
                [sub; 6],
            ),
            (
                "tiny normal z, x0 and xref",
                [tiny; 3],
                [[tiny; 6]; N],
                [tiny; 6],
            ),
            (
                "gated outlier",
                [normal[0] + 1e6, normal[1], normal[2]],
                xref,
                x0,
            ),
            ("dropout", [Real::NAN; 3], xref, x0),
        ];
        let mut group = $c.benchmark_group(concat!("step on ", $label));
        for (name, z, xref, x0) in cases {
            // Warmed up on its own data, so every sample measures the same kind of step.
            let mut c = Controller::new(x0);
            for _ in 0..50 {
                c.step(&z, &xref);
            }
            group.bench_function(name, |b| b.iter(|| c.step(black_box(&z), black_box(&xref))));
        }
        group.finish();
    }};
}

fn inputs(c: &mut Criterion) {
    bench_inputs!(c, paper, "paper.toml (f32)");
    bench_inputs!(c, paper_f64, "paper-f64.toml (f64)");
}

criterion_group!(benches, inputs);
criterion_main!(benches);
