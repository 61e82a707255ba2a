//! The emitted scalar type as numbers: rounding, sizes and the nonzeros an unrolled product keeps. The
//! analyses (cost model, certificate, lowering's range checks) use this half; `emit::tokens::Num` writes
//! the literals.

use mpc_spec::Scalar;
use nalgebra::DMatrix;

/// The numbers of one emitted scalar type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Numeric(pub Scalar);

impl Numeric {
    /// `"f32"` or `"f64"`.
    pub fn name(self) -> &'static str {
        match self.0 {
            Scalar::F32 => "f32",
            Scalar::F64 => "f64",
        }
    }

    /// Bytes of one number.
    pub fn bytes(self) -> usize {
        match self.0 {
            Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// The largest finite magnitude, as f64.
    pub fn max(self) -> f64 {
        match self.0 {
            Scalar::F32 => f32::MAX as f64,
            Scalar::F64 => f64::MAX,
        }
    }

    /// The machine epsilon (the gap between 1 and the next number), as f64.
    pub fn epsilon(self) -> f64 {
        match self.0 {
            Scalar::F32 => f32::EPSILON as f64,
            Scalar::F64 => f64::EPSILON,
        }
    }

    /// `v` rounded to the emitted type.
    pub fn round(self, v: f64) -> f64 {
        match self.0 {
            Scalar::F32 => v as f32 as f64,
            Scalar::F64 => v,
        }
    }

    /// Entries of `M` that are not zero in the emitted type: the multiply-adds an unrolled product keeps.
    pub fn nonzeros(self, m: &DMatrix<f64>) -> usize {
        m.iter().filter(|v| self.round(**v) != 0.0).count()
    }

    /// Entries of `M` written as a coefficient in unrolled code: neither zero nor ±1 in the emitted type
    /// (±1 become plain additions and cost nothing).
    pub fn coefficients(self, m: &DMatrix<f64>) -> usize {
        m.iter()
            .filter(|v| self.round(**v) != 0.0 && self.round(v.abs()) != 1.0)
            .count()
    }
}
