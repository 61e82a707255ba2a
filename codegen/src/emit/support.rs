//! The scalar helpers shared by the emitted filter and MPC. They use iterators only: nothing can index out
//! of bounds, so nothing can panic.

use crate::form::{neon, Form};
use crate::lower::Problem;
use crate::plan::Plan;
use proc_macro2::TokenStream;
use quote::quote;

/// `project` (where a portable kernel calls it) and `all_finite`.
pub fn emit(p: &Problem, plan: &Plan) -> TokenStream {
    // The NEON `lanes` kernel projects with `project_lanes`; only its portable twin calls `project`.
    let cfg = match plan.form {
        Form::Lanes(_) if neon::applies(p) => neon::portable_cfg(),
        _ => quote!(),
    };
    quote! {
        /// The projection onto [lo, hi]; NaN maps to `lo`, so the result is always finite and in the box.
        #cfg
        #[inline(always)]
        fn project(v: Real, lo: Real, hi: Real) -> Real {
            let v = if v > lo { v } else { lo };
            if v < hi { v } else { hi }
        }

        /// Whether every entry is finite.
        #[inline(always)]
        fn all_finite(v: &[Real]) -> bool {
            v.iter().all(|x| x.is_finite())
        }
    }
}
