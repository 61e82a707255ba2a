//! The `lanes` emission: H = H_axis ⊗ I, each plan step a vector of lanes (the inputs, padded to a power
//! of two), one N × N table for all of them. One solver iteration is one fused pass: for each row i,
//! g_i = f_i + Σ_j H_axis[i][j]·y_j, then the projected step and the momentum for that row, so that the
//! gradient is never stored. The point y is read whole by every row, so the new point goes to a second
//! buffer and the two swap roles from one iteration to the next.
//!
//! On an ARMv7 with NEON (`--cfg mpc_neon`, nightly) the same pass is written with intrinsics: LLVM does
//! not vectorize f32 for NEON by itself, because NEON flushes subnormals and is not IEEE-exact there.
//! Four rows at a time run in four accumulators with one `vmla.f32 q, q, d[x]` per entry of H_axis.
#![allow(non_snake_case)]

use super::tokens::Num;
use crate::cost::lane_count;
use crate::lower::Problem;
use mpc_spec::{Method, Scalar};
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

/// The cfg of the NEON kernels, and its negation for the portable ones.
pub(super) fn neon_cfg() -> (TokenStream, TokenStream) {
    (
        quote!(#[cfg(all(mpc_neon, target_arch = "arm", target_feature = "neon"))]),
        quote!(#[cfg(not(all(mpc_neon, target_arch = "arm", target_feature = "neon")))]),
    )
}

/// Whether the NEON kernels are emitted: f32 in exactly one 4-lane q register per step.
pub(super) fn has_neon(p: &Problem) -> bool {
    p.scalar == Scalar::F32 && lane_count(p.nu) == 4
}

/// The solver loop: iterations in pairs, the two point buffers swapping roles.
pub fn iterations(p: &Problem) -> TokenStream {
    match p.qp.method {
        Method::Fgm => quote! {
            let mut y = u;
            let mut y_next: Plan = [[0.0; LANES]; N];
            for _ in 0..ITERATIONS / 2 {
                fast_gradient_iteration(&mut u, &y, &mut y_next, &f);
                fast_gradient_iteration(&mut u, &y_next, &mut y, &f);
            }
            if ITERATIONS % 2 == 1 {
                fast_gradient_iteration(&mut u, &y, &mut y_next, &f);
            }
        },
        Method::Gradient => quote! {
            let mut next: Plan = u;
            for _ in 0..ITERATIONS / 2 {
                gradient_iteration(&u, &mut next, &f);
                gradient_iteration(&next, &mut u, &f);
            }
            if ITERATIONS % 2 == 1 {
                gradient_iteration(&u, &mut next, &f);
                u = next;
            }
        },
    }
}

/// H_AXIS and the fused iterations (portable, and NEON where it applies).
pub fn emit(p: &Problem, num: Num) -> TokenStream {
    let N = p.qp.N;
    let H_axis =
        p.qp.H_axis
            .as_ref()
            .expect("lower() chooses `lanes` only with H = H_axis ⊗ I");
    let table = num.matrix(H_axis);
    let table_doc = format!(
        " H_axis with H = H_axis ⊗ I_NU ({N}×{N}): every input's share of the Hessian, one table for all lanes."
    );
    let neon = has_neon(p).then(|| neon(p));
    let (_, portable_cfg) = neon_cfg();
    let portable_cfg = if neon.is_some() {
        portable_cfg
    } else {
        quote!()
    };
    let macs = N * N;
    let lanes = lane_count(p.nu);
    let fgm_doc = format!(
        " One FGM iteration, row by row: g_i = f_i + Σ_j H_AXIS[i][j]·y_j ({macs} lane-wise multiply-adds of {lanes} lanes), next = proj(y_i − STEP·g_i), y_next_i = next + MOMENTUM·(next − u_i), u_i = next."
    );
    let gradient_doc = format!(
        " One projected gradient iteration (Algorithm 1, lines 3-5), row by row: g_i = f_i + Σ_j H_AXIS[i][j]·u_j ({macs} lane-wise multiply-adds of {lanes} lanes), next_i = proj(u_i − STEP·g_i)."
    );
    let (portable_fgm, portable_gradient) = (
        portable_passes(N, Method::Fgm),
        portable_passes(N, Method::Gradient),
    );
    let h_blocks = h_blocks(p, num);
    quote! {
        #[doc = #table_doc]
        pub const H_AXIS: [[Real; N]; N] = #table;

        #h_blocks

        #[doc = #fgm_doc]
        #portable_cfg
        #[allow(dead_code)]
        #[inline]
        fn fast_gradient_iteration(u: &mut Plan, y: &Plan, y_next: &mut Plan, f: &Plan) {
            #portable_fgm
        }

        #[doc = #gradient_doc]
        #portable_cfg
        #[allow(dead_code)]
        #[inline]
        fn gradient_iteration(u: &Plan, next: &mut Plan, f: &Plan) {
            #portable_gradient
        }

        #neon
    }
}

/// `H_BLOCKS[b][j] = H_AXIS[4b..4b + 4][j]`: the four multipliers of block b at step j, zero rows padding
/// the last block; one 128-bit load on NEON.
fn h_blocks(p: &Problem, num: Num) -> TokenStream {
    let N = p.qp.N;
    let H_axis = p.qp.H_axis.as_ref().expect("checked by the caller");
    let blocks = N.div_ceil(4);
    let h_blocks = (0..blocks).map(|b| {
        let columns = (0..N).map(|j| {
            num.vector((0..4).map(|l| {
                let i = 4 * b + l;
                if i < N {
                    H_axis[(i, j)]
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

/// Blocks of four rows per pass over j: eight accumulators, y_j and one multiplier block fit the sixteen
/// q registers. Measured on the emulated A9 for `specs/paper.toml`: 27,140 instructions per control cycle
/// with two blocks per pass, 30,050 with one, 27,140 with three. Unrolling the loop over j makes LLVM
/// split every `vmla` into `vmul` + `vadd` (with `target-cpu=cortex-a9` it splits a VMLA whose
/// accumulator comes straight from another VMLA, a real A9 hazard), which costs more than the loop.
const PASS: usize = 2;

/// The NEON kernels: both iterations in blocks of four rows, two blocks per pass over j.
fn neon(p: &Problem) -> TokenStream {
    let N = p.qp.N;
    let (neon_cfg, _) = neon_cfg();
    let blocks = N.div_ceil(4);
    let blocks_lit = Literal::usize_unsuffixed(blocks);
    let fgm = passes(N, Method::Fgm);
    let gradient = passes(N, Method::Gradient);
    let uses = quote! {
        use core::arch::arm::{
            vbslq_f32, vcgtq_f32, vcltq_f32, vget_high_f32, vget_low_f32, vld1q_f32, vmlaq_lane_f32,
            vmlaq_n_f32, vmlsq_n_f32, vst1q_f32, vsubq_f32,
        };
    };
    let prologue = quote! {
        // Read the table through an opaque reference: with the constants in view, LLVM turns each lane
        // multiplier into a 16-byte splat in a literal pool and spills them all.
        let table: &[[[Real; 4]; N]; #blocks_lit] = core::hint::black_box(&H_BLOCKS);
        // An opaque trip count keeps each pass a loop: fully unrolled, the scheduler orders the work
        // accumulator by accumulator and spills every y_j and every multiplier.
        let rounds = core::hint::black_box(N);
        let (lo, hi) = (vld1q_f32(LO.as_ptr()), vld1q_f32(HI.as_ptr()));
    };
    quote! {
        /// NEON: proj(v) as two compare-and-selects, exactly `project` (NaN → lower bound).
        #neon_cfg
        #[inline(always)]
        unsafe fn project_lanes(
            v: core::arch::arm::float32x4_t,
            lo: core::arch::arm::float32x4_t,
            hi: core::arch::arm::float32x4_t,
        ) -> core::arch::arm::float32x4_t {
            use core::arch::arm::{vbslq_f32, vcgtq_f32, vcltq_f32};
            let v = vbslq_f32(vcgtq_f32(v, lo), v, lo);
            vbslq_f32(vcltq_f32(v, hi), v, hi)
        }

        /// NEON: one FGM iteration, four rows per block, two blocks per pass over j.
        #neon_cfg
        #[allow(dead_code, unused_imports)]
        #[inline]
        fn fast_gradient_iteration(u: &mut Plan, y: &Plan, y_next: &mut Plan, f: &Plan) {
            #uses
            // SAFETY: NEON is enabled at compile time (the cfg above), and every pointer is to a live
            // `[f32; 4]`, which is what the 4-lane loads and stores read and write.
            unsafe {
                #prologue
                #fgm
            }
        }

        /// NEON: one projected gradient iteration, four rows per block, two blocks per pass over j.
        #neon_cfg
        #[allow(dead_code, unused_imports)]
        #[inline]
        fn gradient_iteration(u: &Plan, next: &mut Plan, f: &Plan) {
            #uses
            // SAFETY: as in `fast_gradient_iteration`.
            unsafe {
                #prologue
                #gradient
            }
        }
    }
}

/// The buffer the gradient reads (y for FGM, u for the projected gradient method), and the blocks of
/// four rows of each pass.
fn layout(N: usize, method: Method) -> (TokenStream, Vec<Vec<usize>>) {
    let blocks = N.div_ceil(4);
    let point = super::mpc::point(method);
    let passes = (0..blocks)
        .step_by(PASS)
        .map(|first| (first..(first + PASS).min(blocks)).collect())
        .collect();
    (point, passes)
}

/// The passes of one iteration: blocks in pairs, each pass N steps of up to eight multiply-adds, then
/// the step for the pass's rows. `point` is the buffer the gradient reads.
fn passes(N: usize, method: Method) -> TokenStream {
    let (point, passes) = layout(N, method);
    let passes = passes.into_iter().map(|pass| {
        let first = pass[0];
        let acc = |b: usize, l: usize| format_ident!("acc{}_{}", b - first, l);
        let init = pass.iter().flat_map(|&b| {
            (0..4).map(move |l| {
                let a = acc(b, l);
                let i = 4 * b + l;
                if i < N {
                    let i = Literal::usize_unsuffixed(i);
                    quote!(let mut #a = vld1q_f32(f[#i].as_ptr());)
                } else {
                    quote!(let mut #a = vld1q_f32(REST.as_ptr());)
                }
            })
        });
        let tables: Vec<_> = pass.iter().map(|&b| format_ident!("h{}", b - first)).collect();
        let chunks = pass.iter().map(|&b| {
            let b = Literal::usize_unsuffixed(b);
            quote!(.zip(table[#b].iter()))
        });
        let per_block = pass.iter().map(|&b| {
                let h = format_ident!("h{}", b - first);
                let (a0, a1, a2, a3) = (acc(b, 0), acc(b, 1), acc(b, 2), acc(b, 3));
                quote! {
                    let m = vld1q_f32(#h.as_ptr());
                    let (m_lo, m_hi) = (vget_low_f32(m), vget_high_f32(m));
                    #a0 = vmlaq_lane_f32::<0>(#a0, y_j, m_lo);
                    #a1 = vmlaq_lane_f32::<1>(#a1, y_j, m_lo);
                    #a2 = vmlaq_lane_f32::<0>(#a2, y_j, m_hi);
                    #a3 = vmlaq_lane_f32::<1>(#a3, y_j, m_hi);
                }
            });
        let body = quote! {
            let y_j = vld1q_f32(ys.as_ptr());
            #(#per_block)*
        };
        let pattern = tables
            .iter()
            .fold(quote!(ys), |acc, h| quote!((#acc, #h)));
        let step = pass.iter().flat_map(|&b| {
            (0..4).filter(move |l| 4 * b + l < N).map(move |l| {
                let a = acc(b, l);
                let i = Literal::usize_unsuffixed(4 * b + l);
                match method {
                    Method::Fgm => quote! {
                        let next = project_lanes(vmlsq_n_f32(vld1q_f32(y[#i].as_ptr()), #a, STEP), lo, hi);
                        let previous = vld1q_f32(u[#i].as_ptr());
                        vst1q_f32(y_next[#i].as_mut_ptr(), vmlaq_n_f32(next, vsubq_f32(next, previous), MOMENTUM));
                        vst1q_f32(u[#i].as_mut_ptr(), next);
                    },
                    Method::Gradient => quote! {
                        let stepped = vmlsq_n_f32(vld1q_f32(u[#i].as_ptr()), #a, STEP);
                        vst1q_f32(next[#i].as_mut_ptr(), project_lanes(stepped, lo, hi));
                    },
                }
            })
        });
        quote! {
            {
                #(#init)*
                let steps = #point.iter() #(#chunks)*;
                for #pattern in steps.take(rounds) {
                    #body
                }
                #(#step)*
            }
        }
    });
    quote!(#(#passes)*)
}

/// The portable passes: the same blocks of four rows as the NEON kernel, each row's accumulator a lane
/// array, so that the rows' multiply-add chains are independent and interleaved (a single row's chain
/// over j is latency-bound). Each row still sums f_i + Σ_j H_AXIS[i][j]·y_j in the order of j.
fn portable_passes(N: usize, method: Method) -> TokenStream {
    let (point, passes) = layout(N, method);
    let passes = passes.into_iter().map(|pass| {
        let first = pass[0];
        let acc = |b: usize, l: usize| format_ident!("acc{}_{}", b - first, l);
        let rows = |b: usize| (0..4).filter(move |l| 4 * b + l < N);
        let init = pass.iter().flat_map(|&b| {
            rows(b).map(move |l| {
                let (a, i) = (acc(b, l), Literal::usize_unsuffixed(4 * b + l));
                quote!(let mut #a: [Real; LANES] = f[#i];)
            })
        });
        let tables: Vec<_> = pass.iter().map(|&b| format_ident!("h{}", b - first)).collect();
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
                let a = acc(b, l);
                let i = Literal::usize_unsuffixed(4 * b + l);
                match method {
                    Method::Fgm => quote! {
                        let lanes = u[#i].iter_mut().zip(y_next[#i].iter_mut()).zip(y[#i].iter().zip(#a.iter()));
                        for (((u, y_next), (y, g)), (lo, hi)) in lanes.zip(LO.iter().zip(HI.iter())) {
                            let next = project(*y - STEP * *g, *lo, *hi);
                            *y_next = next + MOMENTUM * (next - *u);
                            *u = next;
                        }
                    },
                    Method::Gradient => quote! {
                        let lanes = next[#i].iter_mut().zip(u[#i].iter().zip(#a.iter()));
                        for ((next, (u, g)), (lo, hi)) in lanes.zip(LO.iter().zip(HI.iter())) {
                            *next = project(*u - STEP * *g, *lo, *hi);
                        }
                    },
                }
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
