//! ADMM in the sampled certificate ([`crate::certify::sampling`]).

use crate::certify::evidence::Limits;
use crate::certify::sampling::{
    data, draw_sample, region_span, resolve_region, Iterate, Sampled, Spent, Stepped, LIMIT_FACTOR,
};
use crate::lower::problem::{Problem, Qp};
use crate::solver::constrained::Status;
use crate::solver::constrained::{Fallback, InequalityQp};
use crate::solver::exact::exact;
use crate::solver::ipm::mpc_qp;
use mpc_spec::{Diagnostic, Diagnostics, Spec};
use nalgebra::DVector;

/// ADMM ([`crate::solver::admm`]) at a tuned ρ ([`tune_admm`]), run in the module's scalar (`f32` runs the
/// f32 iteration: the certificate measures what the emitted solver does), warm-started from the
/// shifted (x, z, y).
pub struct Admm {
    /// The penalty (each row's is ρ times its curvature) and the x-update's form.
    pub tuned: crate::solver::admm::Tuned,
    /// Whether the iteration runs in f32.
    pub f32: bool,
    /// [`crate::solver::admm::tuned_settings`] of `tuned`.
    pub settings: crate::solver::admm::Settings,
    /// The multiply-adds the tuning spent.
    pub tuning_macs: f64,
    /// The most iterations a case is run for ([`ADMM_PROBE`]'s, or less where a cheaper rival is
    /// known).
    pub most: usize,
}

/// The first and the most iterations an ADMM case is run for when its count is measured.
pub const ADMM_PROBE: (usize, usize) = (256, 20000);

impl Admm {
    /// ADMM on `p` as `tuned` says, in `p`'s scalar.
    pub fn new(p: &Problem, tuned: crate::solver::admm::Tuned, tuning_macs: f64) -> Self {
        Admm {
            tuned,
            f32: p.scalar == mpc_spec::Scalar::F32,
            settings: crate::solver::admm::tuned_settings(&p.qp, tuned),
            tuning_macs,
            most: ADMM_PROBE.1,
        }
    }

    /// The same, a case run for at most `most` iterations (at least the first probe's).
    pub fn at_most(self, most: usize) -> Self {
        Admm {
            most: most.clamp(ADMM_PROBE.0, ADMM_PROBE.1),
            ..self
        }
    }
}

fn admm_iterate(r: &crate::solver::admm::AdmmResult) -> Iterate {
    Iterate {
        z: r.x.clone(),
        primal: r.primal_residual,
        dual: r.dual_residual,
        gap: r.gap,
        failed: r.status == crate::solver::admm::Status::NumericalFailure,
        work: 0,
    }
}

impl Sampled for Admm {
    type Start = crate::solver::admm::Start;

    fn title(&self) -> &'static str {
        "ADMM"
    }

    fn cold(&self, _qp: &Qp) -> crate::solver::admm::Start {
        crate::solver::admm::Start::Cold
    }

    fn probe(&self) -> (usize, usize) {
        (ADMM_PROBE.0, self.most)
    }

    fn trajectory(
        &self,
        _qp: &Qp,
        problem: &InequalityQp,
        start: &crate::solver::admm::Start,
        iterations: usize,
    ) -> Vec<Iterate> {
        let run = if self.f32 {
            crate::solver::admm::trajectory::<f32>(problem, &self.settings, start, iterations)
        } else {
            crate::solver::admm::trajectory::<f64>(problem, &self.settings, start, iterations)
        };
        run.iter().map(admm_iterate).collect()
    }

    fn control_step(
        &self,
        qp: &Qp,
        f: &DVector<f64>,
        offset: &DVector<f64>,
        start: &crate::solver::admm::Start,
        previous_plan: &DVector<f64>,
        count: usize,
    ) -> Stepped<crate::solver::admm::Start> {
        let step = if self.f32 {
            crate::solver::admm::control_step::<f32>
        } else {
            crate::solver::admm::control_step::<f64>
        };
        let step = step(
            qp,
            &self.settings,
            f,
            offset,
            start,
            previous_plan,
            count,
            &Limits::NONE,
            false,
        );
        Stepped {
            iterate: admm_iterate(&step.result),
            next: crate::solver::admm::shifted_start(qp, &step),
            fell_back: step.fallback != Fallback::Solved,
            plan: step.plan,
        }
    }

    fn macs_per_iteration(&self, qp: &Qp) -> usize {
        crate::solver::admm::mpc_settings_macs_per_iteration(qp, &self.settings)
    }

    fn sampled_macs_per_iteration(&self, qp: &Qp) -> usize {
        self.macs_per_iteration(qp) + crate::certify::budget::admm_simulation_overhead(qp)
    }

    fn limits_residuals(&self) -> bool {
        true
    }

    /// ADMM converges linearly: its error falls in proportion to its residuals, so a residual
    /// [`LIMIT_FACTOR`] times the sample's worst admits an error up to that many times the sample's
    /// (a cold case the sample missed was accepted at 5× `accuracy`, residual 15× the sample's worst).
    /// The limits allow the residuals to grow only as far as the error may: accuracy / worst error, at
    /// least 1, at most [`LIMIT_FACTOR`].
    fn limit_factor(&self, accuracy: f64, worst_error: f64) -> f64 {
        if worst_error > 0.0 {
            (accuracy / worst_error).clamp(1.0, LIMIT_FACTOR)
        } else {
            LIMIT_FACTOR
        }
    }

    fn admm(&self) -> Option<crate::solver::admm::Tuned> {
        Some(self.tuned)
    }

    fn spent_before(&self) -> f64 {
        self.tuning_macs
    }
}

/// Cold cases of the certificate's sample ADMM's ρ is tuned on: the first of them, in the sample's order.
pub const TUNING_COLD: usize = 32;
/// Steps of the warm sequence ρ is tuned on: the certificate's first sequence, flown by the exact solution.
pub const TUNING_WARM: usize = 32;

/// ADMM's ρ, measured on a subset of the certificate's own sample ([`crate::solver::admm::tune_rho`] in f64):
/// its first [`TUNING_COLD`] cold cases that have a solution, and [`TUNING_WARM`] steps of its first
/// warm sequence flown by the exact solution, each warm-started from the previous exact (x, z, y)
/// shifted. Returns ρ and the multiply-adds the search spent (counted against the build's budget).
pub fn tune_admm(spec: &Spec, p: &Problem) -> Result<(f64, f64), Diagnostics> {
    let region = resolve_region(spec, p, "ADMM")?;
    let qp = &p.qp;
    let sample = draw_sample(spec, p, &region);
    let nu = qp.u_min.len();
    let span = DVector::from_fn(qp.Nc * nu, |i, _| qp.u_max[i % nu] - qp.u_min[i % nu]);
    // Priced before it runs: an exact solve per tuning case, and the coarse grid's nine trials at
    // least the first probe on each, an iteration at the direct form's count and the simulation's
    // dense products and accuracy check.
    let per_iteration =
        (crate::solver::admm::mpc_macs_per_iteration_in(qp, crate::solver::admm::Form::Direct)
            + crate::certify::budget::admm_simulation_overhead(qp)) as f64;
    let tuning_cases = TUNING_COLD.min(sample.cold.len())
        + sample
            .starts
            .first()
            .map_or(0, |_| TUNING_WARM.min(sample.steps));
    let exact_cost = tuning_cases as f64 * crate::certify::budget::exact_macs(qp);
    let checked = per_iteration;
    let least = exact_cost + 9.0 * (tuning_cases * ADMM_PROBE.0) as f64 * checked;
    if least > crate::certify::budget::LOWERING_MACS {
        return Err(admm_over_budget(spec, p, least, tuning_cases, true));
    }
    let mut cases = Vec::new();
    for c in &sample.cold {
        if cases.len() == TUNING_COLD {
            break;
        }
        let (f, offset) = data(p, c);
        let problem = mpc_qp(qp, &f, &offset);
        let exact = exact(&problem);
        if exact.status == Status::Converged {
            cases.push(crate::solver::admm::Case {
                qp: problem,
                exact: exact.z,
                start: crate::solver::admm::Start::Cold,
                span: span.clone(),
            });
        }
    }
    if let Some(first) = sample.starts.first() {
        let mut c = first.clone();
        let mut start = crate::solver::admm::Start::Cold;
        for _ in 0..TUNING_WARM.min(sample.steps) {
            let (f, offset) = data(p, &c);
            let problem = mpc_qp(qp, &f, &offset);
            let exact = exact(&problem);
            if exact.status != Status::Converged {
                break;
            }
            cases.push(crate::solver::admm::Case {
                qp: problem.clone(),
                exact: exact.z.clone(),
                start: start.clone(),
                span: span.clone(),
            });
            let y = crate::solver::admm::duals_from_ipm(&problem, &exact);
            let cz = DVector::from_iterator(
                problem.n() + problem.A.nrows(),
                exact
                    .z
                    .iter()
                    .copied()
                    .chain((&problem.A * &exact.z).iter().copied()),
            );
            start = crate::solver::admm::shift(qp, &exact.z, &cz, &y);
            let u = exact.z.rows(0, p.nu).into_owned();
            let mut push = u.clone();
            for i in 0..c.d.len() {
                push[i] += c.d[i];
            }
            c.x0 = &p.F * &c.x0 + &p.G * push;
            c.last = u;
        }
    }
    let settings =
        |problem: &InequalityQp, rho: f64| crate::solver::admm::Settings::scaled(problem, rho);
    // The search stops once it has spent what the budget leaves after the exact solves.
    let most = ((crate::certify::budget::LOWERING_MACS - exact_cost) / checked).max(0.0) as usize;
    let tuned =
        crate::solver::admm::tune_rho_within(&cases, &settings, qp.accuracy, ADMM_PROBE.1, most);
    match tuned {
        Ok(t) => {
            let macs = exact_cost + t.iterations_run as f64 * checked;
            Spent { macs: 0.0 }.add(macs, spec, "ADMM")?;
            Ok((t.rho, macs))
        }
        Err(crate::solver::admm::Untuned::OverBudget(run)) => Err(admm_over_budget(
            spec,
            p,
            exact_cost + run as f64 * checked,
            tuning_cases,
            false,
        )),
        Err(crate::solver::admm::Untuned::NoRho) => Err(Diagnostic::new(
            format!(
                "ADMM reaches `accuracy = {:e}` within {} iterations at no ρ from 1e-4 to 1e4 on the tuning cases of `[mpc.region]`",
                spec.mpc.accuracy, ADMM_PROBE.1
            ),
            spec.spans.get("mpc.accuracy").or(spec.spans.get("mpc.method")).or(spec.spans.get("mpc.region")),
        )
        .note("hint: loosen `accuracy`, scale the model's units so the Hessian is better conditioned, narrow `[mpc.region]`, or choose `method = \"ipm\"`")
        .into()),
    }
}

/// The diagnostic of ADMM's tuning of ρ over the build's budget (`macs` predicted or spent), on the
/// method: ADMM's build cost grows with the horizon (an exact solve of every tuning case, then
/// thousands of iterations on each at up to thirteen ρ).
fn admm_over_budget(
    spec: &Spec,
    p: &Problem,
    macs: f64,
    cases: usize,
    predicted: bool,
) -> Diagnostics {
    let how = if predicted {
        format!("at least {macs:.2e} before any trial of ρ")
    } else {
        format!("its trials of ρ had spent {macs:.2e} when the next could run past it")
    };
    Diagnostic::new(
        format!(
            "tuning ADMM's ρ would take more than the build's limit of {:.0e} multiply-adds: {how}",
            crate::certify::budget::LOWERING_MACS
        ),
        spec.spans
            .get("mpc.method")
            .or_else(|| region_span(spec)),
    )
    .label(format!(
        "{cases} tuning cases at horizon N = {}, n = {} unknowns and {} rows each",
        p.qp.N,
        p.qp.H.nrows() + p.qp.rows.slacks(),
        p.qp.rows.len()
    ))
    .note("hint: `method = \"ipm\"` (or `\"auto\"`) certifies this problem at a fraction of ADMM's build cost; or shorten the `horizon`, or loosen `accuracy`")
    .into()
}
