//! The fixed-iteration MPC: the gradient map, the unrolled Hessian product and `Mpc`.
#![allow(non_snake_case)]

use super::tokens::{at1, at2, Num};
use crate::lower::Problem;
use mpc_spec::Method;
use proc_macro2::TokenStream;
use quote::quote;

/// The `Mpc` type and its unrolled kernels.
pub fn emit(p: &Problem, num: Num) -> TokenStream {
    let qp = &p.qp;
    let (nx, nu, N) = (p.nx, p.nu, qp.N);
    let nz = N * nu;
    let (x0, xref, y, f) = (quote!(x0), quote!(xref), quote!(y), quote!(f));

    // f = Fx·x0 − Fr·Xref (+ Fd·d), one entry per decision variable (eq. 10).
    let nd = p.filter.nd;
    let d = quote!(d);
    let f_entries: Vec<TokenStream> = (0..nz)
        .map(|i| {
            let from_x0 = (0..nx).map(|k| (qp.Fx[(i, k)], at1(&x0, k)));
            let from_ref = (0..N * nx).map(|j| (-qp.Fr[(i, j)], at2(&xref, j, nx)));
            let from_d = (0..nd).map(|j| (qp.Fd[(i, j)], at1(&d, j)));
            num.sum(None, from_x0.chain(from_ref).chain(from_d))
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
    // Warm start: the previous plan shifted by one block, the rest input appended (Algorithm 1, line 8).
    let shifted = (1..N).map(|k| {
        let k = proc_macro2::Literal::usize_unsuffixed(k);
        quote!(self.plan[#k])
    });
    let iterations = match qp.method {
        Method::Gradient => quote! {
            for _ in 0..ITERATIONS {
                let g = gradient(&u, &f);
                u = projected_step(&u, &g);
            }
        },
        Method::Fgm => quote! {
            let mut y = u;
            for _ in 0..ITERATIONS {
                let g = gradient(&y, &f);
                let next = projected_step(&y, &g);
                y = extrapolate(&next, &u);
                u = next;
            }
        },
    };
    let body = quote! {
        let mut u: [[Real; NU]; N] = [#(#shifted,)* U_REST];
        #iterations
        self.plan = u;
        u[0]
    };
    let (d_param, solve_fns) = if nd > 0 {
        (
            quote!(d: &[Real; ND],),
            quote! {
                /// One control step with no disturbance estimate (d = 0); see [`Mpc::solve_with_disturbance`].
                pub fn solve(&mut self, x0: &[Real; NX], xref: &[[Real; NX]; N]) -> [Real; NU] {
                    self.solve_with_disturbance(x0, &[0.0; ND], xref)
                }

                /// One control step of the offset-free MPC: `x0` is the current state, `d` the estimated
                /// input disturbance (`Kalman::disturbance`), `xref[k]` the reference of predicted state k+1.
                /// The prediction includes d and the input cost is on u + d, so the command cancels a
                /// constant disturbance. Returns the first input, always finite and inside [U_MIN, U_MAX];
                /// a non-finite argument returns the rest input and resets the warm start.
                pub fn solve_with_disturbance(&mut self, x0: &[Real; NX], d: &[Real; ND], xref: &[[Real; NX]; N]) -> [Real; NU] {
                    if !(all_finite(x0) && all_finite(d) && xref.iter().all(|r| all_finite(r))) {
                        self.reset();
                        return U_REST;
                    }
                    let f = linear_term(x0, d, xref);
                    #body
                }
            },
        )
    } else {
        (
            quote!(),
            quote! {
                /// One control step: `x0` is the current state, `xref[k]` the reference of predicted state k+1.
                /// Returns the first input of the plan, always finite and inside [U_MIN, U_MAX]. A non-finite
                /// `x0` or `xref` returns the rest input and resets the warm start.
                pub fn solve(&mut self, x0: &[Real; NX], xref: &[[Real; NX]; N]) -> [Real; NU] {
                    if !(all_finite(x0) && xref.iter().all(|r| all_finite(r))) {
                        self.reset();
                        return U_REST;
                    }
                    let f = linear_term(x0, xref);
                    #body
                }
            },
        )
    };
    let (nnz_h, nnz_f) = (
        qp.H.iter().filter(|v| num.round(**v) != 0.0).count(),
        qp.Fx
            .iter()
            .chain(qp.Fr.iter())
            .filter(|v| num.round(**v) != 0.0)
            .count(),
    );
    let gradient_doc =
        format!(" ∇J(y) = H·y + f (eq. 11), unrolled over the {nnz_h} nonzeros of H.");
    let linear_doc =
        format!(" f = Fx·x0 − Fr·Xref (eq. 10), unrolled over the {nnz_f} nonzeros of Fx and Fr.");

    quote! {
        #[doc = #linear_doc]
        #[inline(always)]
        fn linear_term(x0: &[Real; NX], #d_param xref: &[[Real; NX]; N]) -> [[Real; NU]; N] {
            [#(#f_rows),*]
        }

        #[doc = #gradient_doc]
        #[inline(always)]
        fn gradient(y: &[[Real; NU]; N], f: &[[Real; NU]; N]) -> [[Real; NU]; N] {
            [#(#g_rows),*]
        }

        /// proj(y − STEP·g) onto the input box (Algorithm 1, lines 4-5).
        #[inline(always)]
        fn projected_step(y: &[[Real; NU]; N], g: &[[Real; NU]; N]) -> [[Real; NU]; N] {
            let mut out = *y;
            for (out_k, g_k) in out.iter_mut().zip(g.iter()) {
                for (((u, g), lo), hi) in out_k.iter_mut().zip(g_k.iter()).zip(U_MIN.iter()).zip(U_MAX.iter()) {
                    *u = project(*u - STEP * *g, *lo, *hi);
                }
            }
            out
        }

        /// The momentum step of the fast gradient method: next + MOMENTUM·(next − previous).
        #[allow(dead_code)]
        #[inline(always)]
        fn extrapolate(next: &[[Real; NU]; N], previous: &[[Real; NU]; N]) -> [[Real; NU]; N] {
            let mut out = *next;
            for (out_k, prev_k) in out.iter_mut().zip(previous.iter()) {
                for (y, prev) in out_k.iter_mut().zip(prev_k.iter()) {
                    *y = *y + MOMENTUM * (*y - *prev);
                }
            }
            out
        }

        /// Fixed-iteration, warm-started MPC over the condensed QP (paper Section 2.4, Algorithm 1).
        #[derive(Clone, Debug, PartialEq)]
        pub struct Mpc {
            plan: [[Real; NU]; N],
        }

        impl Mpc {
            /// A cold controller: the first solve starts from the rest input (zero, projected onto the box).
            pub const fn new() -> Self {
                Mpc { plan: [U_REST; N] }
            }

            #solve_fns
            /// The plan of the last solve, one input per predicted step.
            pub fn plan(&self) -> &[[Real; NU]; N] {
                &self.plan
            }

            /// Forgets the warm start.
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

/// `[[e0, e1], [e2, e3]]` from a flat list, `width` per block.
pub fn blocks(entries: &[TokenStream], width: usize) -> Vec<TokenStream> {
    entries.chunks(width).map(|c| quote!([#(#c),*])).collect()
}
