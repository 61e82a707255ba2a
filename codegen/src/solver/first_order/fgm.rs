//! Nesterov's fast gradient method with constant momentum β = (1 − √(αμ)) / (1 + √(αμ)):
//! next = proj(y − α∇J(y)), y ← next + β(next − u), u ← next.
//!
//! With a step α ≤ 1/L, Δ_k ≤ 2(1 − √(αμ))^k · Δ_0 (Nesterov's constant step scheme,
//! Δ_k ≤ (1 − √(αμ))^k (Δ_0 + μ/2‖U_0 − U*‖²), and μ/2‖U_0 − U*‖² ≤ Δ_0 by strong convexity at the
//! constrained optimum), from any start in the box. Along an eigenvalue λ of H the error follows
//! e⁺ = (1+β)(1−αλ)e − β(1−αλ)e⁻, which is stable exactly when α < (2+2β)/((1+2β)λ).
#![allow(non_snake_case)]

use super::{bounded_step, Algorithm, Parameters, Point, Rate, StepFn};
use crate::linalg::spectral_radius;
use mpc_spec::Method;
use nalgebra::{DMatrix, DVector};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};

/// The fast gradient method.
#[derive(Clone, Copy, Debug)]
pub struct Fgm;

/// The one reference iteration, on plans or on matrices of plans.
fn run<V: Point>(beta: f64, start: V, iterations: usize, step: &dyn Fn(&V) -> V) -> V {
    let mut u = start;
    let mut y = u.clone();
    for _ in 0..iterations {
        let next = step(&y);
        y = next.extrapolate(&u, beta);
        u = next;
    }
    u
}

impl Algorithm for Fgm {
    fn method(&self) -> Method {
        Method::Fgm
    }

    fn title(&self) -> &'static str {
        "Nesterov's fast gradient method with constant momentum"
    }

    fn name(&self) -> &'static str {
        "FGM"
    }

    fn momentum(&self, step: f64, mu: f64) -> f64 {
        let r = (step * mu).min(1.0).sqrt();
        (1.0 - r) / (1.0 + r)
    }

    fn step_too_large(&self, p: &Parameters) -> Option<String> {
        let (step, momentum, L) = (p.step, p.momentum, p.L);
        let limit = (2.0 + 2.0 * momentum) / ((1.0 + 2.0 * momentum) * L);
        (step >= limit).then(|| {
            format!("below (2+2β)/((1+2β)L) = {limit:.6} (β = {momentum:.4}, L = {L:.6}), or the fast gradient iteration diverges")
        })
    }

    fn rate(&self, p: &Parameters) -> Option<Rate> {
        let (step, mu) = (p.step, p.mu);
        bounded_step(step, p.L).then(|| Rate {
            constant: 2.0,
            factor: 1.0 - (step * mu).min(1.0).sqrt(),
        })
    }

    fn bound_form(&self) -> &'static str {
        "≤ 2·(1 − √(αμ))^k · Δ_0"
    }

    fn contraction_at(&self, p: &Parameters, lambda: f64) -> f64 {
        let a = 1.0 - p.step * lambda;
        let b = p.momentum;
        spectral_radius(&DMatrix::from_row_slice(
            2,
            2,
            &[(1.0 + b) * a, -b * a, 1.0, 0.0],
        ))
    }

    fn reference(
        &self,
        p: &Parameters,
        start: DVector<f64>,
        iterations: usize,
        step: StepFn<DVector<f64>>,
    ) -> DVector<f64> {
        run(p.momentum, start, iterations, step)
    }

    fn reference_linear(
        &self,
        p: &Parameters,
        start: DMatrix<f64>,
        iterations: usize,
        step: StepFn<DMatrix<f64>>,
    ) -> Option<DMatrix<f64>> {
        Some(run(p.momentum, start, iterations, step))
    }

    fn update_macs(&self, entries: usize) -> usize {
        // The projected step and the momentum.
        2 * entries
    }

    fn step_doc(&self, p: &Parameters) -> String {
        format!(" The step α = {} (1/L = {:.6e}).", p.step, 1.0 / p.L)
    }

    fn momentum_doc(&self, p: &Parameters) -> String {
        format!(
            " Nesterov momentum β = (1 − √(αμ)) / (1 + √(αμ)), μ = {:.6e}.",
            p.mu
        )
    }

    fn point(&self) -> TokenStream {
        quote!(y)
    }

    fn iterations(&self, gradient_call: &TokenStream, steps: &TokenStream) -> TokenStream {
        quote! {
            let mut y = u;
            let mut g: Plan = [[0.0; LANES]; #steps];
            for _ in 0..ITERATIONS {
                #gradient_call;
                fast_gradient_step(&mut u, &mut y, &g);
            }
        }
    }

    fn step_kernel(&self) -> TokenStream {
        quote! {
            /// The fast gradient step: next = proj(y − STEP·g), y ← next + MOMENTUM·(next − u), u ← next.
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

    fn fused_name(&self) -> Ident {
        format_ident!("fast_gradient_iteration")
    }

    fn fused_params(&self) -> TokenStream {
        quote!(u: &mut Plan, y: &Plan, y_next: &mut Plan, f: &Plan)
    }

    fn fused_doc(&self, macs: usize, lanes: usize) -> String {
        format!(
            " One FGM iteration, row by row: g_i = f_i + Σ_j H_AXIS[i][j]·y_j ({macs} lane-wise multiply-adds of {lanes} lanes), next = proj(y_i − STEP·g_i), y_next_i = next + MOMENTUM·(next − u_i), u_i = next."
        )
    }

    fn fused_neon_doc(&self) -> &'static str {
        " NEON: one FGM iteration, four rows per block, two blocks per pass over j."
    }

    fn fused_iterations(&self) -> TokenStream {
        quote! {
            let mut y = u;
            let mut y_next: Plan = [[0.0; LANES]; N];
            for _ in 0..ITERATIONS / 2 {
                fast_gradient_iteration(&mut u, &y, &mut y_next, &f);
                fast_gradient_iteration(&mut u, &y_next, &mut y, &f);
            }
            if ITERATIONS % 2 == 1 {
                fast_gradient_iteration(&mut u, &y, &mut y_next, &f);
            }
        }
    }

    fn fused_row(&self, i: &Literal, g: &Ident) -> TokenStream {
        quote! {
            let lanes = u[#i].iter_mut().zip(y_next[#i].iter_mut()).zip(y[#i].iter().zip(#g.iter()));
            for (((u, y_next), (y, g)), (lo, hi)) in lanes.zip(LO.iter().zip(HI.iter())) {
                let next = project(*y - STEP * *g, *lo, *hi);
                *y_next = next + MOMENTUM * (next - *u);
                *u = next;
            }
        }
    }

    fn fused_row_neon_intrinsics(&self) -> &'static [&'static str] {
        &[
            "vld1q_f32",
            "vmlaq_n_f32",
            "vmlsq_n_f32",
            "vst1q_f32",
            "vsubq_f32",
        ]
    }

    fn fused_row_neon(&self, i: &Literal, g: &Ident) -> TokenStream {
        quote! {
            let next = project_lanes(vmlsq_n_f32(vld1q_f32(y[#i].as_ptr()), #g, STEP), lo, hi);
            let previous = vld1q_f32(u[#i].as_ptr());
            vst1q_f32(y_next[#i].as_mut_ptr(), vmlaq_n_f32(next, vsubq_f32(next, previous), MOMENTUM));
            vst1q_f32(u[#i].as_mut_ptr(), next);
        }
    }
}
