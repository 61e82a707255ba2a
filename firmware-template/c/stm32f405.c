/* Startup and peripherals of the STM32F405 (Cortex-M4F) for the C firmware: the vector table, the
 * reset handler (FPU on, .data copied, .bss zeroed, then main), fault handlers that exit through
 * semihosting with the Rust firmware's statuses (16 HardFault, 17 anything else), USART1 and TIM2
 * programmed exactly as firmware-template/src/stm32f405/{usart,tim2}.rs. */
#include <stdint.h>
#include <string.h>

#include "board.h"

#define REG(addr) (*(volatile uint32_t *)(addr))

/* Reset and clock control: peripheral clock enables. */
#define RCC_AHB1ENR 0x40023830u
#define RCC_APB1ENR 0x40023840u
#define RCC_APB2ENR 0x40023844u

/* Sets `bits` in a clock enable register and reads it back: a peripheral may not be touched until
 * its clock runs (errata sheet ES0182). */
static void rcc_enable(uint32_t reg, uint32_t bits) {
    REG(reg) |= bits;
    (void)REG(reg);
}

#define USART1 0x40011000u
#define GPIOA 0x40020000u

void board_serial_init(void) {
    rcc_enable(RCC_AHB1ENR, 1u << 0);
    rcc_enable(RCC_APB2ENR, 1u << 4);
    REG(GPIOA + 0x00) = (REG(GPIOA + 0x00) & ~(3u << 18)) | (2u << 18); /* PA9: alternate function */
    REG(GPIOA + 0x24) = (REG(GPIOA + 0x24) & ~(0xfu << 4)) | (7u << 4); /* AF7: USART1_TX */
    REG(USART1 + 0x08) = (8u << 4) | 11u;                             /* 115108 baud from 16 MHz */
    REG(USART1 + 0x0c) = (1u << 13) | (1u << 3);                      /* UE, TE */
}

void board_byte(char c) {
    while ((REG(USART1 + 0x00) & (1u << 7)) == 0) {
    }
    REG(USART1 + 0x04) = (uint8_t)c;
}

#define TIM2 0x40000000u

void board_timer_start(void) {
    rcc_enable(RCC_APB1ENR, 1u << 0);
    REG(TIM2 + 0x28) = 0;          /* PSC */
    REG(TIM2 + 0x2c) = 0xffffffffu; /* ARR */
    REG(TIM2 + 0x14) = 1;          /* EGR.UG: load the prescaler, clear the counter */
    REG(TIM2 + 0x00) = 1;          /* CR1.CEN */
}

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
int main(void);

_Noreturn void Reset_Handler(void) {
    /* CPACR: full access to CP10 and CP11 (the FPU) before any floating-point instruction. */
    REG(0xe000ed88u) |= 0xfu << 20;
    __asm__ volatile("dsb\n\tisb" ::: "memory");
    memcpy(&_sdata, &_sidata, (size_t)((char *)&_edata - (char *)&_sdata));
    memset(&_sbss, 0, (size_t)((char *)&_ebss - (char *)&_sbss));
    board_exit((uint32_t)main());
}

static _Noreturn void HardFault_Handler(void) { board_exit(16); }
static _Noreturn void Default_Handler(void) { board_exit(17); }

/* The Cortex-M4 vector table: the initial stack pointer, then the exception handlers. No interrupt is
 * enabled, so the table stops at SysTick. */
__attribute__((section(".vectors"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))(&_estack),
    Reset_Handler,
    Default_Handler,   /* NMI */
    HardFault_Handler, /* and every fault escalated to it */
    Default_Handler,   /* MemManage */
    Default_Handler,   /* BusFault */
    Default_Handler,   /* UsageFault */
    0,
    0,
    0,
    0,
    Default_Handler, /* SVCall */
    Default_Handler, /* DebugMonitor */
    0,
    Default_Handler, /* PendSV */
    Default_Handler, /* SysTick */
};
