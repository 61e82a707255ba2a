//! `malloc` and friends for DAQP's C code: a bump allocator over a static arena, reset between
//! problems (each problem's workspace is dropped whole). `free` returns nothing; the high-water mark
//! is the RAM the DAQP side took (its workspace and its c_float copies of the QP's data).

use core::cell::UnsafeCell;
use core::ffi::c_void;

/// The arena's size: what the largest problem's DAQP workspace needs, with room (zynq: DDR; the
/// STM32F405's 128 KiB SRAM is shared with the stack).
#[cfg(board = "zynq")]
const ARENA: usize = 1 << 20;
#[cfg(board = "stm32f405")]
const ARENA: usize = 72 * 1024;

/// Every block starts on this boundary (c_float double, AAPCS).
const ALIGN: usize = 8;

#[repr(C, align(8))]
struct Arena(
    UnsafeCell<[u8; ARENA]>,
    UnsafeCell<usize>,
    UnsafeCell<usize>,
);

// SAFETY: the firmware is single-threaded and takes no interrupts.
unsafe impl Sync for Arena {}

/// The arena, its next free offset and the high-water mark.
static HEAP: Arena = Arena(
    UnsafeCell::new([0; ARENA]),
    UnsafeCell::new(0),
    UnsafeCell::new(0),
);

// The counters are read and reset with volatile accesses: LLVM takes `malloc` for the C library's,
// which touches no memory of this program, and would otherwise fold a read after a C call that
// allocated into the value before it.

/// Forgets every block (the caller has dropped whatever used them).
pub fn reset() {
    // SAFETY: single-threaded; no block is used after a reset (see above).
    unsafe {
        core::ptr::write_volatile(HEAP.1.get(), 0);
        core::ptr::write_volatile(HEAP.2.get(), 0);
    }
}

/// Most bytes in use since the last reset.
pub fn high_water() -> usize {
    // SAFETY: single-threaded read.
    unsafe { core::ptr::read_volatile(HEAP.2.get()) }
}

fn bump(size: usize) -> *mut c_void {
    // SAFETY: single-threaded; the offsets stay within the arena.
    unsafe {
        let next = core::ptr::read_volatile(HEAP.1.get());
        let start = (next + ALIGN - 1) & !(ALIGN - 1);
        let Some(end) = start.checked_add(size.max(1)) else {
            return core::ptr::null_mut();
        };
        if end > ARENA {
            return core::ptr::null_mut();
        }
        core::ptr::write_volatile(HEAP.1.get(), end);
        let hw = core::ptr::read_volatile(HEAP.2.get());
        core::ptr::write_volatile(HEAP.2.get(), hw.max(end));
        (HEAP.0.get() as *mut u8).add(start) as *mut c_void
    }
}

#[no_mangle]
extern "C" fn malloc(size: usize) -> *mut c_void {
    bump(size)
}

#[no_mangle]
extern "C" fn calloc(count: usize, size: usize) -> *mut c_void {
    let Some(bytes) = count.checked_mul(size) else {
        return core::ptr::null_mut();
    };
    let p = bump(bytes);
    if !p.is_null() {
        // SAFETY: `p` is a fresh block of `bytes` bytes.
        unsafe { core::ptr::write_bytes(p as *mut u8, 0, bytes) };
    }
    p
}

#[no_mangle]
extern "C" fn free(_: *mut c_void) {}

/// DAQP's C code calls the double-precision `sqrt` (as a libm function if the compiler does not
/// inline it); the M4F has no f64 hardware, so this is libm's software square root there.
#[no_mangle]
extern "C" fn sqrt(x: f64) -> f64 {
    libm::sqrt(x)
}

#[no_mangle]
extern "C" fn sqrtf(x: f32) -> f32 {
    libm::sqrtf(x)
}
