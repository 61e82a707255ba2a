//! The run-time iteration on one block, in the style of DAQP's `daqp_ldp`: the dual active-set method
//! of Goldfarb and Idnani on the least-distance problem min ½‖u‖² s.t. dl ≤ M̂·u ≤ du.
//!
//! The iterate is a multiplier λ on the working set W (λ ≥ 0 on an upper side, ≤ 0 on a lower one:
//! dual feasible), with u = −M̂_Wᵀ·λ. One pass:
//! 1. the constrained stationary point λ* of W: L·D·Lᵀ·λ* = −d_W, the forward substitution reused up
//!    to the first row of the factor that changed;
//! 2. if some λ*_i has the wrong sign, step from λ toward λ* until the first multiplier reaches zero and
//!    remove that constraint (a downdate of the factor);
//! 3. otherwise λ = λ*, and the slacks of the inactive rows, μ = M̂·u = −G_{:,W}·λ (|W| per row, from
//!    the Gram matrix), give the most violated side, which is added with multiplier 0 (an update of the
//!    factor, its new row looked up in G); none violated: optimal.
//!
//! A side that depends on the working set (its pivot below [`Tolerances::singular`], or more sides
//! than variables) makes W singular: the null direction p of G_WW (p = 1 on the new side) leaves u
//! unchanged and raises the dual objective, so λ moves along it until a multiplier reaches zero, and
//! that constraint is removed; if none ever does the dual is unbounded and the QP infeasible.
//!
//! Each pass costs the multiply-adds it runs ([`Macs`]); the count of a pass is kept so that a
//! certificate can price the worst one.

use super::ldl::Ldl;
use super::prepared::Block;
use super::{Macs, Side, Status, Tolerances};

/// What a block's solve ends with.
pub(super) struct BlockRun {
    pub(super) status: Status,
    /// The working set: (position in the block, side), in the factor's order.
    pub(super) working: Vec<(usize, Side)>,
    /// The multipliers of the scaled problem, signed (≥ 0 upper, ≤ 0 lower), aligned with `working`.
    pub(super) lambda: Vec<f64>,
    pub(super) iterations: usize,
    pub(super) macs: Macs,
    pub(super) per_pass: Vec<usize>,
}

struct Run<'a> {
    block: &'a Block,
    lower: &'a [f64],
    upper: &'a [f64],
    tol: &'a Tolerances,
    working: Vec<(usize, Side)>,
    active: Vec<bool>,
    /// Sides found dependent with a violation within round-off: left out of the scans of this solve.
    excluded: Vec<bool>,
    lambda: Vec<f64>,
    star: Vec<f64>,
    y: Vec<f64>,
    scaled: Vec<f64>,
    /// Rows of `y` and `scaled` still valid.
    reuse: usize,
    ldl: Ldl,
    /// The last row of the factor depends on the others (its pivot set to zero).
    singular: bool,
    /// The violation the last added side had when it was added.
    added_violation: f64,
    macs: Macs,
}

impl Run<'_> {
    fn d(&self, i: usize) -> f64 {
        let (c, side) = self.working[i];
        match side {
            Side::Upper => self.upper[c],
            Side::Lower => self.lower[c],
        }
    }

    /// Appends constraint `c` at `side` with multiplier `lambda` to the factor; marks the set singular
    /// when its pivot is below the tolerance or the set has more sides than the block has variables.
    fn push(&mut self, c: usize, side: Side, lambda: f64) {
        let g: Vec<f64> = self
            .working
            .iter()
            .map(|&(w, _)| self.block.G[(w, c)])
            .collect();
        let pivot = self
            .ldl
            .push(&g, self.block.G[(c, c)], &mut self.macs.factor);
        self.working.push((c, side));
        self.lambda.push(lambda);
        self.active[c] = true;
        if pivot.is_nan() || pivot < self.tol.singular || self.working.len() > self.block.n() {
            self.ldl.set_last_pivot(0.0);
            self.singular = true;
        }
    }

    /// Removes position `i` of the working set (a downdate); the set is singular afterwards when the
    /// last pivot fell below the tolerance (round-off), else the small-pivot guard runs.
    fn remove(&mut self, i: usize) {
        let (c, _) = self.working.remove(i);
        self.lambda.remove(i);
        self.active[c] = false;
        self.ldl.remove(i, &mut self.macs.factor);
        self.reuse = self.reuse.min(i);
        self.singular = false;
        let k = self.ldl.len();
        let last = if k > 0 { self.ldl.pivot(k - 1) } else { 1.0 };
        if last.is_nan() || last < self.tol.singular {
            self.ldl.set_last_pivot(0.0);
            self.singular = true;
        } else {
            self.pivot_last();
        }
    }

    /// DAQP's `pivot_last`: when the second-to-last pivot is small and smaller than the last, that
    /// constraint is moved to the end (removed and appended again), so a nearly dependent side sits
    /// where the next change can drop it without perturbing the rows after it.
    fn pivot_last(&mut self) {
        let k = self.ldl.len();
        if k < 2 {
            return;
        }
        let r = k - 2;
        let (dr, dl) = (self.ldl.pivot(r), self.ldl.pivot(k - 1));
        if dr < self.tol.pivot && dr < dl {
            let (c, side) = self.working.remove(r);
            let lambda = self.lambda.remove(r);
            self.active[c] = false;
            self.ldl.remove(r, &mut self.macs.factor);
            self.reuse = self.reuse.min(r);
            self.push(c, side, lambda);
        }
    }

    /// Refactorises G_WW from scratch in the working set's order, dropping a side whose pivot is then
    /// below the tolerance.
    fn refactor(&mut self) {
        let old: Vec<((usize, Side), f64)> =
            self.working.drain(..).zip(self.lambda.drain(..)).collect();
        for &((c, _), _) in &old {
            self.active[c] = false;
        }
        self.ldl.clear();
        self.reuse = 0;
        self.singular = false;
        for ((c, side), lambda) in old {
            self.push(c, side, lambda);
            if self.singular {
                self.drop_last();
            }
        }
    }

    /// Removes the last side (no downdate needed) and clears the singular mark.
    fn drop_last(&mut self) {
        let k = self.working.len();
        if k == 0 {
            return;
        }
        self.ldl.remove(k - 1, &mut self.macs.factor);
        let (c, _) = self.working.remove(k - 1);
        self.lambda.remove(k - 1);
        self.active[c] = false;
        self.reuse = self.reuse.min(k - 1);
        self.singular = false;
    }

    /// λ* of the working set.
    fn stationary(&mut self) {
        let k = self.working.len();
        let rhs: Vec<f64> = (0..k).map(|i| -self.d(i)).collect();
        self.ldl.solve_cached(
            |i| rhs[i],
            &mut self.y,
            &mut self.scaled,
            self.reuse,
            &mut self.star,
            &mut self.macs.solve,
        );
        self.reuse = k;
    }

    /// The null direction of the singular set, into `star`: p = L⁻ᵀ·e_last, flipped for a lower side so
    /// that the new side's multiplier grows with the right sign.
    fn singular_direction(&mut self) {
        let k = self.working.len();
        let s = k - 1;
        self.star.resize(k, 0.0);
        self.star[s] = 1.0;
        for i in (0..s).rev() {
            let mut v = -self.ldl.l(s, i);
            for j in i + 1..s {
                v -= self.ldl.l(j, i) * self.star[j];
            }
            self.star[i] = v;
        }
        self.macs.solve += s * s.saturating_sub(1) / 2;
        if self.working[s].1 == Side::Lower {
            for p in &mut self.star[..k] {
                *p = -*p;
            }
        }
    }

    /// The first multiplier to reach zero on the way from λ toward λ* (or along the singular
    /// direction): its position and the step.
    fn blocking(&self) -> Option<(usize, f64)> {
        let mut best: Option<(usize, f64)> = None;
        for (i, &(_, side)) in self.working.iter().enumerate() {
            let st = self.star[i];
            let wrong = match side {
                Side::Upper => st < -self.tol.dual,
                Side::Lower => st > self.tol.dual,
            };
            if !wrong {
                continue;
            }
            let p = if self.singular {
                st
            } else {
                st - self.lambda[i]
            };
            let alpha = (-self.lambda[i] / p).max(0.0);
            if best.is_none_or(|(_, b)| alpha < b) {
                best = Some((i, alpha));
            }
        }
        best
    }

    /// λ ← λ + α·(λ* − λ) (or + α·p), then the blocking constraint leaves.
    fn step_and_remove(&mut self, i: usize, alpha: f64) {
        let k = self.working.len();
        for j in 0..k {
            let p = if self.singular {
                self.star[j]
            } else {
                self.star[j] - self.lambda[j]
            };
            self.lambda[j] += alpha * p;
        }
        self.macs.step += k;
        self.lambda[i] = 0.0;
        self.remove(i);
    }

    /// The most violated inactive side: (constraint, side, violation).
    fn scan(&mut self) -> Option<(usize, Side, f64)> {
        let k = self.working.len();
        let g = &self.block.G;
        let mut best: Option<(usize, Side, f64)> = None;
        let mut scanned = 0;
        for c in 0..self.block.rows.len() {
            if self.active[c] || self.excluded[c] {
                continue;
            }
            scanned += 1;
            let mut mu = 0.0;
            for (&(w, _), l) in self.working.iter().zip(&self.lambda) {
                mu -= g[(w, c)] * l;
            }
            for (side, violation, d) in [
                (Side::Upper, mu - self.upper[c], self.upper[c]),
                (Side::Lower, self.lower[c] - mu, self.lower[c]),
            ] {
                if violation > self.tol.primal * (1.0 + d.abs())
                    && best.is_none_or(|(_, _, b)| violation > b)
                {
                    best = Some((c, side, violation));
                }
            }
        }
        self.macs.scan += scanned * k;
        best
    }

    /// One step of iterative refinement of λ on the working set: r = G_WW·λ + d_W, λ −= (L·D·Lᵀ)⁻¹·r.
    fn refine(&mut self) {
        let k = self.working.len();
        let g = &self.block.G;
        let r: Vec<f64> = (0..k)
            .map(|i| {
                let wi = self.working[i].0;
                let s: f64 = (0..k)
                    .map(|j| g[(wi, self.working[j].0)] * self.lambda[j])
                    .sum();
                s + self.d(i)
            })
            .collect();
        self.macs.solve += k * k;
        let (mut y, mut scaled, mut delta) = (Vec::new(), Vec::new(), Vec::new());
        self.ldl.solve_cached(
            |i| r[i],
            &mut y,
            &mut scaled,
            0,
            &mut delta,
            &mut self.macs.solve,
        );
        for (l, dl) in self.lambda.iter_mut().zip(&delta) {
            *l -= dl;
        }
        self.macs.step += k;
    }
}

/// Solves the block's least-distance problem with sides `lower`/`upper` (scaled, ±∞ where absent),
/// from the warm set `warm` (positions in the block with their sides; see [`super::solve`] for the
/// rule), for at most `max_iterations` changes of the working set.
pub(super) fn run(
    block: &Block,
    lower: &[f64],
    upper: &[f64],
    warm: &[(usize, Side)],
    max_iterations: usize,
    tol: &Tolerances,
) -> BlockRun {
    let nc = block.rows.len();
    let mut run = Run {
        block,
        lower,
        upper,
        tol,
        working: Vec::new(),
        active: vec![false; nc],
        excluded: vec![false; nc],
        lambda: Vec::new(),
        star: Vec::new(),
        y: Vec::new(),
        scaled: Vec::new(),
        reuse: 0,
        ldl: Ldl::default(),
        singular: false,
        added_violation: 0.0,
        macs: Macs::default(),
    };
    let mut per_pass = Vec::new();
    let finish = |run: Run, status: Status, iterations: usize, per_pass: Vec<usize>| BlockRun {
        status,
        working: run.working,
        lambda: run.lambda,
        iterations,
        macs: run.macs,
        per_pass,
    };
    if lower.iter().chain(upper).any(|v| v.is_nan()) {
        return finish(run, Status::NumericalFailure, 0, per_pass);
    }
    // A row whose sides cross admits nothing.
    if lower.iter().zip(upper).any(|(l, u)| l > u) {
        return finish(run, Status::Infeasible, 0, per_pass);
    }
    // The warm set: sides that exist, one per row, independent of those before them; multipliers
    // start at ±1 (dual feasible), and the first passes remove the sides whose λ* has the wrong sign.
    for &(c, side) in warm {
        let exists = c < nc
            && match side {
                Side::Upper => upper[c].is_finite(),
                Side::Lower => lower[c].is_finite(),
            };
        if !exists || run.active[c] {
            continue;
        }
        let sign = match side {
            Side::Upper => 1.0,
            Side::Lower => -1.0,
        };
        run.push(c, side, sign);
        if run.singular {
            run.drop_last();
        }
    }
    // Each pass's multiply-adds; the first pass carries the warm start's factorisation, and a pass
    // that ends the solve is recorded after the loop.
    let mut mark = 0;
    let record = |run: &Run, per_pass: &mut Vec<usize>, mark: &mut usize| {
        per_pass.push(run.macs.total() - *mark);
        *mark = run.macs.total();
    };
    let mut iterations = 0;
    let mut refactored = false;
    let mut refined = false;
    let mut best = f64::NEG_INFINITY;
    let mut stalled = 0;
    let status = loop {
        let changed;
        if !run.singular {
            run.stationary();
            if !run.star.iter().all(|v| v.is_finite()) {
                break Status::NumericalFailure;
            }
            if let Some((i, alpha)) = run.blocking() {
                if iterations >= max_iterations {
                    break Status::IterationLimit;
                }
                run.step_and_remove(i, alpha);
                iterations += 1;
                record(&run, &mut per_pass, &mut mark);
                continue;
            }
            let k = run.working.len();
            run.lambda.copy_from_slice(&run.star[..k]);
            // The dual objective ‖u‖² = −d_Wᵀλ*, which grows from one full step to the next; a run of
            // full steps without progress is cycling.
            let value: f64 = -(0..k).map(|i| run.d(i) * run.lambda[i]).sum::<f64>();
            run.macs.step += k;
            if best.is_finite() && value - best <= tol.progress * (1.0 + best.abs()) {
                stalled += 1;
                if stalled > tol.cycle {
                    if refactored {
                        break Status::Cycling;
                    }
                    refactored = true;
                    run.refactor();
                    stalled = 0;
                    best = f64::NEG_INFINITY;
                    record(&run, &mut per_pass, &mut mark);
                    continue;
                }
            } else {
                best = value;
                stalled = 0;
            }
            match run.scan() {
                None => {
                    let min_pivot = run.ldl.min_pivot();
                    if !refactored && k > 2 && min_pivot < tol.refactor {
                        refactored = true;
                        run.refactor();
                        record(&run, &mut per_pass, &mut mark);
                        continue;
                    }
                    if !refined && k > 0 && min_pivot < tol.pivot {
                        refined = true;
                        run.refine();
                        run.reuse = 0;
                        if let Some((c, side, violation)) = run.scan() {
                            if iterations >= max_iterations {
                                break Status::IterationLimit;
                            }
                            run.added_violation = violation;
                            run.push(c, side, 0.0);
                            if !run.singular {
                                run.pivot_last();
                            }
                            iterations += 1;
                            record(&run, &mut per_pass, &mut mark);
                            continue;
                        }
                    }
                    record(&run, &mut per_pass, &mut mark);
                    break Status::Solved;
                }
                Some((c, side, violation)) => {
                    if iterations >= max_iterations {
                        record(&run, &mut per_pass, &mut mark);
                        break Status::IterationLimit;
                    }
                    run.added_violation = violation;
                    run.push(c, side, 0.0);
                    if !run.singular {
                        run.pivot_last();
                    }
                    changed = true;
                }
            }
        } else {
            run.singular_direction();
            match run.blocking() {
                Some((i, alpha)) => {
                    if iterations >= max_iterations {
                        break Status::IterationLimit;
                    }
                    run.step_and_remove(i, alpha);
                    changed = true;
                }
                None => {
                    let last = run.working.len() - 1;
                    let (c, side) = run.working[last];
                    let d = match side {
                        Side::Upper => upper[c],
                        Side::Lower => lower[c],
                    };
                    if run.lambda[last] == 0.0
                        && run.added_violation <= tol.infeasible * (1.0 + d.abs())
                    {
                        // A dependent side violated within round-off (a degenerate vertex): set it
                        // aside for this solve rather than call the QP infeasible.
                        run.drop_last();
                        run.excluded[c] = true;
                        record(&run, &mut per_pass, &mut mark);
                        continue;
                    }
                    record(&run, &mut per_pass, &mut mark);
                    break Status::Infeasible;
                }
            }
        }
        if changed {
            iterations += 1;
        }
        record(&run, &mut per_pass, &mut mark);
    };
    if run.macs.total() > mark {
        record(&run, &mut per_pass, &mut mark);
    }
    finish(run, status, iterations, per_pass)
}
