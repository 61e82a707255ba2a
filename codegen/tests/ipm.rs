//! The dense interior-point method (`codegen::ipm`) against Clarabel and the box oracle: the box QPs of
//! two specs, the paper's QP with velocity rows, the iterations a fixed-iteration solve needs, and
//! infeasible or non-finite data.
#![allow(non_snake_case)]

use codegen::ipm::{self, InequalityQp, IpmResult, Start, Status};
use codegen::lower::Qp;
use codegen::oracle::{exact_solution, Mpc};
use nalgebra::{DMatrix, DVector};

const PAPER: &str = include_str!("../../specs/paper.toml");
const TWO_MASS: &str = include_str!("../../tests/specs/two-mass-outputs.toml");

/// The tolerance `solve` runs to, and the agreement asked of it (fraction of the input span).
const TOLERANCE: f64 = 1e-9;
const AGREEMENT: f64 = 1e-6;
/// The accuracy for a fixed-iteration solve: |U − U*|∞ ≤ 1e-3·span, violation ≤
/// 1e-3·max(1, |bound|).
const ACCURACY: f64 = 1e-3;

fn problem(src: &str) -> codegen::Problem {
    codegen::lower(&mpc_spec::load(src).unwrap()).unwrap()
}

/// A deterministic stream of numbers in [−1, 1) (an LCG): the tests need no statistics.
struct Stream(u64);

impl Stream {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

// Clarabel on an `InequalityQp`, shared with the integration tests.
#[path = "../../tests/benches/exact.rs"]
mod exact;
use exact::clarabel;

/// The span u_max − u_min of each entry of U.
fn span(qp: &Qp) -> DVector<f64> {
    let nu = qp.u_min.len();
    DVector::from_fn(qp.N * nu, |i, _| qp.u_max[i % nu] - qp.u_min[i % nu])
}

/// max_i |a_i − b_i| / span_i.
fn error(a: &DVector<f64>, b: &DVector<f64>, span: &DVector<f64>) -> f64 {
    (a - b).component_div(span).amax()
}

/// The largest violation of the rows, each relative to max(1, |its finite bound|).
fn violation(qp: &InequalityQp, z: &DVector<f64>) -> f64 {
    let Az = &qp.A * z;
    let mut worst: f64 = 0.0;
    for r in 0..qp.A.nrows() {
        for (excess, bound) in [
            (Az[r] - qp.upper[r], qp.upper[r]),
            (qp.lower[r] - Az[r], qp.lower[r]),
        ] {
            if bound.is_finite() {
                worst = worst.max(excess / bound.abs().max(1.0));
            }
        }
    }
    let n = qp.n();
    for i in 0..n {
        worst = worst.max(z[i] - qp.z_max[i]).max(qp.z_min[i] - z[i]);
    }
    worst
}

/// One problem to solve: a QP and where its iteration starts.
struct Case {
    qp: InequalityQp,
    start: Start,
}

/// The box QP's random cases: states and references scaled from small to saturating; with move
/// suppression a random last input too.
fn box_cases(src: &str, seed: u64, count: usize) -> (Qp, Vec<InequalityQp>) {
    let p = problem(src);
    let qp = p.qp.clone();
    let nx = qp.Fx.ncols();
    let mut rng = Stream(seed);
    let mut cases = Vec::new();
    for k in 0..count {
        let scale = [0.01, 0.1, 1.0, 5.0, 20.0][k % 5];
        let mut mpc = Mpc::new(&p);
        let last = DVector::from_fn(p.nu, |i, _| {
            0.5 * (qp.u_min[i] + qp.u_max[i]) + 0.5 * (qp.u_max[i] - qp.u_min[i]) * rng.next()
        });
        assert!(mpc.set_last_input(&last));
        let x0 = DVector::from_fn(nx, |_, _| scale * rng.next());
        let r = DVector::from_fn(qp.nz, |_, _| scale * rng.next());
        let f = mpc.linear_term(&x0, &vec![r; qp.N]);
        cases.push(InequalityQp::from_box(&qp, &f));
    }
    (qp, cases)
}

/// The paper's QP for state x0 and a fixed position target, plus |v_k| ≤ 2 m/s on every axis of the
/// predicted states x_1 … x_N and, with `floor`, the altitude z_k ≥ 0 (the 60-row variant):
/// with x_k = Sx_k x0 + Su_k U, the rows Su_k (velocity and altitude rows) with bounds ±2 − Sx_k x0
/// and [−Sx_k x0, ∞), by step.
fn paper_with_limits(
    p: &codegen::Problem,
    x0: &DVector<f64>,
    target: &DVector<f64>,
    floor: bool,
) -> InequalityQp {
    let qp = &p.qp;
    let nx = qp.Fx.ncols();
    let axes = nx / 2;
    let mpc = Mpc::new(p);
    let f = mpc.linear_term(x0, &vec![target.clone(); qp.N]);
    let free = &qp.Sx * x0;
    // (row of Sx and Su, lower, upper) before the free response.
    let rows: Vec<(usize, f64, f64)> = (0..qp.N)
        .flat_map(|k| {
            let velocities = (axes..nx).map(move |i| (k * nx + i, -2.0, 2.0));
            let altitude = floor.then_some((k * nx + axes - 1, 0.0, f64::INFINITY));
            velocities.chain(altitude)
        })
        .collect();
    let A = DMatrix::from_fn(rows.len(), qp.Su.ncols(), |r, j| qp.Su[(rows[r].0, j)]);
    let lower = DVector::from_fn(rows.len(), |r, _| rows[r].1 - free[rows[r].0]);
    let upper = DVector::from_fn(rows.len(), |r, _| rows[r].2 - free[rows[r].0]);
    InequalityQp::from_box(qp, &f).with_rows(&A, &lower, &upper)
}

/// Random states for the velocity rows: positions ±5 m away from targets ±5 m (the rows and the box
/// active), velocities inside ±2 m/s, every fourth at 95 % of the bound. With the altitude floor the
/// altitude starts in [0.3, 5] m (above the 0.18 m a 1.9 m/s descent needs to stop at 10 m/s²) and
/// every third target is on the ground.
fn velocity_cases(p: &codegen::Problem, seed: u64, count: usize, floor: bool) -> Vec<InequalityQp> {
    let axes = p.qp.Fx.ncols() / 2;
    let mut rng = Stream(seed);
    (0..count)
        .map(|k| {
            let x0 = DVector::from_fn(2 * axes, |i, _| {
                if floor && i == axes - 1 {
                    2.65 + 2.35 * rng.next()
                } else if i < axes {
                    5.0 * rng.next()
                } else if k % 4 == 0 {
                    1.9 * rng.next().signum()
                } else {
                    2.0 * rng.next()
                }
            });
            let target = DVector::from_fn(2 * axes, |i, _| {
                if floor && i == axes - 1 {
                    if k % 3 == 0 {
                        0.0
                    } else {
                        2.5 + 2.5 * rng.next()
                    }
                } else if i < axes {
                    5.0 * rng.next()
                } else {
                    0.0
                }
            });
            paper_with_limits(p, &x0, &target, floor)
        })
        .collect()
}

fn converged(qp: &InequalityQp, what: &str) -> IpmResult {
    let r = ipm::solve(qp, TOLERANCE, 100);
    assert_eq!(r.status, Status::Converged, "{what}: {r:?}");
    r
}

/// The box QPs: `solve` to 1e-9 agrees with Clarabel and with the projected-gradient oracle to
/// 1e-6 of the input span, on cases that saturate and cases that do not.
#[test]
fn box_qps_agree_with_clarabel_and_the_oracle() {
    for (name, src, seed) in [("paper", PAPER, 1), ("two-mass", TWO_MASS, 2)] {
        let (qp, cases) = box_cases(src, seed, 50);
        let span = span(&qp);
        let (mut saturated, mut interior) = (0, 0);
        for (k, case) in cases.iter().enumerate() {
            let r = converged(case, &format!("{name} case {k}"));
            let reference = clarabel(case);
            let exact = exact_solution(&qp, &case.f, 1e-14, 400_000);
            let (to_clarabel, to_exact) =
                (error(&r.z, &reference, &span), error(&r.z, &exact, &span));
            assert!(
                to_clarabel <= AGREEMENT && to_exact <= AGREEMENT,
                "{name} case {k}: {to_clarabel:e} of the span from Clarabel, {to_exact:e} from the oracle"
            );
            let at_bound = (0..r.z.len())
                .any(|i| (r.z[i] - case.z_min[i]).min(case.z_max[i] - r.z[i]) <= 1e-6 * span[i]);
            if at_bound {
                saturated += 1;
            } else {
                interior += 1;
            }
        }
        assert!(
            saturated >= 10 && interior >= 10,
            "{name}: {saturated} saturating, {interior} interior"
        );
    }
}

/// General rows: the paper's QP with |v_k| ≤ 2 m/s on the predicted velocities (and then also
/// z_k ≥ 0) agrees with Clarabel given the same rows, and the rows are active in some cases.
#[test]
fn velocity_rows_agree_with_clarabel() {
    let p = problem(PAPER);
    let span = span(&p.qp);
    for floor in [false, true] {
        velocity_rows_case(&p, &span, floor);
    }
}

fn velocity_rows_case(p: &codegen::Problem, span: &DVector<f64>, floor: bool) {
    let mut active = 0;
    for (k, case) in velocity_cases(p, 3, 50, floor).iter().enumerate() {
        let r = converged(case, &format!("case {k}, floor {floor}"));
        let reference = clarabel(case);
        let to_clarabel = error(&r.z, &reference, span);
        assert!(
            to_clarabel <= AGREEMENT,
            "case {k}, floor {floor}: {to_clarabel:e} of the span from Clarabel"
        );
        assert!(
            violation(case, &r.z) <= 1e-8,
            "case {k}: violation {:e}",
            violation(case, &r.z)
        );
        let Az = &case.A * &r.z;
        if (0..Az.len()).any(|i| (Az[i] - case.lower[i]).min(case.upper[i] - Az[i]) <= 1e-6) {
            active += 1;
        }
    }
    assert!(
        active >= 10,
        "floor {floor}: the rows were active in {active} cases only"
    );
}

/// v shifted by one step: every block of `per_step` entries moves up one step, the last step repeated.
fn shift(v: &DVector<f64>, per_step: usize) -> DVector<f64> {
    let n = v.len();
    let mut w = v.clone();
    w.rows_mut(0, n - per_step)
        .copy_from(&v.rows(per_step, n - per_step));
    w
}

/// A closed loop of `steps` on the spec's plant (x ← F x + G u, read off the first block rows of Sx
/// and Su) from each of `starts`, each solve warm-started from the previous plan shifted with the rest
/// input appended; with `dual`, from its slacks and multipliers too (box sides and row sides shifted
/// by a step each, the last step repeated). `make` builds the QP of a state and the last input; the
/// box is finite and every step has the same row sides. Returns the warm cases.
fn closed_loops(
    p: &codegen::Problem,
    make: &dyn Fn(&DVector<f64>, &DVector<f64>) -> InequalityQp,
    starts: &[DVector<f64>],
    steps: usize,
    dual: bool,
) -> Vec<Case> {
    let qp = &p.qp;
    let (nx, nu) = (qp.Fx.ncols(), p.nu);
    let F = qp.Sx.rows(0, nx).into_owned();
    let G = qp.Su.view((0, 0), (nx, nu)).into_owned();
    let rest = qp.rest_input();
    let mut cases = Vec::new();
    for x0 in starts {
        let mut x = x0.clone();
        let mut previous: Option<IpmResult> = None;
        let mut last = rest.clone();
        for _ in 0..steps {
            let iqp = make(&x, &last);
            let warm = previous.as_ref().map(|r| {
                let n = r.z.len();
                let mut z = DVector::zeros(n);
                z.rows_mut(0, n - nu).copy_from(&r.z.rows(nu, n - nu));
                z.rows_mut(n - nu, nu).copy_from(&rest);
                if !dual {
                    return Start::Primal(z);
                }
                let sides = |v: &DVector<f64>| {
                    let rows = v.len() - 2 * n;
                    let boxed = shift(&v.rows(0, 2 * n).into_owned(), 2 * nu);
                    let general = shift(&v.rows(2 * n, rows).into_owned(), rows / qp.N);
                    DVector::from_iterator(v.len(), boxed.iter().chain(general.iter()).copied())
                };
                Start::PrimalDual {
                    z,
                    s: sides(&r.s),
                    lambda: sides(&r.lambda),
                }
            });
            let r = converged(&iqp, "closed loop");
            last = r.z.rows(0, nu).into_owned();
            x = &F * &x + &G * &last;
            if let Some(start) = warm {
                cases.push(Case { qp: iqp, start });
            }
            previous = Some(r);
        }
    }
    cases
}

/// What a case needs: the iterations `solve` takes to 1e-9, the fewest fixed iterations that meet the
/// issue's accuracy, and the reference solution.
struct Need {
    to_tolerance: usize,
    to_accuracy: usize,
    exact: DVector<f64>,
}

fn accurate(case: &Case, z: &DVector<f64>, exact: &DVector<f64>, span: &DVector<f64>) -> bool {
    error(z, exact, span) <= ACCURACY && violation(&case.qp, z) <= ACCURACY
}

fn need(case: &Case, span: &DVector<f64>) -> Need {
    let r = ipm::solve_from(&case.qp, &case.start, TOLERANCE, 100);
    assert_eq!(r.status, Status::Converged, "{r:?}");
    let to_accuracy = (0..=r.iterations)
        .find(|k| {
            accurate(
                case,
                &ipm::solve_fixed(&case.qp, &case.start, *k).z,
                &r.z,
                span,
            )
        })
        .expect("the converged count meets the accuracy");
    Need {
        to_tolerance: r.iterations,
        to_accuracy,
        exact: r.z,
    }
}

/// Fixed iterations: the counts cold and warm (closed loops), printed; `solve_fixed` with the largest
/// count that any case needed to meet the accuracy, and with the largest count to 1e-9, meets the
/// accuracy on every case.
#[test]
fn fixed_iterations_meet_the_accuracy() {
    let paper = problem(PAPER);
    let two_mass = problem(TWO_MASS);
    let starts: Vec<DVector<f64>> = {
        let mut rng = Stream(4);
        (0..5)
            .map(|_| {
                DVector::from_fn(6, |i, _| {
                    if i == 2 {
                        2.65 + 2.35 * rng.next()
                    } else if i < 3 {
                        5.0 * rng.next()
                    } else {
                        1.9 * rng.next()
                    }
                })
            })
            .collect()
    };
    // Down to the ground: the altitude floor becomes active in the closed loops.
    let target = DVector::from_vec(vec![1.0, 1.0, 0.0, 0.0, 0.0, 0.0]);
    let paper_box = |x: &DVector<f64>, _: &DVector<f64>| {
        let f = Mpc::new(&paper).linear_term(x, &vec![target.clone(); paper.qp.N]);
        InequalityQp::from_box(&paper.qp, &f)
    };
    let paper_rows =
        |x: &DVector<f64>, _: &DVector<f64>| paper_with_limits(&paper, x, &target, false);
    let paper_floor =
        |x: &DVector<f64>, _: &DVector<f64>| paper_with_limits(&paper, x, &target, true);
    // The two-mass plant from rest-ish states to p2 = 1, its moves measured from the last input.
    let two_mass_box = |x: &DVector<f64>, last: &DVector<f64>| {
        let mut mpc = Mpc::new(&two_mass);
        assert!(mpc.set_last_input(last));
        let f = mpc.linear_term(x, &vec![DVector::from_element(1, 1.0); two_mass.qp.N]);
        InequalityQp::from_box(&two_mass.qp, &f)
    };
    let two_mass_starts: Vec<DVector<f64>> = {
        let mut rng = Stream(7);
        (0..5)
            .map(|_| DVector::from_fn(4, |_, _| rng.next()))
            .collect()
    };
    let cold = |cases: Vec<InequalityQp>| -> Vec<Case> {
        cases
            .into_iter()
            .map(|qp| Case {
                qp,
                start: Start::Cold,
            })
            .collect()
    };
    let groups: Vec<(&str, &codegen::Problem, Vec<Case>)> = vec![
        ("paper box, cold", &paper, cold(box_cases(PAPER, 1, 50).1)),
        (
            "paper box, warm z",
            &paper,
            closed_loops(&paper, &paper_box, &starts, 30, false),
        ),
        (
            "paper box, warm z, s, λ",
            &paper,
            closed_loops(&paper, &paper_box, &starts, 30, true),
        ),
        (
            "paper |v| <= 2, cold",
            &paper,
            cold(velocity_cases(&paper, 3, 50, false)),
        ),
        (
            "paper |v| <= 2, warm z, s, λ",
            &paper,
            closed_loops(&paper, &paper_rows, &starts, 30, true),
        ),
        (
            "paper |v| <= 2, z >= 0, cold",
            &paper,
            cold(velocity_cases(&paper, 6, 50, true)),
        ),
        (
            "paper |v| <= 2, z >= 0, warm z",
            &paper,
            closed_loops(&paper, &paper_floor, &starts, 30, false),
        ),
        (
            "paper |v| <= 2, z >= 0, warm z, s, λ",
            &paper,
            closed_loops(&paper, &paper_floor, &starts, 30, true),
        ),
        (
            "two-mass box, cold",
            &two_mass,
            cold(box_cases(TWO_MASS, 2, 50).1),
        ),
        (
            "two-mass box, warm z, s, λ",
            &two_mass,
            closed_loops(&two_mass, &two_mass_box, &two_mass_starts, 30, true),
        ),
    ];
    for (name, p, cases) in &groups {
        let span = span(&p.qp);
        let needs: Vec<Need> = cases.iter().map(|c| need(c, &span)).collect();
        let tolerance_max = needs.iter().map(|n| n.to_tolerance).max().unwrap();
        let accuracy_max = needs.iter().map(|n| n.to_accuracy).max().unwrap();
        let median = {
            let mut v: Vec<usize> = needs.iter().map(|n| n.to_accuracy).collect();
            v.sort();
            v[v.len() / 2]
        };
        let macs = ipm::macs_per_iteration(&cases[0].qp);
        println!(
            "{name}: {} cases; to 1e-9: max {tolerance_max} iterations; to the accuracy: median {median}, \
             max {accuracy_max} ({macs} multiply-adds an iteration, {} a solve)",
            cases.len(),
            macs * accuracy_max
        );
        // The calibration (numpy, cold worst case, multiply-adds a solve): the cost model may
        // be at most 1.5× it.
        let calibration = match *name {
            "paper box, cold" => Some(188_000),
            "paper |v| <= 2, z >= 0, cold" => Some(434_000),
            _ => None,
        };
        if let Some(calibrated) = calibration {
            assert!(
                2 * macs * accuracy_max <= 3 * calibrated,
                "{name}: {} multiply-adds a solve, over 1.5 × the calibration's {calibrated}",
                macs * accuracy_max
            );
        }
        for k in [accuracy_max, tolerance_max] {
            for (i, (case, need)) in cases.iter().zip(&needs).enumerate() {
                let r = ipm::solve_fixed(&case.qp, &case.start, k);
                // Fewer only when the point was optimal to rounding, which it then holds.
                assert!(
                    r.iterations == k || (r.iterations < k && r.status == ipm::Status::Converged)
                );
                assert!(
                    accurate(case, &r.z, &need.exact, &span),
                    "{name} case {i}: {k} iterations leave {:e} of the span, violation {:e}",
                    error(&r.z, &need.exact, &span),
                    violation(&case.qp, &r.z)
                );
            }
        }
    }
}

/// Contradicting rows (z_0 ≥ 5 and z_0 ≤ −5, and a row with lower > upper) end as Infeasible or at
/// the iteration limit with a finite z; non-finite data ends as NumericalFailure with the start's z.
#[test]
fn infeasible_and_non_finite_data_never_panic() {
    let (_, cases) = box_cases(PAPER, 5, 1);
    let base = cases[0].clone();
    let n = base.n();
    let e0 = DMatrix::from_fn(1, n, |_, j| if j == 0 { 1.0 } else { 0.0 });
    let two = DMatrix::from_fn(2, n, |_, j| if j == 0 { 1.0 } else { 0.0 });
    let contradicting = [
        base.clone().with_rows(
            &two,
            &DVector::from_vec(vec![5.0, f64::NEG_INFINITY]),
            &DVector::from_vec(vec![f64::INFINITY, -5.0]),
        ),
        base.clone().with_rows(
            &e0,
            &DVector::from_element(1, 1.0),
            &DVector::from_element(1, -1.0),
        ),
    ];
    for (k, qp) in contradicting.iter().enumerate() {
        for r in [
            ipm::solve(qp, TOLERANCE, 200),
            ipm::solve_fixed(qp, &Start::Cold, 30),
            ipm::solve_fixed(qp, &Start::Primal(DVector::zeros(n)), 300),
        ] {
            assert!(
                matches!(r.status, Status::Infeasible | Status::IterationLimit),
                "contradiction {k}: {:?}",
                r.status
            );
            assert!(
                r.z.iter().all(|v| v.is_finite()),
                "contradiction {k}: {:?}",
                r.z
            );
        }
        assert_eq!(
            ipm::solve(qp, TOLERANCE, 200).status,
            Status::Infeasible,
            "contradiction {k}"
        );
    }
    let warm = DVector::from_element(n, 0.5);
    for bad in [f64::NAN, f64::INFINITY] {
        let mut qp = base.clone();
        qp.f[3] = bad;
        for (start, z) in [
            (Start::Cold, DVector::zeros(n)),
            (Start::Primal(warm.clone()), warm.clone()),
        ] {
            for r in [
                ipm::solve_from(&qp, &start, TOLERANCE, 50),
                ipm::solve_fixed(&qp, &start, 10),
            ] {
                assert_eq!(r.status, Status::NumericalFailure);
                assert_eq!(r.z, z, "the start's plan comes back");
            }
        }
    }
    // A NaN bound is refused too; an infinite one only drops its side.
    let mut qp = base.clone();
    qp.z_max[0] = f64::NAN;
    assert_eq!(
        ipm::solve(&qp, TOLERANCE, 50).status,
        Status::NumericalFailure
    );
    let mut qp = base.clone();
    qp.z_max[0] = f64::INFINITY;
    assert_eq!(qp.sides(), base.sides() - 1);
    assert_eq!(ipm::solve(&qp, TOLERANCE, 100).status, Status::Converged);
}

/// A small problem written out: min ½‖z − (1, 1)‖² subject to z_0 ≤ 0.2, z_0 + z_1 = 1 (a row with
/// lower = upper) and a row with no finite side. The minimiser is (0.2, 0.8) with multipliers 0.6 on
/// z_0 ≤ 0.2 and 0.2 on the upper side of the equality (∇ = (−0.8, −0.2) = −0.6·e_0 − 0.2·(1, 1)).
#[test]
fn a_small_problem_with_an_equality_and_unbounded_sides() {
    let qp = InequalityQp {
        // H = I, f = −(1, 1)
        H: DMatrix::identity(2, 2),
        f: DVector::from_vec(vec![-1.0, -1.0]),
        z_min: DVector::from_element(2, f64::NEG_INFINITY),
        z_max: DVector::from_vec(vec![0.2, f64::INFINITY]),
        // A = [1 1; 1 −1]
        A: DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, -1.0]),
        lower: DVector::from_vec(vec![1.0, f64::NEG_INFINITY]),
        upper: DVector::from_vec(vec![1.0, f64::INFINITY]),
    };
    // z_0 ≤ 0.2, then the equality's upper and lower sides.
    assert_eq!(qp.sides(), 3);
    let r = ipm::solve(&qp, 1e-12, 100);
    assert_eq!(r.status, Status::Converged, "{r:?}");
    let expected = DVector::from_vec(vec![0.2, 0.8]);
    assert!((&r.z - &expected).amax() <= 1e-9, "{}", r.z);
    assert!((&r.z - clarabel(&qp)).amax() <= 1e-9);
    // The equality's net multiplier is λ_upper − λ_lower.
    let multipliers = [r.lambda[0], r.lambda[1] - r.lambda[2]];
    assert!((multipliers[0] - 0.6).abs() <= 1e-9 && (multipliers[1] - 0.2).abs() <= 1e-9);
    // Without any finite side the minimiser is one Newton step; zero iterations leave the start.
    let free = InequalityQp {
        z_max: DVector::from_element(2, f64::INFINITY),
        A: DMatrix::zeros(0, 2),
        lower: DVector::zeros(0),
        upper: DVector::zeros(0),
        ..qp.clone()
    };
    let r = ipm::solve(&free, 1e-12, 100);
    assert_eq!((r.status, r.iterations), (Status::Converged, 1));
    assert!((&r.z - DVector::from_element(2, 1.0)).amax() <= 1e-12);
    let start = DVector::from_element(2, 3.0);
    let r = ipm::solve_fixed(&free, &Start::Primal(start.clone()), 0);
    assert_eq!(
        (r.status, r.iterations, &r.z),
        (Status::IterationLimit, 0, &start)
    );
}

/// The multiply-adds of an iteration by the calibration rule, over what the emitted method visits, on
/// the paper's box QP: n = 45 unknowns whose three axes are independent (three dense 15 × 15 blocks of
/// H and of the normal matrix), 90 box sides of one nonzero each, no rows.
#[test]
fn macs_follow_the_calibration_rule() {
    let (_, cases) = box_cases(PAPER, 1, 1);
    let (blocks, b, sides) = (3, 15, 90);
    // L·D·Lᵀ of a dense b × b block: per column j, j for the pivot and j + 1 for each of the b − 1 − j
    // rows below it, Σ = b(b − 1)/2 + (b³ − b)/6 (15 × 15: 665; 45 × 45 dense would be 16,170).
    let ldl = blocks * (b * (b - 1) / 2 + (b * b * b - b) / 6);
    // H·z and a pair of triangular solves with the diagonal: b² per block.
    let (hz, solve) = (blocks * b * b, blocks * b * b);
    // G z and Gᵀλ: one signed term per side. Residuals H z + 2 G; GᵀDG one weight per side; two
    // directions of 2 G + a solve; the corrector's refinement H Δz + 2 G + a solve; 12 per side.
    let g = sides;
    let refinement = ipm::REFINEMENT;
    let expected = hz
        + 2 * g
        + sides
        + ldl
        + 2 * (2 * g + solve)
        + refinement * (hz + 2 * g + solve)
        + 12 * sides;
    assert_eq!(ipm::macs_per_iteration(&cases[0]), expected);
    assert_eq!(ipm::Sparsity::of(&cases[0]).envelope.ldl_macs(), ldl);
    // A two-sided row on the first 10 unknowns couples the axes into one block. It is formed once
    // (10·11/2 products and a weight per side), it adds its nonzeros and a term per side to every G
    // product, 12 per side, and the factorisation, the solves and H·z grow to the merged envelope.
    let n = 45;
    let row = DMatrix::from_fn(1, n, |_, j| if j < 10 { 1.0 } else { 0.0 });
    let one = DVector::from_element(1, 1.0);
    let with_row = cases[0].clone().with_rows(&row, &-&one, &one);
    let merged = ipm::Sparsity::of(&with_row);
    assert_eq!(merged.envelope.order, (0..n).collect::<Vec<_>>());
    assert_eq!((merged.rows.len(), merged.side_row.len()), (1, 2));
    let (hz2, solve2, ldl2) = (
        merged.h_macs(),
        merged.envelope.solve_macs(),
        merged.envelope.ldl_macs(),
    );
    assert!(ldl2 > ldl && solve2 > solve && hz2 > hz);
    let g_row = 10 + 2;
    assert_eq!(
        ipm::macs_per_iteration(&with_row),
        expected
            + (hz2 - hz) * (1 + refinement)
            + (solve2 - solve) * (2 + refinement)
            + (ldl2 - ldl)
            + (10 * 11 / 2 + 2)
            + (2 + 4 + 2 * refinement) * g_row
            + 12 * 2
    );
}

/// The acceptance test reads the gap, not only the residuals: a truncated solve whose residuals pass
/// loose limits but whose relative duality gap is above the gap limit falls back; without a gap limit
/// the same solve is accepted.
#[test]
fn a_solve_with_small_residuals_and_a_large_gap_falls_back() {
    let p = problem(include_str!("../../specs/paper-limits.toml"));
    let qp = &p.qp;
    let mut x0 = DVector::zeros(p.nx);
    x0[3] = 1.9;
    let reference = DVector::from_fn(qp.N * qp.nz, |i, _| if i % qp.nz == 0 { 8.0 } else { 0.0 });
    let last = qp.rest_input();
    let f = &qp.Fx * &x0 - &qp.Fr * &reference + &qp.Fu * &last;
    let offset = qp.rows.offset(&x0, &DVector::zeros(0), &last);
    let plan = qp.rest_plan();
    let step = |gap: f64| {
        let limits = codegen::evidence::Limits {
            primal: f64::INFINITY,
            dual: f64::INFINITY,
            gap,
        };
        ipm::control_step(qp, &f, &offset, &Start::Cold, &plan, 3, &limits, false)
    };
    let accepted = step(f64::INFINITY);
    assert_eq!(accepted.fallback, ipm::Fallback::Solved);
    let gap = accepted.result.relative_gap;
    assert!(
        gap > 1e-3,
        "three iterations already closed the gap to {gap:e}"
    );
    assert_eq!(step(gap / 2.0).fallback, ipm::Fallback::WarmStart);
    assert_eq!(step(gap * 2.0).fallback, ipm::Fallback::Solved);
}
