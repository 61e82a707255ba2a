//! The `report` submodule: the certificate as constants, so that firmware and tests can read what the
//! compiler proved. One constant per [`Certificate::fields`] entry, and the a priori rate and the two
//! gains beside them.

use crate::certify::certificate::{Certificate, Value};
use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::quote;

/// An f64 literal, `f64::NAN` where the number does not exist.
fn real(v: f64) -> TokenStream {
    if v.is_finite() {
        let l = Literal::f64_suffixed(v);
        quote!(#l)
    } else {
        quote!(f64::NAN)
    }
}

/// The type and the value of one field's constant.
fn constant(value: Value) -> (TokenStream, TokenStream) {
    let count = |v: usize| Literal::usize_unsuffixed(v);
    match value {
        Value::Real(v) => (quote!(f64), real(v)),
        Value::Count(v) => {
            let v = count(v);
            (quote!(usize), quote!(#v))
        }
        Value::MaybeReal(Some(v)) => {
            let v = real(v);
            (quote!(Option<f64>), quote!(Some(#v)))
        }
        Value::MaybeReal(None) => (quote!(Option<f64>), quote!(None)),
        Value::MaybeCount(Some(v)) => {
            let v = count(v);
            (quote!(Option<usize>), quote!(Some(#v)))
        }
        Value::MaybeCount(None) => (quote!(Option<usize>), quote!(None)),
    }
}

/// `pub mod report { ... }`.
pub fn emit(c: &Certificate, backoff: &[crate::lower::backoff::Margin]) -> TokenStream {
    let fields = c
        .fields()
        .into_iter()
        .filter(|f| !f.constant.is_empty())
        .map(|field| {
            let name = Ident::new(field.constant, Span::call_site());
            let (ty, value) = constant(field.value);
            let doc = format!(" {}", field.doc);
            quote! {
                #[doc = #doc]
                pub const #name: #ty = #value;
            }
        });
    let matrix = |m: &nalgebra::DMatrix<f64>| {
        let rows = m.row_iter().map(|r| {
            let items = r.iter().map(|v| real(*v));
            quote!([#(#items),*])
        });
        quote!([#(#rows),*])
    };
    let (lqr_gain, mpc_gain) = (matrix(&c.lqr.gain), matrix(&c.mpc.gain));
    // With weighted moves the gains act on (x, u₋₁).
    let (columns, lqr_doc, mpc_doc) = if c.mpc.moves {
        (
            quote!(NX + NU),
            " The paper's check (Section 2.4.3) with weighted moves: the LQR gain on (x, u₋₁) of the move, Δu = −K·(x, u₋₁).",
            " The unconstrained receding-horizon gain (first block of H⁻¹·[Fx Fu]): u = −K·(x, u₋₁) at zero reference.",
        )
    } else {
        (
            quote!(NX),
            " The paper's check (Section 2.4.3): the LQR gain of the stage weights Q, R.",
            " The unconstrained receding-horizon gain (first block of H⁻¹·Fx): u = −K·x at zero reference.",
        )
    };
    let rate = match c.rate {
        Some(rate) => {
            let (constant, factor) = (real(rate.constant), real(rate.factor));
            quote!(Some((#constant, #factor)))
        }
        None => quote!(None),
    };
    // Only a spec with a back-off has the table.
    let backoff = (!backoff.is_empty()).then(|| {
        let k = Literal::usize_unsuffixed(backoff.len());
        let items = backoff.iter().map(|m| {
            let (name, margin) = (m.kind.name(), real(m.margin));
            quote!((#name, #margin))
        });
        quote! {
            /// The back-offs (`x_backoff`, a group's `backoff`): each tightened bound's name in the spec
            /// and its margin in the bound's units. The rows hold lower + margin ≤ row ≤ upper − margin,
            /// and `SolverStatus::softened` is measured from the tightened bound.
            pub const BACKOFF: [(&str, f64); #k] = [#(#items),*];
        }
    });
    quote! {
        /// What the compiler proved and counted about this controller (see `codegen::certificate` for the
        /// bounds' forms). Every number is f64, computed once at compile time.
        pub mod report {
            use super::{NU, NX};
            #(#fields)*
            /// The a priori bound J(U_k) − J* ≤ C·ρᵏ·(J(U_0) − J*): (C, ρ); `None` for a step above 1/L.
            pub const RATE: Option<(f64, f64)> = #rate;
            #[doc = #lqr_doc]
            pub const LQR_GAIN: [[f64; #columns]; NU] = #lqr_gain;
            #[doc = #mpc_doc]
            pub const MPC_GAIN: [[f64; #columns]; NU] = #mpc_gain;
            #backoff
        }
    }
}
