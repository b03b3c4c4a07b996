/*
 * The STM32L476 peripheral models of the twin: their register state and their access
 * functions. Each model is written from RM0351 (STM32L4x5/L4x6 reference manual) and the
 * STM32L476xx datasheet (DS10198); the .c file of each cites the behaviour it implements.
 * Offsets are from the peripheral base; `now` is simulated time in picoseconds.
 */
#ifndef TWIN_TWIN_PERIPH_H
#define TWIN_TWIN_PERIPH_H

#include <stdbool.h>
#include <stdint.h>

struct twin;

/* Base addresses: RM0351 §2.2.2 Table 1. */
#define TWIN_IWDG_BASE       0x40003000u
#define TWIN_USART2_BASE     0x40004400u
#define TWIN_I2C1_BASE       0x40005400u
#define TWIN_RCC_BASE        0x40021000u
#define TWIN_FLASHIF_BASE    0x40022000u
#define TWIN_GPIO_BASE       0x48000000u /* GPIOA; port n at + n * 0x400 */
#define TWIN_GPIO_PORTS      8u          /* A..H */
#define TWIN_DBGMCU_APB1FZR1 0xE0042008u
#define TWIN_ADC_BASE        0x50040000u /* ADC1; ADC2 + 0x100, ADC3 + 0x200, common + 0x300 */
#define TWIN_SYSMEM_CAL_PAGE 0x1FFF7000u /* the page of system memory with the calibration */

/* ---- RCC (RM0351 §6.4) and FLASH_ACR (RM0351 §3.7.1) ---- */
struct twin_rcc {
    uint32_t cr, icscr, cfgr, pllcfgr, ahb1enr, ahb2enr, ahb3enr, apb1enr1, apb1enr2, apb2enr;
    uint32_t ccipr, bdcr, csr;
    uint64_t hsi_ready_ps; /* HSIRDY rises then (UINT64_MAX: HSI off) */
    uint64_t pll_ready_ps; /* PLLRDY rises then (UINT64_MAX: PLL off or not locking) */
    uint32_t pll_r_hz;     /* PLLCLK (the R output) of the configuration locked last */
    bool hsi_broken;       /* test hook: HSI16 never becomes ready */
};
struct twin_flash_if {
    uint32_t acr;
};
void twin_rcc_reset(struct twin *t, bool power_on);
uint32_t twin_rcc_read(struct twin *t, uint32_t off);
void twin_rcc_write(struct twin *t, uint32_t off, uint32_t v);
uint32_t twin_flash_if_read(struct twin *t, uint32_t off);
void twin_flash_if_write(struct twin *t, uint32_t off, uint32_t v);

/* ---- FLASH program/erase interface (RM0351 §3.3.5-3.3.7, §3.7) and the record pages ---- */
/* The storage pages the flight image's linker script reserves (stm32l476rg.ld): bank 2,
 * pages 252..255, the last 8 KB of the 1 MB flash (the calibration's age on 252 and 253, the
 * record on 254 and 255). Only they may be erased or programmed; they are mapped as I/O so
 * each access reaches the model. */
#define TWIN_RECORDS_BASE   0x080FE000u
#define TWIN_RECORDS_SIZE   0x2000u
#define TWIN_RECORDS_PNB    252u
#define TWIN_RECORD_PAGE_AT 0x1000u /* the record's first page (254) from TWIN_RECORDS_BASE */
#define TWIN_FLASH_NO_CUT   UINT32_MAX
struct twin_flash {
    uint32_t sr, cr, eccr;
    unsigned key_step;       /* 1: KEY1 written, KEY2 next */
    bool locked_until_reset; /* a wrong key sequence (RM0351 §3.3.5) */
    uint64_t busy_until_ps;  /* SR.BSY until then */
    bool first_pending;      /* the first word of a double-word is written */
    uint32_t first_word, first_off;
    uint8_t ecc_bad[TWIN_RECORDS_SIZE / 8u / 8u]; /* torn double-words (bit per double-word) */
    /* power cut: after `cut_after` erases + double-words the power goes (the operation it
     * falls in half done) and the MCU reboots; TWIN_FLASH_NO_CUT: never */
    uint32_t cut_after, ops;
    uint32_t erases, programs, cuts;
};
/* Reset (CR locked, flags clear); the memory and the cut counters are kept: a reboot. */
void twin_flash_reset(struct twin *t);
uint32_t twin_flash_read(struct twin *t, uint32_t off);
void twin_flash_write(struct twin *t, uint32_t off, uint32_t v);
/* The record pages as memory: `off` from TWIN_RECORDS_BASE, `size` 1, 2 or 4 bytes. */
uint32_t twin_flash_mem_read(struct twin *t, uint32_t off, unsigned size);
void twin_flash_mem_write(struct twin *t, uint32_t off, unsigned size, uint32_t v);

/* Is the bus clock of the peripheral at `base` enabled (RM0351 §6.4 xxxENR registers)? */
bool twin_rcc_clock_on(const struct twin *t, uint32_t base);

/* ---- GPIO (RM0351 §8.4, §8.5) ---- */
struct twin_gpio {
    uint32_t moder, otyper, ospeedr, pupdr, odr, lckr, afrl, afrh, ascr;
};
void twin_gpio_reset(struct twin *t);
uint32_t twin_gpio_read(struct twin *t, unsigned port, uint32_t off);
void twin_gpio_write(struct twin *t, unsigned port, uint32_t off, uint32_t v);
/* Mode (MODER field) and alternate function of a pin. */
uint32_t twin_gpio_mode(const struct twin *t, unsigned port, unsigned pin);
uint32_t twin_gpio_af(const struct twin *t, unsigned port, unsigned pin);

/* ---- I2C1, the I2Cv2 peripheral (RM0351 §39) ---- */
#define TWIN_I2C_BUF 256u
struct twin_i2c {
    uint32_t cr1, cr2, oar1, oar2, timingr, timeoutr, isr, pecr, rxdr, txdr;
    /* The transfer in progress (master mode). */
    bool active;  /* START sent, STOP not yet */
    bool reading; /* current phase direction */
    uint8_t addr7;
    /* When the transaction on the simulated bus began: its first START (a repeated START
     * that reads the device just written continues it). The world takes the transaction
     * at this time and adds its own wire time (sim_i2c), as host_sim's bus does. */
    uint64_t start_ps;
    uint32_t nbytes; /* bytes left in this NBYTES chunk */
    uint8_t tx[TWIN_I2C_BUF];
    uint32_t tx_len;
    uint8_t rx[TWIN_I2C_BUF];
    uint32_t rx_len, rx_pos;
    int result;                 /* outcome of the bus transaction (HAL code), once done */
    bool done;                  /* the transaction was carried out on the simulated bus */
    bool txdr_full;             /* a byte written to TXDR not yet shifted out */
    uint64_t event_ps;          /* the next flag change (UINT64_MAX: none) */
    uint32_t event;             /* what happens then (twin_i2c.c) */
    uint32_t spurious_berr_ppm; /* test hook: errata 2.6.x spurious BERR (ES0250) */
    uint32_t prng;
    uint32_t berr_injected;
};
void twin_i2c_reset(struct twin *t);
uint32_t twin_i2c_read(struct twin *t, uint32_t off);
void twin_i2c_write(struct twin *t, uint32_t off, uint32_t v);

/* ---- USART2 (RM0351 §40) ---- */
#define TWIN_USART_RXQ 256u
struct twin_usart {
    uint32_t cr1, cr2, cr3, brr, gtpr, rtor, isr, rdr, tdr;
    bool shift_busy; /* a byte in the transmit shift register */
    uint8_t shift;
    uint64_t shift_done_ps;      /* when it has been sent */
    uint8_t rxq[TWIN_USART_RXQ]; /* bytes the host is sending (commands) */
    unsigned rx_head, rx_count;
    uint64_t rx_next_ps; /* the next byte's stop bit ends then (the host sends at 115200 Bd) */
    void (*on_tx)(void *ctx, uint8_t byte, uint64_t now_ps);
    void *tx_ctx;
    uint64_t bytes_tx, bytes_rx, overruns;
};
#define TWIN_USART2_IRQ 38u     /* NVIC position (RM0351 Table 58) */
#define TWIN_HOST_BAUD  115200u /* the host's end of the line */
void twin_usart_reset(struct twin *t);
uint32_t twin_usart_read(struct twin *t, uint32_t off);
void twin_usart_write(struct twin *t, uint32_t off, uint32_t v);
/* Bring the USART up to now: bytes sent, bytes received (RXNE, or ORE if RDR is full). */
void twin_usart_update(struct twin *t);
/* Is the USART's interrupt line to the NVIC asserted (a flag with its enable)? */
bool twin_usart_irq(const struct twin *t);
/* When the line may next rise by itself (a byte sent or received, ps), UINT64_MAX: never. */
uint64_t twin_usart_next_event_ps(const struct twin *t);
/* Queue bytes for the firmware's receiver, sent back to back at TWIN_HOST_BAUD after what is
 * queued already: the time the last one's stop bit ends (ps), or 0 if the queue is full. */
uint64_t twin_usart_send_to_mcu(struct twin *t, const uint8_t *data, unsigned len);

/* ---- IWDG (RM0351 §32) ---- */
struct twin_iwdg {
    bool running;
    bool unlocked;
    uint32_t pr, rlr, winr;
    uint64_t update_done_ps; /* PVU/RVU/WVU clear then */
    uint32_t sr;
    uint64_t expire_ps; /* the counter reaches 0 then (UINT64_MAX: not running) */
    uint32_t kicks;
};
void twin_iwdg_reset(struct twin *t);
uint32_t twin_iwdg_read(struct twin *t, uint32_t off);
void twin_iwdg_write(struct twin *t, uint32_t off, uint32_t v);
/* The watchdog's expiry time (UINT64_MAX: none). */
uint64_t twin_iwdg_expiry(const struct twin *t);

/* ---- ADC1 and the internal temperature sensor (RM0351 §18; DS10198 "Temperature sensor
 * characteristics", "ADC characteristics") ---- */
struct twin_adc {
    uint32_t isr, cr, cfgr, smpr1, smpr2, sqr1, dr, ccr;
    uint64_t regulator_ps; /* ADVREGEN set then (UINT64_MAX: off) */
    uint64_t paths_ps;     /* TSEN and VREFEN both on since then (UINT64_MAX: not) */
    uint64_t cal_done_ps;  /* ADCAL clears then (UINT64_MAX: no calibration running) */
    bool calibrated;       /* a calibration completed since the regulator came on */
    uint64_t ready_ps;     /* ADRDY rises then (UINT64_MAX: not enabling) */
    uint64_t eoc_ps;       /* the conversion ends then (UINT64_MAX: none running) */
    uint16_t result;       /* what DR holds at EOC */
    uint8_t channel;       /* the channel converting */
    /* observations */
    uint32_t conversions, sensor_conversions, unknown_temperature;
    int16_t first_cdeg, last_cdeg; /* the die temperature of the first and last sensor one */
};
void twin_adc_reset(struct twin *t);
uint32_t twin_adc_read(struct twin *t, uint32_t off);
void twin_adc_write(struct twin *t, uint32_t off, uint32_t v);
/* The page of system memory holding the factory calibration (read only). */
uint32_t twin_adc_sysmem_read(struct twin *t, uint32_t off);
/* The model's part: its factory words and the board's supply (twin_adc.c). */
#define TWIN_TS_CAL1     1034u /* at 30 °C, Vref+ 3.0 V */
#define TWIN_TS_CAL2     1372u /* at 110 °C */
#define TWIN_VREFINT_CAL 1656u
#define TWIN_VDDA_MV     3300u /* NUCLEO-L476RG: VDDA from the 3.3 V rail (UM1724) */

/* ---- System control space: SysTick, NVIC, SCB, FPU/MPU storage (ARMv7-M ARM B3) ---- */
struct twin_scs {
    uint32_t syst_csr, syst_rvr;
    /* Simulated time (ps) of the last enable of the counter (UINT64_MAX: never since reset):
     * the board's clock counts from it (boards/stm32/stm32_systick_time.c). */
    uint64_t syst_enabled_ps;
    uint64_t syst_next; /* cycles of the next wrap to 0 (UINT64_MAX: disabled) */
    bool countflag;
    uint32_t pending; /* bit n: system exception n pending */
    uint32_t vtor, aircr, scr, ccr, shpr[3], shcsr, cfsr, hfsr, mmfar, bfar, cpacr;
    uint32_t nvic_iser[8], nvic_ipr[64];
    uint32_t mpu_ctrl, mpu_rnr, mpu_rbar[8], mpu_rasr[8];
    uint32_t fpccr, fpcar, fpdscr;
};
void twin_scs_reset(struct twin *t);
uint32_t twin_scs_read(struct twin *t, uint32_t addr);
void twin_scs_write(struct twin *t, uint32_t addr, uint32_t v);
/* Bring SysTick up to t->cycles: COUNTFLAG and the pending SysTick exception. */
void twin_systick_update(struct twin *t);

#endif /* TWIN_TWIN_PERIPH_H */
