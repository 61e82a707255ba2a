//! Streaming statistics of a run: control-cycle ticks and tracking errors. No allocation, no
//! panicking arithmetic (integer overflow would need 2^64 ticks).

/// Global timer ticks per control cycle.
pub struct Ticks {
    /// Fewest ticks of a cycle (`u64::MAX` before the first).
    pub min: u64,
    /// Most ticks of a cycle.
    pub max: u64,
    /// Sum over all cycles.
    pub sum: u64,
    /// Number of cycles.
    pub count: u64,
}

impl Ticks {
    /// No cycle yet.
    pub const fn new() -> Self {
        Self {
            min: u64::MAX,
            max: 0,
            sum: 0,
            count: 0,
        }
    }

    /// Adds one cycle.
    pub fn add(&mut self, ticks: u64) {
        self.min = self.min.min(ticks);
        self.max = self.max.max(ticks);
        self.sum = self.sum.saturating_add(ticks);
        self.count += 1;
    }

    /// Mean ticks per cycle, rounded to nearest (0 before the first cycle).
    pub fn mean(&self) -> u64 {
        self.sum
            .saturating_add(self.count / 2)
            .checked_div(self.count)
            .unwrap_or(0)
    }
}

/// Position tracking error `p − p_ref` per axis, m. The host test accumulates the same sums in
/// the same order, so both sides round alike.
pub struct Errors {
    sum_sq: [f64; 3],
    max_abs: [f64; 3],
    count: u64,
}

impl Errors {
    /// No sample yet.
    pub const fn new() -> Self {
        Self {
            sum_sq: [0.0; 3],
            max_abs: [0.0; 3],
            count: 0,
        }
    }

    /// Adds the error of one cycle.
    pub fn add(&mut self, e: &[f64; 3]) {
        for ((s, m), &e) in self.sum_sq.iter_mut().zip(&mut self.max_abs).zip(e) {
            *s += e * e;
            // `f64::max` would drop a NaN; keep it so the end check sees it.
            let a = if e < 0.0 { -e } else { e };
            if a > *m || a.is_nan() {
                *m = a;
            }
        }
        self.count += 1;
    }

    /// Root mean square error per axis, m.
    pub fn rmse(&self) -> [f64; 3] {
        let n = self.count as f64;
        self.sum_sq.map(|s| libm::sqrt(s / n))
    }

    /// Largest absolute error per axis, m.
    pub fn max_abs(&self) -> [f64; 3] {
        self.max_abs
    }
}

/// `x` m in whole micrometres, rounded; `None` if not finite or negative. Printing integers
/// keeps float formatting (and its panicking paths) out of the firmware.
pub fn micrometres(x: f64) -> Option<u64> {
    let um = x * 1e6 + 0.5;
    // `as` saturates; the range check (false for NaN and infinities) keeps a huge error from
    // passing as u64::MAX.
    (0.0..1.8e19).contains(&um).then_some(um as u64)
}
