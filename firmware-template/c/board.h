/* The C firmware's board, as firmware-template/src/<board>/ for the Rust firmware: text on a UART, a
 * timer for the timing, semihosting for the exit status. BOARD_ZYNQ (scripts/c-firmware.sh --board
 * zynq) picks the Zynq-7000 under QEMU's xilinx-zynq-a9 (zynq.c, zynq.S: UART0, the MPCore global
 * timer); otherwise the STM32F405 under QEMU's netduinoplus2 (stm32f405.c: USART1, TIM2). */
#ifndef BOARD_H
#define BOARD_H

#include <stdint.h>

#ifdef BOARD_ZYNQ
/* The board name in RESULT, and what a tick counts. */
#define BOARD_NAME "zynq-7000"
#define BOARD_TIMER "global timer ticks"
/* Resets UART0 and enables it for 115200 8N1. */
void board_serial_init(void);
/* Sends one byte, waiting while the transmit FIFO is full. */
void board_byte(char c);
/* Starts the global timer at prescaler 0 (one tick per 10 instructions under QEMU's -icount shift=0). */
void board_timer_start(void);
/* The low word of the global timer: differences of a few seconds' ticks are exact modulo 2^32. */
static inline uint32_t board_now(void) { return *(volatile uint32_t *)0xf8f00200u; }
/* The A32 semihosting trap. */
#define BOARD_SEMIHOSTING_TRAP "svc 0x123456"
#else
/* The board name in RESULT, and what a tick counts. */
#define BOARD_NAME "stm32f405"
#define BOARD_TIMER "TIM2 ticks"

/* Clocks GPIOA and USART1 and enables the transmitter, 115200 8N1 at the 16 MHz reset clock. */
void board_serial_init(void);
/* Sends one byte, waiting while the transmitter is busy. */
void board_byte(char c);
/* Clocks TIM2 and starts it counting up from 0 at prescaler 0 (one tick per instruction under
 * QEMU's -icount shift=0). */
void board_timer_start(void);
/* The current count of TIM2. */
static inline uint32_t board_now(void) { return *(volatile uint32_t *)0x40000024u; }
/* The Thumb (M-profile) semihosting trap. */
#define BOARD_SEMIHOSTING_TRAP "bkpt 0xab"
#endif

/* Ends the program with `status` through semihosting (QEMU exits with it): SYS_EXIT_EXTENDED with
 * ADP_Stopped_ApplicationExit and the status as its subcode. Without a semihosting host it sleeps. */
static inline _Noreturn void board_exit(uint32_t status) {
    static uint32_t block[2];
    block[0] = 0x20026u;
    block[1] = status;
    register uint32_t r0 __asm__("r0") = 0x20u;
    register uint32_t *r1 __asm__("r1") = block;
    __asm__ volatile(BOARD_SEMIHOSTING_TRAP : "+r"(r0) : "r"(r1) : "memory");
    for (;;) {
        __asm__ volatile("wfe");
    }
}

#endif
