//! The `report` submodule: the certificate as constants, so that firmware and tests can read what the
//! compiler proved.

use crate::certificate::Certificate;
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// `pub mod report { ... }`.
pub fn emit(c: &Certificate) -> TokenStream {
    let f = |v: f64| {
        if v.is_finite() {
            let l = Literal::f64_suffixed(v);
            quote!(#l)
        } else {
            quote!(f64::NAN)
        }
    };
    let u = |v: usize| Literal::usize_unsuffixed(v);
    let opt_u = |v: Option<usize>| match v {
        Some(v) => {
            let l = u(v);
            quote!(Some(#l))
        }
        None => quote!(None),
    };
    let opt_f = |v: Option<f64>| match v {
        Some(v) => {
            let l = f(v);
            quote!(Some(#l))
        }
        None => quote!(None),
    };
    let matrix = |m: &nalgebra::DMatrix<f64>| {
        let rows = m.row_iter().map(|r| {
            let items = r.iter().map(|v| f(*v)).collect::<Vec<_>>();
            quote!([#(#items),*])
        });
        quote!([#(#rows),*])
    };
    let (lipschitz, strong_convexity, condition_number) =
        (f(c.lipschitz), f(c.strong_convexity), f(c.condition_number));
    let (step, momentum, contraction, tolerance) =
        (f(c.step), f(c.momentum), f(c.contraction), f(c.tolerance));
    let iterations = u(c.iterations);
    let iterations_bound = opt_u(c.iterations_bound);
    let guaranteed_gap = opt_f(c.guaranteed_gap);
    let (rate_constant, rate_factor) = (
        opt_f(c.rate.map(|r| r.constant)),
        opt_f(c.rate.map(|r| r.factor)),
    );
    let (lqr_gain, lqr_rho, lyap_min, lyap_max) = (
        matrix(&c.lqr.gain),
        f(c.lqr.spectral_radius),
        f(c.lqr.lyapunov_min),
        f(c.lqr.lyapunov_max),
    );
    let (mpc_gain, mpc_rho, solver_rho) = (
        matrix(&c.mpc.gain),
        f(c.mpc.spectral_radius),
        opt_f(c.mpc.solver_spectral_radius),
    );
    let disturbance_tau = opt_f(c.disturbance_time_constant);
    let r = &c.resources;
    let (macs_iter, macs_cycle, bytes_constants) = (
        u(r.macs_per_iteration),
        u(r.macs_per_cycle),
        u(r.bytes_constants),
    );
    let (bytes_mpc, bytes_kalman, bytes_state) = (
        u(r.bytes_state_mpc),
        u(r.bytes_state_kalman),
        u(r.bytes_state),
    );
    quote! {
        /// What the compiler proved and counted about this controller (see `codegen::certificate` for the
        /// bounds' forms). Every number is f64, computed once at compile time.
        pub mod report {
            use super::{NU, NX};
            /// L, the largest eigenvalue of the Hessian H.
            pub const LIPSCHITZ: f64 = #lipschitz;
            /// μ, the smallest eigenvalue of H.
            pub const STRONG_CONVEXITY: f64 = #strong_convexity;
            /// L/μ.
            pub const CONDITION_NUMBER: f64 = #condition_number;
            /// The step α.
            pub const STEP: f64 = #step;
            /// The momentum β (0 for the projected gradient method).
            pub const MOMENTUM: f64 = #momentum;
            /// The asymptotic contraction of the solver's error per iteration, constraints inactive.
            pub const CONTRACTION: f64 = #contraction;
            /// Iterations per control step.
            pub const ITERATIONS: usize = #iterations;
            /// The relative suboptimality the bound is stated for: J(U_k) − J* ≤ TOLERANCE·(J(U_0) − J*).
            pub const TOLERANCE: f64 = #tolerance;
            /// The a priori bound J(U_k) − J* ≤ C·ρᵏ·(J(U_0) − J*): (C, ρ); `None` for a step above 1/L.
            pub const RATE: Option<(f64, f64)> = match (#rate_constant, #rate_factor) {
                (Some(c), Some(r)) => Some((c, r)),
                _ => None,
            };
            /// The iterations the bound needs for TOLERANCE from any start in the box.
            pub const ITERATIONS_BOUND: Option<usize> = #iterations_bound;
            /// What ITERATIONS guarantee: (J(U_m) − J*)/(J(U_0) − J*) is at most this.
            pub const GUARANTEED_GAP: Option<f64> = #guaranteed_gap;
            /// The paper's check (Section 2.4.3): the LQR gain of the stage weights Q, R.
            pub const LQR_GAIN: [[f64; NX]; NU] = #lqr_gain;
            /// ρ(F − G·K_LQR).
            pub const LQR_SPECTRAL_RADIUS: f64 = #lqr_rho;
            /// λmin of P solving (F − GK)ᵀP(F − GK) − P = −I.
            pub const LQR_LYAPUNOV_MIN: f64 = #lyap_min;
            /// λmax of that P.
            pub const LQR_LYAPUNOV_MAX: f64 = #lyap_max;
            /// The unconstrained receding-horizon gain (first block of H⁻¹·Fx): u = −K·x at zero reference.
            pub const MPC_GAIN: [[f64; NX]; NU] = #mpc_gain;
            /// ρ(F − G·K_MPC): the loop an exactly solved, unconstrained MPC closes.
            pub const MPC_SPECTRAL_RADIUS: f64 = #mpc_rho;
            /// ρ of the loop the fixed-iteration, warm-started solver closes, in (x, previous plan).
            pub const MPC_SOLVER_SPECTRAL_RADIUS: Option<f64> = #solver_rho;
            /// Multiply-adds of one solver iteration.
            pub const MACS_PER_ITERATION: usize = #macs_iter;
            /// Multiply-adds of one control cycle (filter, gradient map, every iteration).
            pub const MACS_PER_CYCLE: usize = #macs_cycle;
            /// Bytes of coefficients inlined into the code.
            pub const BYTES_CONSTANTS: usize = #bytes_constants;
            /// Bytes of `Mpc`.
            pub const BYTES_STATE_MPC: usize = #bytes_mpc;
            /// Bytes of `Kalman`.
            pub const BYTES_STATE_KALMAN: usize = #bytes_kalman;
            /// Bytes of `Controller`, all the state carried between cycles.
            pub const BYTES_STATE: usize = #bytes_state;
            /// The disturbance estimate's time constant, s (with `[kalman] disturbance`).
            pub const DISTURBANCE_TIME_CONSTANT: Option<f64> = #disturbance_tau;
        }
    }
}
