//! The dual active-set method as the controller runs it: one control step on the MPC's QP, its
//! fallback and its warm start, the same in the oracle, the certificate and the emitted module.
//!
//! A step solves the QP of [`mpc_qp`] (relaxed where the controller is recovering, as the other
//! constrained methods do) from the previous step's working set, with at most [`Caps::warm`] changes
//! of the working set (the sample's warm-started need plus its margin) and [`Caps::warm_work`] work
//! (the kernel's multiply-adds and scanned rows weighed by their cost on the boards,
//! [`super::Macs::work`]: the sample's warm-started most plus its margin). A warm solve that runs out
//! (or cycles) restarts cold in the same step with at most [`Caps::cold`] changes, the sampled count
//! or the exact cold count where the certificate is exact and larger ([`Caps::of`]), and
//! [`Caps::cold_work`]. Within the region, for a constant reference window, a step ends at the
//! optimum after at most `warm + cold` changes; the build prices the work the budgets allow
//! ([`Caps::work_per_step`]), which follows a path's own cost where the changes at the worst pass
//! would price every change at a full working set. A solve that still ends anywhere but at the optimum
//! falls back: a truncated dual iterate is not primal feasible, so its plan is not used; the plan is the
//! previous one shifted by one step with the rest input appended, projected onto the box
//! ([`held_plan`]), and the next solve starts cold. With `[mpc] restart = "continue"`
//! ([`mpc_spec::Restart::Continue`]) a solve never restarts cold: every solve, cold or warm, spends at
//! most [`Caps::warm_work`], one that runs out falls back, and the next step resumes from the working
//! set where it stopped (the method keeps its iterate dual feasible, so that set is a valid start); a
//! step is priced at one such solve, of at most [`Caps::cold`] changes. The warm start is the previous working set as it was, not shifted in time: on the shipped
//! specs it needs fewer changes at the median than the shifted set (`codegen/tests/active_set.rs`
//! prints both).
#![allow(non_snake_case)]

use super::{
    solve_within, Outcome, Prepared, Status as Ended, Tolerances, WorkingSet, UNLIMITED_WORK,
};
use crate::lower::problem::Qp;
use crate::solver::constrained::Fallback;
use crate::solver::ipm::{held_plan, mpc_qp, relaxed, violations};
use mpc_spec::{Restart, Scalar};
use nalgebra::DVector;

/// The method's build-time data of `qp`: the QP's constant structure prepared (its f and sides do not
/// matter), with the rows its certificate proved slack over the region last in their blocks
/// (`Evidence::slack_rows`). `None` where a block of H is not positive definite, which lowering rules
/// out.
pub fn prepare(qp: &Qp) -> Option<Prepared> {
    let slack = qp.evidence.as_ref().map_or(&[][..], |e| &e.slack_rows[..]);
    prepare_with(qp, slack)
}

/// [`prepare`] with the rows of A in `slack` last in their blocks ([`Prepared::with_slack_rows`]).
pub fn prepare_with(qp: &Qp, slack: &[usize]) -> Option<Prepared> {
    let n = qp.Nc * qp.u_min.len();
    let structure = mpc_qp(qp, &DVector::zeros(n), &DVector::zeros(qp.rows.len()));
    let mut prepared = Prepared::with_slack_rows(&structure, slack).ok()?;
    // The slacks follow the plan's n variables.
    for b in &mut prepared.blocks {
        b.packed.refine = b.vars.iter().any(|v| *v >= n);
    }
    Some(prepared)
}

/// The changes of the working set a control step may make, and the work ([`super::Macs::work`]) each
/// solve may spend.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Caps {
    /// A solve from the previous working set (`WARM_ITERATIONS`): the most a warm-started step of the
    /// sample needed plus its margin (`Evidence::warm_cap`), at most the certified count. A warm solve needs a
    /// change or two at the median; one that needs more restarts cold, so a step's worst case is the
    /// cold cap plus this, not twice the cold cap.
    pub warm: usize,
    /// A cold solve, first or after a warm one ran out (`COLD_ITERATIONS`): the certified count
    /// (`ITERATIONS`), or the exact cold count where the certificate has one and it is larger.
    pub cold: usize,
    /// The warm solve's budget of work (`WARM_WORK`): the most a warm-started step of the sample spent
    /// plus its margin (`Evidence::warm_work_cap`); [`UNLIMITED_WORK`] without a sample.
    pub warm_work: usize,
    /// The cold solve's budget of work (`COLD_WORK`): the most a cold case of the sample spent, or
    /// where the exact count completed the larger of that and its heaviest path's, plus the margin
    /// (`Evidence::cold_work_cap`); [`UNLIMITED_WORK`] without a sample.
    pub cold_work: usize,
    /// What a warm solve that runs out does (`[mpc] restart`): restart cold in the step, or fall back
    /// and resume at the next, every solve then within [`Caps::warm_work`].
    pub restart: Restart,
}

impl Caps {
    /// The caps of `qp` as certified: cold the larger of `qp.iterations` and the exact count where the
    /// partition completed; warm the sample's warm-started need plus its margin, at most
    /// `qp.iterations` (`qp.iterations` without a sample); the budgets of work the sample's.
    pub fn of(qp: &Qp) -> Caps {
        let e = qp.evidence.as_ref();
        let exact = e.map_or(0, |e| e.exact_cold());
        let cold = qp.iterations.max(exact);
        Caps {
            warm: e.map_or(qp.iterations, |e| e.warm_cap()).min(qp.iterations),
            cold,
            warm_work: e.map_or(UNLIMITED_WORK, |e| e.warm_work_cap()),
            cold_work: e.and_then(|e| e.cold_work_cap()).unwrap_or(UNLIMITED_WORK),
            restart: qp.restart,
        }
    }

    /// `warm` changes warm, and cold the larger of `warm` and `exact`, without budgets of work (the
    /// sample runs its warm steps so: their needs, not these caps, set the count, `WARM_ITERATIONS` and
    /// the budgets).
    pub fn with(warm: usize, exact: usize) -> Caps {
        Caps {
            warm,
            cold: warm.max(exact),
            warm_work: UNLIMITED_WORK,
            cold_work: UNLIMITED_WORK,
            restart: Restart::Cold,
        }
    }

    /// The changes and the budget of work of a solve from `warm` (else cold). With
    /// [`Restart::Continue`] every solve has the cold cap of changes and the warm budget of work: a
    /// step then holds one solve, priced at that pair either way, and a solve that resumes from where
    /// the last ran out goes as far as the budget lets it.
    pub fn of_solve(&self, warm: bool) -> (usize, usize) {
        match (warm, self.restart) {
            (true, Restart::Cold) => (self.warm, self.warm_work),
            (false, Restart::Cold) => (self.cold, self.cold_work),
            (_, Restart::Continue) => (self.cold, self.warm_work),
        }
    }

    /// The most changes of the working set one control step makes: a warm solve that runs out, then
    /// the cold restart; with [`Restart::Continue`] one solve of the cold cap.
    pub fn per_step(&self) -> usize {
        match self.restart {
            Restart::Cold => self.warm + self.cold,
            Restart::Continue => self.of_solve(false).0,
        }
    }

    /// The most work one control step spends ([`super::Macs::work`]): a warm solve, then the cold
    /// restart, each [`SolveWork::at_most`] its caps; with [`Restart::Continue`] one solve
    /// ([`Caps::of_solve`]).
    pub fn work_per_step(&self, solve: SolveWork) -> usize {
        let cold = self.work_per_cold_solve(solve);
        match self.restart {
            Restart::Cold => solve
                .at_most(self.warm, self.warm_work)
                .saturating_add(cold),
            // A warm solve has the same caps as a cold one.
            Restart::Continue => cold,
        }
    }

    /// The most work a cold solve spends: [`Caps::work_per_step`]'s cold part.
    pub fn work_per_cold_solve(&self, solve: SolveWork) -> usize {
        let (changes, budget) = self.of_solve(false);
        solve.at_most(changes, budget)
    }
}

/// What a solve's work is bounded from ([`super::Macs::work`]).
#[derive(Clone, Copy, Debug)]
pub struct SolveWork {
    /// The worst pass of the iteration ([`work_per_pass`]).
    pub pass: usize,
    /// The offsets, before the first change ([`macs_offsets`]).
    pub before: usize,
    /// After the budget's last test: the recovery of z and in f32 the checks on it
    /// ([`work_after_budget`]).
    pub after: usize,
}

impl SolveWork {
    /// The work of the prepared QP's solves in `scalar`.
    pub fn of(prepared: &Prepared, scalar: mpc_spec::Scalar) -> SolveWork {
        use super::kernel64::WORK_SWEEP;
        SolveWork {
            pass: work_per_pass(prepared),
            before: macs_offsets(prepared) * WORK_SWEEP,
            after: work_after_budget(prepared, scalar),
        }
    }

    /// The most work a solve of at most `changes` changes and `budget` work spends: the lesser of
    /// its budget plus the pass that may start just under it and the offsets and `changes` passes,
    /// then what follows the last test.
    pub fn at_most(&self, changes: usize, budget: usize) -> usize {
        let passes = changes
            .saturating_mul(self.pass)
            .saturating_add(self.before);
        budget
            .saturating_add(self.pass)
            .min(passes)
            .saturating_add(self.after)
    }
}

/// One control step of the dual active-set method.
#[derive(Clone, Debug)]
pub struct Step {
    /// The plan U (N·nu), inside the input box.
    pub plan: DVector<f64>,
    /// The solve (its z includes the slacks).
    pub outcome: Outcome,
    /// Whether the plan is the solve's.
    pub fallback: Fallback,
    /// Whether the next step resumes from this one's working set where its solve ran out
    /// ([`Restart::Continue`]).
    pub resumes: bool,
}

impl Step {
    /// The next step's warm start: this step's working set where its plan is the optimum of the QP the
    /// certificate covers (not a relaxed one), or where its solve ran out of changes or work and the
    /// controller resumes ([`Restart::Continue`]); a cold start otherwise.
    pub fn next_start(&self) -> Option<WorkingSet> {
        let resume = self.resumes
            && self.fallback == Fallback::WarmStart
            && self.outcome.status == Ended::IterationLimit;
        (self.fallback == Fallback::Solved || resume).then(|| self.outcome.working_set.clone())
    }

    /// Whether the controller is recovering after this step: the hard rows admitted no plan, or the
    /// plan is a relaxed one.
    pub fn recovering(&self) -> bool {
        self.outcome.status == Ended::Infeasible || self.fallback == Fallback::Relaxed
    }
}

/// One control step: at most `caps.warm` changes of the working set from `start`, then, where that
/// ran out or cycled, a cold restart with at most `caps.cold` (cold from the first where `start` is
/// `None` or the step relaxes; no restart with [`Restart::Continue`], [`Caps::of_solve`]), by the kernel in `scalar` (f32 as an f32 module runs it); then the
/// plan, or the held plan where the solve did not end at the optimum. The outcome's iterations count
/// both solves.
#[allow(clippy::too_many_arguments)]
pub fn control_step(
    qp: &Qp,
    prepared: &Prepared,
    f: &DVector<f64>,
    offset: &DVector<f64>,
    start: Option<&WorkingSet>,
    previous_plan: &DVector<f64>,
    caps: Caps,
    recovering: bool,
    scalar: Scalar,
) -> Step {
    let held = held_plan(qp, previous_plan);
    let relax = recovering && violations(qp, &held, offset).0 > qp.accuracy;
    let mut problem = mpc_qp(qp, f, offset);
    if relax {
        problem = relaxed(qp, problem, &held);
    }
    let start = if relax { None } else { start };
    let tolerances = Tolerances::of(scalar);
    let outcome = match prepared.offsets(&problem) {
        Ok(offsets) => {
            let run =
                |start, cap| solve_within(prepared, &offsets, start, cap, &tolerances, scalar);
            let first = run(start, caps.of_solve(start.is_some()));
            let ran_out = matches!(first.status, Ended::IterationLimit | Ended::Cycling);
            if start.is_some() && ran_out && caps.restart == Restart::Cold {
                let mut restart = run(None, caps.of_solve(false));
                restart.iterations += first.iterations;
                for (b, k) in restart
                    .block_iterations
                    .iter_mut()
                    .zip(&first.block_iterations)
                {
                    *b += k;
                }
                restart
            } else {
                first
            }
        }
        Err(_) => failed(problem.n()),
    };
    let n = f.len();
    let nu = qp.u_min.len();
    if outcome.status == Ended::Solved {
        let plan = DVector::from_fn(n, |i, _| {
            crate::linalg::project(outcome.z[i], qp.u_min[i % nu], qp.u_max[i % nu])
        });
        return Step {
            plan,
            outcome,
            fallback: if relax {
                Fallback::Relaxed
            } else {
                Fallback::Solved
            },
            resumes: false,
        };
    }
    Step {
        plan: held,
        outcome,
        fallback: Fallback::WarmStart,
        resumes: caps.restart == Restart::Continue && !relax,
    }
}

/// The outcome of data the kernel refuses (a non-finite f or side): a numerical failure.
fn failed(n: usize) -> Outcome {
    Outcome {
        status: Ended::NumericalFailure,
        z: DVector::from_element(n, f64::NAN),
        working_set: WorkingSet::default(),
        multipliers: Vec::new(),
        iterations: 0,
        block_iterations: Vec::new(),
        macs: Default::default(),
        per_pass: Vec::new(),
    }
}

/// The worst pass of a block's iteration (one change of the working set, at a full working set of
/// n + 1): the scan's multiply-adds (a column of G per working entry), the rows it visits, and the
/// multiply-adds of an addition to the factor, a removal, the solve with the factor and the step.
fn worst_pass(b: &super::Block) -> (usize, usize, usize) {
    let (n, nc) = (b.n() + 1, b.rows.len());
    (
        nc * n,
        nc,
        n * n / 2 + 2 * n + n * n + 5 * n + n * n + 2 * n,
    )
}

/// Multiply-adds of the worst pass of the iteration over the blocks (`worst_pass`).
pub fn macs_per_iteration(prepared: &Prepared) -> usize {
    prepared
        .blocks
        .iter()
        .map(|b| {
            let (scan, _, factor) = worst_pass(b);
            scan + factor
        })
        .max()
        .unwrap_or(0)
}

/// The work ([`super::Macs::work`]) of the worst pass over the blocks (`worst_pass`), two ends of a
/// pass counted (a change and the test after it).
pub fn work_per_pass(prepared: &Prepared) -> usize {
    use super::kernel64::{WORK_MULTIPLY_ADD, WORK_PASS, WORK_ROW, WORK_SCAN};
    prepared
        .blocks
        .iter()
        .map(|b| {
            let (scan, rows, factor) = worst_pass(b);
            scan * WORK_SCAN + rows * WORK_ROW + factor * WORK_MULTIPLY_ADD + 2 * WORK_PASS
        })
        .max()
        .unwrap_or(0)
}

/// The work a solve may spend after its last test of the budget: the recovery of z, and in f32 the
/// primal refinement, the check on z and its restart ([`macs_f32_checks`], weighed as the factor's).
pub fn work_after_budget(prepared: &Prepared, scalar: mpc_spec::Scalar) -> usize {
    use super::kernel64::{WORK_MULTIPLY_ADD, WORK_SWEEP};
    macs_recovery(prepared) * WORK_SWEEP + macs_checks_in(prepared, scalar) * WORK_MULTIPLY_ADD
}

/// [`macs_f32_checks`] for a kernel in `scalar`: none in f64.
pub fn macs_checks_in(prepared: &Prepared, scalar: mpc_spec::Scalar) -> usize {
    match scalar {
        mpc_spec::Scalar::F32 => macs_f32_checks(prepared),
        mpc_spec::Scalar::F64 => 0,
    }
}

/// Multiply-adds the f32 kernel adds once per solve in a block with slacks ([`prepare`]): the primal
/// refinement on the working rows (their residuals, a solve with the factor, a recovery of z), the
/// check of every row on z, and the one restart they may call for (the offsets again, the working set
/// pushed back into the factor, the refinement again); the changes after it are within the count.
pub fn macs_f32_checks(prepared: &Prepared) -> usize {
    prepared
        .blocks
        .iter()
        .filter(|b| b.packed.refine)
        .map(|b| {
            let (n, k) = (b.n(), b.n() + 1);
            let mut lengths: Vec<usize> = b.coefficients.iter().map(Vec::len).collect();
            let rows: usize = lengths.iter().sum();
            lengths.sort_unstable_by(|x, y| y.cmp(x));
            let working: usize = lengths.iter().take(k).map(|l| l + 2).sum();
            let recovery = if b.packed.z_cols.is_empty() {
                working + n * (n + 1)
            } else {
                n * k
            };
            let refinement = working + k * k + recovery;
            let offsets = n * (n + 1) + rows + 2 * lengths.len();
            // The push of side j: its Gram entries and a substitution along L's rows, then its pivot.
            let pushes: usize = (0..k).map(|j| j + j * j.saturating_sub(1) / 2 + 1).sum();
            2 * refinement + rows + offsets + pushes
        })
        .sum()
}

/// Multiply-adds of what runs once per solve: the offsets (two triangular solves and a sparse row per
/// constraint) and the recovery of z, per block (a column of Z per working entry, or without Z the
/// working rows' coefficients, at most those of the n + 1 longest rows, and two triangular solves).
pub fn macs_once(prepared: &Prepared) -> usize {
    macs_offsets(prepared) + macs_recovery(prepared)
}

/// Multiply-adds of the offsets, [`macs_once`]'s first part.
pub fn macs_offsets(prepared: &Prepared) -> usize {
    prepared
        .blocks
        .iter()
        .map(|b| {
            let n = b.n();
            n * (n + 1) + b.coefficients.iter().map(|c| c.len() + 2).sum::<usize>()
        })
        .sum()
}

/// Multiply-adds of the recovery of z, [`macs_once`]'s second part.
pub fn macs_recovery(prepared: &Prepared) -> usize {
    prepared
        .blocks
        .iter()
        .map(|b| {
            let n = b.n();
            if b.packed.z_cols.is_empty() {
                let mut lengths: Vec<usize> = b.coefficients.iter().map(Vec::len).collect();
                lengths.sort_unstable_by(|x, y| y.cmp(x));
                lengths.iter().take(n + 1).sum::<usize>() + n * (n + 1)
            } else {
                n * (n + 1)
            }
        })
        .sum()
}
