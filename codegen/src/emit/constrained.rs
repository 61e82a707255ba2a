//! What the emitters of the constrained methods (`interior.rs`, `admm.rs`) share: the `SolverStatus` and
//! `Fallback` types, and the tables and terms of the rows' dependence on the data (x0, d, u₋₁).

use super::tokens::Num;
use crate::lower::Problem;
use nalgebra::DMatrix;
use proc_macro2::{Ident, Span, TokenStream};
use quote::quote;

/// `SolverStatus` and `Fallback`: the interior-point method's, and ADMM's without the `gap` it does not
/// have. `method` names the method in the docs.
pub fn status_types(method: &str, gap: bool, iterations_doc: &[&str]) -> TokenStream {
    let doc = format!(" What the {method}'s last solve did ([`Mpc::solver_status`]).");
    let gap = gap.then(|| {
        quote! {
            /// The mean complementarity sᵀλ / NSIDES, in the cost's units.
            pub gap: f64,
        }
    });
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
            #gap
            /// The largest violation of a hard constraint row by the returned plan, relative to
            /// max(1, |bound|).
            pub violation: f64,
            /// The largest violation of a soft row by the returned plan, in its row's units.
            pub softened: f64,
            /// The multipliers certified that the hard constraints admit no plan (or diverged).
            pub infeasible: bool,
            /// A factorisation was refused, or a step was not finite.
            pub numerical_failure: bool,
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
            /// The solve failed (infeasible, non-finite, or residuals above [`PRIMAL_LIMIT`] /
            /// [`DUAL_LIMIT`]): the previous plan shifted by one step with the rest input appended,
            /// projected onto the box. The next solve starts cold.
            WarmStart,
        }
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
