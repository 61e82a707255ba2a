/* Peripherals of the Zynq-7000 (Cortex-A9) for the C firmware, programmed exactly as
 * firmware-template/src/zynq/{uart,timer}.rs: the Cadence UART0 for text and the MPCore global timer
 * for timing (the semihosting exit is board.h's). The startup (vector table, stacks, VFP/NEON, .bss,
 * MMU and L1 caches) is zynq.S; the memory map zynq.ld. */
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

/* The exit of zynq.S: with main's status, or an exception's (the firmware polls and takes no
 * interrupt; the handlers use the Rust firmware's statuses, src/zynq/rt.rs). */
_Noreturn void fault_exit(uint32_t status) { board_exit(status); }
