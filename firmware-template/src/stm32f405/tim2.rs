//! TIM2, the STM32F405's 32-bit general-purpose timer (0x4000_0000), free-running at prescaler 0.
//!
//! Why TIM2: under QEMU with `-icount shift=0` it advances exactly one tick per guest instruction
//! (the firmware's calibration loop checks it), while SysTick counts at a fixed 168 MHz with only
//! 24 bits, and the DWT cycle counter reads 0. On hardware TIM2 runs at the APB1 timer clock:
//! the CPU clock out of reset (16 MHz HSI), 84 MHz once the CPU runs at 168 MHz from the PLL with
//! the usual APB1 prescaler of 4.

use core::ptr::{read_volatile, write_volatile};

use super::rcc;

const BASE: usize = 0x4000_0000;
const CR1: usize = 0x00; // control 1: CEN is bit 0
const EGR: usize = 0x14; // event generation: UG is bit 0
const CNT: usize = 0x24; // counter
const PSC: usize = 0x28; // prescaler
const ARR: usize = 0x2C; // auto-reload

/// A reading of the counter.
pub type Instant = u32;

/// The running TIM2. Only one should exist.
pub struct Tim2(());

impl Tim2 {
    /// Clocks TIM2 and starts it counting up from 0 at prescaler 0, wrapping at 2^32.
    pub fn start() -> Self {
        // SAFETY: TIM2's registers and clock enable on every STM32F405; nothing else uses them,
        // and the timer raises no interrupt (DIER stays 0).
        unsafe {
            rcc::enable(rcc::APB1ENR, 1 << 0);
            write_volatile((BASE + PSC) as *mut u32, 0);
            write_volatile((BASE + ARR) as *mut u32, u32::MAX);
            // The prescaler is buffered: an update event loads it and clears the counter.
            write_volatile((BASE + EGR) as *mut u32, 1);
            write_volatile((BASE + CR1) as *mut u32, 1);
        }
        Tim2(())
    }

    /// The current count.
    #[inline(always)]
    pub fn now(&self) -> Instant {
        // SAFETY: reading the counter has no side effect.
        unsafe { read_volatile((BASE + CNT) as *const u32) }
    }

    /// Ticks since `t0`, correct across one wrap of the counter (2^32 ticks).
    #[inline(always)]
    pub fn since(&self, t0: Instant) -> u64 {
        u64::from(self.now().wrapping_sub(t0))
    }
}
