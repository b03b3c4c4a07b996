/*
 * Cortex-M system registers used by the board time base. Addresses and bits
 * are architectural: ARMv7-M Architecture Reference Manual (Cortex-M4) and
 * ARMv6-M Architecture Reference Manual (Cortex-M0+), §B3.3 "The system timer,
 * SysTick" and §B3.2 "System Control Space" (ICSR).
 */
#ifndef BOARDS_STM32_CORTEX_M_REGS_H
#define BOARDS_STM32_CORTEX_M_REGS_H

#define CORTEX_M_SYST_CSR 0xE000E010u /* SysTick control and status (B3.3.3) */
#define CORTEX_M_SYST_RVR 0xE000E014u /* reload value, 24 bits (B3.3.4) */
#define CORTEX_M_SYST_CVR                                                                          \
    0xE000E018u /* current value, counts down; any write clears it (B3.3.5)                        \
                 */

#define CORTEX_M_SYST_CSR_ENABLE    (1u << 0)
#define CORTEX_M_SYST_CSR_TICKINT   (1u << 1) /* exception on the count to 0 */
#define CORTEX_M_SYST_CSR_CLKSOURCE (1u << 2) /* 1: the processor clock */
#define CORTEX_M_SYST_RELOAD_MAX    0x00FFFFFFu
#define CORTEX_M_SYST_CVR_MASK      0x00FFFFFFu

#define CORTEX_M_ICSR           0xE000ED04u /* Interrupt Control and State Register (B3.2.4) */
#define CORTEX_M_ICSR_PENDSTSET (1u << 26)  /* reads 1 while the SysTick exception is pending */

#endif /* BOARDS_STM32_CORTEX_M_REGS_H */
