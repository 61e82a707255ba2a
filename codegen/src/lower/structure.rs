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

/// Which entries of a matrix can be nonzero: `true` where the value is not exactly zero.
pub fn pattern(M: &DMatrix<f64>) -> DMatrix<bool> {
    M.map(|v| v != 0.0)
}

/// The structural pattern of A·B: (i, j) can be nonzero when some k has both A(i, k) and B(k, j).
pub fn pattern_product(A: &DMatrix<bool>, B: &DMatrix<bool>) -> DMatrix<bool> {
    DMatrix::from_fn(A.nrows(), B.ncols(), |i, j| {
        (0..A.ncols()).any(|k| A[(i, k)] && B[(k, j)])
    })
}

/// The multiply-adds of A·B over the structural nonzeros: the triples (i, k, j) with A(i, k) and B(k, j).
pub fn pattern_product_macs(A: &DMatrix<bool>, B: &DMatrix<bool>) -> usize {
    (0..A.nrows())
        .flat_map(|i| (0..B.ncols()).map(move |j| (i, j)))
        .map(|(i, j)| (0..A.ncols()).filter(|k| A[(i, *k)] && B[(*k, j)]).count())
        .sum()
}

/// The pattern of the inverse of a symmetric positive definite matrix with pattern `S`: its connected
/// components, each full. An LDLᵀ factorization creates no fill between components, so every entry
/// outside them is exactly zero in any precision.
pub fn pattern_inverse(S: &DMatrix<bool>) -> DMatrix<bool> {
    let n = S.nrows();
    let mut reach = S.clone();
    for i in 0..n {
        reach[(i, i)] = true;
    }
    // Transitive closure (Warshall): n is the measurement dimension, small.
    for k in 0..n {
        for i in 0..n {
            for j in 0..n {
                if reach[(i, k)] && reach[(k, j)] {
                    reach[(i, j)] = true;
                }
            }
        }
    }
    reach
}

/// The entries of the time-varying filter's covariance that can ever be nonzero: the smallest pattern
/// that holds P0 and is closed under the prediction F·P·Fᵀ + Q and the Joseph update
/// (I − KC)·P·(I − KC)ᵀ + K·R·Kᵀ with K = P·Cᵀ·(C·P·Cᵀ + R)⁻¹. For the double integrator with
/// independent axes it is one 2 × 2 block per axis: 12 of 36 entries for three axes.
pub fn covariance_pattern(
    F: &DMatrix<f64>,
    C: &DMatrix<f64>,
    Q: &DMatrix<f64>,
    R: &DMatrix<f64>,
    P0: &DMatrix<f64>,
) -> DMatrix<bool> {
    let (F, C, Q, R) = (pattern(F), pattern(C), pattern(Q), pattern(R));
    let or = |A: &DMatrix<bool>, B: &DMatrix<bool>| A.zip_map(B, |a, b| a || b);
    let n = F.nrows();
    let identity = DMatrix::from_fn(n, n, |i, j| i == j);
    let mut P = or(&pattern(P0), &Q);
    loop {
        let prior = or(
            &pattern_product(&pattern_product(&F, &P), &F.transpose()),
            &Q,
        );
        let PCt = pattern_product(&prior, &C.transpose());
        let S = or(&pattern_product(&C, &PCt), &R);
        let K = pattern_product(&PCt, &pattern_inverse(&S));
        let A = or(&identity, &pattern_product(&K, &C));
        let joseph = pattern_product(&pattern_product(&A, &prior), &A.transpose());
        let posterior = or(
            &joseph,
            &pattern_product(&pattern_product(&K, &R), &K.transpose()),
        );
        let next = or(&or(&P, &prior), &posterior);
        if next == P {
            return P;
        }
        P = next;
    }
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
    fn the_double_integrators_covariance_stays_one_block_per_axis() {
        let (F, _, C) =
            crate::lower::plant(&mpc_spec::ModelKind::DoubleIntegrator { axes: 3 }, 0.01).unwrap();
        let Q = crate::lower::white_acceleration_noise(3, 0.01, 0.5);
        let R = DMatrix::identity(3, 3) * 0.09;
        let P = covariance_pattern(&F, &C, &Q, &R, &DMatrix::identity(6, 6));
        // x = [positions; velocities]: axis a owns states a and 3 + a.
        let same_axis = DMatrix::from_fn(6, 6, |i, j| i % 3 == j % 3);
        assert_eq!(P, same_axis);
        assert_eq!(P.iter().filter(|b| **b).count(), 12);
        // A full P0 couples everything.
        let full = covariance_pattern(&F, &C, &Q, &R, &DMatrix::from_element(6, 6, 0.1));
        assert!(full.iter().all(|b| *b));
    }

    #[test]
    fn the_inverse_of_a_block_pattern_keeps_its_blocks() {
        let S = DMatrix::from_row_slice(
            3,
            3,
            &[true, false, true, false, true, false, true, false, true],
        );
        assert_eq!(pattern_inverse(&S), S);
        let chain = DMatrix::from_row_slice(
            3,
            3,
            &[true, true, false, true, true, true, false, true, true],
        );
        assert!(pattern_inverse(&chain).iter().all(|b| *b));
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

/// The envelope (profile) of a symmetric sparsity pattern, after an ordering that puts each connected
/// component's indices together (the drone's independent axes become diagonal blocks). An L·D·Lᵀ
/// factorisation fills nothing outside the envelope, so it and its triangular solves only visit row p's
/// columns `first[p]..p` (A. George and J. W. Liu, *Computer Solution of Large Sparse Positive Definite
/// Systems*, 1981, ch. 4). The ordering keeps the original order within a component, and the components
/// in the order of their first index; without independent components it is the identity.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Envelope {
    /// `order[p]`: the original index at position p.
    pub order: Vec<usize>,
    /// `position[i]`: the position of original index i (the inverse of `order`).
    pub position: Vec<usize>,
    /// `first[p]`: the first column (in positions) of row p's envelope, at most p.
    pub first: Vec<usize>,
}

impl Envelope {
    /// The envelope of the symmetric `pattern` (only its lower triangle and diagonal are read, both
    /// triangles are assumed alike).
    pub fn of(pattern: &DMatrix<bool>) -> Self {
        let n = pattern.nrows();
        // Connected components by union-find over the off-diagonal entries.
        let mut parent: Vec<usize> = (0..n).collect();
        fn root(parent: &mut [usize], mut i: usize) -> usize {
            while parent[i] != i {
                parent[i] = parent[parent[i]];
                i = parent[i];
            }
            i
        }
        for i in 0..n {
            for j in 0..i {
                if pattern[(i, j)] || pattern[(j, i)] {
                    let (a, b) = (root(&mut parent, i), root(&mut parent, j));
                    if a != b {
                        parent[a.max(b)] = a.min(b);
                    }
                }
            }
        }
        let roots: Vec<usize> = (0..n).map(|i| root(&mut parent, i)).collect();
        let mut order: Vec<usize> = (0..n).collect();
        // Stable: within a component the original order; components by their smallest index (the root).
        order.sort_by_key(|&i| roots[i]);
        let mut position = vec![0; n];
        for (p, &i) in order.iter().enumerate() {
            position[i] = p;
        }
        let first = (0..n)
            .map(|p| {
                let i = order[p];
                (0..=p)
                    .find(|&q| {
                        let j = order[q];
                        q == p || pattern[(i, j)] || pattern[(j, i)]
                    })
                    .unwrap_or(p)
            })
            .collect();
        Envelope {
            order,
            position,
            first,
        }
    }

    /// The number of indices.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// Entries of the lower triangle inside the envelope, diagonal included.
    pub fn entries(&self) -> usize {
        self.first.iter().enumerate().map(|(p, f)| p - f + 1).sum()
    }

    /// One past the last row whose envelope reaches column j (j + 1 when none below it does): the
    /// rows an L·D·Lᵀ step at column j updates lie in j + 1..reach(j).
    pub fn reach(&self, j: usize) -> usize {
        (j + 1..self.len())
            .rfind(|&p| self.first[p] <= j)
            .map_or(j + 1, |p| p + 1)
    }

    /// Multiply-adds of L·D·Lᵀ within the envelope: per column j, the pivot's `j − first[j]` and, per row
    /// p > j whose envelope reaches j, `j − max(first[p], first[j])`.
    pub fn ldl_macs(&self) -> usize {
        let mut macs = 0;
        for j in 0..self.len() {
            macs += j - self.first[j];
            for p in j + 1..self.reach(j) {
                if self.first[p] <= j {
                    macs += j - self.first[p].max(self.first[j]) + 1;
                }
            }
        }
        macs
    }

    /// Multiply-adds of the two triangular solves and the diagonal within the envelope.
    pub fn solve_macs(&self) -> usize {
        2 * (self.entries() - self.len()) + self.len()
    }
}
