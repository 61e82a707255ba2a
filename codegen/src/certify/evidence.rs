//! What a method's sampled certificate found ([`crate::certify::sampling`] computes it): plain data, so that the
//! lowered problem can carry it and the emitter and the certificate read it, without their depending
//! on the sampling.

/// The operating region the sample is drawn from.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Region {
    /// Lower corner of the states (nx).
    pub x_min: Vec<f64>,
    /// Upper corner of the states.
    pub x_max: Vec<f64>,
    /// Lower corner of the references (nz).
    pub reference_min: Vec<f64>,
    /// Upper corner of the references.
    pub reference_max: Vec<f64>,
}

/// `iterations = "auto"`: the worst count observed plus 10 %, at least 2 (here, beside the data it
/// sizes, so that this plain-data module imports nothing; [`crate::certify::sampling`] applies it).
pub fn margin(worst: usize) -> usize {
    worst.div_ceil(10).max(2)
}

/// What the sample showed.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Evidence {
    /// The method sampled.
    pub method: mpc_spec::Method,
    /// Where the sample was drawn.
    pub region: Region,
    /// Cold cases run (corners and draws) that have an exact solution.
    pub cold_cases: usize,
    /// Corners among them.
    pub corners: usize,
    /// Draws whose hard rows admit no plan (certified by the interior-point method or Clarabel,
    /// [`crate::solver::exact`]), left out of the counts: the fallback covers them.
    pub infeasible_cases: usize,
    /// Draws that neither exact solver resolved (a numerical failure of both), left out of the counts
    /// too; more than [`crate::certify::sampling::UNRESOLVED_WARNING`] is a warning.
    pub unresolved_cases: usize,
    /// Warm closed-loop steps run (sequences × steps).
    pub warm_steps: usize,
    /// Closed-loop sequences.
    pub sequences: usize,
    /// The most iterations a cold case needed.
    pub cold_worst: usize,
    /// The parameter of the first cold case that spent `cold_work_worst` (for a method that does not
    /// count work, that needed `cold_worst`), by name (`x0[i]`, `r[i]` for the
    /// constant reference, `u_prev[i]` where the last input is kept, `d[i]`): the state a board replays
    /// to measure the worst cold solve against the bound (`mpcc dump-qp --witness`).
    pub cold_witness: Vec<(String, f64)>,
    /// The median a cold case needed.
    pub cold_median: usize,
    /// The most work a cold case's solve spent, for a method that counts it (the dual active set's
    /// [`crate::solver::active_set::Macs::work`]; 0 for the others).
    pub cold_work_worst: usize,
    /// The most work a warm-started step's solve spent (the steps after each sequence's first), as
    /// `cold_work_worst`.
    pub warm_started_work_worst: usize,
    /// The most iterations a warm step needed.
    pub warm_worst: usize,
    /// The most a step started from the previous step's solution needed: the warm steps after each
    /// sequence's first, which starts cold (the dual active set's warm cap, `WARM_ITERATIONS`, is this
    /// plus its margin).
    pub warm_started_worst: usize,
    /// The median a warm step needed.
    pub warm_median: usize,
    /// The iterations per control step: `iterations` as written, or the worst observed plus the margin.
    pub iterations: usize,
    /// Whether `iterations` came from `"auto"`.
    pub auto: bool,
    /// The most iterations any case needed (cold or warm): a written `iterations` below it misses
    /// `accuracy` on part of the sample.
    pub worst_needed: usize,
    /// The worst |U − U*|∞ / span over every case at `iterations`.
    pub worst_error: f64,
    /// The worst hard-row violation (relative to max(1, |bound|)) at `iterations`.
    pub worst_violation: f64,
    /// The run-time limits on the final residuals.
    pub limits: Limits,
    /// Cases at `iterations` that fell back (none within the region, as far as the sample shows).
    pub fallbacks: usize,
    /// Multiply-adds the sample took at build time (against [`crate::certify::budget::LOWERING_MACS`]), ADMM's
    /// tuning of ρ included.
    pub sample_macs: f64,
    /// ADMM's penalty ρ, tuned on the sample ([`crate::solver::admm::tune_rho`]; each row's penalty is ρ times
    /// its curvature, [`crate::solver::admm::row_scales`]); `None` for the other methods.
    pub rho: Option<f64>,
    /// How ADMM's x-update is computed ([`crate::solver::admm::Form`]), chosen or as written; `None` for the
    /// other methods.
    pub admm_form: Option<mpc_spec::AdmmForm>,
    /// The exact count of the dual active-set method's cold start over the region, where
    /// `[mpc.region] certificate = "exact"` (the default) and the method is the dual active-set one; the
    /// certificate carries it apart from the sample ([`crate::certificate::Certificate::exact`]).
    #[serde(skip)]
    pub exact: Option<Exact>,
    /// The dual active-set method's rows of A proved unable to bind over the region
    /// ([`crate::solver::active_set::slack_rows`]): last in their blocks, scanned only where a solve's
    /// data fail the proof. Empty for the other methods.
    pub slack_rows: Vec<usize>,
}

impl Evidence {
    /// The dual active set's warm cap (`WARM_ITERATIONS`): the most a warm-started step needed plus its
    /// [`margin`], at most `iterations`.
    pub fn warm_cap(&self) -> usize {
        let needed = self.warm_started_worst;
        (needed + margin(needed)).min(self.iterations)
    }

    /// The dual active set's budget of work for a warm solve (`WARM_WORK`): the most a warm-started
    /// step spent plus its [`margin`].
    pub fn warm_work_cap(&self) -> usize {
        let spent = self.warm_started_work_worst;
        spent + margin(spent)
    }

    /// The dual active set's budget of work for a cold solve (`COLD_WORK`): the most a cold case
    /// spent, or where the exact count completed the larger of that and its heaviest path's work
    /// ([`Exact::cold_work`]), plus its [`margin`] (for the work the path's values decide: a
    /// refactorisation when a pivot gets small, the refinement at the optimum). `None` where the exact
    /// count completed without the paths' work: its cold cap is then the proof.
    pub fn cold_work_cap(&self) -> Option<usize> {
        let spent = match self.exact.as_ref().filter(|x| x.complete) {
            Some(x) => x.cold_work?.max(self.cold_work_worst),
            None => self.cold_work_worst,
        };
        Some(spent + margin(spent))
    }

    /// The exact cold count where the partition completed, else 0: what a cold solve's cap
    /// (`COLD_ITERATIONS`, [`crate::solver::active_set::mpc::Caps`]) must reach besides `iterations`.
    pub fn exact_cold(&self) -> usize {
        self.exact
            .as_ref()
            .filter(|x| x.complete)
            .map_or(0, |x| x.cold_worst)
    }
}

/// The exact iteration count of the dual active-set method's cold start over the region
/// ([`crate::solver::active_set::exact`]): a proof for every x₀ in the region's box, every reference
/// held constant over the window within its box, every u₋₁ in the input box and every disturbance in
/// its box, in exact arithmetic (the round-off margins are the module doc's). A reference window that
/// varies over the horizon is covered by the sample only.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Exact {
    /// Whether every block's partition completed within the build's budget
    /// ([`crate::certify::budget::EXACT_LPS`]). When not, the counts below are over the regions done,
    /// `note` says why, and the controller's cold cap is the sample's count.
    pub complete: bool,
    /// Why the partition did not complete (or was not tried); `None` when it completed.
    pub note: Option<String>,
    /// The dimension of the parameter θ (x₀, the constant reference, u₋₁ where kept, d).
    pub parameters: usize,
    /// Per block, the coordinates it is partitioned over: the parameters its sides depend on, by name,
    /// those acting in parallel combined (`x0[0] - r[0]`); their count is the partition's dimension.
    pub block_parameters: Vec<Vec<String>>,
    /// Final regions over all blocks.
    pub regions: usize,
    /// Regions where the hard rows admit no plan (the dual is unbounded there).
    pub infeasible_regions: usize,
    /// Regions where the exact iteration returns to a working set it left (a degenerate tie broken the
    /// same way each time): there the kernel's guard ends the solve (`Cycling`) and the controller falls
    /// back. They are outside `cold_worst`.
    pub cycling_regions: usize,
    /// The largest Chebyshev radius of a cycling region, in the block's parameters normalised to
    /// [−1, 1] (0 without one): how thin they are.
    pub cycling_radius: f64,
    /// Feasibility LPs solved.
    pub lps: usize,
    /// Changes of the working set a cold solve makes at most: the sum of the blocks' maxima.
    pub cold_worst: usize,
    /// Per block, its maximum.
    pub block_worst: Vec<usize>,
    /// θ where every block attains its maximum (the Chebyshev centres of the worst regions), by name.
    pub witness: Vec<(String, f64)>,
    /// The most work a cold solve spends over the region ([`crate::solver::active_set::Macs::work`], in
    /// tenths of a multiply-add of the factor's loops): the maximum over the execution paths, each
    /// region's path run by the kernel at its centre ([`crate::solver::active_set::exact::path_work`]).
    /// `None` when the partition did not complete (or two blocks share a parameter).
    pub cold_work: Option<usize>,
    /// θ where the cold solve spends `cold_work`, by name (empty without it): the state a board replays
    /// to measure the heaviest path against the bound.
    pub work_witness: Vec<(String, f64)>,
    /// Regions whose centre the kernel solved with another count of changes than the partition's: a
    /// decision within the kernel's tolerances, which the partition takes as zero (none in f64 on
    /// `tests/specs/active-set/exact-small.toml`; in f32, whose tolerances are wider, 98 of its 321
    /// regions, each one change fewer). Their work is counted as the kernel ran it.
    pub path_mismatches: usize,
    /// Seconds the partition took (not in the `report` module, which is reproducible).
    pub seconds: f64,
}

/// The limits above which a fixed-iteration solve is not trusted and [`crate::solver::constrained::Fallback::WarmStart`] is used.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Limits {
    /// On [`crate::solver::ipm::IpmResult::primal_residual`].
    pub primal: f64,
    /// On [`crate::solver::ipm::IpmResult::dual_residual`].
    pub dual: f64,
    /// On the relative duality gap ([`crate::solver::ipm::IpmResult::relative_gap`]): small residuals alone
    /// accept a point far from the optimum where the QP is infeasible by rounding.
    pub gap: f64,
}

impl Limits {
    /// No limit: only failures and infeasibility fall back.
    pub const NONE: Limits = Limits {
        primal: f64::INFINITY,
        dual: f64::INFINITY,
        gap: f64::INFINITY,
    };
}

/// One method `method = "auto"` weighed ([`crate::plan::choice`]).
#[derive(Clone, Debug, serde::Serialize)]
pub struct Candidate {
    /// The method.
    pub method: mpc_spec::Method,
    /// Why it could not be used, if it could not (the first finding of its lowering or certificate,
    /// or the rule that excludes it).
    pub unavailable: Option<String>,
    /// Its iterations per control step.
    pub iterations: usize,
    /// Multiply-adds of one iteration.
    pub macs_per_iteration: usize,
    /// Multiply-adds of one solve (iterations × per iteration).
    pub macs_per_solve: usize,
    /// Estimated cycles of one solve on the spec's target ([`crate::plan::target`]): what the choice ranks
    /// (infinite for an unavailable candidate; on the host one cycle a multiply-add).
    pub cycles_per_solve: f64,
    /// How its count is certified: `"sampled"` on `[mpc.region]`, `"a priori"` (the bound of
    /// `tolerance`) or `"as written"`.
    pub certified: &'static str,
    /// Whether its certificate shows it reaching `accuracy` at its count (`None`: no sample to show
    /// it, for a first-order method certified a priori or as written).
    pub reaches_accuracy: Option<bool>,
    /// Whether it was chosen.
    pub chosen: bool,
}

/// Fewer cold cases with a solution than this make a thin sample ([`thin`]).
pub const THIN_COLD: usize = 10;

/// A warning when the sample's feasible evidence is thin: fewer than [`THIN_COLD`] cold cases with a
/// solution, fewer with one than without, or no warm step at all while sequences were asked for. The
/// count is then certified on what few states of `[mpc.region]` the hard rows admit (a hard equality
/// row certified on one cold case of 84 and no warm step); the warning is on `[mpc.region]` (or, without
/// one, on the constraints its default comes from).
pub fn thin(spec: &mpc_spec::Spec, e: &Evidence) -> Option<mpc_spec::Diagnostic> {
    let drawn = e.cold_cases + e.infeasible_cases;
    let no_warm = e.sequences > 0 && e.warm_steps == 0;
    if e.cold_cases >= THIN_COLD && e.cold_cases >= e.infeasible_cases && !no_warm {
        return None;
    }
    let warm = if no_warm {
        "no warm step (every closed-loop sequence starts where the hard rows admit no plan)"
            .to_string()
    } else {
        format!("{} warm steps", e.warm_steps)
    };
    let at = [
        "mpc.region",
        "mpc.constraint",
        "mpc.x_min",
        "mpc.x_max",
        "mpc",
    ]
    .iter()
    .find_map(|k| spec.spans.get(k));
    Some(
        mpc_spec::Diagnostic::new(
            format!(
                "the certificate rests on thin evidence: {} of {drawn} cold cases of `[mpc.region]` have a solution, and {warm}",
                e.cold_cases
            ),
            at,
        )
        .label("the hard constraints admit no plan from most of this region")
        .note("hint: draw `[mpc.region]` where the hard rows admit a plan (its `x_min`/`x_max`), or make the rows soft (`soft`, `x_soft`); a count certified on a few cases says little about the rest"),
    )
}

/// A warning when more than a quarter of the draws of `[mpc.region]` are infeasible (and the evidence
/// is not [`thin`], which warns on its own): the certificate then rests on the part of the region the
/// hard rows admit, and the region is larger than the feasible set. It names the region's state corners,
/// `[mpc.region] x_min`/`x_max`, to shrink (where they are written; else the table, or the state bounds
/// the default region comes from).
pub fn infeasible_share(spec: &mpc_spec::Spec, e: &Evidence) -> Option<mpc_spec::Diagnostic> {
    let drawn = e.cold_cases + e.infeasible_cases;
    if 4 * e.infeasible_cases <= drawn {
        return None;
    }
    let at = [
        "mpc.region.x_max",
        "mpc.region.x_min",
        "mpc.region",
        "mpc.x_max",
        "mpc.x_min",
        "mpc.constraint",
        "mpc",
    ]
    .iter()
    .find_map(|k| spec.spans.get(k));
    Some(
        mpc_spec::Diagnostic::new(
            format!(
                "{} of the {drawn} cold cases drawn from `[mpc.region]` are infeasible ({:.0} %, more than a quarter): the certificate rests on the other {}",
                e.infeasible_cases,
                100.0 * e.infeasible_cases as f64 / drawn as f64,
                e.cold_cases
            ),
            at,
        )
        .label("the hard constraints admit no plan from part of this region")
        .note("hint: shrink `[mpc.region]`'s `x_min`/`x_max` (and `reference_min`/`reference_max`) to the states the controller must start from, which the hard rows admit; or make the rows soft (`soft`, `x_soft`)"),
    )
}
