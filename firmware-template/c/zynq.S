/* Startup of the Cortex-A9 for the C firmware: src/zynq/rt.rs of the Rust firmware in assembly, the
 * same steps in the same order (CPU0 only, VBAR, one stack per mode, VFP and NEON on with IEEE
 * rounding and no flush-to-zero, .bss zeroed, a flat MMU map with the L1 caches on), then main, whose
 * status is the exit status. Every exception exits with rt.rs's status for it (10 undefined, 11 a
 * stray svc, 12 prefetch abort, 13 data abort, 14 IRQ, 15 FIQ). */
    .syntax unified
    .arm
    .fpu neon

    .section .vector_table, "ax", %progbits
    .p2align 5
    .global __vector_table
__vector_table:
    b _start
    b undefined
    b supervisor_call
    b prefetch_abort
    b data_abort
    nop
    b irq
    b fiq

    .section .text.start, "ax", %progbits
    .global _start
    .type _start, %function
_start:
    mrc   p15, 0, r0, c0, c0, 5       @ MPIDR: only CPU0 runs
    ands  r0, r0, #3
    bne   9f

    ldr   r0, =__vector_table         @ VBAR, used while SCTLR.V = 0
    mcr   p15, 0, r0, c12, c0, 0
    mrc   p15, 0, r0, c1, c0, 0
    bic   r0, r0, #(1 << 13)
    mcr   p15, 0, r0, c1, c0, 0
    isb

    ldr   r0, =__stack_bottom         @ UND, ABT, IRQ, FIQ stacks, then SVC's
    ldr   r1, =__exception_stack_size
    add   r0, r0, r1
    cps   #0x1b
    mov   sp, r0
    add   r0, r0, r1
    cps   #0x17
    mov   sp, r0
    add   r0, r0, r1
    cps   #0x12
    mov   sp, r0
    add   r0, r0, r1
    cps   #0x11
    mov   sp, r0
    cps   #0x13
    ldr   sp, =__stack_top

    mrc   p15, 0, r0, c1, c0, 2       @ CPACR: CP10 and CP11, then FPEXC.EN
    orr   r0, r0, #(0xf << 20)
    mcr   p15, 0, r0, c1, c0, 2
    isb
    mov   r0, #(1 << 30)
    vmsr  fpexc, r0
    mov   r0, #0                      @ FPSCR: round to nearest, no flush-to-zero, no default NaN
    vmsr  fpscr, r0

    ldr   r0, =__sbss                 @ zero .bss
    ldr   r1, =__ebss
    mov   r2, #0
1:  cmp   r0, r1
    strlo r2, [r0], #4
    blo   1b

    @ Flat map of 4096 1 MiB sections: the first GiB (DDR) normal write-back write-allocate memory, the
    @ rest device memory that never executes; then TLBs, caches and branch predictor invalidated and the
    @ MMU, D-cache, branch prediction and I-cache turned on. QEMU models no cache: counts do not change.
    ldr   r0, =__ttb
    ldr   r3, =0x1c0e                 @ section, C, B, AP = 0b11, TEX = 0b001
    ldr   r4, =0x0c16                 @ section, B, XN, AP = 0b11
    mov   r1, #0
1:  cmp   r1, #0x400
    movlo r2, r3
    movhs r2, r4
    orr   r2, r2, r1, lsl #20
    str   r2, [r0, r1, lsl #2]
    add   r1, r1, #1
    cmp   r1, #0x1000
    blo   1b
    mcr   p15, 0, r0, c2, c0, 0       @ TTBR0
    mov   r0, #0
    mcr   p15, 0, r0, c2, c0, 2       @ TTBCR
    ldr   r0, =0x55555555
    mcr   p15, 0, r0, c3, c0, 0       @ DACR: clients
    mov   r0, #0
    mcr   p15, 0, r0, c8, c7, 0       @ TLBIALL
    mcr   p15, 0, r0, c7, c5, 0       @ ICIALLU
    mcr   p15, 0, r0, c7, c5, 6       @ BPIALL
    mov   r1, #0                      @ DCISW over 4 ways x 256 sets
1:  mov   r2, #0
2:  orr   r0, r2, r1, lsl #30
    mcr   p15, 0, r0, c7, c6, 2
    add   r2, r2, #(1 << 5)
    cmp   r2, #(256 << 5)
    blo   2b
    add   r1, r1, #1
    cmp   r1, #4
    blo   1b
    dsb
    isb
    mrc   p15, 0, r0, c1, c0, 0
    orr   r0, r0, #(1 << 0)           @ M
    orr   r0, r0, #(1 << 2)           @ C
    orr   r0, r0, #(1 << 11)          @ Z
    orr   r0, r0, #(1 << 12)          @ I
    mcr   p15, 0, r0, c1, c0, 0
    dsb
    isb

    bl    main
    bl    fault_exit                  @ exits with main's status, in r0
9:  wfe
    b     9b

    .section .text.default_handlers, "ax", %progbits
undefined:
    mov   r0, #10
    b     fault_exit
supervisor_call:
    ldr   r0, [lr, #-4]               @ a semihosting call with no host to serve it sleeps
    bic   r0, r0, #0xff000000
    ldr   r1, =0x123456
    cmp   r0, r1
    movne r0, #11
    bne   fault_exit
3:  wfe
    b     3b
prefetch_abort:
    mov   r0, #12
    b     fault_exit
data_abort:
    mov   r0, #13
    b     fault_exit
irq:
    mov   r0, #14
    b     fault_exit
fiq:
    mov   r0, #15
    b     fault_exit

    .section .note.GNU-stack, "", %progbits
