//! The fixed-iteration MPC: `Mpc`, its solver loop, and the `unrolled` and `table` gradients (`lanes` and the
//! matrix-free sweeps have modules of their own).
#![allow(non_snake_case)]

use super::tokens::{at1, at2, Num};
use crate::lower::Problem;
use mpc_spec::{Emission, Method};
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// The `Mpc` type and its kernels, in the problem's emission ([`crate::cost`]).
pub fn emit(p: &Problem, num: Num) -> TokenStream {
    let qp = &p.qp;
    let (nu, N) = (p.nu, qp.N);
    let nd = p.filter.nd;
    let lanes = crate::cost::plan_lanes(p);
    let lanes_lit = Literal::usize_unsuffixed(lanes);
    let padded = |v: &nalgebra::DVector<f64>| {
        num.vector((0..lanes).map(|a| if a < nu { v[a] } else { 0.0 }))
    };
    let (lo, hi, rest) = (
        padded(&qp.u_min),
        padded(&qp.u_max),
        padded(&qp.rest_input()),
    );
    let d_arg = if nd > 0 { quote!(d,) } else { quote!() };
    let point = point(qp.method);
    let (kernels, prepare, gradient_call) = match p.emission {
        Emission::Unrolled => (
            unrolled(p, num),
            quote!(let f = linear_term(x0, #d_arg xref);),
            quote!(gradient(&#point, &f, &mut g)),
        ),
        Emission::Table | Emission::Lanes => {
            let product = if p.emission == Emission::Table {
                table(p)
            } else {
                super::lanes::emit(p, num)
            };
            let sweep = super::sweep::emit(p, num, lanes);
            (
                quote!(#sweep #product),
                quote! {
                    // f = ∇J(0): the same sweeps as the matrix-free form, O(N) instead of the O(N²) Fr·Xref.
                    let mut f: Plan = [[0.0; LANES]; N];
                    adjoint_gradient(&[[0.0; LANES]; N], x0, #d_arg xref, &mut f);
                },
                quote!(gradient(&#point, &f, &mut g)),
            )
        }
        Emission::MatrixFree | Emission::Auto => (
            super::sweep::emit(p, num, lanes),
            quote!(),
            quote!(adjoint_gradient(&#point, x0, #d_arg xref, &mut g)),
        ),
    };
    // Warm start: the previous plan shifted by one block, the rest input appended (Algorithm 1, line 8).
    let shifted = (1..N).map(|k| {
        let k = Literal::usize_unsuffixed(k);
        quote!(self.plan[#k])
    });
    let iterations = match (p.emission, qp.method) {
        (Emission::Lanes, _) => super::lanes::iterations(p),
        (_, Method::Gradient) => quote! {
            // Every kernel works in place: no plan is copied inside the loop.
            let mut g: Plan = [[0.0; LANES]; N];
            for _ in 0..ITERATIONS {
                #gradient_call;
                gradient_step(&mut u, &g);
            }
        },
        (_, Method::Fgm) => quote! {
            let mut y = u;
            let mut g: Plan = [[0.0; LANES]; N];
            for _ in 0..ITERATIONS {
                #gradient_call;
                fast_gradient_step(&mut u, &mut y, &g);
            }
        },
    };
    let body = quote! {
        #prepare
        let mut u: Plan = [#(#shifted,)* REST];
        #iterations
        self.plan = u;
        inputs(&u[0])
    };
    let solve_fns = if nd > 0 {
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
                #body
            }
        }
    } else {
        quote! {
            /// One control step: `x0` is the current state, `xref[k]` the reference of predicted state k+1.
            /// Returns the first input of the plan, always finite and inside [U_MIN, U_MAX]. A non-finite
            /// `x0` or `xref` returns the rest input and resets the warm start.
            pub fn solve(&mut self, x0: &[Real; NX], xref: &[[Real; NX]; N]) -> [Real; NU] {
                if !(all_finite(x0) && xref.iter().all(|r| all_finite(r))) {
                    self.reset();
                    return U_REST;
                }
                #body
            }
        }
    };
    let lanes_doc = match p.emission {
        Emission::Lanes => format!(
            " Entries per plan step: the NU inputs padded to {lanes} SIMD lanes (H = H_AXIS ⊗ I); padding stays zero."
        ),
        _ => " Entries per plan step: the NU inputs.".to_string(),
    };
    let emission_doc = format!(
        " How the gradient is emitted: `{}` ([codegen] emission; `mpcc check` prints the cost model).",
        p.emission.name()
    );

    let emission = p.emission.name();
    let steps = if p.emission == Emission::Lanes {
        quote!()
    } else {
        steps()
    };
    quote! {
        #[doc = #emission_doc]
        pub const EMISSION: &str = #emission;
        #[doc = #lanes_doc]
        pub const LANES: usize = #lanes_lit;
        /// A plan: one row of LANES per predicted step.
        type Plan = [[Real; LANES]; N];
        /// U_MIN over the lanes.
        const LO: [Real; LANES] = #lo;
        /// U_MAX over the lanes.
        const HI: [Real; LANES] = #hi;
        /// U_REST over the lanes.
        const REST: [Real; LANES] = #rest;

        #kernels

        /// The NU inputs of one plan step.
        #[inline(always)]
        fn inputs(step: &[Real; LANES]) -> [Real; NU] {
            let mut out = [0.0; NU];
            for (o, v) in out.iter_mut().zip(step.iter()) {
                *o = *v;
            }
            out
        }

        #steps

        /// Fixed-iteration, warm-started MPC over the condensed QP (paper Section 2.4, Algorithm 1).
        #[derive(Clone, Debug, PartialEq)]
        pub struct Mpc {
            plan: Plan,
        }

        impl Mpc {
            /// A cold controller: the first solve starts from the rest input (zero, projected onto the box).
            pub const fn new() -> Self {
                Mpc { plan: [REST; N] }
            }

            #solve_fns
            /// The plan of the last solve, one input per predicted step.
            pub fn plan(&self) -> [[Real; NU]; N] {
                let mut out = [[0.0; NU]; N];
                for (o, step) in out.iter_mut().zip(self.plan.iter()) {
                    *o = inputs(step);
                }
                out
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

/// Where the gradient is taken: the extrapolated point `y` (FGM) or the iterate `u` itself.
pub(super) fn point(method: Method) -> TokenStream {
    match method {
        Method::Fgm => quote!(y),
        Method::Gradient => quote!(u),
    }
}

/// `unrolled`: f = Fx·x0 − Fr·Xref (+ Fd·d) and ∇J = H·y + f, one statement per row, exact zeros skipped.
fn unrolled(p: &Problem, num: Num) -> TokenStream {
    let qp = &p.qp;
    let (nx, nu, N, nd) = (p.nx, p.nu, qp.N, p.filter.nd);
    let nz = N * nu;
    let (x0, xref, y, f, d) = (quote!(x0), quote!(xref), quote!(y), quote!(f), quote!(d));
    // f = Fx·x0 − Fr·Xref (+ Fd·d), one entry per decision variable (eq. 10).
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
    let d_param = if nd > 0 {
        quote!(d: &[Real; ND],)
    } else {
        quote!()
    };
    let gradient_doc = format!(
        " ∇J(y) = H·y + f (eq. 11), unrolled over the {} nonzeros of H.",
        num.nonzeros(&qp.H)
    );
    let linear_doc = format!(
        " f = Fx·x0 − Fr·Xref (eq. 10), unrolled over the {} nonzeros of Fx and Fr.",
        num.nonzeros(&qp.Fx) + num.nonzeros(&qp.Fr)
    );
    quote! {
        #[doc = #linear_doc]
        #[inline(always)]
        fn linear_term(x0: &[Real; NX], #d_param xref: &[[Real; NX]; N]) -> Plan {
            [#(#f_rows),*]
        }

        #[doc = #gradient_doc]
        #[inline(always)]
        fn gradient(y: &Plan, f: &Plan, g: &mut Plan) {
            *g = [#(#g_rows),*];
        }
    }
}

/// `table`: ∇J = H·y + f as a loop over the constant H, column by column (H is symmetric, so column j is
/// row j): every row accumulates at once, which SIMD units run side by side.
fn table(p: &Problem) -> TokenStream {
    let nz = p.qp.N * p.nu;
    let doc = format!(" ∇J(y) = H·y + f (eq. 11), a loop over the {nz}×{nz} table H.");
    quote! {
        #[doc = #doc]
        #[inline(always)]
        fn gradient(y: &Plan, f: &Plan, g: &mut Plan) {
            *g = *f;
            for (h_j, y_j) in H.iter().zip(y.as_flattened().iter()) {
                for (g_i, h_ij) in g.as_flattened_mut().iter_mut().zip(h_j.iter()) {
                    *g_i += *h_ij * *y_j;
                }
            }
        }
    }
}

/// `[[e0, e1], [e2, e3]]` from a flat list, `width` per block.
pub fn blocks(entries: &[TokenStream], width: usize) -> Vec<TokenStream> {
    entries.chunks(width).map(|c| quote!([#(#c),*])).collect()
}

/// The projected step proj(y − STEP·g) onto the input box (Algorithm 1, lines 4-5), fused with FGM's
/// momentum, in place (the `lanes` emission fuses it into its own iteration instead).
fn steps() -> TokenStream {
    quote! {
        /// u ← proj(u − STEP·g) (Algorithm 1, lines 4-5).
        #[allow(dead_code)]
        #[inline(always)]
        fn gradient_step(u: &mut Plan, g: &Plan) {
            for (u_k, g_k) in u.iter_mut().zip(g.iter()) {
                for (((u, g), lo), hi) in u_k.iter_mut().zip(g_k.iter()).zip(LO.iter()).zip(HI.iter()) {
                    *u = project(*u - STEP * *g, *lo, *hi);
                }
            }
        }

        /// The fast gradient step: next = proj(y − STEP·g), y ← next + MOMENTUM·(next − u), u ← next.
        #[allow(dead_code)]
        #[inline(always)]
        fn fast_gradient_step(u: &mut Plan, y: &mut Plan, g: &Plan) {
            for ((u_k, y_k), g_k) in u.iter_mut().zip(y.iter_mut()).zip(g.iter()) {
                let lanes = u_k.iter_mut().zip(y_k.iter_mut()).zip(g_k.iter()).zip(LO.iter().zip(HI.iter()));
                for (((u, y), g), (lo, hi)) in lanes {
                    let next = project(*y - STEP * *g, *lo, *hi);
                    *y = next + MOMENTUM * (next - *u);
                    *u = next;
                }
            }
        }
    }
}
