//! Measurement screening, shared by both filter kinds: what a reading must pass before the Kalman update
//! fuses it (finite, not stuck, inside the χ² gate), re-acquisition after a run of gated readings or a
//! start without an estimate, the bound on the disturbance estimate, and the [`FilterStatus`] that
//! reports all of it.
//!
//! The filter kinds differ only in where S⁻¹ comes from (a constant for the steady-state filter, or a
//! row of its restart table after a re-acquisition; the covariance for the time-varying one) and in what
//! re-acquisition restarts (P at P0, or the restart table); the rest is here.
#![allow(non_snake_case)]

use super::sections::Sections;
use super::tokens::{at1, Num};
use crate::lower::problem::{Filter, Problem};
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// The parts of the filter that screening adds, spliced into `Kalman` by `kalman.rs`.
pub struct Screen {
    /// `Kalman`'s fields: the reading history, the gated run and the status.
    pub fields: TokenStream,
    /// Their initial values in `const fn new` (binds nothing; uses `valid`).
    pub init: TokenStream,
    /// `update`, `status` and the private `screen` prologue up to the gate, then `fuse` (the kind's
    /// arithmetic) and `reacquire`.
    pub methods: TokenStream,
    /// The public types, constants, kernels and tables.
    pub sections: Sections,
}

/// What the screening of `p` emits. `s_inverse` binds `S_inv` (or returns `Measurement::Numerical`) when
/// the gate or the update needs it,
/// `fuse` computes and commits the update from `innovation` and returns the measurement's verdict, and
/// `reset_covariance` is run on re-acquisition, which restarts `what` (for its doc).
pub fn emit(
    p: &Problem,
    f: &Filter,
    num: Num,
    s_inverse: TokenStream,
    fuse: TokenStream,
    reset_covariance: TokenStream,
    what: &str,
) -> Screen {
    let gate = f.screening.gate;
    let history = keeps_history(f);
    let mut fields = quote!();
    let mut init = quote!();
    if history {
        fields.extend(quote! {
            last: [Real; NY],
            repeats: u32,
        });
        init.extend(quote!(last: [0.0; NY], repeats: 0,));
    }
    if gate.is_some() {
        fields.extend(quote!(gated: u32,));
        init.extend(quote!(gated: 0,));
    }
    fields.extend(quote!(status: FilterStatus,));
    init.extend(quote!(status: FilterStatus::new(valid),));
    Screen {
        fields,
        init,
        methods: methods(f, s_inverse, fuse, reset_covariance, what),
        sections: Sections {
            constants: constants(p, f, num),
            api: api(f.nd),
            kernels: kernels(p, f, num),
            tables: tables(f, num),
        },
    }
}

/// Whether the last reading is kept: when a stuck sensor is detected or a gated run must tell a
/// changing reading from a repeated one.
fn keeps_history(f: &Filter) -> bool {
    f.screening.stuck_cycles.is_some() || f.screening.gate.is_some()
}

/// `Kalman`'s screening methods: `update`, `status`, `has_estimate`, `screen` and `reacquire`.
fn methods(
    f: &Filter,
    s_inverse: TokenStream,
    fuse: TokenStream,
    reset_covariance: TokenStream,
    what: &str,
) -> TokenStream {
    let reacquire_doc = format!(" the rest and the disturbance kept), and restarts {what}.");
    let (gate, stuck) = (f.screening.gate, f.screening.stuck_cycles);
    let history = keeps_history(f);
    let remember = if history {
        quote! {
            // A reading is new when it differs in any bit from the previous one.
            let changing = self.repeats == 0 || !same_bits(&z, &self.last);
            self.repeats = if changing { 1 } else { self.repeats.saturating_add(1) };
            self.last = z;
        }
    } else {
        quote!()
    };
    let stuck_check = stuck.map(|_| {
        quote! {
            if self.repeats >= STUCK_CYCLES {
                return Measurement::Stuck;
            }
        }
    });
    let gate_check = gate.as_ref().map(|_| {
        quote! {
            let nis = normalized(&innovation, &S_inv);
            self.status.innovation = nis;
            // `!(nis <= GATE)` also rejects a NaN statistic.
            if !(nis <= GATE) {
                if changing {
                    self.gated = self.gated.saturating_add(1);
                }
                if self.gated >= REACQUIRE_AFTER {
                    return self.reacquire(&z);
                }
                return Measurement::Gated;
            }
        }
    });
    let reset_gated = gate.as_ref().map(|_| quote!(self.gated = 0;));
    quote! {
        /// The measurement update with `z`, after screening: a non-finite reading, a stuck sensor's
        /// repeated reading and (with a gate) a reading whose normalized innovation squared exceeds
        /// [`GATE`] are rejected and change nothing but the status. Returns what was done with `z`;
        /// [`Kalman::status`] has the counts.
        pub fn update(&mut self, z: &[Real; NY]) -> Measurement {
            let verdict = self.screen(z);
            let status = &mut self.status;
            status.measurement = verdict;
            if verdict.accepted() {
                status.consecutive_rejections = 0;
                status.cycles_since_accepted = 0;
                #reset_gated
            } else {
                status.consecutive_rejections = status.consecutive_rejections.saturating_add(1);
                status.cycles_since_accepted = status.cycles_since_accepted.saturating_add(1);
            }
            verdict
        }

        /// What the filter did with the last reading, and its counts.
        pub fn status(&self) -> &FilterStatus {
            &self.status
        }

        /// Whether the filter holds an estimate: false after a non-finite `x0` until the first usable
        /// reading.
        pub fn has_estimate(&self) -> bool {
            self.status.estimate_valid
        }

        /// Screens `z`, then fuses it.
        fn screen(&mut self, z: &[Real; NY]) -> Measurement {
            self.status.innovation = 0.0;
            if !all_finite(z) {
                return Measurement::NonFinite;
            }
            let z = flushed(z);
            #remember
            #stuck_check
            if !self.status.estimate_valid {
                return self.reacquire(&z);
            }
            #s_inverse
            let innovation = innovation(&z, &self.x);
            #gate_check
            #fuse
        }

        /// Moves the estimate onto the measurement, x ← x + C⁺·(z − C x) (the measured directions set,
        #[doc = #reacquire_doc]
        fn reacquire(&mut self, z: &[Real; NY]) -> Measurement {
            let x = reacquired(&self.x, &innovation(z, &self.x));
            if !all_finite(&x) {
                return Measurement::Numerical;
            }
            self.x = flushed(&x);
            #reset_covariance
            #reset_gated
            self.status.estimate_valid = true;
            self.status.reacquisitions = self.status.reacquisitions.saturating_add(1);
            Measurement::Reacquired
        }
    }
}

/// The kernels section: the innovation, its normalized square, the re-acquired state, the reading
/// comparison and the disturbance bound.
fn kernels(p: &Problem, f: &Filter, num: Num) -> TokenStream {
    let (nx, nd, ny) = (p.nx, f.nd, p.ny);
    let (gate, history) = (f.screening.gate, keeps_history(f));
    let (x, e) = (quote!(x), quote!(e));
    let reacquired_rows = (0..nx).map(|i| {
        num.sum(
            Some(at1(&x, i)),
            (0..ny).map(|j| (f.C_pinv[(i, j)], at1(&e, j))),
        )
    });
    let mut kernels = quote! {
        /// z − C·x.
        #[inline(always)]
        fn innovation(z: &[Real; NY], x: &[Real; NX]) -> [Real; NY] {
            let mut e = *z;
            for (e, zp) in e.iter_mut().zip(measure(x).iter()) {
                *e -= *zp;
            }
            e
        }

        /// x + C⁺·e, unrolled over the pseudo-inverse of C.
        #[inline(always)]
        fn reacquired(x: &[Real; NX], e: &[Real; NY]) -> [Real; NX] {
            [#(#reacquired_rows),*]
        }
    };
    if gate.is_some() {
        kernels.extend(quote! {
            /// eᵀ·S⁻¹·e, the normalized innovation squared (χ² with NY degrees of freedom).
            #[inline(always)]
            fn normalized(e: &[Real; NY], S_inv: &[[Real; NY]; NY]) -> Real {
                let mut sum = 0.0;
                for (ei, row) in e.iter().zip(S_inv.iter()) {
                    let mut r = 0.0;
                    for (sij, ej) in row.iter().zip(e.iter()) {
                        r += *sij * *ej;
                    }
                    sum += *ei * r;
                }
                sum
            }
        });
    }
    if history {
        kernels.extend(quote! {
            /// Whether two readings are the same in every bit.
            #[inline(always)]
            fn same_bits(a: &[Real; NY], b: &[Real; NY]) -> bool {
                a.iter().zip(b.iter()).all(|(a, b)| a.to_bits() == b.to_bits())
            }
        });
    }
    if nd > 0 {
        kernels.extend(quote! {
            /// d held within [D_MIN, D_MAX]; true when an entry was moved.
            #[inline(always)]
            fn bounded(d: &[Real; ND]) -> ([Real; ND], bool) {
                let mut out = *d;
                let mut moved = false;
                for ((v, lo), hi) in out.iter_mut().zip(D_MIN.iter()).zip(D_MAX.iter()) {
                    if *v < *lo {
                        *v = *lo;
                        moved = true;
                    } else if *v > *hi {
                        *v = *hi;
                        moved = true;
                    }
                }
                (out, moved)
            }
        });
    }
    kernels
}

/// The constants section: the gate, the counts and the disturbance bound.
fn constants(p: &Problem, f: &Filter, num: Num) -> TokenStream {
    let (s, nd, ny) = (&f.screening, f.nd, p.ny);
    let (gate, stuck) = (s.gate.map(|g| num.lit(g)), s.stuck_cycles);
    let mut constants = quote!();
    if let Some(g) = &gate {
        let doc = format!(
            " The χ² gate on the normalized innovation squared eᵀS⁻¹e ([kalman] gate): a consistent \
             filter's reading exceeds it with probability {:.1e} (NY = {ny} degrees of freedom).",
            s.false_rejection
        );
        let after = Literal::u32_unsuffixed(s.reacquire_after);
        constants.extend(quote! {
            #[doc = #doc]
            pub const GATE: Real = #g;
            /// Consecutive gated readings, each different from the one before, after which the filter
            /// re-acquires from the measurement ([kalman] reacquire_after).
            pub const REACQUIRE_AFTER: u32 = #after;
        });
    }
    if let Some(n) = stuck {
        let n = Literal::u32_unsuffixed(n);
        constants.extend(quote! {
            /// Bit-identical readings in a row from which the sensor is taken as stuck and its reading
            /// rejected ([kalman] stuck_cycles); a stuck reading never causes a re-acquisition.
            pub const STUCK_CYCLES: u32 = #n;
        });
    }
    if nd > 0 {
        let d_min = num.vector(p.qp.u_max.iter().map(|v| -v));
        let d_max = num.vector(p.qp.u_min.iter().map(|v| -v));
        constants.extend(quote! {
            /// The smallest disturbance estimate the inputs can cancel: −U_MAX.
            pub const D_MIN: [Real; ND] = #d_min;
            /// The largest disturbance estimate the inputs can cancel: −U_MIN.
            pub const D_MAX: [Real; ND] = #d_max;
        });
    }
    constants
}

/// The api section: the `Measurement` enum and the `FilterStatus` struct.
fn api(nd: usize) -> TokenStream {
    let clamped_field = (nd > 0).then(|| {
        quote! {
            /// Whether the disturbance estimate is held at [`D_MIN`] or [`D_MAX`]: the disturbance is larger
            /// than the inputs can cancel, or the filter is winding up.
            pub disturbance_clamped: bool,
        }
    });
    let clamped_init = (nd > 0).then(|| quote!(disturbance_clamped: false,));
    quote! {
        /// What the filter did with a reading.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum Measurement {
            /// No reading yet.
            NoneYet,
            /// Fused by the Kalman update.
            Accepted,
            /// Fused by re-acquisition: the estimate was moved onto the measurement (the first usable
            /// reading after a non-finite `x0`, or a reading after a run of gated ones).
            Reacquired,
            /// An entry was NaN or infinite (a dropout): not fused.
            NonFinite,
            /// Its normalized innovation squared exceeded [`GATE`]: not fused.
            Gated,
            /// Bit-identical to the readings before it for [`STUCK_CYCLES`] cycles: not fused.
            Stuck,
            /// The update's arithmetic failed (an innovation covariance that is not positive definite,
            /// or a non-finite result): not fused.
            Numerical,
        }

        impl Measurement {
            /// Whether the reading was fused.
            pub const fn accepted(self) -> bool {
                matches!(self, Measurement::Accepted | Measurement::Reacquired)
            }
        }

        /// The filter's part of a control cycle's [`Status`].
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct FilterStatus {
            /// What was done with the last reading.
            pub measurement: Measurement,
            /// The last reading's normalized innovation squared eᵀS⁻¹e (0 when it was not computed).
            pub innovation: Real,
            /// Readings rejected in a row.
            pub consecutive_rejections: u32,
            /// Readings since the last one fused (0 when the last was fused).
            pub cycles_since_accepted: u32,
            /// Re-acquisitions since construction, the first acquisition after a non-finite `x0`
            /// included.
            pub reacquisitions: u32,
            /// Whether the filter holds an estimate: false from a non-finite `x0` until the first
            /// usable reading; the controller commands [`U_REST`] meanwhile.
            pub estimate_valid: bool,
            #clamped_field
        }

        impl FilterStatus {
            const fn new(estimate_valid: bool) -> Self {
                FilterStatus {
                    measurement: Measurement::NoneYet,
                    innovation: 0.0,
                    consecutive_rejections: 0,
                    cycles_since_accepted: 0,
                    reacquisitions: 0,
                    estimate_valid,
                    #clamped_init
                }
            }
        }
    }
}

/// The tables section: the steady-state filter's S⁻¹ for the gate.
fn tables(f: &Filter, num: Num) -> TokenStream {
    if f.screening.gate.is_some() && f.kind == mpc_spec::FilterKind::SteadyState {
        let s_inv = num.matrix(&f.S_inf_inv);
        quote! {
            /// (C P∞ Cᵀ + R)⁻¹: the steady-state innovation covariance, inverted, for the gate.
            const S_INV: [[Real; NY]; NY] = #s_inv;
        }
    } else {
        quote!()
    }
}
