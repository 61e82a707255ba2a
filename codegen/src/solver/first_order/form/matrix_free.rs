//! `matrix_free`: the gradient ∇J(v) = 2 Suᵀ Q_blk (Sx·x0 + Su·v − Xref) + 2 R_blk·v without Su or H: a
//! forward sweep of the dynamics and a backward adjoint sweep, O(N) per iteration, but a recursion from
//! step to step whose latency the hardware cannot hide. The same sweeps give f = ∇J(0) for the table
//! forms. When the model has lanes ([`crate::lower::problem::ModelLanes`]) the sweeps run every lane at once with
//! one set of constants (NEON on the A9); otherwise they are unrolled over the model's nonzeros.
#![allow(non_snake_case)]

use super::{lane_count, linear_args, linear_params, neon, reference_row, GradientForm};
use crate::emit::tokens::{at1, Num};
use crate::lower::problem::{ModelLanes, Problem};
use crate::numeric::Numeric;
use crate::plan::cost::{
    Estimate, BYTES_OF_A_LOOP, BYTES_PER_INLINED_MAC, SWEEP, SWEEP_IN_LANES, VECTOR_WIDTH,
};
use crate::solver::first_order::Algorithm;
use mpc_spec::Emission;
use nalgebra::DMatrix;
use proc_macro2::{Literal, TokenStream};
use quote::quote;
use std::cell::RefCell;
use std::collections::BTreeSet;

/// The matrix-free form.
#[derive(Clone, Copy, Debug)]
pub struct MatrixFree;

/// Per step: x⁺ = F x + G u forward; λ = 2W e + Fᵀ λ⁺ and g = Gᵀ λ⁺ + 2R u backward, e = x − r. With the
/// model in lanes ([`crate::lower::problem::ModelLanes`]) every operation is one lane vector.
pub fn estimate(p: &Problem) -> Estimate {
    let num = Numeric(p.scalar);
    let nnz = |M: &DMatrix<f64>| num.nonzeros(M);
    let (N, nu) = (p.qp.N, p.nu);
    let ([F, G, Q, Qf, R], width, weight) = match &p.model_lanes {
        Some(m) => (
            [&m.F, &m.G, &m.Q, &m.Qf, &m.R],
            lane_count(nu),
            SWEEP_IN_LANES,
        ),
        None => ([&p.F, &p.G, &p.qp.Q, &p.qp.Qf, &p.qp.R], 1, SWEEP),
    };
    let step = 2 * nnz(F) + 2 * nnz(G) + nnz(Q).max(nnz(Qf)) + nnz(R) + F.nrows();
    Estimate {
        emission: Emission::MatrixFree,
        unavailable: None,
        macs: N * step * width,
        score: weight * (N * step * width.div_ceil(VECTOR_WIDTH)) as f64,
        // The body of one step, with both weightings (stage and terminal) unrolled.
        code_bytes: (step + nnz(Qf)) * BYTES_PER_INLINED_MAC + BYTES_OF_A_LOOP,
        table_bytes: 0,
    }
}

impl GradientForm for MatrixFree {
    fn emission(&self) -> Emission {
        Emission::MatrixFree
    }

    /// The sweeps run in lanes when the model has them.
    fn plan_lanes(&self, p: &Problem) -> usize {
        if p.model_lanes.is_some() {
            lane_count(p.nu)
        } else {
            p.nu
        }
    }

    fn kernels(&self, p: &Problem, _algorithm: &dyn Algorithm, num: Num) -> TokenStream {
        emit(p, num, self.plan_lanes(p))
    }

    fn prepare(&self, _p: &Problem) -> TokenStream {
        quote!()
    }

    fn gradient_call(&self, p: &Problem, algorithm: &dyn Algorithm) -> TokenStream {
        let (point, d_arg) = (algorithm.point(), linear_args(p));
        quote!(adjoint_gradient(&#point, x0, #d_arg xref, &mut g))
    }
}

/// The statements computing f = ∇J(0) by the sweeps, for the table forms: O(N) instead of the O(N²)
/// Fr·Xref.
pub fn linear_term(p: &Problem) -> TokenStream {
    let d_arg = linear_args(p);
    quote! {
        // f = ∇J(0): the same sweeps as the matrix-free form, O(N) instead of the O(N²) Fr·Xref.
        let mut f: Plan = [[0.0; LANES]; N];
        adjoint_gradient(&[[0.0; LANES]; N], x0, #d_arg xref, &mut f);
    }
}

/// `fn adjoint_gradient(v, x0, [d,] xref, g)`, in lanes when the model and the plan have them.
pub(crate) fn emit(p: &Problem, num: Num, lanes: usize) -> TokenStream {
    match lane_model(p, lanes) {
        Some(m) => in_lanes(p, m, num),
        None => scalar(p, num, lanes),
    }
}

/// The model per lane, when the sweeps run in lanes: the model has them and the plan is in lanes.
fn lane_model(p: &Problem, lanes: usize) -> Option<&ModelLanes> {
    p.model_lanes.as_ref().filter(|_| lanes == lane_count(p.nu))
}

/// Whether the sweeps of a plan of `lanes` entries per step have NEON twins.
pub(crate) fn uses_neon(p: &Problem, lanes: usize) -> bool {
    neon::applies(p) && lane_model(p, lanes).is_some()
}

/// The matrix-free gradient ∇J(v) = 2 Suᵀ Q_blk (Sx·x0 + Su·v − Xref) + 2 R_blk·v without Su: a forward
/// sweep x_{k+1} = F x_k + G u_k, then a backward adjoint sweep λ_k = 2W_k (x_k − r_k) + Fᵀ λ_{k+1},
/// g_k = Gᵀ λ_{k+1} + 2R u_k. With a disturbance, u = v + d (the offset-free problem is the plain one in
/// v + d, see [`crate::lower::problem::Qp::Fd`]).
fn scalar(p: &Problem, num: Num, lanes: usize) -> TokenStream {
    let qp = &p.qp;
    let (nx, nu, nd) = (p.nx, p.nu, p.nd());
    let (prev, u, e, lambda) = (quote!(prev), quote!(u), quote!(e), quote!(lambda));
    let inputs: Vec<TokenStream> = (0..nu)
        .map(|a| {
            let a = Literal::usize_unsuffixed(a);
            if nd > 0 {
                quote!(v_k[#a] + d[#a])
            } else {
                quote!(v_k[#a])
            }
        })
        .collect();
    let forward: Vec<TokenStream> = (0..nx)
        .map(|i| {
            let from_x = (0..nx).map(|j| (p.F[(i, j)], at1(&prev, j)));
            let from_u = (0..nu).map(|b| (p.G[(i, b)], at1(&u, b)));
            num.sum(None, from_x.chain(from_u))
        })
        .collect();
    let (stage, terminal) = match &qp.Cz {
        // 2W(x_k − r_k): the error once, then its weighting.
        None => {
            let error: Vec<TokenStream> = (0..nx)
                .map(|i| {
                    let i = Literal::usize_unsuffixed(i);
                    quote!(x_k[#i] - r_k[#i])
                })
                .collect();
            let weighted = |W: &nalgebra::DMatrix<f64>| -> Vec<TokenStream> {
                (0..nx)
                    .map(|i| num.sum(None, (0..nx).map(|j| (2.0 * W[(i, j)], at1(&e, j)))))
                    .collect()
            };
            let prologue = quote!(let e: [Real; NX] = [#(#error),*];);
            (
                (prologue.clone(), weighted(&qp.Q)),
                (prologue, weighted(&qp.Qf)),
            )
        }
        // 2(Q x_k − Qr r_k), Q = C_zᵀWC_z and Qr = C_zᵀW: outputs weighted in the state space.
        Some(_) => {
            let (x, r) = (quote!(x_k), quote!(r_k));
            let weighted =
                |Q: &nalgebra::DMatrix<f64>, Qr: &nalgebra::DMatrix<f64>| -> Vec<TokenStream> {
                    (0..nx)
                        .map(|i| {
                            let from_x = (0..nx).map(|j| (2.0 * Q[(i, j)], at1(&x, j)));
                            let from_r = (0..qp.nz).map(|j| (-2.0 * Qr[(i, j)], at1(&r, j)));
                            num.sum(None, from_x.chain(from_r))
                        })
                        .collect()
                };
            (
                (quote!(), weighted(&qp.Q, &qp.Qr)),
                (quote!(), weighted(&qp.Qf, &qp.Qfr)),
            )
        }
    };
    let prologue = stage.0;
    // The backward sweep reads the input for 2R·u only: with R = 0 (moves weighted instead) it does not.
    let reads_input = (0..nu * nu).any(|i| num.round(qp.R[(i / nu, i % nu)]) != 0.0);
    let (step, steps) = if reads_input {
        (
            quote!(((g_k, x_k), (r_k, v_k))),
            quote!(g.iter_mut().zip(x.iter()).zip(xref.iter().zip(v.iter()))),
        )
    } else {
        (
            quote!(((g_k, x_k), r_k)),
            quote!(g.iter_mut().zip(x.iter()).zip(xref.iter())),
        )
    };
    let (backward, weighted) = stage_or_terminal(&stage.1, &terminal.1, step);
    let we = quote!(we);
    let adjoint: Vec<TokenStream> = (0..nx)
        .map(|i| {
            num.sum(
                Some(at1(&we, i)),
                (0..nx).map(|j| (p.F[(j, i)], at1(&lambda, j))),
            )
        })
        .collect();
    let grad: Vec<TokenStream> = (0..lanes)
        .map(|a| {
            if a >= nu {
                return num.lit(0.0);
            }
            let from_lambda = (0..nx).map(|i| (p.G[(i, a)], at1(&lambda, i)));
            let from_u = (0..nu).map(|b| (2.0 * qp.R[(a, b)], at1(&u, b)));
            num.sum(None, from_lambda.chain(from_u))
        })
        .collect();
    let d_param = linear_params(p);
    let row = reference_row(p);
    let moves = moves(p, num);
    let input = reads_input.then(|| quote!(let u: [Real; NU] = [#(#inputs),*];));
    quote! {
        /// ∇J(v) without H: a forward sweep of the dynamics, then a backward adjoint sweep (O(N)).
        /// λ_k = 2W_k(x_k − r_k) + Fᵀλ_{k+1}, g_k = Gᵀλ_{k+1} + 2R·u_k, W_k = Q, and Qf at the last step.
        #[inline(always)]
        fn adjoint_gradient(v: &Plan, x0: &[Real; NX], #d_param xref: &[[Real; #row]; N], g: &mut Plan) {
            // The predicted states x_1 … x_N.
            let mut x = [[0.0; NX]; N];
            let mut prev = *x0;
            for (x_k, v_k) in x.iter_mut().zip(v.iter()) {
                let u: [Real; NU] = [#(#inputs),*];
                *x_k = [#(#forward),*];
                prev = *x_k;
            }
            let mut lambda = [0.0; NX];
            let steps = #steps;
            for #backward {
                #input
                #prologue
                let we: [Real; NX] = #weighted;
                lambda = [#(#adjoint),*];
                *g_k = [#(#grad),*];
            }
            #moves
        }
    }
}

/// The moves' part of the gradient, 2R_du(Δ_k − Δ_{k+1}) with Δ_k = v_k − v_{k−1}, v_{−1} = u₋₁ (`last`)
/// and Δ_N = 0; nothing without weighted moves. The moves are those of the command v, which a disturbance
/// estimate does not change.
fn moves(p: &Problem, num: Num) -> TokenStream {
    if !p.has_moves() {
        return quote!();
    }
    let nu = p.nu;
    let (v_k, before, m, g_k) = (quote!(v_k), quote!(before), quote!(m), quote!(g_k));
    let delta = (0..nu).map(|a| {
        let (va, ba) = (at1(&v_k, a), at1(&before, a));
        quote!(#va - #ba)
    });
    let change = (0..nu).map(|a| {
        let a = Literal::usize_unsuffixed(a);
        quote!(d_k[#a] - d_next[#a])
    });
    // An input whose moves are not weighted keeps its gradient entry.
    let weighted = |a: usize| (0..nu).any(|b| num.round(p.qp.R_du[(a, b)]) != 0.0);
    let add = (0..nu).filter(|a| weighted(*a)).map(|a| {
        let sum = num.sum(None, (0..nu).map(|b| (2.0 * p.qp.R_du[(a, b)], at1(&m, b))));
        let a = Literal::usize_unsuffixed(a);
        quote!(#g_k[#a] += #sum;)
    });
    quote! {
        // The moves Δ_k = v_k − v_{k−1}, from the last input.
        let mut delta = [[0.0; NU]; N];
        let mut before = *last;
        for (d_k, v_k) in delta.iter_mut().zip(v.iter()) {
            *d_k = [#(#delta),*];
            for (b, v) in before.iter_mut().zip(v_k.iter()) {
                *b = *v;
            }
        }
        let next = delta.iter().skip(1).chain(core::iter::once(&[0.0; NU]));
        for ((g_k, d_k), d_next) in g.iter_mut().zip(delta.iter()).zip(next) {
            let m: [Real; NU] = [#(#change),*];
            #(#add)*
        }
    }
}

/// 2W_k·e_k: the terminal weighting at the last step, the stage weighting before; one expression when
/// Qf = Q.
/// Returns the backward loop's head and the weighting.
fn stage_or_terminal(
    stage: &[TokenStream],
    terminal: &[TokenStream],
    step: TokenStream,
) -> (TokenStream, TokenStream) {
    let same = stage
        .iter()
        .zip(terminal)
        .all(|(s, t)| s.to_string() == t.to_string());
    if same {
        (quote!(#step in steps.rev()), quote!([#(#stage),*]))
    } else {
        (
            quote!((k, #step) in steps.enumerate().rev()),
            quote!(if k + 1 == N { [#(#terminal),*] } else { [#(#stage),*] }),
        )
    }
}

/// The lane operations the sweeps call, so that only those are emitted.
#[derive(Default)]
struct LaneOps(RefCell<BTreeSet<&'static str>>);

impl LaneOps {
    /// `op(args)`, recorded.
    fn call(&self, op: &'static str, args: TokenStream) -> TokenStream {
        self.0.borrow_mut().insert(op);
        let op = quote::format_ident!("{}", op);
        quote!(#op(#args))
    }
}

/// `acc ± c·x …` over lane vectors through the `lane_*` helpers, ±1 as plain additions, zeros skipped.
fn lane_sum(
    num: Num,
    ops: &LaneOps,
    base: Option<TokenStream>,
    terms: Vec<(f64, TokenStream)>,
) -> TokenStream {
    let mut out = base;
    for (c, x) in terms {
        let c = num.round(c);
        if c == 0.0 {
            continue;
        }
        out = Some(match (out, c) {
            (None, 1.0) => x,
            (Some(acc), 1.0) => ops.call("lane_add", quote!(#acc, #x)),
            (Some(acc), -1.0) => ops.call("lane_sub", quote!(#acc, #x)),
            (None, c) => {
                let c = num.lit(c);
                ops.call("lane_scale", quote!(#c, #x))
            }
            (Some(acc), c) => {
                let c = num.lit(c);
                ops.call("lane_mul_add", quote!(#acc, #c, #x))
            }
        });
    }
    out.unwrap_or_else(|| quote!([0.0; LANES]))
}

/// The sweeps with component s of every lane in one vector: x[s·NU + a] is lane a's component s.
fn in_lanes(p: &Problem, m: &ModelLanes, num: Num) -> TokenStream {
    let (nu, nd) = (p.nu, p.nd());
    let lanes = lane_count(nu);
    let S = m.F.nrows();
    let s_lit = Literal::usize_unsuffixed(S);
    let ix = |i: usize| Literal::usize_unsuffixed(i);
    // Lane vector of component s of a state array: [x[s·NU], …, x[s·NU + NU − 1], 0, …].
    let gather = |name: TokenStream, s: usize| {
        let items = (0..lanes).map(|a| {
            if a < nu {
                let i = ix(s * nu + a);
                quote!(#name[#i])
            } else {
                num.lit(0.0)
            }
        });
        quote!([#(#items),*])
    };
    let vec_at = |name: &str, s: usize| {
        let name = quote::format_ident!("{}", name);
        let s = ix(s);
        quote!(#name[#s])
    };
    let ops = LaneOps::default();
    let x0 = (0..S).map(|s| gather(quote!(x0), s));
    let input = if nd > 0 {
        let d = (0..lanes).map(|a| {
            if a < nu {
                let a = ix(a);
                quote!(d[#a])
            } else {
                num.lit(0.0)
            }
        });
        (
            quote!(let disturbance: [Real; LANES] = [#(#d),*];),
            ops.call("lane_add", quote!(*v_k, disturbance)),
        )
    } else {
        (quote!(), quote!(*v_k))
    };
    let (d_lanes, u_k) = input;
    let forward = (0..S)
        .map(|s| {
            let from_x = (0..S).map(|t| (m.F[(s, t)], vec_at("prev", t)));
            let from_u = std::iter::once((m.G[(s, 0)], quote!(u)));
            lane_sum(num, &ops, None, from_x.chain(from_u).collect())
        })
        .collect::<Vec<_>>();
    let error = (0..S)
        .map(|s| {
            let r = gather(quote!(r_k), s);
            let x = vec_at("x_k", s);
            ops.call("lane_sub", quote!(#x, #r))
        })
        .collect::<Vec<_>>();
    let weighted = |W: &DMatrix<f64>| -> Vec<TokenStream> {
        (0..S)
            .map(|s| {
                let terms = (0..S).map(|t| (2.0 * W[(s, t)], vec_at("e", t))).collect();
                lane_sum(num, &ops, None, terms)
            })
            .collect()
    };
    let (backward, weighted) = stage_or_terminal(
        &weighted(&m.Q),
        &weighted(&m.Qf),
        quote!(((g_k, x_k), (r_k, v_k))),
    );
    let adjoint = (0..S)
        .map(|s| {
            let terms = (0..S).map(|t| (m.F[(t, s)], vec_at("lambda", t))).collect();
            lane_sum(num, &ops, Some(vec_at("we", s)), terms)
        })
        .collect::<Vec<_>>();
    let gradient = {
        let from_lambda = (0..S).map(|s| (m.G[(s, 0)], vec_at("lambda", s)));
        let from_u = std::iter::once((2.0 * m.R[(0, 0)], quote!(u)));
        lane_sum(num, &ops, None, from_lambda.chain(from_u).collect())
    };
    let d_param = linear_params(p);
    let helpers = lane_helpers(neon::applies(p), &ops.0.borrow());
    quote! {
        #helpers

        /// ∇J(v) without H, every lane at once: a forward sweep of the dynamics, then a backward adjoint
        /// sweep (O(N)), on vectors of one state component across the lanes (F = F_axis ⊗ I).
        /// λ_k = 2W_k(x_k − r_k) + Fᵀλ_{k+1}, g_k = Gᵀλ_{k+1} + 2R·u_k, W_k = Q, and Qf at the last step.
        #[inline(always)]
        fn adjoint_gradient(v: &Plan, x0: &[Real; NX], #d_param xref: &[[Real; NX]; N], g: &mut Plan) {
            #d_lanes
            // The predicted states x_1 … x_N, component by component.
            let mut x = [[[0.0; LANES]; #s_lit]; N];
            let mut prev: [[Real; LANES]; #s_lit] = [#(#x0),*];
            for (x_k, v_k) in x.iter_mut().zip(v.iter()) {
                let u = #u_k;
                *x_k = [#(#forward),*];
                prev = *x_k;
            }
            let mut lambda = [[0.0; LANES]; #s_lit];
            let steps = g.iter_mut().zip(x.iter()).zip(xref.iter().zip(v.iter()));
            for #backward {
                let u = #u_k;
                let e: [[Real; LANES]; #s_lit] = [#(#error),*];
                let we: [[Real; LANES]; #s_lit] = #weighted;
                lambda = [#(#adjoint),*];
                *g_k = #gradient;
            }
        }
    }
}

/// The lane operations `used`, in a fixed order: loops over the lanes, and their NEON twins on the A9.
fn lane_helpers(neon: bool, used: &BTreeSet<&'static str>) -> TokenStream {
    let portable_cfg = if neon { neon::portable_cfg() } else { quote!() };
    let ops = ["lane_add", "lane_sub", "lane_scale", "lane_mul_add"]
        .into_iter()
        .filter(|op| used.contains(op));
    let helpers = ops.map(|op| {
        let (doc, portable) = portable_lane_helper(op);
        let twin = neon.then(|| neon::lane_helper(op));
        quote! {
            #[doc = #doc]
            #portable_cfg
            #[inline(always)]
            #portable
            #twin
        }
    });
    let lane_op = (neon && !used.is_empty()).then(neon::lane_op);
    quote! {
        #lane_op
        #(#helpers)*
    }
}

/// The portable lane operation `op`.
fn portable_lane_helper(op: &str) -> (&'static str, TokenStream) {
    match op {
        "lane_add" => (
            " a + b, lane by lane.",
            quote! {
                fn lane_add(a: [Real; LANES], b: [Real; LANES]) -> [Real; LANES] {
                    let mut out = a;
                    for (o, b) in out.iter_mut().zip(b.iter()) {
                        *o += *b;
                    }
                    out
                }
            },
        ),
        "lane_sub" => (
            " a − b, lane by lane.",
            quote! {
                fn lane_sub(a: [Real; LANES], b: [Real; LANES]) -> [Real; LANES] {
                    let mut out = a;
                    for (o, b) in out.iter_mut().zip(b.iter()) {
                        *o -= *b;
                    }
                    out
                }
            },
        ),
        "lane_scale" => (
            " c·a, lane by lane.",
            quote! {
                fn lane_scale(c: Real, a: [Real; LANES]) -> [Real; LANES] {
                    let mut out = a;
                    for o in out.iter_mut() {
                        *o *= c;
                    }
                    out
                }
            },
        ),
        _ => (
            " acc + c·a, lane by lane.",
            quote! {
                fn lane_mul_add(acc: [Real; LANES], c: Real, a: [Real; LANES]) -> [Real; LANES] {
                    let mut out = acc;
                    for (o, a) in out.iter_mut().zip(a.iter()) {
                        *o += c * *a;
                    }
                    out
                }
            },
        ),
    }
}
