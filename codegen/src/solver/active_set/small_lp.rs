//! A dense LP in few variables from a feasible point, for the exact count's partition
//! ([`super::exact`]): max cᵀx s.t. aᵢᵀx ≤ bᵢ, with n ≤ a dozen unknowns and tens to hundreds of rows.
//!
//! The primal active-set method for LP in inequality form (the simplex method seen from the vertices):
//! from a feasible x, move along c projected onto the null space of the working rows until a row blocks,
//! and add it; where the projection vanishes, the working rows' multipliers (the least-squares solution of A_Wᵀ·λ = c) decide:
//! all nonnegative is the optimum, else the row of the smallest index with a negative one leaves (Bland's
//! rule, against cycling on the degenerate vertices the splits produce). Each step solves a k × k system
//! (k ≤ n), so a solve costs microseconds where a general interior-point solver costs a millisecond.
//! Where it cannot decide (a step cap, a singular system) it says so, and the caller asks Clarabel.

use nalgebra::{DMatrix, DVector};

/// Why [`maximise`] gave up; the caller falls back to a general solver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Undecided {
    /// The objective grows without bound along a feasible ray.
    Unbounded,
    /// The step cap, a singular system, or a non-finite number.
    Numerics,
}

/// Relative tolerance on the projected objective, the multipliers and the blocking test.
const TOL: f64 = 1e-11;

/// Rows aᵢᵀx ≤ bᵢ of an LP in n unknowns, stored flat (one allocation however many rows: the
/// partition clones and extends them at every split).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Rows {
    n: usize,
    a: Vec<f64>,
    b: Vec<f64>,
}

impl Rows {
    /// No rows, in `n` unknowns, with room for `m`.
    pub fn with_capacity(n: usize, m: usize) -> Rows {
        Rows {
            n,
            a: Vec::with_capacity(n * m),
            b: Vec::with_capacity(m),
        }
    }

    /// The unknowns.
    pub fn n(&self) -> usize {
        self.n
    }

    /// The rows.
    pub fn len(&self) -> usize {
        self.b.len()
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.b.is_empty()
    }

    /// Appends aᵀx ≤ b; `a` has the n coefficients.
    pub fn push(&mut self, a: &[f64], b: f64) {
        debug_assert_eq!(a.len(), self.n);
        self.a.extend_from_slice(a);
        self.b.push(b);
    }

    /// Row i.
    pub fn row(&self, i: usize) -> (&[f64], f64) {
        (&self.a[i * self.n..(i + 1) * self.n], self.b[i])
    }

    /// The rows in order.
    pub fn iter(&self) -> impl Iterator<Item = (&[f64], f64)> + '_ {
        self.a
            .chunks_exact(self.n.max(1))
            .zip(self.b.iter().copied())
            .take(self.b.len())
    }

    /// Keeps the rows for which `keep` holds, in order.
    pub fn retain(&mut self, mut keep: impl FnMut(&[f64], f64) -> bool) {
        let n = self.n;
        let mut kept = 0;
        for i in 0..self.b.len() {
            let b = self.b[i];
            if keep(&self.a[i * n..(i + 1) * n], b) {
                self.a.copy_within(i * n..(i + 1) * n, kept * n);
                self.b[kept] = b;
                kept += 1;
            }
        }
        self.a.truncate(kept * n);
        self.b.truncate(kept);
    }
}

/// The maximiser of cᵀx over {x : aᵢᵀx ≤ bᵢ for each row (aᵢ, bᵢ)}, from `start`, which must be
/// feasible (within round-off). Rows are expected of unit norm, or near it.
pub fn maximise(c: &[f64], rows: &Rows, start: &[f64]) -> Result<Vec<f64>, Undecided> {
    let n = c.len();
    debug_assert_eq!(rows.n(), n);
    let c = DVector::from_column_slice(c);
    let scale = c.amax().max(1e-300);
    let mut x = DVector::from_column_slice(start);
    let mut working: Vec<usize> = Vec::with_capacity(n);
    let mut in_working = vec![false; rows.len()];
    let cap = 20 * (rows.len() + n) + 100;
    for _ in 0..cap {
        let k = working.len();
        let (direction, multipliers) = if k == 0 {
            (c.clone(), DVector::zeros(0))
        } else {
            // A_Wᵀ = Q·R (thin): the projection c − Q·Qᵀc, and R·λ = Qᵀc (better conditioned than the
            // normal equations, whose Gram matrix squares the rows' condition).
            let a_wt = DMatrix::from_fn(n, k, |j, i| rows.row(working[i]).0[j]);
            let qr = a_wt.qr();
            let (q, r) = (qr.q(), qr.r());
            let qtc = q.transpose() * &c;
            let lambda = r.solve_upper_triangular(&qtc).ok_or(Undecided::Numerics)?;
            (&c - &q * &qtc, lambda)
        };
        if !direction.iter().all(|v| v.is_finite()) {
            return Err(Undecided::Numerics);
        }
        let longest = direction.amax();
        if longest <= TOL * scale {
            // c lies in the working rows' span: their multipliers decide.
            let leaving = working
                .iter()
                .zip(multipliers.iter())
                .filter(|(_, &l)| l < -TOL * scale)
                .map(|(&r, _)| r)
                .min();
            match leaving {
                None => return Ok(x.iter().copied().collect()),
                Some(r) => {
                    working.retain(|&w| w != r);
                    in_working[r] = false;
                    continue;
                }
            }
        }
        // The ratio test along the direction; ties go to the smallest row (Bland).
        let mut step = f64::INFINITY;
        let mut blocking = None;
        for (i, (a, b)) in rows.iter().enumerate() {
            if in_working[i] {
                continue;
            }
            let rate: f64 = a.iter().zip(direction.iter()).map(|(u, v)| u * v).sum();
            if rate <= TOL * longest {
                continue;
            }
            let slack: f64 = b - a.iter().zip(x.iter()).map(|(u, v)| u * v).sum::<f64>();
            let t = slack.max(0.0) / rate;
            if t < step {
                step = t;
                blocking = Some(i);
            }
        }
        let Some(i) = blocking else {
            return Err(Undecided::Unbounded);
        };
        if working.len() == n {
            // Cannot happen in exact arithmetic (the null space is {0}); round-off.
            return Err(Undecided::Numerics);
        }
        x += step * &direction;
        working.push(i);
        in_working[i] = true;
    }
    Err(Undecided::Numerics)
}

/// The rows of the box [−1, 1]ⁿ: ±xⱼ ≤ 1.
pub fn unit_box(n: usize) -> Rows {
    let mut rows = Rows::with_capacity(n, 2 * n);
    let mut a = vec![0.0; n];
    for j in 0..n {
        for sign in [1.0, -1.0] {
            a[j] = sign;
            rows.push(&a, 1.0);
        }
        a[j] = 0.0;
    }
    rows
}

/// The maximiser by Clarabel (an interior-point method, robust on degenerate LPs), or `None` where it
/// reports no solution.
pub fn with_clarabel(c: &[f64], rows: &Rows) -> Option<Vec<f64>> {
    use clarabel::algebra::CscMatrix;
    use clarabel::solver::{
        DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
    };
    let (n, m) = (c.len(), rows.len());
    let (mut colptr, mut rowval, mut nzval) = (vec![0], Vec::new(), Vec::new());
    for j in 0..n {
        for (i, (a, _)) in rows.iter().enumerate() {
            if a[j] != 0.0 {
                rowval.push(i);
                nzval.push(a[j]);
            }
        }
        colptr.push(rowval.len());
    }
    let a = CscMatrix::new(m, n, colptr, rowval, nzval);
    let p = CscMatrix::zeros((n, n));
    let q: Vec<f64> = c.iter().map(|v| -v).collect();
    let b: Vec<f64> = rows.iter().map(|r| r.1).collect();
    let settings = DefaultSettings {
        verbose: false,
        presolve_enable: false,
        ..DefaultSettings::default()
    };
    let mut solver = DefaultSolver::new(
        &p,
        &q,
        &a,
        &b,
        &[SupportedConeT::NonnegativeConeT(m)],
        settings,
    )
    .ok()?;
    solver.solve();
    matches!(
        solver.solution.status,
        SolverStatus::Solved | SolverStatus::AlmostSolved
    )
    .then(|| solver.solution.x.clone())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Clarabel's optimum of the same LP, the independent reference.
    fn clarabel(c: &[f64], rows: &Rows) -> f64 {
        let x = with_clarabel(c, rows).expect("Clarabel solves it");
        c.iter().zip(&x).map(|(u, v)| u * v).sum()
    }

    /// Random polytopes inside a box, with duplicated and degenerate rows through one vertex: the
    /// optimum agrees with Clarabel's and the maximiser is feasible.
    #[test]
    fn agrees_with_clarabel_on_random_polytopes() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for case in 0..400 {
            let n = 1 + case % 6;
            let mut rows = unit_box(n);
            for _ in 0..rng.gen_range(0..30) {
                let a: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
                let norm = a.iter().map(|v| v * v).sum::<f64>().sqrt();
                // Oriented so that the origin, the start, is feasible.
                let sign = if a.iter().sum::<f64>() < 0.0 {
                    -1.0
                } else {
                    1.0
                };
                let a: Vec<f64> = a.iter().map(|v| sign * v / norm).collect();
                // Through the corner (1, …, 1) sometimes: degenerate vertices.
                let b = if rng.gen_bool(0.3) {
                    a.iter().sum::<f64>()
                } else {
                    rng.gen_range(0.0..1.0)
                };
                if rng.gen_bool(0.1) {
                    rows.push(&a, b);
                }
                rows.push(&a, b);
            }
            let c: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let x = maximise(&c, &rows, &vec![0.0; n]).unwrap();
            for (a, b) in rows.iter() {
                let v: f64 = a.iter().zip(&x).map(|(u, w)| u * w).sum();
                assert!(v <= b + 1e-9, "case {case}: infeasible by {}", v - b);
            }
            let ours: f64 = c.iter().zip(&x).map(|(u, w)| u * w).sum();
            let theirs = clarabel(&c, &rows);
            assert!(
                (ours - theirs).abs() <= 1e-6,
                "case {case}: {ours} against {theirs}"
            );
        }
    }
}
