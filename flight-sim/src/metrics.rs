//! The paper's metrics: Table 2 (tracking and control signal), Table 3 (step response) and
//! the gust figures of Section 3.2.4.
//!
//! Table 2 and Table 3 are streaming accumulators (no storage, usable on the firmware); the gust
//! figures need the whole Y error of a run and of its undisturbed twin, so they take slices.
//!
//! Conventions (the paper does not state them; these are the usual discrete forms):
//! - the error is the true position minus the reference, per axis, at every cycle `k`,
//!   `t_k = k·dt` from the start of the run;
//! - integrals are rectangle sums: IAE `Σ|e|dt`, ISE `Σe²dt`, ITAE `Σ t|e| dt`, ITSE `Σ t e² dt`;
//! - RMSE `sqrt(mean e²)`; max abs error `max |e|`;
//! - smoothness is the mean rate of change of the command, `mean_k |u_k − u_{k−1}| / dt`;
//! - the control variance is the population variance of the command, `mean (u − ū)²`.

use libm::sqrt;

/// Table 2 of one run, per axis `[x, y, z]`: `NE` tracked quantities and `NC` commands, three of each
/// for the drone (any number for a [`LinearPlant`](crate::LinearPlant)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Table2<const NE: usize = 3, const NC: usize = NE> {
    /// Max absolute error, m.
    pub max_abs_error: [f64; NE],
    /// Root-mean-square error, m.
    pub rmse: [f64; NE],
    /// Integral of the absolute error, m·s.
    pub iae: [f64; NE],
    /// Integral of the squared error, m²·s.
    pub ise: [f64; NE],
    /// Integral of time times absolute error, m·s².
    pub itae: [f64; NE],
    /// Integral of time times squared error, m²·s².
    pub itse: [f64; NE],
    /// Mean rate of change of the command, m/s³.
    pub smoothness: [f64; NC],
    /// Variance of the command, (m/s²)².
    pub variance: [f64; NC],
}

// `[f64; N]: Default` exists for N ≤ 32 only, not for a const generic N.
impl<const NE: usize, const NC: usize> Default for Table2<NE, NC> {
    fn default() -> Self {
        Self {
            max_abs_error: [0.0; NE],
            rmse: [0.0; NE],
            iae: [0.0; NE],
            ise: [0.0; NE],
            itae: [0.0; NE],
            itse: [0.0; NE],
            smoothness: [0.0; NC],
            variance: [0.0; NC],
        }
    }
}

/// Accumulates [`Table2`] one cycle at a time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tracking<const NE: usize = 3, const NC: usize = NE> {
    dt: f64,
    n: usize,
    max_abs: [f64; NE],
    sum_abs: [f64; NE],
    sum_sq: [f64; NE],
    sum_t_abs: [f64; NE],
    sum_t_sq: [f64; NE],
    sum_du: [f64; NC],
    previous_u: [f64; NC],
    // Welford's running mean and sum of squared deviations of the command.
    mean_u: [f64; NC],
    m2_u: [f64; NC],
}

impl<const NE: usize, const NC: usize> Tracking<NE, NC> {
    /// An empty accumulator for samples `dt` seconds apart.
    pub const fn new(dt: f64) -> Self {
        Self {
            dt,
            n: 0,
            max_abs: [0.0; NE],
            sum_abs: [0.0; NE],
            sum_sq: [0.0; NE],
            sum_t_abs: [0.0; NE],
            sum_t_sq: [0.0; NE],
            sum_du: [0.0; NC],
            previous_u: [0.0; NC],
            mean_u: [0.0; NC],
            m2_u: [0.0; NC],
        }
    }

    /// Adds one cycle at time `t`: tracking error `error` (m) and command `u` (m/s²).
    pub fn push(&mut self, t: f64, error: &[f64; NE], u: &[f64; NC]) {
        self.n += 1;
        let n = self.n as f64;
        for i in 0..NE {
            let a = error[i].abs();
            let s = error[i] * error[i];
            if a > self.max_abs[i] {
                self.max_abs[i] = a;
            }
            self.sum_abs[i] += a;
            self.sum_sq[i] += s;
            self.sum_t_abs[i] += t * a;
            self.sum_t_sq[i] += t * s;
        }
        for i in 0..NC {
            if self.n > 1 {
                self.sum_du[i] += (u[i] - self.previous_u[i]).abs();
            }
            let delta = u[i] - self.mean_u[i];
            self.mean_u[i] += delta / n;
            self.m2_u[i] += delta * (u[i] - self.mean_u[i]);
        }
        self.previous_u = *u;
    }

    /// Number of cycles pushed.
    pub const fn len(&self) -> usize {
        self.n
    }

    /// Whether nothing was pushed.
    pub const fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The metrics so far (all zero when empty).
    pub fn finish(&self) -> Table2<NE, NC> {
        let mut t = Table2::default();
        if self.n == 0 {
            return t;
        }
        let n = self.n as f64;
        for i in 0..NE {
            t.max_abs_error[i] = self.max_abs[i];
            t.rmse[i] = sqrt(self.sum_sq[i] / n);
            t.iae[i] = self.sum_abs[i] * self.dt;
            t.ise[i] = self.sum_sq[i] * self.dt;
            t.itae[i] = self.sum_t_abs[i] * self.dt;
            t.itse[i] = self.sum_t_sq[i] * self.dt;
        }
        for i in 0..NC {
            t.smoothness[i] = if self.n > 1 {
                self.sum_du[i] / ((n - 1.0) * self.dt)
            } else {
                0.0
            };
            t.variance[i] = self.m2_u[i] / n;
        }
        t
    }
}

/// Table 3 of one axis. Times are from the instant of the step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepMetrics {
    /// From 10 % to 90 % of the step (crossings interpolated), s; `None` if 90 % is never reached.
    pub rise_time: Option<f64>,
    /// Time of the largest response after the step, s.
    pub peak_time: Option<f64>,
    /// `100 · (peak − target) / step`, 0 when the response never passes the target, %.
    pub overshoot_pct: f64,
    /// Time after which the response stays within the band around the target (entry
    /// interpolated), s; `None` if it is outside the band at the end of the record.
    pub settling_time: Option<f64>,
}

/// Accumulates [`StepMetrics`] of one axis, one sample at a time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepResponse {
    y0: f64,
    step: f64,
    at: f64,
    band: f64,
    previous: Option<(f64, f64)>,
    t10: Option<f64>,
    t90: Option<f64>,
    peak: Option<(f64, f64)>,
    /// Entry into the band after the last exit, or `None` while outside.
    settled_at: Option<f64>,
}

impl StepResponse {
    /// The settling band of Table 3 here: ±2 % of the step.
    pub const BAND: f64 = 0.02;

    /// A response from `y0` to `y0 + step` with the step at time `at`, settling band ±2 %.
    pub const fn new(y0: f64, step: f64, at: f64) -> Self {
        Self::with_band(y0, step, at, Self::BAND)
    }

    /// As [`StepResponse::new`] with a settling band of `band` (a fraction of the step).
    pub const fn with_band(y0: f64, step: f64, at: f64, band: f64) -> Self {
        Self {
            y0,
            step,
            at,
            band,
            previous: None,
            t10: None,
            t90: None,
            peak: None,
            settled_at: None,
        }
    }

    /// Adds the sample `y` at time `t` (times increasing).
    pub fn push(&mut self, t: f64, y: f64) {
        let r = if self.step != 0.0 {
            (y - self.y0) / self.step
        } else {
            0.0
        };
        let inside = (r - 1.0).abs() <= self.band;
        match self.previous {
            Some((tp, rp)) => {
                if self.t10.is_none() && rp < 0.1 && r >= 0.1 {
                    self.t10 = Some(crossing(tp, rp, t, r, 0.1));
                }
                if self.t90.is_none() && rp < 0.9 && r >= 0.9 {
                    self.t90 = Some(crossing(tp, rp, t, r, 0.9));
                }
                let was_inside = (rp - 1.0).abs() <= self.band;
                if inside && !was_inside {
                    let edge = if rp < 1.0 {
                        1.0 - self.band
                    } else {
                        1.0 + self.band
                    };
                    self.settled_at = Some(crossing(tp, rp, t, r, edge));
                } else if !inside {
                    self.settled_at = None;
                }
            }
            None => {
                if r >= 0.1 {
                    self.t10 = Some(t);
                }
                if r >= 0.9 {
                    self.t90 = Some(t);
                }
                self.settled_at = if inside { Some(t) } else { None };
            }
        }
        if t >= self.at && self.peak.is_none_or(|(_, rp)| r > rp) {
            self.peak = Some((t, r));
        }
        self.previous = Some((t, r));
    }

    /// The metrics of the samples so far.
    pub fn finish(&self) -> StepMetrics {
        let rise_time = match (self.t10, self.t90) {
            (Some(a), Some(b)) => Some(b - a),
            _ => None,
        };
        let (peak_time, overshoot_pct) = match self.peak {
            Some((t, r)) => (
                Some(t - self.at),
                if r > 1.0 { 100.0 * (r - 1.0) } else { 0.0 },
            ),
            None => (None, 0.0),
        };
        StepMetrics {
            rise_time,
            peak_time,
            overshoot_pct,
            settling_time: self
                .settled_at
                .map(|t| if t > self.at { t - self.at } else { 0.0 }),
        }
    }
}

/// Time at which the segment from `(t0, r0)` to `(t1, r1)` crosses `level`.
fn crossing(t0: f64, r0: f64, t1: f64, r1: f64, level: f64) -> f64 {
    if r1 == r0 {
        t1
    } else {
        t0 + (t1 - t0) * (level - r0) / (r1 - r0)
    }
}

/// The gust figures of Section 3.2.4 for one controller.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GustMetrics {
    /// RMSE of the Y error from [`GUST_SETTLE`] s after the onset to the end of the gust, m:
    /// the error held while the gust blows.
    pub rmse_y_during: f64,
    /// Time from the end of the gust until the gust's effect on Y has died out (see
    /// [`gust`]), s; `None` if it never does within the record.
    pub recovery_time: Option<f64>,
    /// RMSE of the Y error over [`GUST_AFTER`] s after recovery (or to the end of the record,
    /// if shorter), m; `None` without a recovery.
    pub rmse_y_after: Option<f64>,
}

/// Seconds after the gust's onset from which the held error is measured.
pub const GUST_SETTLE: f64 = 3.0;
/// Length of the window after recovery over which the error after recovery is measured, s.
pub const GUST_AFTER: f64 = 10.0;

/// The gust figures from the Y error of a disturbed run, `y_gust[k]`, and of the same
/// controller's undisturbed run with the same seed, `y_calm[k]` (both `p − p_ref`, cycle `k` at
/// `k·dt`), for a gust on `[start, end)`.
///
/// The two runs meet the same noise, so `y_gust − y_calm` is the gust's own effect. Recovery is
/// the first time after the end of the gust from which that effect stays within the calm run's
/// RMSE on Y (the controller's noise-level error) until the end of the record.
pub fn gust(dt: f64, y_gust: &[f64], y_calm: &[f64], start: f64, end: f64) -> GustMetrics {
    let n = if y_gust.len() < y_calm.len() {
        y_gust.len()
    } else {
        y_calm.len()
    };
    let index = |t: f64| -> usize {
        let k = libm::ceil(t / dt - 1e-9);
        if k <= 0.0 {
            0
        } else if k as usize > n {
            n
        } else {
            k as usize
        }
    };
    let rms = |s: &[f64]| -> f64 {
        if s.is_empty() {
            0.0
        } else {
            sqrt(s.iter().map(|e| e * e).sum::<f64>() / s.len() as f64)
        }
    };
    let (k_hold, k_end) = (index(start + GUST_SETTLE), index(end));
    let rmse_y_during = rms(&y_gust[k_hold.min(k_end)..k_end]);
    let band = rms(&y_calm[..n]);
    // Last cycle at or after the end of the gust where the effect exceeds the band.
    let mut last_out = None;
    for k in (k_end..n).rev() {
        if (y_gust[k] - y_calm[k]).abs() > band {
            last_out = Some(k);
            break;
        }
    }
    let recovered = match last_out {
        None if k_end < n => Some(k_end),
        None => None,
        Some(k) if k + 1 < n => Some(k + 1),
        Some(_) => None,
    };
    match recovered {
        Some(k) => {
            let t = k as f64 * dt;
            let k_after = index(t + GUST_AFTER);
            GustMetrics {
                rmse_y_during,
                recovery_time: Some(if t > end { t - end } else { 0.0 }),
                rmse_y_after: Some(rms(&y_gust[k..k_after.max(k + 1).min(n)])),
            }
        }
        None => GustMetrics {
            rmse_y_during,
            recovery_time: None,
            rmse_y_after: None,
        },
    }
}

/// The band of [`gust_settling`]: 0.1 m, the "back under 0.1 m".
pub const SETTLE_BAND: f64 = 0.1;

/// How fast a disturbance's own effect on one axis dies out, after its onset and after its end
/// (see [`gust_settling`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GustSettling {
    /// Time from the onset until the effect is back within the band for good while the
    /// disturbance lasts, s: 0 if it never leaves the band, `None` if it is still outside at the
    /// end of the disturbance.
    pub settle_after_onset: Option<f64>,
    /// Time from the end until the effect is back within the band for good, to the end of the
    /// record, s: 0 if it is within the band from the end on, `None` if it is outside at the end
    /// of the record (or the record stops before the disturbance does).
    pub settle_after_end: Option<f64>,
    /// The largest effect over the record, m.
    pub max_effect: f64,
}

/// Index of the first cycle at or after time `t`, clamped to `[0, n]`.
fn cycle_at(dt: f64, t: f64, n: usize) -> usize {
    let k = libm::ceil(t / dt - 1e-9);
    if k <= 0.0 {
        0
    } else if k as usize > n {
        n
    } else {
        k as usize
    }
}

/// The times a disturbance on `[start, end)` takes to stop mattering on one axis, from the error
/// of the disturbed run, `e_gust[k]`, and of the same controller's undisturbed run with the same
/// seed, `e_calm[k]` (cycle `k` at `k·dt`).
///
/// As in [`gust`], the two runs meet the same noise, so `e_gust − e_calm` is the disturbance's own
/// effect, free of the noise that no controller can remove (the raw error of the calm run is
/// above 0.1 m on many cycles). The effect is *back within the band* at the first cycle from which
/// `|e_gust − e_calm| ≤ band` on every cycle until the end of the disturbance (after the onset)
/// or until the end of the record (after the end). Times are cycle-resolved.
pub fn gust_settling(
    dt: f64,
    e_gust: &[f64],
    e_calm: &[f64],
    start: f64,
    end: f64,
    band: f64,
) -> GustSettling {
    let n = e_gust.len().min(e_calm.len());
    let effect = |k: usize| (e_gust[k] - e_calm[k]).abs();
    let max_effect = (0..n).map(effect).fold(0.0, f64::max);
    // The first cycle of [from, to) from which the effect stays within the band up to `to`;
    // `None` if it is outside on the last cycle before `to` or the range is empty.
    let settled = |from: usize, to: usize| -> Option<usize> {
        if from >= to {
            return None;
        }
        match (from..to).rev().find(|&k| effect(k) > band) {
            None => Some(from),
            Some(k) if k + 1 < to => Some(k + 1),
            Some(_) => None,
        }
    };
    let (k_start, k_end) = (cycle_at(dt, start, n), cycle_at(dt, end, n));
    let since = |k: usize, t0: f64| {
        let t = k as f64 * dt;
        if t > t0 {
            t - t0
        } else {
            0.0
        }
    };
    let ends_in_record = end < n as f64 * dt;
    GustSettling {
        settle_after_onset: settled(k_start, k_end).map(|k| since(k, start)),
        settle_after_end: if ends_in_record {
            settled(k_end, n).map(|k| since(k, end))
        } else {
            None
        },
        max_effect,
    }
}

/// RMS of `e` over the cycles of `[from, to)` (`e[k]` at `k·dt`), 0 for an empty range.
pub fn rms_over(dt: f64, e: &[f64], from: f64, to: f64) -> f64 {
    let n = e.len();
    let (a, b) = (cycle_at(dt, from, n), cycle_at(dt, to, n));
    if a >= b {
        return 0.0;
    }
    sqrt(e[a..b].iter().map(|x| x * x).sum::<f64>() / (b - a) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn table2_by_hand() {
        // dt = 0.5, errors on x: 1, -2, 3 at t = 0, 0.5, 1; y constant 0.5; z zero.
        // commands on x: 0, 2, -2 ; y: 1, 1, 1 ; z: 0, 0, 3.
        let mut m = Tracking::new(0.5);
        m.push(0.0, &[1.0, 0.5, 0.0], &[0.0, 1.0, 0.0]);
        m.push(0.5, &[-2.0, 0.5, 0.0], &[2.0, 1.0, 0.0]);
        m.push(1.0, &[3.0, 0.5, 0.0], &[-2.0, 1.0, 3.0]);
        let t = m.finish();
        assert_eq!(t.max_abs_error, [3.0, 0.5, 0.0]);
        // RMSE x: sqrt((1 + 4 + 9) / 3).
        assert!(close(t.rmse[0], (14.0f64 / 3.0).sqrt(), 1e-12));
        assert!(close(t.rmse[1], 0.5, 1e-12));
        // IAE x: (1 + 2 + 3)·0.5 = 3; ISE x: 14·0.5 = 7.
        assert!(close(t.iae[0], 3.0, 1e-12) && close(t.ise[0], 7.0, 1e-12));
        // ITAE x: (0·1 + 0.5·2 + 1·3)·0.5 = 2; ITSE x: (0 + 0.5·4 + 9)·0.5 = 5.5.
        assert!(close(t.itae[0], 2.0, 1e-12) && close(t.itse[0], 5.5, 1e-12));
        // ITAE y: (0 + 0.5 + 1)·0.5·0.5 = 0.375.
        assert!(close(t.itae[1], 0.375, 1e-12));
        // Smoothness x: (|2 − 0| + |−2 − 2|) / (2 · 0.5) = 6; y: 0; z: 3 / 1 = 3.
        assert!(close(t.smoothness[0], 6.0, 1e-12));
        assert_eq!(t.smoothness[1], 0.0);
        assert!(close(t.smoothness[2], 3.0, 1e-12));
        // Variance x: mean 0, (0 + 4 + 4) / 3; y: 0; z: mean 1, (1 + 1 + 4) / 3 = 2.
        assert!(close(t.variance[0], 8.0 / 3.0, 1e-12));
        assert!(close(t.variance[1], 0.0, 1e-12));
        assert!(close(t.variance[2], 2.0, 1e-12));
        assert_eq!(Tracking::<3>::new(0.1).finish(), Table2::default());
    }

    /// Feeds `f` sampled every `dt` on `[0, t_end]` to a 0 → 1 step at t = 0.
    fn response(f: impl Fn(f64) -> f64, dt: f64, t_end: f64) -> StepMetrics {
        let mut s = StepResponse::new(0.0, 1.0, 0.0);
        let n = (t_end / dt) as usize;
        for k in 0..=n {
            let t = k as f64 * dt;
            s.push(t, f(t));
        }
        s.finish()
    }

    #[test]
    fn first_order_step_in_closed_form() {
        // y = 1 − exp(−t/τ): rise 10-90 % = τ ln 9, settling 2 % = τ ln 50, no overshoot.
        let tau = 0.7;
        let m = response(|t| 1.0 - libm::exp(-t / tau), 1e-3, 10.0);
        assert!(close(m.rise_time.unwrap(), tau * 9f64.ln(), 1e-5));
        assert!(close(m.settling_time.unwrap(), tau * 50f64.ln(), 1e-5));
        assert_eq!(m.overshoot_pct, 0.0);
        // The peak is at the end of the record for a monotone response.
        assert!(close(m.peak_time.unwrap(), 10.0, 1e-9));
    }

    #[test]
    fn second_order_step_in_closed_form() {
        // y = 1 − e^{−ζωt}(cos ω_d t + ζ/√(1−ζ²) sin ω_d t): peak at π/ω_d,
        // overshoot exp(−ζπ/√(1−ζ²)).
        let (zeta, w) = (0.3f64, 2.0f64);
        let wd = w * (1.0 - zeta * zeta).sqrt();
        let y = |t: f64| {
            1.0 - (-zeta * w * t).exp()
                * ((wd * t).cos() + zeta / (1.0 - zeta * zeta).sqrt() * (wd * t).sin())
        };
        let dt = 1e-3;
        let m = response(y, dt, 30.0);
        assert!(close(m.peak_time.unwrap(), core::f64::consts::PI / wd, dt));
        let os = 100.0 * (-zeta * core::f64::consts::PI / (1.0 - zeta * zeta).sqrt()).exp();
        assert!(
            close(m.overshoot_pct, os, 1e-3),
            "{} vs {os}",
            m.overshoot_pct
        );
        // Settling: the last time |y − 1| = 0.02, found by a fine scan of the exact response.
        let mut last = 0.0;
        let mut t = 0.0;
        while t < 30.0 {
            if (y(t) - 1.0).abs() > 0.02 {
                last = t;
            }
            t += 1e-5;
        }
        assert!(
            close(m.settling_time.unwrap(), last, 2e-5),
            "{:?} vs {last}",
            m.settling_time
        );
        // Rise: the exact crossings of 0.1 and 0.9, found by bisection.
        let cross = |level: f64| {
            let (mut a, mut b) = (0.0, core::f64::consts::PI / wd);
            for _ in 0..60 {
                let c = 0.5 * (a + b);
                if y(c) < level {
                    a = c
                } else {
                    b = c
                }
            }
            a
        };
        assert!(close(m.rise_time.unwrap(), cross(0.9) - cross(0.1), 1e-5));
    }

    #[test]
    fn step_metrics_edge_cases() {
        // Never reaches 90 %, never settles; a downward step is normalised the same way.
        let m = response(|t| 0.5 * t.min(1.0), 0.01, 2.0);
        assert_eq!(m.rise_time, None);
        assert_eq!(m.settling_time, None);
        let mut s = StepResponse::new(5.0, -2.0, 1.0);
        for k in 0..400 {
            let t = k as f64 * 0.01;
            s.push(
                t,
                if t < 1.0 {
                    5.0
                } else {
                    3.0 - 0.2 * libm::exp(-(t - 1.0))
                },
            );
        }
        let m = s.finish();
        // Jumps to 90 % at once (the sample at t = 1 is y = 2.8, r = 1.1): overshoot 10 %.
        assert!(close(m.overshoot_pct, 10.0, 1e-9));
        assert!(close(m.peak_time.unwrap(), 0.0, 1e-12));
        // |r − 1| = 0.1 e^{−τ} ≤ 0.02 from τ = ln 5.
        assert!(close(m.settling_time.unwrap(), 5f64.ln(), 1e-3));
    }

    #[test]
    fn gust_settling_by_hand() {
        // dt = 1, gust on [2, 8): the effect jumps to 0.5, decays to 0.05 by t = 5; after the end it
        // jumps to -0.3 at t = 8, 9 and is back within 0.1 m from t = 10. Calm error ±0.2 (above
        // the band: only the effect counts).
        let calm: [f64; 14] = core::array::from_fn(|k| if k % 2 == 0 { 0.2 } else { -0.2 });
        let effect = [
            0., 0., 0.5, 0.3, 0.15, 0.05, 0.08, -0.02, -0.3, -0.2, 0.09, 0.0, 0.0, 0.0,
        ];
        let gusty: [f64; 14] = core::array::from_fn(|k| calm[k] + effect[k]);
        let s = gust_settling(1.0, &gusty, &calm, 2.0, 8.0, 0.1);
        assert_eq!(s.settle_after_onset, Some(3.0));
        assert_eq!(s.settle_after_end, Some(2.0));
        assert!((s.max_effect - 0.5).abs() < 1e-12);
        // Never leaves the band: 0; still out at the end of the gust or the record: None.
        let s = gust_settling(1.0, &calm, &calm, 2.0, 8.0, 0.1);
        assert_eq!(
            (s.settle_after_onset, s.settle_after_end),
            (Some(0.0), Some(0.0))
        );
        let held: [f64; 14] = core::array::from_fn(|k| calm[k] + if k >= 2 { 1.0 } else { 0.0 });
        let s = gust_settling(1.0, &held, &calm, 2.0, 8.0, 0.1);
        assert_eq!((s.settle_after_onset, s.settle_after_end), (None, None));
        // A record that stops before the gust does: nothing after the end.
        let s = gust_settling(1.0, &gusty[..6], &calm[..6], 2.0, 8.0, 0.1);
        assert_eq!(
            (s.settle_after_onset, s.settle_after_end),
            (Some(3.0), None)
        );
        // RMS over a window: t in [2, 4) is cycles 2 and 3.
        let r = rms_over(1.0, &effect, 2.0, 4.0);
        assert!((r - ((0.25 + 0.09) / 2.0f64).sqrt()).abs() < 1e-12);
        assert_eq!(rms_over(1.0, &effect, 5.0, 5.0), 0.0);
    }

    #[test]
    fn gust_by_hand() {
        // dt = 1: calm error alternates ±0.1 (RMSE 0.1); gust from t = 2 to 6 adds 1.0 to the
        // error, then the effect decays as 0.5, 0.25, 0.05, 0.
        let calm: [f64; 20] = core::array::from_fn(|k| if k % 2 == 0 { 0.1 } else { -0.1 });
        let effect = [
            0., 0., 1., 1., 1., 1., 0.5, 0.25, 0.05, 0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0.,
        ];
        let gusty: [f64; 20] = core::array::from_fn(|k| calm[k] + effect[k]);
        let g = gust(1.0, &gusty, &calm, 2.0, 6.0);
        // During: from t = 5 (onset + 3 s) to 6: sample 5 only, error 0.9.
        assert!(close(g.rmse_y_during, 0.9, 1e-12), "{}", g.rmse_y_during);
        // The effect is 0.25 at t = 7 and 0.05 ≤ 0.1 from t = 8 on: recovery 2 s after the end.
        assert_eq!(g.recovery_time, Some(2.0));
        // After: samples 8..18: calm ± 0.1 plus 0.05 at t = 8.
        let after: f64 = (8..18).map(|k| gusty[k] * gusty[k]).sum::<f64>() / 10.0;
        assert!(close(g.rmse_y_after.unwrap(), after.sqrt(), 1e-12));
        // Still out at the end of the record: no recovery.
        let never: [f64; 20] = core::array::from_fn(|k| calm[k] + if k >= 2 { 1.0 } else { 0.0 });
        let g = gust(1.0, &never, &calm, 2.0, 6.0);
        assert_eq!((g.recovery_time, g.rmse_y_after), (None, None));
    }
}
