/* Peripherals of the Zynq-7000 (Cortex-A9) for the C firmware, programmed exactly as
 * firmware-template/src/zynq/{uart,timer,semihosting}.rs: the Cadence UART0 for text, the MPCore
 * global timer for timing, and the semihosting exit. The startup (vector table, stacks, VFP/NEON,
 * .bss, MMU and L1 caches) is zynq.S; the memory map zynq.ld. */
#include <stdint.h>

#include "board.h"

#define REG(addr) (*(volatile uint32_t *)(addr))

/* UART0: control, mode, baud generator, status, FIFO, baud divider. */
#define UART0 0xe0000000u
#define UART_CR (UART0 + 0x00)
#define UART_MR (UART0 + 0x04)
#define UART_BAUDGEN (UART0 + 0x18)
#define UART_SR (UART0 + 0x2c)
#define UART_FIFO (UART0 + 0x30)
#define UART_BAUDDIV (UART0 + 0x34)

void board_serial_init(void) {
    REG(UART_CR) = (1u << 1) | (1u << 0);           /* TXRST, RXRST */
    REG(UART_MR) = 0x4u << 3;                       /* 8 data bits, no parity, 1 stop bit */
    REG(UART_BAUDGEN) = 124;                        /* 100 MHz / (124 * (6 + 1)) = 115207 baud */
    REG(UART_BAUDDIV) = 6;
    REG(UART_CR) = (1u << 4) | (1u << 2) | (1u << 8); /* TXEN, RXEN, STOPBRK */
}

void board_byte(char c) {
    while (REG(UART_SR) & (1u << 4)) { /* TXFULL */
    }
    REG(UART_FIFO) = (uint8_t)c;
}

/* The global timer: counter (low, high) and control, in the MPCore's private peripherals. */
#define GLOBAL_TIMER 0xf8f00200u

void board_timer_start(void) { REG(GLOBAL_TIMER + 0x08) = 1; /* enable, prescaler 0 */ }

_Noreturn void board_exit(uint32_t status) {
    /* SYS_EXIT_EXTENDED with ADP_Stopped_ApplicationExit and the status as its subcode; `svc
     * 0x123456` is the A32 semihosting trap. */
    static uint32_t block[2];
    block[0] = 0x20026u;
    block[1] = status;
    register uint32_t r0 __asm__("r0") = 0x20u;
    register uint32_t *r1 __asm__("r1") = block;
    __asm__ volatile("svc 0x123456" : "+r"(r0) : "r"(r1) : "memory");
    for (;;) {
        __asm__ volatile("wfe");
    }
}

/* Every exception is a failure here (the firmware polls, it takes no interrupt): zynq.S's handlers
 * exit with the Rust firmware's statuses (src/zynq/rt.rs). */
_Noreturn void fault_exit(uint32_t status) { board_exit(status); }
