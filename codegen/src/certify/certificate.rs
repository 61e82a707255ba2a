//! What the compiler proves about a controller, computed at compile time from the lowered problem:
//! the QP's conditioning and the solver's rates, an a priori iteration bound, the nominal stability of
//! the paper (Section 2.4.3) and of the MPC itself, and the emitted code's resources.
//!
//! # The a priori bound
//! Each algorithm states its own bound on the gap Δ_k = J(U_k) − J* of the box-constrained QP
//! ([`crate::solver::first_order::Algorithm::rate`]; the proofs' sources are in `solver/gradient.rs` and `solver/fgm.rs`).
//! They hold for any start inside the box, warm or cold. Steps above 1/L have no such bound (they may still
//! converge: see [`Certificate::contraction`]).
#![allow(non_snake_case)]

use crate::certify::budget::{self, BuildCost};
pub use crate::certify::coordinates::CoordinateRange;
use crate::linalg::{extreme_eigenvalues, lqr_gain, lyapunov_identity, spectral_radius};
use crate::lower::problem::{Filter, Problem};
use crate::numeric::Numeric;
use crate::plan::cost::Estimate;
use crate::plan::Plan;
pub use crate::solver::first_order::Rate;
use mpc_spec::{Diagnostic, Diagnostics, Emission, FilterKind, Iterations, Spec};
use nalgebra::DMatrix;
use serde::Serialize;

/// The tolerance the report uses when the spec gives none.
pub const DEFAULT_TOLERANCE: f64 = 1e-4;

/// Above this many decision variables the solver's closed loop (an (nx + N·nu)-dimensional linear system
/// built by unrolling every iteration) is not formed at compile time.
pub const MAX_SOLVER_ANALYSIS_SIZE: usize = 300;

/// The paper's nominal stability check: an LQR gain from the stage weights and its closed loop.
#[derive(Clone, Debug, Serialize)]
pub struct Lqr {
    /// K of the discrete algebraic Riccati equation with Q and R (nu × nx).
    #[serde(skip)]
    pub gain: DMatrix<f64>,
    /// ρ(F − G·K).
    pub spectral_radius: f64,
    /// λmin of P solving (F − GK)ᵀ P (F − GK) − P = −I (NaN when the loop is unstable).
    pub lyapunov_min: f64,
    /// λmax of that P.
    pub lyapunov_max: f64,
}

/// The MPC's own closed loops, constraints inactive and references zero.
#[derive(Clone, Debug, Serialize)]
pub struct MpcLoop {
    /// The unconstrained receding-horizon gain: the first block of H⁻¹·Fx, so u = −K·x (nu × nx); with
    /// weighted moves of H⁻¹·[Fx Fu], u = −K·(x, u₋₁).
    #[serde(skip)]
    pub gain: DMatrix<f64>,
    /// ρ(F − G·K) for that gain: the loop an exactly solved MPC closes.
    pub spectral_radius: f64,
    /// Whether the moves are weighted, so that this gain and the LQR's act on (x, u₋₁).
    #[serde(skip)]
    pub moves: bool,
    /// ρ of the loop the fixed-iteration, warm-started solver actually closes, a linear system in the
    /// state and the previous plan; `None` for problems above [`MAX_SOLVER_ANALYSIS_SIZE`] decision variables
    /// or [`budget::SOLVER_ANALYSIS_MACS`] multiply-adds, and for algorithms whose iteration is not linear.
    pub solver_spectral_radius: Option<f64>,
}

/// The emitted code's cost.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Resources {
    /// Multiply-adds of one solver iteration.
    pub macs_per_iteration: usize,
    /// Multiply-adds of one control cycle (filter update and predict, gradient map, the solve).
    pub macs_per_cycle: usize,
    /// Multiply-adds of one control step's solve as the cost model prices it
    /// ([`crate::plan::Solver::macs_per_step`]), in the solver's scalar.
    pub macs_per_solve: usize,
    /// Multiply-adds the solver does once a solve besides its iterations (the interior-point method's
    /// cold start, which every solve computes; ADMM's final residuals), in the solver's scalar.
    pub macs_once_per_solve: usize,
    /// Bytes of the nonzero coefficients inlined into the code (±1 become additions and cost nothing).
    pub bytes_constants: usize,
    /// Bytes of `Mpc` (the plan).
    pub bytes_state_mpc: usize,
    /// Bytes of `Kalman` (the estimate, the covariance for the time-varying filter, the screening's
    /// memory and its status).
    pub bytes_state_kalman: usize,
    /// Bytes of `Controller`: everything carried between control cycles.
    pub bytes_state: usize,
    /// Multiply-adds of the filter's update and predict, unrolled in the emitted code.
    pub macs_filter: usize,
}

/// Everything the compiler proves and counts about one controller. Its JSON (`mpcc check --json`) is this
/// struct through serde, under the field names; the `report` module and the text of `mpcc check` come from
/// [`Certificate::fields`].
#[derive(Clone, Debug, Serialize)]
pub struct Certificate {
    /// L = λmax(H).
    pub lipschitz: f64,
    /// μ = λmin(H).
    pub strong_convexity: f64,
    /// L/μ.
    pub condition_number: f64,
    /// The step α.
    pub step: f64,
    /// The momentum β (0 for the gradient method).
    pub momentum: f64,
    /// The asymptotic contraction of the error per iteration, constraints inactive: max over the
    /// eigenvalues λ of H of |1 − αλ| (gradient) or of the spectral radius of the 2 × 2 momentum
    /// recursion (fast gradient). Below 1 exactly when the iteration converges.
    pub contraction: f64,
    /// The iterations per control step.
    pub iterations: usize,
    /// The relative suboptimality of the bound (the spec's `tolerance`, or [`DEFAULT_TOLERANCE`]).
    pub tolerance: f64,
    /// The a priori rate, if the step has one.
    pub rate: Option<Rate>,
    /// The iterations the bound needs for `tolerance`.
    pub iterations_bound: Option<usize>,
    /// What `iterations` guarantee: Δ_m/Δ_0 ≤ this.
    pub guaranteed_gap: Option<f64>,
    /// The paper's LQR check.
    pub lqr: Lqr,
    /// The MPC's own loops.
    pub mpc: MpcLoop,
    /// Costs.
    #[serde(flatten)]
    pub resources: Resources,
    /// How the gradient is emitted.
    pub emission: Emission,
    /// The cost model's estimate of every emission choice ([`crate::plan::cost`]).
    #[serde(rename = "emission_estimates")]
    pub estimates: Vec<Estimate>,
    /// What building the module is predicted to cost ([`crate::certify::budget`]).
    pub build_cost: BuildCost,
    /// The disturbance estimate's time constant in seconds, with `[kalman] disturbance`: −Δt / ln ρ of the
    /// steady-state estimation error dynamics F_a(I − K∞C_a), whose slowest mode is the disturbance's.
    pub disturbance_time_constant: Option<f64>,
    /// The absolute coordinates each scalar type can carry with u₀ within 1 % of the smallest input span
    /// ([`crate::certify::coordinates`]).
    pub coordinate_range: CoordinateRange,
    /// The sampled evidence of `[mpc.region]` ([`crate::certify::sampling`]): always for the interior-point
    /// method, for a first-order method when the spec has a region (its a priori bound stays beside it).
    pub sampled: Option<crate::certify::evidence::Evidence>,
    /// The dual active-set method's exact cold count over `[mpc.region]` ([`crate::solver::active_set::exact`]),
    /// where `[mpc.region] certificate = "exact"` (the default): for constant reference windows.
    pub exact: Option<crate::certify::evidence::Exact>,
    /// Changes of the working set one control step of the dual active-set method makes at most: a warm
    /// solve of `iterations` that runs out, then a cold restart of `cold_iterations`.
    pub cold_iterations: Option<usize>,
    /// The dual active set's budgets of work, warm solve then cold (`WARM_WORK`, `COLD_WORK`;
    /// [`crate::certify::evidence::Evidence::cold_work_cap`]; with `restart = "continue"` a cold solve
    /// has the warm budget).
    pub work_budgets: Option<(usize, Option<usize>)>,
    /// The dual active set's `[mpc] restart`: what a warm solve that runs out does.
    pub restart: Option<mpc_spec::Restart>,
    /// The multiply-adds the cost model prices for a cold solve alone, where a step may hold two
    /// ([`crate::plan::Solver::macs_per_cold_solve`]): the figure a board's worst cold case is held to.
    pub cold_solve_macs: Option<usize>,
    /// `[mpc] accuracy`.
    pub accuracy: f64,
    /// The interior-point method's form of its normal system, with the multiply-adds of an iteration in
    /// each form ([`crate::solver::riccati::Choice`]); `None` for the other methods.
    pub normal_form: Option<crate::solver::riccati::Choice>,
    /// ADMM's structure of its x-update, with the multiply-adds of an iteration in each
    /// ([`crate::solver::admm::StructureChoice`]); `None` for the other methods and before ρ is tuned.
    pub admm_structure: Option<crate::solver::admm::StructureChoice>,
    /// The method as written (`auto` when it was not); the method used is the problem's.
    pub method_requested: mpc_spec::Method,
    /// What `method = "auto"` weighed ([`crate::plan::choice`]); empty for a written method.
    pub candidates: Vec<crate::certify::evidence::Candidate>,
}

/// A number of the certificate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// A real number (NaN where it does not exist, as the Lyapunov solution of an unstable loop).
    Real(f64),
    /// A count.
    Count(usize),
    /// A real number that may be absent (the bound of a step above 1/L).
    MaybeReal(Option<f64>),
    /// A count that may be absent.
    MaybeCount(Option<usize>),
}

/// How `mpcc check` shows a number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shown {
    /// The number.
    Plain,
    /// A spectral radius with its verdict, stable or not.
    Stability,
    /// A contraction with its verdict, converges or not.
    Convergence,
    /// The step and its multiple of 1/L.
    Step,
    /// The tolerance and where it came from.
    Tolerance,
    /// The guaranteed gap ratio after the iterations.
    Gap,
    /// The number, and its section only when it is present.
    IfPresent,
    /// A size in bytes ("840 MB").
    Bytes,
    /// A time in seconds.
    Seconds,
    /// The range of the absolute coordinates: "for |x[0..3]| ≤ 3.2e3".
    Range,
}

/// One number of the certificate under the names of its outputs: the `report` module's constant and the
/// line of `mpcc check` (the JSON is the [`Certificate`] itself).
#[derive(Clone, Debug, PartialEq)]
pub struct Field {
    /// Its key in the JSON (dotted for a nested object): the serde name of the certificate's field.
    pub json: &'static str,
    /// The `report` constant; empty for a number the report does not carry (the build's cost).
    pub constant: &'static str,
    /// Its doc.
    pub doc: &'static str,
    /// The section of `mpcc check`.
    pub section: &'static str,
    /// The line's label.
    pub label: String,
    /// How the line shows it.
    pub shown: Shown,
    /// The number.
    pub value: Value,
}

/// The sections of `mpcc check`, in order.
pub mod section {
    /// The QP's conditioning.
    pub const QP: &str = "QP (condensed Hessian H)";
    /// The algorithm's parameters.
    pub const SOLVER: &str = "solver";
    /// The a priori bound.
    pub const BOUND: &str = "a priori bound (any start inside the box)";
    /// The paper's LQR check.
    pub const LQR: &str = "nominal stability: LQR of Q and R (paper, 2.4.3)";
    /// The MPC's loops.
    pub const LOOPS: &str = "MPC closed loops (constraints inactive)";
    /// The disturbance estimate.
    pub const OFFSET_FREE: &str = "offset-free: the input disturbance estimate";
    /// The absolute coordinates the scalar types can carry ([`crate::certify::coordinates`]).
    pub const COORDINATES: &str =
        "absolute coordinates (rounding; first-order, worst case over signs)";
    /// The code's cost.
    pub const RESOURCES: &str = "resources";
    /// The sampled certificate of `[mpc.region]`.
    pub const SAMPLED: &str = "evidence sampled on [mpc.region], not a proof";
    /// The exact count of the dual active-set method.
    pub const EXACT: &str =
        "exact count over [mpc.region] (dual active-set, cold start, constant reference window)";
    /// The build's predicted cost ([`crate::certify::budget`]); not in the `report` module.
    pub const BUILD: &str = "build cost (predicted; limits in codegen::budget)";
}

impl Certificate {
    /// Every scalar of the certificate in the order `mpcc check` prints them; the `report` module emits
    /// each as a constant (with `RATE`, `LQR_GAIN` and `MPC_GAIN` beside them).
    pub fn fields(&self) -> Vec<Field> {
        use section::*;
        use Shown::*;
        use Value::*;
        let field = |json, constant, doc, section, label: &str, shown, value| Field {
            json,
            constant,
            doc,
            section,
            label: label.to_string(),
            shown,
            value,
        };
        let (r, b) = (&self.resources, &self.build_cost);
        let range = &self.coordinate_range;
        let percent = format!("{}", range.accuracy * 100.0);
        let keeps =
            |scalar: &str| format!("{scalar} keeps u₀ within {percent} % of the input span");
        let mut fields = vec![
            field("lipschitz", "LIPSCHITZ", "L, the largest eigenvalue of the Hessian H.", QP, "L = λmax(H)", Plain, Real(self.lipschitz)),
            field("strong_convexity", "STRONG_CONVEXITY", "μ, the smallest eigenvalue of H.", QP, "μ = λmin(H)", Plain, Real(self.strong_convexity)),
            field("condition_number", "CONDITION_NUMBER", "L/μ.", QP, "condition number L/μ", Plain, Real(self.condition_number)),
            field("step", "STEP", "The step α.", SOLVER, "step α", Step, Real(self.step)),
            field("momentum", "MOMENTUM", "The momentum β (0 for the projected gradient method).", SOLVER, "momentum β", Plain, Real(self.momentum)),
            field("contraction", "CONTRACTION", "The asymptotic contraction of the solver's error per iteration, constraints inactive.", SOLVER, "contraction per iteration", Convergence, Real(self.contraction)),
            field("iterations", "ITERATIONS", "Iterations per control step.", SOLVER, "iterations per control step", Plain, Count(self.iterations)),
            field("rate.factor", "RATE_FACTOR", "The a priori bound's factor per iteration ρ (see `RATE`).", BOUND, "factor per iteration", Plain, MaybeReal(self.rate.map(|r| r.factor))),
            field("tolerance", "TOLERANCE", "The relative suboptimality the bound is stated for: J(U_k) − J* ≤ TOLERANCE·(J(U_0) − J*).", BOUND, "tolerance on Δ_k/Δ_0", Tolerance, Real(self.tolerance)),
            field("iterations_bound", "ITERATIONS_BOUND", "The iterations the bound needs for TOLERANCE from any start in the box.", BOUND, "iterations the bound needs", Plain, MaybeCount(self.iterations_bound)),
            field("guaranteed_gap", "GUARANTEED_GAP", "What ITERATIONS guarantee: (J(U_m) − J*)/(J(U_0) − J*) is at most this.", BOUND, &format!("what {} iterations guarantee", self.iterations), Gap, MaybeReal(self.guaranteed_gap)),
            field("lqr.spectral_radius", "LQR_SPECTRAL_RADIUS", "ρ(F − G·K_LQR).", LQR, "ρ(F − G·K_LQR)", Stability, Real(self.lqr.spectral_radius)),
            field("lqr.lyapunov_min", "LQR_LYAPUNOV_MIN", "λmin of P solving (F − GK)ᵀP(F − GK) − P = −I.", LQR, "λmin(P), P from (F − GK)ᵀP(F − GK) − P = −I", Plain, Real(self.lqr.lyapunov_min)),
            field("lqr.lyapunov_max", "LQR_LYAPUNOV_MAX", "λmax of that P.", LQR, "λmax(P)", Plain, Real(self.lqr.lyapunov_max)),
            field("mpc.spectral_radius", "MPC_SPECTRAL_RADIUS", "ρ(F − G·K_MPC): the loop an exactly solved, unconstrained MPC closes.", LOOPS, "ρ(F − G·K_MPC), QP solved exactly", Stability, Real(self.mpc.spectral_radius)),
            field("mpc.solver_spectral_radius", "MPC_SOLVER_SPECTRAL_RADIUS", "ρ of the loop the fixed-iteration, warm-started solver closes, in (x, previous plan).", LOOPS, "ρ of the fixed-iteration warm-started solver", Stability, MaybeReal(self.mpc.solver_spectral_radius)),
            field("disturbance_time_constant", "DISTURBANCE_TIME_CONSTANT", "The disturbance estimate's time constant, s (with `[kalman] disturbance`).", OFFSET_FREE, "time constant, s", IfPresent, MaybeReal(self.disturbance_time_constant)),
            field("coordinate_range.sensitivity.total", "COORDINATE_SENSITIVITY", "g: the worst first-order ‖δu₀‖∞ per unit of u·X, X the absolute coordinates' magnitude, u the unit roundoff.", COORDINATES, "g = ‖δu₀‖∞ per rounding u·X of |x|", Plain, Real(range.sensitivity.total)),
            field("coordinate_range.command_accuracy", "COMMAND_ACCURACY", "The command accuracy the ranges are stated for: 1 % of the smallest input span.", COORDINATES, &format!("command accuracy ({percent} % of the smallest span)"), Plain, Real(range.command_accuracy)),
            field("coordinate_range.f32", "COORDINATE_RANGE_F32", "X_max in f32: absolute coordinates up to this magnitude keep u₀ within COMMAND_ACCURACY.", COORDINATES, &keeps("f32"), Range, Real(range.f32)),
            field("coordinate_range.f64", "COORDINATE_RANGE_F64", "X_max in f64.", COORDINATES, &keeps("f64"), Range, Real(range.f64)),
            field("macs_per_iteration", "MACS_PER_ITERATION", "Multiply-adds of one solver iteration.", RESOURCES, "multiply-adds per iteration", Plain, Count(r.macs_per_iteration)),
            field("macs_per_cycle", "MACS_PER_CYCLE", "Multiply-adds of one control cycle (filter, gradient map, every iteration).", RESOURCES, "multiply-adds per control cycle", Plain, Count(r.macs_per_cycle)),
            field("bytes_constants", "BYTES_CONSTANTS", "Bytes of coefficients inlined into the code.", RESOURCES, "bytes of constants", Plain, Count(r.bytes_constants)),
            field("bytes_state_mpc", "BYTES_STATE_MPC", "Bytes of `Mpc`.", RESOURCES, "bytes of state: Mpc", Plain, Count(r.bytes_state_mpc)),
            field("bytes_state_kalman", "BYTES_STATE_KALMAN", "Bytes of `Kalman`.", RESOURCES, "bytes of state: Kalman", Plain, Count(r.bytes_state_kalman)),
            field("bytes_state", "BYTES_STATE", "Bytes of `Controller`, all the state carried between cycles.", RESOURCES, "bytes of state: Controller", Plain, Count(r.bytes_state)),
            field("macs_filter", "MACS_FILTER", "Multiply-adds of the filter's update and predict, unrolled in the code.", RESOURCES, "multiply-adds of the filter", Plain, Count(r.macs_filter)),
            field("build_cost.lowering_bytes", "", "", BUILD, "lowering: matrices formed", Bytes, Real(b.lowering_bytes)),
            field("build_cost.lowering_macs", "", "", BUILD, "lowering: multiply-adds", Plain, Real(b.lowering_macs)),
            field("build_cost.emitted_numbers", "", "", BUILD, "emitted: numbers in tables", Plain, Count(b.emitted_numbers)),
            field("build_cost.emitted_unrolled", "", "", BUILD, "emitted: unrolled multiply-adds", Plain, Count(b.emitted_unrolled)),
            field("build_cost.source_bytes", "", "", BUILD, "emitted: source", Bytes, Real(b.source_bytes)),
            field("build_cost.rustc_seconds", "", "", BUILD, "rustc on the module: time", Seconds, Real(b.rustc_seconds)),
            field("build_cost.rustc_bytes", "", "", BUILD, "rustc on the module: memory", Bytes, Real(b.rustc_bytes)),
        ];
        let Some(e) = &self.sampled else {
            return fields;
        };
        // The first-order method's step, contraction and a priori bound do not exist here.
        const FIRST_ORDER: &[&str] = &[
            "step",
            "momentum",
            "contraction",
            "rate.factor",
            "tolerance",
            "iterations_bound",
            "guaranteed_gap",
            "mpc.solver_spectral_radius",
        ];
        if !e.method.box_only() {
            fields.retain(|f| !FIRST_ORDER.contains(&f.json));
        }
        let at = fields
            .iter()
            .position(|f| f.section == LQR)
            .unwrap_or(fields.len());
        let how = if e.auto {
            format!(
                "iterations: worst observed + {} (margin)",
                e.iterations - e.cold_worst.max(e.warm_worst)
            )
        } else {
            "iterations: as written".to_string()
        };
        let evidence = [
            field("accuracy", "ACCURACY", "`[mpc] accuracy`: |U − U*|∞ ≤ ACCURACY·(u_max − u_min), hard-row violation ≤ ACCURACY·max(1, |bound|).", SAMPLED, "accuracy asked (of the input span)", Plain, Real(self.accuracy)),
            field("sampled.cold_cases", "SAMPLED_COLD_CASES", "Cold cases sampled (corners and draws) that have a solution.", SAMPLED, "cold cases with a solution", Plain, Count(e.cold_cases)),
            field("sampled.corners", "SAMPLED_CORNERS", "Corners of the state region among them.", SAMPLED, "of which corners of the region", Plain, Count(e.corners)),
            field("sampled.infeasible_cases", "SAMPLED_INFEASIBLE_CASES", "Draws whose hard rows admit no plan (certified by either exact solver), left out: the fallback covers them.", SAMPLED, "draws without a solution (hard rows)", Plain, Count(e.infeasible_cases)),
            field("sampled.unresolved_cases", "SAMPLED_UNRESOLVED_CASES", "Cases (cold draws, or warm steps, each ending its sequence) that neither exact solver resolved, left out.", SAMPLED, "cases neither exact solver resolved", Plain, Count(e.unresolved_cases)),
            field("sampled.warm_steps", "SAMPLED_WARM_STEPS", "Warm-started closed-loop steps sampled.", SAMPLED, &format!("warm closed-loop steps ({} sequences)", e.sequences), Plain, Count(e.warm_steps)),
            field("sampled.cold_median", "SAMPLED_COLD_MEDIAN", "Iterations a cold case needed to reach ACCURACY: median.", SAMPLED, "iterations needed cold: median", Plain, Count(e.cold_median)),
            field("sampled.cold_worst", "SAMPLED_COLD_WORST", "Iterations a cold case needed: worst.", SAMPLED, "iterations needed cold: worst", Plain, Count(e.cold_worst)),
            field("sampled.warm_median", "SAMPLED_WARM_MEDIAN", "Iterations a warm step needed: median.", SAMPLED, "iterations needed warm: median", Plain, Count(e.warm_median)),
            field("sampled.warm_worst", "SAMPLED_WARM_WORST", "Iterations a warm step needed: worst.", SAMPLED, "iterations needed warm: worst", Plain, Count(e.warm_worst)),
            field("sampled.iterations", "", "", SAMPLED, &how, Plain, Count(e.iterations)),
            field("sampled.worst_error", "SAMPLED_WORST_ERROR", "The worst |U − U*|∞ / span over the sample at ITERATIONS.", SAMPLED, "worst |U − U*|∞ / span at the count", Plain, Real(e.worst_error)),
            field("sampled.worst_violation", "SAMPLED_WORST_VIOLATION", "The worst hard-row violation (relative) over the sample at ITERATIONS.", SAMPLED, "worst hard-row violation at the count", Plain, Real(e.worst_violation)),
            field("sampled.limits.primal", "SAMPLED_PRIMAL_LIMIT", "Final relative primal residual above which the solve falls back.", SAMPLED, "fallback above relative primal residual", Plain, Real(e.limits.primal)),
            field("sampled.limits.dual", "SAMPLED_DUAL_LIMIT", "Final relative dual residual above which the solve falls back.", SAMPLED, "fallback above relative dual residual", Plain, Real(e.limits.dual)),
            field("sampled.limits.gap", "SAMPLED_GAP_LIMIT", "Final duality gap, relative to max(1, |J|), above which the solve falls back.", SAMPLED, "fallback above relative duality gap", Plain, Real(e.limits.gap)),
        ];
        fields.splice(at..at, evidence);
        if e.method == mpc_spec::Method::ActiveSet {
            let at = fields
                .iter()
                .position(|f| f.section == LQR)
                .unwrap_or(fields.len());
            let x = self.exact.as_ref();
            let count = |v: Option<usize>| MaybeCount(v);
            let done = x.filter(|x| x.complete);
            let exact = [
                field("exact.cold_worst", "EXACT_COLD_WORST", "Changes of the working set a cold solve makes at most over `[mpc.region]`, for a constant reference window: exact (absent when the partition did not complete).", EXACT, "iterations cold: exact worst", IfPresent, count(done.map(|x| x.cold_worst))),
                field("exact.cold_work", "EXACT_COLD_WORK", "Work a cold solve spends at most over `[mpc.region]`, for a constant reference window: the heaviest execution path of the partition, each region's path run by the kernel at its centre (tenths of a multiply-add of the factor's loops; absent when the partition did not complete).", EXACT, "work of a cold solve: exact worst path (tenths of a multiply-add)", IfPresent, count(done.and_then(|x| x.cold_work))),
                field("exact.regions", "EXACT_REGIONS", "Regions of the parameter box, each with one sequence of working sets (those done, when the partition did not complete).", EXACT, "regions of the partition", IfPresent, count(x.map(|x| x.regions))),
                field("exact.infeasible_regions", "EXACT_INFEASIBLE_REGIONS", "Regions where the hard rows admit no plan.", EXACT, "of which infeasible", IfPresent, count(x.map(|x| x.infeasible_regions))),
                field("exact.cycling_regions", "EXACT_CYCLING_REGIONS", "Regions where the exact iteration repeats a working set (a degenerate tie), outside the exact count: there the kernel's tolerances break the tie, or its guard ends the solve (Cycling) and the controller falls back.", EXACT, "of which cycling (outside the count)", IfPresent, count(x.map(|x| x.cycling_regions))),
                field("exact.cycling_radius", "", "", EXACT, "their largest radius (normalised parameters)", IfPresent, MaybeReal(x.filter(|x| x.cycling_regions > 0).map(|x| x.cycling_radius))),
                field("exact.parameters", "EXACT_PARAMETERS", "The dimension of the parameter: x0, the constant reference, u₋₁ where kept, d.", EXACT, "parameter dimension (all blocks)", IfPresent, count(x.map(|x| x.parameters))),
                field("exact.lps", "", "", EXACT, "feasibility LPs solved", IfPresent, count(x.map(|x| x.lps))),
                field("exact.seconds", "", "", EXACT, "time the partition took", Seconds, MaybeReal(x.map(|x| x.seconds))),
                field("cold_iterations", "COLD_ITERATIONS", "A cold solve's cap: the exact count, or ITERATIONS if larger (the sampled count where the certificate is not exact).", EXACT, "cap of a cold solve (first, or after a warm one)", IfPresent, count(self.cold_iterations)),
                field("warm_work", "WARM_WORK", "A warm solve's budget of work: the most a warm-started step of the sample spent plus its margin. Work is the kernel's multiply-adds and scanned rows weighed by their cost on the boards, in tenths of a multiply-add of the factor's loops.", EXACT, "budget of work of a warm solve (tenths of a multiply-add)", IfPresent, count(self.work_budgets.map(|w| w.0))),
                field("cold_work", "COLD_WORK", "A cold solve's budget of work: the most a cold case of the sample spent, or where the exact count completed the larger of that and EXACT_COLD_WORK, plus its margin (WARM_WORK with `restart = \"continue\"`).", EXACT, "budget of work of a cold solve (tenths of a multiply-add)", IfPresent, count(self.work_budgets.and_then(|w| w.1))),
                field("cold_solve_macs", "", "", EXACT, "multiply-adds priced for a cold solve (of the factor's loops)", IfPresent, count(self.cold_solve_macs)),
                field("warm_iterations", "WARM_ITERATIONS", "A warm solve's cap: the most a warm-started step of the sample needed plus its margin, at most ITERATIONS; a step makes at most WARM_ITERATIONS + COLD_ITERATIONS changes, which the cost model prices (with `restart = \"continue\"` every solve has COLD_ITERATIONS and WARM_WORK, and a step holds one).", EXACT, "cap of a warm solve (then a cold restart; restart = \"cold\")", IfPresent, count(self.cold_iterations.map(|_| e.warm_cap()))),
            ];
            fields.splice(at..at, exact);
        }
        // A method without run-time residual limits (the dual active-set method: a solve ends at the
        // optimum or is not used) has none to report.
        if e.method == mpc_spec::Method::ActiveSet {
            fields.retain(|f| !f.json.starts_with("sampled.limits"));
        }
        if let (Some(rho), Some(form)) = (e.rho, e.admm_form) {
            let label = format!("ADMM's ρ (tuned on the sample), {} form", form.name());
            let at = fields
                .iter()
                .position(|f| f.json == "sampled.limits.primal")
                .unwrap_or(fields.len());
            fields.insert(at, field("sampled.rho", "SAMPLED_RHO", "ADMM's penalty ρ, tuned on the sample (each row's penalty is ρ times the row's curvature).", SAMPLED, &label, Plain, Real(rho)));
        }
        fields
    }
}

/// The rules that need the certificate: an unstable closed loop is an error unless the spec sets
/// `accept_unstable`; fixed iterations below what the spec's `tolerance` needs ([`DEFAULT_TOLERANCE`] when
/// it has none) are a warning, or an error with `strict`, and iterations whose bound cannot decrease at all
/// are an error; a `tolerance` below the arithmetic's resolution is a warning. Returns the warnings.
pub fn review(spec: &Spec, c: &Certificate) -> Result<Diagnostics, Diagnostics> {
    let (mut errors, mut warnings) = (Diagnostics::default(), Diagnostics::default());
    // Matrices accepted as symmetric up to rounding (mpc_spec::SYMMETRY_TOLERANCE) are used as (A + Aᵀ)/2.
    let mut written = vec![("mpc.q", &spec.mpc.q), ("mpc.r", &spec.mpc.r)];
    if spec.spans.get("mpc.qf").is_some() {
        written.push(("mpc.qf", &spec.mpc.qf));
    }
    if let Some(r_du) = &spec.mpc.r_du {
        written.push(("mpc.r_du", r_du));
    }
    if let Some(kalman) = &spec.kalman {
        if let mpc_spec::KalmanNoise::Covariances { q, r } = &kalman.noise {
            written.extend([("kalman.q", q), ("kalman.r", r)]);
        }
        written.push(("kalman.p0", &kalman.p0));
    }
    for (key, m) in written {
        let asymmetry = m.asymmetry();
        if asymmetry > 1e-12 {
            warnings.push(
                Diagnostic::new(
                    format!("`{key}` is not exactly symmetric: a_ij and a_ji differ by up to {asymmetry:.3e} of √(|a_ii·a_jj|); the compiler uses (A + Aᵀ)/2"),
                    spec.spans.get(key),
                )
                .label("symmetrized"),
            );
        }
    }
    // `accuracy` is a promise only where a sample measured it: a first-order method without
    // `[mpc.region]` counts its iterations from `tolerance`'s a priori bound.
    if c.sampled.is_none() && spec.spans.get("mpc.accuracy").is_some() {
        warnings.push(
            Diagnostic::new(
                format!("`accuracy` is not certified without `[mpc.region]`: `method = \"{}\"` counts its iterations from `tolerance`'s a priori bound", spec.mpc.method.name()),
                spec.spans.get("mpc.accuracy"),
            )
            .label("not checked")
            .note("hint: add `[mpc.region]` with the states and references the controller meets, and the compiler measures the iterations that reach `accuracy` there"),
        );
    }
    // One finding per cause: the solver's loop is only reported when the exactly solved MPC is stable.
    let unstable = |rho: f64| rho.is_nan() || rho >= 1.0;
    let mut loops = vec![(
        "the LQR loop of the stage weights, ρ(F − G·K_LQR),",
        c.lqr.spectral_radius,
    )];
    if unstable(c.mpc.spectral_radius) {
        loops.push((
            "the unconstrained MPC loop, ρ(F − G·K_MPC),",
            c.mpc.spectral_radius,
        ));
    } else if let Some(rho) = c.mpc.solver_spectral_radius {
        loops.push(("the loop of the fixed-iteration, warm-started solver", rho));
    }
    if !spec.mpc.accept_unstable {
        for (what, rho) in loops {
            if unstable(rho) {
                errors.push(
                    Diagnostic::new(
                        format!("the closed loop is not stable: {what} has spectral radius {rho:.6}"),
                        spec.spans.get("mpc"),
                    )
                    .label("controller defined here")
                    .note("hint: raise the weights, the horizon or the iterations, or set `accept_unstable = true` in `[mpc]` to build it anyway"),
                );
            }
        }
    }
    // A tolerance the arithmetic cannot resolve: each iteration evaluates the gradient H·U + f in the
    // emitted scalar with a relative error of about its ε, which moves the iteration's fixed point by up to
    // κ(H)·ε relative to U* (a linear system's perturbation bound), so below ε·κ(H) the iterates stop
    // improving in the arithmetic whatever the a priori bound promises. ε·κ is the order of that floor,
    // not a tight bound; a tolerance under it is met on paper only.
    if let Some(tol) = spec.mpc.tolerance {
        let scalar = Numeric(spec.codegen.scalar);
        let floor = scalar.epsilon() * c.condition_number;
        if tol < floor {
            warnings.push(
                Diagnostic::new(
                    format!(
                        "`mpc.tolerance` = {tol:e} is below what the arithmetic can resolve: the solver runs in {}, whose ε = {:.3e} times the condition number κ(H) = {:.4} is {floor:.3e}",
                        scalar.name(),
                        scalar.epsilon(),
                        c.condition_number
                    ),
                    spec.spans.get("mpc.tolerance"),
                )
                .label(format!("below ε·κ(H) = {floor:.3e}"))
                .note(format!("hint: write a tolerance of at least {floor:.1e}; the {} iterations it asks for only repeat rounding", c.iterations)),
            );
        }
    }
    if let (Iterations::Fixed(m), Some(rate)) = (spec.mpc.iterations, c.rate) {
        let iterations = || spec.spans.get("mpc.iterations");
        if rate.factor >= 1.0 {
            // 1 − αμ (or 1 − √(αμ)) rounds to 1: the bound is constant·1^m whatever the count, so no number of
            // iterations guarantees any decrease of the gap. With `step = "auto"` (αμ = 1/κ) check_hessian
            // refuses this first; it is a written step's doing.
            errors.push(
                Diagnostic::new(
                    format!("the a priori bound guarantees no improvement at all: its factor per iteration rounds to 1 with the step α = {:e} and μ = λmin(H) = {:.4e}", c.step, c.strong_convexity),
                    spec.spans.get("mpc.step").or_else(iterations),
                )
                .label(format!("no count of iterations, {m} or more, reduces the bound"))
                .note(format!("hint: write `step = \"auto\"` for 1/L = {:e}", 1.0 / c.lipschitz)),
            );
        } else if let Some(needed) = c.iterations_bound.filter(|needed| m < *needed) {
            // `tolerance` is the spec's, or DEFAULT_TOLERANCE when it has none: a count that misses the
            // default is as much a finding as one that misses a written tolerance.
            let tol = c.tolerance;
            let gap = c.guaranteed_gap.unwrap_or(1.0);
            let (what, hint) = match spec.mpc.tolerance {
                Some(_) => (
                    format!("`tolerance = {tol:e}`"),
                    "hint: write `iterations = \"auto\"`, raise the count, or loosen `tolerance`"
                        .to_string(),
                ),
                None => (
                    format!("the default tolerance {tol:e} (no `tolerance` is written)"),
                    if gap < 1.0 {
                        format!("hint: write `iterations = \"auto\"` with a `tolerance`, raise the count to {needed}, or write the tolerance these iterations do meet, `tolerance = {}`", met_tolerance(gap))
                    } else {
                        format!("hint: write `iterations = \"auto\"` with a `tolerance`, or raise the count to {needed}: `iterations = {m}` guarantee nothing")
                    },
                ),
            };
            // A bound of 1 or more on the relative cost (as printed) guarantees nothing: an error on the
            // key that makes it so, `iterations` where a count within the limit meets the tolerance, else
            // the input weight whose condition number no count overcomes. A sampled count (a region)
            // stands on its evidence, and the bound stays a warning there.
            let vacuous = format!("{gap:.3e}").parse::<f64>().unwrap_or(gap) >= 1.0;
            if vacuous && c.sampled.is_none() && needed > mpc_spec::MAX_ITERATIONS {
                // κ(H) is the state weight's size against the input weight's: the one further from 1
                // (in decades) is named, `q` for a huge state weight, `r` for a tiny input weight.
                let decades = |m: &mpc_spec::Matrix, pick: fn(f64, f64) -> f64, start: f64| {
                    let d = (0..m.rows.min(m.cols))
                        .map(|i| m.get(i, i).abs())
                        .fold(start, pick);
                    if d > 0.0 && d.is_finite() {
                        d.log10().abs()
                    } else {
                        0.0
                    }
                };
                let weight = if decades(&spec.mpc.q, f64::max, 0.0)
                    > decades(&spec.mpc.r, f64::min, f64::INFINITY)
                {
                    "q"
                } else {
                    "r"
                };
                let key = format!("mpc.{weight}");
                errors.push(
                    Diagnostic::new(
                        format!("the a priori bound guarantees nothing: (J(U_{m}) − J*)/(J(U_0) − J*) ≤ {gap:.3e}, and {what} would need {needed} iterations, above the limit of {}", mpc_spec::MAX_ITERATIONS),
                        spec.spans.get(&key).or_else(iterations),
                    )
                    .label(format!("the condition number κ(H) = {:.3e} comes from this weight's size against the other's", c.condition_number))
                    .note(format!("hint: bring `{weight}` closer to the other weight (raise `r` or `r_du`, or lower `q`), or shorten the horizon, so that κ(H) falls; or give the controller a `[mpc.region]` to certify it by sampling")),
                );
                return Err(errors.sorted());
            }
            let d = Diagnostic::new(
                format!("`iterations = {m}` is below the {needed} that guarantee {what}: the bound only guarantees (J(U_{m}) − J*)/(J(U_0) − J*) ≤ {gap:.3e}"),
                iterations(),
            )
            .label(format!("the a priori bound needs {needed}"))
            .note(if vacuous && c.sampled.is_none() {
                format!("hint: a bound of 1 guarantees nothing: raise the count to {needed}, or write `iterations = \"auto\"` with a `tolerance`")
            } else {
                hint
            });
            if spec.mpc.strict || (vacuous && c.sampled.is_none()) {
                errors.push(d);
            } else {
                warnings.push(d);
            }
        }
    }
    // A written count below what the sample needed: evidence it misses `accuracy` there (for the
    // interior-point method the run-time residual limits then make those solves fall back).
    if let Some(e) = c
        .sampled
        .as_ref()
        .filter(|e| !e.auto && e.iterations < e.worst_needed)
    {
        let d = Diagnostic::new(
            format!(
                "`iterations = {}` is below the {} the sampled cases of `[mpc.region]` needed to reach `accuracy = {:e}`",
                e.iterations, e.worst_needed, c.accuracy
            ),
            spec.spans.get("mpc.iterations"),
        )
        .label(format!("the sample needed {}", e.worst_needed))
        .note(if !e.method.box_only() {
            "hint: write `iterations = \"auto\"`, or raise the count; a truncated interior-point solve is not graceful, and where its residuals exceed the certified limits the controller falls back to the shifted previous plan"
        } else {
            "hint: write `iterations = \"auto\"`, or raise the count; a truncated first-order solve is feasible for the box but farther from the optimum than `accuracy`"
        });
        if spec.mpc.strict {
            errors.push(d);
        } else {
            warnings.push(d);
        }
    }
    // Draws that neither exact solver resolved are left out of the evidence: more than a few, and the
    // counts miss a part of the region without saying so.
    if let Some(e) = c
        .sampled
        .as_ref()
        .filter(|e| e.unresolved_cases > crate::certify::sampling::UNRESOLVED_WARNING)
    {
        warnings.push(
            Diagnostic::new(
                format!(
                    "{} cases of `[mpc.region]` were solved by neither the interior-point method nor Clarabel and are left out of the certificate ({} cold cases and {} warm steps count)",
                    e.unresolved_cases, e.cold_cases, e.warm_steps
                ),
                spec.spans.get("mpc.region").or(spec.spans.get("mpc")),
            )
            .label("evidence thinner than the sample")
            .note("hint: scale the model's units so the QP is better conditioned, or narrow `[mpc.region]`"),
        );
    }
    if errors.is_empty() {
        Ok(warnings)
    } else {
        Err(errors.sorted())
    }
}

/// The guaranteed gap ratio rounded up to two significant digits: a `tolerance` the iterations meet.
fn met_tolerance(gap: f64) -> String {
    let exponent = gap.log10().floor() - 1.0;
    let scale = 10f64.powf(exponent);
    let mut up = (gap / scale).ceil() * scale;
    let show = |v: f64| {
        if exponent >= -5.0 {
            format!("{v:.*}", (-exponent) as usize)
        } else {
            format!("{v:.1e}")
        }
    };
    // The printed value is what the spec will hold: step up once more if it rounded below `gap`.
    if show(up).parse::<f64>().map_or(true, |v| v < gap) {
        up += scale;
    }
    let shown = show(up);
    if shown.contains('e') {
        shown
    } else {
        shown
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_string()
    }
}

/// What the module of a lowered and planned problem costs, to run and to build: cheap counts, computed
/// before the certificate's analyses so that a module past the budgets is refused without them.
pub fn predicted(p: &Problem, plan: &Plan) -> (Resources, BuildCost) {
    let resources = resources(p, plan);
    let (tables, unrolled) = emitted_terms(p, plan, &resources);
    let build_cost = budget::predict(
        budget::Dims {
            nx: p.nx as f64,
            nu: p.nu as f64,
            N: p.qp.N as f64,
            na: (p.nx + p.nd()) as f64,
        },
        tables,
        unrolled,
    );
    (resources, build_cost)
}

/// Computes the certificate of a lowered and planned problem.
pub fn certify(p: &Problem, plan: &Plan) -> Certificate {
    let qp = &p.qp;
    let rate = plan.algorithm().and_then(|a| a.rate(&qp.parameters()));
    let tolerance = qp.tolerance.unwrap_or(DEFAULT_TOLERANCE);
    let (resources, build_cost) = predicted(p, plan);
    Certificate {
        lipschitz: qp.L,
        strong_convexity: qp.mu,
        condition_number: qp.L / qp.mu,
        step: qp.step,
        momentum: qp.momentum,
        contraction: contraction(p, plan),
        iterations: qp.iterations,
        tolerance,
        rate,
        iterations_bound: rate.map(|r| r.iterations_for(tolerance)),
        guaranteed_gap: rate.map(|r| r.guaranteed(qp.iterations)),
        lqr: lqr(p),
        mpc: mpc_loop(p, plan),
        resources,
        build_cost,
        emission: plan.emission(),
        estimates: plan.estimates.clone(),
        coordinate_range: crate::certify::coordinates::coordinate_range(
            p,
            plan.emission(),
            crate::certify::coordinates::DEFAULT_ACCURACY,
        ),
        sampled: qp.evidence.clone(),
        exact: qp.evidence.as_ref().and_then(|e| e.exact.clone()),
        cold_iterations: (qp.method == mpc_spec::Method::ActiveSet).then(|| {
            // `Caps::of(qp).cold` of the active set's module, formed here from the evidence alone.
            qp.iterations
                .max(qp.evidence.as_ref().map_or(0, |e| e.exact_cold()))
        }),
        work_budgets: qp
            .evidence
            .as_ref()
            .filter(|_| qp.method == mpc_spec::Method::ActiveSet)
            // `Caps::of(qp)`'s budgets, formed here from the evidence alone: with `restart = "continue"`
            // a cold solve has the warm budget.
            .map(|e| {
                let cold = match qp.restart {
                    mpc_spec::Restart::Cold => e.cold_work_cap(),
                    mpc_spec::Restart::Continue => Some(e.warm_work_cap()),
                };
                (e.warm_work_cap(), cold)
            }),
        restart: (qp.method == mpc_spec::Method::ActiveSet).then_some(qp.restart),
        cold_solve_macs: plan.solver.macs_per_cold_solve(p, plan),
        accuracy: qp.accuracy,
        normal_form: plan.solver.normal_form(qp),
        admm_structure: plan.solver.admm_structure(qp),
        method_requested: p.requested,
        candidates: p.candidates.clone(),
        disturbance_time_constant: p.filter.as_ref().filter(|f| f.nd > 0).map(|f| {
            let na = p.nx + f.nd;
            let error = &f.Fa * (DMatrix::identity(na, na) - &f.K_inf * &f.Ca);
            -p.dt / spectral_radius(&error).ln()
        }),
    }
}

fn contraction(p: &Problem, plan: &Plan) -> f64 {
    let qp = &p.qp;
    // An interior-point method has no contraction per iteration.
    let Some(algorithm) = plan.algorithm() else {
        return f64::NAN;
    };
    let eig = nalgebra::SymmetricEigen::new(qp.H.clone()).eigenvalues;
    eig.iter()
        .map(|lambda| algorithm.contraction_at(&qp.parameters(), *lambda))
        .fold(0.0, f64::max)
}

/// The LQR of the stage weights. With weighted moves the loop is on ξ = (x, u₋₁) with the move Δu as its
/// input (ξ⁺ = [F G; 0 I]ξ + [G; I]Δu), stage cost xᵀQx + uᵀRu + ΔuᵀR_duΔu with u = u₋₁ + Δu, so R may be
/// zero: the cross term ξᵀ[0; R]Δu is removed by the usual change of input before the Riccati recursion.
fn lqr(p: &Problem) -> Lqr {
    let LqrSystem { F, G, Q, N, R } = lqr_system(p);
    let nan = || Lqr {
        gain: DMatrix::from_element(p.nu, F.ncols(), f64::NAN),
        spectral_radius: f64::NAN,
        lyapunov_min: f64::NAN,
        lyapunov_max: f64::NAN,
    };
    // u = v − R⁻¹Nᵀξ removes the cross term: F̄ = F − G R⁻¹Nᵀ, Q̄ = Q − N R⁻¹ Nᵀ, K = K̄ + R⁻¹Nᵀ.
    let Some(R_chol) = R.clone().cholesky() else {
        return nan();
    };
    let cross = R_chol.solve(&N.transpose());
    let F_bar = &F - &G * &cross;
    let Q_bar = crate::linalg::symmetrize(&(&Q - &N * &cross));
    let Some(K_bar) = lqr_gain(&F_bar, &G, &Q_bar, &R) else {
        return nan();
    };
    let K = K_bar + cross;
    let Fcl = &F - &G * &K;
    let rho = spectral_radius(&Fcl);
    let (lmin, lmax) =
        lyapunov_identity(&Fcl).map_or((f64::NAN, f64::NAN), |P| extreme_eigenvalues(&P));
    Lqr {
        gain: K,
        spectral_radius: rho,
        lyapunov_min: lmin,
        lyapunov_max: lmax,
    }
}

/// An LQR problem with stage cost ξᵀQξ + 2ξᵀNv + vᵀRv on ξ⁺ = Fξ + Gv.
struct LqrSystem {
    F: DMatrix<f64>,
    G: DMatrix<f64>,
    Q: DMatrix<f64>,
    N: DMatrix<f64>,
    R: DMatrix<f64>,
}

/// The plant's own LQR problem (N = 0) without weighted moves; with them, the state (x, u₋₁) and the move
/// as input.
fn lqr_system(p: &Problem) -> LqrSystem {
    let qp = &p.qp;
    let (nx, nu) = (p.nx, p.nu);
    if !p.has_moves() {
        return LqrSystem {
            F: p.F.clone(),
            G: p.G.clone(),
            Q: qp.Q.clone(),
            N: DMatrix::zeros(nx, nu),
            R: qp.R.clone(),
        };
    }
    let n = nx + nu;
    let mut F = DMatrix::identity(n, n);
    F.view_mut((0, 0), (nx, nx)).copy_from(&p.F);
    F.view_mut((0, nx), (nx, nu)).copy_from(&p.G);
    let mut G = DMatrix::zeros(n, nu);
    G.view_mut((0, 0), (nx, nu)).copy_from(&p.G);
    G.view_mut((nx, 0), (nu, nu)).fill_with_identity();
    let mut Q = DMatrix::zeros(n, n);
    Q.view_mut((0, 0), (nx, nx)).copy_from(&qp.Q);
    Q.view_mut((nx, nx), (nu, nu)).copy_from(&qp.R);
    let mut N = DMatrix::zeros(n, nu);
    N.view_mut((nx, 0), (nu, nu)).copy_from(&qp.R);
    LqrSystem {
        F,
        G,
        Q,
        N,
        R: &qp.R + &qp.R_du,
    }
}

/// The MPC's loops. With weighted moves the plan depends on (x, u₋₁), u₋₁ the previous command: the
/// exact loop is on that pair, and the solver's loop already carries u₋₁ as the first block of the
/// previous plan.
fn mpc_loop(p: &Problem, plan: &Plan) -> MpcLoop {
    let qp = &p.qp;
    let (nx, nu) = (p.nx, p.nu);
    let nz = qp.Nc * nu;
    let moves = if p.has_moves() { nu } else { 0 };
    // f = Fx·x + Fu·u₋₁ at zero reference: the gain on (x, u₋₁).
    let mut Fxu = DMatrix::zeros(nz, nx + moves);
    Fxu.view_mut((0, 0), (nz, nx)).copy_from(&qp.Fx);
    Fxu.view_mut((0, nx), (nz, moves))
        .copy_from(&qp.Fu.columns(0, moves));
    // `lower` refuses an H that does not factorize (check_hessian); NaN if it ever did.
    let K = match qp.H.clone().cholesky() {
        Some(H) => (H.inverse() * &Fxu).rows(0, nu).into_owned(),
        None => DMatrix::from_element(nu, nx + moves, f64::NAN),
    };
    // The MPC gives the input u = −K·ξ itself, not a move: on ξ = (x, u₋₁) the loop is [F G; 0 I]ξ +
    // [G; I](u − u₋₁), so the move form's input matrix also takes u₋₁ off (columns nx.. of ξ).
    let LqrSystem { F, G, .. } = lqr_system(p);
    let mut closed = &F - &G * &K;
    if moves > 0 {
        let taken_off = closed.columns(nx, nu) - &G;
        closed.columns_mut(nx, nu).copy_from(&taken_off);
    }
    let spectral = spectral_radius(&closed);
    let affordable = nz <= MAX_SOLVER_ANALYSIS_SIZE
        && budget::solver_analysis_macs(nx, nz, qp.iterations) <= budget::SOLVER_ANALYSIS_MACS;
    let solver = affordable.then_some(()).and_then(|()| {
        // The plan after m iterations is linear in z = [x; U_prev]: U_m = M·z. Build M by running the
        // solver on matrices (columns = unit directions of z), references zero and bounds inactive.
        // u₋₁ is U_prev's first block, the command applied last.
        let dim = nx + nz;
        let mut shift = DMatrix::zeros(nz, dim);
        for i in 0..nz - nu {
            shift[(i, nx + nu + i)] = 1.0;
        }
        let mut f = DMatrix::zeros(nz, dim);
        f.view_mut((0, 0), (nz, nx)).copy_from(&qp.Fx);
        f.view_mut((0, nx), (nz, moves))
            .copy_from(&qp.Fu.columns(0, moves));
        let step = |Y: &DMatrix<f64>| Y - (&qp.H * Y + &f) * qp.step;
        let U =
            plan.algorithm()?
                .reference_linear(&qp.parameters(), shift, qp.iterations, &step)?;
        let mut A = DMatrix::zeros(dim, dim);
        let x_next = &p.G * U.rows(0, nu);
        A.view_mut((0, 0), (nx, dim)).copy_from(&x_next);
        let F_block = A.view((0, 0), (nx, nx)) + &p.F;
        A.view_mut((0, 0), (nx, nx)).copy_from(&F_block);
        A.view_mut((nx, 0), (nz, dim)).copy_from(&U);
        Some(spectral_radius(&A))
    });
    MpcLoop {
        gain: K,
        moves: moves > 0,
        spectral_radius: spectral,
        solver_spectral_radius: solver,
    }
}

/// The numbers the module writes in tables and the multiply-adds it unrolls: the public matrices, the
/// form's tables, the filter, and an unrolled gradient or the body of the sweeps.
fn emitted_terms(p: &Problem, plan: &Plan, r: &Resources) -> (usize, usize) {
    let qp = &p.qp;
    let (nx, nu, ny, na) = (p.nx, p.nu, p.ny, p.nx + p.nd());
    let nz = qp.Nc * nu;
    let form_tables = plan.estimate().table_bytes / Numeric(p.scalar).bytes();
    let tables = nz * (nz + nx + qp.N * nx + p.nd())
        + nx * (nx + nu)
        + ny * nx
        + na * (3 * na + ny)
        + ny * ny
        + form_tables;
    let estimate = |form: Emission| {
        plan.estimates
            .iter()
            .find(|e| e.emission == form)
            .map_or(0, |e| e.macs)
    };
    let form = match plan.emission() {
        Emission::Unrolled => {
            estimate(Emission::Unrolled) + qp.Fx.len() + qp.Fr.len() + qp.Fd.len()
        }
        _ => estimate(Emission::MatrixFree) / qp.N.max(1),
    };
    (tables, r.macs_filter + form)
}

fn resources(p: &Problem, plan: &Plan) -> Resources {
    let num = Numeric(p.scalar);
    // ADMM's final residuals and infeasibility test; the interior-point method's cold start, which the
    // emitted method computes on every solve (its control flow does not depend on the data).
    let (per_iteration, once_per_solve) = plan.solver.macs(p, plan);
    // f: unrolled over Fx, Fr and Fd, or one pass of the matrix-free sweeps (f = ∇J(0)).
    let (gradient_map, gradient_map_constants) =
        plan.form.gradient().gradient_map(p, &plan.estimates);
    let size = num.bytes();
    let real = (size, size);
    let array = |n: usize, (s, a): (usize, usize)| (n * s, a);
    let flag = (1, 1);
    // The method's fields: the plan, its warm start, the last input, its status.
    let fields = plan.solver.state_fields(p, plan);
    let mpc = layout(&fields.mpc);
    let filter = p.filter.as_ref().map(|f| filter_resources(p, f, num));
    let (macs_filter, filter_constants, kalman) = filter.map_or((0, 0, (0, 1)), |f| f);
    // `Status`: the filter's (inside the `Kalman`, copied), the command's verdict, a flag per input; the
    // controller keeps the estimate the command was computed from.
    let controller = match &p.filter {
        Some(f) => {
            let filter_status = filter_status_layout(f, size);
            let status = layout(
                &[
                    &[filter_status, flag, array(p.nu, flag)],
                    &fields.status[..],
                ]
                .concat(),
            );
            layout(&[kalman, mpc, array(p.nx, real), status])
        }
        None => layout(&[
            mpc,
            layout(&[&[flag, array(p.nu, flag)], &fields.status[..]].concat()),
        ]),
    };
    let macs_per_solve = plan.solver.macs_per_step(p, plan);
    Resources {
        macs_per_iteration: per_iteration,
        macs_per_cycle: macs_per_solve + gradient_map + macs_filter,
        macs_per_solve,
        macs_once_per_solve: once_per_solve,
        macs_filter,
        bytes_constants: (gradient_map_constants + filter_constants) * size,
        bytes_state_mpc: mpc.0,
        bytes_state_kalman: kalman.0,
        bytes_state: controller.0,
    }
}

/// `FilterStatus`: the verdict (a one-byte enum), the statistic, three counts and the flags.
fn filter_status_layout(f: &Filter, size: usize) -> (usize, usize) {
    let (real, flag) = ((size, size), (1, 1));
    let counts = (3 * 4, 4);
    layout(&[
        flag,
        real,
        counts,
        flag,
        if f.nd > 0 { flag } else { (0, 1) },
    ])
}

/// The filter's multiply-adds per cycle, the coefficients it holds, and the `Kalman`'s layout.
fn filter_resources(p: &Problem, f: &Filter, num: Numeric) -> (usize, usize, (usize, usize)) {
    let nnz = |M: &DMatrix<f64>| num.nonzeros(M);
    let coefficients = |M: &DMatrix<f64>| num.coefficients(M);
    // The filter works on (x, d): na = nx + nd states.
    let (na, ny) = (p.nx + f.nd, p.ny);
    let (F, G, C) = (&f.Fa, &f.Ga, &f.Ca);
    let predict_state = nnz(&F.rows(0, p.nx).into_owned()) + nnz(G);
    let mut filter_constants = coefficients(F) + coefficients(G) + coefficients(C);
    let filter = match f.kind {
        FilterKind::SteadyState => {
            filter_constants += coefficients(&f.K_inf);
            predict_state + nnz(C) + nnz(&f.K_inf)
        }
        FilterKind::TimeVarying => {
            filter_constants += coefficients(&f.Qn) + coefficients(&f.Rn);
            // Every product over the entries that can be nonzero (the covariance's structural pattern),
            // as the emitter unrolls them: F·P·Fᵀ; P·Cᵀ, C·P·Cᵀ, the ny × ny inverse, K, the
            // correction, I − K·C, (I − KC)·P·(I − KC)ᵀ and K·R·Kᵀ.
            use crate::lower::structure::{
                pattern, pattern_inverse, pattern_product as times, pattern_product_macs as macs,
            };
            let (P, Fp, Cp, Rp) = (&f.P_pattern, pattern(F), pattern(C), pattern(&f.Rn));
            let FP = times(&Fp, P);
            let PCt = times(P, &Cp.transpose());
            let S_inv = pattern_inverse(&times(&Cp, &PCt));
            let K = times(&PCt, &S_inv);
            let A = times(&K, &Cp);
            let AP = times(&A, P);
            let KR = times(&K, &Rp);
            let innovation = DMatrix::from_element(ny, 1, true);
            predict_state
                + macs(&Fp, P)
                + macs(&FP, &Fp.transpose())
                + macs(P, &Cp.transpose())
                + macs(&Cp, &PCt)
                + ny * ny * ny
                + macs(&PCt, &S_inv)
                + macs(&K, &innovation)
                + na * nnz(C)
                + macs(&A, P)
                + macs(&AP, &A.transpose())
                + macs(&K, &Rp)
                + macs(&KR, &K.transpose())
        }
    };
    // The gate's eᵀS⁻¹e (S⁻¹ a table for the steady-state filter) and the re-acquisition's C⁺.
    let filter = filter + f.screening.gate.map_or(0, |_| ny * ny + ny);
    filter_constants += coefficients(&f.C_pinv.rows(0, p.nx).into_owned());
    if f.screening.gate.is_some() && f.kind == FilterKind::SteadyState {
        filter_constants += ny * ny;
    }
    // The restart table: each row the entries of K_k (and, with a gate, of S_k⁻¹) that can be nonzero.
    if let Some(first) = f.restart.first() {
        let entries = |M: fn(&crate::linalg::Gain) -> &DMatrix<f64>| {
            let (r, c) = M(first).shape();
            (0..r * c)
                .filter(|&n| {
                    f.restart
                        .iter()
                        .any(|g| num.round(M(g)[(n % r, n / r)]) != 0.0)
                })
                .count()
        };
        let gate_entries = if f.screening.gate.is_some() {
            entries(|g| &g.S_inv)
        } else {
            0
        };
        filter_constants += f.restart.len() * (entries(|g| &g.K) + gate_entries);
    }
    let size = num.bytes();
    let real = (size, size);
    let array = |n: usize, (s, a): (usize, usize)| (n * s, a);
    let u32_ = (4, 4);
    let history = f.screening.stuck_cycles.is_some() || f.screening.gate.is_some();
    let kalman = layout(&[
        array(na, real),
        if f.kind == FilterKind::TimeVarying {
            array(na * na, real)
        } else {
            (0, 1)
        },
        if history { array(ny, real) } else { (0, 1) },
        if history { u32_ } else { (0, 1) },
        if f.screening.gate.is_some() {
            u32_
        } else {
            (0, 1)
        },
        // The restart's count of fused readings.
        if f.restart.is_empty() { (0, 1) } else { u32_ },
        filter_status_layout(f, size),
    ]);
    (filter, filter_constants, kalman)
}

/// The size and alignment of a Rust struct (the default representation) with fields of these sizes and
/// alignments: the compiler orders fields so that none needs padding before it (every size is a multiple
/// of its alignment), so the size is the sum rounded up to the largest alignment.
use crate::plan::layout;
