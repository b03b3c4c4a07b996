/*
 * Startup shared by every Cortex-M board: the vector table, the reset handler
 * (copy .data, zero .bss, enable the FPU where there is one, call main) and
 * default fault handlers. newlib's crt0 is not used (-nostartfiles): it has no
 * Cortex-M vector table. Section symbols come from boards/cortex-m/sections.ld.
 * Vector layout: ARMv7-M Architecture Reference Manual, B1.5.2 (ARMv6-M: B1.5.2 too).
 */
#include <stdint.h>

#include "board.h"

extern uint32_t __data_load_start[], __data_start[], __data_end[];
extern uint32_t __bss_start[], __bss_end[];
extern uint32_t __stack_top[];

int main(void);
void Reset_Handler(void);
void Default_Handler(void);
void HardFault_Handler(void);

/* Weak so a board can take any of these over by defining the same name. */
void NMI_Handler(void) __attribute__((weak, alias("Default_Handler")));
void MemManage_Handler(void) __attribute__((weak, alias("Default_Handler")));
void BusFault_Handler(void) __attribute__((weak, alias("Default_Handler")));
void UsageFault_Handler(void) __attribute__((weak, alias("Default_Handler")));
void SVC_Handler(void) __attribute__((weak, alias("Default_Handler")));
void PendSV_Handler(void) __attribute__((weak, alias("Default_Handler")));
void SysTick_Handler(void) __attribute__((weak, alias("Default_Handler")));
#if defined(BOARD_UART_IRQ)
/* The board's telemetry UART interrupt (BOARD_UART_IRQ: its NVIC number, from the build). */
void Uart_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));
#endif

typedef void (*vector_fn)(void);

/* Exception number (IPSR) of the fault being reported (zeroed at boot, so a board_fault()
 * that is not an exception prints none), and the same kept across the reset that follows
 * (.noinit, for a debugger after the fact; garbage after power-on). */
volatile uint32_t cortex_m_fault_vector;
__attribute__((section(".noinit"))) volatile uint32_t cortex_m_last_fault_vector;

/* 16 system entries, then BOARD_IRQ_COUNT external interrupts: every one points at
 * Default_Handler (a zero entry would make an unexpected IRQ fetch from address 0 and fault
 * with INVSTATE, ARMv7-M ARM B1.5.6, far from its cause). */
__attribute__((section(".vectors"),
               used)) static const vector_fn vector_table[16 + BOARD_IRQ_COUNT] = {
    (vector_fn)(uintptr_t)__stack_top,
    Reset_Handler,
    NMI_Handler,
    HardFault_Handler,
    MemManage_Handler,
    BusFault_Handler,
    UsageFault_Handler,
    0,
    0,
    0,
    0,
    SVC_Handler,
    0,
    0,
    PendSV_Handler,
    SysTick_Handler,
#if defined(BOARD_UART_IRQ)
    [16 ... 16 + BOARD_UART_IRQ - 1] = Default_Handler,
    [16 + BOARD_UART_IRQ] = Uart_IRQHandler,
    [16 + BOARD_UART_IRQ + 1 ... 16 + BOARD_IRQ_COUNT - 1] = Default_Handler,
#else
    [16 ... 16 + BOARD_IRQ_COUNT - 1] = Default_Handler,
#endif
};

void Reset_Handler(void) {
    /* Bounded copies: the linker script gives both ends of each section. */
    const uint32_t *src = __data_load_start;
    for (uint32_t *dst = __data_start; dst < __data_end; ++dst, ++src) {
        *dst = *src;
    }
    for (uint32_t *dst = __bss_start; dst < __bss_end; ++dst) {
        *dst = 0u;
    }
#if defined(__ARM_FP)
    /* CPACR (0xE000ED88): full access to CP10 and CP11 before any FPU instruction
     * (ARMv7-M ARM, B3.2.20). Only the camera pose module uses it. */
    volatile uint32_t *const cpacr = (volatile uint32_t *)0xE000ED88u;
    *cpacr |= (0xFu << 20);
    __asm__ volatile("dsb\n isb" ::: "memory");
#endif
    board_exit(main());
}

void HardFault_Report(void);

/* The stack may be what faulted (an overflow into the reserved addresses below RAM), so
 * the handler first puts MSP back at the top of the stack region, then reports in C.
 * Nothing is returned to: board_fault() resets. */
__attribute__((naked)) void HardFault_Handler(void) {
    __asm__ volatile("ldr r0, =__stack_top\n"
                     "msr msp, r0\n"
                     "ldr r1, =HardFault_Report\n"
                     "bx r1\n");
}

/* `used`: called only from the naked handler's assembly, which link-time optimisation does not
 * see as a reference (it would drop the function). */
__attribute__((used)) void HardFault_Report(void) {
    cortex_m_fault_vector = 3u;
    cortex_m_last_fault_vector = 3u;
    board_fault("HardFault");
}

void Default_Report(void);

/* Any other exception or IRQ without its own handler: record which (IPSR) and reset. Like
 * HardFault_Handler it restarts from the top of the stack region first: nothing is
 * returned to, and the report then needs no room below the interrupted thread's deepest
 * frame (tools/stack_check.py counts a naked entry as 0 bytes; the report alone uses about
 * 100 B of the whole stack region). */
__attribute__((naked)) void Default_Handler(void) {
    __asm__ volatile("ldr r0, =__stack_top\n"
                     "msr msp, r0\n"
                     "ldr r1, =Default_Report\n"
                     "bx r1\n");
}

/* `used`: as HardFault_Report. */
__attribute__((used)) void Default_Report(void) {
    uint32_t ipsr; /* still in handler mode: IPSR names the exception taken */
    __asm__ volatile("mrs %0, ipsr" : "=r"(ipsr));
    cortex_m_fault_vector = ipsr & 0x1FFu;
    cortex_m_last_fault_vector = ipsr & 0x1FFu;
    board_fault("unexpected exception");
}
