//! The interior-point method's certificate: evidence, not a proof. A fixed-iteration IPM has no
//! practical a priori bound (short-step theory asks 32-122× the counts observed), so the compiler runs
//! the method at build time, in f64, on a seeded sample of the operating region `[mpc.region]` and
//! measures how many iterations reach `accuracy` against the exact solution (the same IPM run to a
//! 1e-10 tolerance, cross-checked against Clarabel in the tests):
//! - **cold** cases: the region's corners (all of them up to [`MAX_CORNERS`], else that many drawn) and
//!   `samples` uniform draws of the state, the reference (constant over the horizon), the last input
//!   and the disturbance estimate;
//! - **warm** closed-loop sequences: `sequences` runs of `steps` steps on the nominal model from a drawn
//!   state towards a drawn reference, each solve warm-started from the previous one as the emitted
//!   controller does (a warm solve can need more iterations than a cold one).
//!
//! A case needs k iterations when every iterate from the k-th on (up to [`MAX_PROBE`]) has
//! |U − U*|∞ ≤ accuracy·(u_max − u_min) per input and violates no hard row by more than
//! accuracy·max(1, |bound|). `iterations = "auto"` is the worst count observed plus [`margin`]. At the
//! count used, the worst final residuals set the run-time [`Limits`]: [`LIMIT_FACTOR`] times them (at
//! least [`LIMIT_FLOOR`]), above which the emitted solver falls back.
#![allow(non_snake_case)]

use crate::evidence::Limits;
pub use crate::evidence::{Evidence, Region};
use crate::lower::{Problem, Qp};
use crate::solver::ipm::{
    control_step, mpc_macs_per_iteration, mpc_qp, shifted_start, solve, trajectory, violations,
    Fallback, IpmResult, Start, Status,
};
use mpc_spec::{Diagnostic, Diagnostics, Iterations, Spec, MAX_ITERATIONS};
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Draws besides the corners when `[mpc.region] samples` is not written.
pub const DEFAULT_SAMPLES: usize = 50;
/// Closed-loop sequences when `sequences` is not written.
pub const DEFAULT_SEQUENCES: usize = 4;
/// Steps per sequence when `steps` is not written.
pub const DEFAULT_STEPS: usize = 50;
/// At most this many corners of the state region are used (all of them for nx ≤ 6).
pub const MAX_CORNERS: usize = 64;
/// Iterations each case is run for when its count is measured.
pub const MAX_PROBE: usize = 60;
/// The exact reference's tolerance on the IPM's relative residuals, gap and complementarity.
pub const EXACT_TOLERANCE: f64 = 1e-10;
/// The run-time limits are this many times the worst final residuals of the sample.
pub const LIMIT_FACTOR: f64 = 100.0;
/// The limits are at least this: below it a residual is converged whatever the sample's rounding was
/// (a limit at 100× a rounding-level residual would reject solves for their rounding alone).
pub const LIMIT_FLOOR: f64 = 1e-6;
/// The seed of the sample: the same spec gives the same evidence on every machine.
pub const SEED: u64 = 17;

/// `iterations = "auto"`: the worst count observed plus 10 %, at least 2.
pub fn margin(worst: usize) -> usize {
    worst.div_ceil(10).max(2)
}

/// A case's data: the state, the reference (per stage), the disturbance, the last input.
#[derive(Clone)]
struct Case {
    x0: DVector<f64>,
    reference: DVector<f64>,
    d: DVector<f64>,
    last: DVector<f64>,
}

/// Certifies the interior-point method of `p` on the region of `spec`, and resolves its iteration
/// count. Fails where the region cannot be resolved or a case does not reach `accuracy` within
/// [`MAX_PROBE`] iterations.
pub fn certify(spec: &Spec, p: &Problem) -> Result<Evidence, Diagnostics> {
    let region = resolve_region(spec, p)?;
    check_budget(spec, p)?;
    let qp = &p.qp;
    let nx = p.nx;
    let written = &spec.mpc.region;
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    let span = |key: &str| spec.spans.get(key);
    let nd = p.nd();
    let draw = |rng: &mut ChaCha8Rng, lo: &[f64], hi: &[f64]| {
        DVector::from_iterator(
            lo.len(),
            lo.iter().zip(hi).map(|(a, b)| rng.gen_range(*a..=*b)),
        )
    };
    let d_lo: Vec<f64> = (0..nd).map(|i| -qp.u_max[i]).collect();
    let d_hi: Vec<f64> = (0..nd).map(|i| -qp.u_min[i]).collect();
    let u_lo: Vec<f64> = qp.u_min.iter().copied().collect();
    let u_hi: Vec<f64> = qp.u_max.iter().copied().collect();
    let case = |rng: &mut ChaCha8Rng, x0: DVector<f64>| Case {
        x0,
        reference: draw(rng, &region.reference_min, &region.reference_max),
        d: draw(rng, &d_lo, &d_hi),
        last: if p.keeps_last_input() {
            draw(rng, &u_lo, &u_hi)
        } else {
            qp.rest_input()
        },
    };
    // Cold cases: corners, then draws.
    let corners_all = 1usize.checked_shl(nx as u32).unwrap_or(usize::MAX);
    let corners = corner_count(nx);
    let mut cases = Vec::new();
    for c in 0..corners {
        let bits: u64 = if corners_all <= MAX_CORNERS {
            c as u64
        } else {
            rng.gen()
        };
        let x0 = DVector::from_fn(nx, |i, _| {
            if bits >> (i % 64) & 1 == 1 {
                region.x_max[i]
            } else {
                region.x_min[i]
            }
        });
        cases.push(case(&mut rng, x0));
    }
    for _ in 0..written.samples.unwrap_or(DEFAULT_SAMPLES) {
        let x0 = draw(&mut rng, &region.x_min, &region.x_max);
        cases.push(case(&mut rng, x0));
    }
    let mut cold_counts = Vec::new();
    let mut infeasible_cases = 0;
    let mut cold_runs = Vec::new();
    for c in &cases {
        let (f, offset) = data(p, c);
        let problem = mpc_qp(qp, &f, &offset);
        let exact = solve(&problem, EXACT_TOLERANCE, 200);
        // No exact solution: the hard rows admit no plan (certified or not within the reference's
        // iterations); such a case tests the fallback, not the count.
        if exact.status != Status::Converged {
            infeasible_cases += 1;
            continue;
        }
        let run = trajectory(&problem, &Start::Cold, MAX_PROBE);
        let Some(k) = needed(qp, &run, &exact, &offset) else {
            return Err(not_reached(spec, "a cold case", c).into());
        };
        cold_counts.push(k);
        cold_runs.push((run, exact, offset));
    }
    if cold_counts.is_empty() {
        return Err(Diagnostic::new(
            "every case drawn from `[mpc.region]` is infeasible: the hard constraints admit no plan there",
            span("mpc.region").or(span("mpc")),
        )
        .note("hint: make the state bounds soft (`x_soft`), or draw the region inside the bounds")
        .into());
    }
    let cold_worst = *cold_counts.iter().max().unwrap_or(&1);
    // Warm sequences at a candidate count, raised until it covers what the warm steps need.
    let sequences = written.sequences.unwrap_or(DEFAULT_SEQUENCES);
    let steps = written.steps.unwrap_or(DEFAULT_STEPS);
    let starts: Vec<Case> = (0..sequences)
        .map(|_| {
            let x0 = draw(&mut rng, &region.x_min, &region.x_max);
            case(&mut rng, x0)
        })
        .collect();
    let fixed = match spec.mpc.iterations {
        Iterations::Fixed(n) => Some(n),
        Iterations::Auto => None,
    };
    let mut count = fixed.unwrap_or(cold_worst + margin(cold_worst));
    let mut warm = Warm::default();
    for _ in 0..4 {
        warm = warm_sequences(p, &starts, steps, count, spec)?;
        let worst = warm
            .counts
            .iter()
            .copied()
            .max()
            .unwrap_or(0)
            .max(cold_worst);
        let wanted = worst + margin(worst);
        if fixed.is_some() || wanted <= count {
            break;
        }
        count = wanted;
    }
    if count > MAX_ITERATIONS {
        return Err(Diagnostic::new(
            format!("the interior-point method would need {count} iterations"),
            span("mpc.iterations"),
        )
        .into());
    }
    // At the count used: the worst error and violation, cold and warm.
    let mut worst_error = warm.worst_error;
    let mut worst_violation = warm.worst_violation;
    for (run, exact, offset) in &cold_runs {
        let (e, v) = accuracy_of(qp, at(run, count), exact, offset);
        worst_error = worst_error.max(e);
        worst_violation = worst_violation.max(v);
    }
    // The residual limits, at the count that reaches the accuracy on every case (a fixed count below
    // it is then flagged at run time by its residuals, not accepted by them).
    let worst_needed = cold_worst.max(warm.counts.iter().copied().max().unwrap_or(0));
    let at_limit = count.max(worst_needed);
    let (mut primal, mut dual) = (0.0_f64, 0.0_f64);
    for s in cold_runs
        .iter()
        .map(|(run, _, _)| series(run))
        .chain(warm.series.iter().cloned())
    {
        let (p, d) = s[at_limit.min(s.len() - 1)];
        primal = primal.max(p);
        dual = dual.max(d);
    }
    let limits = Limits {
        primal: (LIMIT_FACTOR * primal).max(LIMIT_FLOOR),
        dual: (LIMIT_FACTOR * dual).max(LIMIT_FLOOR),
    };
    let median = |v: &mut Vec<usize>| {
        v.sort_unstable();
        v.get(v.len() / 2).copied().unwrap_or(0)
    };
    let mut warm_counts = warm.counts.clone();
    let cold_cases = cold_counts.len();
    Ok(Evidence {
        region,
        cold_cases,
        corners,
        infeasible_cases,
        warm_steps: warm.counts.len(),
        sequences,
        cold_worst,
        cold_median: median(&mut cold_counts),
        warm_worst: warm.counts.iter().copied().max().unwrap_or(0),
        warm_median: median(&mut warm_counts),
        iterations: count,
        auto: fixed.is_none(),
        worst_needed,
        worst_error,
        worst_violation,
        limits,
        fallbacks: warm.fallbacks,
    })
}

/// What the warm sequences showed at one count.
#[derive(Default)]
struct Warm {
    counts: Vec<usize>,
    worst_error: f64,
    worst_violation: f64,
    /// Per step, the relative (primal, dual) residuals after each iteration.
    series: Vec<Vec<(f64, f64)>>,
    fallbacks: usize,
}

/// The corners of the state region the sample uses: all 2^nx, at most [`MAX_CORNERS`].
fn corner_count(nx: usize) -> usize {
    1usize
        .checked_shl(nx as u32)
        .unwrap_or(usize::MAX)
        .min(MAX_CORNERS)
}

/// The sample's cost, predicted before it is spent: every case runs [`MAX_PROBE`] iterations and the
/// exact reference (about as many again; warm candidates up to four rounds), each iteration
/// [`mpc_macs_per_iteration`]. It counts against the build budget of lowering
/// ([`crate::budget::LOWERING_MACS`]), and a sample above it is refused at `[mpc.region]`.
fn check_budget(spec: &Spec, p: &Problem) -> Result<(), Diagnostics> {
    let written = &spec.mpc.region;
    let corners = corner_count(p.nx);
    let cold = corners + written.samples.unwrap_or(DEFAULT_SAMPLES);
    let warm =
        4 * written.sequences.unwrap_or(DEFAULT_SEQUENCES) * written.steps.unwrap_or(DEFAULT_STEPS);
    let macs = ((cold + warm) * 2 * MAX_PROBE) as f64 * mpc_macs_per_iteration(&p.qp) as f64;
    if macs <= crate::budget::LOWERING_MACS {
        return Ok(());
    }
    Err(Diagnostic::new(
        format!(
            "the interior-point method's certificate would take {macs:.2e} multiply-adds to sample, above the build's limit of {:.0e}",
            crate::budget::LOWERING_MACS
        ),
        spec.spans.get("mpc.region").or(spec.spans.get("mpc.method")),
    )
    .label(format!("{cold} cold cases and {warm} warm steps (up to four rounds), {} multiply-adds an iteration", mpc_macs_per_iteration(&p.qp)))
    .note("hint: fewer `samples`, `sequences` or `steps` in `[mpc.region]`, or a smaller problem")
    .into())
}

/// The relative (primal, dual) residuals of a run, iteration by iteration.
fn series(run: &[IpmResult]) -> Vec<(f64, f64)> {
    run.iter()
        .map(|r| (r.primal_residual, r.dual_residual))
        .collect()
}

/// Closed loops on the nominal model x⁺ = F x + G (u + d), each solve warm-started from the previous
/// one and run for `count` iterations, as the emitted controller does; every step's need is measured
/// from the same warm start.
fn warm_sequences(
    p: &Problem,
    starts: &[Case],
    steps: usize,
    count: usize,
    spec: &Spec,
) -> Result<Warm, Diagnostics> {
    let qp = &p.qp;
    let mut warm = Warm::default();
    for start_case in starts {
        let mut c = start_case.clone();
        let mut start = Start::Cold;
        let mut plan = qp.rest_plan();
        for _ in 0..steps {
            let (f, offset) = data(p, &c);
            let problem = mpc_qp(qp, &f, &offset);
            let exact = solve(&problem, EXACT_TOLERANCE, 200);
            if exact.status != Status::Converged {
                // Infeasible from here: the fallback takes over; the sequence ends.
                break;
            }
            let run = trajectory(&problem, &start, MAX_PROBE.max(count));
            let Some(k) = needed(qp, &run, &exact, &offset) else {
                return Err(not_reached(spec, "a warm closed-loop step", &c).into());
            };
            warm.counts.push(k);
            warm.series.push(series(&run));
            let step = control_step(qp, &f, &offset, &start, &plan, count, &Limits::NONE);
            let r = &step.result;
            let (e, v) = accuracy_of(qp, r, &exact, &offset);
            warm.worst_error = warm.worst_error.max(e);
            warm.worst_violation = warm.worst_violation.max(v);
            if step.fallback != Fallback::Solved {
                warm.fallbacks += 1;
            }
            start = shifted_start(qp, &step);
            plan = step.plan.clone();
            let u = plan.rows(0, p.nu).into_owned();
            let mut push = u.clone();
            for i in 0..c.d.len() {
                push[i] += c.d[i];
            }
            c.x0 = &p.F * &c.x0 + &p.G * push;
            c.last = u;
        }
    }
    Ok(warm)
}

/// f and the rows' offset of a case.
fn data(p: &Problem, c: &Case) -> (DVector<f64>, DVector<f64>) {
    let qp = &p.qp;
    let N = qp.N;
    let nz = qp.nz;
    let Xref = DVector::from_fn(N * nz, |i, _| c.reference[i % nz]);
    let f = &qp.Fx * &c.x0 - &qp.Fr * Xref + &qp.Fu * &c.last + qp.Fd.columns(0, c.d.len()) * &c.d;
    let offset = qp.rows.offset(&c.x0, &c.d, &c.last);
    (f, offset)
}

/// The iterate after `count` iterations (the last one when the run stopped early).
fn at(run: &[IpmResult], count: usize) -> &IpmResult {
    &run[count.min(run.len() - 1)]
}

/// |U − U*|∞ / span (worst input) and the worst hard-row violation of an iterate.
fn accuracy_of(qp: &Qp, r: &IpmResult, exact: &IpmResult, offset: &DVector<f64>) -> (f64, f64) {
    let nu = qp.u_min.len();
    let n = qp.N * nu;
    if r.z.len() < n || r.status == Status::NumericalFailure {
        return (f64::INFINITY, f64::INFINITY);
    }
    let U = DVector::from_fn(n, |i, _| {
        crate::linalg::project(r.z[i], qp.u_min[i % nu], qp.u_max[i % nu])
    });
    let error = (0..n)
        .map(|i| (U[i] - exact.z[i]).abs() / (qp.u_max[i % nu] - qp.u_min[i % nu]))
        .fold(0.0, f64::max);
    let (hard, _) = violations(qp, &U, offset);
    (error, hard)
}

/// The iterations a run needs: the first k from which every iterate meets the accuracy.
fn needed(qp: &Qp, run: &[IpmResult], exact: &IpmResult, offset: &DVector<f64>) -> Option<usize> {
    let ok: Vec<bool> = run
        .iter()
        .map(|r| {
            let (e, v) = accuracy_of(qp, r, exact, offset);
            e <= qp.accuracy && v <= qp.accuracy
        })
        .collect();
    if !ok.last().copied().unwrap_or(false) {
        return None;
    }
    let first_bad_from_end = ok.iter().rposition(|good| !good);
    Some(first_bad_from_end.map_or(0, |i| i + 1).max(1))
}

fn not_reached(spec: &Spec, what: &str, c: &Case) -> Diagnostic {
    Diagnostic::new(
        format!(
            "the interior-point method does not reach `accuracy = {:e}` within {MAX_PROBE} iterations on {what} of `[mpc.region]`",
            spec.mpc.accuracy
        ),
        spec.spans.get("mpc.accuracy").or(spec.spans.get("mpc.method")),
    )
    .label(format!("at x0 = {:?}", c.x0.as_slice()))
    .note("hint: loosen `accuracy`, scale the model's units so the Hessian is better conditioned, or narrow `[mpc.region]`")
}

/// The region: `[mpc.region]`, else the state bounds, else an error naming the unbounded state; the
/// references default to the tracked outputs' range over the state region.
pub fn resolve_region(spec: &Spec, p: &Problem) -> Result<Region, Diagnostics> {
    let nx = p.nx;
    let written = &spec.mpc.region;
    let c = &spec.mpc.constraints;
    let mut diags = Diagnostics::default();
    let mut x_min = vec![0.0; nx];
    let mut x_max = vec![0.0; nx];
    for i in 0..nx {
        let lo = written.x_min.get(i).copied().or(c
            .x_min
            .get(i)
            .copied()
            .filter(|b| b.is_finite()));
        let hi = written.x_max.get(i).copied().or(c
            .x_max
            .get(i)
            .copied()
            .filter(|b| b.is_finite()));
        match (lo, hi) {
            (Some(lo), Some(hi)) => {
                x_min[i] = lo;
                x_max[i] = hi;
            }
            _ => diags.push(
                Diagnostic::new(
                    format!("the interior-point method is certified on a sampled region, and state {i} has no range"),
                    spec.spans.get("mpc.region").or(spec.spans.get("mpc.method")),
                )
                .label(format!("x[{i}] is not bounded on both sides by `x_min`/`x_max`"))
                .note("hint: write `[mpc.region]` with `x_min` and `x_max` (nx entries each): the states the controller is expected to meet"),
            ),
        }
    }
    if !diags.is_empty() {
        return Err(diags.sorted());
    }
    let Cz = p.qp.Cz.clone().unwrap_or_else(|| DMatrix::identity(nx, nx));
    let range = |row: usize, upper: bool| {
        (0..nx)
            .map(|j| {
                let a = Cz[(row, j)];
                if (a >= 0.0) == upper {
                    a * x_max[j]
                } else {
                    a * x_min[j]
                }
            })
            .sum::<f64>()
    };
    let nz = Cz.nrows();
    let reference_min = if written.reference_min.is_empty() {
        (0..nz).map(|r| range(r, false)).collect()
    } else {
        written.reference_min.clone()
    };
    let reference_max = if written.reference_max.is_empty() {
        (0..nz).map(|r| range(r, true)).collect()
    } else {
        written.reference_max.clone()
    };
    Ok(Region {
        x_min,
        x_max,
        reference_min,
        reference_max,
    })
}
