//! `lanes`: H = H_axis ⊗ I, each plan step a vector of lanes (the inputs, padded to a power of two), one
//! N × N table for all of them. One solver iteration is one fused pass: for each row i,
//! g_i = f_i + Σ_j H_axis(i, j)·y_j, then the algorithm's step for that row, so that the gradient is never
//! stored. The point y is read whole by every row, so the new point goes to a second buffer and the two
//! swap roles from one iteration to the next. The NEON twin of the pass is [`super::neon`]'s.
#![allow(non_snake_case)]

use super::{lane_count, matrix_free, neon, GradientForm};
use crate::emit::tokens::Num;
use crate::lower::problem::Problem;
use crate::numeric::Numeric;
use crate::plan::cost::{Estimate, BYTES_OF_A_LOOP, VECTOR_WIDTH};
use crate::solver::first_order::Algorithm;
use mpc_spec::Emission;
use nalgebra::DMatrix;
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

/// The lanes form, with H = H_axis ⊗ I_nu.
#[derive(Clone, Debug)]
pub struct Lanes {
    /// H_axis (N × N): every input's share of the Hessian.
    pub H_axis: DMatrix<f64>,
}

/// N² vector multiply-adds of the padded lanes; unavailable without the structure.
pub fn estimate(p: &Problem, H_axis: Option<&DMatrix<f64>>) -> Estimate {
    let (N, nu) = (p.qp.N, p.nu);
    let lanes = lane_count(nu);
    Estimate {
        emission: Emission::Lanes,
        unavailable: match H_axis {
            Some(_) => None,
            None => Some(format!("H is not H_axis ⊗ I_{nu}")),
        },
        macs: N * N * lanes,
        score: (N * N * lanes.div_ceil(VECTOR_WIDTH)) as f64,
        code_bytes: BYTES_OF_A_LOOP,
        // H_BLOCKS: H_axis in blocks of four rows, the last one zero-padded.
        table_bytes: 4 * N.div_ceil(4) * N * Numeric(p.scalar).bytes(),
    }
}

impl GradientForm for Lanes {
    fn emission(&self) -> Emission {
        Emission::Lanes
    }

    fn plan_lanes(&self, p: &Problem) -> usize {
        lane_count(p.nu)
    }

    fn kernels(&self, p: &Problem, algorithm: &dyn Algorithm, num: Num) -> TokenStream {
        let N = p.qp.N;
        let sweep = matrix_free::emit(p, num, self.plan_lanes(p));
        let has_neon = neon::applies(p);
        let portable_cfg = has_neon.then(neon::portable_cfg);
        let (name, params) = (algorithm.fused_name(), algorithm.fused_params());
        let doc = algorithm.fused_doc(N * N, lane_count(p.nu));
        let body = portable_passes(N, algorithm);
        let neon = has_neon.then(|| neon::lanes_kernels(N, algorithm));
        quote! {
            #[doc = #doc]
            #portable_cfg
            #[inline]
            fn #name(#params) {
                #body
            }

            #neon
            #sweep
        }
    }

    fn tables(&self, p: &Problem, num: Num) -> TokenStream {
        let N = p.qp.N;
        let table = num.matrix(&self.H_axis);
        let table_doc = format!(
            " H_axis with H = H_axis ⊗ I_NU ({N}×{N}): every input's share of the Hessian, one table for all lanes."
        );
        let h_blocks = self.h_blocks(N, num);
        quote! {
            #[doc = #table_doc]
            pub const H_AXIS: [[Real; N]; N] = #table;
            #h_blocks
        }
    }

    fn prepare(&self, p: &Problem) -> TokenStream {
        matrix_free::linear_term(p)
    }

    /// Unused: the fused pass computes each row's gradient where it steps.
    fn gradient_call(&self, _p: &Problem, _algorithm: &dyn Algorithm) -> TokenStream {
        quote!()
    }

    fn iterations(&self, _p: &Problem, algorithm: &dyn Algorithm) -> TokenStream {
        algorithm.fused_iterations()
    }

    fn separate_step(&self) -> bool {
        false
    }

    /// The fused iteration's NEON twin (and the sweeps', which run in the same lanes).
    fn uses_neon(&self, p: &Problem) -> bool {
        neon::applies(p)
    }
}

impl Lanes {
    /// `H_BLOCKS[b][j] = H_AXIS[4b..4b + 4][j]`: the four multipliers of block b at step j, zero rows
    /// padding the last block; one 128-bit load on NEON.
    fn h_blocks(&self, N: usize, num: Num) -> TokenStream {
        let blocks = N.div_ceil(4);
        let h_blocks = (0..blocks).map(|b| {
            let columns = (0..N).map(|j| {
                num.vector((0..4).map(|l| {
                    let i = 4 * b + l;
                    if i < N {
                        self.H_axis[(i, j)]
                    } else {
                        0.0
                    }
                }))
            });
            quote!([#(#columns),*])
        });
        let blocks = Literal::usize_unsuffixed(blocks);
        quote! {
            /// H_AXIS in blocks of four rows, column by column (zero rows pad the last block): the rows of a
            /// block accumulate side by side, and on NEON their four multipliers are one load.
            const H_BLOCKS: [[[Real; 4]; N]; #blocks] = [#(#h_blocks),*];
        }
    }
}

/// The portable passes: the same blocks of four rows as the NEON kernel, each row's accumulator a lane
/// array, so that the rows' multiply-add chains are independent and interleaved (a single row's chain
/// over j is latency-bound). Each row still sums f_i + Σ_j H_AXIS[i][j]·y_j in the order of j.
fn portable_passes(N: usize, algorithm: &dyn Algorithm) -> TokenStream {
    let point = algorithm.point();
    let passes = neon::passes_layout(N).into_iter().map(|pass| {
        let first = pass[0];
        let acc = |b: usize, l: usize| format_ident!("acc{}_{}", b - first, l);
        let rows = |b: usize| (0..4).filter(move |l| 4 * b + l < N);
        let init = pass.iter().flat_map(|&b| {
            rows(b).map(move |l| {
                let (a, i) = (acc(b, l), Literal::usize_unsuffixed(4 * b + l));
                quote!(let mut #a: [Real; LANES] = f[#i];)
            })
        });
        let tables: Vec<_> = pass
            .iter()
            .map(|&b| format_ident!("h{}", b - first))
            .collect();
        let chunks = pass.iter().map(|&b| {
            let b = Literal::usize_unsuffixed(b);
            quote!(.zip(H_BLOCKS[#b].iter()))
        });
        let pattern = tables.iter().fold(quote!(y_j), |acc, h| quote!((#acc, #h)));
        let body = pass.iter().flat_map(|&b| {
            let h = format_ident!("h{}", b - first);
            rows(b).map(move |l| {
                let (a, l) = (acc(b, l), Literal::usize_unsuffixed(l));
                quote! {
                    for (a, y) in #a.iter_mut().zip(y_j.iter()) {
                        *a += #h[#l] * *y;
                    }
                }
            })
        });
        let step = pass.iter().flat_map(|&b| {
            rows(b).map(move |l| {
                let i = Literal::usize_unsuffixed(4 * b + l);
                algorithm.fused_row(&i, &acc(b, l))
            })
        });
        quote! {
            {
                #(#init)*
                for #pattern in #point.iter() #(#chunks)* {
                    #(#body)*
                }
                #(#step)*
            }
        }
    });
    quote!(#(#passes)*)
}
