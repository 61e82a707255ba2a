//! Bare-metal Zynq-7000 firmware (placeholder computation during bring-up).
#![no_std]
#![no_main]

mod decimal;
mod rt;
mod semihosting;
mod timer;
mod uart;

use timer::GlobalTimer;
use uart::Uart0;

/// Iterations of the calibration loop: 2 instructions each.
const CALIB_ITERS: u32 = 1_000_000;

/// Runs a loop of exactly `2 * iters` instructions and returns the global timer ticks it took.
fn timed_loop(timer: &GlobalTimer, iters: u32) -> u64 {
    let t0 = timer.now();
    // SAFETY: a register-only countdown loop.
    unsafe {
        core::arch::asm!(
            "1:",
            "subs {n}, {n}, #1",
            "bne 1b",
            n = inout(reg) iters.max(1) => _,
            options(nomem, nostack),
        );
    }
    timer.now().wrapping_sub(t0)
}

#[no_mangle]
extern "C" fn main() -> ! {
    let mut uart = Uart0::new();
    let timer = GlobalTimer::start();
    uart.str("firmware-template: booted\n");
    let t1 = timed_loop(&timer, CALIB_ITERS);
    let t2 = timed_loop(&timer, 2 * CALIB_ITERS);
    uart.str("calibration: ")
        .u64(u64::from(2 * CALIB_ITERS))
        .str(" instructions in ")
        .u64(t1)
        .str(" ticks, ")
        .u64(u64::from(4 * CALIB_ITERS))
        .str(" in ")
        .u64(t2)
        .str(" ticks\n");
    semihosting::exit(0)
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    semihosting::exit(20)
}
