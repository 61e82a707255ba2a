//! Scalar conversion between the `f64` simulation and a controller's own scalar.

/// A controller scalar (`f32` or `f64`, as the generated module's `Real`).
pub trait Real: Copy + Default {
    /// Converts from the simulation's `f64` (rounding for `f32`).
    fn from_f64(x: f64) -> Self;
    /// Converts to `f64` (exact).
    fn to_f64(self) -> f64;
}

impl Real for f32 {
    #[inline]
    fn from_f64(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self as f64
    }
}

impl Real for f64 {
    #[inline]
    fn from_f64(x: f64) -> Self {
        x
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
}

/// Converts an array element by element between two [`Real`] scalars.
#[inline]
pub fn cast<A: Real, B: Real, const K: usize>(x: &[A; K]) -> [B; K] {
    let mut out = [B::default(); K];
    for (o, v) in out.iter_mut().zip(x) {
        *o = B::from_f64(v.to_f64());
    }
    out
}
