//! ADMM (`codegen::admm`) on the constrained QPs of the shipped specs (`specs/quadcopter.toml`,
//! `specs/hover.toml`, `specs/paper-limits.toml`): ρ tuned on a sample, then on other cases (cold draws
//! and a warm closed loop run by the fixed-iteration control step) every solve within `accuracy` of the
//! exact solution, in f64 and in f32, f32 needing at most [`F32_FACTOR`] × f64's count; the cost against
//! issue 17's calibration; the infeasibility test and the fallback.
#![allow(non_snake_case)]

use codegen::admm::{self, Case, Fallback, Form, Settings, Start, Status};
use codegen::evidence::Limits;
use codegen::ipm::{self, InequalityQp};
use codegen::lower::Qp;
use nalgebra::DVector;

// Clarabel on an `InequalityQp`, shared with the integration tests.
#[allow(dead_code)]
#[path = "../../tests/benches/exact.rs"]
mod exact;

const QUADCOPTER: &str = include_str!("../../specs/quadcopter.toml");
const HOVER: &str = include_str!("../../specs/hover.toml");
const PAPER_LIMITS: &str = include_str!("../../specs/paper-limits.toml");

/// f32 may need at most this many times f64's iterations on a case (the calibration: "kept its f64
/// counts").
const F32_FACTOR: f64 = 1.25;

/// A run is capped at this many iterations when counted.
const CAP: usize = 20_000;

/// The calibration's best-ρ ADMM multiply-adds a solve (issue 17: cold worst case, hard rows) and issue
/// 18's target, at most 1.5× them.
const TARGET: f64 = 1.5;

/// A deterministic stream of numbers in [0, 1) (an LCG): the tests need no statistics.
struct Stream(u64);

impl Stream {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

struct Spec {
    p: codegen::Problem,
    region: codegen::sampling::Region,
}

fn load(text: &str) -> Spec {
    let spec = mpc_spec::load(text).unwrap();
    let p = codegen::lower::uncertified(&spec).unwrap();
    let region = codegen::sampling::resolve_region(&spec, &p, "ADMM").unwrap();
    Spec { p, region }
}

impl Spec {
    fn qp(&self) -> &Qp {
        &self.p.qp
    }

    /// A state and a constant reference drawn from the region.
    fn draw(&self, rng: &mut Stream) -> (DVector<f64>, DVector<f64>) {
        let pick = |rng: &mut Stream, lo: &[f64], hi: &[f64]| {
            DVector::from_iterator(
                lo.len(),
                lo.iter().zip(hi).map(|(a, b)| a + (b - a) * rng.next()),
            )
        };
        let r = &self.region;
        let x0 = pick(rng, &r.x_min, &r.x_max);
        (x0, pick(rng, &r.reference_min, &r.reference_max))
    }

    /// f and the rows' offset at (x0, reference), the last input at rest.
    fn data(&self, x0: &DVector<f64>, reference: &DVector<f64>) -> (DVector<f64>, DVector<f64>) {
        let qp = self.qp();
        let Xref = DVector::from_fn(qp.N * qp.nz, |i, _| reference[i % qp.nz]);
        let last = qp.rest_input();
        let f = &qp.Fx * x0 - &qp.Fr * Xref + &qp.Fu * &last;
        let offset = qp.rows.offset(x0, &DVector::zeros(0), &last);
        (f, offset)
    }

    fn span(&self) -> DVector<f64> {
        let qp = self.qp();
        let nu = qp.u_min.len();
        DVector::from_fn(qp.N * nu, |i, _| qp.u_max[i % nu] - qp.u_min[i % nu])
    }

    /// The exact solution (the interior-point method to 1e-10), `None` where the hard rows admit none.
    fn exact(&self, problem: &InequalityQp) -> Option<ipm::IpmResult> {
        let r = ipm::solve(problem, 1e-10, 200);
        (r.status == ipm::Status::Converged).then_some(r)
    }

    /// `count` cold cases with an exact solution.
    fn cold(&self, seed: u64, count: usize) -> Vec<Case> {
        let mut rng = Stream(seed);
        let mut out = Vec::new();
        while out.len() < count {
            let (x0, r) = self.draw(&mut rng);
            let (f, offset) = self.data(&x0, &r);
            let problem = ipm::mpc_qp(self.qp(), &f, &offset);
            if let Some(exact) = self.exact(&problem) {
                out.push(Case {
                    qp: problem,
                    exact: exact.z,
                    start: Start::Cold,
                    span: self.span(),
                });
            }
        }
        out
    }

    /// A closed loop on the nominal model flown by the exact solution, each step a case warm-started
    /// from the previous step's exact (x, z, y) shifted: what a warm start carries when the previous
    /// solve was accurate. The reference changes every `hold` steps.
    fn warm(&self, seed: u64, steps: usize, hold: usize) -> Vec<Case> {
        let mut rng = Stream(seed);
        let (mut x0, mut r) = self.draw(&mut rng);
        let mut out = Vec::new();
        let mut start = Start::Cold;
        let p = &self.p;
        for k in 0..steps {
            if k % hold == hold - 1 {
                r = self.draw(&mut rng).1;
            }
            let (f, offset) = self.data(&x0, &r);
            let problem = ipm::mpc_qp(self.qp(), &f, &offset);
            let Some(exact) = self.exact(&problem) else {
                break;
            };
            out.push(Case {
                qp: problem.clone(),
                exact: exact.z.clone(),
                start: start.clone(),
                span: self.span(),
            });
            let y = admm::duals_from_ipm(&problem, &exact);
            let cz = DVector::from_iterator(
                problem.n() + problem.A.nrows(),
                exact
                    .z
                    .iter()
                    .copied()
                    .chain((&problem.A * &exact.z).iter().copied()),
            );
            start = admm::shift(self.qp(), &exact.z, &cz, &y);
            let u = exact.z.rows(0, p.nu).into_owned();
            x0 = &p.F * &x0 + &p.G * u;
        }
        out
    }
}

/// ρ on every row alike, `rho` (the closed-form rules' form).
fn uniform(qp: &InequalityQp, rho: f64) -> Settings {
    Settings {
        rho: DVector::from_element(qp.n() + qp.A.nrows(), rho),
        sigma: admm::sigma_of(qp),
        alpha: admm::ALPHA,
        form: Form::Direct,
        stages: None,
    }
}

/// The worst count over `cases` in T, `None` if one misses within `cap`.
fn worst<T: admm::Real>(
    cases: &[Case],
    settings: &dyn Fn(&InequalityQp, f64) -> Settings,
    rho: f64,
    accuracy: f64,
    cap: usize,
) -> Option<usize> {
    cases
        .iter()
        .map(|c| c.needed::<T>(&settings(&c.qp, rho), accuracy, cap))
        .try_fold(0, |w, k| k.map(|k| w.max(k)))
}

/// The cost of one solve at `count` iterations in `settings`: the iterations and the final residuals.
fn macs_per_solve(qp: &Qp, count: usize, settings: &Settings) -> usize {
    count * admm::mpc_settings_macs_per_iteration(qp, settings) + admm::mpc_residual_macs(qp)
}

/// Tunes ρ on a sample of `tuning_cold` cold cases and 30 warm steps, checks the calibration's facts
/// about ρ where `calibration_facts` (the rule √(λmin λmax) on every row loses to the tuned ρ), then runs the
/// fixed count in `form` on other cases (cold, and a closed loop warm-started by the control step
/// itself) in T, each within `accuracy`.
fn meets_the_accuracy<T: admm::Real>(
    name: &str,
    text: &str,
    calibrated: f64,
    scalar: &str,
    form: Form,
    tuning_cold: usize,
    calibration_facts: bool,
) {
    let s = load(text);
    let qp = s.qp();
    let accuracy = qp.accuracy;
    let mut tuning = s.cold(1, tuning_cold);
    tuning.extend(s.warm(2, 60, 30));
    let tuned = admm::tune_rho(&tuning, &Settings::scaled, accuracy, CAP)
        .unwrap_or_else(|| panic!("{name}: no ρ reaches the accuracy within {CAP}"));
    let grid: Vec<String> = tuned
        .grid
        .iter()
        .map(|(r, k)| format!("{r:.1e}:{}", k.map_or("-".into(), |k| k.to_string())))
        .collect();
    println!(
        "{name}: tuned ρ = {:.3e}, worst {} on the tuning sample ({} cases); grid (- = worse than the best so far) {}",
        tuned.rho,
        tuned.worst,
        tuning.len(),
        grid.join(" ")
    );
    // The calibration's facts, on the tuning sample: the rule √(λmin λmax) on every row, and ρ 10× off (`inf`: some case needs more than 12× the tuned count).
    if calibration_facts {
        let e = qp.H.clone().symmetric_eigenvalues();
        let rule = (e.min() * e.max()).sqrt();
        let at = |settings: &dyn Fn(&InequalityQp, f64) -> Settings, rho: f64| {
            worst::<f64>(&tuning, settings, rho, accuracy, 12 * tuned.worst)
        };
        let ratio = |k: Option<usize>| k.map_or(f64::INFINITY, |k| k as f64 / tuned.worst as f64);
        let (rule_k, up, down) = (
            at(&uniform, rule),
            at(&Settings::scaled, 10.0 * tuned.rho),
            at(&Settings::scaled, tuned.rho / 10.0),
        );
        println!(
        "{name}: ρ = √(λmin λmax) = {rule:.2e} on every row: {:.1}× the tuned count; tuned ρ ×10: {:.1}×, ÷10: {:.1}×",
        ratio(rule_k),
        ratio(up),
        ratio(down)
    );
        assert!(
            ratio(rule_k) > 1.0,
            "{name}: the closed-form rule beats the tuned ρ"
        );
    }
    let count = tuned.worst + tuned.worst.div_ceil(10);
    // The settings the emitted solver runs with: the x-update in the structure the cost model picks.
    let chosen = admm::tuned_settings(
        qp,
        admm::Tuned {
            rho: tuned.rho,
            form,
        },
    );
    // Other cases at the fixed count: cold draws and a 100-step closed loop warm-started by the control
    // step's own shifted (x, z, y), the reference changing every 50 steps.
    let span = s.span();
    let error = |plan: &DVector<f64>, exact: &DVector<f64>| {
        (0..plan.len())
            .map(|i| (plan[i] - exact[i]).abs() / span[i])
            .fold(0.0, f64::max)
    };
    let mut worst_error: f64 = 0.0;
    let (mut f64_need, mut t_need, mut factor) = (0, 0, 0.0_f64);
    for (k, c) in s.cold(11, 30).iter().enumerate() {
        let settings = chosen.clone();
        let r = admm::solve_fixed::<T>(&c.qp, &settings, &Start::Cold, count);
        let (e, v) = c.accuracy_of(&r.x);
        assert!(
            e <= accuracy && v <= accuracy,
            "{name} {scalar} cold case {k}: |U − U*|∞ = {e:e} of the span, violation {v:e}"
        );
        worst_error = worst_error.max(e);
        if k < 10 {
            // The exact reference against Clarabel.
            let clarabel = exact::clarabel(&c.qp);
            let n = span.len();
            let gap = error(
                &c.exact.rows(0, n).into_owned(),
                &clarabel.rows(0, n).into_owned(),
            );
            assert!(
                gap <= 1e-6,
                "{name} case {k}: the exact solution is {gap:e} from Clarabel"
            );
        }
        let a = c.needed::<f64>(&settings, accuracy, CAP).unwrap();
        let b = c.needed::<T>(&settings, accuracy, CAP);
        let b = b.unwrap_or_else(|| panic!("{name} {scalar} cold case {k} does not settle"));
        f64_need = f64_need.max(a);
        t_need = t_need.max(b);
        factor = factor.max(b as f64 / a as f64);
    }
    let mut rng = Stream(13);
    let (mut x0, mut reference) = s.draw(&mut rng);
    let mut start = Start::Cold;
    let mut plan = qp.rest_plan();
    let mut fallbacks = 0;
    for step in 0..100 {
        if step % 50 == 49 {
            reference = s.draw(&mut rng).1;
        }
        let (f, offset) = s.data(&x0, &reference);
        let problem = ipm::mpc_qp(qp, &f, &offset);
        let Some(exact) = s.exact(&problem) else {
            break;
        };
        let settings = chosen.clone();
        let st = admm::control_step::<T>(
            qp,
            &settings,
            &f,
            &offset,
            &start,
            &plan,
            count,
            &Limits::NONE,
            false,
        );
        fallbacks += usize::from(st.fallback != Fallback::Solved);
        let c = Case {
            qp: problem,
            exact: exact.z.clone(),
            start: start.clone(),
            span: span.clone(),
        };
        let (e, v) = c.accuracy_of(&st.result.x);
        assert!(
            e <= accuracy && v <= accuracy,
            "{name} {scalar} warm step {step}: |U − U*|∞ = {e:e} of the span, violation {v:e}"
        );
        worst_error = worst_error.max(e);
        start = admm::shifted_start(qp, &st);
        plan = st.plan.clone();
        x0 = &s.p.F * &x0 + &s.p.G * plan.rows(0, s.p.nu).into_owned();
    }
    assert_eq!(fallbacks, 0, "{name}: a trusted solve fell back");
    let macs = macs_per_solve(qp, count, &chosen);
    println!(
        "{name} {scalar}: {count} iterations, worst |U − U*|∞ {worst_error:.2e} of the span over 30 cold cases and 100 warm steps; \
         cold needs f64 {f64_need}, {scalar} {t_need} (per case {scalar}/f64 at most {factor:.2}); \
         {} multiply-adds an iteration ({} x-update; condensed {}), {macs} a solve = {:.2}× the calibration's {calibrated:.0}",
        admm::mpc_settings_macs_per_iteration(qp, &chosen),
        chosen.structure().name(),
        admm::mpc_macs_per_iteration_in(qp, form),
        macs as f64 / calibrated
    );
    assert!(
        factor <= F32_FACTOR,
        "{name}: {scalar} needs {factor:.2}× f64's count on a case"
    );
    assert!(
        macs as f64 <= TARGET * calibrated,
        "{name}: {macs} multiply-adds a solve, {:.2}× the calibration",
        macs as f64 / calibrated
    );
}

#[test]
fn quadcopter_f64() {
    meets_the_accuracy::<f64>(
        "quadcopter",
        QUADCOPTER,
        7.9e6,
        "f64",
        Form::Direct,
        40,
        true,
    );
}

#[test]
fn quadcopter_f32() {
    meets_the_accuracy::<f32>(
        "quadcopter",
        QUADCOPTER,
        7.9e6,
        "f32",
        Form::Direct,
        40,
        true,
    );
}

/// Hover's counts have a tail: tuned on 40 cold cases, the count (773 + 10 %) missed one of the 30
/// validation draws (1.3e-3 of the span at 851 iterations), so its tuning sample has 120. On it, the
/// calibration's fact about the closed-form rule does not hold and is not asserted: √(λmin λmax) = 1.38e3
/// on every row needed 0.9× the tuned count (tuned ρ ×10: 5.3×, ÷10: more than 12×; measured once with
/// `calibration_facts`, some 40 s). Hover's state bounds (±5) are far outside its region, so the rows that
/// the per-row scaling serves are rarely active.
#[test]
fn hover_f64() {
    meets_the_accuracy::<f64>("hover", HOVER, 17e6, "f64", Form::Direct, 120, false);
}

/// In f32 only the residual form reaches `accuracy` on hover: the factor rounded to f32 is the exact
/// factor of P + σI + CᵀRC + E, ‖E‖ ≈ ε‖CᵀRC‖, so the direct form's fixed point solves the QP with P + E
/// for P, and some cold cases never settle below 1e-3 of the span. The residual form's fixed point does
/// not depend on K's rounding (`admm::Form`).
#[test]
fn hover_f32() {
    meets_the_accuracy::<f32>("hover", HOVER, 17e6, "f32", Form::Residual, 120, false);
}

/// The direct form in f32 on hover, for the record: some cold case never settles within the cap.
#[test]
fn hover_f32_direct_form_does_not_settle() {
    let s = load(HOVER);
    let qp = s.qp();
    let cases = s.cold(11, 30);
    let missed = cases.iter().any(|c| {
        let settings = Settings::scaled(&c.qp, 10.0);
        c.needed::<f32>(&settings, qp.accuracy, 4_000).is_none()
            && c.needed::<f64>(&settings, qp.accuracy, 4_000).is_some()
    });
    assert!(missed, "the direct form settles in f32 on every case");
}

#[test]
fn paper_limits_f64() {
    meets_the_accuracy::<f64>(
        "paper-limits",
        PAPER_LIMITS,
        1.9e6,
        "f64",
        Form::Direct,
        40,
        true,
    );
}

#[test]
fn paper_limits_f32() {
    meets_the_accuracy::<f32>(
        "paper-limits",
        PAPER_LIMITS,
        1.9e6,
        "f32",
        Form::Direct,
        40,
        true,
    );
}

/// Falling at 6 m/s 2 m below the quadcopter's floor z ≥ −1: no input keeps z ≥ −1. The test on δy
/// says so, the plan falls back to the shifted previous one inside the box; non-finite data is a
/// numerical failure, also inside the box.
#[test]
fn infeasible_and_non_finite_data_fall_back() {
    let s = load(QUADCOPTER);
    let qp = s.qp();
    let mut x0 = DVector::zeros(s.p.nx);
    x0[5] = -3.0;
    x0[11] = -6.0;
    let (f, offset) = s.data(&x0, &DVector::zeros(qp.nz));
    let problem = ipm::mpc_qp(qp, &f, &offset);
    let settings = Settings::scaled(&problem, 10.0);
    let plan = qp.rest_plan();
    let limits = Limits {
        primal: 1e-3,
        dual: 1e-3,
        gap: 1e-3,
    };
    let inside = |p: &DVector<f64>| {
        let nu = qp.u_min.len();
        (0..p.len())
            .all(|i| p[i].is_finite() && p[i] >= qp.u_min[i % nu] && p[i] <= qp.u_max[i % nu])
    };
    let step64 = admm::control_step::<f64>(
        qp,
        &settings,
        &f,
        &offset,
        &Start::Cold,
        &plan,
        400,
        &limits,
        false,
    );
    let step32 = admm::control_step::<f32>(
        qp,
        &settings,
        &f,
        &offset,
        &Start::Cold,
        &plan,
        400,
        &limits,
        false,
    );
    for (scalar, st) in [("f64", &step64), ("f32", &step32)] {
        println!(
            "{scalar}: {:?}, residuals {:.1e} {:.1e}",
            st.result.status, st.result.primal_residual, st.result.dual_residual
        );
        assert_eq!(st.result.status, Status::Infeasible, "{scalar}");
        assert_eq!(st.fallback, Fallback::WarmStart);
        assert!(inside(&st.plan));
        assert!(matches!(admm::shifted_start(qp, st), Start::Cold));
    }
    let mut bad = f.clone();
    bad[0] = f64::NAN;
    let st = admm::control_step::<f32>(
        qp,
        &settings,
        &bad,
        &offset,
        &Start::Cold,
        &plan,
        50,
        &limits,
        false,
    );
    assert_eq!(st.result.status, Status::NumericalFailure);
    assert_eq!(st.fallback, Fallback::WarmStart);
    assert!(inside(&st.plan));
    // A feasible case is not called infeasible, in either scalar.
    let c = &s.cold(5, 1)[0];
    for r in [
        admm::solve_fixed::<f64>(&c.qp, &settings, &Start::Cold, 400),
        admm::solve_fixed::<f32>(&c.qp, &settings, &Start::Cold, 400),
    ] {
        assert_eq!(r.status, Status::IterationLimit);
    }
}

/// `method = "admm"` is certified like the interior-point method, in the module's scalar, at a ρ
/// tuned on part of the same sample: the count reaches `accuracy` on every case of the sample, the
/// sample (tuning included) stays inside the build's budget, and the limits are set.
#[test]
fn the_certificate_tunes_rho_and_samples_the_region() {
    // paper-limits takes 50 s here (its corners need 2,500 iterations), and f64 as long again as f32:
    // add them to the lists to see them.
    let (names, scalars): (&[(&str, &str)], &[&str]) = (&[("quadcopter", QUADCOPTER)], &["f32"]);
    for (name, text) in names {
        for scalar in scalars {
            let src = text
                .replacen("\n[mpc]\n", "\n[mpc]\nmethod = \"admm\"\n", 1)
                .replace("scalar = \"f64\"", &format!("scalar = \"{scalar}\""))
                .replace("scalar = \"f32\"", &format!("scalar = \"{scalar}\""));
            let spec = mpc_spec::load(&src).unwrap();
            assert_eq!(spec.mpc.method, mpc_spec::Method::Admm);
            let start = std::time::Instant::now();
            let p = codegen::lower(&spec).unwrap();
            let e = p.qp.evidence.as_ref().expect("ADMM is sampled");
            let rho = e.rho.expect("ADMM's certificate carries its ρ");
            let form = e.admm_form.expect("and its form");
            println!(
                "{name} admm {scalar}: ρ = {rho:.3e}, {:?} form, {} iterations (cold worst {}, warm worst {}), worst error {:.2e}, limits {:.1e}/{:.1e}, {} fallbacks, {:.2e} multiply-adds sampled, {:.1} s",
                form, e.iterations, e.cold_worst, e.warm_worst, e.worst_error, e.limits.primal, e.limits.dual,
                e.fallbacks, e.sample_macs, start.elapsed().as_secs_f64()
            );
            assert!(rho > 0.0 && rho.is_finite());
            assert!(e.worst_needed <= e.iterations);
            assert!(e.worst_error <= p.qp.accuracy, "{name} {scalar}");
            assert!(e.sample_macs <= codegen::budget::LOWERING_MACS);
            assert!(e.limits.primal.is_finite() && e.limits.dual.is_finite());
            assert_eq!(p.qp.iterations, e.iterations);
        }
    }
}

/// The stage-wise x-update (`Structure::Riccati`) gives the condensed one's iterates to rounding, in
/// both forms: on each shipped spec's cold cases, 50 iterations in f64 from the same start end within
/// 1e-9 of the span of each other; the cost model's counts are printed (`-- --nocapture`).
#[test]
fn the_stage_wise_x_update_gives_the_condensed_iterates() {
    for (name, text) in [
        ("quadcopter", QUADCOPTER),
        ("hover", HOVER),
        ("paper-limits", PAPER_LIMITS),
    ] {
        let s = load(text);
        let qp = s.qp();
        for form in [Form::Direct, Form::Residual] {
            let condensed = admm::mpc_settings(qp, 10.0).in_form(form);
            let choice = admm::StructureChoice::of(qp, &condensed);
            println!(
                "{name}, {form:?}: condensed {} multiply-adds/iteration, stage-wise {:?} ({:?}), chosen {:?}",
                choice.condensed_macs_per_iteration,
                choice.riccati_macs_per_iteration,
                choice.riccati_unavailable,
                choice.structure
            );
            let program = admm::stages_program(qp, &condensed).unwrap();
            let staged = Settings {
                stages: Some(std::sync::Arc::new(program)),
                ..condensed.clone()
            };
            for case in s.cold(7, 3) {
                let a = admm::solve_fixed::<f64>(&case.qp, &condensed, &Start::Cold, 50);
                let b = admm::solve_fixed::<f64>(&case.qp, &staged, &Start::Cold, 50);
                let gap = (0..case.span.len())
                    .map(|i| (a.x[i] - b.x[i]).abs() / case.span[i])
                    .fold(0.0, f64::max);
                let zgap = (&a.z - &b.z).amax() / (1.0 + a.z.amax());
                println!("  plan gap {gap:.2e} of the span, z gap {zgap:.2e}");
                assert!(gap <= 1e-9 && zgap <= 1e-9, "{name}: {gap:e} {zgap:e}");
            }
        }
    }
}
