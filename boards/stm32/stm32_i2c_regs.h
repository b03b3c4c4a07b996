/*
 * Register map of the STM32 "I2Cv2" peripheral, identical on STM32L476
 * (RM0351 §39 "Inter-integrated circuit (I2C) interface", "I2C registers") and
 * STM32G071 (RM0444 §32, same title and section). Register names below are the
 * manuals' subsection titles; subsection numbers differ between revisions;
 * offsets cross-checked against ST's CMSIS device header layout (I2C_TypeDef:
 * CR1 0x00 ... TXDR 0x28). Only what the master driver uses is listed.
 */
#ifndef BOARDS_STM32_I2C_REGS_H
#define BOARDS_STM32_I2C_REGS_H

/* Register offsets from the peripheral base ("I2C register map" table in both manuals). */
#define STM32_I2C_CR1     0x00u
#define STM32_I2C_CR2     0x04u
#define STM32_I2C_TIMINGR 0x10u
#define STM32_I2C_ISR     0x18u
#define STM32_I2C_ICR     0x1Cu
#define STM32_I2C_RXDR    0x24u
#define STM32_I2C_TXDR    0x28u

/* I2C_CR1 "Control register 1". Analog filter on (ANFOFF = 0),
 * digital filter off (DNF = 0), no interrupts: the driver polls. */
#define STM32_I2C_CR1_PE (1u << 0) /* peripheral enable; 0 = software reset ("Software reset") */

/* I2C_CR2 "Control register 2". */
#define STM32_I2C_CR2_SADD_SHIFT   0u /* SADD[7:1] holds the 7-bit address in 7-bit mode */
#define STM32_I2C_CR2_RD_WRN       (1u << 10)
#define STM32_I2C_CR2_START        (1u << 13)
#define STM32_I2C_CR2_STOP         (1u << 14)
#define STM32_I2C_CR2_NBYTES_SHIFT 16u /* NBYTES[23:16]: bytes in this (reload) chunk */
#define STM32_I2C_CR2_RELOAD       (1u << 24)
#define STM32_I2C_CR2_AUTOEND      (1u << 25)
#define STM32_I2C_NBYTES_MAX       255u /* NBYTES is 8 bits; longer transfers use RELOAD */

/* I2C_ISR "Interrupt and status register". */
#define STM32_I2C_ISR_TXE (1u << 0)
#define STM32_I2C_ISR_TXIS                                                                         \
    (1u << 1) /* TXDR empty and the next byte is wanted (after address ACK) */
#define STM32_I2C_ISR_RXNE  (1u << 2)
#define STM32_I2C_ISR_NACKF (1u << 4)
#define STM32_I2C_ISR_STOPF (1u << 5)
#define STM32_I2C_ISR_TC    (1u << 6) /* NBYTES done, AUTOEND = 0, RELOAD = 0 */
#define STM32_I2C_ISR_TCR   (1u << 7) /* NBYTES done with RELOAD = 1 */
#define STM32_I2C_ISR_BERR  (1u << 8)
#define STM32_I2C_ISR_ARLO  (1u << 9)
#define STM32_I2C_ISR_OVR   (1u << 10)
#define STM32_I2C_ISR_BUSY  (1u << 15)

/* I2C_ICR "Interrupt clear register": write 1 to clear. */
#define STM32_I2C_ICR_ADDRCF   (1u << 3)
#define STM32_I2C_ICR_NACKCF   (1u << 4)
#define STM32_I2C_ICR_STOPCF   (1u << 5)
#define STM32_I2C_ICR_BERRCF   (1u << 8)
#define STM32_I2C_ICR_ARLOCF   (1u << 9)
#define STM32_I2C_ICR_OVRCF    (1u << 10)
#define STM32_I2C_ICR_PECCF    (1u << 11)
#define STM32_I2C_ICR_TIMOUTCF (1u << 12)
#define STM32_I2C_ICR_ALERTCF  (1u << 13)
#define STM32_I2C_ICR_ALL                                                                          \
    (STM32_I2C_ICR_ADDRCF | STM32_I2C_ICR_NACKCF | STM32_I2C_ICR_STOPCF | STM32_I2C_ICR_BERRCF |   \
     STM32_I2C_ICR_ARLOCF | STM32_I2C_ICR_OVRCF | STM32_I2C_ICR_PECCF | STM32_I2C_ICR_TIMOUTCF |   \
     STM32_I2C_ICR_ALERTCF)

/*
 * I2C_TIMINGR "Timing register" fields and the one value used
 * here: Fast-mode 400 kHz from a 16 MHz kernel clock (HSI16 on both boards).
 *   PRESC = 1  -> t_PRESC = (1+1) / 16 MHz = 125 ns
 *   SCLL  = 9  -> t_SCLL  = (9+1) x 125 ns = 1250 ns  (t_LOW >= 1.3 us once t_SYNC1 is added)
 *   SCLH  = 3  -> t_SCLH  = (3+1) x 125 ns =  500 ns  (t_HIGH >= 0.6 us once t_SYNC2 is added)
 *   SDADEL = 2 -> data hold  2 x 125 ns = 250 ns, inside [62.5, 452.5] ns allowed by
 *                 the SDADEL bounds of "I2C timings" with t_f = 300 ns, t_HD;DAT(max) = 0.9 us,
 * analog filter on SCLDEL = 3 -> data setup 4 x 125 ns = 500 ns >= t_r(300 ns) + t_SU;DAT(100 ns)
 *   t_SCL = t_SCLL + t_SCLH + t_SYNC1 + t_SYNC2 ~ 2.5 us -> ~400 kHz.
 * These are the values of the reference manuals' example table "Examples of
 * timing settings for f_I2CCLK = 16 MHz", Fast-mode column (section
 * "I2C_TIMINGR register configuration examples" of RM0351 §39 and RM0444 §32);
 * the computation above re-derives them.
 */
#define STM32_I2C_TIMINGR_VALUE(presc, scldel, sdadel, sclh, scll)                                 \
    (((uint32_t)(presc) << 28) | ((uint32_t)(scldel) << 20) | ((uint32_t)(sdadel) << 16) |         \
     ((uint32_t)(sclh) << 8) | (uint32_t)(scll))
#define STM32_I2C_TIMINGR_400KHZ_AT_16MHZ                                                          \
    STM32_I2C_TIMINGR_VALUE(1u, 3u, 2u, 3u, 9u) /* 0x10320309 */
/*
 * Standard-mode 100 kHz from the same 16 MHz kernel clock, the same table's Standard-mode
 * column:
 *   PRESC = 3  -> t_PRESC = 4 / 16 MHz = 250 ns
 *   SCLL = 0x13 -> t_SCLL = 20 x 250 ns = 5.0 us (t_LOW >= 4.7 us)
 *   SCLH = 0xF  -> t_SCLH = 16 x 250 ns = 4.0 us (t_HIGH >= 4.0 us)
 *   SDADEL = 2  -> data hold 500 ns; SCLDEL = 4 -> data setup 1250 ns >= t_r (1000 ns) +
 *                  t_SU;DAT (250 ns)
 *   t_SCL ~ 10 us -> ~100 kHz.
 */
#define STM32_I2C_TIMINGR_100KHZ_AT_16MHZ                                                          \
    STM32_I2C_TIMINGR_VALUE(3u, 4u, 2u, 0xFu, 0x13u) /* 0x30420F13 */

#endif /* BOARDS_STM32_I2C_REGS_H */
