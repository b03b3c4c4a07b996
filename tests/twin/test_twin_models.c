/* Unit tests of the twin's peripheral models and strict rules, driven through the bus
 * dispatch (twin_bus_read/write) as the emulated core would, with no firmware. */
#include <stdio.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "hal/hal_err.h"
#include "twin.h"
#include "twin_world.h"

static int failures;

#define CHECK(cond)                                                                                \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond);               \
            ++failures;                                                                            \
        }                                                                                          \
    } while (0)

#define RCC_AHB2ENR  (TWIN_RCC_BASE + 0x4Cu)
#define RCC_APB1ENR1 (TWIN_RCC_BASE + 0x58u)
#define RCC_CR       (TWIN_RCC_BASE + 0x00u)
#define RCC_CFGR     (TWIN_RCC_BASE + 0x08u)
#define I2C_CR1      (TWIN_I2C1_BASE + 0x00u)
#define I2C_CR2      (TWIN_I2C1_BASE + 0x04u)
#define I2C_TIMINGR  (TWIN_I2C1_BASE + 0x10u)
#define I2C_ISR      (TWIN_I2C1_BASE + 0x18u)
#define I2C_RXDR     (TWIN_I2C1_BASE + 0x24u)
#define I2C_TXDR     (TWIN_I2C1_BASE + 0x28u)
#define SYST_CSR     0xE000E010u
#define SYST_RVR     0xE000E014u
#define SYST_CVR     0xE000E018u

static struct twin T;
static struct twin_world W;
static struct scene_row rows[4];

static void fresh(bool strict) {
    twin_free(&T);
    if (twin_init(&T, strict, stderr) != 0) {
        fprintf(stderr, "twin_init failed\n");
        exit(1);
    }
    twin_world_init(&W, rows, 4u, 20000u, NULL);
    T.world = &W;
    twin_reset(&T, true);
}

static void w32(uint32_t addr, uint32_t v) {
    twin_bus_write(&T, addr, 4u, v);
}

static uint32_t r32(uint32_t addr) {
    return twin_bus_read(&T, addr, 4u);
}

static void test_unclocked_peripheral_is_a_violation(void) {
    fresh(true);
    (void)r32(I2C_ISR); /* I2C1EN still 0 */
    CHECK(T.stop == TWIN_STOP_VIOLATION);
    CHECK(strstr(T.stop_msg, "clock") != NULL);
    fresh(true);
    w32(RCC_APB1ENR1, 1u << 21);
    (void)r32(I2C_ISR);
    CHECK(T.stop == TWIN_RUNNING);
}

static void test_timingr_with_pe_set_is_a_violation(void) {
    fresh(true);
    w32(RCC_APB1ENR1, 1u << 21);
    w32(I2C_TIMINGR, 0x10320309u);
    w32(I2C_CR1, 1u);
    CHECK(T.stop == TWIN_RUNNING);
    w32(I2C_TIMINGR, 0x10320309u);
    CHECK(T.stop == TWIN_STOP_VIOLATION);
    CHECK(strstr(T.stop_msg, "I2C1_TIMINGR") != NULL && strstr(T.stop_msg, "PE = 1") != NULL);
}

static void test_start_during_a_transfer_is_a_violation(void) {
    fresh(true);
    w32(RCC_APB1ENR1, 1u << 21);
    w32(I2C_TIMINGR, 0x10320309u);
    w32(I2C_CR1, 1u);
    /* Read 2 bytes from 0x29 (the VL53 models answer at their boot address). */
    const uint32_t cr2 = (0x29u << 1) | (1u << 10) | (2u << 16) | (1u << 25) | (1u << 13);
    w32(I2C_CR2, cr2);
    CHECK(T.stop == TWIN_RUNNING);
    w32(I2C_CR2, cr2);
    CHECK(T.stop == TWIN_STOP_VIOLATION);
    CHECK(strstr(T.stop_msg, "START while a transfer is running") != NULL);
}

static void test_read_paced_by_timingr(void) {
    fresh(true);
    w32(RCC_APB1ENR1, 1u << 21);
    w32(I2C_TIMINGR, 0x10320309u);
    w32(I2C_CR1, 1u);
    /* Let the models boot (1.2 ms), then read IDENTIFICATION__MODEL_ID's index first. */
    T.cycles += twin_ps_to_cycles(&T, 5000000000ull);
    const uint64_t t0 = twin_now_ps(&T);
    w32(I2C_CR2, (0x29u << 1) | (1u << 10) | (1u << 16) | (1u << 25) | (1u << 13));
    uint32_t isr = 0;
    for (int i = 0; i < 100 && (isr & (1u << 2)) == 0u; ++i) {
        isr = r32(I2C_ISR); /* each poll jumps to the next bus event */
    }
    CHECK((isr & (1u << 2)) != 0u); /* RXNE */
    /* START + address + ACK + 8 data bits + ACK: 19 bit times of ~2.2 us at 0x10320309. */
    const uint64_t dt_ns = (twin_now_ps(&T) - t0) / 1000u;
    CHECK(dt_ns > 19u * 2000u && dt_ns < 19u * 3000u);
    (void)r32(I2C_RXDR);
    for (int i = 0; i < 100 && (isr & (1u << 5)) == 0u; ++i) {
        isr = r32(I2C_ISR);
    }
    CHECK((isr & (1u << 5)) != 0u);  /* STOPF after AUTOEND */
    CHECK((isr & (1u << 15)) == 0u); /* BUSY cleared */
    CHECK(T.stop == TWIN_RUNNING);
}

/* A write reaches the world once its bytes are in, but at its START's time: the world's
 * bus adds the wire time itself, so its clock ends with the core's, not that far ahead (a
 * sensor released after a long write booted early in the world's time, twin/models/twin_i2c.c). */
static void test_world_clock_follows_a_write(void) {
    fresh(true);
    w32(RCC_APB1ENR1, 1u << 21);
    w32(I2C_TIMINGR, 0x10320309u);
    w32(I2C_CR1, 1u);
    T.cycles += twin_ps_to_cycles(&T, 5000000000ull);
    twin_world_sync(&W, twin_now_ps(&T) / 1000000u); /* the models booted (a GPIO access) */
    static const uint8_t index[2] = {0x01u, 0x0Fu};
    /* 2 bytes (IDENTIFICATION__MODEL_ID's index), START and AUTOEND */
    w32(I2C_CR2, (0x29u << 1) | (2u << 16) | (1u << 25) | (1u << 13));
    uint32_t isr = 0;
    unsigned sent = 0;
    for (int i = 0; i < 200 && (isr & (1u << 5)) == 0u; ++i) {
        isr = r32(I2C_ISR); /* each poll jumps to the next bus event */
        if ((isr & (1u << 1)) != 0u && sent < 2u) {
            w32(I2C_TXDR, index[sent++]); /* TXIS */
        }
    }
    CHECK((isr & (1u << 5)) != 0u); /* STOPF */
    const uint64_t core_us = twin_now_ps(&T) / 1000000u;
    const uint64_t world_us = sim_clock_now(&W.rig.clock);
    /* 29 bit times (~64 us) ahead before; the two buses' wire times differ by a few us */
    CHECK(world_us + 10u >= core_us && world_us <= core_us + 10u);
    CHECK(T.stop == TWIN_RUNNING);
}

static void test_systick_counts_cycles(void) {
    fresh(true);
    w32(SYST_RVR, 999u);
    w32(SYST_CVR, 0u);
    w32(SYST_CSR, 7u);
    CHECK(r32(SYST_CVR) == 0u);
    T.cycles += 1u;
    CHECK(r32(SYST_CVR) == 999u);
    T.cycles += 999u;
    twin_systick_update(&T);
    CHECK((T.scs.pending & (1u << 15)) != 0u); /* the wrap pends SysTick */
    CHECK((r32(SYST_CSR) & (1u << 16)) != 0u); /* COUNTFLAG, cleared by the read */
    CHECK((r32(SYST_CSR) & (1u << 16)) == 0u);
}

static void test_clock_switch_waits_for_ready(void) {
    fresh(true);
    w32(RCC_CFGR, 1u); /* HSI16 not on: the switch does not happen */
    CHECK((r32(RCC_CFGR) & 0xCu) == 0u);
    CHECK(T.sysclk_hz == TWIN_MSI_HZ);
    w32(RCC_CR, r32(RCC_CR) | (1u << 8));
    CHECK((r32(RCC_CR) & (1u << 10)) != 0u); /* the ready poll jumps to HSIRDY */
    w32(RCC_CFGR, 1u);
    CHECK((r32(RCC_CFGR) & 0xCu) == 0x4u);
    CHECK(T.sysclk_hz == TWIN_HSI16_HZ);
}

#define RCC_PLLCFGR (TWIN_RCC_BASE + 0x0Cu)
#define FLASH_ACR   0x40022000u
#define PLL_32MHZ   (2u | (8u << 8) | (1u << 25)) /* HSI16 / 1 x 8 / 4 */
#define PLLREN      (1u << 24)

/* Bring HSI16 up and the PLL to lock with `cfg` (RM0351 §6.2.5). */
static void pll_lock(uint32_t cfg) {
    w32(RCC_CR, r32(RCC_CR) | (1u << 8));
    (void)r32(RCC_CR); /* HSIRDY */
    w32(RCC_PLLCFGR, cfg);
    w32(RCC_CR, r32(RCC_CR) | (1u << 24));
    CHECK((r32(RCC_CR) & (1u << 25)) != 0u); /* the lock poll jumps to PLLRDY */
    w32(RCC_PLLCFGR, cfg | PLLREN);
}

/* The PLL as the RM0351 sequence has it: locked, R output enabled, wait states first. */
static void test_pll_sequence(void) {
    fresh(true);
    pll_lock(PLL_32MHZ);
    CHECK(T.stop == TWIN_RUNNING);
    w32(FLASH_ACR, 0x600u | 1u); /* 1 WS up to 32 MHz (RM0351 Table 12) */
    w32(RCC_CFGR, 3u);
    CHECK((r32(RCC_CFGR) & 0xCu) == 0xCu);
    CHECK(T.sysclk_hz == 32000000u);
    CHECK(T.stop == TWIN_RUNNING);
    w32(RCC_PLLCFGR, PLL_32MHZ | PLLREN | (1u << 4)); /* M changed with the PLL on */
    CHECK(T.stop == TWIN_STOP_VIOLATION);
    /* Raising the clock before the wait states. */
    fresh(true);
    pll_lock(PLL_32MHZ);
    w32(RCC_CFGR, 3u);
    CHECK(T.stop == TWIN_STOP_VIOLATION && strstr(T.stop_msg, "LATENCY") != NULL);
    /* Selected without PLLREN: no switch, a violation. */
    fresh(true);
    w32(RCC_CR, r32(RCC_CR) | (1u << 8));
    (void)r32(RCC_CR);
    w32(RCC_PLLCFGR, PLL_32MHZ);
    w32(RCC_CR, r32(RCC_CR) | (1u << 24));
    (void)r32(RCC_CR);
    w32(FLASH_ACR, 0x601u);
    w32(RCC_CFGR, 3u);
    CHECK(T.stop == TWIN_STOP_VIOLATION && T.sysclk_hz == TWIN_MSI_HZ);
    /* A VCO below 64 MHz (16 x 2) never locks. */
    fresh(true);
    w32(RCC_CR, r32(RCC_CR) | (1u << 8));
    (void)r32(RCC_CR);
    w32(RCC_PLLCFGR, 2u | (2u << 8));
    w32(RCC_CR, r32(RCC_CR) | (1u << 24));
    CHECK(T.stop == TWIN_STOP_VIOLATION && (r32(RCC_CR) & (1u << 25)) == 0u);
}

#define USART_CR1 (TWIN_USART2_BASE + 0x00u)
#define USART_BRR (TWIN_USART2_BASE + 0x0Cu)
#define USART_ISR (TWIN_USART2_BASE + 0x1Cu)
#define USART_ICR (TWIN_USART2_BASE + 0x20u)
#define USART_RDR (TWIN_USART2_BASE + 0x24u)
#define USART_TDR (TWIN_USART2_BASE + 0x28u)
#define NVIC_ISER 0xE000E100u

/* Let `us` microseconds of core time pass (at the reset clock) and bring USART2 up to it. */
static void usart_after_us(uint32_t us) {
    T.cycles += (uint64_t)us * (T.sysclk_hz / 1000000u);
    twin_usart_update(&T);
}

/* RM0351 §40.5.3, §40.7: the host's bytes arrive at 115200 Bd (86.8 us each); RXNE with
 * RXNEIE raises the line; a byte arriving with RXNE still set is lost and sets ORE, which
 * keeps the line up (RXNEIE) until ICR.ORECF; TXE with TXEIE raises it too. */
static void test_usart_interrupts_and_overrun(void) {
    fresh(true);
    w32(RCC_APB1ENR1, 1u << 17); /* USART2EN */
    w32(USART_BRR, 35u);         /* 4 MHz / 115200 */
    w32(USART_CR1, 0x2Du);       /* UE | RE | TE | RXNEIE */
    CHECK(!twin_usart_irq(&T));
    const uint64_t t0 = twin_now_ps(&T);
    const uint64_t last = twin_usart_send_to_mcu(&T, (const uint8_t *)"ab", 2u);
    CHECK(last == t0 + 2u * 86805555u); /* back to back at the line rate */
    CHECK(twin_usart_next_event_ps(&T) == t0 + 86805555u);
    usart_after_us(90u);
    CHECK((r32(USART_ISR) & (1u << 5)) != 0u); /* RXNE */
    CHECK(twin_usart_irq(&T));
    usart_after_us(90u);                       /* 'b' arrives, RDR still full */
    CHECK((r32(USART_ISR) & (1u << 3)) != 0u); /* ORE */
    CHECK(T.usart.overruns == 1u);
    CHECK(r32(USART_RDR) == 'a'); /* the old byte kept, RXNE cleared by the read */
    CHECK((r32(USART_ISR) & (1u << 5)) == 0u);
    CHECK(twin_usart_irq(&T)); /* ORE with RXNEIE */
    w32(USART_ICR, 1u << 3);
    CHECK(!twin_usart_irq(&T));
    w32(USART_CR1, 0xADu); /* + TXEIE: TXE is set, the line rises */
    CHECK(twin_usart_irq(&T));
    w32(USART_TDR, 'x'); /* into the shift register: TXE stays set */
    w32(USART_TDR, 'y'); /* TDR full: TXE clear, the line down until 'x' has gone */
    CHECK(!twin_usart_irq(&T));
    CHECK(twin_usart_next_event_ps(&T) != UINT64_MAX);
    usart_after_us(90u);
    CHECK(twin_usart_irq(&T));
    CHECK(T.stop == TWIN_RUNNING);
    w32(NVIC_ISER + 4u, 1u << 6); /* IRQ 38, USART2: modelled */
    CHECK(T.stop == TWIN_RUNNING);
    w32(USART_CR1, 0x102Du); /* M0: a 9-bit word, not modelled */
    CHECK(T.stop == TWIN_STOP_VIOLATION);
    fresh(true);
    w32(NVIC_ISER, 1u); /* IRQ 0: no model behind it */
    CHECK(T.stop == TWIN_STOP_VIOLATION);
}

static void test_reserved_address_is_a_violation(void) {
    fresh(true);
    (void)r32(0x40010000u); /* SYSCFG: not modelled */
    CHECK(T.stop == TWIN_STOP_VIOLATION);
    fresh(false);
    (void)r32(0x40010000u); /* lenient: a warning only */
    CHECK(T.stop == TWIN_RUNNING);
}

#define FLASH_KEYR (TWIN_FLASHIF_BASE + 0x08u)
#define FLASH_SR   (TWIN_FLASHIF_BASE + 0x10u)
#define FLASH_CR   (TWIN_FLASHIF_BASE + 0x14u)
#define FLASH_ECCR (TWIN_FLASHIF_BASE + 0x18u)

static void unlock_flash(void) {
    w32(FLASH_KEYR, 0x45670123u);
    w32(FLASH_KEYR, 0xCDEF89ABu);
}

/* The record pages' flash interface (twin_flash.c), strict: what RM0351 §3.3 forbids. */
static void test_flash_rules(void) {
    fresh(true);
    w32(FLASH_CR, 1u); /* PG while locked */
    CHECK(T.stop == TWIN_STOP_VIOLATION && strstr(T.stop_msg, "locked") != NULL);
    fresh(true);
    w32(FLASH_KEYR, 0x12345678u);
    CHECK(T.stop == TWIN_STOP_VIOLATION && strstr(T.stop_msg, "key") != NULL);
    fresh(true);
    w32(TWIN_RECORDS_BASE, 0u); /* a write without PG */
    CHECK(T.stop == TWIN_STOP_VIOLATION && strstr(T.stop_msg, "PGSERR") != NULL);
    fresh(true);
    unlock_flash();
    w32(FLASH_CR, (1u << 1) | (100u << 3) | (1u << 11) | (1u << 16)); /* erase bank 2 page 100 */
    CHECK(T.stop == TWIN_STOP_VIOLATION && strstr(T.stop_msg, "record pages") != NULL);
    fresh(true);
    unlock_flash();
    w32(FLASH_CR, 1u); /* PG */
    w32(TWIN_RECORDS_BASE + 8u, 0x11223344u);
    w32(TWIN_RECORDS_BASE + 12u, 0x55667788u);
    CHECK(T.stop == TWIN_RUNNING && T.flash_pe.programs == 1u);
    CHECK((r32(FLASH_SR) & (1u << 16)) != 0u); /* BSY, then (the poll warps) done */
    CHECK(r32(TWIN_RECORDS_BASE + 12u) == 0x55667788u);
    w32(TWIN_RECORDS_BASE + 8u, 0u); /* the same double-word again */
    w32(TWIN_RECORDS_BASE + 12u, 0u);
    CHECK(T.stop == TWIN_STOP_VIOLATION && strstr(T.stop_msg, "PROGERR") != NULL);
    /* a power cut in a double-word: half of it, and an ECC double error when read */
    fresh(true);
    T.flash_pe.cut_after = 0u;
    unlock_flash();
    w32(FLASH_CR, 1u);
    w32(TWIN_RECORDS_BASE + 16u, 0x11223344u);
    w32(TWIN_RECORDS_BASE + 20u, 0x55667788u);
    CHECK(T.reset_pending && T.flash_pe.cuts == 1u);
    CHECK(r32(TWIN_RECORDS_BASE + 20u) == 0xFFFFFFFFu);
    CHECK((r32(FLASH_ECCR) & (1u << 31)) != 0u && (T.scs.pending & (1u << 2)) != 0u);
}

#define ADC_ISR   (TWIN_ADC_BASE + 0x00u)
#define ADC_CR    (TWIN_ADC_BASE + 0x08u)
#define ADC_SMPR1 (TWIN_ADC_BASE + 0x14u)
#define ADC_SMPR2 (TWIN_ADC_BASE + 0x18u)
#define ADC_SQR1  (TWIN_ADC_BASE + 0x30u)
#define ADC_DR    (TWIN_ADC_BASE + 0x40u)
#define ADC_CCR   (TWIN_ADC_BASE + 0x308u)

static void after_us(uint32_t us) {
    T.cycles += (uint64_t)us * (T.sysclk_hz / 1000000u);
}

/* RM0351 §18.4.6-§18.4.9 in order, at the reset clock (4 MHz, ADC at HCLK/2): deep
 * power-down off, the regulator and its 20 us, the paths, calibration, enable, ready. */
static void adc_up(void) {
    w32(RCC_AHB2ENR, 1u << 13); /* ADCEN */
    w32(ADC_CR, 0u);
    w32(ADC_CR, 1u << 28);
    after_us(20u);
    w32(ADC_CCR, (2u << 16) | (1u << 22) | (1u << 23));
    w32(ADC_CR, (1u << 28) | (1u << 31));
    for (unsigned i = 0; i < 10u && (r32(ADC_CR) & (1u << 31)) != 0u; ++i) {
    }
    after_us(120u);
    w32(ADC_CR, (1u << 28) | 1u);
    for (unsigned i = 0; i < 10u && (r32(ADC_ISR) & 1u) == 0u; ++i) {
    }
    w32(ADC_SMPR1, 7u);
    w32(ADC_SMPR2, 7u << 21);
}

static uint16_t adc_convert(uint8_t channel) {
    w32(ADC_SQR1, (uint32_t)channel << 6);
    w32(ADC_CR, (1u << 28) | 1u | (1u << 2));
    for (unsigned i = 0; i < 10u && (r32(ADC_ISR) & (1u << 2)) == 0u; ++i) {
    }
    return (uint16_t)r32(ADC_DR);
}

/* The ADC (twin_adc.c), strict: the documented sequence gives the trace's temperature within
 * the 12-bit quantisation; each step out of order stops the run and converts nothing. */
static void test_adc_temperature_sensor(void) {
    for (unsigned i = 0; i < 4u; ++i) {
        rows[i] = (struct scene_row){.has_temp = true, .temp_c = 25.0 + 10.0 * i};
    }
    rows[3].has_temp = false;
    fresh(true);
    twin_world_start_boot(&W, 0u);
    /* The calibration words where the firmware reads them. */
    CHECK((r32(0x1FFF75A8u) & 0xFFFFu) == TWIN_TS_CAL1);
    CHECK((r32(0x1FFF75A8u) >> 16) == TWIN_VREFINT_CAL);
    CHECK((r32(0x1FFF75C8u) >> 16) == TWIN_TS_CAL2);
    adc_up();
    CHECK(T.stop == TWIN_RUNNING);
    const uint16_t vref = adc_convert(0u);
    const uint16_t ts = adc_convert(17u);
    CHECK(T.stop == TWIN_RUNNING);
    /* Back to °C as the firmware does (VREFINT-scaled line through the two points). */
    const double ts_3v0 = (double)ts * TWIN_VREFINT_CAL / vref;
    const double c = 30.0 + (ts_3v0 - TWIN_TS_CAL1) * 80.0 / (TWIN_TS_CAL2 - TWIN_TS_CAL1);
    const double lsb_c = 80.0 / (TWIN_TS_CAL2 - TWIN_TS_CAL1) * 3300.0 / 3000.0;
    CHECK(c > 25.0 - lsb_c && c < 25.0 + lsb_c);
    CHECK(T.adc.sensor_conversions == 1u && T.adc.last_cdeg == 2500);
    /* A row without temp_c: the sensor converts 0 (the firmware refuses it). */
    T.cycles += twin_ps_to_cycles(&T, 3ull * 20000u * 1000000u); /* row 3 */
    CHECK(adc_convert(17u) == 0u);
    CHECK(T.adc.unknown_temperature == 1u);

    /* Out of order, each on a fresh part: ADVREGEN in deep power-down; ADCAL before the
     * regulator's start-up; ADSTART before ADRDY; the sensor sampled too short. */
    fresh(true);
    w32(RCC_AHB2ENR, 1u << 13);
    w32(ADC_CR, 1u << 28);
    CHECK(T.stop == TWIN_STOP_VIOLATION);
    fresh(true);
    w32(RCC_AHB2ENR, 1u << 13);
    w32(ADC_CR, 0u);
    w32(ADC_CR, 1u << 28);
    w32(ADC_CCR, 2u << 16);
    w32(ADC_CR, (1u << 28) | (1u << 31));
    CHECK(T.stop == TWIN_STOP_VIOLATION);
    fresh(true);
    w32(RCC_AHB2ENR, 1u << 13);
    w32(ADC_SQR1, 17u << 6);
    w32(ADC_CR, 1u << 2);
    CHECK(T.stop == TWIN_STOP_VIOLATION);
    CHECK(T.adc.conversions == 0u);
    fresh(true);
    twin_world_start_boot(&W, 0u);
    adc_up();
    w32(ADC_SMPR2, 1u << 21); /* 6.5 ADC clocks: 3.25 us at 2 MHz, under 5 us */
    (void)adc_convert(17u);
    CHECK(T.stop == TWIN_STOP_VIOLATION);
    /* Unclocked: ADCEN off. */
    fresh(true);
    (void)r32(ADC_CR);
    CHECK(T.stop == TWIN_STOP_VIOLATION);
}

int main(void) {
    test_unclocked_peripheral_is_a_violation();
    test_timingr_with_pe_set_is_a_violation();
    test_start_during_a_transfer_is_a_violation();
    test_read_paced_by_timingr();
    test_world_clock_follows_a_write();
    test_systick_counts_cycles();
    test_clock_switch_waits_for_ready();
    test_pll_sequence();
    test_reserved_address_is_a_violation();
    test_usart_interrupts_and_overrun();
    test_flash_rules();
    test_adc_temperature_sensor();
    twin_free(&T);
    if (failures != 0) {
        fprintf(stderr, "%d checks failed\n", failures);
        return 1;
    }
    puts("twin models: all checks passed");
    return 0;
}
