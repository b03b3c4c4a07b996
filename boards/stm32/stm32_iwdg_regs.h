/*
 * Independent watchdog (IWDG) register map, the same on STM32L476 (RM0351
 * "Independent watchdog (IWDG)", §"IWDG registers") and STM32G071 (RM0444
 * "Independent watchdog (IWDG)", §"IWDG registers"); offsets as in ST CMSIS
 * IWDG_TypeDef (KR 0x00, PR 0x04, RLR 0x08, SR 0x0C, WINR 0x10).
 */
#ifndef BOARDS_STM32_IWDG_REGS_H
#define BOARDS_STM32_IWDG_REGS_H

#define STM32_IWDG_KR  0x00u
#define STM32_IWDG_PR  0x04u /* PR[2:0]: LSI divider 4 << PR (0..6) */
#define STM32_IWDG_RLR 0x08u /* RL[11:0] */
#define STM32_IWDG_SR  0x0Cu /* PVU bit 0, RVU bit 1, WVU bit 2: update in progress */

#define STM32_IWDG_KEY_START  0xCCCCu /* starts the watchdog (and the LSI) */
#define STM32_IWDG_KEY_UNLOCK 0x5555u /* enables writes to PR, RLR, WINR */
#define STM32_IWDG_KEY_RELOAD 0xAAAAu /* reloads the counter from RLR */

#define STM32_IWDG_PR_MAX     6u
#define STM32_IWDG_RLR_MAX    0x0FFFu
#define STM32_IWDG_SR_UPDATES 0x7u

#endif /* BOARDS_STM32_IWDG_REGS_H */
