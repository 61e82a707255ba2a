//! Code generation for `mpc!`, as a plain library that the proc macro and the `mpcc` command call.
//!
//! The phases are gated, as in cxx: [`mpc_spec::load`] parses and checks the spec; [`lower()`] computes the
//! condensed QP, its constraint rows ([`constraints`]), its solver's parameters and the filter in f64 with
//! nalgebra, and certifies an interior-point method's count by sampling ([`sampling`]); [`plan()`] resolves the
//! algorithm and the gradient form once (no `auto` after it); [`certify`] proves and counts; the [`emit`]
//! module turns it all into a module with `quote!`. The [`oracle`] runs the same algorithms at run time over
//! nalgebra matrices: the generic solver every generated controller is tested against.
//!
//! One place per concept:
//! - [`solver`]: one file per algorithm (`gradient.rs`, `fgm.rs`) behind [`solver::Algorithm`], which owns
//!   the algorithm's parameters, step check, certificate terms, f64 reference iteration, cost and emitted
//!   iteration;
//! - [`form`]: one file per gradient form (`unrolled.rs`, `table.rs`, `lanes.rs`, `matrix_free.rs`) behind
//!   [`form::GradientForm`], each with its cost estimate; the Cortex-A9's NEON kernels in `form/neon.rs`;
//! - [`ipm`] (`solver/ipm.rs`): the dense primal-dual interior-point method for the constrained QPs, in
//!   f64: its reference iteration, the MPC's control step with its fallback, and its cost; it is not a
//!   first-order [`solver::Algorithm`], and `emit/interior.rs` emits it;
//! - [`admm`] (`solver/admm.rs`, `solver/admm/stages.rs`): OSQP's ADMM on the same QPs, its x-update
//!   dense on the condensed QP or stage by stage (Riccati gains), in f32 or f64
//!   (the method for targets without f64 hardware), with ρ measured on a sample; `emit/admm.rs` emits it;
//! - [`target`]: what the compiler knows of the machine (`[codegen] target`): f64 hardware, SIMD, clock,
//!   cycles per multiply-add, and the refusal of a step that does not fit its sampling period;
//! - [`linalg`] the build-time linear algebra, [`numeric`] the emitted scalar's numbers, [`structure`] the
//!   structure read off the matrices, [`cost`] the cost model's weights.
//!
//! ```
//! let spec = mpc_spec::load(include_str!("../../specs/paper.toml")).unwrap();
//! let generated = codegen::generate(&spec, &codegen::Opt::default()).unwrap();
//! assert!(generated.tokens.to_string().contains("pub struct Controller"));
//! ```
#![warn(missing_docs)]

pub mod budget;
pub mod certificate;
pub mod choice;
pub mod constraints;
pub mod coordinates;
pub mod cost;
pub mod discretize;
pub mod emit;
pub mod evidence;
pub mod form;
pub mod input;
pub mod linalg;
pub mod lower;
pub mod numeric;
pub mod oracle;
pub mod parallel;
pub mod plan;
pub mod render;
pub mod sampling;
pub mod solver;
pub mod structure;
pub mod target;

pub use certificate::{certify, Certificate};
pub use emit::Origin;
pub use lower::Problem;
pub use mpc_spec::{Diagnostic, Diagnostics, Spec};
pub use plan::{plan, Plan};
pub use solver::admm;
pub use solver::exact;
pub use solver::ipm;
pub use solver::riccati;

use proc_macro2::{Ident, Span, TokenStream};

/// How to emit a module.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct Opt {
    /// The module's name.
    pub name: String,
    /// Its visibility as written (`pub`, `pub(crate)`, or empty).
    pub visibility: String,
    /// Where the spec came from.
    pub origin: Origin,
    /// The largest ADMM kernel (multiply-adds) written out, one statement per output; past it the kernel
    /// loops over tables. [`emit::WRITE_OUT_BUDGET`] unless a test forces the loops (the same rounding
    /// either way).
    pub write_out_budget: usize,
}

impl Default for Opt {
    fn default() -> Self {
        Opt {
            name: "controller".into(),
            visibility: "pub".into(),
            origin: Origin::Inline,
            write_out_budget: emit::WRITE_OUT_BUDGET,
        }
    }
}

impl Opt {
    /// Options for `vis mod name`, from `origin`.
    pub fn new(name: impl Into<String>, visibility: impl Into<String>, origin: Origin) -> Self {
        Opt {
            name: name.into(),
            visibility: visibility.into(),
            origin,
            write_out_budget: emit::WRITE_OUT_BUDGET,
        }
    }
}

/// A generated module.
#[derive(Clone, Debug)]
pub struct Generated {
    /// `vis mod name { ... }`.
    pub tokens: TokenStream,
    /// What was computed at compile time.
    pub problem: Problem,
    /// The algorithm and gradient form the module is made of.
    pub plan: Plan,
    /// What the compiler proved and counted.
    pub certificate: Certificate,
    /// Findings that do not stop the build (e.g. fewer iterations than the spec's `tolerance` needs).
    pub warnings: Diagnostics,
    /// The estimated cycles of one control step on the spec's `[codegen] target`.
    pub step: target::StepCost,
}

impl Generated {
    /// The module formatted by prettyplease, opening with an `@generated` line.
    #[cfg(feature = "format")]
    pub fn pretty(&self) -> String {
        let file: syn::File =
            syn::parse2(self.tokens.clone()).expect("the emitter produces valid Rust");
        format!(
            "// @generated by mpcc: do not edit.\n{}",
            prettyplease::unparse(&file)
        )
    }
}

/// Lowers `spec` with its method resolved ([`choice::resolve`]: `method = "auto"` becomes the cheapest
/// method whose certificate reaches `accuracy`) and its iteration count certified: the problem every
/// later phase works on.
pub fn lower(spec: &Spec) -> Result<Problem, Diagnostics> {
    choice::resolve(spec).map(|(_, problem)| problem)
}

/// Lowers `spec`, whose method is not `auto`, ([`lower::uncertified`]) and certifies its iteration count on a sample of
/// `[mpc.region]` ([`sampling::certify`]) where there is one to sample: always for the interior-point
/// method and for ADMM (its ρ tuned first on part of the same sample, [`sampling::tune_admm`]), and for a first-order method when `[mpc.region]` is written (its `iterations = "auto"` is
/// then at least the sample's need for `accuracy`, and at least what `tolerance` guarantees): the
/// problem every later phase works on.
pub(crate) fn certified(spec: &Spec) -> Result<Problem, Diagnostics> {
    let mut problem = lower::uncertified(spec)?;
    let evidence = match (spec.mpc.method, solver::algorithm(spec.mpc.method)) {
        (mpc_spec::Method::Admm, _) => {
            // ρ measured on part of the sample (in f64, where the forms agree), then the whole sample
            // at that ρ in the written form; without one, the direct form in f64. In f32 the direct
            // form's rounded factor biases its fixed point, which on an ill-conditioned H costs many
            // iterations or misses `accuracy`: the residual form first, then the direct one run at
            // most as long as it could be cheaper, and the cheaper of the two is kept. Each attempt
            // counts the earlier ones' multiply-adds against the build's budget.
            let (rho, tuning_macs) = sampling::tune_admm(spec, &problem)?;
            let method =
                |form, spent| sampling::Admm::new(&problem, admm::Tuned { rho, form }, spent);
            let certify =
                |method: &sampling::Admm| sampling::certify_metered(spec, &problem, method, 0);
            // What a pass spent on its exact references, which its meter does not count: one
            // exact solve a case, at the budget's price.
            let (cold, warm) = budget::sample_cases(spec, problem.nx);
            let exact = (cold + warm) as f64 * budget::exact_macs(&problem.qp);
            let cost = |method: &sampling::Admm, e: &evidence::Evidence| {
                e.iterations as f64
                    * sampling::Sampled::macs_per_iteration(method, &problem.qp) as f64
            };
            match spec.mpc.admm_form {
                Some(form) => Some(certify(&method(form, tuning_macs)).map_err(|(d, _)| d)?),
                None if problem.scalar == mpc_spec::Scalar::F64 => {
                    Some(certify(&method(admm::Form::Direct, tuning_macs)).map_err(|(d, _)| d)?)
                }
                None => {
                    let residual = method(admm::Form::Residual, tuning_macs);
                    match certify(&residual) {
                        Ok(e) => {
                            let direct = method(admm::Form::Direct, e.sample_macs + exact);
                            let per_iteration =
                                sampling::Sampled::macs_per_iteration(&direct, &problem.qp).max(1);
                            let most = (cost(&residual, &e) / per_iteration as f64) as usize;
                            let direct = direct.at_most(most);
                            match certify(&direct) {
                                Ok(d) if cost(&direct, &d) < cost(&residual, &e) => Some(d),
                                Ok(d) => Some(evidence::Evidence {
                                    sample_macs: d.sample_macs,
                                    ..e
                                }),
                                Err((_, spent)) => Some(evidence::Evidence {
                                    sample_macs: spent,
                                    ..e
                                }),
                            }
                        }
                        Err((_, spent)) => Some(
                            certify(&method(admm::Form::Direct, spent + exact))
                                .map_err(|(d, _)| d)?,
                        ),
                    }
                }
            }
        }
        (_, None) => Some(sampling::certify(
            spec,
            &problem,
            &sampling::InteriorPoint,
            0,
        )?),
        (_, Some(algorithm)) if spec.spans.get("mpc.region").is_some() => {
            // The a priori count of `tolerance` (zero without one) is the floor of `auto`.
            let floor = match spec.mpc.iterations {
                mpc_spec::Iterations::Auto => problem.qp.iterations,
                mpc_spec::Iterations::Fixed(_) => 0,
            };
            Some(sampling::certify(
                spec,
                &problem,
                &sampling::FirstOrder(algorithm),
                floor,
            )?)
        }
        (_, Some(_)) => None,
    };
    if let Some(evidence) = evidence {
        problem.qp.iterations = evidence.iterations;
        problem.qp.evidence = Some(evidence);
    }
    Ok(problem)
}

/// Lowers `spec`, plans its solver, certifies it and emits its module.
pub fn generate(spec: &Spec, opt: &Opt) -> Result<Generated, Diagnostics> {
    let (resolved, problem) = choice::resolve(spec)?;
    let spec = &resolved;
    let plan = Plan {
        write_out_budget: opt.write_out_budget,
        ..plan(spec, &problem)?
    };
    // The build's cost is counted before the certificate's analyses, which take seconds on a large H.
    let (resources, build_cost) = certificate::predicted(&problem, &plan);
    if budget::over(&build_cost).is_some() {
        // A forced emission is compared with the cost model's own choice, which the error then names.
        let own = (spec.codegen.emission != mpc_spec::Emission::Auto)
            .then(|| {
                let mut auto = spec.clone();
                auto.codegen.emission = mpc_spec::Emission::Auto;
                plan::plan(&auto, &problem).ok()
            })
            .flatten()
            .map(|own| (own.emission(), certificate::predicted(&problem, &own).1));
        budget::before_emission(spec, &build_cost, resources.macs_filter, own.as_ref())?;
    }
    // A step that cannot fit the sampling period at the target's clock is refused before the analyses.
    let step = target::StepCost::of(spec, &problem, &resources);
    target::check_period(spec, &step)?;
    let certificate = certify(&problem, &plan);
    let mut warnings = certificate::review(spec, &certificate)?;
    warnings.0.extend(target::review(spec).0);
    if let Some(thin) = problem
        .qp
        .evidence
        .as_ref()
        .and_then(|e| evidence::thin(spec, e))
    {
        warnings.push(thin);
    }
    let vis: TokenStream = opt.visibility.parse().map_err(|_| {
        Diagnostics::from(Diagnostic::new(
            format!("invalid visibility `{}`", opt.visibility),
            None,
        ))
    })?;
    let name = Ident::new(&opt.name, Span::call_site());
    emit::tokens::take_non_finite();
    let tokens = emit::module(&problem, &plan, &certificate, &vis, &name, &opt.origin);
    let non_finite = emit::tokens::take_non_finite();
    if non_finite > 0 {
        return Err(Diagnostic::new(
            format!(
                "the emitted module would hold {non_finite} number(s) beyond the range of {}: a weight, bound or constraint coefficient is too large",
                problem.scalar.name()
            ),
            spec.spans
                .get("mpc.constraint")
                .or(spec.spans.get("mpc"))
                .or(spec.spans.get("model")),
        )
        .label("a product of the spec's numbers overflows")
        .note("hint: rescale the model's units or the constraint rows so that their products stay within range, or write `scalar = \"f64\"` in `[codegen]`")
        .into());
    }
    Ok(Generated {
        tokens,
        problem,
        plan,
        certificate,
        warnings,
        step,
    })
}

/// Parses, checks, lowers and emits the spec text `source`.
pub fn generate_from_source(source: &str, opt: &Opt) -> Result<Generated, Diagnostics> {
    generate(&mpc_spec::load(source)?, opt)
}
