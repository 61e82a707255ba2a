//! The Cortex-A9 global timer: a 64-bit up-counter shared by both cores, clocked at PERIPHCLK
//! (half the CPU clock on the Zynq, e.g. 333.3 MHz at 667 MHz) divided by (prescaler + 1).
//!
//! Under QEMU with `-icount shift=0` it advances one tick per 10 guest instructions (checked by
//! the firmware's calibration loop and by the test).

use core::ptr::{read_volatile, write_volatile};

/// Private peripherals of the MPCore (the CBAR value on the Zynq-7000) + the global timer's offset.
const BASE: usize = 0xF8F0_0000 + 0x200;
const COUNTER_LO: usize = 0x00;
const COUNTER_HI: usize = 0x04;
const CONTROL: usize = 0x08;
/// Timer enable, prescaler 0, no compare, no interrupt.
const CONTROL_ENABLE: u32 = 1;

/// A reading of the timer.
pub type Instant = u64;

/// The running global timer. Only one should exist.
pub struct GlobalTimer(());

impl GlobalTimer {
    /// Starts the timer (prescaler 0), keeping its count.
    pub fn start() -> Self {
        // SAFETY: the global timer's registers are at BASE on every Zynq-7000; only this firmware
        // uses them, and enabling it has no other effect.
        unsafe { write_volatile((BASE + CONTROL) as *mut u32, CONTROL_ENABLE) };
        GlobalTimer(())
    }

    /// The current count. The two halves are read separately, so the high word is read again
    /// to catch a carry between the reads (Cortex-A9 MPCore TRM, 4.4.1).
    #[inline(always)]
    pub fn now(&self) -> u64 {
        loop {
            // SAFETY: reading the counter registers has no side effect.
            let (hi, lo, hi2) = unsafe {
                (
                    read_volatile((BASE + COUNTER_HI) as *const u32),
                    read_volatile((BASE + COUNTER_LO) as *const u32),
                    read_volatile((BASE + COUNTER_HI) as *const u32),
                )
            };
            if hi == hi2 {
                return (u64::from(hi) << 32) | u64::from(lo);
            }
        }
    }

    /// Ticks since `t0` (the 64-bit counter does not wrap in practice).
    #[inline(always)]
    pub fn since(&self, t0: Instant) -> u64 {
        self.now().wrapping_sub(t0)
    }
}
