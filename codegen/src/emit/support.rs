//! Scalar helpers and runtime matrix products shared by the emitted filter and MPC. They use iterators
//! only: nothing can index out of bounds, so nothing can panic.

use proc_macro2::TokenStream;
use quote::quote;

/// The helper functions, emitted once per module.
pub fn emit() -> TokenStream {
    quote! {
        /// The projection onto [lo, hi]; NaN maps to `lo`, so the result is always finite and in the box.
        #[inline(always)]
        fn project(v: Real, lo: Real, hi: Real) -> Real {
            let v = if v > lo { v } else { lo };
            if v < hi { v } else { hi }
        }

        /// Whether every entry is finite.
        #[inline(always)]
        fn all_finite(v: &[Real]) -> bool {
            v.iter().all(|x| x.is_finite())
        }

        /// A·B.
        #[inline(always)]
        fn mat_mul<const R: usize, const K: usize, const C: usize>(a: &[[Real; K]; R], b: &[[Real; C]; K]) -> [[Real; C]; R] {
            let mut out = [[0.0; C]; R];
            for (out_i, a_i) in out.iter_mut().zip(a.iter()) {
                for (a_ik, b_k) in a_i.iter().zip(b.iter()) {
                    for (o, b_kj) in out_i.iter_mut().zip(b_k.iter()) {
                        *o += *a_ik * *b_kj;
                    }
                }
            }
            out
        }

        /// A·Bᵀ.
        #[inline(always)]
        fn mat_mul_transposed<const R: usize, const K: usize, const C: usize>(a: &[[Real; K]; R], b: &[[Real; K]; C]) -> [[Real; C]; R] {
            let mut out = [[0.0; C]; R];
            for (out_i, a_i) in out.iter_mut().zip(a.iter()) {
                for (o, b_j) in out_i.iter_mut().zip(b.iter()) {
                    *o = a_i.iter().zip(b_j.iter()).fold(0.0, |acc, (x, y)| acc + *x * *y);
                }
            }
            out
        }

        /// (M + Mᵀ)/2.
        #[inline(always)]
        fn symmetrized<const D: usize>(m: &[[Real; D]; D]) -> [[Real; D]; D] {
            let mut out = *m;
            for (i, out_i) in out.iter_mut().enumerate() {
                for (o, m_j) in out_i.iter_mut().zip(m.iter()) {
                    if let Some(m_ji) = m_j.get(i) {
                        *o = 0.5 * (*o + *m_ji);
                    }
                }
            }
            out
        }
    }
}
