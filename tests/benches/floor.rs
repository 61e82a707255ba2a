//! The floor: the time a solve would take if every multiply-add of the per-axis dense form ran at this
//! machine's peak fused multiply-add rate. Peak rates come from a microbenchmark: independent FMA chains
//! (more than the FMA units' latency × throughput, so the units never wait), 8-wide f32 and 4-wide f64
//! AVX2 where the CPU has AVX2 and FMA, one scalar multiply-add per chain elsewhere.

use std::hint::black_box;
use std::time::Instant;

/// Independent accumulators per kernel: two FMA pipes × latency 4 (Zen 3; Intel since Skylake alike)
/// need 8 to stay busy; 12 leaves margin and still fits the 16 vector registers.
const CHAINS: usize = 12;

/// Multiply-adds of one solve in the per-axis dense form: the three axes do not couple, so each
/// iteration's gradient H·y is nu products of an N×N block with an N-vector (nu·N² multiply-adds;
/// 90·N² for the paper's nu = 3 and 30 iterations). The linear term, the projection and the momentum
/// step, O(N) per iteration, are left out.
pub fn multiply_adds_per_solve(n: usize, nu: usize, iterations: usize) -> usize {
    nu * n * n * iterations
}

/// Peak multiply-add rates of this machine, per second.
#[derive(Clone, Copy, Debug)]
pub struct Peak {
    /// f32 multiply-adds per second.
    pub f32_per_s: f64,
    /// f64 multiply-adds per second.
    pub f64_per_s: f64,
    /// What ran: "avx2+fma" or "scalar".
    pub kernel: &'static str,
}

/// Measures the peak rates: each kernel run for about `millis` ms, best of five runs (the other core
/// may be busy; the best run is the one least disturbed).
pub fn measure(millis: f64) -> Peak {
    let kernel = if simd_available() {
        "avx2+fma"
    } else {
        "scalar"
    };
    Peak {
        f32_per_s: best_rate(millis, kernel_f32),
        f64_per_s: best_rate(millis, kernel_f64),
        kernel,
    }
}

/// The best rate of `kernel(rounds) -> multiply-adds done` over five runs of about `millis` ms.
fn best_rate(millis: f64, kernel: impl Fn(u64) -> u64) -> f64 {
    // Calibrate the round count on a short run.
    let t = Instant::now();
    let done = kernel(black_box(10_000));
    let rate = done as f64 / t.elapsed().as_secs_f64();
    let madds_per_round = done as f64 / 10_000.0;
    let rounds = ((rate * millis * 1e-3) / madds_per_round).max(1.0) as u64;
    (0..5)
        .map(|_| {
            let t = Instant::now();
            let done = kernel(black_box(rounds));
            done as f64 / t.elapsed().as_secs_f64()
        })
        .fold(0.0, f64::max)
}

fn simd_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `rounds` rounds of CHAINS independent f32 multiply-adds (8-wide under AVX2); the multiply-adds done.
fn kernel_f32(rounds: u64) -> u64 {
    #[cfg(target_arch = "x86_64")]
    if simd_available() {
        // SAFETY: the CPU has AVX2 and FMA (checked just above).
        black_box(unsafe { x86::fma_f32(rounds) });
        return rounds * CHAINS as u64 * 8;
    }
    black_box(scalar_f32(rounds));
    rounds * CHAINS as u64
}

/// `rounds` rounds of CHAINS independent f64 multiply-adds (4-wide under AVX2); the multiply-adds done.
fn kernel_f64(rounds: u64) -> u64 {
    #[cfg(target_arch = "x86_64")]
    if simd_available() {
        // SAFETY: the CPU has AVX2 and FMA (checked just above).
        black_box(unsafe { x86::fma_f64(rounds) });
        return rounds * CHAINS as u64 * 4;
    }
    black_box(scalar_f64(rounds));
    rounds * CHAINS as u64
}

// Each chain iterates acc ← acc·a + b, which converges to b / (1 − a): no overflow, no denormals, and
// the compiler may not merge or skip the steps (no fast-math).
fn scalar_f32(rounds: u64) -> f32 {
    let (a, b) = (black_box(0.999_9_f32), black_box(1e-4_f32));
    let mut acc = [1.0_f32; CHAINS];
    for _ in 0..rounds {
        for x in acc.iter_mut() {
            *x = *x * a + b;
        }
    }
    acc.iter().sum()
}

fn scalar_f64(rounds: u64) -> f64 {
    let (a, b) = (black_box(0.999_9_f64), black_box(1e-4_f64));
    let mut acc = [1.0_f64; CHAINS];
    for _ in 0..rounds {
        for x in acc.iter_mut() {
            *x = *x * a + b;
        }
    }
    acc.iter().sum()
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::CHAINS;
    use std::arch::x86_64::*;

    /// CHAINS 8-wide f32 FMA chains, `rounds` steps each; a lane of their sum (to keep them live).
    ///
    /// # Safety
    /// The CPU must have AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn fma_f32(rounds: u64) -> f32 {
        let a = _mm256_set1_ps(std::hint::black_box(0.999_9));
        let b = _mm256_set1_ps(std::hint::black_box(1e-4));
        let mut acc = [_mm256_set1_ps(1.0); CHAINS];
        for _ in 0..rounds {
            for x in acc.iter_mut() {
                *x = _mm256_fmadd_ps(*x, a, b);
            }
        }
        let sum = acc
            .iter()
            .fold(_mm256_setzero_ps(), |s, x| _mm256_add_ps(s, *x));
        _mm256_cvtss_f32(sum)
    }

    /// CHAINS 4-wide f64 FMA chains, `rounds` steps each; a lane of their sum.
    ///
    /// # Safety
    /// The CPU must have AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn fma_f64(rounds: u64) -> f64 {
        let a = _mm256_set1_pd(std::hint::black_box(0.999_9));
        let b = _mm256_set1_pd(std::hint::black_box(1e-4));
        let mut acc = [_mm256_set1_pd(1.0); CHAINS];
        for _ in 0..rounds {
            for x in acc.iter_mut() {
                *x = _mm256_fmadd_pd(*x, a, b);
            }
        }
        let sum = acc
            .iter()
            .fold(_mm256_setzero_pd(), |s, x| _mm256_add_pd(s, *x));
        _mm256_cvtsd_f64(sum)
    }
}
