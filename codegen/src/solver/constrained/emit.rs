//! What the emitters of the constrained methods (`interior.rs`, `admm.rs`) share: the `SolverStatus` and
//! `Fallback` types, the entry points around their `checked` solve, the doc of their certificate, and
//! the tables and terms of the rows' dependence on the data (x0, d, u₋₁).

use crate::certify::evidence::Evidence;
use crate::emit::solve_api::{last_input_fns, reference_doc, solve_fns};
use crate::emit::tokens::Num;
use crate::lower::problem::Problem;
use nalgebra::DMatrix;
use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::quote;

/// `SolverStatus` and `Fallback`, the same for the interior-point method and ADMM. `method` names the
/// method in the docs.
pub fn status_types(method: &str, iterations_doc: &[&str]) -> TokenStream {
    let doc = format!(" What the {method}'s last solve did ([`Mpc::solver_status`]).");
    quote! {
        #[doc = #doc]
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct SolverStatus {
            #(#[doc = #iterations_doc])*
            pub iterations: u32,
            /// ‖G z + s − h‖∞ relative to the data's scale, at the end.
            pub primal_residual: f64,
            /// ‖H z + f + Gᵀλ‖∞ relative to the data's scale, at the end.
            pub dual_residual: f64,
            /// The duality gap at the end relative to the objective J of the QP, gap / max(1, |J|).
            pub gap: f64,
            /// The largest violation of a hard constraint row by the returned plan, relative to
            /// max(1, |bound|).
            pub violation: f64,
            /// The largest violation of a soft row by the returned plan, in its row's units.
            pub softened: f64,
            /// The multipliers certified that the hard constraints admit no plan (or diverged).
            pub infeasible: bool,
            /// A factorisation was refused, or a step was not finite.
            pub numerical_failure: bool,
            /// An entry of the reference window lay outside `[mpc.region]`'s reference range
            /// (`REFERENCE_MIN`/`REFERENCE_MAX`); where it was farther from the tracked output than the
            /// region covers (`REACH_LO`/`REACH_HI`) it was brought to that distance: the plan moves
            /// toward it as fast as the constraints allow, on a QP like those the region certified.
            pub reference_beyond_region: bool,
            /// A state counted as an absolute coordinate, or a reference entry, was larger in magnitude
            /// than `report::COORDINATE_RANGE_*` for this scalar: the command may be off by more than
            /// `report::COMMAND_ACCURACY` from rounding alone. Give coordinates from a local origin.
            pub beyond_coordinate_range: bool,
            /// Whether the plan is the solve's or the fallback's.
            pub fallback: Fallback,
        }

        /// Where the plan came from.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum Fallback {
            /// No solve yet.
            NoneYet,
            /// The solve's plan, projected onto the input box (which changes it by rounding at most).
            Solved,
            /// The solve failed (infeasible, non-finite, or residuals or gap above [`PRIMAL_LIMIT`] /
            /// [`DUAL_LIMIT`] / [`GAP_LIMIT`]): the previous plan shifted by one step with the rest input appended,
            /// projected onto the box. The next solve starts cold.
            WarmStart,
            /// An earlier solve found that the hard rows admit no plan (`infeasible`), and the held plan
            /// (the previous one shifted) violates them: this plan solves the QP with each hard row
            /// widened to the value the held plan gives it, so it violates no hard row more than holding
            /// would, and the cost steers it back (`violation` says how far it still is). Once the held
            /// plan meets the rows to [`ACCURACY`] the hard QP is solved again (it then has a plan).
            /// Relaxed solves start cold; their iterations are not what `[mpc.region]` certified.
            Relaxed,
        }
    }
}

/// The parts of `Mpc` around a constrained method's `checked(x0, [d,] xref)`: the public solve
/// functions, the disturbance's parameter and check, f's terms besides Fx·x0 − Fr·Xref, and the last
/// input's field and accessors where the first move is weighted.
pub struct Entry {
    /// `solve` (and `solve_with_disturbance` where d is estimated), which return the rest input where
    /// `checked` refuses an argument.
    pub solve_fns: TokenStream,
    /// `d: &[Real; ND],` in `checked`'s parameters, where d is estimated.
    pub d_param: TokenStream,
    /// `&& all_finite(d)` in `checked`'s argument check.
    pub d_finite: TokenStream,
    /// f's terms `+ FU[i]·u₋₁` and `+ FD[i]·d`, those that exist.
    pub f_terms: TokenStream,
    /// The field `last`, its initial value in `new`, its accessors, and its update after a solve.
    pub last_field: TokenStream,
    /// See [`Entry::last_field`].
    pub last_init: TokenStream,
    /// See [`Entry::last_field`].
    pub last_fns: TokenStream,
    /// See [`Entry::last_field`].
    pub set_last: TokenStream,
}

/// [`Entry`] of `p`.
pub fn entry(p: &Problem) -> Entry {
    let nd = p.nd();
    let keeps_last = p.keeps_last_input();
    let reference_doc = reference_doc(p);
    let solve_doc = format!(
        " One control step: `x0` is the current state, {reference_doc}. Returns the first input\n \
         of the plan, always finite and inside [U_MIN, U_MAX]; [`Mpc::solver_status`] says how the\n \
         plan was made. A non-finite argument returns the rest input and resets the warm start."
    );
    let solve_doc: Vec<&str> = solve_doc.split('\n').collect();
    let disturbance_doc: Vec<&str> = solve_doc
        .iter()
        .copied()
        .chain([" The prediction includes the estimated input disturbance `d` (offset-free MPC)."])
        .collect();
    let solve_fns = solve_fns(p, &solve_doc, &disturbance_doc);
    let f_last = p.has_moves().then(|| quote!(+ dot(&FU[i], &last)));
    let f_d = (nd > 0).then(|| quote!(+ dot(&FD[i], &d)));
    let (last_field, last_init, last_fns, set_last) = if keeps_last {
        (
            quote!(last: [Real; NU],),
            quote!(last: U_REST,),
            last_input_fns([
                " The last input u₋₁, from which the first move is measured: the last command returned,",
                " or what [`Mpc::set_last_input`] set.",
            ]),
            quote!(self.last = first;),
        )
    } else {
        (quote!(), quote!(), quote!(), quote!())
    };
    let (d_param, d_finite) = if nd > 0 {
        (quote!(d: &[Real; ND],), quote!(&&all_finite(d)))
    } else {
        (quote!(), quote!())
    };
    Entry {
        solve_fns,
        d_param,
        d_finite,
        f_terms: quote!(#f_last #f_d),
        last_field,
        last_init,
        last_fns,
        set_last,
    }
}

/// The reference's reach ([`crate::lower::problem::Qp::reference_reach`]): its tables `REACH_LO`/`REACH_HI` in
/// `num`, and the code that brings the window `reference` (f64 with `wide`, else `Real`) within them of
/// the tracked output at `x0` (same type), setting `beyond`. Without a reach (no certificate), `beyond`
/// is false and nothing is emitted.
pub fn reach(p: &Problem, num: Num, wide: bool) -> (TokenStream, TokenStream) {
    let Some(reach) = p.qp.reference_reach() else {
        return (quote!(), quote!(let beyond = false;));
    };
    let nz = Literal::usize_unsuffixed(p.qp.nz);
    let [lo, hi, range_min, range_max] = [&reach.lo, &reach.hi, &reach.range_min, &reach.range_max]
        .map(|v| num.vector(v.iter().copied()));
    let ty = if wide { quote!(f64) } else { quote!(Real) };
    let tables = quote! {
        /// The region's reference range (`[mpc.region]` reference_min, reference_max): an entry inside
        /// it is never moved; one outside is [`SolverStatus::reference_beyond_region`].
        const REFERENCE_MIN: [Real; #nz] = #range_min;
        const REFERENCE_MAX: [Real; #nz] = #range_max;
        /// How far the reference may lie from the tracked output (reference_min − the output's largest
        /// value over the state region, reference_max − its smallest): an entry outside the range is
        /// brought within that distance.
        const REACH_LO: [Real; #nz] = #lo;
        const REACH_HI: [Real; #nz] = #hi;
    };
    let of = |e: TokenStream| match (wide, num.0) {
        (true, mpc_spec::Scalar::F32) => quote!(f64::from(#e)),
        _ => e,
    };
    let [lo_of, hi_of, min_of, max_of] =
        [quote!(*lo), quote!(*hi), quote!(*min), quote!(*max)].map(of);
    let fill = match &p.qp.Cz {
        Some(_) => {
            let c_of = of(quote!(*c));
            quote! {
                for (t, row) in tracked.iter_mut().zip(CZ.iter()) {
                    *t = row.iter().zip(x0.iter()).fold(0.0, |s, (c, x)| s + #c_of * x);
                }
            }
        }
        None => quote!(tracked.copy_from_slice(&x0);),
    };
    let code = quote! {
        // A reference entry outside `[mpc.region]`'s range is brought within the distance of the tracked
        // output that the region covers: the plan then moves toward it as fast as the constraints
        // allow. An entry inside the range is never moved.
        let mut tracked: [#ty; #nz] = [0.0; #nz];
        #fill
        let mut beyond = false;
        for r in reference.chunks_exact_mut(#nz) {
            let bounds = REACH_LO.iter().zip(REACH_HI.iter()).zip(REFERENCE_MIN.iter().zip(REFERENCE_MAX.iter()));
            for ((v, t), ((lo, hi), (min, max))) in r.iter_mut().zip(tracked.iter()).zip(bounds) {
                let outside = (*v < #min_of) | (*v > #max_of);
                beyond |= outside;
                let (a, b) = (*t + #lo_of, *t + #hi_of);
                let reached = if *v < a { a } else if *v > b { b } else { *v };
                *v = if outside { reached } else { *v };
            }
        }
    };
    (tables, code)
}

/// The check of the data against the absolute-coordinate range the compiler states for the module's
/// scalar (`report::COORDINATE_RANGE_*`, [`crate::certify::coordinates`]): the table of the states counted as
/// absolute coordinates, and the code that sets `beyond_coordinates` when one of them in `x0`, or any
/// entry of `reference` (before its reach), is larger in magnitude than the range. `x0` and `reference`
/// are f64 with `wide`, else `Real`.
pub fn coordinate_check(p: &Problem, wide: bool) -> (TokenStream, TokenStream) {
    let states = crate::certify::coordinates::absolute_states(&p.F);
    let count = Literal::usize_unsuffixed(states.len());
    let indices = states.iter().map(|i| Literal::usize_unsuffixed(*i));
    let range = match p.scalar {
        mpc_spec::Scalar::F32 => quote!(report::COORDINATE_RANGE_F32),
        mpc_spec::Scalar::F64 => quote!(report::COORDINATE_RANGE_F64),
    };
    let magnitude = if wide {
        quote!(v.abs())
    } else {
        match p.scalar {
            mpc_spec::Scalar::F32 => quote!(f64::from(v.abs())),
            mpc_spec::Scalar::F64 => quote!(v.abs()),
        }
    };
    let tables = quote! {
        /// The states counted as absolute coordinates (the null space of F − I): with the references,
        /// what [`SolverStatus::beyond_coordinate_range`] compares with `report::COORDINATE_RANGE_*`.
        const ABSOLUTE_STATES: [usize; #count] = [#(#indices),*];
    };
    let code = quote! {
        // Absolute coordinates beyond the range stated for this scalar: the command may be off by more
        // than `report::COMMAND_ACCURACY`, and the status says so.
        // (The data are finite here: a non-finite argument was refused before.)
        let outside = |v: &f64| *v > #range;
        let mut beyond_coordinates = false;
        for i in ABSOLUTE_STATES {
            if let Some(v) = x0.get(i) {
                beyond_coordinates |= outside(&#magnitude);
            }
        }
        for v in reference.iter() {
            beyond_coordinates |= outside(&#magnitude);
        }
    };
    (tables, code)
}

/// `Mpc`'s doc line on its certificate; `setting` (e.g. ADMM's ρ) follows "to reach `accuracy`".
pub fn evidence_doc(evidence: Option<&Evidence>, setting: &str) -> String {
    match evidence {
        Some(e) => format!(
            " Certified by sampling, not proved: {} cold cases ({} corners) and {} warm closed-loop steps of `[mpc.region]` needed at most {} (cold) and {} (warm) iterations to reach `accuracy`{setting}; `report::SAMPLED_*` has the rest.",
            e.cold_cases, e.corners, e.warm_steps, e.cold_worst, e.warm_worst
        ),
        None => " Not certified.".to_string(),
    }
}

/// The rows' dependence on the data as tables `{prefix}_X`, `{prefix}_D`, `{prefix}_U` (those that are
/// not zero) and the terms `dot(&{prefix}_X[j], &x0)`, … that a row's offset sums (`j` the row).
pub struct Offsets {
    /// The tables.
    pub tables: TokenStream,
    /// One term per table, in the order x0, d, u₋₁.
    pub terms: Vec<TokenStream>,
}

/// [`Offsets`] of the rows `rows(W)` of each dependence W (Wx, Wd, Wu), written in `num` with element
/// type `ty`, `count` rows; `docs` are the three tables' docs.
pub fn offsets(
    p: &Problem,
    num: Num,
    ty: &TokenStream,
    prefix: &str,
    count: &TokenStream,
    rows: &dyn Fn(&DMatrix<f64>) -> DMatrix<f64>,
    docs: [&str; 3],
) -> Offsets {
    let w = &p.qp.rows;
    let nd = p.nd();
    let index = Ident::new("j", Span::call_site());
    let name = |s: &str| Ident::new(&format!("{prefix}_{s}"), Span::call_site());
    let (x, d, u) = (name("X"), name("D"), name("U"));
    let [x_doc, d_doc, u_doc] = docs;
    let mx = num.matrix(&rows(&w.Wx));
    let mut tables = quote! {
        #[doc = #x_doc]
        const #x: [[#ty; NX]; #count] = #mx;
    };
    let mut terms = vec![quote!(dot(&#x[#index], &x0))];
    if nd > 0 && w.Wd.iter().any(|v| *v != 0.0) {
        let m = num.matrix(&rows(&w.Wd.columns(0, nd).into_owned()));
        tables.extend(quote! {
            #[doc = #d_doc]
            const #d: [[#ty; ND]; #count] = #m;
        });
        terms.push(quote!(dot(&#d[#index], &d)));
    }
    if w.Wu.iter().any(|v| *v != 0.0) {
        let m = num.matrix(&rows(&w.Wu));
        tables.extend(quote! {
            #[doc = #u_doc]
            const #u: [[#ty; NU]; #count] = #m;
        });
        terms.push(quote!(dot(&#u[#index], &last)));
    }
    Offsets { tables, terms }
}

/// The plan's N steps over `self.plan` (NP entries): [`crate::emit::held_steps`] of its blocks.
pub fn held(p: &crate::lower::problem::Problem) -> TokenStream {
    crate::emit::held_steps(p, quote!(self.plan.chunks_exact(NU)))
}

/// What a constrained method's `Mpc` holds besides the fields every method's has, for [`mpc_type`].
pub struct MpcParts<'a> {
    /// `SolverStatus` and `Fallback` ([`status_types`]).
    pub status_types: TokenStream,
    /// The type's doc, line by line, and the certificate's line after it ([`evidence_doc`]).
    pub doc: &'a [&'a str],
    /// The certificate's line of the type's doc ([`evidence_doc`]).
    pub evidence_doc: &'a str,
    /// The scalar of the plan the method keeps: `f64` for a method that widens, else `Real`.
    pub plan_scalar: TokenStream,
    /// The method's warm-start fields with their docs, after the plan.
    pub point_fields: TokenStream,
    /// Their cold values in `new`.
    pub point_init: TokenStream,
    /// The doc of `new`.
    pub new_doc: &'a str,
    /// The body of `plan()`'s loop over one step: `o` the output's step, `step` the plan's.
    pub plan_step: TokenStream,
    /// The plan's N steps ([`crate::emit::held_steps`] of `self.plan.chunks_exact(NU)`).
    pub held: TokenStream,
    /// The entry points ([`entry`]) and `checked`, the method's solve.
    pub entry: Entry,
    /// `Mpc::checked`.
    pub checked: TokenStream,
}

/// The constrained `Mpc` struct with `new`, the solve functions, `solver_status`, the last-input
/// accessors, `plan`, `reset` and `Default`: written once for the interior-point method and ADMM.
pub fn mpc_type(parts: MpcParts) -> TokenStream {
    let MpcParts {
        status_types,
        doc,
        evidence_doc,
        plan_scalar,
        point_fields,
        point_init,
        new_doc,
        plan_step,
        held,
        entry,
        checked,
    } = parts;
    let Entry {
        solve_fns,
        last_field,
        last_init,
        last_fns,
        ..
    } = entry;
    quote! {
        #status_types

        #(#[doc = #doc])*
        #[doc = #evidence_doc]
        #[derive(Clone, Debug, PartialEq)]
        pub struct Mpc {
            /// The plan, projected onto the box.
            plan: [#plan_scalar; NP],
            #point_fields
            /// Whether the controller is recovering from hard rows that admitted no plan: the next solve
            /// widens them to the held plan where it violates them ([`Fallback::Relaxed`]).
            relax: bool,
            #last_field
            status: SolverStatus,
        }

        impl Mpc {
            #[doc = #new_doc]
            pub const fn new() -> Self {
                Mpc {
                    plan: rest_plan(),
                    #point_init
                    warm: false,
                    relax: false,
                    #last_init
                    status: SolverStatus {
                        iterations: 0,
                        primal_residual: 0.0,
                        dual_residual: 0.0,
                        gap: 0.0,
                        violation: 0.0,
                        softened: 0.0,
                        infeasible: false,
                        numerical_failure: false,
                        reference_beyond_region: false,
                        beyond_coordinate_range: false,
                        fallback: Fallback::NoneYet,
                    },
                }
            }

            #solve_fns

            #checked

            /// What the last solve did.
            pub fn solver_status(&self) -> &SolverStatus {
                &self.status
            }

            #last_fns

            /// The plan of the last solve, one input per predicted step.
            pub fn plan(&self) -> [[Real; NU]; N] {
                let mut out = [[0.0; NU]; N];
                for (o, step) in out.iter_mut().zip(#held) {
                    #plan_step
                }
                out
            }

            /// Forgets the warm start (and the last input).
            pub fn reset(&mut self) {
                *self = Self::new();
            }
        }

        impl Default for Mpc {
            fn default() -> Self {
                Self::new()
            }
        }
    }
}
