/* The C firmware's board: the STM32F405 under QEMU's netduinoplus2 (stm32f405.c), as
 * firmware-template/src/stm32f405/ for the Rust firmware: USART1 for text, TIM2 for timing,
 * semihosting for the exit status. */
#ifndef BOARD_H
#define BOARD_H

#include <stdint.h>

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
/* Ends the program with `status` through semihosting (QEMU exits with it). */
_Noreturn void board_exit(uint32_t status);

#endif
