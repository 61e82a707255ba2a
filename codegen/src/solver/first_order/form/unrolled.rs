//! `unrolled`: f = Fx·x0 − Fr·Xref (+ Fd·d) and ∇J = H·y + f, one statement per row, each nonzero
//! coefficient inlined and exact zeros skipped. Fastest for small sparse H, but its code grows with N²
//! and must fit the instruction cache.
#![allow(non_snake_case)]

use super::{linear_args, linear_params, reference_row, GradientForm};
use crate::emit::tokens::{at1, at2, blocks, Num};
use crate::lower::problem::Problem;
use crate::numeric::Numeric;
use crate::plan::cost::{Estimate, BYTES_PER_INLINED_MAC};
use crate::solver::first_order::Algorithm;
use mpc_spec::Emission;
use proc_macro2::TokenStream;
use quote::quote;

/// The unrolled form.
#[derive(Clone, Copy, Debug)]
pub struct Unrolled;

/// One multiply-add per nonzero of H, 12 bytes of A32 each.
pub fn estimate(p: &Problem) -> Estimate {
    let nnz = Numeric(p.scalar).nonzeros(&p.qp.H);
    Estimate {
        emission: Emission::Unrolled,
        unavailable: None,
        macs: nnz,
        score: nnz as f64,
        code_bytes: nnz * BYTES_PER_INLINED_MAC,
        table_bytes: 0,
    }
}

impl GradientForm for Unrolled {
    fn emission(&self) -> Emission {
        Emission::Unrolled
    }

    fn kernels(&self, p: &Problem, _algorithm: &dyn Algorithm, num: Num) -> TokenStream {
        let qp = &p.qp;
        let (nx, nu, N, nd) = (p.nx, p.nu, qp.N, p.nd());
        // One row per variable of the QP: the Nc free inputs; the references span the N steps.
        let nz = qp.Nc * nu;
        let (x0, xref, y, f, d) = (quote!(x0), quote!(xref), quote!(y), quote!(f), quote!(d));
        let last = quote!(last);
        let (nr, moves) = (qp.nz, if p.has_moves() { nu } else { 0 });
        // f = Fx·x0 − Fr·Xref (+ Fu·u₋₁ + Fd·d), one entry per decision variable (eq. 10).
        let f_entries: Vec<TokenStream> = (0..nz)
            .map(|i| {
                let from_x0 = (0..nx).map(|k| (qp.Fx[(i, k)], at1(&x0, k)));
                let from_ref = (0..N * nr).map(|j| (-qp.Fr[(i, j)], at2(&xref, j, nr)));
                let from_last = (0..moves).map(|j| (qp.Fu[(i, j)], at1(&last, j)));
                let from_d = (0..nd).map(|j| (qp.Fd[(i, j)], at1(&d, j)));
                num.sum(None, from_x0.chain(from_ref).chain(from_last).chain(from_d))
            })
            .collect();
        // ∇J = H·y + f (eq. 11), exact zeros of H skipped.
        let g_entries: Vec<TokenStream> = (0..nz)
            .map(|i| {
                num.sum(
                    Some(at2(&f, i, nu)),
                    (0..nz).map(|j| (qp.H[(i, j)], at2(&y, j, nu))),
                )
            })
            .collect();
        let f_rows = blocks(&f_entries, nu);
        let g_rows = blocks(&g_entries, nu);
        let d_param = linear_params(p);
        let row = reference_row(p);
        let numeric = num.numeric();
        let gradient_doc = format!(
            " ∇J(y) = H·y + f (eq. 11), unrolled over the {} nonzeros of H.",
            numeric.nonzeros(&qp.H)
        );
        let linear_doc = if p.has_moves() {
            format!(
                " f = Fx·x0 − Fr·Xref + Fu·u₋₁ (eq. 10 with the moves), unrolled over the {} nonzeros of Fx, Fr and Fu.",
                numeric.nonzeros(&qp.Fx) + numeric.nonzeros(&qp.Fr) + numeric.nonzeros(&qp.Fu)
            )
        } else {
            format!(
                " f = Fx·x0 − Fr·Xref (eq. 10), unrolled over the {} nonzeros of Fx and Fr.",
                numeric.nonzeros(&qp.Fx) + numeric.nonzeros(&qp.Fr)
            )
        };
        quote! {
            #[doc = #linear_doc]
            #[inline(always)]
            fn linear_term(x0: &[Real; NX], #d_param xref: &[[Real; #row]; N]) -> Plan {
                [#(#f_rows),*]
            }

            #[doc = #gradient_doc]
            #[inline(always)]
            fn gradient(y: &Plan, f: &Plan, g: &mut Plan) {
                *g = [#(#g_rows),*];
            }
        }
    }

    fn prepare(&self, p: &Problem) -> TokenStream {
        let d_arg = linear_args(p);
        quote!(let f = linear_term(x0, #d_arg xref);)
    }

    fn gradient_call(&self, _p: &Problem, algorithm: &dyn Algorithm) -> TokenStream {
        let point = algorithm.point();
        quote!(gradient(&#point, &f, &mut g))
    }

    /// No sweeps and no lanes.
    fn uses_neon(&self, _p: &Problem) -> bool {
        false
    }

    /// f unrolled over Fx, Fr and Fd; H, Fx, Fr and Fd inlined.
    fn gradient_map(&self, p: &Problem, _estimates: &[Estimate]) -> (usize, usize) {
        let num = Numeric(p.scalar);
        let qp = &p.qp;
        let macs = num.nonzeros(&qp.Fx)
            + num.nonzeros(&qp.Fr)
            + num.nonzeros(&qp.Fu)
            + num.nonzeros(&qp.Fd);
        let constants = [&qp.H, &qp.Fx, &qp.Fr, &qp.Fu, &qp.Fd]
            .iter()
            .map(|M| num.coefficients(M))
            .sum();
        (macs, constants)
    }
}
