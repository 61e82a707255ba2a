//! The solve functions and last-input accessors of `Mpc` that every method's emitter shares.

use crate::lower::problem::Problem;
use proc_macro2::TokenStream;
use quote::quote;

/// The doc of `xref` in the solve functions: a reference of the outputs or of the state.
pub fn reference_doc(p: &Problem) -> &'static str {
    if p.qp.Cz.is_some() {
        "`xref[k]` the reference of the outputs z = C_z·x at predicted step k+1"
    } else {
        "`xref[k]` the reference of predicted state k+1"
    }
}

/// `Mpc::solve`, documented by `solve_doc`, over the private `checked(x0, [d,] xref)`: the rest input
/// where `checked` refuses an argument. With a disturbance estimate, `solve` is
/// `Mpc::solve_with_disturbance` (documented by `disturbance_doc`) at d = 0.
pub fn solve_fns(p: &Problem, solve_doc: &[&str], disturbance_doc: &[&str]) -> TokenStream {
    let row = crate::solver::first_order::form::reference_row(p);
    if p.nd() > 0 {
        quote! {
            /// One control step with no disturbance estimate (d = 0); see [`Mpc::solve_with_disturbance`].
            pub fn solve(&mut self, x0: &[Real; NX], xref: &[[Real; #row]; N]) -> [Real; NU] {
                self.solve_with_disturbance(x0, &[0.0; ND], xref)
            }

            #(#[doc = #disturbance_doc])*
            pub fn solve_with_disturbance(&mut self, x0: &[Real; NX], d: &[Real; ND], xref: &[[Real; #row]; N]) -> [Real; NU] {
                match self.checked(x0, d, xref) {
                    Some(u) => u,
                    None => U_REST,
                }
            }
        }
    } else {
        quote! {
            #(#[doc = #solve_doc])*
            pub fn solve(&mut self, x0: &[Real; NX], xref: &[[Real; #row]; N]) -> [Real; NU] {
                match self.checked(x0, xref) {
                    Some(u) => u,
                    None => U_REST,
                }
            }
        }
    }
}

/// `Mpc::last_input` (documented by `doc`) and `Mpc::set_last_input`, for an `Mpc` whose field `last`
/// holds the input the first move is measured from (every method's, where moves are weighted or bounded).
pub fn last_input_fns(doc: [&str; 2]) -> TokenStream {
    quote! {
        #(#[doc = #doc])*
        pub fn last_input(&self) -> &[Real; NU] {
            &self.last
        }

        /// Sets the last input u₋₁, for a vehicle flown by something else until now. A non-finite
        /// entry is refused: nothing changes and the result is `false`.
        pub fn set_last_input(&mut self, u: &[Real; NU]) -> bool {
            if !all_finite(u) {
                return false;
            }
            self.last = flushed(u);
            true
        }
    }
}
