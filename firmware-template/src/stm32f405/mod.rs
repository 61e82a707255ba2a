//! Board: STM32F405 (Cortex-M4F, single-precision FPU), QEMU machine `netduinoplus2`; target
//! `thumbv7em-none-eabihf`. Startup from `cortex-m-rt` (`rt`), USART1 for text and TIM2 for
//! timing; memory layout in `boards/stm32f405/memory.x`.
//!
//! The clocks are left as reset leaves them (16 MHz HSI, no prescalers): on hardware the timer
//! then counts CPU cycles. Switching to the 168 MHz PLL is the user's board setup, and changes
//! USART1's baud divisor and TIM2's tick (APB1 timer clock, 84 MHz with the usual prescalers).

mod rt;
mod semihosting;
mod tim2;
mod usart;

pub use rt::{stack_bounds, STACK_PAINT};
pub use semihosting::exit;
pub use tim2::Tim2 as Timer;
pub use usart::Usart1 as Serial;

/// The board name in RESULT.
pub const NAME: &str = "stm32f405";
/// The processor, for the banner.
pub const CPU: &str = "Cortex-M4F, single-precision FPU";
/// What a tick counts, for the summary.
pub const TIMER: &str = "TIM2 ticks";

/// Reset and clock control: peripheral clock enables.
pub(crate) mod rcc {
    use core::ptr::{read_volatile, write_volatile};

    const BASE: usize = 0x4002_3800;
    /// AHB1 peripheral clock enable: GPIOA is bit 0.
    pub const AHB1ENR: usize = BASE + 0x30;
    /// APB1 peripheral clock enable: TIM2 is bit 0.
    pub const APB1ENR: usize = BASE + 0x40;
    /// APB2 peripheral clock enable: USART1 is bit 4.
    pub const APB2ENR: usize = BASE + 0x44;

    /// Sets `bits` in the enable register at `reg`, then reads it back: the peripheral may not be
    /// touched until its clock runs (errata sheet ES0182, "Delay after an RCC peripheral clock enabling").
    ///
    /// # Safety
    /// `reg` must be one of the enable registers above; enabling a peripheral clock has no other effect.
    pub unsafe fn enable(reg: usize, bits: u32) {
        write_volatile(reg as *mut u32, read_volatile(reg as *const u32) | bits);
        let _ = read_volatile(reg as *const u32);
    }
}
