//! The emitter: `quote!` only, no math. It turns a lowered [`Problem`] into the generated module.

pub use crate::plan::WRITE_OUT_BUDGET;
mod controller;
mod kalman;
mod report;
mod screening;
pub mod sections;
pub mod solve_api;
pub mod sparse;
mod support;
pub mod tokens;

pub use sections::Sections;

use crate::certify::certificate::Certificate;
use crate::lower::problem::Problem;
use crate::numeric::Numeric;
use crate::plan::Plan;
use proc_macro2::{Ident, Literal, TokenStream};
use quote::quote;
use tokens::Num;

/// Where the spec came from, for the module's docs and for rebuild tracking.
#[derive(Clone, Debug)]
pub enum Origin {
    /// A file: its absolute path is `include_str!`-ed so that editing it rebuilds the user's crate.
    File {
        /// The path as the user wrote it.
        written: String,
        /// The absolute path.
        absolute: String,
    },
    /// Spec text written inside the macro call.
    Inline,
    /// A file named in the docs only, without rebuild tracking: `mpcc emit`'s output, which must not
    /// depend on the machine it was made on.
    Named(String),
}

/// Whether an f32 literal in `tokens` is the f32 of one of the constants clippy's `approx_constant` knows.
fn rounds_to_a_std_constant(tokens: &TokenStream) -> bool {
    use std::f64::consts as c;
    const CONSTANTS: [f64; 19] = [
        c::E,
        c::FRAC_1_PI,
        c::FRAC_1_SQRT_2,
        c::FRAC_2_PI,
        c::FRAC_2_SQRT_PI,
        c::FRAC_PI_2,
        c::FRAC_PI_3,
        c::FRAC_PI_4,
        c::FRAC_PI_6,
        c::FRAC_PI_8,
        c::LN_10,
        c::LN_2,
        c::LOG10_E,
        c::LOG2_E,
        c::LOG2_10,
        c::LOG10_2,
        c::PI,
        c::SQRT_2,
        c::TAU,
    ];
    tokens.clone().into_iter().any(|t| match t {
        proc_macro2::TokenTree::Group(g) => rounds_to_a_std_constant(&g.stream()),
        proc_macro2::TokenTree::Literal(l) => l
            .to_string()
            .strip_suffix("f32")
            .and_then(|v| v.parse::<f32>().ok())
            .is_some_and(|v| CONSTANTS.iter().any(|k| *k as f32 == v)),
        _ => false,
    })
}

/// The generated module `vis mod name { ... }`.
pub fn module(
    p: &Problem,
    plan: &Plan,
    certificate: &Certificate,
    vis: &TokenStream,
    name: &Ident,
    origin: &Origin,
) -> TokenStream {
    let num = Num(p.scalar);
    let items = items(p, plan, num);
    let report = report::emit(certificate, &p.qp.backoff);
    // Only the lints the code needs, each where it is needed: the paper's names (P, S_inv, FP) and
    // `!(d > 0.0)` (the NaN-aware pivot test) in the time-varying filter, S_inv and `!(nis <= GATE)` in
    // the gate; the target's own cfg where NEON
    // kernels are emitted; and tables above clippy's 16 KiB for const arrays (H, FR at long horizons),
    // which stay `const` for const contexts: the code reads them by reference, so they are promoted to
    // statics, never copied.
    let time_varying = p
        .filter
        .as_ref()
        .is_some_and(|f| f.kind == mpc_spec::FilterKind::TimeVarying || f.screening.gate.is_some())
        .then(|| quote!(non_snake_case, clippy::neg_cmp_op_on_partial_ord,));
    let neon_cfg = plan
        .form
        .gradient()
        .uses_neon(p)
        .then(|| quote!(unexpected_cfgs,));
    let largest_table = plan.solver.largest_table(p);
    let large_tables = (largest_table > 16 * 1024).then(|| quote!(clippy::large_const_arrays,));
    // A spec's value rounded to f32 that is a std constant's f32 (an angle bound of π/6 as
    // -0.5235988f32) reads to clippy as an approximation of it: the value is the spec's, not a constant's.
    let approx = rounds_to_a_std_constant(&items).then(|| quote!(clippy::approx_constant,));
    let allow = quote!(#time_varying #neon_cfg #large_tables #approx);
    let allow = (!allow.is_empty()).then(|| quote!(#![allow(#allow)]));
    let halves = if p.filter.is_some() {
        " [`Controller::step`] runs one control cycle; [`Mpc`] and [`Kalman`] are its two halves."
    } else {
        " [`Controller::step`] runs one control cycle from the measured state (no filter); [`Mpc`] solves."
    };
    let (algorithm, shape) = (plan.solver.title(), plan.solver.shape_doc(p, plan));
    let note = plan
        .solver
        .emission_note()
        .map(|note| quote!(#[doc = #note]));
    let summary = format!(" {algorithm}: {} iterations per step,", p.qp.iterations);
    let range = &certificate.coordinate_range;
    let coordinates = format!(
        " Absolute coordinates up to |{}| ≤ {:.1e} keep u₀ within {} % of the input span in {}",
        range.names(),
        range.of(p.scalar),
        range.accuracy * 100.0,
        Numeric(p.scalar).name()
    );
    let beyond = format!(
        " (`report::COORDINATE_RANGE_{}`); beyond, give the controller coordinates from a local origin.",
        Numeric(p.scalar).name().to_uppercase()
    );
    let (doc, track) = match origin {
        Origin::File { written, absolute } => (
            format!(" Controller generated by `mpc!` from `{written}`."),
            quote! {
                // Makes cargo rebuild this crate when the spec changes.
                const _: &str = include_str!(#absolute);
            },
        ),
        Origin::Inline => (
            " Controller generated by `mpc!` from an inline spec.".to_string(),
            quote!(),
        ),
        Origin::Named(name) => (
            format!(" Controller generated by `mpcc emit` from `{name}`."),
            quote!(),
        ),
    };
    quote! {
        #[doc = #doc]
        ///
        #[doc = #summary]
        #[doc = #shape]
        #note
        #[doc = #halves]
        /// Every constant was computed at compile time in f64 and rounded once to [`Real`].
        #[doc = #coordinates]
        #[doc = #beyond]
        ///
        /// Reading order: dimensions and parameters, the public types, their kernels, the constant tables,
        /// and the `report` of what the compiler proved.
        #vis mod #name {
            #allow
            #track
            #items
            #report
        }
    }
}

/// The number of blocks of the emitted plan: `N`, or `CONTROL_HORIZON` under a control horizon.
pub fn plan_steps(p: &Problem) -> TokenStream {
    if p.qp.blocked() {
        quote!(CONTROL_HORIZON)
    } else {
        quote!(N)
    }
}

/// The plan's N steps from the iterator `blocks` over its blocks: under move blocking each block
/// repeated for its `MOVE_BLOCKS` steps. What every method's `Mpc::plan` expands.
pub fn held_steps(p: &Problem, blocks: TokenStream) -> TokenStream {
    if p.qp.blocked() {
        quote!(#blocks.zip(MOVE_BLOCKS).flat_map(|(block, steps)| core::iter::repeat_n(block, steps)))
    } else {
        blocks
    }
}

/// The input that plan entry `i` drives: `i % NU`, or `0` for a single input (clippy's
/// `modulo_one` would flag `i % 1` in the generated module).
pub fn input_of(p: &Problem) -> TokenStream {
    if p.nu == 1 {
        quote!(0)
    } else {
        quote!(i % NU)
    }
}

/// The name of a helper's plan-entry parameter that [`input_of`] reads: `_i` when a single input
/// leaves it unread (rustc's `unused_variables` in the generated module).
pub fn entry_param(p: &Problem) -> TokenStream {
    if p.nu == 1 {
        quote!(_i)
    } else {
        quote!(i)
    }
}

/// The module's items without the `mod` wrapper.
pub fn items(p: &Problem, plan: &Plan, num: Num) -> TokenStream {
    let qp = &p.qp;
    let real = num.ty();
    let (nx, nu, ny, n, iterations) = (p.nx, p.nu, p.ny, qp.N, qp.iterations);
    let [nx, nu, ny, n, iterations] = [nx, nu, ny, n, iterations].map(Literal::usize_unsuffixed);
    let nz = Literal::usize_unsuffixed(qp.Nc * p.nu);
    let nr = Literal::usize_unsuffixed(qp.N * qp.nz);
    let dt = num.lit(p.dt);
    let control_horizon = qp.blocked().then(|| {
        let nc = Literal::usize_unsuffixed(qp.Nc);
        let blocks = qp.blocks.iter().map(|&b| Literal::usize_unsuffixed(b));
        let doc = if qp.held_tail() {
            " Control horizon Nc: the plan holds the free inputs u_0 … u_{Nc−1}; u_k = u_{Nc−1} for k ≥ Nc."
        } else {
            " Move blocking: the plan holds one free input per block, Nc blocks."
        };
        quote! {
            #[doc = #doc]
            pub const CONTROL_HORIZON: usize = #nc;
            /// The blocks' lengths in steps (they sum to N): the plan's block j drives `MOVE_BLOCKS[j]` steps.
            pub const MOVE_BLOCKS: [usize; CONTROL_HORIZON] = [#(#blocks),*];
        }
    });
    let u_min = num.vector(qp.u_min.iter().copied());
    let u_max = num.vector(qp.u_max.iter().copied());
    let u_rest = num.vector(qp.rest_input().iter().copied());
    // The interior-point method computes in f64 whatever `Real` is: its tables are f64. The others
    // compute in `Real`.
    let (wide, table) = if plan.solver.widens() {
        (Num(mpc_spec::Scalar::F64), quote!(f64))
    } else {
        (num, quote!(Real))
    };
    let (h, fx, fr) = (num.matrix(&qp.H), wide.matrix(&qp.Fx), wide.matrix(&qp.Fr));
    let (f, g) = (num.matrix(&p.F), num.matrix(&p.G));
    let nd = p.nd();
    // The tracked outputs: NZ and C_z with `outputs`; without, the state is tracked and the reference
    // window keeps its NX columns.
    let (output_dimensions, output_table) = match &qp.Cz {
        Some(outputs) => {
            let nz_lit = Literal::usize_unsuffixed(qp.nz);
            let cz = num.matrix(outputs);
            (
                quote! {
                    /// Tracked outputs z = C_z·x (`[mpc] outputs`): the reference window has NZ columns.
                    pub const NZ: usize = #nz_lit;
                },
                quote! {
                    /// The output map C_z of `[mpc] outputs`: z = C_z·x.
                    pub const CZ: [[Real; NX]; NZ] = #cz;
                },
            )
        }
        None => (quote!(), quote!()),
    };
    let moves_table = p.has_moves().then(|| {
        let fu = wide.matrix(&qp.Fu);
        quote! {
            /// Fu = −2 Dᵀ R_du_blk E: the gradient's dependence on the last input, f gains Fu·u₋₁.
            pub const FU: [[#table; NU]; #nz] = #fu;
        }
    });
    // The filter's state: x, or (x, d) with a disturbance model.
    let ns = if nd > 0 { quote!(NA) } else { quote!(NX) };
    let (disturbance_dimensions, disturbance_table) = if nd > 0 {
        let nd_lit = Literal::usize_unsuffixed(nd);
        let fd = wide.matrix(&qp.Fd);
        (
            quote! {
                /// Disturbance states: one constant input disturbance per input channel (offset-free MPC).
                pub const ND: usize = #nd_lit;
                /// The filter's state dimension: the state, then the disturbance.
                pub const NA: usize = NX + ND;
            },
            {
                let doc = if p.has_moves() {
                    " Fd = H·(1_N ⊗ I) + Fu: the gradient's dependence on the estimated disturbance, f = Fx·x0 − Fr·Xref + Fu·u₋₁ + Fd·d."
                } else {
                    " Fd = H·(1_N ⊗ I): the gradient's dependence on the estimated disturbance, f = Fx·x0 − Fr·Xref + Fd·d."
                };
                quote! {
                    #[doc = #doc]
                    pub const FD: [[#table; ND]; #nz] = #fd;
                }
            },
        )
    } else {
        (quote!(), quote!())
    };
    let filter_tables = p.filter.as_ref().map(|filter| {
        let (qn, rn, p0) = (
            num.matrix(&filter.Qn),
            num.matrix(&filter.Rn),
            num.matrix(&filter.P0),
        );
        let (k_inf, p_inf) = (num.matrix(&filter.K_inf), num.matrix(&filter.P_inf));
        quote! {
            /// Process noise covariance Q, eq. 3 (with the disturbance's random walk last, if modelled).
            pub const Q_NOISE: [[Real; #ns]; #ns] = #qn;
            /// Measurement noise covariance R.
            pub const R_NOISE: [[Real; NY]; NY] = #rn;
            /// Initial covariance P0.
            pub const P0: [[Real; #ns]; #ns] = #p0;
            /// Steady-state prior covariance P∞ of the discrete Riccati recursion.
            pub const P_INF: [[Real; #ns]; #ns] = #p_inf;
            /// Steady-state Kalman gain K∞ = P∞ Cᵀ (C P∞ Cᵀ + R)⁻¹.
            pub const K_INF: [[Real; NY]; #ns] = #k_inf;
        }
    });
    let measurement_table = p.filter.is_some().then(|| {
        let c = num.matrix(&p.C);
        quote! {
            /// Measurement matrix C (the paper's H of eq. 2).
            pub const C: [[Real; NX]; NY] = #c;
        }
    });
    let ny_doc = if p.filter.is_some() {
        " Measurement dimension."
    } else {
        " Measurement dimension: the state, measured (no filter)."
    };
    let parameters = plan.solver.parameter_constants(p, num);
    let fr_doc = if qp.Cz.is_some() {
        " Fr = 2 Suᵀ Qr_blk, Qr = C_zᵀ·W (eq. 10 for outputs), acting on the output references stacked."
    } else {
        " Fr = 2 Suᵀ Q_blk (eq. 10), acting on Xref = [xref₁; …; xref_N] (eq. 14)."
    };
    let h_doc = format!(
        " Hessian H = 2(Suᵀ Q_blk Su + R_blk), eq. 9; (N·NU)×(N·NU), L = {:.6e}, μ = {:.6e}.",
        qp.L, qp.mu
    );
    // The constrained methods' H carries the slacks: their emitters write it.
    let h_table = plan.solver.skeleton_writes_h().then(|| {
        quote! {
            #[doc = #h_doc]
            pub const H: [[Real; #nz]; #nz] = #h;
        }
    });
    let mpc = plan.solver.emit(p, plan, num);
    let kalman = p
        .filter
        .as_ref()
        .map(|f| kalman::emit(p, f, num))
        .unwrap_or_default();
    let support = support::emit(p, plan, plan.solver.projects());
    let Sections {
        constants: mpc_constants,
        api: mpc_api,
        kernels: mpc_kernels,
        tables: mpc_tables,
    } = mpc;
    let Sections {
        constants: kalman_constants,
        api: kalman_api,
        kernels: kalman_kernels,
        tables: kalman_tables,
    } = kalman;
    let (controller_api, controller_kernels) = controller::emit(p, plan.solver.fallback_name());
    quote! {
        /// The scalar type of this controller.
        pub type Real = #real;
        /// State dimension.
        pub const NX: usize = #nx;
        /// Input dimension.
        pub const NU: usize = #nu;
        #[doc = #ny_doc]
        pub const NY: usize = #ny;
        /// Prediction horizon.
        pub const N: usize = #n;
        #control_horizon
        /// Solver iterations per control step.
        pub const ITERATIONS: usize = #iterations;
        /// Sampling time, s.
        pub const DT: Real = #dt;
        #parameters
        /// Lower input bounds (eq. 6).
        pub const U_MIN: [Real; NU] = #u_min;
        /// Upper input bounds (eq. 6).
        pub const U_MAX: [Real; NU] = #u_max;
        /// The input that cold starts use and warm starts append: zero projected onto the box.
        pub const U_REST: [Real; NU] = #u_rest;
        #output_dimensions
        #disturbance_dimensions
        #mpc_constants

        #kalman_constants

        #controller_api
        #mpc_api
        #kalman_api

        #controller_kernels
        #mpc_kernels
        #kalman_kernels
        #support

        /// State transition F, eq. 2.
        pub const F: [[Real; NX]; NX] = #f;
        /// Input matrix G, eq. 2.
        pub const G: [[Real; NU]; NX] = #g;
        #measurement_table
        #output_table
        #h_table
        /// Fx = 2 Suᵀ Q_blk Sx (eq. 10): f = Fx·x0 − Fr·Xref.
        pub const FX: [[#table; NX]; #nz] = #fx;
        #[doc = #fr_doc]
        pub const FR: [[#table; #nr]; #nz] = #fr;
        #moves_table
        #disturbance_table
        #filter_tables
        #mpc_tables
        #kalman_tables
    }
}
