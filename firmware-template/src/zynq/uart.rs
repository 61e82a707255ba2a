//! Text output on the Zynq's UART0 (Cadence UART at 0xE000_0000), polled, 115200 8N1.
//!
//! After reset the transmitter is disabled, and QEMU silently drops what is written to a disabled
//! transmitter, so [`Uart0::new`] configures and enables it first.

use core::ptr::{read_volatile, write_volatile};

use crate::console::Console;

const BASE: usize = 0xE000_0000;
const CR: usize = 0x00; // control
const MR: usize = 0x04; // mode
const BAUDGEN: usize = 0x18; // baud rate generator: CD
const SR: usize = 0x2C; // channel status
const FIFO: usize = 0x30; // TX/RX FIFO
const BAUDDIV: usize = 0x34; // baud rate divider: BDIV

const CR_RXRST: u32 = 1 << 0;
const CR_TXRST: u32 = 1 << 1;
const CR_RXEN: u32 = 1 << 2;
const CR_TXEN: u32 = 1 << 4;
const CR_STOPBRK: u32 = 1 << 8;
/// 8 data bits, no parity (PAR = 0b1xx), 1 stop bit, normal mode, UART_REF_CLK.
const MR_8N1: u32 = 0b100 << 3;
const SR_TXFULL: u32 = 1 << 4;
/// 100 MHz UART_REF_CLK / (CD * (BDIV + 1)) = 100e6 / (124 * 7) = 115207 baud (Zynq TRM table 19-1).
const CD_115200: u32 = 124;
const BDIV_115200: u32 = 6;

/// The UART0 transmitter, configured and enabled. Only one should exist.
pub struct Uart0(());

impl Uart0 {
    /// Resets and configures UART0 for 115200 8N1 and enables it.
    pub fn new() -> Self {
        // SAFETY: UART0's registers are at BASE on every Zynq-7000; nothing else uses them.
        unsafe {
            write(CR, CR_TXRST | CR_RXRST);
            write(MR, MR_8N1);
            write(BAUDGEN, CD_115200);
            write(BAUDDIV, BDIV_115200);
            write(CR, CR_TXEN | CR_RXEN | CR_STOPBRK);
        }
        Uart0(())
    }
}

impl Console for Uart0 {
    /// Waits while the TX FIFO is full.
    fn byte(&mut self, b: u8) {
        // SAFETY: as in `new`; `&mut self` serialises access to the FIFO.
        unsafe {
            while read(SR) & SR_TXFULL != 0 {}
            write(FIFO, u32::from(b));
        }
    }
}

/// # Safety
/// `offset` must be a register of UART0 that may be read with no side effect the caller does not want.
unsafe fn read(offset: usize) -> u32 {
    read_volatile((BASE + offset) as *const u32)
}

/// # Safety
/// `offset` must be a register of UART0, and writing `value` to it must keep the UART usable.
unsafe fn write(offset: usize, value: u32) {
    write_volatile((BASE + offset) as *mut u32, value)
}
