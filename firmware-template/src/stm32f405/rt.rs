//! Startup of the Cortex-M4F, from `cortex-m-rt`: vector table, reset handler (FPU enabled
//! through CPACR, .bss zeroed, .data copied, the stack painted with its `paint-stack` feature),
//! then `main`. This file only adds the exception handlers and reads the painted stack.
//!
//! Developer notes
//! - Every exception is a failure for this firmware (it polls, it takes no interrupts): each
//!   handler exits through semihosting with its own status, so a test sees which one fired.
//!   MemManage, BusFault and UsageFault are not enabled, so they escalate to HardFault.
//! - `main` is the shared `extern "C" fn main() -> !` of `main.rs`, which `Reset` calls (this is
//!   what `#[entry]` would generate, minus its `static mut` rewriting, which is not needed).

use cortex_m_rt::{exception, ExceptionFrame, STACK_PAINT_VALUE};

use super::semihosting;

/// Exit statuses of the exception handlers.
pub mod status {
    /// HardFault (and every fault escalated to it).
    pub const HARD_FAULT: u32 = 16;
    /// Any other exception or interrupt (none is enabled).
    pub const OTHER: u32 = 17;
}

#[exception]
unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
    semihosting::exit(status::HARD_FAULT)
}

#[exception]
unsafe fn DefaultHandler(_irqn: i16) -> ! {
    semihosting::exit(status::OTHER)
}

extern "C" {
    // Set by cortex-m-rt's link.x: the stack grows down from `_stack_start` (the end of RAM) to
    // `_stack_end` (the end of .bss/.uninit); the reset handler paints everything in between.
    static _stack_start: u32;
    static _stack_end: u32;
}

/// Bytes of the main stack used so far at most: the painted words that were overwritten.
/// (A word that happens to be written with the paint value itself is counted as unused.)
pub fn stack_high_water() -> usize {
    // SAFETY: cortex-m-rt's link script places [_stack_end, _stack_start) in RAM as the stack,
    // painted at reset; reading its words, above or below the stack pointer, has no side effect.
    unsafe {
        let bottom = core::ptr::addr_of!(_stack_end);
        let top = core::ptr::addr_of!(_stack_start);
        let mut p = bottom;
        while p < top && core::ptr::read_volatile(p) == STACK_PAINT_VALUE {
            p = p.add(1);
        }
        (top as usize).wrapping_sub(p as usize)
    }
}
