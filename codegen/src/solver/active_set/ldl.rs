//! The L·D·Lᵀ factor of the working set's block of the Gram matrix, G_WW = L·D·Lᵀ (L unit lower
//! triangular), kept up to date by rank one as the working set changes: a row appended when a
//! constraint is added (its entries of G looked up, one forward substitution), a row and column
//! removed when a constraint leaves (a rank-one update of the trailing block). A refactorisation is
//! the same appends from an empty factor.
//!
//! Every loop counts its multiply-adds into the counter it is given (a division counts as one), so the
//! outcome's counts are what was run, not a formula.

/// L stored by rows (row i holds L[i][0..i], the unit diagonal implied) and the pivots D.
#[derive(Clone, Debug, Default)]
pub(super) struct Ldl {
    l: Vec<Vec<f64>>,
    d: Vec<f64>,
}

impl Ldl {
    /// The number of rows.
    pub(super) fn len(&self) -> usize {
        self.d.len()
    }

    /// Empties the factor.
    pub(super) fn clear(&mut self) {
        self.l.clear();
        self.d.clear();
    }

    /// L[i][j], j < i.
    pub(super) fn l(&self, i: usize, j: usize) -> f64 {
        self.l[i][j]
    }

    /// The pivot D[i].
    pub(super) fn pivot(&self, i: usize) -> f64 {
        self.d[i]
    }

    /// The smallest pivot (+∞ for an empty factor).
    pub(super) fn min_pivot(&self) -> f64 {
        self.d.iter().copied().fold(f64::INFINITY, f64::min)
    }

    /// Appends the row of a constraint whose Gram entries with the rows already in the factor are
    /// `g` (in the factor's order) and whose diagonal entry is `diagonal`: l = D⁻¹·L⁻¹·g and the new
    /// pivot diagonal − lᵀ·D·l, which it returns. A pivot near zero says the constraint depends on
    /// those before it; the caller decides (and may set it to zero with [`Ldl::set_last_pivot`]).
    pub(super) fn push(&mut self, g: &[f64], diagonal: f64, macs: &mut usize) -> f64 {
        let k = self.len();
        debug_assert_eq!(g.len(), k);
        let mut row = g.to_vec();
        for i in 0..k {
            let li = &self.l[i];
            let mut s = row[i];
            for (j, lij) in li.iter().enumerate() {
                s -= lij * row[j];
            }
            row[i] = s;
        }
        *macs += k * k.saturating_sub(1) / 2;
        let mut pivot = diagonal;
        for (i, r) in row.iter_mut().enumerate() {
            let t = *r;
            *r = t / self.d[i];
            pivot -= t * *r;
        }
        *macs += 2 * k;
        self.l.push(row);
        self.d.push(pivot);
        pivot
    }

    /// Overwrites the last pivot (zero marks a dependent row: the singular case).
    pub(super) fn set_last_pivot(&mut self, value: f64) {
        if let Some(last) = self.d.last_mut() {
            *last = value;
        }
    }

    /// Removes row and column `r`. The rows after it keep their L and D up to the rank-one term
    /// D_r·w·wᵀ (w the removed column below the diagonal), which is added back to the trailing block by
    /// method C1 of Gill, Golub, Murray and Saunders, "Methods for modifying matrix factorizations"
    /// (1974), as DAQP's `update_LDL_remove`: O(t²) for t trailing rows, stable since the term is
    /// positive semidefinite.
    pub(super) fn remove(&mut self, r: usize, macs: &mut usize) {
        let k = self.len();
        if r >= k {
            return;
        }
        let mut w: Vec<f64> = (r + 1..k).map(|i| self.l[i].remove(r)).collect();
        self.l.remove(r);
        let mut alpha = self.d.remove(r);
        let t = w.len();
        for j in 0..t {
            let p = w[j];
            if p == 0.0 {
                // Row r + j is not touched by the term: its pivot and the later rows' entries in its
                // column stay (and the division below would be 0/0 on a zero pivot).
                continue;
            }
            let di = self.d[r + j];
            let dbar = di + alpha * p * p;
            let beta = p * alpha / dbar;
            alpha = di * alpha / dbar;
            self.d[r + j] = dbar;
            for (q, wq) in w.iter_mut().enumerate().skip(j + 1) {
                let lq = &mut self.l[r + q][r + j];
                *wq -= p * *lq;
                *lq += beta * *wq;
            }
            *macs += 5 + 2 * (t - j - 1);
        }
    }

    /// Solves L·D·Lᵀ·x = b from the factor, `from` the first row of the forward substitution that
    /// is not cached: `y` holds L⁻¹·b and `scaled` D⁻¹·L⁻¹·b on rows before it (they depend only on the
    /// rows of the factor and of b up to there, which have not changed), and both are completed here.
    pub(super) fn solve_cached(
        &self,
        b: impl Fn(usize) -> f64,
        y: &mut Vec<f64>,
        scaled: &mut Vec<f64>,
        from: usize,
        x: &mut Vec<f64>,
        macs: &mut usize,
    ) {
        let k = self.len();
        let from = from.min(k);
        y.resize(k, 0.0);
        scaled.resize(k, 0.0);
        x.resize(k, 0.0);
        for i in from..k {
            let mut s = b(i);
            for (j, lij) in self.l[i].iter().enumerate() {
                s -= lij * y[j];
            }
            y[i] = s;
            scaled[i] = s / self.d[i];
            *macs += i + 1;
        }
        self.backward(scaled, x, macs);
    }

    /// x = L⁻ᵀ·z.
    pub(super) fn backward(&self, z: &[f64], x: &mut [f64], macs: &mut usize) {
        let k = self.len();
        for i in (0..k).rev() {
            let mut s = z[i];
            for (j, xj) in x.iter().enumerate().take(k).skip(i + 1) {
                s -= self.l[j][i] * xj;
            }
            x[i] = s;
        }
        *macs += k * k.saturating_sub(1) / 2;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    /// A random-looking symmetric positive definite matrix.
    fn spd(k: usize) -> DMatrix<f64> {
        let b = DMatrix::from_fn(k + 2, k, |i, j| ((i * 7 + j * 13) % 11) as f64 / 5.0 - 1.0);
        b.transpose() * b + DMatrix::identity(k, k) * 0.1
    }

    fn reconstruct(f: &Ldl) -> DMatrix<f64> {
        let k = f.len();
        let l = DMatrix::from_fn(k, k, |i, j| match i.cmp(&j) {
            std::cmp::Ordering::Greater => f.l(i, j),
            std::cmp::Ordering::Equal => 1.0,
            std::cmp::Ordering::Less => 0.0,
        });
        let d = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(f.d.clone()));
        &l * d * l.transpose()
    }

    /// Appends and removals keep L·D·Lᵀ equal to the remaining rows' block.
    #[test]
    fn updates_and_downdates_track_the_block() {
        let g = spd(7);
        let mut f = Ldl::default();
        let mut rows: Vec<usize> = Vec::new();
        let mut macs = 0;
        for c in 0..7 {
            let col: Vec<f64> = rows.iter().map(|&r| g[(r, c)]).collect();
            f.push(&col, g[(c, c)], &mut macs);
            rows.push(c);
        }
        for r in [3, 0, 4] {
            f.remove(r, &mut macs);
            rows.remove(r);
            let block = DMatrix::from_fn(rows.len(), rows.len(), |i, j| g[(rows[i], rows[j])]);
            assert!((reconstruct(&f) - block).amax() < 1e-12);
        }
        let b: Vec<f64> = (0..rows.len()).map(|i| i as f64 - 1.0).collect();
        let (mut y, mut s, mut x) = (Vec::new(), Vec::new(), Vec::new());
        f.solve_cached(|i| b[i], &mut y, &mut s, 0, &mut x, &mut macs);
        let block = DMatrix::from_fn(rows.len(), rows.len(), |i, j| g[(rows[i], rows[j])]);
        let r = block * nalgebra::DVector::from_vec(x) - nalgebra::DVector::from_vec(b);
        assert!(r.amax() < 1e-12);
    }
}
