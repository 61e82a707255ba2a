//! Sampled certificates: evidence, not a proof. A fixed-iteration interior-point method has no
//! practical a priori bound (short-step theory asks 32-122× the counts observed), and a first-order
//! method's bound is on the gap of the cost, not on |U − U*|∞, and 2.4-3.6× the counts observed. So the
//! compiler runs the method ([`Sampled`]: [`crate::solver::ipm::sampled::InteriorPoint`], [`crate::solver::first_order::sampled::FirstOrder`], [`crate::solver::admm::sampled::Admm`]) at build time (in
//! f64; ADMM in the module's scalar, at the ρ [`crate::solver::admm::sampled::tune_admm`] measured on part of the sample), on a
//! seeded sample of the operating region `[mpc.region]` and measures how many iterations reach
//! `accuracy` against the exact solution (the interior-point method run to a 1e-10 tolerance,
//! cross-checked against Clarabel in the tests):
//! - **cold** cases: the region's corners (all of them up to [`MAX_CORNERS`], else that many drawn) and
//!   `samples` uniform draws of the state, the reference (constant over the horizon), the last input
//!   and the disturbance estimate;
//! - **warm** closed-loop sequences: `sequences` runs of `steps` steps on the nominal model from a drawn
//!   state towards a drawn reference, each solve warm-started from the previous one as the emitted
//!   controller does (a warm solve can need more iterations than a cold one).
//!
//! A case needs k iterations when every iterate from the k-th on has |U − U*|∞ ≤
//! accuracy·(u_max − u_min) per input and violates no hard row by more than accuracy·max(1, |bound|),
//! over a run at least twice k long (up to the method's most, [`Sampled::probe`]: [`MAX_PROBE`] for
//! the interior-point method, [`crate::solver::first_order::sampled::FIRST_ORDER_PROBE`] for a first-order one). `iterations = "auto"` is
//! the worst count observed plus [`margin`]. At the count used, the interior-point method's worst
//! final residuals set the run-time [`Limits`]: [`LIMIT_FACTOR`] times them (at least
//! [`LIMIT_FLOOR`]), above which the emitted solver falls back.
//!
//! The cold cases, and the warm sequences, are independent of one another: they run on every core
//! ([`crate::certify::parallel`]), and their multiply-adds are counted against the build's budget, and their
//! failures reported, in the sample's order, so the evidence and the diagnostics are the same on any
//! number of cores.
#![allow(non_snake_case)]

use crate::certify::evidence::Limits;
pub use crate::certify::evidence::{Evidence, Region};
use crate::lower::problem::{Problem, Qp};
use crate::solver::constrained::{InequalityQp, Status};
use crate::solver::ipm::{mpc_qp, violations, IpmResult};
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
use crate::solver::exact::exact;
pub use crate::solver::exact::EXACT_TOLERANCE;
/// The run-time limits are this many times the worst final residuals of the sample.
pub const LIMIT_FACTOR: f64 = 100.0;
/// The limits are at least this: below it a residual is converged whatever the sample's rounding was
/// (a limit at 100× a rounding-level residual would reject solves for their rounding alone).
pub const LIMIT_FLOOR: f64 = 1e-6;
/// More cases than this that neither exact solver resolves are a warning: the certificate's evidence
/// is then thinner than the sample asked for, in a part of the region the counts do not see.
pub const UNRESOLVED_WARNING: usize = 2;
/// The seed of the sample: the same spec gives the same evidence on every machine.
pub const SEED: u64 = 17;

pub use crate::certify::evidence::margin;

/// A case's data: the state, the reference (per stage), the disturbance, the last input.
#[derive(Clone)]
pub(crate) struct Case {
    pub(crate) x0: DVector<f64>,
    reference: DVector<f64>,
    pub(crate) d: DVector<f64>,
    pub(crate) last: DVector<f64>,
}

/// The names of the parameter θ = (x₀, r, u₋₁ where kept, d) of `p`'s cases, in that order: the
/// sample's witness and the exact count's parameters (`solver::active_set::exact`).
pub fn parameter_names(p: &Problem) -> Vec<String> {
    let nlast = if p.keeps_last_input() { p.nu } else { 0 };
    let named = |what: &'static str, n: usize| (0..n).map(move |i| format!("{what}[{i}]"));
    named("x0", p.nx)
        .chain(named("r", p.qp.nz))
        .chain(named("u_prev", nlast))
        .chain(named("d", p.nd()))
        .collect()
}

impl Case {
    /// θ of this case, named as [`parameter_names`].
    fn theta(&self, p: &Problem) -> Vec<(String, f64)> {
        let last = if p.keeps_last_input() {
            self.last.as_slice()
        } else {
            &[]
        };
        let values = self.x0.iter().chain(self.reference.iter().take(p.qp.nz));
        parameter_names(p)
            .into_iter()
            .zip(values.chain(last).chain(self.d.iter()).copied())
            .collect()
    }
}

/// What the certificate needs of a method: its iterates on one control step's QP ([`mpc_qp`]), and
/// its control step as the emitted controller runs it. One adapter per method, in its folder
/// (`solver/<method>/sampled.rs`).
pub trait Sampled: Sync {
    /// What one control step hands the next as its warm start.
    type Start: Clone + Send + Sync;
    /// Its name in prose, for the diagnostics: "the interior-point method".
    fn title(&self) -> &'static str;
    /// The start after `new`, `reset` or a fallback.
    fn cold(&self, qp: &Qp) -> Self::Start;
    /// Iterations a case is first run for, and at most: a run is doubled until the count it needs is
    /// at most half its length (every iterate from the count on, to at least twice it, meets
    /// `accuracy`), or the most is reached.
    fn probe(&self) -> (usize, usize);
    /// The start (element 0) and the iterates after 1 … `iterations` iterations (fewer where the method
    /// stopped on a failure, which is then last).
    fn trajectory(
        &self,
        qp: &Qp,
        problem: &InequalityQp,
        start: &Self::Start,
        iterations: usize,
    ) -> Vec<Iterate>;
    /// One control step of `count` iterations: the plan, what it hands the next step, and whether it
    /// fell back.
    fn control_step(
        &self,
        qp: &Qp,
        f: &DVector<f64>,
        offset: &DVector<f64>,
        start: &Self::Start,
        previous_plan: &DVector<f64>,
        count: usize,
    ) -> Stepped<Self::Start>;
    /// Multiply-adds of one iteration.
    fn macs_per_iteration(&self, qp: &Qp) -> usize;
    /// What one iteration costs the build, counted against its budget: the emitted count by default;
    /// more where the certificate's simulation of the method does more than the emitted code.
    fn sampled_macs_per_iteration(&self, qp: &Qp) -> usize {
        self.macs_per_iteration(qp)
    }
    /// Whether the method's final residuals are limited at run time ([`Limits`]).
    fn limits_residuals(&self) -> bool;
    /// The run-time limits' multiple of the sample's worst final residuals, given the sample's worst
    /// error at the count used (relative to the span) and `accuracy`: [`LIMIT_FACTOR`] for a method whose
    /// residuals fall much faster than its error near the solution (the interior-point method's).
    fn limit_factor(&self, _accuracy: f64, _worst_error: f64) -> f64 {
        LIMIT_FACTOR
    }
    /// The tuned parameters the evidence reports (ADMM's ρ and form); `None` for a method without them.
    fn admm(&self) -> Option<crate::solver::admm::Tuned> {
        None
    }
    /// Multiply-adds spent before the sample (ADMM's tuning of ρ), counted against the build's budget.
    fn spent_before(&self) -> f64 {
        0.0
    }
}

/// One iterate of a sampled method.
#[derive(Clone, Debug)]
pub struct Iterate {
    /// The plan (with the soft slacks after it, where the method has them).
    pub z: DVector<f64>,
    /// The relative primal residual (zero for a method without one).
    pub primal: f64,
    /// The relative dual residual (zero for a method without one).
    pub dual: f64,
    /// The relative duality gap (zero for a method without one).
    pub gap: f64,
    /// Whether the method failed here (its plan is then not judged).
    pub failed: bool,
    /// The work of the solve this iterate belongs to, for a method that counts it (the dual active
    /// set's [`crate::solver::active_set::Macs::work`], the same on each of a solve's iterates); else 0.
    pub work: usize,
}

/// One control step of a sampled method.
pub struct Stepped<S> {
    /// The solve's last iterate.
    pub iterate: Iterate,
    /// The plan the controller applies, inside the input box.
    pub plan: DVector<f64>,
    /// The next step's warm start.
    pub next: S,
    /// Whether the plan is a fallback rather than the solve's.
    pub fell_back: bool,
}

/// An iterate of a method without residuals: its plan alone.
pub fn plain_iterate(z: DVector<f64>) -> Iterate {
    Iterate {
        z,
        primal: 0.0,
        dual: 0.0,
        gap: 0.0,
        failed: false,
        work: 0,
    }
}

/// The multiply-adds the sample has spent, against the build's budget.
pub(crate) struct Spent {
    pub(crate) macs: f64,
}

impl Spent {
    pub(crate) fn add(&mut self, macs: f64, spec: &Spec, title: &str) -> Result<(), Diagnostics> {
        self.macs += macs;
        if self.macs <= crate::certify::budget::LOWERING_MACS {
            return Ok(());
        }
        Err(over_budget(spec, title))
    }
}

/// The diagnostic of a sample that has spent the build's budget, on `[mpc.region]`.
fn over_budget(spec: &Spec, title: &str) -> Diagnostics {
    Diagnostic::new(
        format!(
            "sampling {title}'s certificate has taken more than the build's limit of {:.0e} multiply-adds",
            crate::certify::budget::LOWERING_MACS
        ),
        region_span(spec),
    )
    .note("hint: fewer `samples`, `sequences` or `steps` in `[mpc.region]`, a looser `accuracy`, or a method that needs fewer iterations")
    .into()
}

/// The build's budget as parts of the sample running at once see it: everything they spent, in
/// whatever order. A part stops once it is over the limit (so the build stays within about the limit
/// whatever the threads do); which diagnostic that is, is then decided in the sample's order
/// ([`in_order`]).
struct Meter {
    macs: std::sync::Mutex<f64>,
}

impl Meter {
    fn new(macs: f64) -> Self {
        Meter {
            macs: std::sync::Mutex::new(macs),
        }
    }

    fn over(&self) -> bool {
        *self.macs.lock().unwrap_or_else(|e| e.into_inner()) > crate::certify::budget::LOWERING_MACS
    }

    fn add(&self, macs: f64) {
        *self.macs.lock().unwrap_or_else(|e| e.into_inner()) += macs;
    }
}

/// A part of the sample stopped by its [`Meter`].
struct Stopped;

/// A case run until its need is measured: the run and the count, `None` where it does not reach
/// `accuracy` within the method's most ([`Sampled::probe`]). The run is at least `at_least` long.
/// Each run's multiply-adds are pushed on `spends`, for the caller to count in the sample's order, and
/// added to `meter`, which stops the case once the build's budget is spent.
#[allow(clippy::too_many_arguments)]
fn measure<M: Sampled>(
    method: &M,
    qp: &Qp,
    problem: &InequalityQp,
    start: &M::Start,
    exact: &IpmResult,
    offset: &DVector<f64>,
    at_least: usize,
    spends: &mut Vec<f64>,
    meter: &Meter,
) -> Result<Option<(Vec<Iterate>, usize)>, Stopped> {
    let (first, most) = method.probe();
    let mut length = first.max(at_least);
    let per_iteration = method.sampled_macs_per_iteration(qp) as f64;
    loop {
        if meter.over() {
            return Err(Stopped);
        }
        let run = method.trajectory(qp, problem, start, length);
        spends.push(length as f64 * per_iteration);
        meter.add(length as f64 * per_iteration);
        let k = needed(qp, &run, exact, offset);
        match k {
            Some(k) if 2 * k <= length || length >= most => return Ok(Some((run, k))),
            None if length >= most => return Ok(None),
            _ => length = (2 * length).min(most.max(at_least)),
        }
    }
}

/// What one independent part of the sample (a cold case, a warm sequence) did, computed on its own
/// thread: the multiply-adds it spent, in order, and then its outcome.
struct Part<T> {
    spends: Vec<f64>,
    outcome: Outcome<T>,
}

/// How a [`Part`] ended.
enum Outcome<T> {
    /// It ran to its end.
    Done(T),
    /// This case did not reach `accuracy` within the method's most iterations.
    NotReached(Case),
    /// The [`Meter`] stopped the part.
    Stopped,
}

/// `work` on every item, on every core ([`crate::certify::parallel::until_failure`]), with the outcomes and the
/// diagnostic a loop over the items in the sample's order would give: the multiply-adds are counted
/// against the build's budget in that order, and the first failure in that order is the sample's. A
/// part the shared meter stopped (the parts together spent the budget), and every part after it, is run
/// again on its own, against the budget as the loop would have spent it so far.
fn in_order<I: Sync, T: Send, M: Sampled>(
    items: &[I],
    work: impl Fn(&I, &Meter) -> Part<T> + Sync,
    spent: &mut Spent,
    (spec, method, what): (&Spec, &M, &str),
) -> Result<Vec<T>, Diagnostics> {
    let shared = Meter::new(spent.macs);
    let mut parts: Vec<Option<Part<T>>> = crate::certify::parallel::until_failure(
        items,
        |item| work(item, &shared),
        |part| !matches!(part.outcome, Outcome::Done(_)),
    )
    .into_iter()
    .map(Some)
    .collect();
    let mut outcomes = Vec::with_capacity(items.len());
    for (index, item) in items.iter().enumerate() {
        let part = match parts.get_mut(index).and_then(Option::take) {
            Some(part) if !matches!(part.outcome, Outcome::Stopped) => part,
            _ => work(item, &Meter::new(spent.macs)),
        };
        for macs in part.spends {
            spent.add(macs, spec, method.title())?;
        }
        match part.outcome {
            Outcome::Done(t) => outcomes.push(t),
            Outcome::NotReached(c) => return Err(not_reached(spec, method, what, &c).into()),
            // Stopped alone, it has spent past the budget, and the sums above have said so.
            Outcome::Stopped => return Err(over_budget(spec, method.title())),
        }
    }
    Ok(outcomes)
}

/// Certifies `method` on the region of `spec` for the lowered `p`, and resolves its iteration count
/// (`iterations = "auto"`: the worst need plus [`margin`], at least `floor`). Fails where the region
/// cannot be resolved, the sample would exceed the build's budget, or a case does not reach
/// `accuracy` within the method's most iterations.
pub fn certify<M: Sampled>(
    spec: &Spec,
    p: &Problem,
    method: &M,
    floor: usize,
) -> Result<Evidence, Diagnostics> {
    certify_metered(spec, p, method, floor).map_err(|(d, _)| d)
}

/// [`certify`], with the multiply-adds spent (the method's [`Sampled::spent_before`] included) beside a
/// failure, so that a retry counts them against the build's budget.
pub fn certify_metered<M: Sampled>(
    spec: &Spec,
    p: &Problem,
    method: &M,
    floor: usize,
) -> Result<Evidence, (Diagnostics, f64)> {
    let mut spent = Spent {
        macs: method.spent_before(),
    };
    certify_spending(spec, p, method, floor, &mut spent).map_err(|d| (d, spent.macs))
}

fn certify_spending<M: Sampled>(
    spec: &Spec,
    p: &Problem,
    method: &M,
    floor: usize,
    spent: &mut Spent,
) -> Result<Evidence, Diagnostics> {
    let region = resolve_region(spec, p, method.title())?;
    check_budget(spec, p, method)?;
    let qp = &p.qp;
    let span = |key: &str| spec.spans.get(key);
    let Sample {
        cold: cases,
        corners,
        starts,
        sequences,
        steps,
    } = draw_sample(spec, p, &region);
    let mut cold_counts = Vec::new();
    let mut infeasible_cases = 0;
    let mut unresolved_cases = 0;
    let mut cold_runs = Vec::new();
    let mut cold_witness = Vec::new();
    // The heaviest cold case so far: (work, changes), the work first where the method counts it.
    let mut heaviest = None;
    let mut cold_work_worst = 0;
    let cold = method.cold(qp);
    let cold_case = |c: &Case, meter: &Meter| {
        let (f, offset) = data(p, c);
        let problem = mpc_qp(qp, &f, &offset);
        let exact = exact(&problem);
        // No exact solution: the hard rows admit no plan (certified by one of the two solvers), or
        // neither solver resolved it; such a case tests the fallback, not the count.
        if exact.status != Status::Converged {
            return Part {
                spends: Vec::new(),
                outcome: Outcome::Done(Err(exact.status)),
            };
        }
        let mut spends = Vec::new();
        let measured = measure(
            method,
            qp,
            &problem,
            &cold,
            &exact,
            &offset,
            0,
            &mut spends,
            meter,
        );
        let outcome = match measured {
            Ok(Some((run, k))) => Outcome::Done(Ok((run, k, exact, offset))),
            Ok(None) => Outcome::NotReached(c.clone()),
            Err(Stopped) => Outcome::Stopped,
        };
        Part { spends, outcome }
    };
    let outcomes = in_order(&cases, cold_case, spent, (spec, method, "a cold case"))?;
    for (c, outcome) in cases.iter().zip(outcomes) {
        let (run, k, exact, offset) = match outcome {
            Ok(solved) => solved,
            Err(Status::Infeasible) => {
                infeasible_cases += 1;
                continue;
            }
            Err(_) => {
                unresolved_cases += 1;
                continue;
            }
        };
        let work = run.last().map_or(0, |i| i.work);
        if heaviest.is_none_or(|h| (work, k) > h) {
            heaviest = Some((work, k));
            cold_witness = c.theta(p);
        }
        cold_work_worst = cold_work_worst.max(work);
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
    let fixed = match spec.mpc.iterations {
        Iterations::Fixed(n) => Some(n),
        Iterations::Auto => None,
    };
    let mut count = fixed.unwrap_or((cold_worst + margin(cold_worst)).max(floor));
    let mut warm = Warm::default();
    for _ in 0..4 {
        warm = warm_sequences(p, method, &starts, steps, count, spec, spent)?;
        let worst = warm
            .counts
            .iter()
            .copied()
            .max()
            .unwrap_or(0)
            .max(cold_worst);
        let wanted = (worst + margin(worst)).max(floor);
        if fixed.is_some() || wanted <= count {
            break;
        }
        count = wanted;
    }
    if count > MAX_ITERATIONS {
        return Err(Diagnostic::new(
            format!("{} would need {count} iterations", method.title()),
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
    let limits = if method.limits_residuals() {
        let (mut primal, mut dual, mut gap) = (0.0_f64, 0.0_f64, 0.0_f64);
        for s in cold_runs
            .iter()
            .map(|(run, _, _)| series(run))
            .chain(warm.series.iter().cloned())
        {
            let (p, d, g) = s[at_limit.min(s.len() - 1)];
            primal = primal.max(p);
            dual = dual.max(d);
            gap = gap.max(g);
        }
        let factor = method.limit_factor(qp.accuracy, worst_error);
        Limits {
            primal: (factor * primal).max(LIMIT_FLOOR),
            dual: (factor * dual).max(LIMIT_FLOOR),
            gap: (factor * gap).max(LIMIT_FLOOR),
        }
    } else {
        Limits::NONE
    };
    let median = |v: &mut Vec<usize>| {
        v.sort_unstable();
        v.get(v.len() / 2).copied().unwrap_or(0)
    };
    let mut warm_counts = warm.counts.clone();
    let cold_cases = cold_counts.len();
    Ok(Evidence {
        method: spec.mpc.method,
        region,
        cold_cases,
        corners,
        infeasible_cases,
        unresolved_cases: unresolved_cases + warm.unresolved,
        warm_steps: warm.counts.len(),
        sequences,
        cold_worst,
        cold_witness,
        cold_median: median(&mut cold_counts),
        cold_work_worst,
        warm_started_work_worst: warm.warm_started_work_worst,
        warm_worst: warm.counts.iter().copied().max().unwrap_or(0),
        warm_started_worst: warm.warm_started_worst,
        warm_median: median(&mut warm_counts),
        iterations: count,
        auto: fixed.is_none(),
        worst_needed,
        worst_error,
        worst_violation,
        limits,
        fallbacks: warm.fallbacks,
        sample_macs: spent.macs,
        rho: method.admm().map(|t| t.rho),
        admm_form: method.admm().map(|t| t.form),
        exact: None,
        slack_rows: Vec::new(),
    })
}

/// The seeded sample of `[mpc.region]`: the cold cases (corners, then draws) and the warm sequences'
/// first cases, drawn in that order from [`SEED`].
pub(crate) struct Sample {
    pub(crate) cold: Vec<Case>,
    corners: usize,
    pub(crate) starts: Vec<Case>,
    sequences: usize,
    pub(crate) steps: usize,
}

pub(crate) fn draw_sample(spec: &Spec, p: &Problem, region: &Region) -> Sample {
    let qp = &p.qp;
    let nx = p.nx;
    let written = &spec.mpc.region;
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
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
    let mut cold = Vec::new();
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
        cold.push(case(&mut rng, x0));
    }
    for _ in 0..written.samples.unwrap_or(DEFAULT_SAMPLES) {
        let x0 = draw(&mut rng, &region.x_min, &region.x_max);
        cold.push(case(&mut rng, x0));
    }
    let sequences = written.sequences.unwrap_or(DEFAULT_SEQUENCES);
    let steps = written.steps.unwrap_or(DEFAULT_STEPS);
    let starts = (0..sequences)
        .map(|_| {
            let x0 = draw(&mut rng, &region.x_min, &region.x_max);
            case(&mut rng, x0)
        })
        .collect();
    Sample {
        cold,
        corners,
        starts,
        sequences,
        steps,
    }
}

/// What the warm sequences showed at one count.
#[derive(Default)]
struct Warm {
    counts: Vec<usize>,
    /// The most any step after its sequence's first (which starts cold) needed: the warm-started need.
    warm_started_worst: usize,
    /// The most work such a step spent ([`Iterate::work`]).
    warm_started_work_worst: usize,
    worst_error: f64,
    worst_violation: f64,
    /// Per step, the relative (primal, dual) residuals after each iteration.
    series: Vec<Vec<(f64, f64, f64)>>,
    fallbacks: usize,
    /// Steps whose exact reference neither solver resolved (each ends its sequence).
    unresolved: usize,
}

/// The corners of the state region the sample uses: all 2^nx, at most [`MAX_CORNERS`].
fn corner_count(nx: usize) -> usize {
    1usize
        .checked_shl(nx as u32)
        .unwrap_or(usize::MAX)
        .min(MAX_CORNERS)
}

/// The cold cases and the warm steps of the certificate's sample of `spec` (an `nx`-state plant): the
/// corners and `samples`, and `sequences`·`steps`.
pub fn sample_cases(spec: &Spec, nx: usize) -> (usize, usize) {
    let r = &spec.mpc.region;
    (
        corner_count(nx) + r.samples.unwrap_or(DEFAULT_SAMPLES),
        r.sequences.unwrap_or(DEFAULT_SEQUENCES) * r.steps.unwrap_or(DEFAULT_STEPS),
    )
}

/// The hint of a sample over the build's budget ([`crate::certify::budget`]): which keys of `[mpc.region]` to
/// lower, with their values (written or default), and how they compose.
pub fn region_hint(spec: &Spec, nx: usize) -> String {
    let r = &spec.mpc.region;
    let (cold, warm) = sample_cases(spec, nx);
    let value = |v: Option<usize>, default: usize| match v {
        Some(v) => format!("{v}"),
        None => format!("{default} (default)"),
    };
    format!(
        "hint: the sample is {cold} cold cases (the corners and `samples` = {}) and {warm} warm steps (`sequences` = {} × `steps` = {}), each priced at the method's run and an exact solve; lower `samples`, or `sequences` × `steps`, in `[mpc.region]`, or shorten the `horizon`",
        value(r.samples, DEFAULT_SAMPLES),
        value(r.sequences, DEFAULT_SEQUENCES),
        value(r.steps, DEFAULT_STEPS),
    )
}

/// The sample's cost, predicted before it is spent: every case, cold and the warm steps' first round,
/// runs the method's first probe ([`Sampled::probe`]) and the exact reference (about as many iterations
/// again), each iteration [`Sampled::macs_per_iteration`], and costs
/// [`crate::certify::budget::CASE_OVERHEAD_MACS`] besides. It counts against the build budget of
/// lowering ([`crate::certify::budget::LOWERING_MACS`]), and a sample above it is refused at `[mpc.region]`.
/// What is spent past the prediction (a probe doubled past the first, the warm rounds after the first,
/// at most four in all) is counted as it is spent, against the same limit, and stops the sample there:
/// pricing all four rounds up front refused specs whose sample fits (hover's f32 ADMM on the M4F,
/// `codegen/tests/m4f.rs`).
fn check_budget<M: Sampled>(spec: &Spec, p: &Problem, method: &M) -> Result<(), Diagnostics> {
    let written = &spec.mpc.region;
    let corners = corner_count(p.nx);
    let cold = corners + written.samples.unwrap_or(DEFAULT_SAMPLES);
    let warm =
        written.sequences.unwrap_or(DEFAULT_SEQUENCES) * written.steps.unwrap_or(DEFAULT_STEPS);
    let per_iteration = method.sampled_macs_per_iteration(&p.qp);
    // The method's first probe, and the exact reference: about as many iterations again, or the
    // dense reference's price where that is more (ADMM's iterations are cheap, its reference is not);
    // after what the method spent before the sample (ADMM's tuning).
    let probe = method.probe().0 as f64 * per_iteration as f64;
    let exact = probe.max(crate::certify::budget::exact_macs(&p.qp));
    let macs = method.spent_before()
        + (cold + warm) as f64 * (probe + exact + crate::certify::budget::CASE_OVERHEAD_MACS);
    if macs <= crate::certify::budget::LOWERING_MACS {
        return Ok(());
    }
    Err(Diagnostic::new(
        format!(
            "{}'s certificate would take {macs:.2e} multiply-adds to sample, above the build's limit of {:.0e}",
            method.title(),
            crate::certify::budget::LOWERING_MACS
        ),
        region_span(spec),
    )
    .label(format!("{cold} cold cases and {warm} warm steps (their first round), {per_iteration} multiply-adds an iteration"))
    .note(region_hint(spec, p.nx))
    .into())
}

/// The relative (primal, dual) residuals of a run, iteration by iteration.
fn series(run: &[Iterate]) -> Vec<(f64, f64, f64)> {
    run.iter().map(|r| (r.primal, r.dual, r.gap)).collect()
}

/// Closed loops on the nominal model x⁺ = F x + G (u + d), each solve warm-started from the previous
/// one and run for `count` iterations, as the emitted controller does; every step's need is measured
/// from the same warm start.
fn warm_sequences<M: Sampled>(
    p: &Problem,
    method: &M,
    starts: &[Case],
    steps: usize,
    count: usize,
    spec: &Spec,
    spent: &mut Spent,
) -> Result<Warm, Diagnostics> {
    let sequence = |start_case: &Case, meter: &Meter| {
        warm_sequence(p, method, start_case, steps, count, meter)
    };
    let what = (spec, method, "a warm closed-loop step");
    let mut warm = Warm::default();
    for sequence in in_order(starts, sequence, spent, what)? {
        warm.warm_started_worst = warm.warm_started_worst.max(sequence.warm_started_worst);
        warm.warm_started_work_worst = warm
            .warm_started_work_worst
            .max(sequence.warm_started_work_worst);
        warm.counts.extend(sequence.counts);
        warm.series.extend(sequence.series);
        warm.worst_error = warm.worst_error.max(sequence.worst_error);
        warm.worst_violation = warm.worst_violation.max(sequence.worst_violation);
        warm.fallbacks += sequence.fallbacks;
        warm.unresolved += sequence.unresolved;
    }
    Ok(warm)
}

/// One closed loop of [`warm_sequences`] from `start_case`.
fn warm_sequence<M: Sampled>(
    p: &Problem,
    method: &M,
    start_case: &Case,
    steps: usize,
    count: usize,
    meter: &Meter,
) -> Part<Warm> {
    let qp = &p.qp;
    let mut warm = Warm::default();
    let mut spends = Vec::new();
    let per_iteration = method.sampled_macs_per_iteration(qp) as f64;
    let mut c = start_case.clone();
    let mut start = method.cold(qp);
    let mut plan = qp.rest_plan();
    for _ in 0..steps {
        let (f, offset) = data(p, &c);
        let problem = mpc_qp(qp, &f, &offset);
        let exact = exact(&problem);
        if exact.status != Status::Converged {
            // Infeasible from here (the fallback takes over), or unresolved: the sequence ends.
            warm.unresolved += usize::from(exact.status != Status::Infeasible);
            break;
        }
        let measured = measure(
            method,
            qp,
            &problem,
            &start,
            &exact,
            &offset,
            count,
            &mut spends,
            meter,
        );
        let (run, k) = match measured {
            Ok(Some(measured)) => measured,
            Ok(None) => {
                return Part {
                    spends,
                    outcome: Outcome::NotReached(c),
                }
            }
            Err(Stopped) => {
                return Part {
                    spends,
                    outcome: Outcome::Stopped,
                }
            }
        };
        if !warm.counts.is_empty() {
            warm.warm_started_worst = warm.warm_started_worst.max(k);
            let work = run.last().map_or(0, |i| i.work);
            warm.warm_started_work_worst = warm.warm_started_work_worst.max(work);
        }
        warm.counts.push(k);
        warm.series.push(series(&run));
        let step = method.control_step(qp, &f, &offset, &start, &plan, count);
        spends.push(count as f64 * per_iteration);
        meter.add(count as f64 * per_iteration);
        let (e, v) = accuracy_of(qp, &step.iterate, &exact, &offset);
        warm.worst_error = warm.worst_error.max(e);
        warm.worst_violation = warm.worst_violation.max(v);
        if step.fell_back {
            warm.fallbacks += 1;
        }
        start = step.next;
        plan = step.plan;
        let u = plan.rows(0, p.nu).into_owned();
        let mut push = u.clone();
        for i in 0..c.d.len() {
            push[i] += c.d[i];
        }
        c.x0 = &p.F * &c.x0 + &p.G * push;
        c.last = u;
    }
    Part {
        spends,
        outcome: Outcome::Done(warm),
    }
}

/// f and the rows' offset of a case.
pub(crate) fn data(p: &Problem, c: &Case) -> (DVector<f64>, DVector<f64>) {
    let qp = &p.qp;
    let N = qp.N;
    let nz = qp.nz;
    let Xref = DVector::from_fn(N * nz, |i, _| c.reference[i % nz]);
    let f = &qp.Fx * &c.x0 - &qp.Fr * Xref + &qp.Fu * &c.last + qp.Fd.columns(0, c.d.len()) * &c.d;
    let offset = qp.rows.offset(&c.x0, &c.d, &c.last);
    (f, offset)
}

/// The iterate after `count` iterations (the last one when the run stopped early).
fn at(run: &[Iterate], count: usize) -> &Iterate {
    &run[count.min(run.len() - 1)]
}

/// |U − U*|∞ / span (worst input) and the worst hard-row violation of an iterate.
fn accuracy_of(qp: &Qp, r: &Iterate, exact: &IpmResult, offset: &DVector<f64>) -> (f64, f64) {
    let nu = qp.u_min.len();
    let n = qp.Nc * nu;
    if r.z.len() < n || r.failed {
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
fn needed(qp: &Qp, run: &[Iterate], exact: &IpmResult, offset: &DVector<f64>) -> Option<usize> {
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

fn not_reached<M: Sampled>(spec: &Spec, method: &M, what: &str, c: &Case) -> Diagnostic {
    let most = method.probe().1;
    Diagnostic::new(
        format!(
            "{} does not reach `accuracy = {:e}` within {most} iterations on {what} of `[mpc.region]`",
            method.title(),
            spec.mpc.accuracy
        ),
        spec.spans.get("mpc.accuracy").or_else(|| region_span(spec)),
    )
    .label(format!("at x0 = {:?}", c.x0.as_slice()))
    .note("hint: loosen `accuracy`, scale the model's units so the Hessian is better conditioned, narrow `[mpc.region]`, or choose another `method`")
}

/// Where a finding about the sample points: `[mpc.region]`, else `method`, else the first constraint key
/// (under the default `auto` neither may be written), else `[mpc]`.
pub(crate) fn region_span(spec: &Spec) -> Option<mpc_spec::Span> {
    [
        "mpc.region",
        "mpc.method",
        "mpc.x_min",
        "mpc.x_max",
        "mpc.du_min",
        "mpc.du_max",
        "mpc.constraint",
        "mpc",
    ]
    .iter()
    .find_map(|k| spec.spans.get(k))
}

/// The region: `[mpc.region]`, else the state bounds, else an error naming the unbounded state; the
/// references default to the tracked outputs' range over the state region. `method` names the method in the error.
pub fn resolve_region(spec: &Spec, p: &Problem, method: &str) -> Result<Region, Diagnostics> {
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
                    format!("{method} is certified on a sampled region, and state {i} has no range"),
                    region_span(spec),
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Parts that spend `spends[i]` multiply-adds each (without computing anything), case `fails` not
    /// reaching `accuracy`: [`in_order`] must give what a loop in the sample's order gives, on any
    /// number of threads and whatever the shared meter stopped.
    fn run(spends: &[f64], fails: Option<usize>, threads: usize) -> Result<Vec<usize>, String> {
        let spec = mpc_spec::load(include_str!("../../../specs/paper-limits.toml")).unwrap();
        let items: Vec<usize> = (0..spends.len()).collect();
        let work = |&i: &usize, meter: &Meter| {
            // Late enough that a later part on another thread has spent first: the shared meter then
            // stops this one, which must be run again on its own.
            if i == 3 {
                std::thread::sleep(std::time::Duration::from_millis(50));
            }
            if meter.over() {
                return Part {
                    spends: Vec::new(),
                    outcome: Outcome::Stopped,
                };
            }
            meter.add(spends[i]);
            let case = Case {
                x0: DVector::from_element(1, i as f64),
                reference: DVector::zeros(1),
                d: DVector::zeros(1),
                last: DVector::zeros(1),
            };
            Part {
                spends: vec![spends[i]],
                outcome: if fails == Some(i) {
                    Outcome::NotReached(case)
                } else {
                    Outcome::Done(i)
                },
            }
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut spent = Spent { macs: 0.0 };
        pool.install(|| {
            in_order(
                &items,
                work,
                &mut spent,
                (
                    &spec,
                    &crate::solver::ipm::sampled::InteriorPoint,
                    "a cold case",
                ),
            )
            .map_err(|d| d.iter().next().unwrap().message.clone())
        })
    }

    #[test]
    fn parts_run_in_parallel_give_the_sequential_outcome_and_diagnostic() {
        let limit = crate::certify::budget::LOWERING_MACS;
        for threads in [1, 2, 4] {
            // Within the budget: every outcome, in order.
            assert_eq!(
                run(&[limit / 20.0; 10], None, threads),
                Ok((0..10).collect())
            );
            // Over it at the sixth part: the budget's diagnostic.
            let over = run(&[limit / 5.5; 10], None, threads).unwrap_err();
            assert!(over.contains("more than the build's limit"), "{over}");
            // A case that misses `accuracy` before the budget is spent is the diagnostic, even when
            // later parts, run at the same time, spend far more than the budget.
            let mut spends = vec![limit / 20.0; 10];
            spends[7] = 100.0 * limit;
            let missed = run(&spends, Some(3), threads).unwrap_err();
            assert!(missed.contains("does not reach `accuracy"), "{missed}");
            assert!(missed.contains("a cold case"), "{missed}");
            // ... and the budget is, when it is spent first in the sample's order.
            spends[1] = 100.0 * limit;
            let over = run(&spends, Some(3), threads).unwrap_err();
            assert!(over.contains("more than the build's limit"), "{over}");
        }
    }
}
