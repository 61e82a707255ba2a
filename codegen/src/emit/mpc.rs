//! The fixed-iteration MPC: `Mpc` and its solver loop, from the plan's algorithm ([`crate::solver`]) and
//! gradient form ([`crate::form`]).
#![allow(non_snake_case)]

use super::tokens::Num;
use super::Sections;
use crate::lower::Problem;
use crate::plan::Plan;
use proc_macro2::Literal;
use quote::quote;

/// The `Mpc` type, its kernels and its tables.
pub fn emit(p: &Problem, plan: &Plan, num: Num) -> Sections {
    let qp = &p.qp;
    let (nu, N) = (p.nu, qp.N);
    let nd = p.filter.nd;
    let (algorithm, form) = (plan.algorithm, plan.form.gradient());
    let lanes = form.plan_lanes(p);
    let lanes_lit = Literal::usize_unsuffixed(lanes);
    let padded = |v: &nalgebra::DVector<f64>| {
        num.vector((0..lanes).map(|a| if a < nu { v[a] } else { 0.0 }))
    };
    let (lo, hi, rest) = (
        padded(&qp.u_min),
        padded(&qp.u_max),
        padded(&qp.rest_input()),
    );
    let kernels = form.kernels(p, algorithm, num);
    let tables = form.tables(p, num);
    let prepare = form.prepare(p);
    // Warm start: the previous plan shifted by one block, the rest input appended (Algorithm 1, line 8).
    let shifted = (1..N).map(|k| {
        let k = Literal::usize_unsuffixed(k);
        quote!(self.plan[#k])
    });
    let iterations = form.iterations(p, algorithm);
    let body = quote! {
        #prepare
        let mut u: Plan = [#(#shifted,)* REST];
        #iterations
        self.plan = u;
        Some(inputs(&u[0]))
    };
    // Data enters flushed of magnitudes the arithmetic would turn subnormal (`flushed`).
    let flush_reference = quote! {
        let mut reference = *xref;
        for row in reference.iter_mut() {
            *row = flushed(row);
        }
        let xref = &reference;
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
                match self.checked(x0, d, xref) {
                    Some(u) => u,
                    None => U_REST,
                }
            }

            /// [`Mpc::solve_with_disturbance`], with `None` (and a reset warm start) for a non-finite argument.
            fn checked(&mut self, x0: &[Real; NX], d: &[Real; ND], xref: &[[Real; NX]; N]) -> Option<[Real; NU]> {
                if !(all_finite(x0) && all_finite(d) && xref.iter().all(|r| all_finite(r))) {
                    self.reset();
                    return None;
                }
                let (x0, d) = (&flushed(x0), &flushed(d));
                #flush_reference
                #body
            }
        }
    } else {
        quote! {
            /// One control step: `x0` is the current state, `xref[k]` the reference of predicted state k+1.
            /// Returns the first input of the plan, always finite and inside [U_MIN, U_MAX]. A non-finite
            /// `x0` or `xref` returns the rest input and resets the warm start.
            pub fn solve(&mut self, x0: &[Real; NX], xref: &[[Real; NX]; N]) -> [Real; NU] {
                match self.checked(x0, xref) {
                    Some(u) => u,
                    None => U_REST,
                }
            }

            /// [`Mpc::solve`], with `None` (and a reset warm start) for a non-finite argument.
            fn checked(&mut self, x0: &[Real; NX], xref: &[[Real; NX]; N]) -> Option<[Real; NU]> {
                if !(all_finite(x0) && xref.iter().all(|r| all_finite(r))) {
                    self.reset();
                    return None;
                }
                let x0 = &flushed(x0);
                #flush_reference
                #body
            }
        }
    };
    let emission = plan.emission();
    let lanes_doc = if lanes > nu {
        format!(" Entries per plan step: the NU inputs padded to {lanes} SIMD lanes; the padding stays zero.")
    } else {
        " Entries per plan step: the NU inputs.".to_string()
    };
    let emission_doc = format!(
        " How the gradient is emitted: `{}` ([codegen] emission; `mpcc check` prints the cost model).",
        emission.name()
    );
    let emission = emission.name();
    let step = form.separate_step().then(|| algorithm.step_kernel());
    Sections {
        constants: quote! {
            #[doc = #emission_doc]
            pub const EMISSION: &str = #emission;
            #[doc = #lanes_doc]
            pub const LANES: usize = #lanes_lit;
            /// A plan: one row of LANES per predicted step.
            type Plan = [[Real; LANES]; N];
        },
        api: quote! {
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
        },
        kernels: quote! {
            /// The NU inputs of one plan step.
            #[inline(always)]
            fn inputs(step: &[Real; LANES]) -> [Real; NU] {
                let mut out = [0.0; NU];
                for (o, v) in out.iter_mut().zip(step.iter()) {
                    *o = *v;
                }
                out
            }

            #step
            #kernels
        },
        tables: quote! {
            /// U_MIN over the lanes.
            const LO: [Real; LANES] = #lo;
            /// U_MAX over the lanes.
            const HI: [Real; LANES] = #hi;
            /// U_REST over the lanes.
            const REST: [Real; LANES] = #rest;
            #tables
        },
    }
}
