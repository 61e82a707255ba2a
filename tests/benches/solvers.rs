//! Per-solve and per-cycle time of the generated controllers against the generic runtime solver and two
//! established QP solvers (Clarabel; OSQP with `--features osqp`, which needs cmake), on the paper's
//! problem and a horizon sweep, side by side in one run. Before the timings the run prints the floor (the
//! per-axis dense form's multiply-adds at this machine's peak FMA rate); after them, each solver's
//! distance from the exact QP optimum. Both also go to `floor.json` and `suboptimality.json` in
//! criterion's output directory.
//!
//! `cargo bench -p mpc-tests --bench solvers [--features osqp]`; figures in BENCHMARKS.md.

mod baselines;
mod floor;

use codegen::oracle;
use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use nalgebra::DVector;
use rand::Rng;
use std::path::PathBuf;

mpc_macros::mpc!(mod n5 = "benches/specs/paper-n5.toml");
mpc_macros::mpc!(mod n15 = "../specs/paper.toml");
mpc_macros::mpc!(mod n15_f64 = "benches/specs/paper-f64.toml");
mpc_macros::mpc!(mod n30 = "benches/specs/paper-n30.toml");
mpc_macros::mpc!(mod n60 = "benches/specs/paper-n60.toml");
mpc_macros::mpc!(mod n100 = "benches/specs/paper-n100.toml");
// The emissions side by side (`auto` chooses lanes up to N = 60 and matrix_free at N = 100).
mpc_macros::mpc!(mod n15_unrolled = "specs/emission/paper-unrolled.toml");
mpc_macros::mpc!(mod n15_table = "specs/emission/paper-table.toml");
mpc_macros::mpc!(mod n15_matrix_free = "specs/emission/paper-matrix-free.toml");
mpc_macros::mpc!(mod n30_matrix_free = "benches/specs/paper-n30-matrix-free.toml");
mpc_macros::mpc!(mod n60_matrix_free = "benches/specs/paper-n60-matrix-free.toml");
mpc_macros::mpc!(mod n100_lanes = "benches/specs/paper-n100-lanes.toml");

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

/// The horizon sweep: the paper's spec (N = 15) and its copies with other horizons.
const SPECS: [&str; 5] = [
    "benches/specs/paper-n5.toml",
    "../specs/paper.toml",
    "benches/specs/paper-n30.toml",
    "benches/specs/paper-n60.toml",
    "benches/specs/paper-n100.toml",
];

/// One horizon's QPs: the 64 situations, their linear terms f = Fx·x0 − Fr·Xref and exact optima U*.
struct Horizon {
    p: codegen::Problem,
    cases: Vec<(DVector<f64>, Vec<DVector<f64>>)>,
    f: Vec<Vec<f64>>,
    exact: Vec<DVector<f64>>,
    /// The largest KKT residual of the U* (see `oracle::kkt_residual`), in the gradient's units.
    kkt: f64,
}

impl Horizon {
    fn new(path: &str) -> Self {
        let p = problem(path);
        let cases: Vec<(DVector<f64>, Vec<DVector<f64>>)> = situations(p.qp.N)
            .into_iter()
            .map(|(x, r)| {
                (
                    DVector::from_row_slice(&x),
                    r.iter().map(|v| DVector::from_row_slice(v)).collect(),
                )
            })
            .collect();
        let mpc = oracle::Mpc::new(&p);
        let f: Vec<DVector<f64>> = cases
            .iter()
            .map(|(x0, xref)| mpc.linear_term(x0, xref))
            .collect();
        let exact: Vec<DVector<f64>> = f
            .iter()
            .map(|f| oracle::exact_solution(&p.qp, f, 1e-13, 1_000_000))
            .collect();
        let kkt = f
            .iter()
            .zip(&exact)
            .map(|(f, u)| oracle::kkt_residual(&p.qp, f, u))
            .fold(0.0, f64::max);
        Horizon {
            f: f.iter().map(|f| f.as_slice().to_vec()).collect(),
            p,
            cases,
            exact,
            kkt,
        }
    }

    fn n(&self) -> usize {
        self.p.qp.N
    }
}

/// A solver's distance from the exact optimum on one horizon's 64 situations.
struct Accuracy {
    solver: String,
    n: usize,
    /// Mean over the situations of |U − U*|∞ over the whole plan.
    mean_plan: f64,
    /// The largest |U − U*|∞.
    max_plan: f64,
    /// Mean of |u0 − u0*|∞, the applied input alone.
    mean_first: f64,
    /// Mean iterations per solve.
    iterations: f64,
}

/// Runs `solve(i) -> (U, iterations)` over the situations twice in the benchmark's order, so each solve is
/// warm-started from the previous situation as in the timed loop, and measures the second pass.
fn accuracy(
    h: &Horizon,
    solver: &str,
    mut solve: impl FnMut(usize) -> (Vec<f64>, u32),
) -> Accuracy {
    let nu = h.p.nu;
    let m = h.cases.len();
    let (mut sum_plan, mut max_plan, mut sum_first, mut iterations) = (0.0, 0.0_f64, 0.0, 0);
    for i in 0..2 * m {
        let (u, its) = solve(i % m);
        if i < m {
            continue;
        }
        let exact = &h.exact[i % m];
        assert_eq!(u.len(), exact.len(), "{solver}: plan length");
        let dist = |range: std::ops::Range<usize>| {
            range.map(|j| (u[j] - exact[j]).abs()).fold(0.0, f64::max)
        };
        let plan = dist(0..u.len());
        sum_plan += plan;
        max_plan = max_plan.max(plan);
        sum_first += dist(0..nu);
        iterations += its;
    }
    Accuracy {
        solver: solver.into(),
        n: h.n(),
        mean_plan: sum_plan / m as f64,
        max_plan,
        mean_first: sum_first / m as f64,
        iterations: iterations as f64 / m as f64,
    }
}

/// Where criterion writes (`CRITERION_HOME`, else `$CARGO_TARGET_DIR/criterion`, else the workspace's
/// `target/criterion`).
fn criterion_dir() -> PathBuf {
    if let Some(home) = std::env::var_os("CRITERION_HOME") {
        return home.into();
    }
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../target")))
        .join("criterion")
}

fn write_json(name: &str, value: &serde_json::Value) {
    let dir = criterion_dir();
    let path = dir.join(name);
    let written = std::fs::create_dir_all(&dir)
        .and_then(|_| std::fs::write(&path, serde_json::to_string_pretty(value).unwrap()));
    match written {
        Ok(()) => eprintln!("(written to {})", path.display()),
        Err(e) => eprintln!("could not write {}: {e}", path.display()),
    }
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string())
}

/// Measures the peak FMA rates and prints, per horizon, the floor: the per-axis dense form's
/// multiply-adds per solve at those rates.
fn print_floor(horizons: &[Horizon]) {
    let peak = floor::measure(50.0);
    let cpu = cpu_model();
    eprintln!(
        "\nfloor on {cpu}: peak {:.2} G f32 multiply-adds/s, {:.2} G f64 multiply-adds/s ({}, one core)",
        peak.f32_per_s * 1e-9,
        peak.f64_per_s * 1e-9,
        peak.kernel
    );
    eprintln!(
        "{:>5} {:>12} {:>10} {:>14} {:>14}",
        "N", "madds/solve", "nnz(H)", "floor f32", "floor f64"
    );
    let mut rows = Vec::new();
    for h in horizons {
        let (n, nu, iterations) = (h.n(), h.p.nu, h.p.qp.iterations);
        let madds = floor::multiply_adds_per_solve(n, nu, iterations);
        let nnz = h.p.qp.H.iter().filter(|v| **v != 0.0).count();
        let (t32, t64) = (madds as f64 / peak.f32_per_s, madds as f64 / peak.f64_per_s);
        eprintln!(
            "{n:>5} {madds:>12} {nnz:>10} {:>11.3} µs {:>11.3} µs",
            t32 * 1e6,
            t64 * 1e6
        );
        rows.push(serde_json::json!({
            "N": n, "nu": nu, "iterations": iterations, "multiply_adds_per_solve": madds,
            "nnz_H": nnz, "floor_f32_s": t32, "floor_f64_s": t64,
        }));
    }
    write_json(
        "floor.json",
        &serde_json::json!({
            "cpu": cpu,
            "kernel": peak.kernel,
            "peak_f32_multiply_adds_per_s": peak.f32_per_s,
            "peak_f64_multiply_adds_per_s": peak.f64_per_s,
            "multiply_adds_per_solve": "nu * N^2 * iterations (per-axis dense form)",
            "horizons": rows,
        }),
    );
}

fn print_accuracy(horizons: &[Horizon], table: &[Accuracy]) {
    eprintln!(
        "\nsuboptimality over the 64 situations, warm-started in the benchmark's order (U* exact):"
    );
    for h in horizons {
        eprintln!(
            "  N = {:>3}: largest KKT residual of U* {:.1e}",
            h.n(),
            h.kkt
        );
    }
    eprintln!(
        "{:<16} {:>5} {:>16} {:>16} {:>16} {:>11}",
        "solver", "N", "mean |U-U*|inf", "max |U-U*|inf", "mean |u0-u0*|", "iterations"
    );
    for a in table {
        eprintln!(
            "{:<16} {:>5} {:>16.3e} {:>16.3e} {:>16.3e} {:>11.1}",
            a.solver, a.n, a.mean_plan, a.max_plan, a.mean_first, a.iterations
        );
    }
    let rows: Vec<serde_json::Value> = table
        .iter()
        .map(|a| {
            serde_json::json!({
                "solver": a.solver, "N": a.n, "mean_plan_inf": a.mean_plan,
                "max_plan_inf": a.max_plan, "mean_first_input_inf": a.mean_first,
                "mean_iterations": a.iterations,
            })
        })
        .collect();
    write_json(
        "suboptimality.json",
        &serde_json::json!({ "situations": 64, "rows": rows }),
    );
}

macro_rules! bench_generated {
    ($group:expr, $table:expr, $h:expr, $m:ident, $label:expr, $real:ty) => {{
        use $m::{Mpc, N, NU};
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
        $table.push(accuracy($h, $label, |i| {
            let (x0, xref) = &cases[i];
            mpc.solve(x0, xref);
            let plan = mpc.plan();
            let u = (0..N * NU).map(|j| plan[j / NU][j % NU] as f64).collect();
            (u, $m::ITERATIONS as u32)
        }));
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
    table: &mut Vec<Accuracy>,
    h: &Horizon,
) {
    let n = h.n();
    let mut mpc = oracle::Mpc::new(&h.p);
    let iterations = h.p.qp.iterations as u32;
    table.push(accuracy(h, "generic f64", |i| {
        let (x0, xref) = &h.cases[i];
        mpc.solve(x0, xref);
        (mpc.plan().as_slice().to_vec(), iterations)
    }));
    let mut i = 0;
    group.bench_function(BenchmarkId::new("generic f64", n), |b| {
        b.iter(|| {
            let (x0, xref) = &h.cases[i % h.cases.len()];
            i += 1;
            black_box(mpc.solve(black_box(x0), black_box(xref)))
        })
    });
}

/// Clarabel, set up once; per solve only q changes. q = f is computed outside the timed loop (the
/// generated and generic solvers compute it inside theirs).
fn bench_clarabel(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    table: &mut Vec<Accuracy>,
    h: &Horizon,
) {
    let mut solver = baselines::Clarabel::new(&h.p.qp);
    table.push(accuracy(h, "clarabel", |i| {
        let u = solver.solve(&h.f[i]).to_vec();
        (u, solver.iterations())
    }));
    let mut i = 0;
    group.bench_function(BenchmarkId::new("clarabel", h.n()), |b| {
        b.iter(|| {
            let q = &h.f[i % h.f.len()];
            i += 1;
            black_box(solver.solve(black_box(q))[0])
        })
    });
}

/// OSQP, set up once, warm-started; per solve only q changes (computed outside the timed loop).
#[cfg(feature = "osqp")]
fn bench_osqp(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    table: &mut Vec<Accuracy>,
    h: &Horizon,
) {
    let mut solver = baselines::Osqp::new(&h.p.qp);
    table.push(accuracy(h, "osqp", |i| {
        let u = solver.solve(&h.f[i]).to_vec();
        (u, solver.iterations())
    }));
    let mut i = 0;
    group.bench_function(BenchmarkId::new("osqp", h.n()), |b| {
        b.iter(|| {
            let q = &h.f[i % h.f.len()];
            i += 1;
            black_box(solver.solve(black_box(q))[0])
        })
    });
}

fn solve(c: &mut Criterion) {
    let horizons: Vec<Horizon> = SPECS.iter().map(|path| Horizon::new(path)).collect();
    print_floor(&horizons);
    let mut table = Vec::new();
    let mut group = c.benchmark_group("solve");
    let [h5, h15, h30, h60, h100] = &horizons[..] else {
        unreachable!()
    };
    bench_generated!(group, table, h5, n5, "generated f32", f32);
    bench_generated!(group, table, h15, n15, "generated f32", f32);
    bench_generated!(group, table, h15, n15_f64, "generated f64", f64);
    bench_generated!(group, table, h30, n30, "generated f32", f32);
    bench_generated!(group, table, h60, n60, "generated f32", f32);
    bench_generated!(group, table, h100, n100, "generated f32", f32);
    bench_generated!(
        group,
        table,
        h15,
        n15_unrolled,
        "generated f32 unrolled",
        f32
    );
    bench_generated!(group, table, h15, n15_table, "generated f32 table", f32);
    bench_generated!(
        group,
        table,
        h15,
        n15_matrix_free,
        "generated f32 matrix_free",
        f32
    );
    bench_generated!(
        group,
        table,
        h30,
        n30_matrix_free,
        "generated f32 matrix_free",
        f32
    );
    bench_generated!(
        group,
        table,
        h60,
        n60_matrix_free,
        "generated f32 matrix_free",
        f32
    );
    bench_generated!(group, table, h100, n100_lanes, "generated f32 lanes", f32);
    for h in &horizons {
        bench_oracle(&mut group, &mut table, h);
        bench_clarabel(&mut group, &mut table, h);
        #[cfg(feature = "osqp")]
        bench_osqp(&mut group, &mut table, h);
    }
    group.finish();
    table.sort_by_key(|a| a.n);
    print_accuracy(&horizons, &table);
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
