//! The scalar helpers shared by the emitted filter and MPC. They use iterators only: nothing can index out
//! of bounds, so nothing can panic.

use crate::lower::problem::Problem;
use crate::plan::Plan;
use crate::solver::first_order::form::{neon, Form};
use proc_macro2::TokenStream;
use quote::quote;

/// `project` (where a portable kernel calls it), `all_finite`, `finite` (with a filter) and `flushed`.
pub fn emit(p: &Problem, plan: &Plan, projects: bool) -> TokenStream {
    // The NEON `lanes` kernel projects with `project_lanes`; only its portable twin calls `project`.
    let cfg = match plan.form {
        Form::Lanes(_) if neon::applies(p) => neon::portable_cfg(),
        _ => quote!(),
    };
    // `Kalman::new` is the one constant context.
    let finite = p.filter.is_some().then(|| {
        quote! {
            /// [`all_finite`] for constant contexts (`Kalman::new`).
            const fn finite(mut v: &[Real]) -> bool {
                while let Some((first, rest)) = v.split_first() {
                    if !first.is_finite() {
                        return false;
                    }
                    v = rest;
                }
                true
            }
        }
    });
    let project = projects.then(|| {
        quote! {
            /// The projection onto [lo, hi]; NaN maps to `lo`, so the result is always finite and in the box.
            #cfg
            #[inline(always)]
            fn project(v: Real, lo: Real, hi: Real) -> Real {
                let v = if v > lo { v } else { lo };
                if v < hi { v } else { hi }
            }
        }
    });
    quote! {
        #project

        /// Whether every entry is finite.
        #[inline(always)]
        fn all_finite(v: &[Real]) -> bool {
            v.iter().all(|x| x.is_finite())
        }

        #finite

        /// Magnitudes below this are read as zero where data enters and where the estimate is stored:
        /// the smallest normal number over ε, so that a product with any coefficient above ε stays
        /// normal. Subnormal arithmetic costs up to 100× on x86; nothing this small is resolvable next
        /// to a value of order one.
        const FLUSH_BELOW: Real = Real::MIN_POSITIVE / Real::EPSILON;

        /// `v` with entries below [`FLUSH_BELOW`] in magnitude set to zero.
        #[inline(always)]
        fn flushed<const M: usize>(v: &[Real; M]) -> [Real; M] {
            let mut out = *v;
            for e in out.iter_mut() {
                if e.abs() < FLUSH_BELOW {
                    *e = 0.0;
                }
            }
            out
        }
    }
}
