//! What the build holds, for every mode's `RESULT`: a hash of the baked spec's text and the
//! controller's scalar.

use crate::console::Console;
use crate::{ctrl, SPEC_TEXT};

/// FNV-1a (64-bit) of the baked spec's text, so a test can check which spec a binary holds.
pub const SPEC_FNV1A64: u64 = fnv1a64(SPEC_TEXT.as_bytes());

/// FNV-1a (64-bit) of `bytes`.
pub const fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut i = 0;
    while i < bytes.len() {
        h = fnv1a64_byte(h, bytes[i]);
        i += 1;
    }
    h
}

/// One byte into an FNV-1a (64-bit) hash `h` (start from `fnv1a64(&[])`).
pub const fn fnv1a64_byte(h: u64, b: u8) -> u64 {
    (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
}

/// The controller's scalar type, by size.
pub const SCALAR: &str = if core::mem::size_of::<ctrl::Real>() == 4 {
    "f32"
} else {
    "f64"
};

/// `v` as `digits` lowercase hex digits (the low ones).
pub fn hex(out: &mut impl Console, v: u64, digits: u32) {
    for shift in (0..digits).rev() {
        let d = ((v >> (4 * shift)) & 0xf) as u8;
        out.byte(if d < 10 { b'0' + d } else { b'a' + d - 10 });
    }
}
