// The dual active-set method's run time, written once: the build's reference compiles this file with
// `Real` = f64 (and f32) and a counting `Tally` (`solver/active_set/mod.rs`), and every emitted module
// includes it verbatim with its own `Real` and a `Tally` that counts nothing (`emit.rs`). So the
// controller runs the reference's arithmetic in the reference's order, and agrees with it to the bit.
//
// The file is plain `core` Rust over slices and caller-owned storage: no allocation, and every index
// that depends on the data goes through `at`/`put`, which read 0 and write nothing past an end, so no
// path panics. A block's method is DAQP's (`daqp_ldp`): Goldfarb and Idnani's dual active-set method on
// the least-distance problem min ½‖u‖² s.t. lo ≤ M̂·u ≤ hi, with the L·D·Lᵀ of the working set's block of
// the Gram matrix G = M̂·M̂ᵀ updated by rank one (Gill, Golub, Murray and Saunders' method C1 for a
// removal). See `mod.rs` for the method and its tolerances.

/// The kernel's work, which `Tally` counts and a solve's budget caps, in tenths of a multiply-add of
/// the factor's loops: each multiply-add there (the factor, the solves with it, the steps) weighs
/// [`WORK_MULTIPLY_ADD`], one of the offsets' or the recovery's [`WORK_SWEEP`], one of the scan's
/// column updates (a tight loop) [`WORK_SCAN`], each row a scan visits (its slack cleared, its two
/// sides compared) [`WORK_ROW`] and each pass of the iteration (its tests and bookkeeping)
/// [`WORK_PASS`]. The weights are the boards' (`docs/methods.md`, "The worst case on the boards"): the
/// instructions of the certificates' heaviest cold cases follow this sum within 4 % on the Cortex-A9
/// and 6 % on the Cortex-M4F, where the multiply-adds alone spread over 2.2×.
pub(super) const WORK_MULTIPLY_ADD: usize = 10;
/// See [`WORK_MULTIPLY_ADD`].
pub(super) const WORK_SWEEP: usize = 5;
/// See [`WORK_MULTIPLY_ADD`].
pub(super) const WORK_SCAN: usize = 1;
/// See [`WORK_MULTIPLY_ADD`].
pub(super) const WORK_ROW: usize = 45;
/// See [`WORK_MULTIPLY_ADD`].
pub(super) const WORK_PASS: usize = 200;

/// `v[i]`, or 0 past its end.
#[inline(always)]
fn at(v: &[Real], i: usize) -> Real {
    match v.get(i) {
        Some(x) => *x,
        None => 0.0,
    }
}

/// `v[i]` of an index table, or 0 past its end.
#[inline(always)]
fn at_index(v: &[usize], i: usize) -> usize {
    match v.get(i) {
        Some(x) => *x,
        None => 0,
    }
}

/// `v[i]` of the working set or the warm start (stored as u32, so that the state's layout is the same on
/// every target), or 0 past its end.
#[inline(always)]
fn at_entry(v: &[u32], i: usize) -> usize {
    match v.get(i) {
        Some(x) => *x as usize,
        None => 0,
    }
}

/// `v[i]` of a flag table, or false past its end.
#[inline(always)]
fn at_flag(v: &[bool], i: usize) -> bool {
    match v.get(i) {
        Some(x) => *x,
        None => false,
    }
}

/// `v[i] = x`, nothing past its end.
#[inline(always)]
fn put<T>(v: &mut [T], i: usize, x: T) {
    if let Some(o) = v.get_mut(i) {
        *o = x;
    }
}

/// Removes entry `i` of the first `k` of `v`, moving the later ones down.
#[inline(always)]
fn remove_at<T>(v: &mut [T], i: usize, k: usize) {
    if i < k {
        if let Some(s) = v.get_mut(i..k) {
            s.rotate_left(1);
        }
    }
}

/// How a solve ended, in increasing severity.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Ended {
    /// The KKT conditions hold within the tolerances.
    Solved,
    /// The iterations ran out: the iterate is dual feasible, not primal feasible.
    IterationLimit,
    /// The dual objective stopped increasing, even after a refactorisation.
    Cycling,
    /// The dual is unbounded, or a row's sides cross: the constraints admit no point.
    Infeasible,
    /// A side or a multiplier is not finite.
    NumericalFailure,
}

impl Ended {
    /// The order of severity.
    fn severity(self) -> u8 {
        match self {
            Ended::Solved => 0,
            Ended::IterationLimit => 1,
            Ended::Cycling => 2,
            Ended::Infeasible => 3,
            Ended::NumericalFailure => 4,
        }
    }
}

/// The iteration's tolerances, relative to the normalised problem (rows of unit norm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Tolerances {
    /// A side is violated when its slack exceeds primal·(1 + |side|).
    pub(super) primal: Real,
    /// A multiplier has the wrong sign beyond this.
    pub(super) dual: Real,
    /// A pivot below this marks the new side dependent on the working set.
    pub(super) singular: Real,
    /// At the optimum, a pivot below this refactorises once.
    pub(super) refactor: Real,
    /// A pivot below this moves its side last, and at the optimum refines λ once.
    pub(super) pivot: Real,
    /// A full step raising the dual objective by less than progress·(1 + |objective|) is no progress.
    pub(super) progress: Real,
    /// Full steps without progress before a refactorisation, and then before `Cycling`.
    pub(super) cycle: usize,
    /// A dependent side violated by at most infeasible·(1 + |side|) is round-off at a degenerate
    /// vertex: set aside for the solve.
    pub(super) infeasible: Real,
}

/// One independent block's constant data, computed at build time.
#[derive(Clone, Copy, Debug)]
pub(super) struct Block<'a> {
    /// The block's variables, indices into z.
    pub(super) vars: &'a [usize],
    /// The upper-triangular Cholesky factor R of the block of H (H_bb = Rᵀ·R), packed by rows: row i
    /// holds `R[i][i..n]`.
    pub(super) r: &'a [Real],
    /// Per constraint, its index into the QP's sides: a bound on variable j is j, row r of A is n + r.
    pub(super) sides: &'a [usize],
    /// Per constraint, s = ‖R⁻ᵀ·a‖, the norm its row had before it was normalised.
    pub(super) scale: &'a [Real],
    /// Constraint c's nonzero coefficients are `values[starts[c]..starts[c + 1]]` at the block's
    /// positions `positions[…]`.
    pub(super) starts: &'a [usize],
    /// See `starts`.
    pub(super) positions: &'a [usize],
    /// See `starts`.
    pub(super) values: &'a [Real],
    /// The Gram matrix G = M̂·M̂ᵀ of the normalised rows, its lower triangle packed by columns: column
    /// j holds `G[j..nc][j]` from `j·nc − j·(j − 1)/2` ([`Block::column`]), so that the scan walks the
    /// long part of a working entry's column contiguously (the bounds, which come first, are most of
    /// the working sets).
    pub(super) gram: &'a [Real],
    /// Z = R⁻¹·M̂ᵀ by columns: column c at c·n (z = z_free − Z_W·λ); empty for a block with many
    /// constraints a variable, which recovers z as z_free − H⁻¹·Σ_W (λ_c / s_c)·a_c instead.
    pub(super) z_cols: &'a [Real],
    /// Where the block's warm start begins in the warm-start storage (n + 1 entries).
    pub(super) warm_at: usize,
    /// Whether the f32 kernel refines z and checks the rows on it: a block with soft rows' slacks,
    /// whose multipliers reach the rows' weights.
    pub(super) refine: bool,
    /// The constraints a solve visits where the slack rows after them are proved so ([`Block::limit`]):
    /// the bounds and the rows that may bind over the region; the rows after them cannot.
    pub(super) core: usize,
    /// Per slack constraint (c ≥ `core`), the least and the most aᵀz within the block's bounds (the
    /// build's: the emitted module's are constants, and the reference's `Prepared::offsets` refuses
    /// others): no plan within them violates its row where its lower side is at most the first and its
    /// upper side at least the second.
    pub(super) reach: &'a [Real],
}

impl Block<'_> {
    /// aᵀz for constraint c's coefficients over the block's z, and how many they are.
    fn row_times(&self, c: usize, z: &[Real]) -> (Real, usize) {
        let (start, end) = (at_index(self.starts, c), at_index(self.starts, c + 1));
        let (positions, values) = (
            self.positions.get(start..end).unwrap_or(&[]),
            self.values.get(start..end).unwrap_or(&[]),
        );
        let mut a = 0.0;
        for (p, v) in positions.iter().zip(values) {
            a += *v * at(z, *p);
        }
        (a, values.len())
    }

    /// The number of variables.
    fn n(&self) -> usize {
        self.vars.len()
    }

    /// The number of constraints.
    fn nc(&self) -> usize {
        self.sides.len()
    }

    /// The constraints this solve visits: [`Block::core`] where every slack row's sides lie beyond its
    /// reach (no plan within the bounds violates it: the row cannot bind), else all of them (the state
    /// or the reference is outside the region the proof holds on, or the solve is a relaxed one).
    fn limit(&self, lower: &[Real], upper: &[Real], tally: &mut Tally) -> usize {
        let nc = self.nc();
        if self.core >= nc {
            return nc;
        }
        tally.offsets(nc - self.core);
        for c in self.core..nc {
            let side = at_index(self.sides, c);
            let j = 2 * (c - self.core);
            let slack = at(lower, side) <= at(self.reach, j) && at(upper, side) >= at(self.reach, j + 1);
            if !slack {
                return nc;
            }
        }
        self.core
    }

    /// Where column j of G's packed lower triangle begins.
    #[inline(always)]
    fn column(&self, j: usize) -> usize {
        j * (2 * self.nc() + 1 - j) / 2
    }

    /// `G[i][j]`.
    #[inline(always)]
    fn g(&self, i: usize, j: usize) -> Real {
        let (a, b) = if i >= j { (i, j) } else { (j, i) };
        at(self.gram, self.column(b) + (a - b))
    }
}

/// The run-time storage of a block's solve, owned by the caller and sized for the largest block: the
/// working set (at most n + 1 sides: the last may be dependent) with its multipliers and factor, and per
/// constraint the scaled sides and marks.
pub(super) struct Work<'a> {
    /// The working set's constraints, in the factor's order.
    pub(super) set: &'a mut [u32],
    /// Whether each is active at its upper side.
    pub(super) upper: &'a mut [bool],
    /// Their multipliers (≥ 0 at an upper side, ≤ 0 at a lower one).
    pub(super) lambda: &'a mut [Real],
    /// λ* of the working set, or the singular direction.
    pub(super) star: &'a mut [Real],
    /// L⁻¹·(−d_W), cached up to `reuse`.
    pub(super) y: &'a mut [Real],
    /// D⁻¹·L⁻¹·(−d_W), cached up to `reuse`.
    pub(super) scaled: &'a mut [Real],
    /// Scratch of the working set's length.
    pub(super) tmp: &'a mut [Real],
    /// L by rows, row i at i·cap holding `L[i][0..i]`.
    pub(super) l: &'a mut [Real],
    /// The pivots D.
    pub(super) d: &'a mut [Real],
    /// Per constraint, its slack −G_{c,W}·λ (the scan's scratch).
    pub(super) mu: &'a mut [Real],
    /// Per constraint, whether it is in the working set.
    pub(super) active: &'a mut [bool],
    /// Per constraint, whether it was set aside as dependent within round-off.
    pub(super) excluded: &'a mut [bool],
    /// Per constraint, the scaled lower side (lower − aᵀz_free) / s.
    pub(super) lo: &'a mut [Real],
    /// Per constraint, the scaled upper side.
    pub(super) hi: &'a mut [Real],
    /// The block's unconstrained minimiser −H_bb⁻¹·f_b.
    pub(super) z_free: &'a mut [Real],
    /// The capacity of the working set and the row stride of `l`.
    pub(super) cap: usize,
}

/// The state of one block's iteration.
struct Run<'w, 'a, 'b> {
    b: &'b Block<'b>,
    w: &'w mut Work<'a>,
    tol: &'b Tolerances,
    tally: &'w mut Tally,
    /// The working set's size.
    k: usize,
    /// Rows of `y` and `scaled` still valid.
    reuse: usize,
    /// The last side of the factor depends on the others (its pivot set to zero).
    singular: bool,
    /// The violation the last added side had when it was added.
    added_violation: Real,
    /// The constraints this solve visits ([`Block::limit`]).
    limit: usize,
}

impl Run<'_, '_, '_> {
    /// The side of working entry i.
    fn side(&self, i: usize) -> Real {
        let c = at_entry(self.w.set, i);
        if at_flag(self.w.upper, i) {
            at(self.w.hi, c)
        } else {
            at(self.w.lo, c)
        }
    }

    /// `L[i][j]`.
    #[inline(always)]
    fn l(&self, i: usize, j: usize) -> Real {
        at(self.w.l, i * self.w.cap + j)
    }

    /// Appends the factor's row for constraint `c` (its Gram entries with the set looked up, one forward
    /// substitution along L's rows) and returns its pivot.
    fn ldl_push(&mut self, c: usize) -> Real {
        let (k, cap) = (self.k, self.w.cap);
        let b = self.b;
        let (before, after) = match self.w.l.split_at_mut_checked(k * cap) {
            Some(parts) => parts,
            None => return Real::NAN,
        };
        let (Some(row), Some(set), Some(d)) = (
            after.get_mut(..k),
            self.w.set.get(..k),
            self.w.d.get(..k),
        ) else {
            return Real::NAN;
        };
        for (i, wi) in set.iter().enumerate() {
            let Some((done, cur)) = row.split_at_mut_checked(i) else {
                break;
            };
            let Some(ri) = cur.first_mut() else {
                break;
            };
            let mut s = b.g(*wi as usize, c);
            if let Some(li) = before.get(i * cap..i * cap + i) {
                for (a, x) in li.iter().zip(done.iter()) {
                    s -= *a * *x;
                }
            }
            *ri = s;
        }
        self.tally.factor(k * k.saturating_sub(1) / 2);
        let mut pivot = b.g(c, c);
        for (ri, di) in row.iter_mut().zip(d) {
            let t = *ri;
            let r = t / *di;
            *ri = r;
            pivot -= t * r;
        }
        self.tally.factor(2 * k);
        put(self.w.d, k, pivot);
        pivot
    }

    /// Removes row and column `r` of the factor: the rows after it keep their L and D up to the
    /// rank-one term D_r·w·wᵀ (w the removed column), added back to the trailing block by method C1.
    fn ldl_remove(&mut self, r: usize) {
        let (k, cap) = (self.k, self.w.cap);
        if r >= k {
            return;
        }
        let t = k - r - 1;
        for q in 0..t {
            let v = self.l(r + 1 + q, r);
            put(self.w.tmp, q, v);
        }
        let mut alpha = at(self.w.d, r);
        // Rows after r move up one, without column r.
        for i in r..k - 1 {
            for j in 0..i {
                let from = if j < r { j } else { j + 1 };
                let v = self.l(i + 1, from);
                put(self.w.l, i * cap + j, v);
            }
            let v = at(self.w.d, i + 1);
            put(self.w.d, i, v);
        }
        for j in 0..t {
            let p = at(self.w.tmp, j);
            if p == 0.0 {
                // Row r + j is untouched by the term (and the division below would be 0/0 on a zero
                // pivot).
                continue;
            }
            let di = at(self.w.d, r + j);
            let dbar = di + alpha * p * p;
            let beta = p * alpha / dbar;
            alpha = di * alpha / dbar;
            put(self.w.d, r + j, dbar);
            for q in j + 1..t {
                let at_l = (r + q) * cap + r + j;
                let lq = at(self.w.l, at_l);
                let wq = at(self.w.tmp, q) - p * lq;
                put(self.w.tmp, q, wq);
                put(self.w.l, at_l, lq + beta * wq);
            }
            self.tally.factor(5 + 2 * (t - j - 1));
        }
    }

    /// Appends constraint `c` at its upper (or lower) side with multiplier `lambda`; marks the set
    /// singular when its pivot is below the tolerance or the set has more sides than variables.
    fn push(&mut self, c: usize, upper: bool, lambda: Real) {
        if self.k >= self.w.cap {
            // Not reached: a set grows past n only by one dependent side, which leaves before the next.
            self.singular = true;
            return;
        }
        let pivot = self.ldl_push(c);
        put(self.w.set, self.k, c as u32);
        put(self.w.upper, self.k, upper);
        put(self.w.lambda, self.k, lambda);
        put(self.w.active, c, true);
        self.k += 1;
        if pivot.is_nan() || pivot < self.tol.singular || self.k > self.b.n() {
            put(self.w.d, self.k - 1, 0.0);
            self.singular = true;
        }
    }

    /// Removes working entry `i` without touching the singular mark or the pivots' guard.
    fn take(&mut self, i: usize) -> (usize, bool, Real) {
        let c = at_entry(self.w.set, i);
        let upper = at_flag(self.w.upper, i);
        let lambda = at(self.w.lambda, i);
        self.ldl_remove(i);
        remove_at(self.w.set, i, self.k);
        remove_at(self.w.upper, i, self.k);
        remove_at(self.w.lambda, i, self.k);
        put(self.w.active, c, false);
        self.k -= 1;
        self.reuse = self.reuse.min(i);
        (c, upper, lambda)
    }

    /// Removes working entry `i` (a downdate); the set is singular afterwards when the last pivot fell
    /// below the tolerance (round-off), else the small-pivot guard runs.
    fn remove(&mut self, i: usize) {
        if i >= self.k {
            return;
        }
        self.take(i);
        self.singular = false;
        let k = self.k;
        let last = if k > 0 { at(self.w.d, k - 1) } else { 1.0 };
        if last.is_nan() || last < self.tol.singular {
            if k > 0 {
                put(self.w.d, k - 1, 0.0);
            }
            self.singular = true;
        } else {
            self.pivot_last();
        }
    }

    /// DAQP's `pivot_last`: a small second-to-last pivot, smaller than the last, moves its side to the
    /// end, where the next change can drop it without perturbing the sides after it.
    fn pivot_last(&mut self) {
        let k = self.k;
        if k < 2 {
            return;
        }
        let r = k - 2;
        let (dr, dl) = (at(self.w.d, r), at(self.w.d, k - 1));
        if dr < self.tol.pivot && dr < dl {
            let (c, upper, lambda) = self.take(r);
            self.push(c, upper, lambda);
        }
    }

    /// Removes the last side (no downdate needed) and clears the singular mark.
    fn drop_last(&mut self) {
        if self.k == 0 {
            return;
        }
        let last = self.k - 1;
        self.take(last);
        self.singular = false;
    }

    /// Refactorises G_WW from scratch in the working set's order, dropping a side whose pivot is then
    /// below the tolerance.
    fn refactor(&mut self) {
        let old = self.k;
        for i in 0..old {
            put(self.w.active, at_entry(self.w.set, i), false);
        }
        self.k = 0;
        self.reuse = 0;
        self.singular = false;
        // Entry i is read before the rebuilt set (never longer than i) writes there.
        for i in 0..old {
            let (c, upper, lambda) = (
                at_entry(self.w.set, i),
                at_flag(self.w.upper, i),
                at(self.w.lambda, i),
            );
            self.push(c, upper, lambda);
            if self.singular {
                self.drop_last();
            }
        }
    }

    /// Solves L·D·Lᵀ·x = b into `star` (b = −d_W, the cached rows reused from `from`), or, with
    /// `refining`, b = `tmp` with nothing cached.
    fn ldl_solve(&mut self, from: usize, refining: bool) {
        let (k, cap) = (self.k, self.w.cap);
        for i in from.min(k)..k {
            let mut s = if refining {
                at(self.w.tmp, i)
            } else {
                -self.side(i)
            };
            if let (Some(li), Some(y)) = (
                self.w.l.get(i * cap..i * cap + i),
                self.w.y.get(..i),
            ) {
                for (a, x) in li.iter().zip(y) {
                    s -= *a * *x;
                }
            }
            put(self.w.y, i, s);
            put(self.w.scaled, i, s / at(self.w.d, i));
            self.tally.solve(i + 1);
        }
        // Lᵀ by columns of L: entry (j, i) at j·cap + i.
        for i in (0..k).rev() {
            let mut s = at(self.w.scaled, i);
            let later = self.w.star.get(i + 1..k).unwrap_or(&[]);
            let column = self.w.l.get((i + 1) * cap + i..).unwrap_or(&[]);
            for (a, x) in column.iter().step_by(cap.max(1)).zip(later) {
                s -= *a * *x;
            }
            put(self.w.star, i, s);
        }
        self.tally.solve(k * k.saturating_sub(1) / 2);
    }

    /// λ* of the working set, into `star`.
    fn stationary(&mut self) {
        self.ldl_solve(self.reuse, false);
        self.reuse = self.k;
    }

    /// The null direction of the singular set, into `star`: p = L⁻ᵀ·e_last, flipped at a lower side so
    /// that the new side's multiplier grows with the right sign.
    fn singular_direction(&mut self) {
        let k = self.k;
        if k == 0 {
            return;
        }
        let s = k - 1;
        put(self.w.star, s, 1.0);
        for i in (0..s).rev() {
            let mut v = -self.l(s, i);
            for j in i + 1..s {
                v -= self.l(j, i) * at(self.w.star, j);
            }
            put(self.w.star, i, v);
        }
        self.tally.solve(s * s.saturating_sub(1) / 2);
        if !at_flag(self.w.upper, s) {
            for p in self.w.star.iter_mut().take(k) {
                *p = -*p;
            }
        }
    }

    /// The first multiplier to reach zero on the way from λ toward λ* (or along the singular
    /// direction): its position and the step.
    fn blocking(&self) -> Option<(usize, Real)> {
        let mut best: Option<(usize, Real)> = None;
        for i in 0..self.k {
            let st = at(self.w.star, i);
            let wrong = if at_flag(self.w.upper, i) {
                st < -self.tol.dual
            } else {
                st > self.tol.dual
            };
            if !wrong {
                continue;
            }
            let lambda = at(self.w.lambda, i);
            let p = if self.singular { st } else { st - lambda };
            let alpha = (-lambda / p).max(0.0);
            let better = match best {
                None => true,
                Some((_, b)) => alpha < b,
            };
            if better {
                best = Some((i, alpha));
            }
        }
        best
    }

    /// λ ← λ + α·(λ* − λ) (or + α·p), then the blocking side leaves.
    fn step_and_remove(&mut self, i: usize, alpha: Real) {
        let k = self.k;
        for j in 0..k {
            let st = at(self.w.star, j);
            let lambda = at(self.w.lambda, j);
            let p = if self.singular { st } else { st - lambda };
            put(self.w.lambda, j, lambda + alpha * p);
        }
        self.tally.step(k);
        put(self.w.lambda, i, 0.0);
        self.remove(i);
    }

    /// The most violated inactive side: (constraint, upper, violation). The slacks μ = −G_{:,W}·λ
    /// are summed a working entry at a time along G's packed storage (column w from the diagonal down,
    /// contiguous, then row w before the diagonal), in the working set's order.
    fn scan(&mut self) -> Option<(usize, bool, Real)> {
        let (k, nc, gram) = (self.k, self.b.nc(), self.b.gram);
        // The constraints past the limit are neither scanned nor in the working set.
        let mu = self.w.mu.get_mut(..self.limit)?;
        for m in mu.iter_mut() {
            *m = 0.0;
        }
        let set = self.w.set.get(..k).unwrap_or(&[]);
        for (wi, lambda) in set.iter().zip(self.w.lambda.iter()) {
            let (wi, lambda) = (*wi as usize, *lambda);
            let Some((head, tail)) = mu.split_at_mut_checked(wi) else {
                continue;
            };
            let base = self.b.column(wi);
            if let Some(column) = gram.get(base..base + tail.len()) {
                for (m, g) in tail.iter_mut().zip(column) {
                    *m -= *g * lambda;
                }
            }
            // Row wi before the diagonal: G[wi][c] is column c's entry wi, at column(c) + wi − c.
            let mut index = wi;
            for (c, m) in head.iter_mut().enumerate() {
                if let Some(g) = gram.get(index) {
                    *m -= *g * lambda;
                }
                index += nc - c - 1;
            }
        }
        let mut best: Option<(usize, bool, Real)> = None;
        let mut scanned = 0;
        let marks = self.w.active.iter().zip(self.w.excluded.iter());
        let sides = self.w.lo.iter().zip(self.w.hi.iter());
        for (c, ((mu, (active, excluded)), (lo, hi))) in mu.iter().zip(marks).zip(sides).enumerate() {
            if *active | *excluded {
                continue;
            }
            scanned += 1;
            let (mu, lo, hi) = (*mu, *lo, *hi);
            for (upper, violation, side) in [(true, mu - hi, hi), (false, lo - mu, lo)] {
                let worse = match best {
                    None => true,
                    Some((_, _, b)) => violation > b,
                };
                if violation > self.tol.primal * (1.0 + side.abs()) && worse {
                    best = Some((c, upper, violation));
                }
            }
        }
        self.tally.scan(scanned * k);
        self.tally.rows(self.limit);
        best
    }

    /// One step of iterative refinement of λ on the working set: r = G_WW·λ + d_W, λ −= (L·D·Lᵀ)⁻¹·r.
    fn refine(&mut self) {
        let k = self.k;
        for i in 0..k {
            let wi = at_entry(self.w.set, i);
            let mut s = 0.0;
            for j in 0..k {
                s += self.b.g(wi, at_entry(self.w.set, j)) * at(self.w.lambda, j);
            }
            let r = s + self.side(i);
            put(self.w.tmp, i, r);
        }
        self.tally.solve(k * k);
        self.ldl_solve(0, true);
        for i in 0..k {
            let l = at(self.w.lambda, i) - at(self.w.star, i);
            put(self.w.lambda, i, l);
        }
        self.tally.step(k);
        self.reuse = 0;
    }

    /// Adds the violated side (c, upper) with multiplier 0, the small-pivot guard after it.
    fn add(&mut self, c: usize, upper: bool, violation: Real) {
        self.added_violation = violation;
        self.push(c, upper, 0.0);
        if !self.singular {
            self.pivot_last();
        }
    }
}

/// `z` ← H_bb⁻¹·z: Rᵀ·y = z by columns of Rᵀ (R's rows), then R·x = y by rows from the last, `r` R
/// packed by rows. False if `r` is shorter than R.
fn h_inverse(r: &[Real], z: &mut [Real]) -> bool {
    let n = z.len();
    // Rᵀ·y = z by columns of Rᵀ (R's rows): y_i, then its terms taken from the later entries, in
    // the order a row-by-row substitution takes them.
    let mut rest = r;
    let mut zs: &mut [Real] = z;
    while let Some((zi, later)) = zs.split_first_mut() {
        let Some((row, tail)) = rest.split_at_checked(later.len() + 1) else {
            return false;
        };
        let Some((rii, ri)) = row.split_first() else {
            return false;
        };
        let y = *zi / *rii;
        *zi = y;
        for (zk, rk) in later.iter_mut().zip(ri) {
            *zk -= *rk * y;
        }
        rest = tail;
        zs = later;
    }
    // R·z = y by rows, from the last.
    let mut rest = r;
    for i in (0..n).rev() {
        let Some((head, row)) = rest.split_at_checked(rest.len().saturating_sub(n - i)) else {
            return false;
        };
        let (Some((rii, ri)), Some((zi, later))) =
            (row.split_first(), z.get_mut(i..).and_then(|t| t.split_first_mut()))
        else {
            return false;
        };
        let mut s = *zi;
        for (rk, zk) in ri.iter().zip(later.iter()) {
            s -= *rk * *zk;
        }
        *zi = s / *rii;
        rest = head;
    }
    true
}

/// The block's offsets for the QP's linear term `f` and sides `lower`/`upper` (indexed as the block's
/// `sides`): z_free = −H_bb⁻¹·f_b (Rᵀ·y = −f_b, R·z = y, both along R's packed rows), then per
/// constraint the scaled sides (side − aᵀz_free) / s. False where the tables and the storage disagree
/// in size (not reached: both are sized from the same blocks).
pub(super) fn offsets(
    b: &Block,
    f: &[Real],
    lower: &[Real],
    upper: &[Real],
    w: &mut Work,
    tally: &mut Tally,
    limit: usize,
) -> bool {
    let n = b.n();
    let Some(z) = w.z_free.get_mut(..n) else {
        return false;
    };
    let Some(r) = b.r.get(..n * (n + 1) / 2) else {
        return false;
    };
    for (zi, v) in z.iter_mut().zip(b.vars) {
        *zi = -at(f, *v);
    }
    if !h_inverse(r, z) {
        return false;
    }
    tally.offsets(n * (n + 1));
    let z: &[Real] = z;
    let ends = b.starts.get(1..).unwrap_or(&[]);
    let sides = b.sides.iter().zip(b.scale).zip(ends);
    let mut start = at_index(b.starts, 0);
    let scaled = w.lo.iter_mut().zip(w.hi.iter_mut()).zip(sides).take(limit);
    for ((lo, hi), ((side, s), end)) in scaled {
        let (Some(positions), Some(values)) =
            (b.positions.get(start..*end), b.values.get(start..*end))
        else {
            return false;
        };
        let mut a = 0.0;
        for (p, v) in positions.iter().zip(values) {
            a += *v * at(z, *p);
        }
        *lo = (at(lower, *side) - a) / *s;
        *hi = (at(upper, *side) - a) / *s;
        tally.offsets(values.len() + 2);
        start = *end;
    }
    true
}

/// Solves one block's least-distance problem, its offsets formed ([`offsets`]), from the warm start
/// `warm[..warm_len]` (constraints, twice plus one at an upper side), with at most `max_iterations`
/// changes of the working set. Returns how it ended and the changes made; `k_out` receives the working
/// set's size (its entries in `w.set`, `w.upper`, `w.lambda`).
///
/// The warm start: its sides are added in order, each with multiplier ±1 (dual feasible); a side is
/// skipped when its constraint does not exist, has no finite side there, is already in the set, or
/// depends on the sides before it. The first passes then remove the sides whose λ* has the wrong sign.
#[allow(clippy::too_many_arguments)]
fn solve_block(
    b: &Block,
    w: &mut Work,
    warm: &[u32],
    warm_len: usize,
    max_iterations: usize,
    tol: &Tolerances,
    tally: &mut Tally,
    (limit, k_out): (usize, &mut usize),
) -> (Ended, usize) {
    for c in 0..b.nc() {
        put(w.active, c, false);
        put(w.excluded, c, false);
    }
    let nc = limit;
    let mut run = Run {
        b,
        w,
        tol,
        tally,
        k: 0,
        reuse: 0,
        singular: false,
        added_violation: 0.0,
        limit,
    };
    *k_out = 0;
    let mut broken = false;
    let mut crossed = false;
    for c in 0..nc {
        let (lo, hi) = (at(run.w.lo, c), at(run.w.hi, c));
        broken |= lo.is_nan() | hi.is_nan();
        crossed |= lo > hi;
    }
    if broken {
        return (Ended::NumericalFailure, 0);
    }
    if crossed {
        return (Ended::Infeasible, 0);
    }
    for e in 0..warm_len {
        let code = at_entry(warm, e);
        let (c, upper) = (code / 2, code % 2 == 1);
        let exists = c < nc
            && if upper {
                at(run.w.hi, c).is_finite()
            } else {
                at(run.w.lo, c).is_finite()
            };
        if !exists || at_flag(run.w.active, c) {
            continue;
        }
        run.push(c, upper, if upper { 1.0 } else { -1.0 });
        if run.singular {
            run.drop_last();
        }
    }
    let mut iterations = 0;
    let mut refactored = false;
    let mut refined = false;
    let mut best = Real::NEG_INFINITY;
    let mut stalled = 0;
    let ended = loop {
        let changed;
        if !run.singular {
            run.stationary();
            let mut finite = true;
            for i in 0..run.k {
                finite &= at(run.w.star, i).is_finite();
            }
            if !finite {
                break Ended::NumericalFailure;
            }
            if let Some((i, alpha)) = run.blocking() {
                if iterations >= max_iterations || run.tally.exhausted() {
                    break Ended::IterationLimit;
                }
                run.step_and_remove(i, alpha);
                iterations += 1;
                run.tally.pass();
                continue;
            }
            let k = run.k;
            let mut value = 0.0;
            for i in 0..k {
                let st = at(run.w.star, i);
                put(run.w.lambda, i, st);
                value -= run.side(i) * st;
            }
            run.tally.step(k);
            // The dual objective ‖u‖² = −d_Wᵀλ* grows from one full step to the next; a run of full
            // steps without progress is cycling.
            if best.is_finite() && value - best <= tol.progress * (1.0 + best.abs()) {
                stalled += 1;
                if stalled > tol.cycle {
                    if refactored {
                        break Ended::Cycling;
                    }
                    refactored = true;
                    run.refactor();
                    stalled = 0;
                    best = Real::NEG_INFINITY;
                    run.tally.pass();
                    continue;
                }
            } else {
                best = value;
                stalled = 0;
            }
            match run.scan() {
                None => {
                    let mut min_pivot = Real::INFINITY;
                    for i in 0..k {
                        min_pivot = min_pivot.min(at(run.w.d, i));
                    }
                    if !refactored && k > 2 && min_pivot < tol.refactor {
                        refactored = true;
                        run.refactor();
                        run.tally.pass();
                        continue;
                    }
                    if !refined && k > 0 && min_pivot < tol.pivot {
                        refined = true;
                        run.refine();
                        if let Some((c, upper, violation)) = run.scan() {
                            if iterations >= max_iterations || run.tally.exhausted() {
                                break Ended::IterationLimit;
                            }
                            run.add(c, upper, violation);
                            iterations += 1;
                            run.tally.pass();
                            continue;
                        }
                    }
                    run.tally.pass();
                    break Ended::Solved;
                }
                Some((c, upper, violation)) => {
                    if iterations >= max_iterations || run.tally.exhausted() {
                        run.tally.pass();
                        break Ended::IterationLimit;
                    }
                    run.add(c, upper, violation);
                    changed = true;
                }
            }
        } else {
            run.singular_direction();
            match run.blocking() {
                Some((i, alpha)) => {
                    if iterations >= max_iterations || run.tally.exhausted() {
                        break Ended::IterationLimit;
                    }
                    run.step_and_remove(i, alpha);
                    changed = true;
                }
                None => {
                    let last = run.k.saturating_sub(1);
                    let c = at_entry(run.w.set, last);
                    let side = run.side(last);
                    if at(run.w.lambda, last) == 0.0
                        && run.added_violation <= tol.infeasible * (1.0 + side.abs())
                    {
                        // A dependent side violated within round-off (a degenerate vertex): set aside
                        // for this solve rather than call the QP infeasible.
                        run.drop_last();
                        put(run.w.excluded, c, true);
                        run.tally.pass();
                        continue;
                    }
                    run.tally.pass();
                    break Ended::Infeasible;
                }
            }
        }
        if changed {
            iterations += 1;
        }
        run.tally.pass();
    };
    run.tally.pass();
    *k_out = run.k;
    (ended, iterations)
}

/// z_b −= Z_W·c in `z_free` for the working set's coefficients c (λ, or with `star` the refinement's
/// in `star`), a column of Z at a time (in the working set's order); without Z, Z_W·c = H⁻¹·Σ_W (c_i /
/// s_c)·a_c in `tmp`. False where H⁻¹ fails.
fn recover(b: &Block, w: &mut Work, k: usize, star: bool, tally: &mut Tally) -> bool {
    let n = b.n();
    let coefficients: &[Real] = if star { &*w.star } else { &*w.lambda };
    let z_b = w.z_free.get_mut(..n).unwrap_or(&mut []);
    if b.z_cols.is_empty() {
        let v = w.tmp.get_mut(..n).unwrap_or(&mut []);
        for x in v.iter_mut() {
            *x = 0.0;
        }
        let mut count = 0;
        for (c, coefficient) in w.set.iter().zip(coefficients.iter()).take(k) {
            let c = *c as usize;
            let weight = *coefficient / at(b.scale, c);
            let (start, end) = (at_index(b.starts, c), at_index(b.starts, c + 1));
            let row = b.positions.get(start..end).unwrap_or(&[]);
            for (p, a) in row.iter().zip(b.values.get(start..end).unwrap_or(&[])) {
                if let Some(x) = v.get_mut(*p) {
                    *x += weight * *a;
                }
            }
            count += row.len();
        }
        let solved = h_inverse(b.r.get(..n * (n + 1) / 2).unwrap_or(&[]), v);
        for (zi, x) in z_b.iter_mut().zip(v.iter()) {
            *zi -= *x;
        }
        tally.recover(count + n * (n + 1));
        solved
    } else {
        for (c, coefficient) in w.set.iter().zip(coefficients.iter()).take(k) {
            let c = *c as usize;
            if let Some(column) = b.z_cols.get(c * n..c * n + n) {
                for (v, zc) in z_b.iter_mut().zip(column) {
                    *v -= *coefficient * *zc;
                }
            }
        }
        tally.recover(n * k);
        true
    }
}

/// Restarts of a block after its solve when a row is violated on z itself (f32).
const PRIMAL_RESTARTS: usize = 1;

/// The rows violated on the block's z (in `z_free`), outside the working set, beyond the primal
/// tolerance in the scan's normalised units: their warm-start codes (twice the constraint, plus one at
/// an upper side) written to `out`, as many as it holds; returns how many.
fn violated_on_z(
    b: &Block,
    w: &Work,
    lower: &[Real],
    upper: &[Real],
    tol: &Tolerances,
    tally: &mut Tally,
    (limit, out): (usize, &mut [u32]),
) -> usize {
    let z_b = w.z_free.get(..b.n()).unwrap_or(&[]);
    let mut found = 0;
    for c in 0..limit {
        if found >= out.len() {
            break;
        }
        if at_flag(w.active, c) {
            continue;
        }
        let (a, len) = b.row_times(c, z_b);
        tally.recover(len);
        let side = at_index(b.sides, c);
        let s = at(b.scale, c);
        let (lo, hi) = (at(lower, side), at(upper, side));
        let code = if (a - hi) / s > tol.primal * (1.0 + hi.abs() / s) {
            2 * c + 1
        } else if (lo - a) / s > tol.primal * (1.0 + lo.abs() / s) {
            2 * c
        } else {
            continue;
        };
        put(out, found, code as u32);
        found += 1;
    }
    found
}

/// One step of primal iterative refinement on the working rows: their residuals r = (side − a·z)/s
/// from the QP's own sides (z is of the size of the plan, so these are exact to its round-off), x =
/// G_WW⁻¹·r with the factor, and z += Z_W·x: z then meets the working rows to round-off.
fn refine_primal(
    b: &Block,
    w: &mut Work,
    k: usize,
    lower: &[Real],
    upper: &[Real],
    tol: &Tolerances,
    tally: &mut Tally,
) -> bool {
    let n = b.n();
    for i in 0..k {
        let c = at_entry(w.set, i);
        let side = at_index(b.sides, c);
        let bound = if at_flag(w.upper, i) {
            at(upper, side)
        } else {
            at(lower, side)
        };
        let (a, len) = b.row_times(c, w.z_free.get(..n).unwrap_or(&[]));
        put(w.tmp, i, (bound - a) / at(b.scale, c));
        tally.recover(len + 2);
    }
    let mut run = Run {
        b,
        w,
        tol,
        tally,
        k,
        reuse: 0,
        singular: false,
        added_violation: 0.0,
        limit: b.nc(),
    };
    run.ldl_solve(0, true);
    // λ* of the working set is λ − x (the residual is G_WW·(λ − λ*)); z moves by Z_W·x.
    for (x, lambda) in run.w.star.iter_mut().zip(run.w.lambda.iter_mut()).take(k) {
        *lambda -= *x;
        *x = -*x;
    }
    recover(b, w, k, true, tally)
}

/// Solves the QP min ½zᵀHz + fᵀz s.t. lower ≤ (z, A·z) ≤ upper block by block, each from its warm start
/// in `warm` (a block's at its `warm_at`, `warm_len[b]` entries), with at most `max_iterations` changes
/// of the working set over all blocks. Writes z (z = z_free − Z_W·λ per block) and each block's final
/// working set back into `warm` as the next solve's start; `each(b, w, k, changes)` sees each block's
/// work after its solve, with its working set's size and its changes. Returns the most severe ending and the changes made.
#[allow(clippy::too_many_arguments)]
pub(super) fn solve(
    blocks: &[Block],
    f: &[Real],
    lower: &[Real],
    upper: &[Real],
    w: &mut Work,
    warm: &mut [u32],
    warm_len: &mut [u32],
    max_iterations: usize,
    tol: &Tolerances,
    tally: &mut Tally,
    z: &mut [Real],
    mut each: impl FnMut(usize, &Work, usize, usize),
) -> (Ended, usize) {
    let mut ended = Ended::Solved;
    let mut iterations = 0;
    for (index, b) in blocks.iter().enumerate() {
        let limit = b.limit(lower, upper, tally);
        if !offsets(b, f, lower, upper, w, tally, limit) {
            ended = Ended::NumericalFailure;
            put(warm_len, index, 0);
            continue;
        }
        let mut k = 0;
        let mut block_iterations = 0;
        let mut restarts = 0;
        let block_ended = loop {
            let start = match warm.get(b.warm_at..) {
                Some(s) => s,
                None => &[],
            };
            let (block_ended, changes) = solve_block(
                b,
                w,
                start,
                at_entry(warm_len, index),
                max_iterations.saturating_sub(iterations + block_iterations),
                tol,
                tally,
                (limit, &mut k),
            );
            block_iterations += changes;
            // z_b = z_free − Z_W·λ, in z_free.
            if !recover(b, w, k, false, tally) {
                break Ended::NumericalFailure;
            }
            // In f32 the terms of Z_W·λ are as large as the multipliers (1e5 at a soft row's weight)
            // where z is not, and so is the scan's round-off: one step of primal refinement, then the
            // rows checked on z itself; a row violated there restarts the block from the working set
            // with it added (at most PRIMAL_RESTARTS times).
            if Real::EPSILON > 1e-10 && b.refine && block_ended == Ended::Solved {
                if k > 0 && !refine_primal(b, w, k, lower, upper, tol, tally) {
                    break Ended::NumericalFailure;
                }
                if restarts < PRIMAL_RESTARTS && k <= b.n() {
                    // The working set less the sides whose refined multiplier has the wrong sign
                    // (beyond the dual tolerance, relative to the largest multiplier), then the rows
                    // violated on z.
                    let mut largest: Real = 0.0;
                    for i in 0..k {
                        largest = largest.max(at(w.lambda, i).abs());
                    }
                    let wrong = tol.dual * (1.0 + largest);
                    let mut kept = 0;
                    for i in 0..k {
                        let (upper, lambda) = (at_flag(w.upper, i), at(w.lambda, i));
                        if (upper && lambda < -wrong) || (!upper && lambda > wrong) {
                            continue;
                        }
                        let code = 2 * at_entry(w.set, i) + usize::from(upper);
                        put(warm, b.warm_at + kept, code as u32);
                        kept += 1;
                    }
                    let room = warm
                        .get_mut(b.warm_at + kept..b.warm_at + b.n() + 1)
                        .unwrap_or(&mut []);
                    let added = violated_on_z(b, w, lower, upper, tol, tally, (limit, room));
                    if kept < k || added > 0 {
                        // The violated rows first: where one depends on the kept sides (a vertex
                        // the noise chose), the kept side it depends on is the one skipped.
                        if let Some(start) = warm.get_mut(b.warm_at..b.warm_at + kept + added) {
                            start.rotate_right(added);
                        }
                        put(warm_len, index, (kept + added) as u32);
                        restarts += 1;
                        if !offsets(b, f, lower, upper, w, tally, limit) {
                            break Ended::NumericalFailure;
                        }
                        continue;
                    }
                }
            }
            break block_ended;
        };
        iterations += block_iterations;
        if block_ended.severity() > ended.severity() {
            ended = block_ended;
        }
        let n = b.n();
        let z_b = w.z_free.get_mut(..n).unwrap_or(&mut []);
        for (v, p) in z_b.iter().zip(b.vars) {
            put(z, *p, *v);
        }
        for i in 0..k {
            let code = 2 * at_entry(w.set, i) + usize::from(at_flag(w.upper, i));
            put(warm, b.warm_at + i, code as u32);
        }
        put(warm_len, index, k as u32);
        each(index, w, k, block_iterations);
    }
    (ended, iterations)
}
