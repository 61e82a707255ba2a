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
    let nz = p.qp.Nc * p.nu;
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
        // Under a control horizon f comes from the tables FX, FR (FU, FD): the sweeps run over N steps.
        let sweep = (!p.qp.blocked()).then(|| matrix_free::emit(p, num, self.plan_lanes(p)));
        let nz = p.qp.Nc * p.nu;
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
        if p.qp.blocked() {
            tabulated_linear_term(p)
        } else {
            matrix_free::linear_term(p)
        }
    }

    fn gradient_call(&self, _p: &Problem, algorithm: &dyn Algorithm) -> TokenStream {
        let point = algorithm.point();
        quote!(gradient(&#point, &f, &mut g))
    }
}

/// f = FX·x0 − FR·Xref (+ FU·u₋₁ + FD·d) as loops over the module's tables: the table form's f under a
/// control horizon, where the sweeps (over the N steps) do not give the gradient on the free inputs.
fn tabulated_linear_term(p: &Problem) -> TokenStream {
    let last = p.has_moves().then(|| {
        quote! {
            for (f_i, fu) in f.as_flattened_mut().iter_mut().zip(FU.iter()) {
                *f_i += dot(fu, last);
            }
        }
    });
    let d = (p.nd() > 0).then(|| {
        quote! {
            for (f_i, fd) in f.as_flattened_mut().iter_mut().zip(FD.iter()) {
                *f_i += dot(fd, d);
            }
        }
    });
    quote! {
        let dot = |a: &[Real], b: &[Real]| -> Real { a.iter().zip(b.iter()).map(|(x, y)| *x * *y).sum() };
        let mut f: Plan = [[0.0; LANES]; CONTROL_HORIZON];
        let stacked = xref.as_flattened();
        for (f_i, (fx, fr)) in f.as_flattened_mut().iter_mut().zip(FX.iter().zip(FR.iter())) {
            *f_i = dot(fx, x0) - dot(fr, stacked);
        }
        #last
        #d
    }
}
