//! `table`: ∇J = H·y + f as a loop over the constant H, column by column (H is symmetric, so column j is
//! row j): every row accumulates at once, which SIMD units run side by side. Every entry is multiplied,
//! zeros too; the code does not grow with N. f = ∇J(0) comes from the matrix-free sweeps.

use super::{matrix_free, GradientForm};
use crate::emit::tokens::Num;
use crate::lower::problem::Problem;
use crate::numeric::Numeric;
use crate::plan::cost::{Estimate, BYTES_OF_A_LOOP, VECTOR_WIDTH};
use crate::solver::first_order::Algorithm;
use mpc_spec::Emission;
use proc_macro2::TokenStream;
use quote::quote;

/// The table form.
#[derive(Clone, Copy, Debug)]
pub struct Table;

/// nz² multiply-adds in vectors of four, one loop, H as a table.
pub fn estimate(p: &Problem) -> Estimate {
    let nz = p.qp.N * p.nu;
    Estimate {
        emission: Emission::Table,
        unavailable: None,
        macs: nz * nz,
        score: (nz * nz) as f64 / VECTOR_WIDTH as f64,
        code_bytes: BYTES_OF_A_LOOP,
        table_bytes: nz * nz * Numeric(p.scalar).bytes(),
    }
}

impl GradientForm for Table {
    fn emission(&self) -> Emission {
        Emission::Table
    }

    fn kernels(&self, p: &Problem, _algorithm: &dyn Algorithm, num: Num) -> TokenStream {
        let sweep = matrix_free::emit(p, num, self.plan_lanes(p));
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

            #sweep
        }
    }

    fn prepare(&self, p: &Problem) -> TokenStream {
        matrix_free::linear_term(p)
    }

    fn gradient_call(&self, _p: &Problem, algorithm: &dyn Algorithm) -> TokenStream {
        let point = algorithm.point();
        quote!(gradient(&#point, &f, &mut g))
    }
}
