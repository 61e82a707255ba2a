//! Text output on USART1 (0x4001_1000, TX on PA9), polled, 115200 8N1 from the 16 MHz reset
//! clock. QEMU's netduinoplus2 connects it to its first serial port (stdout with `-nographic`).

use core::ptr::{read_volatile, write_volatile};

use super::rcc;
use crate::console::Console;

const BASE: usize = 0x4001_1000;
const SR: usize = 0x00; // status
const DR: usize = 0x04; // data
const BRR: usize = 0x08; // baud rate
const CR1: usize = 0x0C; // control 1

const SR_TXE: u32 = 1 << 7;
const CR1_TE: u32 = 1 << 3;
const CR1_UE: u32 = 1 << 13;
/// 16 MHz / (16 × 8.6875) = 115108 baud: mantissa 8, fraction 11/16 (RM0090 30.3.4).
const BRR_115200_AT_16MHZ: u32 = (8 << 4) | 11;

const GPIOA: usize = 0x4002_0000;
const GPIO_MODER: usize = 0x00;
const GPIO_AFRH: usize = 0x24;
/// PA9 is USART1_TX as alternate function 7.
const PA9_AF: u32 = 7;

/// The USART1 transmitter, configured and enabled. Only one should exist.
pub struct Usart1(());

impl Usart1 {
    /// Clocks GPIOA and USART1, routes PA9 to USART1_TX, and enables the transmitter, 8N1.
    pub fn new() -> Self {
        // SAFETY: these registers belong to GPIOA, USART1 and their clock enables on every
        // STM32F405; nothing else in this firmware uses them.
        unsafe {
            rcc::enable(rcc::AHB1ENR, 1 << 0);
            rcc::enable(rcc::APB2ENR, 1 << 4);
            modify(GPIOA + GPIO_MODER, 0b11 << 18, 0b10 << 18); // PA9: alternate function
            modify(GPIOA + GPIO_AFRH, 0xf << 4, PA9_AF << 4);
            write_volatile((BASE + BRR) as *mut u32, BRR_115200_AT_16MHZ);
            write_volatile((BASE + CR1) as *mut u32, CR1_UE | CR1_TE);
        }
        Usart1(())
    }
}

impl Console for Usart1 {
    /// Waits until the data register is empty.
    fn byte(&mut self, b: u8) {
        // SAFETY: as in `new`; `&mut self` serialises access to the data register.
        unsafe {
            while read_volatile((BASE + SR) as *const u32) & SR_TXE == 0 {}
            write_volatile((BASE + DR) as *mut u32, u32::from(b));
        }
    }
}

/// Replaces the bits of `mask` in the register at `addr` by `value`.
///
/// # Safety
/// `addr` must be a peripheral register whose read has no side effect, and the new value must
/// keep that peripheral usable.
unsafe fn modify(addr: usize, mask: u32, value: u32) {
    let old = read_volatile(addr as *const u32);
    write_volatile(addr as *mut u32, (old & !mask) | value);
}
