//! Structure the emitter can exploit, read off the f64 matrices themselves (never off the spec's model
//! `type`, so that a `linear` spec with the same structure gets the same code).
//!
//! The condensed QP orders its decision variables step-major, U = [u₀; u₁; …; u_{N−1}], so H is an
//! N × N grid of nu × nu blocks. When every block is a multiple of the identity, H = H_axis ⊗ I_nu: the
//! input's components are independent problems with one shared N × N matrix, and they can run side by
//! side in SIMD lanes with one set of constants (the drone's three axes).
#![allow(non_snake_case)]

use nalgebra::DMatrix;

/// Where `M = A ⊗ I_p` fails: the first entry that breaks the pattern.
#[derive(Clone, Debug, PartialEq)]
pub struct NotKronecker {
    /// Row and column of the entry in M.
    pub entry: (usize, usize),
    /// Its value.
    pub value: f64,
    /// What it should have been (0 off the lanes' diagonal, or the first lane's value).
    pub expected: f64,
}

/// The A of `M = A ⊗ I_p`, with M an (n·p) × (n·p) matrix of p × p blocks, or the entry that breaks it.
///
/// Entries are compared with a tolerance of 8ε·max|M|: what rounding leaves of an exact structure (the
/// lanes are computed by the same sums over different positions) and far below what the emitted scalar
/// can resolve. The first lane's values are the ones kept.
pub fn kronecker_identity(M: &DMatrix<f64>, p: usize) -> Result<DMatrix<f64>, NotKronecker> {
    assert!(p > 0 && M.nrows().is_multiple_of(p) && M.ncols().is_multiple_of(p));
    let tol = 8.0 * f64::EPSILON * M.amax();
    let (n, m) = (M.nrows() / p, M.ncols() / p);
    let A = DMatrix::from_fn(n, m, |i, j| M[(i * p, j * p)]);
    for (r, c) in (0..M.nrows()).flat_map(|r| (0..M.ncols()).map(move |c| (r, c))) {
        let expected = if r % p == c % p {
            A[(r / p, c / p)]
        } else {
            0.0
        };
        let value = M[(r, c)];
        if (value - expected).abs() > tol || !value.is_finite() {
            return Err(NotKronecker {
                entry: (r, c),
                value,
                expected,
            });
        }
    }
    Ok(A)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_the_factor_of_a_kronecker_product() {
        let A = DMatrix::from_row_slice(2, 2, &[2.0, -1.0, -1.0, 3.0]);
        let M = A.kronecker(&DMatrix::<f64>::identity(3, 3));
        assert_eq!(kronecker_identity(&M, 3), Ok(A.clone()));
        // p = 1 is always a Kronecker product: A itself.
        assert_eq!(kronecker_identity(&M, 1).unwrap(), M);
    }

    #[test]
    fn names_the_entry_that_couples_two_lanes() {
        let A = DMatrix::from_row_slice(2, 2, &[2.0, -1.0, -1.0, 3.0]);
        let mut M = A.kronecker(&DMatrix::<f64>::identity(2, 2));
        M[(0, 3)] = 0.5;
        let e = kronecker_identity(&M, 2).unwrap_err();
        assert_eq!((e.entry, e.value, e.expected), ((0, 3), 0.5, 0.0));
    }

    #[test]
    fn names_the_lane_that_differs() {
        let A = DMatrix::from_row_slice(2, 2, &[2.0, -1.0, -1.0, 3.0]);
        let mut M = A.kronecker(&DMatrix::<f64>::identity(2, 2));
        M[(3, 3)] = 3.5;
        let e = kronecker_identity(&M, 2).unwrap_err();
        assert_eq!((e.entry, e.value, e.expected), ((3, 3), 3.5, 3.0));
    }

    #[test]
    fn rounding_noise_is_structure_a_real_coupling_is_not() {
        let A = DMatrix::from_row_slice(1, 1, &[4.0]);
        let mut M = A.kronecker(&DMatrix::<f64>::identity(2, 2));
        M[(1, 1)] = 4.0 * (1.0 + f64::EPSILON);
        assert!(kronecker_identity(&M, 2).is_ok());
        M[(0, 1)] = 1e-9;
        assert!(kronecker_identity(&M, 2).is_err());
    }
}
