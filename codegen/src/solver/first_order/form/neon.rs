//! The target's SIMD: NEON on the ARMv7 of the Zynq's Cortex-A9, under
//! `cfg(all(mpc_neon, target_arch = "arm", target_feature = "neon"))` (the firmware's build script sets
//! `mpc_neon`; the intrinsics need nightly). LLVM does not vectorize f32 for NEON by itself, because
//! NEON flushes subnormals and is not IEEE-exact there, so the kernels are written with intrinsics. The
//! portable kernels they twin stay the reference everywhere else.
#![allow(non_snake_case)]

use super::lane_count;
use crate::lower::problem::Problem;
use crate::solver::first_order::Algorithm;
use mpc_spec::Scalar;
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

/// The cfg of the NEON kernels.
pub fn cfg() -> TokenStream {
    quote!(#[cfg(all(mpc_neon, target_arch = "arm", target_feature = "neon"))])
}

/// The cfg of the portable kernels that NEON ones replace.
pub fn portable_cfg() -> TokenStream {
    quote!(#[cfg(not(all(mpc_neon, target_arch = "arm", target_feature = "neon")))])
}

/// Whether NEON kernels are emitted: f32 in exactly one 4-lane q register per step.
pub fn applies(p: &Problem) -> bool {
    p.scalar == Scalar::F32 && lane_count(p.nu) == 4
}

/// Blocks of four rows per pass over j: eight accumulators, y_j and one multiplier block fit the sixteen
/// q registers. Measured on the emulated A9 for `specs/paper.toml`: 27,140 instructions per control cycle
/// with two blocks per pass, 30,050 with one, 27,140 with three. Unrolling the loop over j makes LLVM
/// split every `vmla` into `vmul` + `vadd` (with `target-cpu=cortex-a9` it splits a VMLA whose
/// accumulator comes straight from another VMLA, a real A9 hazard), which costs more than the loop.
pub const PASS: usize = 2;

/// The layout of the `lanes` passes, NEON and portable alike: the blocks of four rows of each pass.
pub fn passes_layout(N: usize) -> Vec<Vec<usize>> {
    let blocks = N.div_ceil(4);
    (0..blocks)
        .step_by(PASS)
        .map(|first| (first..(first + PASS).min(blocks)).collect())
        .collect()
}

/// The NEON `lanes` kernels: proj as compare-and-selects, and the algorithm's fused iteration in blocks
/// of four rows, two blocks per pass over j, with one `vmla.f32 q, q, d[x]` per entry of H_axis.
pub fn lanes_kernels(N: usize, algorithm: &dyn Algorithm) -> TokenStream {
    let neon_cfg = cfg();
    let blocks_lit = Literal::usize_unsuffixed(N.div_ceil(4));
    let mut intrinsics: Vec<&str> = [
        "vget_high_f32",
        "vget_low_f32",
        "vld1q_f32",
        "vmlaq_lane_f32",
    ]
    .into_iter()
    .chain(algorithm.fused_row_neon_intrinsics().iter().copied())
    .collect();
    intrinsics.sort_unstable();
    intrinsics.dedup();
    let intrinsics = intrinsics.into_iter().map(|i| format_ident!("{}", i));
    let (name, params, doc) = (
        algorithm.fused_name(),
        algorithm.fused_params(),
        algorithm.fused_neon_doc(),
    );
    let body = passes(N, algorithm);
    quote! {
        #[doc = #doc]
        #neon_cfg
        #[inline]
        fn #name(#params) {
            use core::arch::arm::{#(#intrinsics),*};
            // SAFETY: NEON is enabled at compile time (the cfg above), and every pointer is to a live
            // `[f32; 4]`, which is what the 4-lane loads and stores read and write.
            unsafe {
                // Read the table through an opaque reference: with the constants in view, LLVM turns each
                // lane multiplier into a 16-byte splat in a literal pool and spills them all.
                let table: &[[[Real; 4]; N]; #blocks_lit] = core::hint::black_box(&H_BLOCKS);
                // An opaque trip count keeps each pass a loop: fully unrolled, the scheduler orders the
                // work accumulator by accumulator and spills every y_j and every multiplier.
                let rounds = core::hint::black_box(N);
                let (lo, hi) = (vld1q_f32(LO.as_ptr()), vld1q_f32(HI.as_ptr()));
                #body
            }
        }

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
    }
}

/// The passes of one NEON iteration: blocks in pairs, each pass N steps of up to eight multiply-adds, then
/// the algorithm's step for the pass's rows.
fn passes(N: usize, algorithm: &dyn Algorithm) -> TokenStream {
    let point = algorithm.point();
    let passes = passes_layout(N).into_iter().map(|pass| {
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
        let tables: Vec<_> = pass
            .iter()
            .map(|&b| format_ident!("h{}", b - first))
            .collect();
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
        let pattern = tables.iter().fold(quote!(ys), |acc, h| quote!((#acc, #h)));
        let step = pass.iter().flat_map(|&b| {
            (0..4).filter(move |l| 4 * b + l < N).map(move |l| {
                let i = Literal::usize_unsuffixed(4 * b + l);
                algorithm.fused_row_neon(&i, &acc(b, l))
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

/// NEON: one 4-lane operation through a register, for the lane helpers.
pub fn lane_op() -> TokenStream {
    let neon_cfg = cfg();
    quote! {
        /// NEON: one 4-lane operation, through a register.
        #neon_cfg
        #[inline(always)]
        fn lane_op(f: impl FnOnce(core::arch::arm::float32x4_t) -> core::arch::arm::float32x4_t, a: [Real; LANES]) -> [Real; LANES] {
            use core::arch::arm::{vld1q_f32, vst1q_f32};
            let mut out = [0.0; LANES];
            // SAFETY: NEON is enabled at compile time (the cfg above); both pointers are to live [f32; 4].
            unsafe { vst1q_f32(out.as_mut_ptr(), f(vld1q_f32(a.as_ptr()))) };
            out
        }
    }
}

/// The NEON twin of the lane operation `op` ([`super::matrix_free`] has the portable one).
pub fn lane_helper(op: &str) -> TokenStream {
    let neon_cfg = cfg();
    let (doc, body) = match op {
        "lane_add" => (
            " NEON: a + b.",
            quote! {
                fn lane_add(a: [Real; LANES], b: [Real; LANES]) -> [Real; LANES] {
                    use core::arch::arm::{vaddq_f32, vld1q_f32};
                    // SAFETY: as in `lane_op`.
                    lane_op(|a| unsafe { vaddq_f32(a, vld1q_f32(b.as_ptr())) }, a)
                }
            },
        ),
        "lane_sub" => (
            " NEON: a − b.",
            quote! {
                fn lane_sub(a: [Real; LANES], b: [Real; LANES]) -> [Real; LANES] {
                    use core::arch::arm::{vld1q_f32, vsubq_f32};
                    // SAFETY: as in `lane_op`.
                    lane_op(|a| unsafe { vsubq_f32(a, vld1q_f32(b.as_ptr())) }, a)
                }
            },
        ),
        "lane_scale" => (
            " NEON: c·a.",
            quote! {
                fn lane_scale(c: Real, a: [Real; LANES]) -> [Real; LANES] {
                    use core::arch::arm::vmulq_n_f32;
                    // SAFETY: as in `lane_op`.
                    lane_op(|a| unsafe { vmulq_n_f32(a, c) }, a)
                }
            },
        ),
        _ => (
            " NEON: acc + c·a.",
            quote! {
                fn lane_mul_add(acc: [Real; LANES], c: Real, a: [Real; LANES]) -> [Real; LANES] {
                    use core::arch::arm::{vld1q_f32, vmlaq_n_f32};
                    // SAFETY: as in `lane_op`.
                    lane_op(|acc| unsafe { vmlaq_n_f32(acc, vld1q_f32(a.as_ptr()), c) }, acc)
                }
            },
        ),
    };
    quote! {
        #[doc = #doc]
        #neon_cfg
        #[inline(always)]
        #body
    }
}
