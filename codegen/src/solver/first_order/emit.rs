//! The fixed-iteration MPC: `Mpc` and its solver loop, from the plan's algorithm ([`crate::solver`]) and
//! gradient form ([`crate::solver::first_order::form`]).
#![allow(non_snake_case)]

use crate::emit::sections::Sections;
use crate::emit::solve_api::{last_input_fns, reference_doc, solve_fns};
use crate::emit::tokens::Num;
use crate::lower::problem::Problem;
use crate::plan::Plan;
use crate::solver::first_order::Algorithm;
use proc_macro2::Literal;
use quote::quote;

/// The `Mpc` type, its kernels and its tables.
pub fn emit(p: &Problem, plan: &Plan, algorithm: &dyn Algorithm, num: Num) -> Sections {
    let qp = &p.qp;
    let (nu, Nc) = (p.nu, qp.Nc);
    let steps = crate::emit::plan_steps(p);
    let held = crate::emit::held_steps(p, quote!(self.plan.iter()));
    let nd = p.nd();
    let form = plan.form.gradient();
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
    let shifted = (1..Nc).map(|k| {
        let k = Literal::usize_unsuffixed(k);
        quote!(self.plan[#k])
    });
    let iterations = form.iterations(p, algorithm);
    let moves = p.has_moves();
    // With weighted moves the first move is measured from the last input, which the solve then replaces.
    let (bind_last, first) = if moves {
        (
            quote!(let last = &self.last;),
            quote! {
                let first = inputs(&u[0]);
                self.last = first;
                Some(first)
            },
        )
    } else {
        (quote!(), quote!(Some(inputs(&u[0]))))
    };
    let body = quote! {
        #bind_last
        #prepare
        let mut u: Plan = [#(#shifted,)* REST];
        #iterations
        self.plan = u;
        #first
    };
    let row = crate::solver::first_order::form::reference_row(p);
    let reference_doc = reference_doc(p);
    // Data enters flushed of magnitudes the arithmetic would turn subnormal (`flushed`).
    let flush_reference = quote! {
        let mut reference = *xref;
        for row in reference.iter_mut() {
            *row = flushed(row);
        }
        let xref = &reference;
    };
    let offset_doc = format!(
        " One control step of the offset-free MPC: `x0` is the current state, `d` the estimated\n \
         input disturbance (`Kalman::disturbance`), {reference_doc}.\n \
         The prediction includes d and the input cost is on u + d, so the command cancels a\n \
         constant disturbance. Returns the first input, always finite and inside [U_MIN, U_MAX];\n \
         a non-finite argument returns the rest input and resets the warm start."
    );
    let offset_doc: Vec<&str> = offset_doc.split('\n').collect();
    let solve_doc = format!(
        " One control step: `x0` is the current state, {reference_doc}.\n \
         Returns the first input of the plan, always finite and inside [U_MIN, U_MAX]. A non-finite\n \
         `x0` or `xref` returns the rest input and resets the warm start."
    );
    let solve_doc: Vec<&str> = solve_doc.split('\n').collect();
    let entry = solve_fns(p, &solve_doc, &offset_doc);
    let checked = if nd > 0 {
        quote! {
            /// [`Mpc::solve_with_disturbance`], with `None` (and a reset warm start) for a non-finite argument.
            fn checked(&mut self, x0: &[Real; NX], d: &[Real; ND], xref: &[[Real; #row]; N]) -> Option<[Real; NU]> {
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
            /// [`Mpc::solve`], with `None` (and a reset warm start) for a non-finite argument.
            fn checked(&mut self, x0: &[Real; NX], xref: &[[Real; #row]; N]) -> Option<[Real; NU]> {
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
    let solve_fns = quote!(#entry #checked);
    let (last_field, last_init, last_fns, new_doc, reset_doc) = if moves {
        (
            quote!(last: [Real; NU],),
            quote!(last: U_REST),
            last_input_fns([
                " The last input u₋₁, from which the first move Δu₀ = u₀ − u₋₁ is weighted: the last command",
                " returned, or what [`Mpc::set_last_input`] set.",
            ]),
            " A cold controller: the first solve starts from the rest input (zero, projected onto the box), which is also its last input.",
            " Forgets the warm start; the last input becomes the rest input.",
        )
    } else {
        (
            quote!(),
            quote!(),
            quote!(),
            " A cold controller: the first solve starts from the rest input (zero, projected onto the box).",
            " Forgets the warm start.",
        )
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
            /// A plan: one row of LANES per predicted step (per free step under a control horizon).
            type Plan = [[Real; LANES]; #steps];
        },
        api: quote! {
            /// Fixed-iteration, warm-started MPC over the condensed QP (paper Section 2.4, Algorithm 1).
            #[derive(Clone, Debug, PartialEq)]
            pub struct Mpc {
                plan: Plan,
                #last_field
            }

            impl Mpc {
                #[doc = #new_doc]
                pub const fn new() -> Self {
                    Mpc { plan: [REST; #steps], #last_init }
                }

                #solve_fns
                #last_fns
                /// The plan of the last solve, one input per predicted step.
                pub fn plan(&self) -> [[Real; NU]; N] {
                    let mut out = [[0.0; NU]; N];
                    for (o, step) in out.iter_mut().zip(#held) {
                        *o = inputs(step);
                    }
                    out
                }

                #[doc = #reset_doc]
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
