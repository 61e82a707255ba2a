//! Board: Zynq-7000 (Cortex-A9, VFPv3 + NEON), QEMU machine `xilinx-zynq-a9`; target
//! `armv7a-none-eabihf`. Hand-written startup (`rt`), the Cadence UART0 for text and the
//! MPCore global timer for timing; memory layout in `boards/zynq/`.
//!
//! Every board module offers the same items, which `main.rs` and `report.rs` use: `NAME`, `CPU`,
//! `TIMER`, `Serial`, `Timer`, `exit`, `stack_bounds` and `STACK_PAINT`.

mod rt;
mod semihosting;
mod timer;
mod uart;

pub use rt::{stack_bounds, STACK_PAINT};
pub use semihosting::exit;
pub use timer::GlobalTimer as Timer;
pub use uart::Uart0 as Serial;

/// The board name in RESULT.
pub const NAME: &str = "zynq-7000";
/// The processor, for the banner.
pub const CPU: &str = "Cortex-A9, VFPv3 + NEON";
/// What a tick counts, for the summary.
pub const TIMER: &str = "global timer ticks";
