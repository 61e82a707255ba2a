//! The fixed-iteration interior-point MPC: `Mpc`, its `SolverStatus`, and a Mehrotra
//! predictor-corrector in f64 over constant tables, step for step the reference of
//! [`crate::solver::ipm`] (which the oracle runs). The method computes in f64 whatever `Real` is: the
//! data are widened where they enter and the command rounded where it leaves.
//!
//! The normal matrix H + Gᵀ·diag(λ/s)·G is factored as L·D·Lᵀ (no square root: `core` has none), where
//! the reference takes a dense Cholesky factor; the two differ in rounding only. The emitted method
//! works in the order of [`Sparsity`]: the matrix's independent blocks are contiguous, and the
//! factorisation, the solves, H·z and the rows visit only what can be nonzero (the cost model counts
//! exactly that). Its control flow does not depend on the data.
#![allow(non_snake_case)]

use super::emit_rows::{self as rows, Rows};
use crate::emit::sections::Sections;
use crate::emit::tokens::Num;
use crate::lower::problem::Problem;
use crate::lower::structure::Envelope;
use crate::solver::constrained::emit::{
    coordinate_check, entry, evidence_doc, mpc_type, offsets, reach, status_types, Entry, MpcParts,
    Offsets,
};
use crate::solver::ipm::{
    mpc_qp, side_bound, InequalityQp, Layout, Sparsity, FINISHED, FRACTION,
    INFEASIBILITY_TOLERANCE, REFINEMENT, WARM_FLOOR,
};
use mpc_spec::Scalar;
use nalgebra::{DMatrix, DVector};
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// What the sections of the interior-point module are emitted from: the QP's constant structure, in
/// the method's order.
struct Method<'a> {
    p: &'a Problem,
    /// The module's `Real`.
    num: Num,
    /// f64, which the method computes in whatever `Real` is.
    wide: Num,
    structure: &'a InequalityQp,
    layout: &'a Layout,
    sparsity: &'a Sparsity,
    /// The method's Hessian, in the method's order.
    h_method: &'a DMatrix<f64>,
    /// G·z, Gᵀ·v, H·z and (within its budget) the forming, written out over the constant structure.
    written: Rows<'a>,
}

impl Method<'_> {
    /// The method's unknowns: the plan, then the slacks.
    fn nv(&self) -> usize {
        self.h_method.nrows()
    }
}

/// The interior-point `Mpc`, its kernels and its tables.
pub fn emit(p: &Problem, num: Num) -> Sections {
    let (reach_tables, reach_code) = reach(p, num, true);
    let (coordinate_tables, coordinate_code) = coordinate_check(p, true);
    let qp = &p.qp;
    let np = qp.Nc * p.nu;
    let structure = mpc_qp(qp, &DVector::zeros(np), &DVector::zeros(qp.rows.len()));
    let layout = Layout::of(&structure);
    let nv = np + qp.rows.slacks();
    // The method works in the envelope's order (positions): the normal matrix's independent blocks
    // are contiguous, so the factorisation and H·z visit only them.
    let sparsity = Sparsity::of(&structure);
    let order = &sparsity.envelope.order;
    let h_method = DMatrix::from_fn(nv, nv, |p, q| structure.H[(order[p], order[q])]);
    let method = Method {
        p,
        num,
        wide: Num(Scalar::F64),
        structure: &structure,
        layout: &layout,
        sparsity: &sparsity,
        h_method: &h_method,
        written: Rows::new(&structure, &layout, &sparsity),
    };
    let Offsets {
        tables: side_tables,
        terms: side_terms,
    } = side_offsets(&method);
    let sections = Sections {
        constants: constants(&method),
        api: api(&method, &side_terms, &reach_code, &coordinate_code),
        kernels: kernels(&method),
        tables: tables(&method, &reach_tables, &coordinate_tables, &side_tables),
    };
    // The normal system in the form the cost model chooses: the condensed one's kernels and tables, or
    // the Riccati form's.
    crate::solver::riccati::emit::form(p, sections, condensed(&method))
}

/// The sides' dependence on the data: the tables `SIDE_X`, `SIDE_D`, `SIDE_U` and their terms in h.
fn side_offsets(m: &Method) -> Offsets {
    let ng = m.layout.rows.len();
    let side = |M: &DMatrix<f64>| {
        DMatrix::from_fn(ng, M.ncols(), |j, c| {
            let (r, sign) = m.layout.rows[j];
            sign * M[(r, c)]
        })
    };
    offsets(
        m.p,
        m.wide,
        &quote!(f64),
        "SIDE",
        &quote!(NG),
        &side,
        [
            " The sides' dependence on the state: h −= SIDE_X·x0.",
            " The sides' dependence on the disturbance estimate: h −= SIDE_D·d.",
            " The sides' dependence on the last input (the first move): h −= SIDE_U·u₋₁.",
        ],
    )
}

/// The constants section: the method's dimensions, its accuracy and the limits of a trusted plan.
fn constants(m: &Method) -> TokenStream {
    let plan_steps = crate::emit::plan_steps(m.p);
    let qp = &m.p.qp;
    let wide = m.wide;
    let lit = Literal::usize_unsuffixed;
    let (ns, nb, ng, nr) = (
        qp.rows.slacks(),
        m.layout.boxed.len(),
        m.layout.rows.len(),
        m.sparsity.rows.len(),
    );
    let [nv_lit, ns_lit, nb_lit, ng_lit, nr_lit] = [m.nv(), ns, nb, ng, nr].map(lit);
    let limits = qp.ipm_limits();
    let (primal_limit, dual_limit, gap_limit) = (
        wide.lit(limits.primal),
        wide.lit(limits.dual),
        wide.lit(limits.gap),
    );
    let accuracy = wide.lit(qp.accuracy);
    quote! {
        /// Entries of the plan, N·NU.
        pub const NP: usize = #plan_steps * NU;
        /// The interior-point method's unknowns: the plan, then one slack per soft constraint component.
        pub const NV: usize = #nv_lit;
        /// Slacks of the soft constraints.
        pub const NS: usize = #ns_lit;
        /// Sides of the input box and of the slacks' floor σ ≥ 0 (constant).
        pub const NB: usize = #nb_lit;
        /// Finite sides of the constraint rows (their bounds move with the data).
        pub const NG: usize = #ng_lit;
        /// All sides: the length of the slacks s and multipliers λ.
        pub const NSIDES: usize = NB + NG;
        /// Constraint rows with a finite side (a two-sided row has two sides, ±the same product).
        pub const NR: usize = #nr_lit;
        /// `[mpc] accuracy`: the plan within ACCURACY·(U_MAX − U_MIN) of the exact solution.
        pub const ACCURACY: f64 = #accuracy;
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
    m: &Method,
    side_terms: &[TokenStream],
    reach_code: &TokenStream,
    coordinate_code: &TokenStream,
) -> TokenStream {
    let status_types = status_types(
        "interior-point method",
        &[
            " Iterations that moved the point (fewer than [`ITERATIONS`] when it was optimal to rounding,",
            " or the method stopped on infeasibility or a numerical failure). Every solve does the work of",
            " a cold start and [`ITERATIONS`] iterations whatever this says: the control flow does not",
            " depend on the data.",
        ],
    );
    let evidence_doc = evidence_doc(m.p.qp.evidence.as_ref(), "");
    let entry = entry(m.p);
    let checked = checked(m, &entry, side_terms, reach_code, coordinate_code);
    mpc_type(MpcParts {
        status_types,
        doc: &[
            " Fixed-iteration, warm-started MPC with state, output and rate constraints: a primal-dual",
            " interior-point method (Mehrotra's predictor-corrector) in f64, its normal matrix factored",
            " within its envelope. Every solve runs the same instructions, but for the regularised",
            " refactorisations after a pivot that is not positive.",
        ],
        evidence_doc: &evidence_doc,
        plan_scalar: quote!(f64),
        point_fields: quote! {
            /// The last solve's point (plan and slacks, sides' slacks, multipliers): the warm start.
            z: [f64; NV],
            s: [f64; NSIDES],
            lambda: [f64; NSIDES],
            /// Whether the point is a warm start (false after `new`, `reset` or a fallback).
            warm: bool,
        },
        point_init: quote! {
            z: [0.0; NV],
            s: [1.0; NSIDES],
            lambda: [1.0; NSIDES],
        },
        new_doc: " A cold controller: its first solve starts from the method's cold start.",
        held: crate::solver::constrained::emit::held(m.p),
        plan_step: quote! {
            for (a, v) in o.iter_mut().zip(step.iter()) {
                *a = *v as Real;
            }
        },
        entry,
        checked,
    })
}

/// `Mpc::checked`, the solve: the QP's data from the arguments, the warm start, the method, and the
/// choice between its plan and the held one.
fn checked(
    m: &Method,
    entry: &Entry,
    side_terms: &[TokenStream],
    reach_code: &TokenStream,
    coordinate_code: &TokenStream,
) -> TokenStream {
    let p = m.p;
    let row = crate::solver::first_order::form::reference_row(p);
    let n_reference = Literal::usize_unsuffixed(p.qp.N * p.qp.nz);
    let Entry {
        d_param,
        d_finite,
        f_terms,
        set_last,
        ..
    } = entry;
    let (d_flush, d_wide) = if p.nd() > 0 {
        (quote!(let d = &flushed(d);), quote!(let d = widen(d);))
    } else {
        (quote!(), quote!())
    };
    let last_wide = p
        .keeps_last_input()
        .then(|| quote!(let last = widen(&self.last);));
    // Real to f64: exact for f32, nothing to do for f64.
    let wide_of_v = match m.num.0 {
        Scalar::F32 => quote!(f64::from(*v)),
        Scalar::F64 => quote!(*v),
    };
    quote! {
        /// The solve, with `None` (and a reset warm start) for a non-finite argument.
        fn checked(&mut self, x0: &[Real; NX], #d_param xref: &[[Real; #row]; N]) -> Option<[Real; NU]> {
            if !(all_finite(x0) #d_finite && xref.iter().all(|r| all_finite(r))) {
                self.reset();
                return None;
            }
            let x0 = widen(&flushed(x0));
            #d_flush
            #d_wide
            #last_wide
            let mut reference = [0.0; #n_reference];
            for (r, row) in reference.chunks_exact_mut(xref[0].len()).zip(xref.iter()) {
                for (w, v) in r.iter_mut().zip(flushed(row).iter()) {
                    *w = #wide_of_v;
                }
            }
            #coordinate_code
            #reach_code
            // f = Fx·x0 − Fr·Xref (+ Fu·u₋₁ + Fd·d) for the plan, the penalties' weights for the slacks.
            let mut f = [0.0; NV];
            for (i, fi) in f.iter_mut().enumerate().take(NP) {
                *fi = dot(&FX[i], &x0) - dot(&FR[i], &reference) #f_terms;
            }
            for (fi, w) in f.iter_mut().skip(NP).zip(SLACK_WEIGHT.iter()) {
                *fi = *w;
            }
            // h: the box's sides, then the rows' sides moved by the data.
            let mut h = [0.0; NSIDES];
            h[..NB].copy_from_slice(&BOX_H);
            for (j, hj) in h[NB..].iter_mut().enumerate() {
                *hj = SIDE_H[j] #(- #side_terms)*;
            }
            // The held plan: the fallback, and what a relaxed solve widens the hard rows to.
            let mut held = self.plan;
            shift(&mut held, NU);
            held[NP - NU..].copy_from_slice(&REST);
            for (i, p) in held.iter_mut().enumerate() {
                *p = clamp(*p, i);
            }
            // After the hard rows admitted no plan: each hard side widened to the held plan's
            // value, so that the QP has a plan that violates no row more than holding would.
            // Computed every solve and selected, so that every solve runs the same instructions.
            // Recovering, the held plan violating a hard row: relaxed.
            let relax = self.relax & (violations(&held, &h).0 > ACCURACY);
            let held_sides = side_values(&held);
            let mut hs = h;
            for j in 0..NG {
                let widened = larger(h[NB + j], held_sides[NB + j]);
                hs[NB + j] = choose(relax & !SIDE_SOFT[j], widened, h[NB + j]);
            }
            // The warm start, shifted by one step; shifted also when cold (then unused), so that
            // every solve runs the same instructions.
            let (mut z, mut s, mut lambda) = (self.z, self.s, self.lambda);
            shift(&mut z[..NP], NU);
            z[NP - NU..NP].copy_from_slice(&REST);
            shift(&mut s[..2 * NP], 2 * NU);
            shift(&mut s[NB..], SIDES_PER_SLOT);
            shift(&mut lambda[..2 * NP], 2 * NU);
            shift(&mut lambda[NB..], SIDES_PER_SLOT);
            // Into the method's order and back.
            let (f, mut zp) = (permuted(&f), permuted(&z));
            let outcome = interior_point(&f, &hs, &mut zp, &mut s, &mut lambda, self.warm);
            for (p, v) in zp.iter().enumerate() {
                put(&mut z, at_index(&ORDER, p), *v);
            }
            let trusted = (outcome.ended == Ended::Iterations)
                & (outcome.primal <= PRIMAL_LIMIT)
                & (outcome.dual <= DUAL_LIMIT)
                & (outcome.gap <= GAP_LIMIT);
            // Both plans are made and one is selected: the same instructions either way.
            let mut solved = [0.0; NP];
            for (i, (p, v)) in solved.iter_mut().zip(z.iter()).enumerate() {
                *p = clamp(*v, i);
            }
            let pick = trusted as usize;
            self.plan = *[&held, &solved][pick];
            // Copies of what is kept, so that no copy overlaps its source (a `memmove`, whose
            // path depends on the addresses).
            let kept = (self.z, self.s, self.lambda);
            self.z = *[&kept.0, &z][pick];
            self.s = *[&kept.1, &s][pick];
            self.lambda = *[&kept.2, &lambda][pick];
            self.warm = trusted & !relax;
            let (violation, softened) = violations(&self.plan, &h);
            let infeasible = outcome.ended == Ended::Infeasible;
            // Recovering after a solve found the hard rows infeasible, or made a relaxed plan.
            self.relax = infeasible | (trusted & relax);
            self.status = SolverStatus {
                iterations: outcome.iterations,
                primal_residual: outcome.primal,
                dual_residual: outcome.dual,
                gap: outcome.gap,
                violation,
                softened,
                infeasible,
                numerical_failure: outcome.ended == Ended::Failure,
                reference_beyond_region: beyond,
                beyond_coordinate_range: beyond_coordinates,
                fallback: match (trusted, relax) {
                    (true, false) => Fallback::Solved,
                    (true, true) => Fallback::Relaxed,
                    (false, _) => Fallback::WarmStart,
                },
            };
            let mut first = [0.0; NU];
            for (o, v) in first.iter_mut().zip(self.plan.iter()) {
                *o = *v as Real;
            }
            #set_last
            Some(first)
        }
    }
}

/// The kernels section: the scalar helpers, the products with G, Gᵀ and H, and the iteration.
fn kernels(m: &Method) -> TokenStream {
    let written = &m.written;
    let (g_mul, g_tmul, h_mul) = (written.g_mul(), written.g_tmul(), written.h_mul(m.h_method));
    let helpers = helpers(
        m.num,
        crate::emit::input_of(m.p),
        crate::emit::entry_param(m.p),
    );
    let newton_step = newton_step();
    let interior_point = interior_point();
    quote! {
        #helpers

        #g_mul

        #g_tmul

        #h_mul

        #newton_step

        #interior_point
    }
}

/// The helpers the kernels share: the rest plan, f64 of `Real`, the index checks, the projection,
/// the violations, the iteration's types and the branch-free selects.
fn helpers(num: Num, input: TokenStream, entry: TokenStream) -> TokenStream {
    // Real to f64: exact for f32, nothing to do for f64.
    let wide_of_x = match num.0 {
        Scalar::F32 => quote!(f64::from(*x)),
        Scalar::F64 => quote!(*x),
    };
    quote! {
        /// The rest plan: U_REST at every step.
        const fn rest_plan() -> [f64; NP] {
            let mut out = [0.0; NP];
            let mut i = 0;
            while i < NP {
                out[i] = REST[#input];
                i += 1;
            }
            out
        }

        /// `v` in f64.
        #[inline(always)]
        fn widen<const M: usize>(v: &[Real; M]) -> [f64; M] {
            let mut out = [0.0; M];
            for (o, x) in out.iter_mut().zip(v.iter()) {
                *o = #wide_of_x;
            }
            out
        }

        /// a·b.
        #[inline(always)]
        fn dot(a: &[f64], b: &[f64]) -> f64 {
            a.iter().zip(b.iter()).map(|(x, y)| x * y).sum()
        }

        /// Plan entry `i` projected onto its input's bounds; NaN maps to the lower bound.
        #[inline(always)]
        fn clamp(v: f64, #entry: usize) -> f64 {
            let (lo, hi) = (LO[#input], HI[#input]);
            smaller(hi, larger(lo, v))
        }

        /// Moves every block of `width` up by one; the last block stays.
        #[inline(always)]
        fn shift(v: &mut [f64], width: usize) {
            if width > 0 && v.len() > width {
                v.copy_within(width.., 0);
            }
        }

        /// G·(plan, 0): every side's value at the plan, the slacks (past the plan's end) zero.
        fn side_values(plan: &[f64; NP]) -> [f64; NSIDES] {
            // The plan in the method's order.
            let mut zp = [0.0; NV];
            for (p, v) in zp.iter_mut().enumerate() {
                *v = at(plan, at_index(&ORDER, p));
            }
            let mut gz = [0.0; NSIDES];
            g_mul(&zp, &mut gz);
            gz
        }

        /// The largest hard-row violation of the plan (slacks zero) relative to max(1, |bound|), and the
        /// largest soft-row violation in its row's units.
        fn violations(plan: &[f64; NP], h: &[f64; NSIDES]) -> (f64, f64) {
            let gz = side_values(plan);
            let (mut hard, mut soft) = (0.0_f64, 0.0_f64);
            for j in 0..NG {
                let excess = gz[NB + j] - h[NB + j];
                // SIDE_SOFT is constant: the same branch every solve.
                if SIDE_SOFT[j] {
                    soft = larger(soft, excess);
                } else {
                    hard = larger(hard, excess / larger(SIDE_H[j].abs(), 1.0));
                }
            }
            (hard, soft)
        }

        /// `v` in the method's order: entry p is v[ORDER[p]].
        #[inline(always)]
        fn permuted(v: &[f64; NV]) -> [f64; NV] {
            let mut out = [0.0; NV];
            for (p, o) in out.iter_mut().enumerate() {
                *o = at(v, at_index(&ORDER, p));
            }
            out
        }

        /// `v[i]`, or 0 past its end. The index tables are in range by construction; the check is a
        /// select here, where indexing would link a panic.
        #[inline(always)]
        fn at(v: &[f64], i: usize) -> f64 {
            match v.get(i) {
                Some(x) => *x,
                None => 0.0,
            }
        }

        /// `v[i]` of an index table, or 0 past its end (as [`at`]).
        #[inline(always)]
        fn at_index(v: &[usize], i: usize) -> usize {
            match v.get(i) {
                Some(x) => *x,
                None => 0,
            }
        }

        /// `v[i] = x`, nothing past its end (as [`at`]).
        #[inline(always)]
        fn put(v: &mut [f64], i: usize, x: f64) {
            if let Some(o) = v.get_mut(i) {
                *o = x;
            }
        }

        /// How the iteration ended.
        #[derive(Clone, Copy, PartialEq, Eq)]
        enum Ended {
            /// Its iterations ran (or the point was optimal to rounding before).
            Iterations,
            /// The multipliers certify infeasibility, or diverged.
            Infeasible,
            /// A factorisation was refused or a step was not finite; the point is the last finite one.
            Failure,
        }

        /// What the iteration reports.
        struct Outcome {
            ended: Ended,
            iterations: u32,
            primal: f64,
            dual: f64,
            gap: f64,
        }

        /// The residuals of a point.
        struct Residuals {
            /// H z + f + Gᵀλ.
            dual: [f64; NV],
            /// G z + s − h.
            primal: [f64; NSIDES],
            /// Gᵀλ (the infeasibility certificate reads it too).
            gl: [f64; NV],
            relative_primal: f64,
            relative_dual: f64,
            gap: f64,
            objective_scale: f64,
            /// sᵀλ / max(1, |½zᵀHz + fᵀz|): what the acceptance test holds to GAP_LIMIT.
            relative_gap: f64,
        }

        /// max |v_i| (NaN entries are passed over, as by `f64::max`). On the bits: |x|'s bits order as the
        /// values, and a NaN's are above +∞'s, so it is masked to 0; integer selects, which are
        /// predicated instructions on the A9, not branches, and cheaper than `larger`'s masks.
        #[inline(always)]
        fn amax(v: &[f64]) -> f64 {
            let infinity = f64::INFINITY.to_bits();
            f64::from_bits(v.iter().fold(0u64, |m, x| {
                let a = x.to_bits() & !(1u64 << 63);
                m.max(a & 0u64.wrapping_sub((a <= infinity) as u64))
            }))
        }

        /// `a` if `c`, else `b`, by masks on the bits. The mask is hidden from the optimiser
        /// (`black_box`): it would otherwise turn a select into a branch on the data where it judges
        /// that cheaper (it did, in the step to the boundary), and every solve would not run the same
        /// instructions.
        #[inline(always)]
        fn choose(c: bool, a: f64, b: f64) -> f64 {
            let mask = core::hint::black_box(0u64.wrapping_sub(c as u64));
            f64::from_bits((a.to_bits() & mask) | (b.to_bits() & !mask))
        }

        /// The larger of `a` and `b`, `a` when `b` is NaN: a select (`choose`), not a branch or a
        /// libcall (`f64::max` is a call to `fmax` on a VFP without `vmaxnm`).
        #[inline(always)]
        fn larger(a: f64, b: f64) -> f64 {
            choose(b > a, b, a)
        }

        /// The smaller of `a` and `b`, `a` when `b` is NaN.
        #[inline(always)]
        fn smaller(a: f64, b: f64) -> f64 {
            choose(b < a, b, a)
        }
    }
}

/// One Newton step's parts: the residuals, the scaling, the direction and the step to the boundary.
fn newton_step() -> TokenStream {
    quote! {
        fn residuals(f: &[f64; NV], h: &[f64; NSIDES], z: &[f64; NV], s: &[f64; NSIDES], lambda: &[f64; NSIDES]) -> Residuals {
            let mut hz = [0.0; NV];
            h_mul(z, &mut hz);
            let mut gz = [0.0; NSIDES];
            g_mul(z, &mut gz);
            let mut gl = [0.0; NV];
            g_tmul(lambda, &mut gl);
            let mut dual = [0.0; NV];
            for i in 0..NV {
                dual[i] = hz[i] + f[i] + gl[i];
            }
            let mut primal = [0.0; NSIDES];
            for k in 0..NSIDES {
                primal[k] = gz[k] + s[k] - h[k];
            }
            Residuals {
                relative_primal: amax(&primal) / (1.0 + larger(amax(h), amax(&gz))),
                relative_dual: amax(&dual) / (1.0 + larger(larger(amax(f), amax(&hz)), amax(&gl))),
                gap: dot(s, lambda) / NSIDES as f64,
                objective_scale: 1.0 + (0.5 * dot(z, &hz)).abs() + dot(f, z).abs(),
                relative_gap: dot(s, lambda) / larger(1.0, (0.5 * dot(z, &hz) + dot(f, z)).abs()),
                dual,
                primal,
                gl,
            }
        }

        /// What an iteration divides by, computed once: 1/s, 1/λ and the normal matrix's weights
        /// λ/s = λ·(1/s). The directions and the steps to the boundary multiply by them, so an
        /// iteration divides twice per side instead of some seventeen times (a division costs the
        /// A9's VFP tens of cycles, a multiplication one or two).
        struct Scaling {
            inv_s: [f64; NSIDES],
            inv_lambda: [f64; NSIDES],
            w: [f64; NSIDES],
        }

        impl Scaling {
            /// s = λ = 1 (the cold start's point): every entry 1, exactly.
            const ONES: Scaling = Scaling {
                inv_s: [1.0; NSIDES],
                inv_lambda: [1.0; NSIDES],
                w: [1.0; NSIDES],
            };

            /// Recomputed in place for (s, λ): one buffer for the whole solve.
            fn update(&mut self, s: &[f64; NSIDES], lambda: &[f64; NSIDES]) {
                for k in 0..NSIDES {
                    self.inv_s[k] = 1.0 / s[k];
                    self.inv_lambda[k] = 1.0 / lambda[k];
                    self.w[k] = lambda[k] * self.inv_s[k];
                }
            }
        }

        /// The Newton direction for the complementarity right-hand side rc (Λ·Δs + S·Δλ = −rc): from
        /// (H + Gᵀ·D·G)·Δz = −r_d − Gᵀ(D·r_p − rc/s), D = λ/s.
        #[allow(clippy::too_many_arguments)]
        fn direction(
            m: &NormalFactor,
            r: &Residuals,
            s: &[f64; NSIDES],
            lambda: &[f64; NSIDES],
            scale: &Scaling,
            rc: &[f64; NSIDES],
            dz: &mut [f64; NV],
            ds: &mut [f64; NSIDES],
            dl: &mut [f64; NSIDES],
            refinement: usize,
        ) {
            let Scaling { inv_s, inv_lambda, w } = scale;
            let mut t = [0.0; NSIDES];
            for k in 0..NSIDES {
                t[k] = (lambda[k] * r.primal[k] - rc[k]) * inv_s[k];
            }
            g_tmul(&t, dz);
            for (v, rd) in dz.iter_mut().zip(r.dual.iter()) {
                *v = -rd - *v;
            }
            ldl_solve(m, dz);
            let mut gdz = [0.0; NSIDES];
            g_mul(dz, &mut gdz);
            for k in 0..NSIDES {
                dl[k] = (lambda[k] * (gdz[k] + r.primal[k]) - rc[k]) * inv_s[k];
                ds[k] = -(rc[k] + s[k] * dl[k]) * inv_lambda[k];
            }
            // Iterative refinement on H·Δz + Gᵀ·Δλ = −r_d, whose digits the normal matrix loses when
            // λ/s spans many orders of magnitude.
            for _ in 0..refinement {
                let (mut e, mut hdz) = ([0.0; NV], [0.0; NV]);
                g_tmul(dl, &mut e);
                h_mul(dz, &mut hdz);
                for i in 0..NV {
                    e[i] = -r.dual[i] - (hdz[i] + e[i]);
                }
                ldl_solve(m, &mut e);
                g_mul(&e, &mut gdz);
                for i in 0..NV {
                    dz[i] += e[i];
                }
                for k in 0..NSIDES {
                    let cl = w[k] * gdz[k];
                    dl[k] += cl;
                    ds[k] += -(s[k] * cl) * inv_lambda[k];
                }
            }
        }

        /// The largest α keeping s + αΔs ≥ 0 and λ + αΔλ ≥ 0 (infinite when nothing decreases):
        /// 1 / max(−Δs/s, −Δλ/λ, 0), with one division.
        fn step_to_boundary(scale: &Scaling, ds: &[f64; NSIDES], dl: &[f64; NSIDES]) -> f64 {
            // Every rate is computed and the largest kept, on the bits (no branch on the data, no float
            // select): s, λ > 0, so −Δs/s is positive exactly where Δs < 0; elsewhere it is negative or
            // −0 (a NaN Δs gives a NaN of either sign), and a negative double's bits as an i64 are
            // negative, below +0's zero, so the integer maximum passes them over, as the reference's
            // `if Δs < 0`. A positive NaN wins and makes α NaN: the step is then not finite and not
            // taken.
            let mut greatest = 0_i64;
            for k in 0..NSIDES {
                greatest = greatest.max((-ds[k] * scale.inv_s[k]).to_bits() as i64);
                greatest = greatest.max((-dl[k] * scale.inv_lambda[k]).to_bits() as i64);
            }
            1.0 / f64::from_bits(greatest as u64)
        }

        /// Whether every entry is finite (every entry is looked at: no early exit).
        #[inline(always)]
        fn finite64(v: &[f64]) -> bool {
            v.iter().fold(true, |ok, x| ok & x.is_finite())
        }

        /// Whether every entry is positive (every entry is looked at).
        #[inline(always)]
        fn positive64(v: &[f64]) -> bool {
            v.iter().fold(true, |ok, x| ok & (*x > 0.0))
        }
    }
}

/// `interior_point`: the cold and warm starts and the fixed iterations of Mehrotra's method.
fn interior_point() -> TokenStream {
    quote! {
        /// The fixed-iteration Mehrotra predictor-corrector from (z, s, λ) (a warm start, its slacks and
        /// multipliers raised to at least WARM_FLOOR) or from the cold start (one affine step from z = 0,
        /// s = λ = 1, then s, λ ← max(1, |·|)). Leaves the last finite point in (z, s, λ).
        ///
        /// The control flow does not depend on the data: the cold start is computed on every solve
        /// (and used when `warm` is false), every one of the ITERATIONS iterations is computed, and a
        /// point that is held (optimal to rounding, a refused factorisation, a non-finite or
        /// non-positive step, infeasibility) keeps being held by selection, not by a `break`. Only a
        /// pivot that is not positive costs more (the regularised retries in `factor`).
        fn interior_point(
            f: &[f64; NV],
            h: &[f64; NSIDES],
            z: &mut [f64; NV],
            s: &mut [f64; NSIDES],
            lambda: &mut [f64; NSIDES],
            warm: bool,
        ) -> Outcome {
            let mut m = NORMAL_ZERO;
            let (mut dz, mut ds, mut dl) = ([0.0; NV], [0.0; NSIDES], [0.0; NSIDES]);
            // The cold start.
            let (mut zc, mut sc, mut lc) = ([0.0; NV], [1.0; NSIDES], [1.0; NSIDES]);
            let r = residuals(f, h, &zc, &sc, &lc);
            let mut scale = Scaling::ONES;
            let cold_factored = factor(&scale.w, &mut m);
            let mut rc = [0.0; NSIDES];
            for k in 0..NSIDES {
                rc[k] = sc[k] * lc[k];
            }
            direction(&m, &r, &sc, &lc, &scale, &rc, &mut dz, &mut ds, &mut dl, 0);
            for i in 0..NV {
                zc[i] += dz[i];
            }
            for k in 0..NSIDES {
                sc[k] = larger(1.0, (sc[k] + ds[k]).abs());
                lc[k] = larger(1.0, (lc[k] + dl[k]).abs());
            }
            // The warm start.
            for v in s.iter_mut().chain(lambda.iter_mut()) {
                *v = larger(WARM_FLOOR, *v);
            }
            // Selected by index (one of two references, then one copy of the same size), not by a branch;
            // from copies, so that no copy overlaps its source (a `memmove`, whose path depends on the
            // addresses).
            let pick = warm as usize;
            let kept = (*z, *s, *lambda);
            *z = *[&zc, &kept.0][pick];
            *s = *[&sc, &kept.1][pick];
            *lambda = *[&lc, &kept.2][pick];
            let started = (warm | cold_factored) & finite64(z) & finite64(s) & finite64(lambda);
            let mut r = residuals(f, h, z, s, lambda);
            // `live`: the point still moves. `&` and `|` on flags, not `&&`: no branches.
            let (mut live, mut failed, mut infeasible) = (started, !started, false);
            let mut iterations = 0;
            for _ in 0..ITERATIONS {
                // A point optimal to rounding is held: further steps only underflow s∘λ.
                live &= !((r.relative_primal <= FINISHED)
                    & (r.relative_dual <= FINISHED)
                    & (r.gap <= FINISHED * r.objective_scale));
                let mu = dot(s, lambda) / NSIDES as f64;
                scale.update(s, lambda);
                let factored = factor(&scale.w, &mut m);
                failed |= live & !factored;
                live &= factored;
                // Predictor: the affine-scaling direction.
                for k in 0..NSIDES {
                    rc[k] = s[k] * lambda[k];
                }
                direction(&m, &r, s, lambda, &scale, &rc, &mut dz, &mut ds, &mut dl, 0);
                let alpha = smaller(1.0, step_to_boundary(&scale, &ds, &dl));
                let mut mu_affine = 0.0;
                for k in 0..NSIDES {
                    mu_affine += (s[k] + alpha * ds[k]) * (lambda[k] + alpha * dl[k]);
                }
                mu_affine /= NSIDES as f64;
                let ratio = smaller(larger(mu_affine / mu, 0.0), 1.0);
                let sigma = choose(mu > 0.0, ratio * ratio * ratio, 0.0);
                // Corrector: centering and the second-order term of the complementarity.
                for k in 0..NSIDES {
                    rc[k] = s[k] * lambda[k] + ds[k] * dl[k] - sigma * mu;
                }
                direction(&m, &r, s, lambda, &scale, &rc, &mut dz, &mut ds, &mut dl, REFINEMENT);
                let alpha = smaller(1.0, FRACTION * step_to_boundary(&scale, &ds, &dl));
                let (mut zn, mut sn, mut ln) = ([0.0; NV], [0.0; NSIDES], [0.0; NSIDES]);
                for i in 0..NV {
                    zn[i] = z[i] + alpha * dz[i];
                }
                for k in 0..NSIDES {
                    sn[k] = s[k] + alpha * ds[k];
                    ln[k] = lambda[k] + alpha * dl[k];
                }
                let stepped = finite64(&zn) & finite64(&sn) & finite64(&ln) & positive64(&sn) & positive64(&ln);
                failed |= live & !stepped;
                live &= stepped;
                let pick = live as usize;
                let kept = (*z, *s, *lambda);
                *z = *[&kept.0, &zn][pick];
                *s = *[&kept.1, &sn][pick];
                *lambda = *[&kept.2, &ln][pick];
                r = residuals(f, h, z, s, lambda);
                iterations += live as u32;
                // Infeasible: λ ≥ 0 with Gᵀλ ≈ 0 and hᵀλ < 0 (Farkas), or diverged multipliers.
                let htl = dot(h, lambda);
                let certified = ((htl < 0.0) & (amax(&r.gl) <= INFEASIBILITY_TOLERANCE * -htl)) | (amax(lambda) > 1e15);
                infeasible |= live & certified;
                live &= !certified;
            }
            let ended = if infeasible {
                Ended::Infeasible
            } else if failed {
                Ended::Failure
            } else {
                Ended::Iterations
            };
            let (primal, dual, gap) = if started {
                (r.relative_primal, r.relative_dual, r.relative_gap)
            } else {
                (f64::INFINITY, f64::INFINITY, f64::INFINITY)
            };
            Outcome {
                ended,
                iterations,
                primal,
                dual,
                gap,
            }
        }
    }
}

/// The tables section: the method's tuning, the bounds, the sides' data, the order and the Hessian.
fn tables(
    m: &Method,
    reach_tables: &TokenStream,
    coordinate_tables: &TokenStream,
    side_tables: &TokenStream,
) -> TokenStream {
    let (qp, structure, layout, wide) = (&m.p.qp, m.structure, m.layout, m.wide);
    let rows = &qp.rows;
    let lit = Literal::usize_unsuffixed;
    let per_slot_lit = lit(layout.rows.len() / qp.N.max(1));
    let (fraction, floor, finished, infeasibility) = (
        wide.lit(FRACTION),
        wide.lit(WARM_FLOOR),
        wide.lit(FINISHED),
        wide.lit(INFEASIBILITY_TOLERANCE),
    );
    let refinement = lit(REFINEMENT);
    let rest = wide.vector(qp.rest_input().iter().copied());
    let lo = wide.vector(qp.u_min.iter().copied());
    let hi = wide.vector(qp.u_max.iter().copied());
    let slack_weight = wide.vector(rows.slack_weight.iter().copied());
    // Box sides: ±z_i ≤ ±bound, constant.
    let box_h = wide.vector(
        layout
            .boxed
            .iter()
            .map(|&(i, s)| side_bound(s, structure.z_min[i], structure.z_max[i])),
    );
    let side_h = wide.vector(
        layout
            .rows
            .iter()
            .map(|&(r, sign)| side_bound(sign, rows.lower[r], rows.upper[r])),
    );
    let side_soft = layout.rows.iter().map(|&(r, _)| rows.soft[r]);
    let order_lit = m.sparsity.envelope.order.iter().map(|i| lit(*i));
    let hv = wide.matrix(m.h_method);
    quote! {
        #reach_tables
        #coordinate_tables
        /// Tuning of the method, as in the reference (`codegen::ipm`): the fraction of the step to the
        /// boundary, the warm start's floor on s and λ, the rounding level at which a point is held,
        /// and the infeasibility certificate's tolerance.
        const FRACTION: f64 = #fraction;
        const WARM_FLOOR: f64 = #floor;
        const FINISHED: f64 = #finished;
        const INFEASIBILITY_TOLERANCE: f64 = #infeasibility;
        const REFINEMENT: usize = #refinement;
        /// Row sides per slot: a warm start shifts them by this.
        const SIDES_PER_SLOT: usize = #per_slot_lit;
        /// U_MIN, U_MAX and U_REST in f64.
        const LO: [f64; NU] = #lo;
        const HI: [f64; NU] = #hi;
        const REST: [f64; NU] = #rest;
        /// The slacks' penalty weights w (the linear term of the slacks).
        const SLACK_WEIGHT: [f64; NS] = #slack_weight;
        /// Box sides' right-hand sides: ±z_i ≤ BOX_H (upper then lower bound per plan entry, then
        /// σ ≥ 0; the signs and positions are written into the kernels).
        const BOX_H: [f64; NB] = #box_h;
        /// Side j is ±(its row) ≤ h_j, with h_j = SIDE_H[j] − SIDE_X[j]·x0 (− …).
        const SIDE_H: [f64; NG] = #side_h;
        /// Whether a side belongs to a soft row (its violation is priced, not forbidden).
        const SIDE_SOFT: [bool; NG] = [#(#side_soft),*];
        #side_tables
        /// The method's order: position p holds unknown ORDER[p] (plan entries, then slacks). It puts
        /// the normal matrix's independent blocks (the drone's axes) side by side.
        const ORDER: [usize; NV] = [#(#order_lit),*];
        /// The method's Hessian blkdiag(H, diag(q_σ)) (eq. 9's H, then the slacks' quadratic weights),
        /// in the method's order.
        pub const H: [[f64; NV]; NV] = #hv;
    }
}

/// The condensed form of the normal system: `NormalFactor`, `factor` and `ldl_solve` over the normal
/// matrix within its envelope, with the tables they alone read.
fn condensed(m: &Method) -> Sections {
    let envelope = &m.sparsity.envelope;
    let (factor, form_tables) = factor(m);
    let ldl_kernels = ldl_kernels(envelope);
    // The envelope's tables, for the loops that read them (the loop forming reads FIRST, the loop
    // L·D·Lᵀ both); written-out kernels have them as constants.
    let lit = Literal::usize_unsuffixed;
    let ldl_loops = !rows::ldl_written_out(envelope);
    let first_table = (ldl_loops || !m.written.form_written_out()).then(|| {
        let first_lit = envelope.first.iter().map(|f| lit(*f));
        quote! {
            /// The envelope of the normal matrix's lower triangle: row p from column FIRST[p].
            const FIRST: [usize; NV] = [#(#first_lit),*];
        }
    });
    let reach_table = ldl_loops.then(|| {
        let reach_lit = (0..m.nv()).map(|j| lit(envelope.reach(j)));
        quote! {
            /// REACH[j]: one past the last row of the envelope that reaches column j.
            const REACH: [usize; NV] = [#(#reach_lit),*];
        }
    });
    let envelope_tables = quote!(#first_table #reach_table);
    Sections {
        kernels: quote! {
        /// The normal matrix H + Gᵀ·diag(w)·G, factored in place as L·D·Lᵀ within the envelope.
        type NormalFactor = [[f64; NV]; NV];
        const NORMAL_ZERO: NormalFactor = [[0.0; NV]; NV];

        #factor

        #ldl_kernels
        },
        tables: quote!(#form_tables #envelope_tables),
        ..Sections::default()
    }
}

/// `factor`, which forms the normal matrix and factors it, and the tables its loops read: written
/// out, or (past its budget) a loop over the rows' runs.
fn factor(m: &Method) -> (TokenStream, TokenStream) {
    let factor_doc = quote! {
        /// Forms H + Gᵀ·diag(w)·G (lower triangle, within the envelope) and factors it as L·D·Lᵀ in
        /// place, adding a growing multiple of I when a pivot is not positive (a semidefinite H with few
        /// active sides), as the reference does; `false` when every attempt is refused.
    };
    let retry = quote! {
        let scale = 1.0 + (0..NV).fold(0.0, |s, i| larger(s, m[i][i].abs()));
        for (i, row) in m.iter_mut().enumerate() {
            row[i] += delta;
        }
        if ldl(m) {
            return true;
        }
        delta = if delta == 0.0 { 1e-12 * scale } else { delta * 1e3 };
    };
    if m.written.form_written_out() {
        let form = m.written.form(m.h_method);
        (
            quote! {
                #factor_doc
                fn factor(w: &[f64; NSIDES], m: &mut [[f64; NV]; NV]) -> bool {
                    let mut delta = 0.0;
                    for _ in 0..4 {
                        form(w, m);
                        #retry
                    }
                    false
                }

                #form
            },
            quote!(),
        )
    } else {
        (
            quote! {
                #factor_doc
                fn factor(w: &[f64; NSIDES], m: &mut [[f64; NV]; NV]) -> bool {
                    // A two-sided row's sides add their weights to one outer product.
                    let mut wr = [0.0; NR];
                    for j in 0..NG {
                        add(&mut wr, SIDE_ROW[j], w[NB + j]);
                    }
                    let mut delta = 0.0;
                    for _ in 0..4 {
                    for (p, (row, h)) in m.iter_mut().zip(H.iter()).enumerate() {
                        for (e, v) in row.iter_mut().zip(h.iter()).take(p + 1).skip(FIRST[p]) {
                            *e = *v;
                        }
                    }
                    for k in 0..NB {
                        let i = BOX_POS[k];
                        if let Some(row) = m.get_mut(i) {
                            add(row, i, w[k]);
                        }
                    }
                    // Row r's outer product, lower triangle: entry a of run ka times the earlier runs
                    // and its own run up to a.
                    for (r, wj) in wr.iter().enumerate() {
                        let row_runs = runs(r);
                        for (ka, &(at_a, offset_a, len_a)) in row_runs.iter().enumerate() {
                            let run_a = values(offset_a, len_a);
                            for (ia, va) in run_a.iter().enumerate() {
                                if let Some(target) = m.get_mut(at_a + ia) {
                                    let wa = wj * va;
                                    for &(at_b, offset_b, len_b) in row_runs.iter().take(ka) {
                                        let run_b = values(offset_b, len_b);
                                        for (e, vb) in span_mut(target, at_b, len_b).iter_mut().zip(run_b.iter()) {
                                            *e += wa * vb;
                                        }
                                    }
                                    for (e, vb) in span_mut(target, at_a, ia + 1).iter_mut().zip(run_a.iter()) {
                                        *e += wa * vb;
                                    }
                                }
                            }
                        }
                    }
                        #retry
                    }
                    false
                }

            /// `v[i] += x`, nothing past its end (as [`at`]).
            #[inline(always)]
            fn add(v: &mut [f64], i: usize, x: f64) {
                if let Some(o) = v.get_mut(i) {
                    *o += x;
                }
            }
            /// The runs of row r: (first position, offset into ROW_VAL, length).
            #[inline(always)]
            fn runs(r: usize) -> &'static [(usize, usize, usize)] {
                let all: &'static [(usize, usize, usize)] = &RUNS;
                all.get(at_index(&RUN_START, r)..at_index(&RUN_START, r + 1))
                    .unwrap_or(&[])
            }

            /// A run's values: ROW_VAL[offset..offset + len].
            #[inline(always)]
            fn values(offset: usize, len: usize) -> &'static [f64] {
                let all: &'static [f64] = &ROW_VAL;
                all.get(offset..offset + len).unwrap_or(&[])
            }

            /// `v[at..at + len]`, empty past its end (as [`at`]).
            #[inline(always)]
            fn span_mut(v: &mut [f64], at: usize, len: usize) -> &mut [f64] {
                v.get_mut(at..at + len).unwrap_or(&mut [])
            }
            },
            run_tables(m),
        )
    }
}

/// The tables of the forming's loop: the box sides' positions and the rows as runs of positions.
fn run_tables(m: &Method) -> TokenStream {
    let (structure, sparsity, wide) = (m.structure, m.sparsity, m.wide);
    let (order, position) = (&sparsity.envelope.order, &sparsity.envelope.position);
    let lit = Literal::usize_unsuffixed;
    let box_pos = m.layout.boxed.iter().map(|(i, _)| lit(position[*i]));
    // The distinct rows as runs of consecutive positions (a state row of one axis is its inputs so far
    // and its slack: two runs), so the inner loops are over slices, with one range check per run. A
    // run is (first position, offset into ROW_VAL, length).
    let (mut run_start, mut runs, mut row_val) = (vec![0usize], Vec::new(), Vec::new());
    for (&r, positions) in sparsity.rows.iter().zip(&sparsity.row_positions) {
        for (k, &q) in positions.iter().enumerate() {
            if k == 0 || positions[k - 1] + 1 != q {
                runs.push((q, row_val.len(), 0));
            }
            if let Some(run) = runs.last_mut() {
                run.2 += 1;
            }
            row_val.push(structure.A[(r, order[q])]);
        }
        run_start.push(runs.len());
    }
    let (row_nnz, n_runs) = (lit(row_val.len()), lit(runs.len()));
    let run_start_lit = run_start.iter().map(|s| lit(*s));
    let runs_lit = runs.iter().map(|&(at, offset, len)| {
        let (at, offset, len) = (lit(at), lit(offset), lit(len));
        quote!((#at, #offset, #len))
    });
    let row_val = wide.vector(row_val.iter().copied());
    let side_row = sparsity.side_row.iter().map(|r| lit(*r));
    quote! {
        /// The rows with a finite side as runs of consecutive positions (z in the method's order): row
        /// r is the runs RUNS[RUN_START[r]..RUN_START[r + 1]], a run (at, offset, len) the values
        /// ROW_VAL[offset..offset + len] at positions at..at + len.
        /// Box side k is at position BOX_POS[k]; side j belongs to row SIDE_ROW[j].
        const BOX_POS: [usize; NB] = [#(#box_pos),*];
        const SIDE_ROW: [usize; NG] = [#(#side_row),*];
        const RUN_START: [usize; NR + 1] = [#(#run_start_lit),*];
        const RUNS: [(usize, usize, usize); #n_runs] = [#(#runs_lit),*];
        const ROW_VAL: [f64; #row_nnz] = #row_val;
    }
}

/// `ldl` and `ldl_solve` over the envelope: written out within their budget, or loops over it.
fn ldl_kernels(envelope: &Envelope) -> TokenStream {
    if rows::ldl_written_out(envelope) {
        rows::ldl(envelope)
    } else {
        quote! {
            /// L·D·Lᵀ of the lower triangle of `m` within the envelope (row p from FIRST[p]), in place (1/D on
            /// the diagonal); `false` when a pivot is not positive and finite. It runs to the end either
            /// way: the same instructions every time. Nothing fills outside the envelope.
            fn ldl(m: &mut [[f64; NV]; NV]) -> bool {
                let (mut v, mut pivots) = ([0.0; NV], [0.0; NV]);
                let mut positive = true;
                for j in 0..NV {
                    let fj = FIRST[j];
                    let mut d = m[j][j];
                    for k in fj..j {
                        v[k] = m[j][k] * pivots[k];
                        d -= m[j][k] * v[k];
                    }
                    // `&`, not `&&`: no branch. NaN fails `d > 0.0`.
                    positive &= (d > 0.0) & (d < f64::INFINITY);
                    pivots[j] = d;
                    // One division a column: the entries below, and the solves, multiply by its
                    // reciprocal, which the diagonal keeps.
                    let inverse = 1.0 / d;
                    m[j][j] = inverse;
                    for (p, row) in m.iter_mut().enumerate().take(REACH[j]).skip(j + 1) {
                        // FIRST is constant: the same branch every time.
                        let fp = at_index(&FIRST, p);
                        if fp <= j {
                            let mut a = row[j];
                            for k in if fp > fj { fp } else { fj }..j {
                                a -= row[k] * v[k];
                            }
                            row[j] = a * inverse;
                        }
                    }
                }
                positive
            }

            /// Solves L·D·Lᵀ x = b in place, within the envelope.
            fn ldl_solve(m: &[[f64; NV]; NV], b: &mut [f64; NV]) {
                for i in 0..NV {
                    let mut a = b[i];
                    for k in FIRST[i]..i {
                        a -= m[i][k] * b[k];
                    }
                    b[i] = a;
                }
                for i in 0..NV {
                    b[i] *= m[i][i];
                }
                // Lᵀ by rows of L: x_i is final once every later row has given its share.
                for i in (0..NV).rev() {
                    let x = b[i];
                    for k in FIRST[i]..i {
                        b[k] -= m[i][k] * x;
                    }
                }
            }
        }
    }
}
