//! Projected gradient, the paper's Algorithm 1: u ← proj(u − α∇J(u)).
//!
//! With the gap Δ_k = J(U_k) − J* and a step α ≤ 1/L, Δ_k ≤ (1 − αμ)^k · Δ_0 (the proximal-PL rate of
//! Karimi, Nutini and Schmidt 2016, with 1/α ≥ L as the smoothness constant), from any start in the box.
//! It converges for α < 2/L.
#![allow(non_snake_case)]

use super::{bounded_step, Algorithm, Parameters, Point, Rate, StepFn};
use mpc_spec::Method;
use nalgebra::{DMatrix, DVector};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};

/// The projected gradient method.
#[derive(Clone, Copy, Debug)]
pub struct Gradient;

/// The one reference iteration, on plans or on matrices of plans.
fn run<V: Point>(start: V, iterations: usize, step: &dyn Fn(&V) -> V) -> V {
    let mut u = start;
    for _ in 0..iterations {
        u = step(&u);
    }
    u
}

impl Algorithm for Gradient {
    fn method(&self) -> Method {
        Method::Gradient
    }

    fn title(&self) -> &'static str {
        "Projected gradient (the paper's Algorithm 1)"
    }

    fn name(&self) -> &'static str {
        "projected gradient"
    }

    fn momentum(&self, _step: f64, _mu: f64) -> f64 {
        0.0
    }

    fn step_too_large(&self, p: &Parameters) -> Option<String> {
        let (step, L) = (p.step, p.L);
        (step >= 2.0 / L).then(|| {
            format!(
                "below 2/L = {:.6} (L = {L:.6}), or the projected gradient iteration diverges",
                2.0 / L
            )
        })
    }

    fn rate(&self, p: &Parameters) -> Option<Rate> {
        let (step, mu) = (p.step, p.mu);
        bounded_step(step, p.L).then(|| Rate {
            constant: 1.0,
            factor: 1.0 - (step * mu).min(1.0),
        })
    }

    fn bound_form(&self) -> &'static str {
        "≤ (1 − αμ)^k · Δ_0"
    }

    fn contraction_at(&self, p: &Parameters, lambda: f64) -> f64 {
        (1.0 - p.step * lambda).abs()
    }

    fn reference(
        &self,
        _p: &Parameters,
        start: DVector<f64>,
        iterations: usize,
        step: StepFn<DVector<f64>>,
    ) -> DVector<f64> {
        run(start, iterations, step)
    }

    fn reference_linear(
        &self,
        _p: &Parameters,
        start: DMatrix<f64>,
        iterations: usize,
        step: StepFn<DMatrix<f64>>,
    ) -> Option<DMatrix<f64>> {
        Some(run(start, iterations, step))
    }

    fn update_macs(&self, entries: usize) -> usize {
        entries
    }

    fn step_doc(&self, p: &Parameters) -> String {
        format!(
            " The step α of Algorithm 1, line 4 (1/L = {:.6e}).",
            1.0 / p.L
        )
    }

    fn momentum_doc(&self, _p: &Parameters) -> String {
        " Zero: the projected gradient method has no momentum.".to_string()
    }

    fn point(&self) -> TokenStream {
        quote!(u)
    }

    fn iterations(&self, gradient_call: &TokenStream, steps: &TokenStream) -> TokenStream {
        quote! {
            // Every kernel works in place: no plan is copied inside the loop.
            let mut g: Plan = [[0.0; LANES]; #steps];
            for _ in 0..ITERATIONS {
                #gradient_call;
                gradient_step(&mut u, &g);
            }
        }
    }

    fn step_kernel(&self) -> TokenStream {
        quote! {
            /// u ← proj(u − STEP·g) (Algorithm 1, lines 4-5).
            #[inline(always)]
            fn gradient_step(u: &mut Plan, g: &Plan) {
                for (u_k, g_k) in u.iter_mut().zip(g.iter()) {
                    for (((u, g), lo), hi) in u_k.iter_mut().zip(g_k.iter()).zip(LO.iter()).zip(HI.iter()) {
                        *u = project(*u - STEP * *g, *lo, *hi);
                    }
                }
            }
        }
    }

    fn fused_name(&self) -> Ident {
        format_ident!("gradient_iteration")
    }

    fn fused_params(&self) -> TokenStream {
        quote!(u: &Plan, next: &mut Plan, f: &Plan)
    }

    fn fused_doc(&self, macs: usize, lanes: usize) -> String {
        format!(
            " One projected gradient iteration (Algorithm 1, lines 3-5), row by row: g_i = f_i + Σ_j H_AXIS[i][j]·u_j ({macs} lane-wise multiply-adds of {lanes} lanes), next_i = proj(u_i − STEP·g_i)."
        )
    }

    fn fused_neon_doc(&self) -> &'static str {
        " NEON: one projected gradient iteration, four rows per block, two blocks per pass over j."
    }

    fn fused_iterations(&self) -> TokenStream {
        quote! {
            let mut next: Plan = u;
            for _ in 0..ITERATIONS / 2 {
                gradient_iteration(&u, &mut next, &f);
                gradient_iteration(&next, &mut u, &f);
            }
            if ITERATIONS % 2 == 1 {
                gradient_iteration(&u, &mut next, &f);
                u = next;
            }
        }
    }

    fn fused_row(&self, i: &Literal, g: &Ident) -> TokenStream {
        quote! {
            let lanes = next[#i].iter_mut().zip(u[#i].iter().zip(#g.iter()));
            for ((next, (u, g)), (lo, hi)) in lanes.zip(LO.iter().zip(HI.iter())) {
                *next = project(*u - STEP * *g, *lo, *hi);
            }
        }
    }

    fn fused_row_neon_intrinsics(&self) -> &'static [&'static str] {
        &["vld1q_f32", "vmlsq_n_f32", "vst1q_f32"]
    }

    fn fused_row_neon(&self, i: &Literal, g: &Ident) -> TokenStream {
        quote! {
            let stepped = vmlsq_n_f32(vld1q_f32(u[#i].as_ptr()), #g, STEP);
            vst1q_f32(next[#i].as_mut_ptr(), project_lanes(stepped, lo, hi));
        }
    }
}
