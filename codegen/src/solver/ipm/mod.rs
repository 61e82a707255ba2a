//! A dense primal-dual interior-point method for convex QPs with inequality rows, in f64: the
//! reference of the fixed-iteration IPM of issue 17 (state, output and rate rows, ill-conditioned
//! plants), before any of it is emitted.
//!
//! The problem is [`InequalityQp`]: minimise ½zᵀHz + fᵀz subject to z_min ≤ z ≤ z_max and
//! lower ≤ A z ≤ upper, any bound ±∞. Its finite sides are stacked as G z ≤ h (upper sides as they are,
//! lower sides negated; infinite sides dropped), with slacks s > 0 and multipliers λ > 0. Each iteration
//! is Mehrotra's predictor-corrector (S. Mehrotra, "On the implementation of a primal-dual interior
//! point method", SIAM J. Optim. 2(4), 1992; for QPs, Nocedal & Wright, *Numerical Optimization*, 2nd
//! ed., ch. 16.6, Algorithm 16.4): one Cholesky factorisation of the normal matrix
//! H + Gᵀ diag(λ/s) G, an affine (predictor) step, the centering σ = (μ_aff/μ)³, a corrector with the
//! second-order term Δs_aff∘Δλ_aff, and a common step to the boundary with the fraction [`FRACTION`].
//! The cold start is the heuristic of Nocedal & Wright (16.6, p. 484): one affine step from s = λ = 1,
//! then s, λ ← max(1, |·|).
//!
//! Two entry points: [`solve_fixed`] runs exactly a given number of iterations (what a fixed-iteration
//! emitted controller will do), [`solve`] / [`solve_from`] run until the relative residuals, the gap
//! and the complementarity are below a tolerance. Neither panics, and a non-finite iterate is never
//! returned as a solution (see [`Status`]). A warm start ([`Start`]) helps when it carries the
//! previous slacks and multipliers shifted by a step; a plan alone does not (`tests/ipm.rs` prints the
//! counts). [`macs_per_iteration`] counts an iteration's cost by the calibration rule of issue 17.
#![allow(non_snake_case)]

use crate::certify::evidence::Limits;
use crate::lower::problem::Qp;
use crate::solver::riccati::{Choice, Form, Stages};
use nalgebra::{DMatrix, DVector};

pub mod condensed;
pub mod emit;
mod emit_rows;
pub mod method;
pub mod sampled;

pub use crate::solver::constrained::{Fallback, InequalityQp};
pub use condensed::{
    condensed_macs_per_iteration, macs_per_iteration, mpc_qp, normal_pattern, side_bound, Layout,
    Sparsity, REFINEMENT,
};
use condensed::{counts, structure_of, Sides};

/// Its name in prose.
pub const TITLE: &str =
    "A primal-dual interior-point method (Mehrotra's predictor-corrector, dense, f64)";

/// Multiply-adds of one iteration of the emitted method on the MPC's QP ([`mpc_qp`]), whose structure
/// does not depend on the data, in the form the cost model chooses ([`crate::solver::riccati::Choice`]).
pub fn mpc_macs_per_iteration(qp: &Qp) -> usize {
    crate::solver::riccati::Choice::of(qp).macs_per_iteration()
}

/// Multiply-adds of the cold start of the MPC's QP, by the rule of [`macs_per_iteration`]: the residuals,
/// the normal matrix H + GᵀG formed and factored, and one direction. The emitted method computes it on
/// every solve, warm or not, so that its control flow does not depend on the data.
pub fn mpc_cold_start_macs(qp: &Qp) -> usize {
    let choice = crate::solver::riccati::Choice::of(qp);
    match crate::solver::riccati::Stages::of(qp) {
        Ok(stages) if choice.form == crate::solver::riccati::Form::Riccati => {
            stages.cold_start_macs(qp)
        }
        _ => {
            let c = counts(&structure_of(qp));
            c.residuals + c.normal + c.factor + c.direction
        }
    }
}

/// Multiply-adds of one iteration in the Riccati form ([`crate::solver::riccati`]), by the same rule as
/// the condensed count and of what is emitted; `None` where that form is not built for the problem.
pub fn riccati_macs_per_iteration(qp: &Qp) -> Option<usize> {
    crate::solver::riccati::Stages::of(qp)
        .ok()
        .map(|s| s.macs_per_iteration(qp))
}

/// The fraction of the step to the boundary of s > 0, λ > 0 that an iteration takes.
pub const FRACTION: f64 = 0.99;

/// Slacks and multipliers of a warm start are raised to at least this, so the first step is not
/// pinned to the boundary (the cold heuristic's floor). On the paper's closed loops (`tests/ipm.rs`)
/// 1 did best for a shifted (z, s, λ) among 1e-4 … 100.
pub const WARM_FLOOR: f64 = 1.0;

/// A fixed-iteration solve stops moving once its relative residuals, and its gap relative to the
/// objective, are below this: the point is optimal to rounding.
pub const FINISHED: f64 = 1e-12;

/// The infeasibility certificate's tolerance: λ ≥ 0 with ‖Gᵀλ‖∞ ≤ this · (−hᵀλ) proves G z ≤ h empty
/// (Farkas), for z of order one.
pub const INFEASIBILITY_TOLERANCE: f64 = 1e-8;

/// Where the iteration starts.
#[derive(Clone, Debug)]
pub enum Start {
    /// Nocedal & Wright's heuristic: one affine step from z = 0, s = λ = 1, then s, λ ← max(1, |·|).
    Cold,
    /// A plan z (e.g. the previous plan shifted): s = max(h − G z, [`WARM_FLOOR`]), λ = [`WARM_FLOOR`].
    /// Without the multipliers' scale this saves little or nothing over [`Start::Cold`].
    Primal(DVector<f64>),
    /// A plan with its slacks and multipliers (e.g. a previous [`IpmResult`]'s), each raised to at
    /// least [`WARM_FLOOR`].
    PrimalDual {
        /// The plan (n).
        z: DVector<f64>,
        /// The slacks (one per finite side).
        s: DVector<f64>,
        /// The multipliers (one per finite side).
        lambda: DVector<f64>,
    },
}

/// How a solve ended: the constrained methods' shared status.
pub use crate::solver::constrained::Status;

/// What a solve returns. z is always finite.
#[derive(Clone, Debug)]
pub struct IpmResult {
    /// The plan.
    pub z: DVector<f64>,
    /// The multipliers, one per finite side (box sides first: upper then lower per entry, then the
    /// rows' upper then lower sides).
    pub lambda: DVector<f64>,
    /// The slacks h − G z (at convergence), same layout.
    pub s: DVector<f64>,
    /// Iterations run (the start's factorisation not counted).
    pub iterations: usize,
    /// ‖G z + s − h‖∞ / (1 + max(‖h‖∞, ‖G z‖∞)).
    pub primal_residual: f64,
    /// ‖H z + f + Gᵀλ‖∞ / (1 + max(‖f‖∞, ‖H z‖∞, ‖Gᵀλ‖∞)).
    pub dual_residual: f64,
    /// The mean complementarity sᵀλ / (number of sides), in the objective's units.
    pub gap: f64,
    /// The duality gap sᵀλ relative to the objective, sᵀλ / max(1, |½zᵀHz + fᵀz|): what the control
    /// step's acceptance test holds to [`crate::certify::evidence::Limits::gap`].
    pub relative_gap: f64,
    /// max_i min(s_i, λ_i): zero exactly at complementarity. Unlike the gap it shrinks only like √gap at
    /// a degenerate side (s_i and λ_i both tending to zero), where z is off by as much, so [`solve`]
    /// asks it to be below the tolerance too.
    pub complementarity: f64,
    /// How it ended.
    pub status: Status,
}

/// Exactly `iterations` iterations from `start` (fewer only on infeasibility or a numerical failure).
pub fn solve_fixed(qp: &InequalityQp, start: &Start, iterations: usize) -> IpmResult {
    run(qp, start, None, iterations)
}

/// [`solve_fixed`] with the normal system solved in the Riccati form of `stages` (the MPC's QP of
/// [`mpc_qp`] only), or in the condensed form for `None`: the same iterates to rounding.
pub fn solve_fixed_in(
    qp: &InequalityQp,
    start: &Start,
    iterations: usize,
    stages: Option<&Stages>,
) -> IpmResult {
    run_observed(qp, start, None, iterations, stages, &mut |_| {})
}

/// The stages of the Riccati form where the cost model chooses it for `qp` ([`Choice`]), else `None`.
pub fn chosen_stages(qp: &Qp) -> Option<Stages> {
    match Choice::of(qp).form {
        Form::Riccati => Stages::of(qp).ok(),
        Form::Condensed => None,
    }
}

/// A cold solve until the relative residuals, the gap and the complementarity ([`IpmResult`]) are at
/// most `tolerance`, at most `max_iterations` iterations.
pub fn solve(qp: &InequalityQp, tolerance: f64, max_iterations: usize) -> IpmResult {
    run(qp, &Start::Cold, Some(tolerance), max_iterations)
}

/// [`solve`] from a given start.
pub fn solve_from(
    qp: &InequalityQp,
    start: &Start,
    tolerance: f64,
    max_iterations: usize,
) -> IpmResult {
    run(qp, start, Some(tolerance), max_iterations)
}

/// The iterate.
#[derive(Clone)]
struct Point {
    z: DVector<f64>,
    s: DVector<f64>,
    lambda: DVector<f64>,
}

impl Point {
    fn finite(&self) -> bool {
        self.z
            .iter()
            .chain(&self.s)
            .chain(&self.lambda)
            .all(|v| v.is_finite())
    }
}

/// A direction (Δz, Δs, Δλ).
struct Direction {
    z: DVector<f64>,
    s: DVector<f64>,
    lambda: DVector<f64>,
}

/// The residuals at a point.
#[derive(Clone)]
struct Residuals {
    /// H z + f + Gᵀλ.
    dual: DVector<f64>,
    /// G z + s − h.
    primal: DVector<f64>,
    relative_primal: f64,
    relative_dual: f64,
    gap: f64,
    complementarity: f64,
    /// 1 + |½zᵀHz| + |fᵀz|: the objective's scale, which the gap is measured against.
    objective_scale: f64,
    /// sᵀλ / max(1, |½zᵀHz + fᵀz|).
    relative_gap: f64,
}

impl Residuals {
    /// Whether the point is optimal to rounding ([`FINISHED`]): further iterations would only drive s∘λ
    /// towards underflow, where the normal matrix's weights λ/s span more than f64 and the direction
    /// breaks down (observed: a solution found in 16 iterations lost at 28).
    fn finished(&self) -> bool {
        self.relative_primal <= FINISHED
            && self.relative_dual <= FINISHED
            && self.gap <= FINISHED * self.objective_scale
    }

    fn below(&self, tol: f64) -> bool {
        self.relative_primal <= tol
            && self.relative_dual <= tol
            && self.gap <= tol
            && self.complementarity <= tol
    }
}

fn residuals(qp: &InequalityQp, sides: &Sides, p: &Point) -> Residuals {
    let Hz = &qp.H * &p.z;
    let Gz = sides.mul(&p.z);
    let Gl = sides.tmul(&p.lambda);
    let dual = &Hz + &qp.f + &Gl;
    let primal = &Gz + &p.s - &sides.h;
    let amax = |v: &DVector<f64>| if v.is_empty() { 0.0 } else { v.amax() };
    Residuals {
        relative_primal: amax(&primal) / (1.0 + amax(&sides.h).max(amax(&Gz))),
        relative_dual: amax(&dual) / (1.0 + amax(&qp.f).max(amax(&Hz)).max(amax(&Gl))),
        gap: if p.s.is_empty() {
            0.0
        } else {
            p.s.dot(&p.lambda) / p.s.len() as f64
        },
        objective_scale: 1.0 + (0.5 * p.z.dot(&Hz)).abs() + qp.f.dot(&p.z).abs(),
        relative_gap: relative_gap(p.s.dot(&p.lambda), 0.5 * p.z.dot(&Hz) + qp.f.dot(&p.z)),
        complementarity: p
            .s
            .iter()
            .zip(&p.lambda)
            .map(|(s, l)| s.min(*l))
            .fold(0.0, f64::max),
        dual,
        primal,
    }
}

/// A duality gap relative to the objective J: gap / max(1, |J|) (the emitted methods compute the same).
pub fn relative_gap(gap: f64, objective: f64) -> f64 {
    gap / objective.abs().max(1.0)
}

/// The Cholesky factor of the normal matrix, regularised by a growing multiple of I when it is
/// refused (a semidefinite H with too few active sides).
fn factor(M: DMatrix<f64>) -> Option<nalgebra::Cholesky<f64, nalgebra::Dyn>> {
    let n = M.nrows();
    let scale = 1.0 + (0..n).map(|i| M[(i, i)].abs()).fold(0.0, f64::max);
    let mut delta = 0.0;
    for _ in 0..4 {
        let mut R = M.clone();
        for i in 0..n {
            R[(i, i)] += delta;
        }
        if let Some(c) = R.cholesky() {
            return Some(c);
        }
        delta = if delta == 0.0 {
            1e-12 * scale
        } else {
            delta * 1e3
        };
    }
    None
}

/// A factor of the normal matrix, in either form.
enum Factored {
    Dense(nalgebra::Cholesky<f64, nalgebra::Dyn>),
    Riccati(crate::solver::riccati::Factor),
}

impl Factored {
    /// The normal system's solution for the right-hand side b.
    fn solve(&self, b: &DVector<f64>) -> DVector<f64> {
        match self {
            Factored::Dense(c) => c.solve(b),
            Factored::Riccati(f) => f.solve(b),
        }
    }
}

/// The normal matrix H + Gᵀ diag(d) G factored in the condensed form ([`factor`]) or, with `stages`,
/// in the Riccati form, regularised alike: R̃_k + δ·I at every stage is M + δ·I, δ growing from
/// 1e-12·(1 + the largest diagonal entry of the R̃_k).
fn factor_normal(
    qp: &InequalityQp,
    sides: &Sides,
    d: &DVector<f64>,
    stages: Option<&Stages>,
) -> Option<Factored> {
    let Some(stages) = stages else {
        return factor(sides.normal(&qp.H, d)).map(Factored::Dense);
    };
    let scale = stages.scale(&sides.boxed, &sides.rows, d);
    let mut delta = 0.0;
    for _ in 0..4 {
        if let Some(f) = stages.factor(&sides.boxed, &sides.rows, d, delta) {
            return Some(Factored::Riccati(f));
        }
        delta = if delta == 0.0 {
            1e-12 * scale
        } else {
            delta * 1e3
        };
    }
    None
}

/// The Newton direction for the complementarity right-hand side rc (Λ Δs + S Δλ = −rc): from
/// (H + Gᵀ D G) Δz = −r_d − Gᵀ(D r_p − rc/s), D = λ/s, then [`REFINEMENT`] steps of iterative
/// refinement on the unreduced system's first block H Δz + Gᵀ Δλ = −r_d (the other two hold by
/// construction). Near the solution D spans many orders of magnitude, the normal matrix loses the
/// digits of H, and an unrefined direction stops reducing the dual residual while s∘λ goes on
/// shrinking: the solve stalls with a gap of 1e-246 and a dual residual of 1e-5.
fn direction(
    H: &DMatrix<f64>,
    sides: &Sides,
    chol: &Factored,
    r: &Residuals,
    p: &Point,
    rc: &DVector<f64>,
    refinement: usize,
) -> Direction {
    let d = p.lambda.component_div(&p.s);
    let solve = |r_dual: &DVector<f64>, r_primal: &DVector<f64>, rc: &DVector<f64>| {
        let rc_s = rc.component_div(&p.s);
        let rhs = -r_dual - sides.tmul(&(d.component_mul(r_primal) - &rc_s));
        let dz = chol.solve(&rhs);
        let dl = d.component_mul(&(sides.mul(&dz) + r_primal)) - rc_s;
        let ds = -(rc + p.s.component_mul(&dl)).component_div(&p.lambda);
        Direction {
            z: dz,
            s: ds,
            lambda: dl,
        }
    };
    let mut direction = solve(&r.dual, &r.primal, rc);
    let zero = DVector::zeros(p.s.len());
    for _ in 0..refinement {
        // The first block's error e = −r_d − (H Δz + Gᵀ Δλ); the correction solves with r_d = −e.
        let error = -&r.dual - (H * &direction.z + sides.tmul(&direction.lambda));
        let correction = solve(&-error, &zero, &zero);
        direction.z += correction.z;
        direction.s += correction.s;
        direction.lambda += correction.lambda;
    }
    direction
}

/// The largest α keeping s + αΔs ≥ 0 and λ + αΔλ ≥ 0 (∞ when nothing decreases).
fn step_to_boundary(p: &Point, d: &Direction) -> f64 {
    let mut alpha = f64::INFINITY;
    for (v, dv) in p.s.iter().zip(&d.s).chain(p.lambda.iter().zip(&d.lambda)) {
        if *dv < 0.0 {
            alpha = alpha.min(-v / dv);
        }
    }
    alpha
}

fn start_point(
    qp: &InequalityQp,
    sides: &Sides,
    start: &Start,
    stages: Option<&Stages>,
) -> Option<Point> {
    let n = qp.n();
    let m = sides.len();
    let floor = |v: &DVector<f64>| v.map(|x| x.max(WARM_FLOOR));
    let point = match start {
        Start::Cold => {
            let p = Point {
                z: DVector::zeros(n),
                s: DVector::from_element(m, 1.0),
                lambda: DVector::from_element(m, 1.0),
            };
            let r = residuals(qp, sides, &p);
            let chol = factor_normal(qp, sides, &DVector::from_element(m, 1.0), stages)?;
            let d = direction(
                &qp.H,
                sides,
                &chol,
                &r,
                &p,
                &p.s.component_mul(&p.lambda),
                0,
            );
            Point {
                z: &p.z + &d.z,
                s: (&p.s + &d.s).map(|x| x.abs().max(1.0)),
                lambda: (&p.lambda + &d.lambda).map(|x| x.abs().max(1.0)),
            }
        }
        Start::Primal(z) => {
            if z.len() != n {
                return None;
            }
            Point {
                z: z.clone(),
                s: floor(&(&sides.h - sides.mul(z))),
                lambda: DVector::from_element(m, WARM_FLOOR),
            }
        }
        Start::PrimalDual { z, s, lambda } => {
            if z.len() != n || s.len() != m || lambda.len() != m {
                return None;
            }
            Point {
                z: z.clone(),
                s: floor(s),
                lambda: floor(lambda),
            }
        }
    };
    point.finite().then_some(point)
}

/// The fallback z of a failed solve: the start's plan when it is finite and of the right size, else 0.
fn fallback_z(qp: &InequalityQp, start: &Start) -> DVector<f64> {
    let z = match start {
        Start::Cold => None,
        Start::Primal(z) | Start::PrimalDual { z, .. } => Some(z),
    };
    match z {
        Some(z) if z.len() == qp.n() && z.iter().all(|v| v.is_finite()) => z.clone(),
        _ => DVector::zeros(qp.n()),
    }
}

fn result(p: Point, r: &Residuals, iterations: usize, status: Status) -> IpmResult {
    IpmResult {
        z: p.z,
        lambda: p.lambda,
        s: p.s,
        iterations,
        primal_residual: r.relative_primal,
        dual_residual: r.relative_dual,
        gap: r.gap,
        relative_gap: r.relative_gap,
        complementarity: r.complementarity,
        status,
    }
}

fn failure(qp: &InequalityQp, start: &Start, iterations: usize) -> IpmResult {
    IpmResult {
        z: fallback_z(qp, start),
        lambda: DVector::zeros(0),
        s: DVector::zeros(0),
        iterations,
        primal_residual: f64::INFINITY,
        dual_residual: f64::INFINITY,
        gap: f64::INFINITY,
        relative_gap: f64::INFINITY,
        complementarity: f64::INFINITY,
        status: Status::NumericalFailure,
    }
}

/// Whether λ certifies G z ≤ h infeasible (Farkas: λ ≥ 0, Gᵀλ = 0, hᵀλ < 0), or has diverged.
fn infeasible(sides: &Sides, lambda: &DVector<f64>) -> bool {
    let htl = sides.h.dot(lambda);
    let certificate = htl < 0.0 && sides.tmul(lambda).amax() <= INFEASIBILITY_TOLERANCE * (-htl);
    certificate || lambda.amax() > 1e15
}

fn run(qp: &InequalityQp, start: &Start, tolerance: Option<f64>, iterations: usize) -> IpmResult {
    run_observed(qp, start, tolerance, iterations, None, &mut |_| {})
}

/// Every iterate of [`solve_fixed`] from `start`: element k is what `solve_fixed(qp, start, k)`
/// returns, for k = 1 … (up to `iterations`; fewer when the solve stops early on infeasibility or a
/// failure, whose result is then last). Element 0 is the start.
pub fn trajectory(qp: &InequalityQp, start: &Start, iterations: usize) -> Vec<IpmResult> {
    trajectory_in(qp, start, iterations, None)
}

/// [`trajectory`] with the normal system solved in the Riccati form of `stages` (the MPC's QP of
/// [`mpc_qp`] only), or in the condensed form for `None`.
pub fn trajectory_in(
    qp: &InequalityQp,
    start: &Start,
    iterations: usize,
    stages: Option<&Stages>,
) -> Vec<IpmResult> {
    let mut out = Vec::with_capacity(iterations + 1);
    let last = run_observed(qp, start, None, iterations, stages, &mut |r| out.push(r));
    // A solve that stopped on infeasibility or a failure ends with that result, in the place of the
    // iterate it judged.
    match out.last_mut() {
        Some(r) if r.iterations == last.iterations => *r = last,
        Some(r) if r.status == Status::Converged => {}
        _ => out.push(last),
    }
    out
}

/// [`run`], reporting the iterate before the first iteration and after each.
fn run_observed(
    qp: &InequalityQp,
    start: &Start,
    tolerance: Option<f64>,
    iterations: usize,
    stages: Option<&Stages>,
    observe: &mut dyn FnMut(IpmResult),
) -> IpmResult {
    // The Riccati form solves the MPC's QP, whose unknowns are the plan and the slacks.
    let stages = stages.filter(|s| qp.n() == s.N * s.B.ncols() + s.slack_quadratic.len());
    if !qp.consistent() || !qp.finite() {
        return failure(qp, start, 0);
    }
    let sides = Sides::new(qp);
    let m = sides.len();
    if m == 0 {
        // Unconstrained: one Newton step is the minimiser.
        if iterations == 0 {
            let p = Point {
                z: fallback_z(qp, start),
                s: DVector::zeros(0),
                lambda: DVector::zeros(0),
            };
            let r = residuals(qp, &sides, &p);
            return result(p, &r, 0, Status::IterationLimit);
        }
        let z = factor(qp.H.clone()).map(|c| c.solve(&-&qp.f));
        return match z {
            Some(z) if z.iter().all(|v| v.is_finite()) => {
                let p = Point {
                    z,
                    s: DVector::zeros(0),
                    lambda: DVector::zeros(0),
                };
                let r = residuals(qp, &sides, &p);
                result(p, &r, 1, Status::Converged)
            }
            _ => failure(qp, start, 0),
        };
    }
    let Some(mut p) = start_point(qp, &sides, start, stages) else {
        return failure(qp, start, 0);
    };
    let mut r = residuals(qp, &sides, &p);
    observe(result(p.clone(), &r, 0, Status::IterationLimit));
    // A solve to a tolerance remembers the first point optimal to rounding: at a degenerate side (s_i and
    // λ_i both tending to zero) the tolerance on min(s_i, λ_i) can need products that underflow first, and
    // the solve then ends on that point rather than on the breakdown.
    let mut finished: Option<(Point, Residuals, usize)> = None;
    let ended = |p: Point,
                 r: &Residuals,
                 k: usize,
                 status: Status,
                 finished: Option<(Point, Residuals, usize)>| {
        match finished {
            Some((p, r, k)) if tolerance.is_some() => result(p, &r, k, Status::Converged),
            _ => result(p, r, k, status),
        }
    };
    for k in 0..iterations {
        if tolerance.is_some_and(|tol| r.below(tol)) {
            return result(p, &r, k, Status::Converged);
        }
        // A fixed-iteration solve (no tolerance) holds a point optimal to rounding.
        if tolerance.is_none() && r.finished() {
            // The remaining iterations leave the point as it is.
            for _ in k..iterations {
                observe(result(p.clone(), &r, k, Status::Converged));
            }
            return result(p, &r, k, Status::Converged);
        }
        let mu = p.s.dot(&p.lambda) / m as f64;
        let Some(chol) = factor_normal(qp, &sides, &p.lambda.component_div(&p.s), stages) else {
            return ended(p, &r, k, Status::NumericalFailure, finished);
        };
        // Predictor: the affine-scaling direction (σ = 0).
        let affine = direction(
            &qp.H,
            &sides,
            &chol,
            &r,
            &p,
            &p.s.component_mul(&p.lambda),
            0,
        );
        let alpha = step_to_boundary(&p, &affine).min(1.0);
        let mu_affine =
            (&p.s + &affine.s * alpha).dot(&(&p.lambda + &affine.lambda * alpha)) / m as f64;
        let sigma = if mu > 0.0 {
            (mu_affine / mu).clamp(0.0, 1.0).powi(3)
        } else {
            0.0
        };
        // Corrector: centering plus the second-order term of the complementarity.
        let rc = p.s.component_mul(&p.lambda) + affine.s.component_mul(&affine.lambda)
            - DVector::from_element(m, sigma * mu);
        let d = direction(&qp.H, &sides, &chol, &r, &p, &rc, REFINEMENT);
        let alpha = (FRACTION * step_to_boundary(&p, &d)).min(1.0);
        let next = Point {
            z: &p.z + &d.z * alpha,
            s: &p.s + &d.s * alpha,
            lambda: &p.lambda + &d.lambda * alpha,
        };
        if !next.finite() || next.s.iter().chain(&next.lambda).any(|v| *v <= 0.0) {
            return ended(p, &r, k, Status::NumericalFailure, finished);
        }
        p = next;
        r = residuals(qp, &sides, &p);
        observe(result(p.clone(), &r, k + 1, Status::IterationLimit));
        if tolerance.is_some() && finished.is_none() && r.finished() {
            finished = Some((p.clone(), r.clone(), k + 1));
        }
        if infeasible(&sides, &p.lambda) {
            return ended(p, &r, k + 1, Status::Infeasible, finished);
        }
    }
    let status = if tolerance.is_some_and(|tol| r.below(tol)) {
        Status::Converged
    } else {
        Status::IterationLimit
    };
    ended(p, &r, iterations, status, finished)
}

/// One interior-point control step: the plan and what happened.
#[derive(Clone, Debug)]
pub struct Step {
    /// The plan U (N·nu), inside the input box.
    pub plan: DVector<f64>,
    /// The solve (its z includes the slacks).
    pub result: IpmResult,
    /// Whether the plan is the solve's.
    pub fallback: Fallback,
}

/// The warm start of the next step: the solve's (z, s, λ) shifted by one slot (the plan's last step
/// and the rows' last slot repeated, the slacks and their sides kept), or `Cold` after a fallback.
pub fn shifted_start(qp: &Qp, previous: &Step) -> Start {
    let r = &previous.result;
    if previous.fallback != Fallback::Solved || r.s.is_empty() {
        return Start::Cold;
    }
    let nu = qp.u_min.len();
    let n = qp.Nc * nu;
    let ns = qp.rows.slacks();
    let sides_per_slot = (r.s.len() - 2 * n - ns) / qp.N;
    let shift = |v: &DVector<f64>| -> DVector<f64> {
        let mut out = v.clone();
        shift_blocks(&mut out.as_mut_slice()[..2 * n], 2 * nu);
        shift_blocks(&mut out.as_mut_slice()[2 * n + ns..], sides_per_slot);
        out
    };
    let mut z = r.z.clone();
    shift_blocks(&mut z.as_mut_slice()[..n], nu);
    let rest = qp.rest_input();
    z.rows_mut(n - nu, nu).copy_from(&rest);
    Start::PrimalDual {
        z,
        s: shift(&r.s),
        lambda: shift(&r.lambda),
    }
}

/// Moves every block of `width` up by one, the last block kept.
fn shift_blocks(v: &mut [f64], width: usize) {
    if width == 0 || v.len() <= width {
        return;
    }
    v.copy_within(width.., 0);
}

/// The held plan: `previous_plan` shifted by one step, the rest input appended, projected onto the box.
pub fn held_plan(qp: &Qp, previous_plan: &DVector<f64>) -> DVector<f64> {
    let n = previous_plan.len();
    let nu = qp.u_min.len();
    let mut held = previous_plan.clone();
    shift_blocks(held.as_mut_slice(), nu);
    held.rows_mut(n - nu, nu).copy_from(&qp.rest_input());
    DVector::from_fn(n, |i, _| {
        crate::linalg::project(held[i], qp.u_min[i % nu], qp.u_max[i % nu])
    })
}

/// `problem` (the step's QP, [`mpc_qp`]) with each hard row's bounds widened to the value the plan
/// `held` (slacks zero) gives the row: lower ← min(lower, a·held), upper ← max(upper, a·held). The held
/// plan is then feasible, so the QP has a solution, and it equals the hard QP wherever the held plan
/// meets the rows. What the controller solves after the hard rows admitted no plan: a plan that
/// violates no hard row more than holding would, steered back by the cost.
pub fn relaxed(qp: &Qp, mut problem: InequalityQp, held: &DVector<f64>) -> InequalityQp {
    let n = held.len();
    for r in 0..problem.A.nrows() {
        if qp.rows.soft[r] {
            continue;
        }
        let a = problem.A.row(r).columns(0, n).transpose().dot(held);
        problem.lower[r] = problem.lower[r].min(a);
        problem.upper[r] = problem.upper[r].max(a);
    }
    problem
}

/// Whether the controller is recovering after this step: its solve found the hard rows infeasible, or
/// it made a [`relaxed`] plan. A recovering controller's next step solves the relaxed QP when the held
/// plan violates a hard row by more than `accuracy` (relative to max(1, |bound|)), and the hard QP
/// otherwise (the held plan is then a feasible point of it).
pub fn recovering_after(step: &Step) -> bool {
    step.result.status == Status::Infeasible || step.fallback == Fallback::Relaxed
}

/// One control step: `iterations` from `start`, then the plan or the fallback to `previous_plan`
/// shifted (rest input appended) when the solve failed, detected infeasibility, or ended with residuals
/// or gap above `limits`. `recovering` ([`recovering_after`] of the previous step): the step solves the
/// [`relaxed`] QP where the held plan violates a hard row.
#[allow(clippy::too_many_arguments)]
pub fn control_step(
    qp: &Qp,
    f: &DVector<f64>,
    offset: &DVector<f64>,
    start: &Start,
    previous_plan: &DVector<f64>,
    iterations: usize,
    limits: &Limits,
    recovering: bool,
) -> Step {
    let held = held_plan(qp, previous_plan);
    let relax = recovering && violations(qp, &held, offset).0 > qp.accuracy;
    let mut problem = mpc_qp(qp, f, offset);
    if relax {
        problem = relaxed(qp, problem, &held);
    }
    let result = solve_fixed_in(&problem, start, iterations, chosen_stages(qp).as_ref());
    let n = f.len();
    let trusted = matches!(result.status, Status::IterationLimit | Status::Converged)
        && result.primal_residual <= limits.primal
        && result.dual_residual <= limits.dual
        && result.relative_gap <= limits.gap;
    let nu = qp.u_min.len();
    if trusted {
        return Step {
            plan: DVector::from_fn(n, |i, _| {
                crate::linalg::project(result.z[i], qp.u_min[i % nu], qp.u_max[i % nu])
            }),
            result,
            fallback: if relax {
                Fallback::Relaxed
            } else {
                Fallback::Solved
            },
        };
    }
    Step {
        plan: held,
        result,
        fallback: Fallback::WarmStart,
    }
}

/// The largest violation of a hard row by the plan U (slacks zero), each relative to max(1, |bound|);
/// and the largest slack of a soft row, in its row's units.
pub fn violations(qp: &Qp, U: &DVector<f64>, offset: &DVector<f64>) -> (f64, f64) {
    let rows = &qp.rows;
    let n = U.len();
    let (mut hard, mut soft) = (0.0_f64, 0.0_f64);
    for r in 0..rows.len() {
        let a = rows.A.row(r).columns(0, n).transpose().dot(U) + offset[r];
        let below = (rows.lower[r] - a).max(0.0) / rows.lower[r].abs().max(1.0);
        let above = (a - rows.upper[r]).max(0.0) / rows.upper[r].abs().max(1.0);
        if rows.soft[r] {
            soft = soft.max((rows.lower[r] - a).max(a - rows.upper[r]).max(0.0));
        } else {
            hard = hard.max(below.max(above));
        }
    }
    (hard, soft)
}
