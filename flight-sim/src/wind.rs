//! Wind beyond the paper's step gust: a constant mean wind plus Dryden-like coloured turbulence,
//! seeded, as an acceleration added to the plant's input (the same channel as the paper's gust).
//!
//! # The model
//!
//! The drone is the paper's double integrator, so the wind reaches it as an acceleration. A wind
//! velocity `w` (m/s) pushes a drone near hover with `a = k_d · w`, a linear drag with
//! coefficient `k_d` (1/s); the drone's own velocity's drag is left out, as the paper's model has
//! none. The default `k_d = 0.1 s⁻¹` makes a 6 m/s wind push with the paper's 0.6 m/s².
//!
//! The wind velocity per world axis is a mean plus turbulence. The turbulence follows the
//! low-altitude Dryden model of MIL-F-8785C (altitude `h` below 1000 ft, `h` in feet in the
//! formulas):
//!
//! - length scales `L_w = h`, `L_u = L_v = h / (0.177 + 0.000823 h)^1.2`;
//! - intensities `σ_w = 0.1 W20`, `σ_u = σ_v = σ_w / (0.177 + 0.000823 h)^0.4`, where `W20` is the
//!   wind speed at 20 ft; we take `W20` equal to the mean wind speed.
//!
//! A hovering drone sits in a turbulence field that the mean wind carries past it (Taylor's
//! frozen turbulence), so the spatial scale `L` becomes the time constant `τ = L / V` with `V` the
//! mean wind speed. Dryden's longitudinal spectrum is exactly that of a first-order filter,
//! `H_u(s) = σ_u √(2 L_u / (π V)) / (1 + (L_u / V) s)`; its lateral and vertical ones are second
//! order with a zero, and are approximated here by the same first-order form ("Dryden-like"):
//! per axis, white noise through `1 / (1 + τ s)`, scaled to the stationary standard deviation
//! `σ`. With `σ_u = σ_v` and `L_u = L_v` the horizontal turbulence is isotropic, so it is generated
//! along the world's x and y axes whatever the wind's direction; z is the vertical.
//!
//! Discretised exactly at the control period `dt`: `g_{k+1} = φ g_k + σ √(1 − φ²) n_k` with
//! `φ = exp(−dt/τ)` and `n_k` standard normal, started from the stationary distribution
//! (`g_0 = σ n`), so that `g` has standard deviation `σ` and autocorrelation `exp(−|Δt|/τ)` at
//! every cycle.
//!
//! [`Dryden::DEFAULT`] at the flight's altitude of 10 m and a 6 m/s mean wind: `L_u = L_v = 67.4 m`,
//! `L_w = 10 m`, `τ = 11.2 s` horizontally and `1.67 s` vertically, `σ_u = σ_v = 1.13 m/s` and
//! `σ_w = 0.6 m/s`, i.e. pushes of standard deviation 0.113 m/s² horizontally and 0.06 m/s²
//! vertically around a mean push of 0.6 m/s² blowing along (0.6, 0.8, 0) in (x, y, z).
//!
//! The draws come from their own ChaCha8 stream (stream 2 of the seed, the GPS and acceleration
//! noise being streams 0 and 1), drawn every cycle whether the wind blows or not: two
//! controllers flown with the same seed meet the same wind, and adding wind changes no other draw.

use libm::{exp, pow, sqrt};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

use crate::model::DT;

/// A time-varying acceleration added to the plant's input, one call per control cycle in order
/// (see [`fly_with`](crate::fly_with)).
pub trait DisturbanceModel {
    /// The added acceleration per axis over the cycle that starts at time `t`, m/s². Called
    /// exactly once per cycle, with increasing `t`.
    fn accel(&mut self, t: f64) -> [f64; 3];
}

impl<D: DisturbanceModel + ?Sized> DisturbanceModel for &mut D {
    fn accel(&mut self, t: f64) -> [f64; 3] {
        (**self).accel(t)
    }
}

impl DisturbanceModel for crate::Disturbance {
    fn accel(&mut self, t: f64) -> [f64; 3] {
        self.at(t)
    }
}

/// A wind as the plant feels it: a mean push plus first-order coloured turbulence per axis,
/// blowing on `[start, end)`. Build one from physical parameters with [`Dryden::config`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindConfig {
    /// Mean push per axis while the wind blows, m/s².
    pub mean: [f64; 3],
    /// Stationary standard deviation of the turbulent push per axis, m/s².
    pub sigma: [f64; 3],
    /// Correlation time constant of the turbulence per axis, s (> 0).
    pub tau: [f64; 3],
    /// Onset, s.
    pub start: f64,
    /// End (exclusive), s.
    pub end: f64,
}

impl WindConfig {
    /// No wind.
    pub const NONE: Self = Self {
        mean: [0.0; 3],
        sigma: [0.0; 3],
        tau: [1.0; 3],
        start: 0.0,
        end: 0.0,
    };

    /// Whether the wind blows at time `t`.
    pub fn blows(&self, t: f64) -> bool {
        t >= self.start && t < self.end
    }
}

/// Physical parameters of the wind scenario; [`Dryden::config`] turns them into a [`WindConfig`]
/// with the low-altitude Dryden formulas of MIL-F-8785C (see the [module](self) documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dryden {
    /// Mean wind speed at the flight altitude, m/s; also taken as `W20`, the wind speed at 20 ft
    /// that sets the turbulence intensity, and as the speed that carries the turbulence past the
    /// hovering drone.
    pub speed: f64,
    /// Horizontal direction the wind blows towards, `(x, y)`; normalised by [`Dryden::config`].
    pub direction: [f64; 2],
    /// Flight altitude, m (the formulas hold from 10 ft to 1000 ft and are clamped there).
    pub altitude: f64,
    /// Linear drag coefficient from wind velocity to acceleration, 1/s.
    pub drag: f64,
    /// Onset, s.
    pub start: f64,
    /// End (exclusive), s.
    pub end: f64,
}

/// Feet per metre.
const FT: f64 = 1.0 / 0.3048;

impl Dryden {
    /// The simulation's wind scenario: 6 m/s towards (0.6, 0.8, 0) at 10 m, drag 0.1 s⁻¹ (a mean
    /// push of 0.6 m/s², the paper's gust), blowing from t = 20 s to 80 s.
    pub const DEFAULT: Self = Self {
        speed: 6.0,
        direction: [0.6, 0.8],
        altitude: 10.0,
        drag: 0.1,
        start: 20.0,
        end: 80.0,
    };

    /// The altitude in feet, clamped to the model's range [10, 1000] ft.
    fn h_ft(&self) -> f64 {
        (self.altitude * FT).clamp(10.0, 1000.0)
    }

    /// Turbulence length scales `[L_u, L_v, L_w]`, m.
    pub fn length_scales(&self) -> [f64; 3] {
        let h = self.h_ft();
        let l_u = h / pow(0.177 + 0.000823 * h, 1.2);
        [l_u / FT, l_u / FT, h / FT]
    }

    /// Turbulence intensities `[σ_u, σ_v, σ_w]`, m/s.
    pub fn intensities(&self) -> [f64; 3] {
        let h = self.h_ft();
        let sigma_w = 0.1 * self.speed.abs();
        let sigma_u = sigma_w / pow(0.177 + 0.000823 * h, 0.4);
        [sigma_u, sigma_u, sigma_w]
    }

    /// Correlation time constants `L / V` per axis, s (1 s when the wind is calm: there is then no
    /// turbulence to correlate).
    pub fn time_constants(&self) -> [f64; 3] {
        let l = self.length_scales();
        let v = self.speed.abs();
        if v > 0.0 {
            [l[0] / v, l[1] / v, l[2] / v]
        } else {
            [1.0; 3]
        }
    }

    /// The push the plant feels: mean `drag · speed` along the direction, turbulence of standard
    /// deviation `drag · σ` per axis with time constants `L / V`.
    pub fn config(&self) -> WindConfig {
        let [dx, dy] = self.direction;
        let norm = sqrt(dx * dx + dy * dy);
        let (ux, uy) = if norm > 0.0 {
            (dx / norm, dy / norm)
        } else {
            (0.0, 0.0)
        };
        let mean = self.drag * self.speed;
        let s = self.intensities();
        WindConfig {
            mean: [mean * ux, mean * uy, 0.0],
            sigma: [self.drag * s[0], self.drag * s[1], self.drag * s[2]],
            tau: self.time_constants(),
            start: self.start,
            end: self.end,
        }
    }
}

impl Default for Dryden {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The wind of a [`WindConfig`] from a seed: a [`DisturbanceModel`] for
/// [`fly_with`](crate::fly_with). The turbulence evolves every cycle; it is added, with the mean,
/// only while the wind blows.
#[derive(Clone, Debug)]
pub struct Wind {
    config: WindConfig,
    rng: ChaCha8Rng,
    phi: [f64; 3],
    gain: [f64; 3],
    turbulence: [f64; 3],
}

impl Wind {
    /// The wind of `config` from `seed`, stepped at the paper's period [`DT`].
    pub fn new(seed: u64, config: WindConfig) -> Self {
        Self::with_dt(seed, config, DT)
    }

    /// The wind of `config` from `seed`, stepped every `dt` seconds.
    pub fn with_dt(seed: u64, config: WindConfig, dt: f64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(2);
        let mut phi = [0.0; 3];
        let mut gain = [0.0; 3];
        let mut turbulence = [0.0; 3];
        for i in 0..3 {
            let tau = config.tau[i];
            phi[i] = if tau > 0.0 { exp(-dt / tau) } else { 0.0 };
            gain[i] = config.sigma[i] * sqrt(1.0 - phi[i] * phi[i]);
            let n: f64 = StandardNormal.sample(&mut rng);
            turbulence[i] = config.sigma[i] * n;
        }
        Self {
            config,
            rng,
            phi,
            gain,
            turbulence,
        }
    }

    /// The configuration.
    pub const fn config(&self) -> &WindConfig {
        &self.config
    }

    /// The turbulent part of the push at the current cycle, m/s² (whether the wind blows or not).
    pub const fn turbulence(&self) -> [f64; 3] {
        self.turbulence
    }
}

impl DisturbanceModel for Wind {
    fn accel(&mut self, t: f64) -> [f64; 3] {
        let blows = self.config.blows(t);
        let mut out = [0.0; 3];
        for i in 0..3 {
            if blows {
                out[i] = self.config.mean[i] + self.turbulence[i];
            }
            let n: f64 = StandardNormal.sample(&mut self.rng);
            self.turbulence[i] = self.phi[i] * self.turbulence[i] + self.gain[i] * n;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dryden_parameters_by_hand() {
        // h = 10 m = 32.808 ft: 0.177 + 0.000823 h = 0.204001; ^1.2 = 0.148443, ^0.4 = 0.529493; L_u = 221.02 ft.
        let d = Dryden::DEFAULT;
        let l = d.length_scales();
        assert!((l[0] - 67.366).abs() < 0.001 && l[0] == l[1], "{l:?}");
        assert!((l[2] - 10.0).abs() < 1e-9);
        let s = d.intensities();
        assert!((s[2] - 0.6).abs() < 1e-12);
        assert!(
            (s[0] - 0.6 / 0.529_49).abs() < 1e-4 && s[0] == s[1],
            "{s:?}"
        );
        let tau = d.time_constants();
        assert!((tau[0] - l[0] / 6.0).abs() < 1e-12 && (tau[2] - 10.0 / 6.0).abs() < 1e-12);
        let c = d.config();
        assert!((c.mean[0] - 0.36).abs() < 1e-12 && (c.mean[1] - 0.48).abs() < 1e-12);
        assert_eq!(c.mean[2], 0.0);
        assert!((c.sigma[0] - 0.1 * s[0]).abs() < 1e-15 && (c.sigma[2] - 0.06).abs() < 1e-12);
        // Calm: no push, no division by zero.
        let calm = Dryden {
            speed: 0.0,
            ..Dryden::DEFAULT
        }
        .config();
        assert_eq!((calm.mean, calm.sigma), ([0.0; 3], [0.0; 3]));
        assert!(calm.tau.iter().all(|t| t.is_finite() && *t > 0.0));
    }

    #[test]
    fn the_wind_blows_only_in_its_window_and_is_seeded() {
        let c = Dryden::DEFAULT.config();
        let mut a = Wind::new(3, c);
        let mut b = Wind::new(3, c);
        let mut other = Wind::new(4, c);
        let mut differ = false;
        for k in 0..10_000 {
            let t = k as f64 * DT;
            let (x, y, z) = (a.accel(t), b.accel(t), other.accel(t));
            assert_eq!(x, y);
            if c.blows(t) {
                differ |= x != z;
            } else {
                assert_eq!(x, [0.0; 3], "t = {t}");
            }
        }
        assert!(differ);
    }

    /// Mean, standard deviation and lag-`lag` autocorrelation of axis `i` of the turbulence over
    /// `cycles` cycles (streaming, with a ring buffer for the lag).
    fn statistics(w: &mut Wind, i: usize, cycles: usize, lag: usize) -> (f64, f64, f64) {
        let mut ring = [0.0; 4096];
        assert!(lag < ring.len());
        let (mut sum, mut sum_sq, mut sum_lag, mut pairs) = (0.0, 0.0, 0.0, 0.0);
        for k in 0..cycles {
            let x = w.turbulence()[i];
            let _ = w.accel(0.0);
            sum += x;
            sum_sq += x * x;
            if k >= lag {
                sum_lag += x * ring[(k - lag) % ring.len()];
                pairs += 1.0;
            }
            ring[k % ring.len()] = x;
        }
        let n = cycles as f64;
        let mean = sum / n;
        let var = sum_sq / n - mean * mean;
        let cov = sum_lag / pairs - mean * mean;
        (mean, sqrt(var), cov / var)
    }

    #[test]
    fn the_turbulence_has_the_stated_intensity_and_correlation_time() {
        extern crate std;
        // A record of many time constants: about 1/√(T/2τ) relative error on σ.
        let c = Dryden::DEFAULT.config();
        for (i, cycles) in [(0, 2_000_000), (2, 400_000)] {
            let mut w = Wind::new(5, c);
            let tau_cycles = (c.tau[i] / DT) as usize;
            let (mean, sigma, rho) = statistics(&mut w, i, cycles, tau_cycles);
            assert!(
                (sigma / c.sigma[i] - 1.0).abs() < 0.05,
                "axis {i}: σ {sigma} vs {}",
                c.sigma[i]
            );
            assert!(mean.abs() < 0.1 * c.sigma[i], "axis {i}: mean {mean}");
            std::println!(
                "axis {i}: σ {sigma:.5} (stated {:.5}), mean {mean:.2e}, ρ(τ) {rho:.4}",
                c.sigma[i]
            );
            // Autocorrelation at lag τ: e⁻¹.
            assert!(
                (rho - (-1.0f64).exp()).abs() < 0.05,
                "axis {i}: ρ(τ) = {rho}"
            );
        }
    }
}
