//! Small token builders shared by the emitters: literals of the emitted scalar type, matrix constants,
//! and unrolled sums with exact zeros skipped. The numbers themselves (rounding, sizes) are
//! [`Numeric`]'s.

use crate::numeric::Numeric;
use mpc_spec::Scalar;
use nalgebra::DMatrix;
use proc_macro2::{Literal, TokenStream};
use quote::quote;

thread_local! {
    /// Numbers not finite in their emitted type met by [`Num::lit`] on this thread since the last
    /// [`take_non_finite`].
    static NON_FINITE: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// The numbers not finite in their emitted type that the emission on this thread met since the last
/// call (each written as NaN instead of a literal), and resets the count.
pub fn take_non_finite() -> usize {
    NON_FINITE.with(|n| n.replace(0))
}

/// Writes numbers of one scalar type as tokens.
#[derive(Clone, Copy, Debug)]
pub struct Num(pub Scalar);

impl Num {
    /// `f32` or `f64`.
    pub fn ty(self) -> TokenStream {
        match self.0 {
            Scalar::F32 => quote!(f32),
            Scalar::F64 => quote!(f64),
        }
    }

    /// The numbers of this type: rounding, sizes, nonzeros.
    pub fn numeric(self) -> Numeric {
        Numeric(self.0)
    }

    /// `v` rounded to the emitted type.
    pub fn round(self, v: f64) -> f64 {
        self.numeric().round(v)
    }

    /// A suffixed literal of `v`, with its sign as a separate token.
    pub fn lit(self, v: f64) -> TokenStream {
        let magnitude = self.unsigned(v.abs());
        if v.is_sign_negative() && v != 0.0 {
            quote!(-#magnitude)
        } else {
            magnitude
        }
    }

    fn unsigned(self, v: f64) -> TokenStream {
        // A number not finite in the emitted type has no literal (proc-macro2 asserts): the emission
        // writes NaN in its place and counts it, and `codegen::generate` refuses the module
        // ([`take_non_finite`]). Lowering's range checks keep every such number out; this is the last
        // line behind them.
        if !self.round(v).is_finite() {
            NON_FINITE.with(|n| n.set(n.get() + 1));
            let ty = self.ty();
            return quote!(#ty::NAN);
        }
        let lit = match self.0 {
            Scalar::F32 => Literal::f32_suffixed(v as f32),
            Scalar::F64 => Literal::f64_suffixed(v),
        };
        quote!(#lit)
    }

    /// `[a, b, ...]`.
    pub fn vector(self, v: impl IntoIterator<Item = f64>) -> TokenStream {
        let items = v.into_iter().map(|x| self.lit(x));
        quote!([#(#items),*])
    }

    /// `[[..], [..]]`, row by row.
    pub fn matrix(self, m: &DMatrix<f64>) -> TokenStream {
        let rows = m.row_iter().map(|r| self.vector(r.iter().copied()));
        quote!([#(#rows),*])
    }

    /// `base + c₁·v₁ − c₂·v₂ …` evaluated left to right, skipping coefficients that are zero in the
    /// emitted type and writing ±1 coefficients as a plain ± (both exact).
    pub fn sum(
        self,
        base: Option<TokenStream>,
        terms: impl IntoIterator<Item = (f64, TokenStream)>,
    ) -> TokenStream {
        let mut out = base;
        for (c, v) in terms {
            let c = self.round(c);
            if c == 0.0 {
                continue;
            }
            let term = if c.abs() == 1.0 {
                v
            } else if is_product(&v) {
                // c·(x·y), not (c·x)·y: the rounding of the product the caller wrote.
                let m = self.unsigned(c.abs());
                quote!(#m * (#v))
            } else {
                let m = self.unsigned(c.abs());
                quote!(#m * #v)
            };
            out = Some(match (out, c < 0.0) {
                (None, false) => term,
                (None, true) => quote!(-#term),
                (Some(acc), false) => quote!(#acc + #term),
                (Some(acc), true) => quote!(#acc - #term),
            });
        }
        out.unwrap_or_else(|| self.unsigned(0.0))
    }

    /// `base ± c₁·v₁ ± c₂·v₂ …` evaluated left to right, the exact tokens of the fold
    /// `terms.fold(base, |acc, (c, v)| acc + c·v)` in the emitted type: a coefficient's sign becomes the
    /// operator (acc + (−c)·v = acc − c·v exactly), ±1 is a plain ±v (exact), and no term is skipped,
    /// not even a zero (0·∞ is NaN, as in the fold). Unlike [`Num::sum`], for kernels that must match a
    /// reference to the bit.
    pub fn fold(
        self,
        base: TokenStream,
        terms: impl IntoIterator<Item = (f64, TokenStream)>,
    ) -> TokenStream {
        let mut acc = base;
        for (c, v) in terms {
            let c = self.round(c);
            let term = if c.abs() == 1.0 {
                v
            } else {
                let m = self.unsigned(c.abs());
                quote!(#m * #v)
            };
            acc = if c.is_sign_negative() {
                quote!(#acc - #term)
            } else {
                quote!(#acc + #term)
            };
        }
        acc
    }
}

/// Whether `v` is a product `x * y` at its top level (a single value is one token tree, or a name and
/// its indices).
fn is_product(v: &TokenStream) -> bool {
    v.clone()
        .into_iter()
        .any(|t| matches!(t, proc_macro2::TokenTree::Punct(p) if p.as_char() == '*'))
}

/// `name[i]` for a flat index into an `[[Real; cols]; rows]` array.
pub fn at2(name: &TokenStream, i: usize, cols: usize) -> TokenStream {
    let (r, c) = (
        Literal::usize_unsuffixed(i / cols),
        Literal::usize_unsuffixed(i % cols),
    );
    quote!(#name[#r][#c])
}

/// `name[i]` with a constant index, for a local array named by a string.
pub fn at(name: &str, i: usize) -> TokenStream {
    let (name, i) = (
        quote::format_ident!("{}", name),
        Literal::usize_unsuffixed(i),
    );
    quote!(#name[#i])
}

/// `name[i]`.
pub fn at1(name: &TokenStream, i: usize) -> TokenStream {
    let i = Literal::usize_unsuffixed(i);
    quote!(#name[#i])
}

/// `[[e0, e1], [e2, e3]]` from a flat list, `width` per block.
pub fn blocks(entries: &[TokenStream], width: usize) -> Vec<TokenStream> {
    entries.chunks(width).map(|c| quote!([#(#c),*])).collect()
}
