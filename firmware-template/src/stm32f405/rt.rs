//! Startup of the Cortex-M4F, from `cortex-m-rt`: vector table, reset handler (FPU enabled
//! through CPACR, .bss zeroed, .data copied, the stack painted with its `paint-stack` feature),
//! then `main`. This file only adds the exception handlers and says where the painted stack is.
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

/// What the reset handler writes over the stack (cortex-m-rt's `paint-stack`).
pub const STACK_PAINT: u32 = STACK_PAINT_VALUE;

extern "C" {
    // Set by cortex-m-rt's link.x: the stack grows down from `_stack_start` (the end of RAM) to
    // `_stack_end` (the end of .bss/.uninit); the reset handler paints everything in between.
    static _stack_start: u32;
    static _stack_end: u32;
}

/// The main stack: [bottom, top), painted at reset.
pub fn stack_bounds() -> (usize, usize) {
    // Only the addresses of the linker symbols are taken; nothing is read.
    (
        core::ptr::addr_of!(_stack_end) as usize,
        core::ptr::addr_of!(_stack_start) as usize,
    )
}
