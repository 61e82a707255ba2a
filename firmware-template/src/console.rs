//! Text output shared by every board: a board supplies `byte`, this adds strings and integers.

/// A polled byte output (each board's serial port).
pub trait Console {
    /// Sends one byte, waiting while the transmitter is busy.
    fn byte(&mut self, b: u8);

    /// Sends a string, `\n` as `\r\n`.
    fn str(&mut self, s: &str) -> &mut Self
    where
        Self: Sized,
    {
        for b in s.bytes() {
            if b == b'\n' {
                self.byte(b'\r');
            }
            self.byte(b);
        }
        self
    }

    /// Sends `v` in decimal.
    fn u64(&mut self, v: u64) -> &mut Self
    where
        Self: Sized,
    {
        let mut digits = [0u8; 20];
        self.str(crate::decimal::u64(v, &mut digits))
    }
}
