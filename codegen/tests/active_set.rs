//! The dual active-set reference solver (`codegen::solver::active_set`) against Clarabel and the exact
//! reference (`codegen::exact`): random strictly convex QPs with bounds and two-sided rows (the KKT
//! conditions checked directly), infeasible and non-finite data, warm starts, independent blocks, and
//! the shipped constrained specs over `[mpc.region]` and along closed loops with warm starts.
//!
//! `cargo test -p codegen --test active_set -- --nocapture` prints, per spec, the iteration counts
//! (cold, and warm after a sequence's first step, from the previous working set as it is and shifted
//! by a stage) and the multiply-adds per solve.
#![allow(non_snake_case)]

use codegen::exact::{clarabel, exact, Clarabel};
use codegen::ipm::{mpc_qp, InequalityQp, Status as IpmStatus};
use codegen::solver::active_set::{
    solve, solve_in, solve_qp, Active, Outcome, Prepared, Row, Side, Status, WorkingSet,
};
use mpc_spec::Scalar;
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A strictly convex QP of n variables and m rows: H = BᵀB + 0.1·I scaled by up to 100, some bounds
/// absent or one-sided, rows two-sided, one-sided or (rarely) without sides, some coefficients zero;
/// the rows' sides around A·z0 for a z0 inside the box, so the QP is feasible, and f large enough that
/// the unconstrained minimiser lies outside.
fn random_qp(rng: &mut ChaCha8Rng, n: usize, m: usize) -> InequalityQp {
    let B = DMatrix::from_fn(n + 2, n, |_, _| rng.gen_range(-1.0..1.0));
    let scale = 10f64.powf(rng.gen_range(-1.0..2.0));
    let H = (B.transpose() * &B + DMatrix::identity(n, n) * 0.1) * scale;
    let f = DVector::from_fn(n, |_, _| rng.gen_range(-10.0..10.0) * scale);
    let mut z_min = DVector::zeros(n);
    let mut z_max = DVector::zeros(n);
    for j in 0..n {
        let (lo, hi) = (-rng.gen_range(0.5..2.0), rng.gen_range(0.5..2.0));
        let kind: f64 = rng.gen();
        (z_min[j], z_max[j]) = if kind < 0.15 {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else if kind < 0.25 {
            (lo, f64::INFINITY)
        } else if kind < 0.35 {
            (f64::NEG_INFINITY, hi)
        } else {
            (lo, hi)
        };
    }
    let z0 = DVector::from_fn(n, |j, _| {
        let (lo, hi) = (z_min[j].max(-0.4), z_max[j].min(0.4));
        rng.gen_range(lo..hi)
    });
    let A = DMatrix::from_fn(m, n, |_, _| {
        if rng.gen::<f64>() < 0.3 {
            0.0
        } else {
            rng.gen_range(-1.0..1.0)
        }
    });
    let Az0 = &A * &z0;
    let mut lower = DVector::zeros(m);
    let mut upper = DVector::zeros(m);
    for r in 0..m {
        let (lo, hi) = (
            Az0[r] - rng.gen_range(0.0..0.5),
            Az0[r] + rng.gen_range(0.0..0.5),
        );
        let kind: f64 = rng.gen();
        (lower[r], upper[r]) = if kind < 0.03 {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else if kind < 0.2 {
            (lo, f64::INFINITY)
        } else if kind < 0.35 {
            (f64::NEG_INFINITY, hi)
        } else {
            (lo, hi)
        };
    }
    InequalityQp {
        H,
        f,
        z_min,
        z_max,
        A,
        lower,
        upper,
    }
}

/// The constraint's row a (e_i for a bound) and its bound at `side`.
fn side_of(qp: &InequalityQp, a: &Active) -> (DVector<f64>, f64) {
    let n = qp.n();
    match a.row {
        Row::Bound(i) => (
            DVector::from_fn(n, |j, _| if i == j { 1.0 } else { 0.0 }),
            match a.side {
                Side::Lower => qp.z_min[i],
                Side::Upper => qp.z_max[i],
            },
        ),
        Row::General(r) => (
            qp.A.row(r).transpose(),
            match a.side {
                Side::Lower => qp.lower[r],
                Side::Upper => qp.upper[r],
            },
        ),
    }
}

/// The KKT conditions of a solve, each relative: (stationarity, primal violation, complementarity,
/// most negative multiplier).
fn kkt(qp: &InequalityQp, out: &Outcome) -> (f64, f64, f64, f64) {
    let z = &out.z;
    let Hz = &qp.H * z;
    let mut residual = &Hz + &qp.f;
    let mut complementarity: f64 = 0.0;
    let mut negative: f64 = 0.0;
    let mut scale = 1.0 + qp.f.amax().max(Hz.amax());
    for (a, y) in out.working_set.0.iter().zip(&out.multipliers) {
        let (row, bound) = side_of(qp, a);
        let sign = match a.side {
            Side::Upper => 1.0,
            Side::Lower => -1.0,
        };
        residual += &row * (sign * y);
        scale = scale.max((&row * *y).amax());
        complementarity = complementarity.max((row.dot(z) - bound).abs() / (1.0 + bound.abs()));
        negative = negative.min(*y);
    }
    let mut violation: f64 = 0.0;
    for j in 0..qp.n() {
        violation = violation
            .max((z[j] - qp.z_max[j]) / (1.0 + qp.z_max[j].abs()))
            .max((qp.z_min[j] - z[j]) / (1.0 + qp.z_min[j].abs()));
    }
    let Az = &qp.A * z;
    for r in 0..qp.A.nrows() {
        violation = violation
            .max((Az[r] - qp.upper[r]) / (1.0 + qp.upper[r].abs()))
            .max((qp.lower[r] - Az[r]) / (1.0 + qp.lower[r].abs()));
    }
    (
        residual.amax() / scale,
        violation,
        complementarity,
        negative,
    )
}

/// Random QPs of several sizes: the solution within 1e-8 (relative to max(1, ‖z*‖∞)) of Clarabel's,
/// the KKT conditions to 1e-9, and a warm start from the optimal working set takes no iteration and
/// gives the same z.
#[test]
fn random_qps_agree_with_clarabel_and_satisfy_kkt() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (mut solved, mut worst, mut most_active, mut iterations) = (0, 0.0f64, 0, Vec::new());
    for case in 0..120 {
        let n = rng.gen_range(2..25);
        let m = rng.gen_range(0..2 * n + 5);
        let qp = random_qp(&mut rng, n, m);
        let Clarabel::Solved(reference) = clarabel(&qp) else {
            panic!("case {case}: Clarabel did not solve a feasible QP");
        };
        let out = solve_qp(&qp, None, 1000).unwrap();
        assert_eq!(out.status, Status::Solved, "case {case} (n {n}, m {m})");
        let error = (&out.z - &reference.z).amax() / reference.z.amax().max(1.0);
        assert!(error <= 1e-8, "case {case}: {error:e} from Clarabel");
        let (stationarity, violation, complementarity, negative) = kkt(&qp, &out);
        assert!(
            stationarity <= 1e-9 && violation <= 1e-9 && complementarity <= 1e-9,
            "case {case}: KKT {stationarity:e} {violation:e} {complementarity:e}"
        );
        assert!(negative >= -1e-10, "case {case}: multiplier {negative:e}");
        let m = out.macs;
        assert_eq!(
            out.per_pass.iter().sum::<usize>() + m.offsets + m.recover,
            m.total(),
            "case {case}: the passes account for the multiply-adds"
        );
        let warm = solve_qp(&qp, Some(&out.working_set), 1000).unwrap();
        assert_eq!(warm.status, Status::Solved);
        assert_eq!(
            warm.per_pass.iter().sum::<usize>() + warm.macs.offsets + warm.macs.recover,
            warm.macs.total()
        );
        assert!(
            warm.iterations == 0,
            "case {case}: {} iterations from the optimal set",
            warm.iterations
        );
        assert!((&warm.z - &out.z).amax() / reference.z.amax().max(1.0) <= 1e-10);
        solved += 1;
        worst = worst.max(error);
        most_active = most_active.max(out.working_set.len());
        iterations.push(out.iterations);
    }
    println!(
        "random QPs: {solved} solved, worst {worst:.1e} from Clarabel, up to {most_active} active sides, up to {} iterations",
        iterations.iter().max().unwrap_or(&0)
    );
}

/// Garbage warm starts (random sides, both sides of a row, repeats, constraints without that side,
/// more sides than variables) are dropped or removed by the rule, and the solve reaches the cold
/// solve's z.
#[test]
fn arbitrary_warm_sets_reach_the_same_solution() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    for case in 0..60 {
        let n = rng.gen_range(2..15);
        let m = rng.gen_range(1..2 * n + 5);
        let qp = random_qp(&mut rng, n, m);
        let cold = solve_qp(&qp, None, 1000).unwrap();
        assert_eq!(cold.status, Status::Solved);
        let sides = rng.gen_range(0..2 * (n + m));
        let start = WorkingSet(
            (0..sides)
                .map(|_| Active {
                    row: if rng.gen() {
                        Row::Bound(rng.gen_range(0..n + 2))
                    } else {
                        Row::General(rng.gen_range(0..m + 2))
                    },
                    side: if rng.gen() { Side::Upper } else { Side::Lower },
                })
                .collect(),
        );
        let warm = solve_qp(&qp, Some(&start), 1000).unwrap();
        assert_eq!(warm.status, Status::Solved, "case {case}");
        let error = (&warm.z - &cold.z).amax() / cold.z.amax().max(1.0);
        assert!(error <= 1e-9, "case {case}: {error:e}");
    }
}

/// Infeasible QPs end `Infeasible`: a row asked to be both ≤ 0 and ≥ 1 (written twice), a row whose
/// sides cross, a zero row excluding 0, a row out of the box's reach, and random QPs with narrow
/// random sides that Clarabel certifies infeasible.
#[test]
fn infeasible_qps_are_reported() {
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let base = random_qp(&mut rng, 6, 4);
    let n = base.n();
    let row = DMatrix::from_fn(1, n, |_, j| 1.0 + j as f64);
    let inf = f64::INFINITY;
    let one = |v: f64| DVector::from_element(1, v);
    let cases = [
        ("twice", {
            let q = base.clone().with_rows(&row, &one(-inf), &one(0.0));
            q.with_rows(&row, &one(1.0), &one(inf))
        }),
        (
            "crossing",
            base.clone().with_rows(&row, &one(1.0), &one(0.0)),
        ),
        (
            "zero row",
            base.clone()
                .with_rows(&DMatrix::zeros(1, n), &one(1.0), &one(2.0)),
        ),
        ("out of reach", {
            let mut q = base.clone().with_rows(&row, &one(1e3), &one(inf));
            q.z_min.fill(-1.0);
            q.z_max.fill(1.0);
            q
        }),
    ];
    for (what, qp) in cases {
        let out = solve_qp(&qp, None, 1000).unwrap();
        assert_eq!(out.status, Status::Infeasible, "{what}");
    }
    let mut infeasible = 0;
    for case in 0..200 {
        let n = rng.gen_range(2..10);
        let m = rng.gen_range(n..3 * n);
        let mut qp = random_qp(&mut rng, n, m);
        for r in 0..m {
            let c = rng.gen_range(-2.0..2.0);
            qp.lower[r] = c;
            qp.upper[r] = c + rng.gen_range(0.0..0.3);
        }
        let out = solve_qp(&qp, None, 1000).unwrap();
        match clarabel(&qp) {
            Clarabel::Infeasible => {
                infeasible += 1;
                assert_eq!(out.status, Status::Infeasible, "case {case}");
            }
            Clarabel::Solved(r) => {
                assert_eq!(out.status, Status::Solved, "case {case}");
                let error = (&out.z - &r.z).amax() / r.z.amax().max(1.0);
                assert!(error <= 1e-7, "case {case}: {error:e}");
            }
            Clarabel::Undecided => {}
        }
    }
    assert!(infeasible >= 20, "only {infeasible} infeasible draws");
    println!("random narrow QPs: {infeasible} of 200 infeasible, all reported");
}

/// NaN or infinite data, a Hessian that is not positive definite, or offsets of the wrong size are
/// reported, never a panic.
#[test]
fn bad_data_is_reported() {
    let mut rng = ChaCha8Rng::seed_from_u64(14);
    let qp = random_qp(&mut rng, 5, 6);
    let prepared = Prepared::new(&qp).unwrap();
    let mut bad = qp.clone();
    bad.f[1] = f64::NAN;
    assert!(solve_qp(&bad, None, 100).is_err());
    assert!(prepared.offsets(&bad).is_err());
    let mut bad = qp.clone();
    bad.H[(0, 0)] = f64::NAN;
    assert!(Prepared::new(&bad).is_err());
    let mut bad = qp.clone();
    bad.A[(2, 3)] = f64::INFINITY;
    assert!(Prepared::new(&bad).is_err());
    let mut bad = qp.clone();
    bad.upper[0] = f64::NAN;
    assert!(prepared.offsets(&bad).is_err());
    let mut bad = qp.clone();
    bad.H = -bad.H;
    let e = Prepared::new(&bad).unwrap_err();
    assert!(e.to_string().contains("positive definite"), "{e}");
    let mut bad = qp.clone();
    bad.f = DVector::zeros(3);
    assert!(prepared.offsets(&bad).is_err());
    // Offsets of another QP's shape, and NaN offsets written by hand: the solve reports them.
    let other = Prepared::new(&random_qp(&mut rng, 7, 2)).unwrap();
    let offsets = other.offsets(&random_qp(&mut rng, 7, 2));
    if let Ok(o) = offsets {
        assert_eq!(
            solve(&prepared, &o, None, 100).status,
            Status::NumericalFailure
        );
    }
    let mut o = prepared.offsets(&qp).unwrap();
    // The side of the first constraint the blocks hold.
    o.upper[prepared.blocks[0].packed.sides[0]] = f64::NAN;
    assert_eq!(
        solve(&prepared, &o, None, 100).status,
        Status::NumericalFailure
    );
}

/// A block-diagonal QP is split into its blocks (here three, one coupled only through a row), and the
/// solution is the same as Clarabel's on the whole.
#[test]
fn independent_blocks_are_solved_apart() {
    let mut rng = ChaCha8Rng::seed_from_u64(15);
    let parts: Vec<InequalityQp> = (0..3).map(|k| random_qp(&mut rng, 3 + k, 4)).collect();
    let n: usize = parts.iter().map(|p| p.n()).sum();
    let m: usize = parts.iter().map(|p| p.A.nrows()).sum();
    let mut qp = InequalityQp {
        H: DMatrix::zeros(n, n),
        f: DVector::zeros(n),
        z_min: DVector::zeros(n),
        z_max: DVector::zeros(n),
        A: DMatrix::zeros(m, n),
        lower: DVector::zeros(m),
        upper: DVector::zeros(m),
    };
    let (mut at, mut row) = (0, 0);
    for p in &parts {
        let (k, r) = (p.n(), p.A.nrows());
        qp.H.view_mut((at, at), (k, k)).copy_from(&p.H);
        qp.f.rows_mut(at, k).copy_from(&p.f);
        qp.z_min.rows_mut(at, k).copy_from(&p.z_min);
        qp.z_max.rows_mut(at, k).copy_from(&p.z_max);
        qp.A.view_mut((row, at), (r, k)).copy_from(&p.A);
        qp.lower.rows_mut(row, r).copy_from(&p.lower);
        qp.upper.rows_mut(row, r).copy_from(&p.upper);
        at += k;
        row += r;
    }
    // Split the last part's H in two: its rows still couple it.
    let last = n - parts[2].n();
    for i in last..last + 2 {
        for j in last + 2..n {
            qp.H[(i, j)] = 0.0;
            qp.H[(j, i)] = 0.0;
        }
    }
    qp.H += DMatrix::identity(n, n) * 5.0;
    let mut coupled = false;
    for r in m - 4..m {
        let left = (last..last + 2).any(|j| qp.A[(r, j)] != 0.0);
        let right = (last + 2..n).any(|j| qp.A[(r, j)] != 0.0);
        coupled |= left && right;
    }
    let prepared = Prepared::new(&qp).unwrap();
    assert_eq!(prepared.blocks.len(), if coupled { 3 } else { 4 });
    let out = solve(&prepared, &prepared.offsets(&qp).unwrap(), None, 1000);
    assert_eq!(out.status, Status::Solved);
    let Clarabel::Solved(reference) = clarabel(&qp) else {
        panic!("Clarabel did not solve the block QP");
    };
    assert!((&out.z - &reference.z).amax() / reference.z.amax().max(1.0) <= 1e-8);
    assert_eq!(out.block_iterations.iter().sum::<usize>(), out.iterations);
}

/// The iteration cap is honoured and reported.
#[test]
fn the_iteration_limit_is_reported() {
    let mut rng = ChaCha8Rng::seed_from_u64(16);
    let qp = random_qp(&mut rng, 12, 20);
    let full = solve_qp(&qp, None, 1000).unwrap();
    assert_eq!(full.status, Status::Solved);
    assert!(full.iterations >= 2, "{} iterations", full.iterations);
    let capped = solve_qp(&qp, None, full.iterations - 1).unwrap();
    assert_eq!(capped.status, Status::IterationLimit);
    assert_eq!(capped.iterations, full.iterations - 1);
}

// ---------------------------------------------------------------------------------------------
// The shipped constrained specs.

/// Per spec: the sample's size.
const COLD_SAMPLES: usize = 60;
const SEQUENCES: usize = 4;
const STEPS: usize = 40;
/// The plan's agreement with the exact reference, as a fraction of the input span.
const AGREEMENT: f64 = 1e-7;

/// What a spec's test measured.
#[derive(Default)]
struct Tally {
    cold_iterations: Vec<usize>,
    warm_iterations: Vec<usize>,
    shifted_iterations: Vec<usize>,
    /// Cold solves started from the slacks' lower bounds (σ ≥ 0) active.
    slack_iterations: Vec<usize>,
    slack_macs: Vec<usize>,
    /// The first step of each sequence (cold, and from σ ≥ 0).
    first_iterations: Vec<usize>,
    first_slack_iterations: Vec<usize>,
    cold_macs: Vec<usize>,
    warm_macs: Vec<usize>,
    shifted_macs: Vec<usize>,
    worst_pass: usize,
    worst_error: f64,
    infeasible: usize,
    /// Solves where neither reference agreed and the KKT conditions decided.
    references_inexact: usize,
}

fn median_max(v: &[usize]) -> (usize, usize) {
    let mut s = v.to_vec();
    s.sort_unstable();
    (
        s.get(s.len() / 2).copied().unwrap_or(0),
        s.last().copied().unwrap_or(0),
    )
}

/// The plan's error against the exact reference, as a fraction of the span of each input.
fn plan_error(qp: &codegen::lower::Qp, z: &DVector<f64>, exact: &DVector<f64>) -> f64 {
    let nu = qp.u_min.len();
    (0..qp.N * nu)
        .map(|i| (z[i] - exact[i]).abs() / (qp.u_max[i % nu] - qp.u_min[i % nu]))
        .fold(0.0, f64::max)
}

/// The working set a stage later: the first stage's bounds and rows dropped, the others moved up one
/// stage; the slacks' bounds kept.
fn shifted(qp: &codegen::lower::Qp, ws: &WorkingSet) -> WorkingSet {
    let nu = qp.u_min.len();
    let n = qp.N * nu;
    let per_slot = qp.rows.per_slot;
    ws.filter_map(|a| {
        let row = match a.row {
            Row::Bound(i) if i >= n => Row::Bound(i),
            Row::Bound(i) if i >= nu => Row::Bound(i - nu),
            Row::General(r) if r >= per_slot => Row::General(r - per_slot),
            _ => return None,
        };
        Some(Active { row, side: a.side })
    })
}

/// One spec: cold solves at states and references drawn from `[mpc.region]`, then closed loops on the
/// nominal model from drawn states, each step solved cold (for the count), warm from the previous
/// working set and warm from it shifted by a stage; every solve agrees with the exact reference to
/// [`AGREEMENT`] of the span, and infeasible draws are reported so by both.
fn spec_agrees(name: &str, src: &str, seed: u64) {
    let mut spec = mpc_spec::load(src).unwrap();
    // The QP and the region are all this needs: lowered without the certificates (`auto` would sample
    // the interior-point method's and the active set's on the region first).
    spec.mpc.method = mpc_spec::Method::ActiveSet;
    let p = codegen::lower::uncertified(&spec).unwrap();
    let region =
        codegen::sampling::resolve_region(&spec, &p, "the dual active-set method").unwrap();
    let qp = &p.qp;
    let (N, nz, nd) = (qp.N, qp.nz, p.nd());
    let n = N * p.nu;
    let template = mpc_qp(qp, &DVector::zeros(n), &DVector::zeros(qp.rows.len()));
    let prepared = Prepared::new(&template).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let draw = |rng: &mut ChaCha8Rng, lo: &[f64], hi: &[f64]| {
        DVector::from_iterator(
            lo.len(),
            lo.iter().zip(hi).map(|(a, b)| rng.gen_range(*a..=*b)),
        )
    };
    let u_lo: Vec<f64> = qp.u_min.iter().copied().collect();
    let u_hi: Vec<f64> = qp.u_max.iter().copied().collect();
    // A case: state, reference, disturbance (a tenth of the input range), last input.
    let draw_case = |rng: &mut ChaCha8Rng| {
        let x0 = draw(rng, &region.x_min, &region.x_max);
        let reference = draw(rng, &region.reference_min, &region.reference_max);
        let d = DVector::from_fn(nd, |i, _| 0.1 * rng.gen_range(-qp.u_max[i]..=-qp.u_min[i]));
        let last = if p.keeps_last_input() {
            draw(rng, &u_lo, &u_hi)
        } else {
            qp.rest_input()
        };
        (x0, reference, d, last)
    };
    let problem_of =
        |x0: &DVector<f64>, reference: &DVector<f64>, d: &DVector<f64>, last: &DVector<f64>| {
            let Xref = DVector::from_fn(N * nz, |i, _| reference[i % nz]);
            let f = &qp.Fx * x0 - &qp.Fr * Xref + &qp.Fu * last + qp.Fd.columns(0, nd) * d;
            let offset = qp.rows.offset(x0, d, last);
            mpc_qp(qp, &f, &offset)
        };
    let mut tally = Tally::default();
    // The cold start a controller would use: every slack at its lower bound 0 (the unconstrained
    // minimiser has σ = −w/q_σ = −1000 for the specs' weights, which violates every soft row).
    let slack_start = WorkingSet(
        (n..n + qp.rows.slacks())
            .map(|i| Active {
                row: Row::Bound(i),
                side: Side::Lower,
            })
            .collect(),
    );
    // Solves `problem` from `start`; checks it against the exact reference; None where infeasible.
    let check =
        |tally: &mut Tally, problem: &InequalityQp, start: Option<&WorkingSet>, what: &str| {
            let offsets = prepared.offsets(problem).unwrap();
            let out = solve(&prepared, &offsets, start, 10_000);
            let reference = exact(problem);
            match reference.status {
                IpmStatus::Converged => {
                    assert_eq!(out.status, Status::Solved, "{name} {what}");
                    let mut error = plan_error(qp, &out.z, &reference.z);
                    if error > AGREEMENT {
                        // The interior-point reference can stop with complementarity near 1e-5 on the
                        // ill-conditioned QPs (hover's κ(H) = 2.8e4) and still report convergence: then
                        // Clarabel is asked, and where neither is within the agreement the solve must be
                        // the better one, its KKT conditions met to round-off and its cost no higher.
                        if let Clarabel::Solved(r) = clarabel(problem) {
                            error = error.min(plan_error(qp, &out.z, &r.z));
                        }
                        if error > AGREEMENT {
                            let (stationarity, violation, complementarity, negative) =
                                kkt(problem, &out);
                            let cost = |z: &DVector<f64>| {
                                0.5 * z.dot(&(&problem.H * z)) + problem.f.dot(z)
                            };
                            let (ours, theirs) = (cost(&out.z), cost(&reference.z));
                            assert!(
                                stationarity <= 1e-12
                                    && violation <= 1e-12
                                    && complementarity <= 1e-12
                                    && negative >= -1e-12
                                    && ours <= theirs + 1e-12 * theirs.abs().max(1.0),
                                "{name} {what}: {error:e} of the span from both references, KKT \
                             {stationarity:e} {violation:e} {complementarity:e} {negative:e}, cost \
                             {ours} against {theirs}"
                            );
                            tally.references_inexact += 1;
                            error = 0.0;
                        }
                    }
                    tally.worst_error = tally.worst_error.max(error);
                    tally.worst_pass = tally
                        .worst_pass
                        .max(out.per_pass.iter().copied().max().unwrap_or(0));
                    Some(out)
                }
                IpmStatus::Infeasible => {
                    assert_eq!(out.status, Status::Infeasible, "{name} {what}");
                    tally.infeasible += 1;
                    None
                }
                _ => None,
            }
        };
    for k in 0..COLD_SAMPLES {
        let (x0, reference, d, last) = draw_case(&mut rng);
        let problem = problem_of(&x0, &reference, &d, &last);
        if let Some(out) = check(&mut tally, &problem, None, &format!("cold case {k}")) {
            tally.cold_iterations.push(out.iterations);
            tally.cold_macs.push(out.macs.total());
            let out = check(&mut tally, &problem, Some(&slack_start), "slack start")
                .expect("the cold solve was feasible");
            tally.slack_iterations.push(out.iterations);
            tally.slack_macs.push(out.macs.total());
        }
    }
    for s in 0..SEQUENCES {
        let (mut x, reference, d, mut last) = draw_case(&mut rng);
        let mut previous: Option<WorkingSet> = None;
        for step in 0..STEPS {
            let problem = problem_of(&x, &reference, &d, &last);
            let what = format!("sequence {s} step {step}");
            let Some(cold) = check(&mut tally, &problem, None, &what) else {
                break;
            };
            let out = match &previous {
                None => {
                    tally.first_iterations.push(cold.iterations);
                    let out = check(&mut tally, &problem, Some(&slack_start), "slack start")
                        .expect("the cold solve was feasible");
                    tally.first_slack_iterations.push(out.iterations);
                    out
                }
                Some(ws) => {
                    let warm = check(&mut tally, &problem, Some(ws), &format!("{what} warm"))
                        .expect("the cold solve was feasible");
                    let moved = shifted(qp, ws);
                    let shift = check(
                        &mut tally,
                        &problem,
                        Some(&moved),
                        &format!("{what} shifted"),
                    )
                    .expect("the cold solve was feasible");
                    tally.warm_iterations.push(warm.iterations);
                    tally.warm_macs.push(warm.macs.total());
                    tally.shifted_iterations.push(shift.iterations);
                    tally.shifted_macs.push(shift.macs.total());
                    warm
                }
            };
            let u = out.z.rows(0, p.nu).into_owned();
            x = &p.F * &x
                + &p.G * (&u + DVector::from_fn(p.nu, |i, _| d.get(i).copied().unwrap_or(0.0)));
            last = u;
            previous = Some(out.working_set.clone());
        }
    }
    let blocks: Vec<usize> = prepared.blocks.iter().map(|b| b.n()).collect();
    let line = |what: &str, v: &[usize]| {
        let (median, max) = median_max(v);
        println!(
            "  {what:<34} median {median:>6}  max {max:>6}  ({} solves)",
            v.len()
        );
    };
    println!(
        "{name}: n {} in blocks {blocks:?}, {} constraints, {} infeasible draws, worst pass {} multiply-adds, \
         worst error {:.1e} of the span ({} solves closer to the KKT conditions than both references)",
        template.n(),
        prepared.constraints(),
        tally.infeasible,
        tally.worst_pass,
        tally.worst_error,
        tally.references_inexact,
    );
    line("iterations cold (empty set)", &tally.cold_iterations);
    line("iterations cold (σ ≥ 0 active)", &tally.slack_iterations);
    line("iterations first step (empty set)", &tally.first_iterations);
    line(
        "iterations first step (σ ≥ 0)",
        &tally.first_slack_iterations,
    );
    line("iterations warm (previous set)", &tally.warm_iterations);
    line("iterations warm (shifted set)", &tally.shifted_iterations);
    line("multiply-adds cold (empty set)", &tally.cold_macs);
    line("multiply-adds cold (σ ≥ 0 active)", &tally.slack_macs);
    line("multiply-adds warm (previous set)", &tally.warm_macs);
    line("multiply-adds warm (shifted set)", &tally.shifted_macs);
    assert!(
        tally.cold_iterations.len() >= COLD_SAMPLES / 2,
        "{name}: too few feasible cases"
    );
    assert!(
        tally.warm_iterations.len() >= STEPS,
        "{name}: too few warm steps"
    );
}

#[test]
fn quadcopter_agrees_with_the_exact_reference() {
    spec_agrees("quadcopter", include_str!("../../specs/quadcopter.toml"), 1);
}

#[test]
fn hover_agrees_with_the_exact_reference() {
    spec_agrees("hover", include_str!("../../specs/hover.toml"), 2);
}

#[test]
fn paper_limits_agrees_with_the_exact_reference() {
    spec_agrees(
        "paper-limits",
        include_str!("../../specs/paper-limits.toml"),
        3,
    );
}

#[test]
fn paper_geofence_agrees_with_the_exact_reference() {
    spec_agrees(
        "paper-geofence",
        include_str!("../../specs/paper-geofence.toml"),
        4,
    );
}

#[test]
fn afti16_agrees_with_the_exact_reference() {
    spec_agrees("afti16", include_str!("../../specs/afti16.toml"), 5);
}

/// Degenerate QPs: rows written twice, rows that repeat a bound, and a row that is the sum of two
/// others with the matching sides, so that dependent sides are active together at the optimum. They
/// are solved, and agree with Clarabel.
#[test]
fn degenerate_qps_are_solved() {
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    for case in 0..60 {
        let n = rng.gen_range(3..12);
        let m = rng.gen_range(2..2 * n);
        let mut qp = random_qp(&mut rng, n, m);
        let copies = rng.gen_range(1..4);
        for _ in 0..copies {
            let r = rng.gen_range(0..m);
            let row = qp.A.rows(r, 1).into_owned();
            let (lo, hi) = (
                DVector::from_element(1, qp.lower[r]),
                DVector::from_element(1, qp.upper[r]),
            );
            qp = qp.with_rows(&row, &lo, &hi);
        }
        // A bound repeated as a row.
        let j = rng.gen_range(0..n);
        let e = DMatrix::from_fn(1, n, |_, i| if i == j { 1.0 } else { 0.0 });
        let (lo, hi) = (
            DVector::from_element(1, qp.z_min[j]),
            DVector::from_element(1, qp.z_max[j]),
        );
        if lo[0].is_finite() || hi[0].is_finite() {
            qp = qp.with_rows(&e, &lo, &hi);
        }
        // The sum of rows 0 and 1 bounded by the sum of their upper sides.
        if qp.upper[0].is_finite() && qp.upper[1].is_finite() {
            let row = qp.A.rows(0, 1) + qp.A.rows(1, 1);
            let hi = DVector::from_element(1, qp.upper[0] + qp.upper[1]);
            qp = qp.with_rows(&row, &DVector::from_element(1, f64::NEG_INFINITY), &hi);
        }
        let out = solve_qp(&qp, None, 1000).unwrap();
        let Clarabel::Solved(reference) = clarabel(&qp) else {
            panic!("case {case}: Clarabel did not solve a feasible QP");
        };
        assert_eq!(out.status, Status::Solved, "case {case}");
        let error = (&out.z - &reference.z).amax() / reference.z.amax().max(1.0);
        assert!(error <= 1e-8, "case {case}: {error:e} from Clarabel");
        let (stationarity, violation, complementarity, negative) = kkt(&qp, &out);
        assert!(
            stationarity <= 1e-9
                && violation <= 1e-9
                && complementarity <= 1e-9
                && negative >= -1e-10,
            "case {case}: KKT {stationarity:e} {violation:e} {complementarity:e} {negative:e}"
        );
    }
}

/// The f32 kernel on soft rows whose weight is 1e5 (`specs/paper-limits.toml`): the multipliers reach
/// the weight, so z − z_free = −Z_W·λ sums terms of 1e5 to a plan of size 10, and the scan's slacks
/// carry the same round-off. With the f32 kernel's primal refinement and its check of the rows on z
/// (a row violated there, or a multiplier of the wrong sign once refined, restarts the block once),
/// every solve of 400 cold cases (x₀ and the reference drawn in the region, 64 of them at corners of
/// x₀) is within a tenth of `accuracy` of the f64 kernel's plan and of the exact solution; before the
/// refinement the worst was 4e-2 of the span, forty times `accuracy`.
#[test]
fn f32_kernel_refines_z_where_soft_rows_make_the_multipliers_large() {
    let src = include_str!("../../specs/paper-limits.toml").replacen(
        "\nmethod = \"ipm\"\n",
        "\nmethod = \"active_set\"\n",
        1,
    );
    let spec = mpc_spec::load(&src).unwrap();
    let p = codegen::lower(&spec).unwrap();
    let qp = &p.qp;
    let prepared = codegen::solver::active_set::mpc::prepare(qp).unwrap();
    assert!(prepared.blocks.iter().all(|b| b.packed.refine));
    let region =
        codegen::sampling::resolve_region(&spec, &p, "the dual active-set method").unwrap();
    let last = qp.rest_input();
    let d = DVector::zeros(p.nd());
    let mut rng = ChaCha8Rng::seed_from_u64(33);
    let (mut worst, mut worst_exact, mut refused) = (0.0f64, 0.0f64, 0);
    for case in 0..400u32 {
        let x0 = DVector::from_fn(p.nx, |i, _| {
            if case < 64 {
                [region.x_min[i], region.x_max[i]][(case >> i & 1) as usize]
            } else {
                rng.gen_range(region.x_min[i]..=region.x_max[i])
            }
        });
        let reference = DVector::from_fn(qp.nz, |i, _| {
            rng.gen_range(region.reference_min[i]..=region.reference_max[i])
        });
        let xref = DVector::from_fn(qp.N * qp.nz, |i, _| reference[i % qp.nz]);
        let f = &qp.Fx * &x0 - &qp.Fr * xref + &qp.Fu * &last;
        let problem = mpc_qp(qp, &f, &qp.rows.offset(&x0, &d, &last));
        let offsets = prepared.offsets(&problem).unwrap();
        let tol64 = codegen::solver::active_set::Tolerances::F64;
        let tol32 = codegen::solver::active_set::Tolerances::F32;
        let run = |tol, scalar| solve_in(&prepared, &offsets, None, 2048, tol, scalar);
        let (a, b) = (run(&tol64, Scalar::F64), run(&tol32, Scalar::F32));
        assert_eq!(a.status, Status::Solved, "case {case}");
        if b.status != Status::Solved {
            refused += 1;
            continue;
        }
        worst = worst.max(plan_error(qp, &b.z, &a.z));
        let reference = exact(&problem);
        if reference.status == IpmStatus::Converged {
            worst_exact = worst_exact.max(plan_error(qp, &b.z, &reference.z));
        }
    }
    println!(
        "paper-limits, f32 kernel: worst |U − U_f64|∞ / span {worst:.2e}, against the exact solution \
         {worst_exact:.2e}, {refused} not solved"
    );
    assert_eq!(refused, 0);
    assert!(worst <= 0.1 * qp.accuracy, "{worst:e}");
    assert!(worst_exact <= 0.1 * qp.accuracy, "{worst_exact:e}");
}

/// The sampled certificate's witness (`Evidence::cold_witness`, the state and constant reference that
/// `mpcc dump-qp --witness` hands a board to replay against the bound) is a case that needs the
/// sample's worst cold count: its QP formed here from the named parameters and the lowered matrices
/// (f = F_x·x0 − F_r·r + F_u·u₋₁, the rows' offsets), solved cold by the kernel, makes exactly
/// `cold_worst` changes and no case of the sample more.
#[test]
fn the_sampled_witness_is_the_heaviest_cold_case() {
    let src = include_str!("../../specs/quadcopter.toml").replacen(
        "[mpc]\n",
        "[mpc]\nmethod = \"active_set\"\n",
        1,
    );
    let g = codegen::generate_from_source(&src, &Default::default()).unwrap();
    let p = &g.problem;
    let qp = &p.qp;
    let e = g
        .certificate
        .sampled
        .as_ref()
        .expect("a sampled certificate");
    let names = codegen::sampling::parameter_names(p);
    assert_eq!(
        e.cold_witness.iter().map(|(n, _)| n).collect::<Vec<_>>(),
        names.iter().collect::<Vec<_>>(),
        "the witness names θ in order"
    );
    let value = |name: &str| e.cold_witness.iter().find(|(n, _)| n == name).unwrap().1;
    let x0 = DVector::from_fn(p.nx, |i, _| value(&format!("x0[{i}]")));
    let r = DVector::from_fn(qp.nz, |i, _| value(&format!("r[{i}]")));
    assert!(!p.keeps_last_input() && p.nd() == 0, "θ is (x0, r) here");
    let window = DVector::from_fn(qp.N * qp.nz, |i, _| r[i % qp.nz]);
    let last = qp.rest_input();
    let f = &qp.Fx * &x0 - &qp.Fr * window + &qp.Fu * &last;
    let offset = qp.rows.offset(&x0, &DVector::zeros(0), &last);
    let prepared = codegen::solver::active_set::mpc::prepare(qp).unwrap();
    let offsets = prepared.offsets(&mpc_qp(qp, &f, &offset)).unwrap();
    let out = solve_in(
        &prepared,
        &offsets,
        None,
        10 * e.cold_worst,
        &codegen::solver::active_set::Tolerances::of(Scalar::F64),
        Scalar::F64,
    );
    assert_eq!(out.status, Status::Solved);
    println!(
        "quadcopter: the witness spends {} work in {} changes; the sample's cold worst: {} work, {} changes",
        out.macs.work(),
        out.iterations,
        e.cold_work_worst,
        e.cold_worst
    );
    assert_eq!(out.macs.work(), e.cold_work_worst);
    assert!(out.iterations <= e.cold_worst && out.iterations > e.cold_median);
    // The emitted budget lets the witness through, and stops a solve that spends more: the same
    // QP with a budget just below the witness's work ends at the iteration limit.
    let caps = codegen::solver::active_set::mpc::Caps::of(qp);
    assert!(caps.cold_work > e.cold_work_worst);
    let tolerances = codegen::solver::active_set::Tolerances::of(Scalar::F64);
    let starved = codegen::solver::active_set::solve_within(
        &prepared,
        &offsets,
        None,
        (10 * e.cold_worst, e.cold_work_worst / 2),
        &tolerances,
        Scalar::F64,
    );
    assert_eq!(starved.status, Status::IterationLimit);
    assert!(starved.iterations < out.iterations);
}

/// The kinds of work the kernel counts are the table's, so that the emitted `Tally` (written from
/// `WORK_KINDS`) weighs every call the kernel makes, as the build's `Macs::work` does.
#[test]
fn every_kind_of_work_the_kernel_counts_is_weighed() {
    use codegen::solver::active_set::{KERNEL_SOURCE, WORK_KINDS};
    let mut called = std::collections::BTreeSet::new();
    for (i, _) in KERNEL_SOURCE.match_indices("tally.") {
        let name: String = KERNEL_SOURCE[i + "tally.".len()..]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if name != "exhausted" {
            called.insert(name);
        }
    }
    let weighed: std::collections::BTreeSet<String> = WORK_KINDS
        .iter()
        .map(|(kind, _, _)| kind.to_string())
        .collect();
    assert_eq!(called, weighed);
    for (kind, constant, weight) in WORK_KINDS {
        assert!(
            KERNEL_SOURCE.contains(&format!("const {constant}: usize = {weight};")),
            "{kind}: {constant} = {weight}"
        );
    }
}
