//! Straight-line kernels over the interior-point method's constant structure: G·z, Gᵀ·v, H·z and the
//! forming of the normal matrix H + Gᵀ·diag(w)·G, each written out entry by entry with the
//! coefficients as literals and every index a constant.
//!
//! Why: the rows are short (a speed row of the paper's drone is its axis's inputs so far and its
//! slack), so loops over tables of them spent most of their instructions on loop set-up and range
//! checks (benchmarks/NOTES.md, "The interior-point method on the emulated Zynq"). With constant indices
//! into fixed-size arrays there is nothing to check at run time and nothing that can panic, and the
//! code is as long as the work: G·z and Gᵀ·v are one term per nonzero of the rows, H·z one per
//! nonzero of H, the forming one per nonzero product of two entries of a row (Σ nnz²/2, the cost
//! model's count). Only the forming can grow large (a dense row of the condensed QP has N·nu
//! entries); above [`FORM_BUDGET`] terms it stays a loop over the rows' runs (`interior.rs`).

use crate::emit::tokens::{at, Num};
use crate::lower::structure::Envelope;
use crate::solver::ipm::{InequalityQp, Layout, Sparsity};
use mpc_spec::Scalar;
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote, ToTokens};

/// The forming is written out when it has at most this many terms (multiply-adds of Σ nnz²/2, one
/// store per entry of the envelope besides). At about 12 bytes a term this is at most ~200 KB of
/// code, run once an iteration.
pub const FORM_BUDGET: usize = 16_384;

/// The constant structure, in the method's order.
pub struct Rows<'a> {
    qp: &'a InequalityQp,
    layout: &'a Layout,
    sparsity: &'a Sparsity,
}

impl<'a> Rows<'a> {
    pub fn new(qp: &'a InequalityQp, layout: &'a Layout, sparsity: &'a Sparsity) -> Self {
        Rows {
            qp,
            layout,
            sparsity,
        }
    }

    fn nb(&self) -> usize {
        self.layout.boxed.len()
    }

    /// Distinct row k's entries: (position, value).
    fn row(&self, k: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let (r, order) = (self.sparsity.rows[k], &self.sparsity.envelope.order);
        self.sparsity.row_positions[k]
            .iter()
            .map(move |&q| (q, self.qp.A[(r, order[q])]))
    }

    /// Per distinct row, its sides: (index among all sides, sign).
    fn sides_of(&self, k: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let nb = self.nb();
        self.sparsity
            .side_row
            .iter()
            .zip(&self.layout.rows)
            .enumerate()
            .filter(move |(_, (row, _))| **row == k)
            .map(move |(j, (_, &(_, sign)))| (nb + j, sign))
    }

    /// The box sides at position p: (index among all sides, sign).
    fn box_sides_at(&self, p: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let position = &self.sparsity.envelope.position;
        self.layout
            .boxed
            .iter()
            .enumerate()
            .filter(move |(_, (i, _))| position[*i] == p)
            .map(|(k, &(_, sign))| (k, sign))
    }

    /// Terms of the written-out forming: Σ over rows of nnz·(nnz + 1)/2.
    pub fn form_terms(&self) -> usize {
        self.sparsity
            .row_positions
            .iter()
            .map(|r| r.len() * (r.len() + 1) / 2)
            .sum()
    }

    /// Whether the forming is written out (see [`FORM_BUDGET`]).
    pub fn form_written_out(&self) -> bool {
        self.form_terms() <= FORM_BUDGET
    }

    /// `fn g_mul(z, out)`: out = G·z, the box's sides then the rows' (each distinct row once).
    pub fn g_mul(&self) -> TokenStream {
        let wide = Num(Scalar::F64);
        let position = &self.sparsity.envelope.position;
        let boxed = self.layout.boxed.iter().enumerate().map(|(k, &(i, sign))| {
            let value = signed(sign, at("z", position[i]));
            {
                let o = at("out", k);
                quote!(#o = #value;)
            }
        });
        let nr = self.sparsity.rows.len();
        let products = (0..nr).map(|k| {
            let name = format_ident!("a{}", k);
            let sum = wide.sum(None, self.row(k).map(|(q, v)| (v, at("z", q))));
            quote!(let #name = #sum;)
        });
        let nb = self.nb();
        let sides = self
            .sparsity
            .side_row
            .iter()
            .zip(&self.layout.rows)
            .enumerate()
            .map(|(j, (&k, &(_, sign)))| {
                let value = signed(sign, format_ident!("a{}", k).into_token_stream());
                {
                    let o = at("out", nb + j);
                    quote!(#o = #value;)
                }
            });
        quote! {
            /// G z: the box's sides, then the rows' (each distinct row once, ± per side).
            fn g_mul(z: &[f64; NV], out: &mut [f64; NSIDES]) {
                #(#boxed)*
                #(#products)*
                #(#sides)*
            }
        }
    }

    /// `fn g_tmul(v, out)`: out = Gᵀ·v.
    pub fn g_tmul(&self) -> TokenStream {
        let wide = Num(Scalar::F64);
        let nr = self.sparsity.rows.len();
        // A two-sided row's sides are ±the same row: their multipliers are combined first.
        let combined = (0..nr).map(|k| {
            let name = format_ident!("c{}", k);
            let sum = wide.sum(None, self.sides_of(k).map(|(j, s)| (s, at("v", j))));
            quote!(let #name = #sum;)
        });
        let n = self.qp.n();
        let mut by_position: Vec<Vec<(f64, TokenStream)>> = vec![Vec::new(); n];
        for k in 0..nr {
            let c = format_ident!("c{}", k);
            for (q, value) in self.row(k) {
                by_position[q].push((value, quote!(#c)));
            }
        }
        let entries = by_position.into_iter().enumerate().map(|(p, mut terms)| {
            terms.extend(self.box_sides_at(p).map(|(k, s)| (s, at("v", k))));
            let sum = wide.sum(None, terms);
            {
                let o = at("out", p);
                quote!(#o = #sum;)
            }
        });
        quote! {
            /// Gᵀ v.
            fn g_tmul(v: &[f64; NSIDES], out: &mut [f64; NV]) {
                #(#combined)*
                #(#entries)*
            }
        }
    }

    /// `fn h_mul(z, out)`: out = H·z over H's nonzeros, `h` the method's Hessian in its order.
    pub fn h_mul(&self, h: &nalgebra::DMatrix<f64>) -> TokenStream {
        let wide = Num(Scalar::F64);
        let entries = (0..h.nrows()).map(|p| {
            let sum = wide.sum(None, (0..h.ncols()).map(|q| (h[(p, q)], at("z", q))));
            {
                let o = at("out", p);
                quote!(#o = #sum;)
            }
        });
        quote! {
            /// H z over H's nonzeros.
            fn h_mul(z: &[f64; NV], out: &mut [f64; NV]) {
                #(#entries)*
            }
        }
    }

    /// `fn form(w, m)`: the lower triangle of H + Gᵀ·diag(w)·G within the envelope, written out (only
    /// when [`Rows::form_written_out`]); `h` is the method's Hessian in its order.
    pub fn form(&self, h: &nalgebra::DMatrix<f64>) -> TokenStream {
        let wide = Num(Scalar::F64);
        let nr = self.sparsity.rows.len();
        // A two-sided row's sides add their weights to one outer product.
        let weights = (0..nr).map(|k| {
            let name = format_ident!("w{}", k);
            let sum = wide.sum(None, self.sides_of(k).map(|(j, _)| (1.0, at("w", j))));
            quote!(let #name = #sum;)
        });
        let n = self.qp.n();
        let first = &self.sparsity.envelope.first;
        // Per entry (p, q), q ≤ p, of the envelope: the products of row entries that land there.
        let mut terms: Vec<Vec<Vec<(f64, TokenStream)>>> =
            (0..n).map(|p| vec![Vec::new(); p + 1 - first[p]]).collect();
        for k in 0..nr {
            let wk = format_ident!("w{}", k);
            let entries: Vec<(usize, f64)> = self.row(k).collect();
            for (a, &(pa, va)) in entries.iter().enumerate() {
                for &(pb, vb) in &entries[..=a] {
                    // Positions ascend, so pb ≤ pa; the envelope holds (pa, pb) (no fill).
                    terms[pa][pb - first[pa]].push((va * vb, quote!(#wk)));
                }
            }
        }
        let entries = terms.into_iter().enumerate().flat_map(|(p, row)| {
            let first_p = first[p];
            row.into_iter()
                .enumerate()
                .map(move |(c, mut t)| (p, first_p + c, std::mem::take(&mut t)))
        });
        let entries = entries.map(|(p, q, mut t)| {
            if p == q {
                t.extend(self.box_sides_at(p).map(|(k, _)| (1.0, at("w", k))));
            }
            let base = wide.lit(h[(p, q)]);
            let sum = wide.sum(Some(base), t);
            {
                let (p, q) = (lit(p), lit(q));
                quote!(m[#p][#q] = #sum;)
            }
        });
        quote! {
            /// The lower triangle of H + Gᵀ·diag(w)·G within the envelope.
            fn form(w: &[f64; NSIDES], m: &mut [[f64; NV]; NV]) {
                #(#weights)*
                #(#entries)*
            }
        }
    }
}

fn lit(i: usize) -> Literal {
    Literal::usize_unsuffixed(i)
}

/// `v` or `-v` for a side's sign ±1.
fn signed(sign: f64, v: TokenStream) -> TokenStream {
    if sign > 0.0 {
        v
    } else {
        quote!(-#v)
    }
}

/// Multiply-adds of the written-out L·D·Lᵀ above which it stays a loop over the envelope (`interior.rs`):
/// one statement per multiply-add, as [`FORM_BUDGET`].
pub const LDL_BUDGET: usize = 16_384;

/// Whether the factorisation and its solves are written out for `envelope` (see [`LDL_BUDGET`]).
pub fn ldl_written_out(envelope: &Envelope) -> bool {
    envelope.ldl_macs() <= LDL_BUDGET
}

/// `fn ldl(m) -> bool` and `fn ldl_solve(m, b)` written out within `envelope`: the loops of
/// `interior.rs` unrolled, the same operations in the same order (so the same rounding).
pub fn ldl(envelope: &Envelope) -> TokenStream {
    let n = envelope.len();
    let first = &envelope.first;
    let m = |p: usize, q: usize| {
        let (p, q) = (lit(p), lit(q));
        quote!(m[#p][#q])
    };
    let mut factor = Vec::new();
    for j in 0..n {
        let fj = first[j];
        let d = format_ident!("d{}", j);
        // D_k is `d{k}`: the diagonal keeps 1/D_k.
        let pivots = (fj..j).map(|k| {
            let (v, mjk, dk) = (at("v", k), m(j, k), format_ident!("d{}", k));
            quote!(#v = #mjk * #dk;)
        });
        let (mjj, terms) = (m(j, j), (fj..j).map(|k| (m(j, k), at("v", k))));
        let terms = terms.map(|(a, b)| quote!(- #a * #b));
        // One division a column: the entries below, and the solves, multiply by its reciprocal, which the
        // diagonal keeps.
        let inverse = format_ident!("inverse{}", j);
        factor.push(quote! {
            #(#pivots)*
            let #d = #mjj #(#terms)*;
            positive &= (#d > 0.0) & (#d < f64::INFINITY);
            let #inverse = 1.0 / #d;
            #mjj = #inverse;
        });
        for (p, &fp) in first.iter().enumerate().take(envelope.reach(j)).skip(j + 1) {
            if fp > j {
                continue;
            }
            let mpj = m(p, j);
            if fp.max(fj) == j {
                factor.push(quote!(#mpj *= #inverse;));
                continue;
            }
            let terms = (fp.max(fj)..j).map(|k| {
                let (a, b) = (m(p, k), at("v", k));
                quote!(- #a * #b)
            });
            factor.push(quote!(#mpj = (#mpj #(#terms)*) * #inverse;));
        }
    }
    let forward = (0..n).filter(|&i| first[i] < i).map(|i| {
        let bi = at("b", i);
        if first[i] + 1 == i {
            // One term: `b -= l·x` (the same rounding as `b = b − l·x`, which clippy would flag).
            let (a, b) = (m(i, i - 1), at("b", i - 1));
            return quote!(#bi -= #a * #b;);
        }
        let terms = (first[i]..i).map(|k| {
            let (a, b) = (m(i, k), at("b", k));
            quote!(- #a * #b)
        });
        quote!(#bi = #bi #(#terms)*;)
    });
    let diagonal = (0..n).map(|i| {
        let (bi, mii) = (at("b", i), m(i, i));
        quote!(#bi *= #mii;)
    });
    let backward = (0..n).rev().flat_map(|i| {
        (first[i]..i).map(move |k| {
            let (bk, mik, bi) = (at("b", k), m(i, k), at("b", i));
            quote!(#bk -= #mik * #bi;)
        })
    });
    quote! {
        /// L·D·Lᵀ of the lower triangle of `m` within the envelope, in place (1/D on the diagonal),
        /// written out; `false` when a pivot is not positive and finite. Nothing fills outside the
        /// envelope.
        fn ldl(m: &mut [[f64; NV]; NV]) -> bool {
            let mut v = [0.0; NV];
            let mut positive = true;
            #(#factor)*
            positive
        }

        /// Solves L·D·Lᵀ x = b in place, within the envelope, written out.
        fn ldl_solve(m: &[[f64; NV]; NV], b: &mut [f64; NV]) {
            #(#forward)*
            #(#diagonal)*
            // Lᵀ by rows of L: x_i is final once every later row has given its share.
            #(#backward)*
        }
    }
}
