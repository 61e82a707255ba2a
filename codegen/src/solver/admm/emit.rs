//! The fixed-iteration ADMM MPC: `Mpc`, its `SolverStatus` (the interior-point method's type), and OSQP's Algorithm 1 in the module's `Real` over constant tables, step for step the
//! reference of [`crate::solver::admm`] (`Operator::iterate`, `residuals`, `infeasible`,
//! `control_step`), in its order of summation, so that an f64 module matches the oracle to rounding.
//!
//! K = (P + σI + CᵀRC)⁻¹ is applied through its Cholesky factor, packed by rows, and 1/L_ii: two
//! triangular solves, no division. Every loop has a constant trip count and no early exit: a solve
//! costs the same instructions whatever the data (the comparisons select values, as the projection
//! does). The residuals and the infeasibility test run once, after the iterations.
#![allow(non_snake_case)]

use crate::emit::sections::Sections;
use crate::emit::tokens::{at, Num};
use crate::lower::problem::Problem;
use crate::solver::admm::{self, INFEASIBILITY_TOLERANCE};
use crate::solver::constrained::emit::{
    coordinate_check, entry, evidence_doc, mpc_type, offsets, reach, status_types, Entry, MpcParts,
    Offsets,
};
use crate::solver::constrained::InequalityQp;
use crate::solver::ipm::mpc_qp;
use nalgebra::DVector;
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// A bound in `num`, `Real::INFINITY` / `Real::NEG_INFINITY` where it is absent.
fn bound(num: Num, v: f64) -> TokenStream {
    if v == f64::INFINITY {
        quote!(Real::INFINITY)
    } else if v == f64::NEG_INFINITY {
        quote!(Real::NEG_INFINITY)
    } else {
        num.lit(v)
    }
}

/// `e`, a `Real`, in f64 (exact).
fn in_f64(num: Num, e: TokenStream) -> TokenStream {
    match num.0 {
        mpc_spec::Scalar::F32 => quote!(f64::from(#e)),
        mpc_spec::Scalar::F64 => e,
    }
}

/// What the sections of the ADMM module are emitted from.
struct Admm<'a> {
    p: &'a Problem,
    /// The module's `Real`, which ADMM computes in.
    num: Num,
    structure: InequalityQp,
    /// The certificate's settings: the rows' ρ, σ, α, and the stage program of a staged x-update.
    settings: admm::Settings,
    /// The tuning's penalty ρ and form of the x-update.
    rho: f64,
    form: admm::Form,
}

impl Admm<'_> {
    /// ADMM's unknowns x: the plan, then the slacks.
    fn nv(&self) -> usize {
        self.p.qp.Nc * self.p.nu + self.p.qp.rows.slacks()
    }
}

/// The ADMM `Mpc`, its kernels and its tables. `p` must be certified (its evidence carries ρ).
pub fn emit(p: &Problem, num: Num, write_out_budget: usize) -> Sections {
    let (reach_tables, reach_code) = reach(p, num, false);
    let (coordinate_tables, coordinate_code) = coordinate_check(p, false);
    let qp = &p.qp;
    let np = qp.Nc * p.nu;
    let tuning = admm::tuning(qp);
    let m = Admm {
        p,
        num,
        structure: mpc_qp(qp, &DVector::zeros(np), &DVector::zeros(qp.rows.len())),
        settings: admm::certified_settings(qp).unwrap_or_else(|| admm::mpc_settings(qp, 1.0)),
        rho: tuning.map_or(1.0, |t| t.rho),
        form: tuning.map_or(admm::Form::Direct, |t| t.form),
    };
    let operator = operator(&m, write_out_budget);
    let Offsets {
        tables: row_tables,
        terms: row_terms,
    } = row_offsets(&m);
    let data_tables = quote!(#reach_tables #coordinate_tables);
    Sections {
        constants: constants(&m),
        api: api(&m, &row_terms, &reach_code, &coordinate_code),
        kernels: solver_kernels(&m, &operator.kernels),
        tables: tables(&m, &data_tables, &row_tables, &operator.tables),
    }
}

/// The products with C and Cᵀ and the x-update's solve (the factor's, or the stage program's), with
/// the tables their loops read.
fn operator(m: &Admm, write_out_budget: usize) -> Sections {
    let (num, structure, settings, nv) = (m.num, &m.structure, &m.settings, m.nv());
    // The factor of P + σI + CᵀRC, where the x-update is condensed. The settings' factor exists: the
    // certificate ran with it.
    let L = settings.stages.is_none().then(|| {
        admm::factor(structure, settings).unwrap_or_else(|| nalgebra::DMatrix::identity(nv, nv))
    });
    let Sections {
        kernels: mut kernel_code,
        tables: mut kernel_tables,
        ..
    } = kernels(num, &structure.A, L.as_ref(), write_out_budget);
    if let Some(program) = &settings.stages {
        let staged = super::emit_stages::kernel(num, program, write_out_budget);
        kernel_code.extend(staged.kernels);
        kernel_tables.extend(staged.tables);
    }
    Sections {
        kernels: kernel_code,
        tables: kernel_tables,
        ..Sections::default()
    }
}

/// The rows' dependence on the data: the tables `ROW_X`, `ROW_D`, `ROW_U` and their terms in the
/// rows' offsets.
fn row_offsets(m: &Admm) -> Offsets {
    offsets(
        m.p,
        m.num,
        &quote!(Real),
        "ROW",
        &quote!(NG),
        &|M| M.clone(),
        [
            " The rows' dependence on the state: their offset gains ROW_X·x0.",
            " The rows' dependence on the disturbance estimate: their offset gains ROW_D·d.",
            " The rows' dependence on the last input (the first move): their offset gains ROW_U·u₋₁.",
        ],
    )
}

/// The constants section: ADMM's dimensions, its accuracy, ρ and the limits of a trusted plan.
fn constants(m: &Admm) -> TokenStream {
    let plan_steps = crate::emit::plan_steps(m.p);
    let qp = &m.p.qp;
    let (nv, ns, ng) = (m.nv(), qp.rows.slacks(), qp.rows.len());
    let nc = nv + ng;
    let lit = Literal::usize_unsuffixed;
    let [nv_lit, ns_lit, ng_lit, nc_lit] = [nv, ns, ng, nc].map(lit);
    let rho = m.rho;
    let limits = qp.ipm_limits();
    let wide = Num(mpc_spec::Scalar::F64);
    let (primal_limit, dual_limit, gap_limit) = (
        wide.lit(limits.primal),
        wide.lit(limits.dual),
        wide.lit(limits.gap),
    );
    let accuracy = wide.lit(qp.accuracy);
    let rho_lit = wide.lit(rho);
    quote! {
        /// Entries of the plan, N·NU.
        pub const NP: usize = #plan_steps * NU;
        /// ADMM's unknowns x: the plan, then one slack per soft constraint component.
        pub const NV: usize = #nv_lit;
        /// Slacks of the soft constraints.
        pub const NS: usize = #ns_lit;
        /// General constraint rows (their bounds move with the data).
        pub const NG: usize = #ng_lit;
        /// Rows of C = [I; A]: a box row per unknown, then the general rows; the length of z and y.
        pub const NC: usize = #nc_lit;
        /// `[mpc] accuracy`: the plan within ACCURACY·(U_MAX − U_MIN) of the exact solution.
        pub const ACCURACY: f64 = #accuracy;
        /// ADMM's penalty ρ, tuned at build time on the certificate's sample; row i's penalty is
        /// ρ times its curvature ([`RHO_ROW`]).
        pub const RHO: f64 = #rho_lit;
        /// Final relative primal residual above which the plan is not trusted ([`Fallback::WarmStart`]).
        pub const PRIMAL_LIMIT: f64 = #primal_limit;
        /// Final relative dual residual above which the plan is not trusted.
        pub const DUAL_LIMIT: f64 = #dual_limit;
        /// Final duality gap, relative to max(1, |J|), above which the plan is not trusted.
        pub const GAP_LIMIT: f64 = #gap_limit;
    }
}

/// The api section: `SolverStatus`, `Fallback` and the `Mpc` struct with its methods.
fn api(
    m: &Admm,
    row_terms: &[TokenStream],
    reach_code: &TokenStream,
    coordinate_code: &TokenStream,
) -> TokenStream {
    let (qp, num, settings, form, rho) = (&m.p.qp, m.num, &m.settings, m.form, m.rho);
    let status_types = status_types("ADMM", &[" Iterations run: always [`ITERATIONS`]."]);
    let evidence_doc = evidence_doc(qp.evidence.as_ref(), &format!(" at ρ = {rho:.3e}"));
    let real_name = num.numeric().name();
    let form_doc = match form {
        admm::Form::Direct => "",
        admm::Form::Residual => {
            " The x-update is in residual form (x̃ = x + K·r, r its KKT residual), whose fixed point the\n rounding of the factor does not move."
        }
    };
    let structure_doc = match settings.structure() {
        admm::Structure::Condensed => "dense on the condensed QP",
        admm::Structure::Riccati => "its x-update solved stage by stage (a Riccati sweep)",
    };
    let mpc_doc = format!(
        " Fixed-iteration, warm-started MPC with state, output and rate constraints: ADMM (OSQP's\n operator splitting) in {real_name}, {structure_doc}, with its factor computed at build time.{form_doc}"
    );
    let mpc_doc: Vec<&str> = mpc_doc.split('\n').collect();
    let entry = entry(m.p);
    let checked = checked(m, &entry, row_terms, reach_code, coordinate_code);
    mpc_type(MpcParts {
        status_types,
        doc: &mpc_doc,
        evidence_doc: &evidence_doc,
        plan_scalar: quote!(Real),
        point_fields: quote! {
            /// The last solve's iterate (x, z, y): the warm start.
            x: [Real; NV],
            z: [Real; NC],
            y: [Real; NC],
            /// Whether (x, z, y) is a warm start (false after `new`, `reset` or a fallback).
            warm: bool,
        },
        point_init: quote! {
            x: [0.0; NV],
            z: [0.0; NC],
            y: [0.0; NC],
        },
        new_doc: " A cold controller: its first solve starts from x = 0, z = Π(0), y = 0.",
        plan_step: quote!(o.copy_from_slice(step);),
        held: crate::solver::constrained::emit::held(m.p),
        entry,
        checked,
    })
}

/// `Mpc::checked`, the solve: the QP's data from the arguments, the warm or cold start, the
/// iterations, and the choice between their plan and the held one.
fn checked(
    m: &Admm,
    entry: &Entry,
    row_terms: &[TokenStream],
    reach_code: &TokenStream,
    coordinate_code: &TokenStream,
) -> TokenStream {
    let p = m.p;
    let (input, index) = (crate::emit::input_of(p), crate::emit::entry_param(p));
    let row = crate::solver::first_order::form::reference_row(p);
    let nr = Literal::usize_unsuffixed(p.qp.N * p.qp.nz);
    let Entry {
        d_param,
        d_finite,
        f_terms,
        set_last,
        ..
    } = entry;
    let d_flush = (p.nd() > 0).then(|| quote!(let d = flushed(d);));
    let last_local = p.keeps_last_input().then(|| quote!(let last = self.last;));
    quote! {
        /// The solve, with `None` (and a reset warm start) for a non-finite argument.
        fn checked(&mut self, x0: &[Real; NX], #d_param xref: &[[Real; #row]; N]) -> Option<[Real; NU]> {
            if !(all_finite(x0) #d_finite && xref.iter().all(|r| all_finite(r))) {
                self.reset();
                return None;
            }
            let x0 = flushed(x0);
            #d_flush
            #last_local
            let mut reference = [0.0; #nr];
            for (r, row) in reference.chunks_exact_mut(xref[0].len()).zip(xref.iter()) {
                r.copy_from_slice(&flushed(row));
            }
            #coordinate_code
            #reach_code
            // q = Fx·x0 − Fr·Xref (+ Fu·u₋₁ + Fd·d) for the plan, the penalties' weights for the slacks.
            let mut q = [0.0; NV];
            for (i, qi) in q.iter_mut().enumerate().take(NP) {
                *qi = dot(&FX[i], &x0) - dot(&FR[i], &reference) #f_terms;
            }
            for (qi, w) in q.iter_mut().skip(NP).zip(SLACK_WEIGHT.iter()) {
                *qi = *w;
            }
            // The bounds of C's rows: the box's (constant), then the rows' moved by the data.
            let (mut lower, mut upper) = ([0.0; NC], [0.0; NC]);
            lower[..NV].copy_from_slice(&Z_LO);
            upper[..NV].copy_from_slice(&Z_HI);
            for j in 0..NG {
                let offset = #(#row_terms)+*;
                lower[NV + j] = ROW_LOWER[j] - offset;
                upper[NV + j] = ROW_UPPER[j] - offset;
            }
            // The held plan: the fallback, and what a relaxed solve widens the hard rows to.
            let mut held = self.plan;
            shift(&mut held, NU);
            held[NP - NU..].copy_from_slice(&U_REST);
            for (#index, p) in held.iter_mut().enumerate() {
                *p = project(*p, U_MIN[#input], U_MAX[#input]);
            }
            // The bounds without the widening: what the status's violation is measured on.
            let (hard_lower, hard_upper) = (lower, upper);
            // Recovering, the held plan violating a hard row: relaxed.
            let relax = self.relax && violations(&held, &lower, &upper).0 > ACCURACY;
            if relax {
                // After the hard rows admitted no plan: each hard row widened to the held plan's
                // value, so that the QP has a plan that violates no row more than holding would.
                let mut x = [0.0; NV];
                x[..NP].copy_from_slice(&held);
                let mut cx = [0.0; NC];
                c_mul(&x, &mut cx);
                for j in 0..NG {
                    if !ROW_SOFT[j] {
                        let a = cx[NV + j];
                        lower[NV + j] = if a < lower[NV + j] { a } else { lower[NV + j] };
                        upper[NV + j] = if a > upper[NV + j] { a } else { upper[NV + j] };
                    }
                }
            }
            let (mut x, mut z, mut y) = (self.x, self.z, self.y);
            if self.warm & !relax {
                // The previous iterate shifted by one slot, the rest input appended to x and z.
                shift(&mut x[..NP], NU);
                x[NP - NU..NP].copy_from_slice(&U_REST);
                shift(&mut z[..NP], NU);
                z[NP - NU..NP].copy_from_slice(&U_REST);
                shift(&mut z[NV..], PER_SLOT);
                shift(&mut y[..NP], NU);
                shift(&mut y[NV..], PER_SLOT);
            } else {
                x = [0.0; NV];
                for (i, zi) in z.iter_mut().enumerate() {
                    *zi = clamp(0.0, lower[i], upper[i]);
                }
                y = [0.0; NC];
            }
            let mut dy = [0.0; NC];
            for _ in 0..ITERATIONS {
                iterate(&q, &lower, &upper, &mut x, &mut z, &mut y, &mut dy);
            }
            let (primal, dual, gap) = residuals(&q, &x, &z, &y);
            let numerical_failure = !(primal.is_finite() && dual.is_finite() && gap.is_finite());
            let infeasible = ITERATIONS > 0 && !numerical_failure && infeasible(&lower, &upper, &dy);
            let trusted = !numerical_failure && !infeasible && primal <= PRIMAL_LIMIT && dual <= DUAL_LIMIT && gap <= GAP_LIMIT;
            if trusted {
                for (#index, (p, v)) in self.plan.iter_mut().zip(x.iter()).enumerate() {
                    *p = project(*v, U_MIN[#input], U_MAX[#input]);
                }
                self.x = x;
                self.z = z;
                self.y = y;
            } else {
                self.plan = held;
            }
            self.warm = trusted & !relax;
            let (violation, softened) = violations(&self.plan, &hard_lower, &hard_upper);
            // Recovering after a solve found the hard rows infeasible, or made a relaxed plan.
            self.relax = infeasible | (trusted & relax);
            self.status = SolverStatus {
                iterations: ITERATIONS as u32,
                primal_residual: primal,
                dual_residual: dual,
                gap,
                violation,
                softened,
                infeasible,
                numerical_failure,
                reference_beyond_region: beyond,
                beyond_coordinate_range: beyond_coordinates,
                fallback: match (trusted, relax) {
                    (true, false) => Fallback::Solved,
                    (true, true) => Fallback::Relaxed,
                    (false, _) => Fallback::WarmStart,
                },
            };
            let mut first = [0.0; NU];
            first.copy_from_slice(&self.plan[..NU]);
            #set_last
            Some(first)
        }
    }
}

/// The kernels section: the helpers, the operator's products and solve, an iteration, and the
/// residuals and tests that judge its result.
fn solver_kernels(m: &Admm, operator: &TokenStream) -> TokenStream {
    let helpers = helpers(m.num, crate::emit::input_of(m.p));
    let iterate = iterate(m);
    let measures = measures(m.num);
    quote! {
        #helpers

        #operator

        #iterate

        #measures
    }
}

/// The helpers the kernels share: the rest plan, the dot product, the projection, the shift and the
/// largest magnitude.
fn helpers(num: Num, input: TokenStream) -> TokenStream {
    let wide_of_abs = in_f64(num, quote!(x.abs()));
    quote! {
        /// The rest plan: U_REST at every step.
        const fn rest_plan() -> [Real; NP] {
            let mut out = [0.0; NP];
            let mut i = 0;
            while i < NP {
                out[i] = U_REST[#input];
                i += 1;
            }
            out
        }

        /// a·b, summed from the first term.
        #[inline(always)]
        fn dot(a: &[Real], b: &[Real]) -> Real {
            a.iter().zip(b.iter()).fold(0.0, |s, (x, y)| s + x * y)
        }

        /// `v` clamped to [lo, hi], NaN kept (the residuals then see it), as the reference's.
        #[inline(always)]
        fn clamp(v: Real, lo: Real, hi: Real) -> Real {
            if v < lo {
                lo
            } else if v > hi {
                hi
            } else {
                v
            }
        }

        /// Moves every block of `width` up by one; the last block stays.
        #[inline(always)]
        fn shift(v: &mut [Real], width: usize) {
            if width > 0 && v.len() > width {
                v.copy_within(width.., 0);
            }
        }

        /// max |v_i| in f64 (exact).
        #[inline(always)]
        fn amax(v: &[Real]) -> f64 {
            v.iter().fold(0.0, |m: f64, x| m.max(#wide_of_abs))
        }
    }
}

/// `iterate`: one iteration of OSQP's Algorithm 1, its x-update in the tuned form.
fn iterate(m: &Admm) -> TokenStream {
    let (form, settings) = (m.form, &m.settings);
    let x_tilde = match (form, &settings.stages) {
        (_, Some(_)) => quote! {
            let mut xt = [0.0; NV];
            let mut zt = [0.0; NC];
            stage_solve(x, z, y, q, &mut xt, &mut zt);
        },
        (admm::Form::Direct, None) => quote! {
            // x̃ = K (σx − q + Cᵀ(Rz − y)).
            let mut w = [0.0; NC];
            for i in 0..NC {
                w[i] = RHO_ROW[i] * z[i] - y[i];
            }
            let mut xt = [0.0; NV];
            c_tmul(&w, &mut xt);
            // (σx − q) + Cᵀw, the reference's sum (addition commutes exactly).
            for i in 0..NV {
                xt[i] += SIGMA * x[i] - q[i];
            }
            k_solve(&mut xt);
            let mut zt = [0.0; NC];
            c_mul(&xt, &mut zt);
        },
        (admm::Form::Residual, _) => quote! {
            // x̃ = x + K (Cᵀ(R(z − Cx) − y) − (Px + q)): the bracket is the x-update's KKT residual, so
            // the fixed point does not depend on the rounding of the factor (the residual form).
            let mut cx = [0.0; NC];
            c_mul(x, &mut cx);
            let mut w = [0.0; NC];
            for i in 0..NC {
                w[i] = RHO_ROW[i] * (z[i] - cx[i]) - y[i];
            }
            let mut xt = [0.0; NV];
            c_tmul(&w, &mut xt);
            for (i, row) in H.iter().enumerate() {
                xt[i] -= dot(row, x) + q[i];
            }
            k_solve(&mut xt);
            for (t, xi) in xt.iter_mut().zip(x.iter()) {
                *t += *xi;
            }
            let mut zt = [0.0; NC];
            c_mul(&xt, &mut zt);
        },
    };
    quote! {
        /// One iteration of OSQP's Algorithm 1 on (x, z, y); `dy` keeps the change of y.
        fn iterate(
            q: &[Real; NV],
            lower: &[Real; NC],
            upper: &[Real; NC],
            x: &mut [Real; NV],
            z: &mut [Real; NC],
            y: &mut [Real; NC],
            dy: &mut [Real; NC],
        ) {
            #x_tilde
            for (xi, t) in x.iter_mut().zip(xt.iter()) {
                *xi = ALPHA * t + BETA * *xi;
            }
            for i in 0..NC {
                let relaxed = ALPHA * zt[i] + BETA * z[i];
                let zn = clamp(relaxed + RHO_INV[i] * y[i], lower[i], upper[i]);
                let yn = y[i] + RHO_ROW[i] * (relaxed - zn);
                dy[i] = yn - y[i];
                y[i] = yn;
                z[i] = zn;
            }
        }
    }
}

/// What judges the iterate, in f64: the residuals, the infeasibility test and the rows' violations.
fn measures(num: Num) -> TokenStream {
    let widen = |e: TokenStream| in_f64(num, e);
    let (wide_px, wide_x, wide_q) = (widen(quote!(*pxi)), widen(quote!(*xi)), widen(quote!(*qi)));
    let (wide_y, wide_z) = (widen(quote!(*yi)), widen(quote!(*zi)));
    let (wide_lower, wide_upper, wide_d) = (
        widen(quote!(lower[i])),
        widen(quote!(upper[i])),
        widen(quote!(v)),
    );
    let (wide_row_lower, wide_row_upper, wide_a) = (
        widen(quote!(lower[NV + j])),
        widen(quote!(upper[NV + j])),
        widen(quote!(a)),
    );
    let (wide_bound_lower, wide_bound_upper) =
        (widen(quote!(ROW_LOWER[j])), widen(quote!(ROW_UPPER[j])));
    quote! {
        /// The relative residuals ‖Cx − z‖∞ / (1 + max(‖Cx‖∞, ‖z‖∞)) and
        /// ‖Px + q + Cᵀy‖∞ / (1 + max(‖Px‖∞, ‖q‖∞, ‖Cᵀy‖∞)); infinite where an entry is not finite.
        /// The relative primal and dual residuals and the relative duality gap
        /// |xᵀPx + qᵀx + yᵀz| / max(1, |½xᵀPx + qᵀx|) (y is in the bounds' normal cone at z, so yᵀz is
        /// their support function at y), as the reference computes them.
        fn residuals(q: &[Real; NV], x: &[Real; NV], z: &[Real; NC], y: &[Real; NC]) -> (f64, f64, f64) {
            let mut cx = [0.0; NC];
            c_mul(x, &mut cx);
            let mut primal = [0.0; NC];
            for i in 0..NC {
                primal[i] = cx[i] - z[i];
            }
            let mut px = [0.0; NV];
            for (o, row) in px.iter_mut().zip(H.iter()) {
                *o = dot(row, x);
            }
            let mut cty = [0.0; NV];
            c_tmul(y, &mut cty);
            let mut dual = [0.0; NV];
            for i in 0..NV {
                dual[i] = px[i] + q[i] + cty[i];
            }
            if !(all_finite(&primal) && all_finite(&dual)) {
                return (f64::INFINITY, f64::INFINITY, f64::INFINITY);
            }
            let (mut curvature, mut linear, mut support) = (0.0_f64, 0.0_f64, 0.0_f64);
            for ((pxi, qi), xi) in px.iter().zip(q.iter()).zip(x.iter()) {
                curvature += #wide_px * #wide_x;
                linear += #wide_q * #wide_x;
            }
            for (yi, zi) in y.iter().zip(z.iter()) {
                support += #wide_y * #wide_z;
            }
            let objective = 0.5 * curvature + linear;
            (
                amax(&primal) / (1.0 + amax(&cx).max(amax(z))),
                amax(&dual) / (1.0 + amax(&px).max(amax(q)).max(amax(&cty))),
                (curvature + linear + support).abs() / objective.abs().max(1.0),
            )
        }

        /// OSQP's primal infeasibility test (§3.4) on the last change of y: δy projected on the polar
        /// of the bounds' recession cone, δy ≠ 0, ‖Cᵀδy‖∞ ≤ ε‖δy‖∞ and uᵀδy₊ + lᵀδy₋ ≤ −ε‖δy‖∞ (the
        /// support in f64, as the reference sums it).
        fn infeasible(lower: &[Real; NC], upper: &[Real; NC], dy: &[Real; NC]) -> bool {
            let mut d = [0.0; NC];
            for i in 0..NC {
                let v = dy[i];
                d[i] = match (LOWER_FINITE[i], UPPER_FINITE[i]) {
                    (false, false) => 0.0,
                    (true, false) => clamp(v, Real::NEG_INFINITY, 0.0),
                    (false, true) => clamp(v, 0.0, Real::INFINITY),
                    (true, true) => v,
                };
            }
            let norm = amax(&d);
            let mut support = 0.0_f64;
            for i in 0..NC {
                let v = d[i];
                let (lo, hi, w) = (#wide_lower, #wide_upper, #wide_d);
                support += if v > 0.0 {
                    hi * w
                } else if v < 0.0 {
                    lo * w
                } else {
                    0.0
                };
            }
            let mut ct = [0.0; NV];
            c_tmul(&d, &mut ct);
            let ctn = amax(&ct);
            let nonzero = !(norm.is_nan() || norm <= INFEASIBILITY_TOLERANCE);
            nonzero
                && support <= -INFEASIBILITY_TOLERANCE * norm
                && ctn <= INFEASIBILITY_TOLERANCE * norm
        }

        /// The largest hard-row violation of the plan (slacks zero) relative to max(1, |bound|), and the
        /// largest soft-row violation in its row's units, as the interior-point method reports them.
        fn violations(plan: &[Real; NP], lower: &[Real; NC], upper: &[Real; NC]) -> (f64, f64) {
            let (mut hard, mut soft) = (0.0_f64, 0.0_f64);
            // The rows at the plan with its slacks zero (Cx's general rows).
            let mut x = [0.0; NV];
            x[..NP].copy_from_slice(plan);
            let mut cx = [0.0; NC];
            c_mul(&x, &mut cx);
            for j in 0..NG {
                let a = cx[NV + j];
                let (lo, hi, a) = (#wide_row_lower, #wide_row_upper, #wide_a);
                // The rows' bounds without the data's offset, as the reference measures them.
                let (bound_lo, bound_hi) = (#wide_bound_lower, #wide_bound_upper);
                let below = (lo - a).max(0.0) / bound_lo.abs().max(1.0);
                let above = (a - hi).max(0.0) / bound_hi.abs().max(1.0);
                if ROW_SOFT[j] {
                    soft = soft.max((lo - a).max(a - hi).max(0.0));
                } else {
                    hard = hard.max(below.max(above));
                }
            }
            (hard, soft)
        }
    }
}

/// The tables section: the method's tuning, the bounds, the rows' data, ρ, the operator's tables and
/// the Hessian.
fn tables(
    m: &Admm,
    data_tables: &TokenStream,
    row_tables: &TokenStream,
    operator_tables: &TokenStream,
) -> TokenStream {
    let (num, structure, settings, form) = (m.num, &m.structure, &m.settings, m.form);
    let rows = &m.p.qp.rows;
    let lit = Literal::usize_unsuffixed;
    let rho_row = num.vector(settings.rho.iter().copied());
    let rho_inv = num.vector(settings.rho.iter().map(|r| 1.0 / r));
    let (sigma, alpha) = (num.lit(settings.sigma), num.lit(settings.alpha));
    let z_lo = structure.z_min.iter().map(|v| bound(num, *v));
    let z_hi = structure.z_max.iter().map(|v| bound(num, *v));
    let row_lower = rows.lower.iter().map(|v| bound(num, *v));
    let row_upper = rows.upper.iter().map(|v| bound(num, *v));
    let lower_finite = structure
        .z_min
        .iter()
        .chain(rows.lower.iter())
        .map(|v| v.is_finite());
    let upper_finite = structure
        .z_max
        .iter()
        .chain(rows.upper.iter())
        .map(|v| v.is_finite());
    let row_soft = rows.soft.iter();
    let hv = num.matrix(&structure.H);
    let slack_weight = num.vector(rows.slack_weight.iter().copied());
    let per_slot = lit(rows.per_slot);
    let infeasibility = Num(mpc_spec::Scalar::F64).lit(INFEASIBILITY_TOLERANCE);
    // σ enters the direct form's right-hand side; the residual form has it only inside the factor.
    let sigma_table = (form == admm::Form::Direct && settings.stages.is_none()).then(|| {
        quote! {
            /// The proximal weight σ.
            const SIGMA: Real = #sigma;
        }
    });
    quote! {
        #data_tables
        /// OSQP's over-relaxation α, and 1 − α.
        const ALPHA: Real = #alpha;
        const BETA: Real = 1.0 - ALPHA;
        #sigma_table
        /// OSQP's primal infeasibility tolerance ε.
        const INFEASIBILITY_TOLERANCE: f64 = #infeasibility;
        /// Row sides per slot: a warm start shifts the rows' z and y by this.
        const PER_SLOT: usize = #per_slot;
        /// The slacks' penalty weights (the linear term of the slacks).
        const SLACK_WEIGHT: [Real; NS] = #slack_weight;
        /// The box rows' bounds: the input box for the plan, σ ≥ 0 for the slacks.
        const Z_LO: [Real; NV] = [#(#z_lo),*];
        const Z_HI: [Real; NV] = [#(#z_hi),*];
        /// The general rows' bounds before the data's offset (±∞ where absent).
        const ROW_LOWER: [Real; NG] = [#(#row_lower),*];
        const ROW_UPPER: [Real; NG] = [#(#row_upper),*];
        /// Whether a general row is soft (its violation is priced, not forbidden).
        const ROW_SOFT: [bool; NG] = [#(#row_soft),*];
        /// Which rows of C have a finite lower / upper bound (whatever the data).
        const LOWER_FINITE: [bool; NC] = [#(#lower_finite),*];
        const UPPER_FINITE: [bool; NC] = [#(#upper_finite),*];
        #row_tables
        /// Row i's penalty ρ_i = RHO·(its curvature), and 1/ρ_i.
        const RHO_ROW: [Real; NC] = #rho_row;
        const RHO_INV: [Real; NC] = #rho_inv;
        #operator_tables
        /// ADMM's P = blkdiag(H, diag(q_σ)): eq. 9's H, then the slacks' quadratic weights.
        pub const H: [[Real; NV]; NV] = #hv;
    }
}

pub use crate::plan::WRITE_OUT_BUDGET;

/// The kernels over the general rows `A` (rows × NV) and the factor `L` of P + σI + CᵀRC, each in the
/// reference's order of summation (`solver::admm::Operator::{C, Ct, solve}`): written out within
/// [`WRITE_OUT_BUDGET`], which costs a few instructions a multiply-add where the loops over compressed
/// rows cost some ten (benchmarks/NOTES.md, "ADMM on the emulated Cortex-M4F"), else loops over tables.
/// The tables are those the loops need (none when written out).
fn kernels(
    num: Num,
    A: &nalgebra::DMatrix<f64>,
    L: Option<&nalgebra::DMatrix<f64>>,
    write_out_budget: usize,
) -> Sections {
    let (ng, nv) = A.shape();
    let lit = Literal::usize_unsuffixed;
    let rows: Vec<Vec<(usize, f64)>> = (0..ng)
        .map(|r| {
            (0..nv)
                .filter(|&c| A[(r, c)] != 0.0)
                .map(|c| (c, A[(r, c)]))
                .collect()
        })
        .collect();
    let nnz: usize = rows.iter().map(Vec::len).sum();
    let mut code = Vec::new();
    let mut tables = Vec::new();
    if nnz <= write_out_budget {
        // Row j of C·x below the identity: 0 + Σ a·x in column order (the reference's fold from zero).
        let products = rows.iter().enumerate().map(|(j, row)| {
            let (o, sum) = (
                at("out", nv + j),
                num.fold(quote!(0.0), row.iter().map(|&(c, a)| (a, at("x", c)))),
            );
            quote!(#o = #sum;)
        });
        // Column c of Cᵀ·v: v_c plus its rows' shares, rows ascending (the reference's order).
        let columns = (0..nv).filter_map(|c| {
            let terms: Vec<_> = rows
                .iter()
                .enumerate()
                .filter_map(|(j, row)| {
                    row.iter()
                        .find(|&&(k, _)| k == c)
                        .map(|&(_, a)| (a, at("v", nv + j)))
                })
                .collect();
            (!terms.is_empty()).then(|| {
                let (o, sum) = (at("out", c), num.fold(at("v", c), terms));
                quote!(#o = #sum;)
            })
        });
        code.push(quote! {
            /// C x = [x; A x], written out.
            fn c_mul(x: &[Real; NV], out: &mut [Real; NC]) {
                out[..NV].copy_from_slice(x);
                #(#products)*
            }

            /// Cᵀ v = v[..NV] + Aᵀ v[NV..], written out.
            fn c_tmul(v: &[Real; NC], out: &mut [Real; NV]) {
                out.copy_from_slice(&v[..NV]);
                #(#columns)*
            }
        });
    } else {
        let mut start = vec![0usize];
        let (mut cols, mut vals) = (Vec::new(), Vec::new());
        for row in &rows {
            for &(c, a) in row {
                cols.push(c);
                vals.push(a);
            }
            start.push(cols.len());
        }
        let nnz_lit = lit(nnz);
        let start_lit = start.iter().map(|s| lit(*s));
        let col_lit = cols.iter().map(|c| lit(*c));
        let val = num.vector(vals.iter().copied());
        code.push(quote! {
            /// Row j of A in compressed rows: its columns and values. The tables are consistent by
            /// construction; `get` keeps the indexing free of panicking paths, which the compiler cannot
            /// rule out for indices read from a table.
            #[inline(always)]
            fn a_row(j: usize) -> (&'static [usize], &'static [Real]) {
                let span = A_START[j]..A_START[j + 1];
                (
                    A_COL.get(span.clone()).unwrap_or(&[]),
                    A_VAL.get(span).unwrap_or(&[]),
                )
            }

            /// C x = [x; A x].
            fn c_mul(x: &[Real; NV], out: &mut [Real; NC]) {
                out[..NV].copy_from_slice(x);
                for j in 0..NG {
                    let (cols, vals) = a_row(j);
                    let mut a = 0.0;
                    for (&c, &v) in cols.iter().zip(vals) {
                        a += v * x.get(c).copied().unwrap_or(0.0);
                    }
                    out[NV + j] = a;
                }
            }

            /// Cᵀ v = v[..NV] + Aᵀ v[NV..].
            fn c_tmul(v: &[Real; NC], out: &mut [Real; NV]) {
                out.copy_from_slice(&v[..NV]);
                for j in 0..NG {
                    let (cols, vals) = a_row(j);
                    for (&c, &a) in cols.iter().zip(vals) {
                        if let Some(o) = out.get_mut(c) {
                            *o += a * v[NV + j];
                        }
                    }
                }
            }
        });
        tables.push(quote! {
            /// The general rows A in compressed rows: row j is Σ A_VAL[k]·x[A_COL[k]] over
            /// k ∈ A_START[j]..A_START[j + 1].
            const A_START: [usize; NG + 1] = [#(#start_lit),*];
            const A_COL: [usize; #nnz_lit] = [#(#col_lit),*];
            const A_VAL: [Real; #nnz_lit] = #val;
        });
    }
    let Some(L) = L else {
        return Sections {
            kernels: quote!(#(#code)*),
            tables: quote!(#(#tables)*),
            ..Sections::default()
        };
    };
    if nv * nv <= write_out_budget {
        // b_i ← (b_i − Σ_k L_ik·b_k)·(1/L_ii), then b_i ← (b_i − Σ_j L_ji·b_j)·(1/L_ii), as the reference.
        let step = |i: usize, terms: Vec<(f64, TokenStream)>| {
            let (bi, inv) = (at("b", i), num.lit(1.0 / L[(i, i)]));
            if terms.is_empty() {
                return quote!(#bi *= #inv;);
            }
            let sum = num.fold(bi.clone(), terms);
            quote!(#bi = (#sum) * #inv;)
        };
        let forward = (0..nv).map(|i| step(i, (0..i).map(|k| (-L[(i, k)], at("b", k))).collect()));
        let backward = (0..nv)
            .rev()
            .map(|i| step(i, (i + 1..nv).map(|j| (-L[(j, i)], at("b", j))).collect()));
        code.push(quote! {
            /// b ← K b = L⁻ᵀ L⁻¹ b: the forward substitution, then the backward one, written out with L's
            /// entries and 1/L_ii as literals.
            fn k_solve(b: &mut [Real; NV]) {
                #(#forward)*
                #(#backward)*
            }
        });
    } else {
        let nl = lit(nv * (nv + 1) / 2);
        let packed = num.vector(
            (0..nv)
                .flat_map(|i| (0..=i).map(move |k| (i, k)))
                .map(|(i, k)| L[(i, k)]),
        );
        let l_inv = num.vector((0..nv).map(|i| 1.0 / L[(i, i)]));
        code.push(quote! {
            /// b ← K b = L⁻ᵀ L⁻¹ b: the forward substitution, then the backward one.
            fn k_solve(b: &mut [Real; NV]) {
                for i in 0..NV {
                    let row = &L[i * (i + 1) / 2..i * (i + 1) / 2 + i];
                    let mut s = b[i];
                    for (l, w) in row.iter().zip(b.iter()) {
                        s -= l * w;
                    }
                    b[i] = s * L_INV[i];
                }
                for i in (0..NV).rev() {
                    let mut s = b[i];
                    for (j, bj) in b.iter().enumerate().skip(i + 1) {
                        // Column i of L below the diagonal: the index is inside the packed factor for
                        // i < j < NV, which the compiler does not see.
                        s -= L.get(j * (j + 1) / 2 + i).copied().unwrap_or(0.0) * bj;
                    }
                    b[i] = s * L_INV[i];
                }
            }
        });
        tables.push(quote! {
            /// The lower Cholesky factor L of P + σI + CᵀRC, packed by rows (row i: L_i0 … L_ii).
            const L: [Real; #nl] = #packed;
            /// 1 / L_ii.
            const L_INV: [Real; NV] = #l_inv;
        });
    }
    Sections {
        kernels: quote!(#(#code)*),
        tables: quote!(#(#tables)*),
        ..Sections::default()
    }
}
