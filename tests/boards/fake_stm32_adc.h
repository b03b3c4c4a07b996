/*
 * Register-level fake of the STM32L4 ADC (RM0351 §18) as the internal temperature sensor
 * uses it, for stm32_adc_temp.c compiled with STM32_REG_HOOKS. Strict: only the documented
 * sequence gives a conversion. Deep power-down must be left before ADVREGEN; ADCAL needs the
 * regulator's start-up time elapsed and ADEN = 0; ADEN needs ADCAL clear; ADSTART needs
 * ADRDY, the channel's path (VREFEN/TSEN) on for its start-up time and a sampling time at
 * least the datasheet's. A step out of order is counted in `violations` (with the first one
 * named) and does nothing, as a conversion that never comes. Flags: ADCAL clears after a
 * scripted number of CR reads, ADRDY and EOC rise after scripted ISR reads (UINT32_MAX:
 * never, a stuck flag). The calibration words sit in a fake system memory.
 * With `g0` set it is the STM32G0's ADC instead (RM0444 §15): no deep power-down, the clock
 * mode in CFGR2 (ADEN = 0 only), one SMPR (SMP1 / SMP2 chosen by SMPSELx), and the channel a
 * one-bit CHSELR mask that ADSTART may use only once CCRDY has risen after its write.
 */
#ifndef TESTS_BOARDS_FAKE_STM32_ADC_H
#define TESTS_BOARDS_FAKE_STM32_ADC_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* The system-memory window the fake holds: 0x1FFF75A0..0x1FFF75CF of the real part. */
#define FAKE_ADC_SYSMEM_REAL 0x1FFF75A0u
#define FAKE_ADC_SYSMEM_SIZE 0x30u

enum fake_adc_event {
    FA_REGULATOR_ON, /* ADVREGEN 0 -> 1 (deep power-down left) */
    FA_PATHS_ON,     /* VREFEN and TSEN on */
    FA_CAL_START,
    FA_CAL_DONE,
    FA_ENABLE, /* ADEN written */
    FA_READY,  /* ADRDY rose */
    FA_START,  /* ADSTART: `channel` of the log entry */
    FA_EOC,
    FA_DR_READ,
    FA_DISABLE,
};

struct fake_adc_log_entry {
    enum fake_adc_event event;
    uint8_t channel;
};

#define FAKE_ADC_LOG_MAX 64

struct fake_adc {
    uint32_t regs[17];  /* ISR 0x00 .. DR 0x40 */
    uint32_t common[4]; /* CSR, -, CCR, CDR */
    uint8_t sysmem[FAKE_ADC_SYSMEM_SIZE];
    /* script */
    uint16_t raw[19];              /* what a conversion of each channel gives */
    uint32_t cal_reads;            /* CR reads while ADCAL is still 1 */
    uint32_t ready_reads;          /* ISR reads before ADRDY rises */
    uint32_t eoc_reads;            /* ISR reads before EOC rises */
    uint32_t regulator_startup_us; /* tADCVREG_STUP */
    uint32_t path_startup_us;      /* sensor / VREFINT buffer start-up */
    uint32_t min_smp_code;         /* shortest sampling-time code the sensor allows */
    uint8_t ts_channel, vref_channel;
    bool g0; /* the STM32G0 layout (fake_adc_reset_g0) */
    /* state */
    bool ccrdy_pending, chsel_applied;
    uint32_t ccrdy_left;
    uint32_t regulator_on_us, paths_on_us;
    bool regulator_on, paths_on;
    uint32_t cal_left, ready_left, eoc_left;
    bool ready_pending, eoc_pending;
    uint8_t converting;
    /* observations */
    struct fake_adc_log_entry log[FAKE_ADC_LOG_MAX];
    size_t log_len;
    uint32_t violations;
    char first_violation[96];
    uint32_t conversions;
};

extern struct fake_adc fake_adc;

/* Reset state (CR = DEEPPWD), the calibration words of a part (ts_cal1 at 30 °C, ts_cal2,
 * vrefint_cal), flags after 3 reads, start-up times 20 us and 120 us, minimum code 5. */
void fake_adc_reset(uint16_t ts_cal1, uint16_t ts_cal2, uint16_t vrefint_cal);

/* The same for the STM32G0's ADC: CR = 0, the sensor on channel 12, VREFINT on 13. */
void fake_adc_reset_g0(uint16_t ts_cal1, uint16_t ts_cal2, uint16_t vrefint_cal);

/* Addresses for the driver's config: the ADC block, the common block, and where the real
 * address `real` of system memory is in the fake. */
uintptr_t fake_adc_base(void);
uintptr_t fake_adc_common_base(void);
uintptr_t fake_adc_sysmem(uint32_t real);

/* Dispatch (fake_stm32.c): true if `addr` is the ADC fake's. */
bool fake_adc_read(uintptr_t addr, uint32_t *value);
bool fake_adc_write(uintptr_t addr, uint32_t value);

#endif /* TESTS_BOARDS_FAKE_STM32_ADC_H */
