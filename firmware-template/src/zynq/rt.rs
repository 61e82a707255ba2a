//! Startup of the Cortex-A9: vector table, stacks, VFP/NEON, .bss, stack paint, MMU and L1
//! caches, then `main`.
//!
//! Developer notes
//! - All of it is assembly, run before any Rust code: Rust must not run before its stack exists
//!   and its statics are zeroed. Rust sees only `main` (called from here), `fault_exit` and
//!   the linker symbols of the stack.
//! - The core starts in Secure SVC mode with the MMU and caches off, as QEMU and the Zynq boot
//!   ROM leave it. The firmware stays in SVC mode, and turns on the MMU (a flat map) and the L1
//!   caches; the L2 cache controller (PL310) is left off.
//! - Every exception is a failure for this firmware (it polls, it takes no interrupts): each
//!   default handler exits through semihosting with its own status, so a test sees which one fired.

use super::semihosting;

/// Exit statuses of the default exception handlers (see `__default_*` below).
pub mod status {
    /// Undefined instruction (e.g. VFP/NEON used while disabled).
    pub const UNDEFINED: u32 = 10;
    /// An `svc` that is not a semihosting call.
    pub const SVC: u32 = 11;
    /// Prefetch abort.
    pub const PREFETCH_ABORT: u32 = 12;
    /// Data abort.
    pub const DATA_ABORT: u32 = 13;
    /// IRQ (none is enabled).
    pub const IRQ: u32 = 14;
    /// FIQ (none is enabled).
    pub const FIQ: u32 = 15;
}

core::arch::global_asm!(
    r#"
    .section .vector_table, "ax", %progbits
    .arm
    .p2align 5
    .global __vector_table
__vector_table:
    b _start                  @ reset: the boot flow jumps to the ELF entry, which is _start
    b UndefinedInstruction
    b SupervisorCall
    b PrefetchAbort
    b DataAbort
    nop                       @ reserved
    b Irq
    b Fiq

    .section .text.start, "ax", %progbits
    .arm
    .fpu neon
    .global _start
    .type _start, %function
_start:
    @ Only CPU0 runs the firmware; the other core (if started) sleeps for good.
    mrc   p15, 0, r0, c0, c0, 5       @ MPIDR
    ands  r0, r0, #3
    bne   9f

    @ Exceptions go to our table: VBAR is used while SCTLR.V = 0 (its reset value).
    ldr   r0, =__vector_table
    mcr   p15, 0, r0, c12, c0, 0
    mrc   p15, 0, r0, c1, c0, 0
    bic   r0, r0, #(1 << 13)          @ SCTLR.V = 0
    mcr   p15, 0, r0, c1, c0, 0
    isb

    @ Stacks, each mode its own: UND, ABT, IRQ, FIQ at the bottom, SVC above them.
    @ IRQ and FIQ stay masked (CPSR I and F are set at reset).
    ldr   r0, =__stack_bottom
    ldr   r1, =__exception_stack_size
    add   r0, r0, r1
    cps   #0x1b                       @ UND
    mov   sp, r0
    add   r0, r0, r1
    cps   #0x17                       @ ABT
    mov   sp, r0
    add   r0, r0, r1
    cps   #0x12                       @ IRQ
    mov   sp, r0
    add   r0, r0, r1
    cps   #0x11                       @ FIQ
    mov   sp, r0
    cps   #0x13                       @ SVC, where the firmware runs
    ldr   sp, =__stack_top

    @ VFP and NEON: full access to coprocessors 10 and 11 in CPACR, then FPEXC.EN.
    @ Until then any floating-point instruction is undefined.
    mrc   p15, 0, r0, c1, c0, 2
    orr   r0, r0, #(0xf << 20)
    mcr   p15, 0, r0, c1, c0, 2
    isb
    mov   r0, #(1 << 30)
    vmsr  fpexc, r0
    @ FPSCR: round to nearest, no flush-to-zero, no default NaN: IEEE 754 like the host.
    mov   r0, #0
    vmsr  fpscr, r0

    @ Zero .bss (word-aligned at both ends, link.x asserts it).
    ldr   r0, =__sbss
    ldr   r1, =__ebss
    mov   r2, #0
1:  cmp   r0, r1
    strlo r2, [r0], #4
    blo   1b

    @ Paint the SVC stack, so that `crate::stack` can tell how deep it went.
    ldr   r0, =__exception_stacks_top
    ldr   r1, =__stack_top
    ldr   r2, ={paint}
1:  cmp   r0, r1
    strlo r2, [r0], #4
    blo   1b

    @ MMU and L1 caches. With the MMU off every access is strongly ordered and uncached: a real
    @ A9 would run the controller many times slower than the paper's board. Flat map of 4096
    @ 1 MiB sections: DDR (the first GiB) normal write-back write-allocate memory, the rest device
    @ memory that never executes. QEMU translates but models no cache: counts do not change.
    ldr   r0, =__ttb
    ldr   r3, ={ddr_section}
    ldr   r4, ={device_section}
    mov   r1, #0
1:  cmp   r1, #0x400
    movlo r2, r3
    movhs r2, r4
    orr   r2, r2, r1, lsl #20
    str   r2, [r0, r1, lsl #2]
    add   r1, r1, #1
    cmp   r1, #0x1000
    blo   1b
    @ The table is written with the D-cache off, so it is in memory for the table walks.
    mcr   p15, 0, r0, c2, c0, 0       @ TTBR0 = the table, walks non-cacheable
    mov   r0, #0
    mcr   p15, 0, r0, c2, c0, 2       @ TTBCR = 0: TTBR0 translates everything
    ldr   r0, =0x55555555
    mcr   p15, 0, r0, c3, c0, 0       @ DACR: every domain is a client, AP bits apply
    @ Caches and TLBs hold garbage after reset: invalidate them before turning them on.
    mov   r0, #0
    mcr   p15, 0, r0, c8, c7, 0       @ TLBIALL
    mcr   p15, 0, r0, c7, c5, 0       @ ICIALLU
    mcr   p15, 0, r0, c7, c5, 6       @ BPIALL
    @ L1 D-cache by set/way: 4 ways (bits 31:30) x 256 sets (bits 12:5) of 32-byte lines (32 KiB).
    mov   r1, #0
1:  mov   r2, #0
2:  orr   r0, r2, r1, lsl #30
    mcr   p15, 0, r0, c7, c6, 2       @ DCISW
    add   r2, r2, #(1 << 5)
    cmp   r2, #(256 << 5)
    blo   2b
    add   r1, r1, #1
    cmp   r1, #4
    blo   1b
    dsb
    isb
    mrc   p15, 0, r0, c1, c0, 0
    orr   r0, r0, #(1 << 0)           @ M: MMU
    orr   r0, r0, #(1 << 2)           @ C: data cache
    orr   r0, r0, #(1 << 11)          @ Z: branch prediction
    orr   r0, r0, #(1 << 12)          @ I: instruction cache
    mcr   p15, 0, r0, c1, c0, 0
    dsb
    isb

    bl    main
9:  wfe
    b     9b

    @ Default exception handlers: exit with the status of the exception (rt::status).
    .section .text.default_handlers, "ax", %progbits
    .arm
    .global __default_undefined
__default_undefined:
    mov   r0, #{undefined}
    b     fault_exit
    .global __default_svc
__default_svc:
    @ A semihosting call that reached the vector has no host to serve it (a board without a
    @ debugger): exiting would trap again, so sleep instead.
    ldr   r0, [lr, #-4]               @ the A32 `svc` instruction
    bic   r0, r0, #0xff000000         @ its immediate
    ldr   r1, =0x123456
    cmp   r0, r1
    movne r0, #{svc}
    bne   fault_exit
3:  wfe
    b     3b
    .global __default_prefetch_abort
__default_prefetch_abort:
    mov   r0, #{prefetch_abort}
    b     fault_exit
    .global __default_data_abort
__default_data_abort:
    mov   r0, #{data_abort}
    b     fault_exit
    .global __default_irq
__default_irq:
    mov   r0, #{irq}
    b     fault_exit
    .global __default_fiq
__default_fiq:
    mov   r0, #{fiq}
    b     fault_exit
"#,
    undefined = const status::UNDEFINED,
    svc = const status::SVC,
    prefetch_abort = const status::PREFETCH_ABORT,
    data_abort = const status::DATA_ABORT,
    irq = const status::IRQ,
    fiq = const status::FIQ,
    paint = const STACK_PAINT,
    // Section descriptors (ARMv7-A short format): AP = 0b11 (full access), domain 0.
    // DDR: TEX = 0b001, C = 1, B = 1: normal, outer and inner write-back write-allocate.
    ddr_section = const 0b10 | (1 << 2) | (1 << 3) | (0b11 << 10) | (0b001 << 12),
    // Everything else: B = 1 (shareable device), XN = 1.
    device_section = const 0b10 | (1 << 2) | (1 << 4) | (0b11 << 10),
);

/// What the startup code writes over the SVC stack before `main` runs.
pub const STACK_PAINT: u32 = 0xDEAD_BEEF;

extern "C" {
    static __exception_stacks_top: u32;
    static __stack_top: u32;
}

/// The SVC stack, where the firmware runs: [bottom, top), painted at startup.
pub fn stack_bounds() -> (usize, usize) {
    // Only the addresses of the linker symbols are taken; nothing is read.
    (
        core::ptr::addr_of!(__exception_stacks_top) as usize,
        core::ptr::addr_of!(__stack_top) as usize,
    )
}

/// Target of the default exception handlers, running on the exception mode's own stack.
#[no_mangle]
extern "C" fn fault_exit(status: u32) -> ! {
    semihosting::exit(status)
}
