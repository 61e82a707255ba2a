//! Integer to decimal text without `core::fmt`: `fmt` brings in core's panicking paths, and the
//! firmware must link none (the test checks the ELF's symbols).

/// Writes `v` in decimal into the end of `buf` and returns the digits.
pub fn u64(mut v: u64, buf: &mut [u8; 20]) -> &str {
    let mut start = buf.len();
    for slot in buf.iter_mut().rev() {
        *slot = b'0' + (v % 10) as u8;
        v /= 10;
        start -= 1;
        if v == 0 {
            break;
        }
    }
    // u64::MAX has 20 digits, so the loop always ends on `v == 0`; the digits are ASCII.
    match buf.get(start..).map(core::str::from_utf8) {
        Some(Ok(s)) => s,
        _ => "?",
    }
}
