//! The linear Kalman filter (paper Section 2.3): time-varying with a Joseph-form update, or with the
//! steady-state gain solved at compile time.
#![allow(non_snake_case)]

use super::screening::{self, Screen};
use super::sections::Sections;
use super::tokens::{at1, Num};
use crate::lower::problem::{Filter, Problem};
use mpc_spec::FilterKind;
use nalgebra::DMatrix;
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

/// The `Kalman` type and its unrolled kernels.
pub fn emit(p: &Problem, f: &Filter, num: Num) -> Sections {
    let (nx, nu, ny) = (p.nx, p.nu, p.ny);
    let u = quote!(u);
    let (state_params, _) = state_signature(p);
    // x⁺ = F x + G (u + d) (eq. 1 without noise; d only with a disturbance model). d⁺ = d needs no code.
    let predict_rows = (0..nx).map(|i| {
        let fx = (0..nx + f.nd).map(|k| (f.Fa[(i, k)], element(p, k)));
        let gu = (0..nu).map(|k| (f.Ga[(i, k)], at1(&u, k)));
        num.sum(None, fx.chain(gu))
    });
    // C x, the predicted measurement.
    let measure_rows =
        (0..ny).map(|i| num.sum(None, (0..nx).map(|k| (f.Ca[(i, k)], element(p, k)))));
    let predict_doc = if f.nd > 0 {
        " F·x + G·(u + d) (eq. 1 with the input disturbance), unrolled."
    } else {
        " F·x + G·u (eq. 1), unrolled."
    };
    let kernels = quote! {
        #[doc = #predict_doc]
        #[inline(always)]
        fn predict_state(#state_params, u: &[Real; NU]) -> [Real; NX] {
            [#(#predict_rows),*]
        }

        /// C·x, the predicted measurement, unrolled.
        #[inline(always)]
        fn measure(x: &[Real; NX]) -> [Real; NY] {
            [#(#measure_rows),*]
        }
    };
    match f.kind {
        FilterKind::SteadyState => steady_state(p, f, num, kernels),
        FilterKind::TimeVarying => time_varying(p, f, num, kernels),
    }
}

/// Entry k of the filter's state (x, d): `x[k]`, or `d[k − nx]` for the disturbance.
fn element(p: &Problem, k: usize) -> TokenStream {
    if k < p.nx {
        at1(&quote!(x), k)
    } else {
        at1(&quote!(d), k - p.nx)
    }
}

/// The parameters and arguments that carry the filter's state into a kernel.
fn state_signature(p: &Problem) -> (TokenStream, TokenStream) {
    if p.nd() > 0 {
        (
            quote!(x: &[Real; NX], d: &[Real; ND]),
            quote!(&self.x, &self.d),
        )
    } else {
        (quote!(x: &[Real; NX]), quote!(&self.x))
    }
}

/// The `Kalman` items shared by both filter kinds when a disturbance is modelled: its field, its
/// initial value, its accessor, and its commit (held within what the inputs can cancel).
struct DisturbanceParts {
    field: TokenStream,
    init: TokenStream,
    accessor: TokenStream,
    check: TokenStream,
    commit: TokenStream,
}

fn disturbance_parts(p: &Problem) -> DisturbanceParts {
    if p.nd() == 0 {
        return DisturbanceParts {
            field: quote!(),
            init: quote!(),
            accessor: quote!(),
            check: quote!(),
            commit: quote!(),
        };
    }
    DisturbanceParts {
        field: quote!(d: [Real; ND],),
        init: quote!(d: [0.0; ND],),
        accessor: quote! {
            /// The estimated input disturbance (the input that cancels it is its negative), held within
            /// [`D_MIN`], [`D_MAX`].
            pub fn disturbance(&self) -> &[Real; ND] {
                &self.d
            }
        },
        check: quote!(&&all_finite(&d)),
        commit: quote! {
            let (d, clamped) = bounded(&flushed(&d));
            self.d = d;
            self.status.disturbance_clamped = clamped;
        },
    }
}

/// The `Kalman` struct, `new`, `reset`, `predict` and the accessors both kinds share, around the
/// kind's own fields and methods.
struct KindParts {
    doc: &'static str,
    fields: TokenStream,
    init: TokenStream,
    /// Run after the state's prediction is known finite; binds nothing; may veto with `return`.
    predict_covariance: TokenStream,
    commit_covariance: TokenStream,
    methods: TokenStream,
}

fn kalman_type(p: &Problem, screen: &Screen, kind: KindParts) -> TokenStream {
    let (_, state_args) = state_signature(p);
    let d = disturbance_parts(p);
    let (d_field, d_init, d_accessor) = (d.field, d.init, d.accessor);
    let (screen_fields, screen_init, screen_methods) =
        (&screen.fields, &screen.init, &screen.methods);
    let KindParts {
        doc,
        fields,
        init,
        predict_covariance,
        commit_covariance,
        methods,
    } = kind;
    quote! {
        #[doc = #doc]
        #[derive(Clone, Debug, PartialEq)]
        pub struct Kalman {
            x: [Real; NX],
            #d_field
            #fields
            #screen_fields
        }

        impl Kalman {
            /// A filter whose estimate starts at `x0`. A non-finite `x0` is refused: the filter then has
            /// no estimate ([`FilterStatus::estimate_valid`] is false) until its first usable reading,
            /// which it acquires.
            pub const fn new(x0: [Real; NX]) -> Self {
                let valid = finite(&x0);
                Kalman {
                    x: if valid { x0 } else { [0.0; NX] },
                    #d_init
                    #init
                    #screen_init
                }
            }

            /// Starts again from `x0`, as [`Kalman::new`].
            pub fn reset(&mut self, x0: [Real; NX]) {
                *self = Self::new(x0);
            }

            /// The time update with the applied input `u`. A non-finite `u`, a filter without an
            /// estimate or a non-finite result changes nothing.
            pub fn predict(&mut self, u: &[Real; NU]) {
                if !(self.status.estimate_valid && all_finite(u)) {
                    return;
                }
                let u = flushed(u);
                let x = predict_state(#state_args, &u);
                if !all_finite(&x) {
                    return;
                }
                #predict_covariance
                self.x = flushed(&x);
                #commit_covariance
            }

            #screen_methods

            /// The estimate.
            pub fn state(&self) -> &[Real; NX] {
                &self.x
            }

            #d_accessor

            #methods
        }
    }
}

fn steady_state(p: &Problem, f: &Filter, num: Num, kernels: TokenStream) -> Sections {
    let (nx, ny, nd) = (p.nx, p.ny, p.nd());
    let K = &f.K_inf;
    let (x, d, innovation) = (quote!(x), quote!(d), quote!(innovation));
    let correct_rows = (0..nx).map(|i| {
        num.sum(
            Some(at1(&x, i)),
            (0..ny).map(|j| (K[(i, j)], at1(&innovation, j))),
        )
    });
    let parts = disturbance_parts(p);
    let (d_kernel, d_correct) = if nd > 0 {
        let rows = (0..nd).map(|i| {
            num.sum(
                Some(at1(&d, i)),
                (0..ny).map(|j| (K[(nx + i, j)], at1(&innovation, j))),
            )
        });
        (
            quote! {
                /// d + K∞_d·innovation: the disturbance rows of the steady-state gain.
                #[inline(always)]
                fn correct_disturbance(d: &[Real; ND], innovation: &[Real; NY]) -> [Real; ND] {
                    [#(#rows),*]
                }
            },
            quote!(let d = correct_disturbance(&self.d, &innovation);),
        )
    } else {
        (quote!(), quote!())
    };
    let covariance_type = if nd > 0 {
        quote!([[Real; NA]; NA])
    } else {
        quote!([[Real; NX]; NX])
    };
    let (d_check, d_commit) = (parts.check, parts.commit);
    let gate = f.screening.gate.is_some();
    let restart = Restart::of(p, f, num);
    let (s_inverse, correction, advance, reset, fields, init) = match &restart {
        None => (
            if gate {
                quote!(let S_inv = S_INV;)
            } else {
                quote!()
            },
            quote! {
                let x = correct(&self.x, &innovation);
                #d_correct
            },
            quote!(),
            quote!(),
            quote!(),
            quote!(),
        ),
        Some(_) => {
            let s_inv = gate.then(|| {
                quote! {
                    let S_inv = match restart {
                        Some(g) => restart_s_inv(g),
                        None => S_INV,
                    };
                }
            });
            let correction = if nd > 0 {
                quote! {
                    let (x, d) = match restart {
                        Some(g) => (
                            correct_restart(&self.x, &innovation, g),
                            correct_disturbance_restart(&self.d, &innovation, g),
                        ),
                        None => (
                            correct(&self.x, &innovation),
                            correct_disturbance(&self.d, &innovation),
                        ),
                    };
                }
            } else {
                quote! {
                    let x = match restart {
                        Some(g) => correct_restart(&self.x, &innovation, g),
                        None => correct(&self.x, &innovation),
                    };
                }
            };
            (
                quote! {
                    // The restart table's entry for this reading while a re-acquisition's transient lasts.
                    let restart = RESTART.get(self.fused as usize);
                    #s_inv
                },
                correction,
                quote! {
                    if self.fused < RESTART_CYCLES {
                        self.fused += 1;
                    }
                },
                quote!(self.fused = 0;),
                quote!(fused: u32,),
                quote!(fused: RESTART_CYCLES,),
            )
        }
    };
    let fuse = quote! {
        #correction
        if !(all_finite(&x) #d_check) {
            return Measurement::Numerical;
        }
        self.x = flushed(&x);
        #d_commit
        #advance
        Measurement::Accepted
    };
    let what = if restart.is_some() {
        "the restart table"
    } else {
        "nothing else (without a restart table)"
    };
    let screen = screening::emit(p, f, num, s_inverse, fuse, reset, what);
    let covariance_doc = if restart.is_some() {
        " The covariance the gain K∞ was computed from: the steady-state prior P∞ (the gains of the \
         [`RESTART_CYCLES`] readings after a re-acquisition are the time-varying filter's from P0)."
    } else {
        " The covariance the gain was computed from: the steady-state prior P∞."
    };
    let kalman = kalman_type(
        p,
        &screen,
        KindParts {
            doc: " The steady-state Kalman filter: the gain K∞ of the discrete Riccati equation, fixed at compile time; after a re-acquisition, the time-varying filter's gains from P0, a table computed at compile time.",
            fields,
            init,
            predict_covariance: quote!(),
            commit_covariance: quote!(),
            methods: quote! {
                #[doc = #covariance_doc]
                pub fn covariance(&self) -> &#covariance_type {
                    &P_INF
                }
            },
        },
    );
    let Sections {
        mut constants,
        api: screen_api,
        kernels: screen_kernels,
        mut tables,
    } = screen.sections;
    let restart_kernels = restart.map(|r| {
        constants.extend(r.constant);
        tables.extend(r.table);
        r.kernels
    });
    let kernels = quote! {
        #kernels

        /// x + K∞·innovation, unrolled over the steady-state gain.
        #[inline(always)]
        fn correct(x: &[Real; NX], innovation: &[Real; NY]) -> [Real; NX] {
            [#(#correct_rows),*]
        }

        #d_kernel
        #restart_kernels
        #screen_kernels
    };
    Sections {
        constants,
        api: quote!(#kalman #screen_api),
        kernels,
        tables,
    }
}

/// The steady-state filter's restart after a re-acquisition (`Filter::restart`): its length, its table
/// (one row per reading: the entries of K_k that can be nonzero, then those of S_k⁻¹ with a gate) and
/// the kernels that read a row.
struct Restart {
    constant: TokenStream,
    table: TokenStream,
    kernels: TokenStream,
}

impl Restart {
    /// `None` when the table is empty (a time-varying filter).
    fn of(p: &Problem, f: &Filter, num: Num) -> Option<Restart> {
        let gains = &f.restart;
        if gains.is_empty() {
            return None;
        }
        let (nx, nd, ny) = (p.nx, f.nd, p.ny);
        let na = nx + nd;
        let gate = f.screening.gate.is_some();
        // The entries written in some row: an entry zero in every row is left out of the table.
        let used = |M: fn(&crate::linalg::Gain) -> &DMatrix<f64>, i: usize, j: usize| {
            gains.iter().any(|g| num.round(M(g)[(i, j)]) != 0.0)
        };
        let k_at: Vec<(usize, usize)> = (0..na)
            .flat_map(|i| (0..ny).map(move |j| (i, j)))
            .filter(|&(i, j)| used(|g| &g.K, i, j))
            .collect();
        let s_at: Vec<(usize, usize)> = if gate {
            (0..ny)
                .flat_map(|i| (0..ny).map(move |j| (i, j)))
                .filter(|&(i, j)| used(|g| &g.S_inv, i, j))
                .collect()
        } else {
            Vec::new()
        };
        let width = Literal::usize_unsuffixed(k_at.len() + s_at.len());
        let cycles = Literal::usize_unsuffixed(gains.len());
        let rows = gains.iter().map(|g| {
            let entries = k_at
                .iter()
                .map(|&(i, j)| g.K[(i, j)])
                .chain(s_at.iter().map(|&(i, j)| g.S_inv[(i, j)]));
            num.vector(entries)
        });
        let ix = |i: usize| Literal::usize_unsuffixed(i);
        // Row i of x + K_k·e (or of d + K_k·e), over the row's entries in order.
        let correct_row = |base: TokenStream, i: usize| {
            let terms = k_at
                .iter()
                .enumerate()
                .filter(|(_, (r, _))| *r == i)
                .map(|(n, (_, j))| {
                    let (n, j) = (ix(n), ix(*j));
                    quote!(+ g[#n] * e[#j])
                });
            quote!(#base #(#terms)*)
        };
        let x_rows = (0..nx).map(|i| {
            let ii = ix(i);
            correct_row(quote!(x[#ii]), i)
        });
        let mut kernels = quote! {
            /// x + K_k·e over the restart table's row `g`.
            #[inline(always)]
            fn correct_restart(x: &[Real; NX], e: &[Real; NY], g: &[Real; #width]) -> [Real; NX] {
                [#(#x_rows),*]
            }
        };
        if nd > 0 {
            let d_rows = (0..nd).map(|i| {
                let ii = ix(i);
                correct_row(quote!(d[#ii]), nx + i)
            });
            kernels.extend(quote! {
                /// d + K_k,d·e over the restart table's row `g`: its disturbance rows.
                #[inline(always)]
                fn correct_disturbance_restart(d: &[Real; ND], e: &[Real; NY], g: &[Real; #width]) -> [Real; ND] {
                    [#(#d_rows),*]
                }
            });
        }
        if gate {
            let offset = k_at.len();
            let s_rows = (0..ny).map(|i| {
                let row = (0..ny).map(|j| match s_at.iter().position(|&at| at == (i, j)) {
                    Some(n) => {
                        let n = ix(offset + n);
                        quote!(g[#n])
                    }
                    None => num.lit(0.0),
                });
                quote!([#(#row),*])
            });
            kernels.extend(quote! {
                /// S_k⁻¹ from the restart table's row `g`, for the gate.
                #[inline(always)]
                fn restart_s_inv(g: &[Real; #width]) -> [[Real; NY]; NY] {
                    [#(#s_rows),*]
                }
            });
        }
        let m = Literal::u32_unsuffixed(gains.len() as u32);
        let doc = format!(
            " Readings after a re-acquisition fused with the time-varying filter's gains from P0 (the \
             restart table) before K∞ takes over: from there on K∞ adds less than {} % to any state's \
             posterior variance.",
            crate::lower::RESTART_TOLERANCE * 100.0
        );
        Some(Restart {
            constant: quote! {
                #[doc = #doc]
                pub const RESTART_CYCLES: u32 = #m;
            },
            table: quote! {
                /// The restart table: row k − 1 holds the gain K_k of the k-th reading after a
                /// re-acquisition (its entries that can be nonzero, row by row), then S_k⁻¹ for the gate.
                const RESTART: [[Real; #width]; #cycles] = [#(#rows),*];
            },
            kernels,
        })
    }
}

fn time_varying(p: &Problem, f: &Filter, num: Num, kernels: TokenStream) -> Sections {
    let nd = p.nd();
    // The covariance is over the filter's state (x, d): na = nx + nd entries.
    let na = p.nx + nd;
    let Fa = &f.Fa;
    let ns = if nd > 0 { quote!(NA) } else { quote!(NX) };
    let parts = disturbance_parts(p);
    let (P, FP) = (quote!(P), quote!(FP));
    let ix = |i: usize| Literal::usize_unsuffixed(i);
    let m = |name: &TokenStream, i: usize, j: usize| {
        let (i, j) = (ix(i), ix(j));
        quote!(#name[#i][#j])
    };
    // F·P, then (F·P)·Fᵀ + Q, upper triangle computed and mirrored so P stays symmetric. Entries of P
    // that are structurally zero (`Filter::P_pattern`) are skipped, and so are those of F·P.
    let pattern = &f.P_pattern;
    let fp_pattern =
        crate::lower::structure::pattern_product(&crate::lower::structure::pattern(Fa), pattern);
    let fp_rows = (0..na).map(|i| {
        let row = (0..na).map(|j| {
            let terms = (0..na).filter(|k| pattern[(*k, j)]);
            num.sum(None, terms.map(|k| (Fa[(i, k)], m(&P, k, j))))
        });
        quote!([#(#row),*])
    });
    let mut propagate = Vec::new();
    for i in 0..na {
        for j in i..na {
            let terms = (0..na).filter(|k| fp_pattern[(i, *k)]);
            let e = num.sum(None, terms.map(|k| (Fa[(j, k)], m(&FP, i, k))));
            let q = num.lit(f.Qn[(i, j)]);
            let (ii, jj) = (ix(i), ix(j));
            let value = if num.round(f.Qn[(i, j)]) == 0.0 {
                e
            } else {
                quote!(#e + #q)
            };
            propagate.push(quote!(out[#ii][#jj] = #value;));
            if i != j {
                propagate.push(quote!(out[#jj][#ii] = out[#ii][#jj];));
            }
        }
    }
    let (s_inverse, correction) = update_covariance(p, f, num);
    let (d_check, d_commit) = (parts.check, parts.commit);
    let fuse = quote! {
        #correction
        if !(all_finite(&x) #d_check && P.iter().all(|row| all_finite(row))) {
            return Measurement::Numerical;
        }
        self.x = flushed(&x);
        #d_commit
        self.P = P;
        Measurement::Accepted
    };
    let screen = screening::emit(
        p,
        f,
        num,
        s_inverse,
        fuse,
        quote!(self.P = P0;),
        "the covariance",
    );
    let kalman = kalman_type(
        p,
        &screen,
        KindParts {
            doc: " The time-varying Kalman filter (paper eqs. 1-3), with a Joseph-form covariance update that keeps P symmetric positive definite in finite precision: K = P Cᵀ (C P Cᵀ + R)⁻¹, x ← x + K (z − C x), P ← (I − K C) P (I − K C)ᵀ + K R Kᵀ; the time update x ← F x + G u, P ← F P Fᵀ + Q.",
            fields: quote!(P: [[Real; #ns]; #ns],),
            init: quote!(P: P0,),
            predict_covariance: quote! {
                let P = propagate(&self.P);
                if !P.iter().all(|row| all_finite(row)) {
                    return;
                }
            },
            commit_covariance: quote!(self.P = P;),
            methods: quote! {
                /// The covariance: the prior after `predict`, the posterior after `update`.
                pub fn covariance(&self) -> &[[Real; #ns]; #ns] {
                    &self.P
                }
            },
        },
    );
    let inverse = spd_inverse(p.ny);
    let Sections {
        constants,
        api: screen_api,
        kernels: screen_kernels,
        tables,
    } = screen.sections;
    let kernels = quote! {
        #kernels

        /// F·P, unrolled over the nonzeros of F.
        #[inline(always)]
        fn f_times(P: &[[Real; #ns]; #ns]) -> [[Real; #ns]; #ns] {
            [#(#fp_rows),*]
        }

        /// F·P·Fᵀ + Q, symmetric by construction.
        #[inline(always)]
        fn propagate(P: &[[Real; #ns]; #ns]) -> [[Real; #ns]; #ns] {
            let FP = f_times(P);
            let mut out = [[0.0; #ns]; #ns];
            #(#propagate)*
            out
        }

        #inverse
        #screen_kernels
    };
    Sections {
        constants,
        api: quote!(#kalman #screen_api),
        kernels,
        tables,
    }
}

/// The inverse of a symmetric positive definite ny × ny matrix by an unrolled LDLᵀ factorization
/// (no square roots, which `core` lacks); `None` when a pivot is not positive.
fn spd_inverse(ny: usize) -> TokenStream {
    let l = |i: usize, j: usize| format_ident!("l{}_{}", i, j);
    let d = |i: usize| format_ident!("d{}", i);
    let ix = |i: usize| Literal::usize_unsuffixed(i);
    let mut body = Vec::new();
    for j in 0..ny {
        let (dj, jj) = (d(j), ix(j));
        let sub = (0..j).map(|k| {
            let (ljk, dk) = (l(j, k), d(k));
            quote!(- #ljk * #ljk * #dk)
        });
        body.push(quote! {
            let #dj = S[#jj][#jj] #(#sub)*;
            if !(#dj > 0.0) { return None; }
        });
        for i in j + 1..ny {
            let (lij, ii) = (l(i, j), ix(i));
            let sub = (0..j).map(|k| {
                let (lik, ljk, dk) = (l(i, k), l(j, k), d(k));
                quote!(- #lik * #ljk * #dk)
            });
            body.push(quote!(let #lij = (S[#ii][#jj] #(#sub)*) / #dj;));
        }
    }
    // Column c of the inverse: solve L w = e_c, then Lᵀ v = w / d.
    let mut columns = Vec::new();
    for c in 0..ny {
        let w = |i: usize| format_ident!("w{}_{}", c, i);
        let v = |i: usize| format_ident!("v{}_{}", c, i);
        for i in 0..ny {
            let wi = w(i);
            let e = if i == c { quote!(1.0) } else { quote!(0.0) };
            let sub = (0..i).map(|k| {
                let (lik, wk) = (l(i, k), w(k));
                quote!(- #lik * #wk)
            });
            columns.push(quote!(let #wi: Real = #e #(#sub)*;));
        }
        for i in (0..ny).rev() {
            let (vi, wi, di) = (v(i), w(i), d(i));
            let sub = (i + 1..ny).map(|k| {
                let (lki, vk) = (l(k, i), v(k));
                quote!(- #lki * #vk)
            });
            columns.push(quote!(let #vi = #wi / #di #(#sub)*;));
        }
    }
    let rows = (0..ny).map(|i| {
        let row = (0..ny).map(|c| format_ident!("v{}_{}", c, i));
        quote!([#(#row),*])
    });
    quote! {
        /// S⁻¹ for a symmetric positive definite S, by an unrolled LDLᵀ factorization.
        #[inline(always)]
        fn spd_inverse(S: &[[Real; NY]; NY]) -> Option<[[Real; NY]; NY]> {
            #(#body)*
            #(#columns)*
            Some([#(#rows),*])
        }
    }
}

/// The measurement update's arithmetic over the entries that can be nonzero: K = P·Cᵀ·S⁻¹ with
/// S = C·P·Cᵀ + R, the corrected estimate, and the Joseph form (I − KC)·P·(I − KC)ᵀ + K·R·Kᵀ,
/// symmetrized. Returns two parts: the first binds `S_inv` (returning `Measurement::Numerical` when S is
/// not positive definite), the second, which reads `innovation`, binds `x` (and `d`) and `P`.
fn update_covariance(p: &Problem, f: &Filter, num: Num) -> (TokenStream, TokenStream) {
    use super::sparse::{product, symmetrized, Sym};
    use crate::lower::structure::pattern_inverse;
    let (nx, nd, ny) = (p.nx, f.nd, p.ny);
    let na = nx + nd;
    let P = Sym::place(&quote!(self.P), &f.P_pattern);
    let C = Sym::constant(&f.Ca, num);
    let R = Sym::constant(&f.Rn, num);
    let (pct, PCt) = product(num, "pct", &P, &C.transpose(), None);
    let (s, S) = product(num, "s", &C, &PCt, Some(&R));
    let S_array = S.array(num);
    let S_inv = Sym::place(&quote!(S_inv), &pattern_inverse(&S.pattern()));
    let (k, K) = product(num, "k", &PCt, &S_inv, None);
    // x⁺ = x + K·(z − C x), over the filter's state (x, d).
    let innovation = Sym::column(
        (0..ny)
            .map(|j| {
                let j = Literal::usize_unsuffixed(j);
                quote!(innovation[#j])
            })
            .collect(),
    );
    let state = Sym::column(
        (0..na)
            .map(|i| element(p, i))
            .map(|e| quote!(self.#e))
            .collect(),
    );
    let (corrected, X) = product(num, "xn", &K, &innovation, Some(&state));
    let x_rows = (0..nx).map(|i| X.element(i, num));
    let d_rows = (nx..na).map(|i| X.element(i, num));
    let d_binding = if nd > 0 {
        quote!(let d: [Real; ND] = [#(#d_rows),*];)
    } else {
        quote!()
    };
    let identity = Sym::constant(&DMatrix::identity(na, na), num);
    let minus_C = Sym::constant(&(-&f.Ca), num);
    let (a, A) = product(num, "a", &K, &minus_C, Some(&identity));
    let (ap, AP) = product(num, "ap", &A, &P, None);
    let (apa, APA) = product(num, "apa", &AP, &A.transpose(), None);
    let (kr, KR) = product(num, "kr", &K, &R, None);
    let (joseph, J) = product(num, "pj", &KR, &K.transpose(), Some(&APA));
    let (sym, Pn) = symmetrized(num, "pn", &J);
    let P_array = Pn.array(num);
    let s_inverse = quote! {
        #(#pct)*
        #(#s)*
        let S: [[Real; NY]; NY] = #S_array;
        let Some(S_inv) = spd_inverse(&S) else {
            return Measurement::Numerical;
        };
    };
    let correction = quote! {
        #(#k)*
        #(#corrected)*
        let x: [Real; NX] = [#(#x_rows),*];
        #d_binding
        #(#a)*
        #(#ap)*
        #(#apa)*
        #(#kr)*
        #(#joseph)*
        #(#sym)*
        let P = #P_array;
    };
    (s_inverse, correction)
}
