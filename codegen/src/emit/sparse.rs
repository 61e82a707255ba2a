//! Matrices whose structure the emitter knows: every entry is a structural zero, a constant, or a
//! run-time value. Products emit one `let` per entry that can be nonzero and skip every term with a
//! structural zero, so the filter's covariance arithmetic only touches what is not always zero.
#![allow(non_snake_case)]

use super::tokens::Num;
use nalgebra::DMatrix;
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

/// One entry.
#[derive(Clone, Debug)]
pub enum Entry {
    /// Zero in every run.
    Zero,
    /// A compile-time constant (rounded to the emitted type when written).
    Const(f64),
    /// A run-time value: an expression that is a plain place or binding.
    Var(TokenStream),
}

/// A rows × cols matrix of entries.
#[derive(Clone, Debug)]
pub struct Sym {
    rows: usize,
    cols: usize,
    entries: Vec<Entry>,
}

impl Sym {
    fn from_fn(rows: usize, cols: usize, mut f: impl FnMut(usize, usize) -> Entry) -> Self {
        let entries = (0..rows)
            .flat_map(|i| (0..cols).map(move |j| (i, j)))
            .map(|(i, j)| f(i, j))
            .collect();
        Sym {
            rows,
            cols,
            entries,
        }
    }

    /// Entry (i, j).
    pub fn at(&self, i: usize, j: usize) -> &Entry {
        &self.entries[i * self.cols + j]
    }

    /// A constant matrix; entries zero in the emitted type are structural zeros.
    pub fn constant(M: &DMatrix<f64>, num: Num) -> Self {
        Sym::from_fn(M.nrows(), M.ncols(), |i, j| match num.round(M[(i, j)]) {
            0.0 => Entry::Zero,
            _ => Entry::Const(M[(i, j)]),
        })
    }

    /// `name[i][j]` where `pattern` allows a nonzero, structural zeros elsewhere.
    pub fn place(name: &TokenStream, pattern: &DMatrix<bool>) -> Self {
        Sym::from_fn(pattern.nrows(), pattern.ncols(), |i, j| {
            if pattern[(i, j)] {
                let (i, j) = (Literal::usize_unsuffixed(i), Literal::usize_unsuffixed(j));
                Entry::Var(quote!(#name[#i][#j]))
            } else {
                Entry::Zero
            }
        })
    }

    /// A column of run-time values.
    pub fn column(values: Vec<TokenStream>) -> Self {
        let rows = values.len();
        Sym {
            rows,
            cols: 1,
            entries: values.into_iter().map(Entry::Var).collect(),
        }
    }

    /// Entry i of a column as an expression.
    pub fn element(&self, i: usize, num: Num) -> TokenStream {
        write(self.at(i, 0), num)
    }

    /// The transpose.
    pub fn transpose(&self) -> Self {
        Sym::from_fn(self.cols, self.rows, |i, j| self.at(j, i).clone())
    }

    /// The structural pattern.
    pub fn pattern(&self) -> DMatrix<bool> {
        DMatrix::from_fn(self.rows, self.cols, |i, j| {
            !matches!(self.at(i, j), Entry::Zero)
        })
    }

    /// `[[..], ..]`, structural zeros written as `0.0`.
    pub fn array(&self, num: Num) -> TokenStream {
        let rows = (0..self.rows).map(|i| {
            let row = (0..self.cols).map(|j| write(self.at(i, j), num));
            quote!([#(#row),*])
        });
        quote!([#(#rows),*])
    }
}

/// An entry as an expression.
fn write(e: &Entry, num: Num) -> TokenStream {
    match e {
        Entry::Zero => num.lit(0.0),
        Entry::Const(c) => num.lit(*c),
        Entry::Var(v) => v.clone(),
    }
}

/// Binds every entry of `terms(i, j)` (a constant part and run-time terms `(coefficient, value)`) that
/// can be nonzero to `name_i_j`, and returns the statements and the matrix of bindings.
fn bind(
    rows: usize,
    cols: usize,
    name: &str,
    num: Num,
    terms: impl Fn(usize, usize) -> (f64, Vec<(f64, TokenStream)>),
) -> (Vec<TokenStream>, Sym) {
    let mut statements = Vec::new();
    let sym = Sym::from_fn(rows, cols, |i, j| {
        let (constant, run_time) = terms(i, j);
        if run_time.is_empty() {
            return if num.round(constant) == 0.0 {
                Entry::Zero
            } else {
                Entry::Const(constant)
            };
        }
        let base = (num.round(constant) != 0.0).then(|| num.lit(constant));
        let sum = num.sum(base, run_time);
        let binding = format_ident!("{}_{}_{}", name, i, j);
        statements.push(quote!(let #binding: Real = #sum;));
        Entry::Var(quote!(#binding))
    });
    // `from_fn` visits entries in order, so the statements are in row-major order.
    (statements, sym)
}

/// One term of a product: a constant (folded at compile time) or a run-time term.
fn term(a: &Entry, b: &Entry) -> Option<Result<f64, (f64, TokenStream)>> {
    match (a, b) {
        (Entry::Zero, _) | (_, Entry::Zero) => None,
        (Entry::Const(x), Entry::Const(y)) => Some(Ok(x * y)),
        (Entry::Const(c), Entry::Var(v)) | (Entry::Var(v), Entry::Const(c)) => {
            Some(Err((*c, v.clone())))
        }
        // Unparenthesized: `Num::sum` groups a product it scales, and adds or subtracts it as it is.
        (Entry::Var(x), Entry::Var(y)) => Some(Err((1.0, quote!(#x * #y)))),
    }
}

/// A·B (+ C), bound to `name_i_j`.
pub fn product(
    num: Num,
    name: &str,
    A: &Sym,
    B: &Sym,
    plus: Option<&Sym>,
) -> (Vec<TokenStream>, Sym) {
    assert_eq!(A.cols, B.rows);
    bind(A.rows, B.cols, name, num, |i, j| {
        let mut constant = 0.0;
        let mut run_time = Vec::new();
        let extra = plus.map(|C| C.at(i, j).clone()).unwrap_or(Entry::Zero);
        let products = (0..A.cols).filter_map(|k| term(A.at(i, k), B.at(k, j)));
        let added = match &extra {
            Entry::Zero => None,
            Entry::Const(c) => Some(Ok(*c)),
            Entry::Var(v) => Some(Err((1.0, v.clone()))),
        };
        for t in products.chain(added) {
            match t {
                Ok(c) => constant += c,
                Err(t) => run_time.push(t),
            }
        }
        (constant, run_time)
    })
}

/// (M + Mᵀ)/2 over the entries that can be nonzero, bound to `name_i_j`.
pub fn symmetrized(num: Num, name: &str, M: &Sym) -> (Vec<TokenStream>, Sym) {
    bind(M.rows, M.cols, name, num, |i, j| {
        let mut constant = 0.0;
        let mut run_time = Vec::new();
        for e in [M.at(i, j), M.at(j, i)] {
            match e {
                Entry::Zero => {}
                Entry::Const(c) => constant += 0.5 * c,
                Entry::Var(v) => run_time.push((0.5, v.clone())),
            }
        }
        (constant, run_time)
    })
}
