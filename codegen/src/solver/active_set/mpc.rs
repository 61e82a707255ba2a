//! The dual active-set method as the controller runs it: one control step on the MPC's QP, its
//! fallback and its warm start, the same in the oracle, the certificate and the emitted module.
//!
//! A step solves the QP of [`mpc_qp`] (relaxed where the controller is recovering, as the other
//! constrained methods do) from the previous step's working set, with at most [`Caps::warm`] changes
//! of the working set (the sample's warm-started need plus its margin). A warm solve that runs out of
//! changes (or cycles) restarts cold in the same step with at most [`Caps::cold`]: the sampled count,
//! or the exact cold count where the certificate is exact and larger ([`Caps::of`]), so that within
//! the region, for a constant reference window, a step ends at the optimum after at most
//! `warm + cold` changes, which the build prices ([`Caps::per_step`]). A solve that still ends anywhere but at the optimum
//! falls back: a truncated dual iterate is not primal feasible, so its plan is not used; the plan is the
//! previous one shifted by one step with the rest input appended, projected onto the box
//! ([`held_plan`]), and the next solve starts cold. The warm start is the previous working set as it was, not shifted in time: on the shipped
//! specs it needs fewer changes at the median than the shifted set (`codegen/tests/active_set.rs`
//! prints both).
#![allow(non_snake_case)]

use super::{solve_in, Outcome, Prepared, Status as Ended, Tolerances, WorkingSet};
use crate::lower::problem::Qp;
use crate::solver::constrained::Fallback;
use crate::solver::ipm::{held_plan, mpc_qp, relaxed, violations};
use mpc_spec::Scalar;
use nalgebra::DVector;

/// The method's build-time data of `qp`: the QP's constant structure prepared (its f and sides do not
/// matter). `None` where a block of H is not positive definite, which lowering rules out.
pub fn prepare(qp: &Qp) -> Option<Prepared> {
    let n = qp.Nc * qp.u_min.len();
    let structure = mpc_qp(qp, &DVector::zeros(n), &DVector::zeros(qp.rows.len()));
    let mut prepared = Prepared::new(&structure).ok()?;
    // The slacks follow the plan's n variables.
    for b in &mut prepared.blocks {
        b.packed.refine = b.vars.iter().any(|v| *v >= n);
    }
    Some(prepared)
}

/// The changes of the working set a control step may make.
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
}

impl Caps {
    /// The caps of `qp` as certified: cold the larger of `qp.iterations` and the exact count where the
    /// partition completed; warm the sample's warm-started need plus its margin, at most
    /// `qp.iterations` (`qp.iterations` without a sample).
    pub fn of(qp: &Qp) -> Caps {
        let e = qp.evidence.as_ref();
        let exact = e.map_or(0, |e| e.exact_cold());
        Caps {
            warm: e.map_or(qp.iterations, |e| e.warm_cap()).min(qp.iterations),
            cold: qp.iterations.max(exact),
        }
    }

    /// `warm` changes warm, and cold the larger of `warm` and `exact` (the sample runs its warm steps
    /// so: their needs, not these caps, set the count and `WARM_ITERATIONS`).
    pub fn with(warm: usize, exact: usize) -> Caps {
        Caps {
            warm,
            cold: warm.max(exact),
        }
    }

    /// The most changes of the working set one control step makes: a warm solve that runs out, then
    /// the cold restart.
    pub fn per_step(&self) -> usize {
        self.warm + self.cold
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
}

impl Step {
    /// The next step's warm start: this step's working set where its plan is the optimum of the QP the
    /// certificate covers (not a relaxed one); a cold start otherwise.
    pub fn next_start(&self) -> Option<WorkingSet> {
        (self.fallback == Fallback::Solved).then(|| self.outcome.working_set.clone())
    }

    /// Whether the controller is recovering after this step: the hard rows admitted no plan, or the
    /// plan is a relaxed one.
    pub fn recovering(&self) -> bool {
        self.outcome.status == Ended::Infeasible || self.fallback == Fallback::Relaxed
    }
}

/// One control step: at most `caps.warm` changes of the working set from `start`, then, where that
/// ran out or cycled, a cold restart with at most `caps.cold` (cold from the first where `start` is
/// `None` or the step relaxes), by the kernel in `scalar` (f32 as an f32 module runs it); then the
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
            let run = |start, cap| solve_in(prepared, &offsets, start, cap, &tolerances, scalar);
            let cap = if start.is_some() {
                caps.warm
            } else {
                caps.cold
            };
            let first = run(start, cap);
            let ran_out = matches!(first.status, Ended::IterationLimit | Ended::Cycling);
            if start.is_some() && ran_out {
                let mut restart = run(None, caps.cold);
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
        };
    }
    Step {
        plan: held,
        outcome,
        fallback: Fallback::WarmStart,
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

/// Multiply-adds of the worst pass of the iteration (one change of the working set) over the blocks:
/// a scan of every constraint against a full working set, an addition to the factor, a removal, the
/// solve with the factor and the step.
pub fn macs_per_iteration(prepared: &Prepared) -> usize {
    prepared
        .blocks
        .iter()
        .map(|b| {
            let (n, nc) = (b.n() + 1, b.rows.len());
            nc * n + n * n / 2 + 2 * n + n * n + 5 * n + n * n + 2 * n
        })
        .max()
        .unwrap_or(0)
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
    prepared
        .blocks
        .iter()
        .map(|b| {
            let n = b.n();
            let offsets = n * (n + 1) + b.coefficients.iter().map(|c| c.len() + 2).sum::<usize>();
            let recovery = if b.packed.z_cols.is_empty() {
                let mut lengths: Vec<usize> = b.coefficients.iter().map(Vec::len).collect();
                lengths.sort_unstable_by(|x, y| y.cmp(x));
                lengths.iter().take(n + 1).sum::<usize>() + n * (n + 1)
            } else {
                n * (n + 1)
            };
            offsets + recovery
        })
        .sum()
}
