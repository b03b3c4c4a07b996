/*
 * The STM32L4 and STM32G0 ADC temperature drivers (boards/stm32/stm32_adc_temp.c,
 * stm32_adc_g0_temp.c) against the strict ADC fake: the bring-up and conversions in the
 * reference manual's order with nothing out of sequence, every stuck flag ending in
 * HAL_ERR_TIMEOUT within its bound, and the conversion from the factory calibration giving
 * the temperature within the ADC's quantisation.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "fake_stm32.h"
#include "fake_stm32_adc.h"
#include "hal/hal_err.h"
#include "stm32_adc_regs.h"
#include "stm32_adc_temp.h"

/* A plausible L476's words (TS_CAL2 at 110 °C): about 4.2 counts per °C at 3.0 V. */
#define CAL1 1034u
#define CAL2 1372u
#define VREF 1656u

static struct stm32_adc_temp_config cfg;
static struct stm32_adc_temp adc;

static int setup(void **state) {
    (void)state;
    fake_reset(0x29, 1000u);
    fake_adc_reset(CAL1, CAL2, VREF);
    cfg = (struct stm32_adc_temp_config){
        .adc_base = fake_adc_base(),
        .common_base = fake_adc_common_base(),
        .ts_cal1_addr = fake_adc_sysmem(0x1FFF75A8u),
        .ts_cal2_addr = fake_adc_sysmem(0x1FFF75CAu),
        .vrefint_cal_addr = fake_adc_sysmem(0x1FFF75AAu),
        .ts_cal1_cdeg = 3000,
        .ts_cal2_cdeg = 11000,
        .ts_channel = 17u,
        .vrefint_channel = 0u,
        .smp_code = STM32_ADC_SMP_640_5,
        .regulator_startup_us = 20u,
        .sensor_startup_us = 120u,
        .poll_budget_us = 500u,
        .time = fake_time_hal(),
    };
    stm32_adc_temp_init(&adc, &cfg);
    return 0;
}

/* The raw conversions a part with these words gives at `temp_c` and `vdda` volts. */
static void part_at(double temp_c, double vdda, uint16_t *ts, uint16_t *vref) {
    const double at_3v0 = CAL1 + (temp_c - 30.0) * (double)(CAL2 - CAL1) / 80.0;
    *ts = (uint16_t)lround(at_3v0 * 3.0 / vdda);
    *vref = (uint16_t)lround(VREF * 3.0 / vdda);
}

static void test_reads_calibration_words_from_system_memory(void **state) {
    (void)state;
    assert_int_equal(adc.cal.ts_cal1, CAL1);
    assert_int_equal(adc.cal.ts_cal2, CAL2);
    assert_int_equal(adc.cal.vrefint_cal, VREF);
}

static void test_sequence_is_the_documented_one(void **state) {
    (void)state;
    part_at(25.0, 3.3, &fake_adc.raw[17], &fake_adc.raw[0]);
    int16_t cdeg = 0;
    assert_int_equal(stm32_adc_temp_read_cdeg(&adc, &cdeg), HAL_OK);
    if (fake_adc.violations != 0u) {
        fail_msg("out of sequence: %s", fake_adc.first_violation);
    }
    const struct fake_adc_log_entry want[] = {
        {FA_REGULATOR_ON, 0}, {FA_PATHS_ON, 0}, {FA_CAL_START, 0}, {FA_CAL_DONE, 0},
        {FA_ENABLE, 0},       {FA_READY, 0},    {FA_START, 0},     {FA_EOC, 0},
        {FA_DR_READ, 0},      {FA_START, 17},   {FA_EOC, 17},      {FA_DR_READ, 17},
    };
    assert_int_equal(fake_adc.log_len, sizeof want / sizeof want[0]);
    for (size_t i = 0; i < fake_adc.log_len; ++i) {
        assert_int_equal(fake_adc.log[i].event, want[i].event);
        assert_int_equal(fake_adc.log[i].channel, want[i].channel);
    }
    /* Both internal channels at the longest sampling time; the paths on. */
    assert_int_equal((fake_adc.regs[6] >> 21) & 7u, STM32_ADC_SMP_640_5);
    assert_int_equal(fake_adc.regs[5] & 7u, STM32_ADC_SMP_640_5);
    assert_true((fake_adc.common[2] & STM32_ADC_CCR_TSEN) != 0u);
    assert_true(cdeg > 2450 && cdeg < 2550);
    /* A second read converts only: the ADC stays up. */
    fake_adc.log_len = 0u;
    assert_int_equal(stm32_adc_temp_read_cdeg(&adc, &cdeg), HAL_OK);
    assert_int_equal(fake_adc.log_len, 6u);
    assert_int_equal(fake_adc.log[0].event, FA_START);
    assert_int_equal(fake_adc.conversions, 4u);
    assert_int_equal(fake_adc.violations, 0u);
}

/* Each flag that never comes: HAL_ERR_TIMEOUT within the poll budget (plus the start-up
 * waits), never a value. */
static void expect_timeout(void) {
    const uint32_t start = fake.time.now;
    int16_t cdeg = 1234;
    assert_int_equal(stm32_adc_temp_read_cdeg(&adc, &cdeg), HAL_ERR_TIMEOUT);
    assert_int_equal(cdeg, 1234);
    const uint32_t bound =
        cfg.regulator_startup_us + cfg.sensor_startup_us + 3u * (cfg.poll_budget_us + 2u);
    assert_true(fake.time.now - start <= bound);
}

static void test_stuck_calibration_times_out(void **state) {
    (void)state;
    fake_adc.cal_reads = UINT32_MAX;
    expect_timeout();
}

static void test_stuck_ready_times_out(void **state) {
    (void)state;
    fake_adc.ready_reads = UINT32_MAX;
    expect_timeout();
}

static void test_stuck_conversion_times_out_then_recovers(void **state) {
    (void)state;
    part_at(40.0, 3.3, &fake_adc.raw[17], &fake_adc.raw[0]);
    fake_adc.eoc_reads = UINT32_MAX;
    expect_timeout();
    /* The next read stops the stuck conversion, disables, and brings the ADC up again. */
    fake_adc.eoc_reads = 3u;
    int16_t cdeg = 0;
    assert_int_equal(stm32_adc_temp_read_cdeg(&adc, &cdeg), HAL_OK);
    if (fake_adc.violations != 0u) {
        fail_msg("out of sequence: %s", fake_adc.first_violation);
    }
    assert_true(cdeg > 3950 && cdeg < 4050);
}

/* The fake is strict: a sampling time shorter than the sensor needs gives no conversion. */
static void test_short_sampling_time_gives_no_value(void **state) {
    (void)state;
    cfg.smp_code = 2u;
    expect_timeout();
    assert_true(fake_adc.violations > 0u);
    assert_int_equal(fake_adc.conversions, 0u);
}

static void test_anchors_are_exact(void **state) {
    (void)state;
    int16_t cdeg = 0;
    assert_int_equal(stm32_adc_temp_convert(&adc.cal, CAL1, VREF, &cdeg), HAL_OK);
    assert_int_equal(cdeg, 3000);
    assert_int_equal(stm32_adc_temp_convert(&adc.cal, CAL2, VREF, &cdeg), HAL_OK);
    assert_int_equal(cdeg, 11000);
    /* The same reading at a supply 10 % higher: the VREFINT scaling brings it back. */
    assert_int_equal(stm32_adc_temp_convert(&adc.cal, (uint16_t)(CAL1 * 10u / 11u),
                                            (uint16_t)(VREF * 10u / 11u), &cdeg),
                     HAL_OK);
    assert_true(cdeg > 2990 && cdeg < 3010);
}

/* Over the operating range and supplies 1.8..3.6 V: within the quantisation of the two
 * 12-bit conversions (half an LSB each, propagated) plus the 0.01 °C rounding. */
static void test_conversion_within_quantisation(void **state) {
    (void)state;
    const double supplies[] = {1.8, 2.5, 3.0, 3.3, 3.6};
    double worst = 0.0;
    unsigned n = 0;
    for (size_t s = 0; s < sizeof supplies / sizeof supplies[0]; ++s) {
        for (double t = -40.0; t <= 125.0; t += 0.37) {
            uint16_t ts = 0, vref = 0;
            part_at(t, supplies[s], &ts, &vref);
            int16_t cdeg = 0;
            assert_int_equal(stm32_adc_temp_convert(&adc.cal, ts, vref, &cdeg), HAL_OK);
            const double ts_3v0 = (double)ts * VREF / vref;
            const double bound_lsb = 0.5 * VREF / vref + 0.5 * ts_3v0 / vref + 1.0 / 32.0;
            const double bound_c = bound_lsb * 80.0 / (CAL2 - CAL1) + 0.005;
            const double err = cdeg / 100.0 - t;
            if (fabs(err) > bound_c) {
                fail_msg("%.2f C at %.1f V: read %.2f C (bound %.3f)", t, supplies[s], cdeg / 100.0,
                         bound_c);
            }
            worst = fmax(worst, fabs(err));
            ++n;
        }
    }
    print_message("conversion: %u points, worst error %.3f C\n", n, worst);
}

static void test_implausible_is_an_error_never_clamped(void **state) {
    (void)state;
    int16_t cdeg = 777;
    struct stm32_adc_temp_cal erased = {0xFFFFu, 0xFFFFu, 0xFFFFu, 3000, 11000};
    assert_int_equal(stm32_adc_temp_convert(&erased, CAL1, VREF, &cdeg), HAL_ERR_CORRUPT);
    struct stm32_adc_temp_cal swapped = {CAL2, CAL1, VREF, 3000, 11000};
    assert_int_equal(stm32_adc_temp_convert(&swapped, CAL1, VREF, &cdeg), HAL_ERR_CORRUPT);
    /* A VREFINT reading that puts VDDA at 0.9 V or 6 V. */
    assert_int_equal(stm32_adc_temp_convert(&adc.cal, CAL1, VREF * 10u / 3u, &cdeg),
                     HAL_ERR_CORRUPT);
    assert_int_equal(stm32_adc_temp_convert(&adc.cal, CAL1, VREF / 2u, &cdeg), HAL_ERR_CORRUPT);
    assert_int_equal(stm32_adc_temp_convert(&adc.cal, CAL1, 0u, &cdeg), HAL_ERR_CORRUPT);
    /* Full scale: far above 150 °C. */
    assert_int_equal(stm32_adc_temp_convert(&adc.cal, 4095u, VREF, &cdeg), HAL_ERR_CORRUPT);
    assert_int_equal(cdeg, 777);
    /* Through the read: an erased calibration is reported, not converted. */
    setup(NULL);
    fake_adc_reset(0xFFFFu, 0xFFFFu, 0xFFFFu);
    stm32_adc_temp_init(&adc, &cfg);
    part_at(25.0, 3.3, &fake_adc.raw[17], &fake_adc.raw[0]);
    assert_int_equal(stm32_adc_temp_read_cdeg(&adc, &cdeg), HAL_ERR_CORRUPT);
    assert_int_equal(cdeg, 777);
}

/* ---------------------------------------------------------------- STM32G0 (RM0444 §15) */

/* A plausible G0's words: TS_CAL2 at 130 °C. */
#define G0_CAL1 1040u
#define G0_CAL2 1450u

static int setup_g0(void **state) {
    (void)state;
    fake_reset(0x29, 1000u);
    fake_adc_reset_g0(G0_CAL1, G0_CAL2, VREF);
    cfg = (struct stm32_adc_temp_config){
        .adc_base = fake_adc_base(),
        .common_base = fake_adc_common_base(),
        .ts_cal1_addr = fake_adc_sysmem(0x1FFF75A8u),
        .ts_cal2_addr = fake_adc_sysmem(0x1FFF75CAu),
        .vrefint_cal_addr = fake_adc_sysmem(0x1FFF75AAu),
        .ts_cal1_cdeg = 3000,
        .ts_cal2_cdeg = 13000,
        .ts_channel = 12u,
        .vrefint_channel = 13u,
        .smp_code = 7u,
        .regulator_startup_us = 20u,
        .sensor_startup_us = 120u,
        .poll_budget_us = 500u,
        .time = fake_time_hal(),
    };
    stm32_adc_temp_init(&adc, &cfg);
    return 0;
}

static void g0_at(double temp_c, double vdda) {
    const double at_3v0 = G0_CAL1 + (temp_c - 30.0) * (double)(G0_CAL2 - G0_CAL1) / 100.0;
    fake_adc.raw[12] = (uint16_t)lround(at_3v0 * 3.0 / vdda);
    fake_adc.raw[13] = (uint16_t)lround(VREF * 3.0 / vdda);
}

static void test_g0_sequence_and_value(void **state) {
    (void)state;
    g0_at(-12.5, 3.3);
    int16_t cdeg = 0;
    assert_int_equal(stm32_adc_g0_temp_read_cdeg(&adc, &cdeg), HAL_OK);
    if (fake_adc.violations != 0u) {
        fail_msg("out of sequence: %s", fake_adc.first_violation);
    }
    const struct fake_adc_log_entry want[] = {
        {FA_REGULATOR_ON, 0}, {FA_PATHS_ON, 0}, {FA_CAL_START, 0}, {FA_CAL_DONE, 0},
        {FA_ENABLE, 0},       {FA_READY, 0},    {FA_START, 13},    {FA_EOC, 13},
        {FA_DR_READ, 13},     {FA_START, 12},   {FA_EOC, 12},      {FA_DR_READ, 12},
    };
    assert_int_equal(fake_adc.log_len, sizeof want / sizeof want[0]);
    for (size_t i = 0; i < fake_adc.log_len; ++i) {
        assert_int_equal(fake_adc.log[i].event, want[i].event);
        assert_int_equal(fake_adc.log[i].channel, want[i].channel);
    }
    /* One LSB is 100 / 410 °C at 3.0 V, 0.27 °C at 3.3 V; the two conversions' rounding. */
    assert_true(cdeg > -1250 - 30 && cdeg < -1250 + 30);
    /* The exact anchor at 130 °C. */
    assert_int_equal(stm32_adc_temp_convert(&adc.cal, G0_CAL2, VREF, &cdeg), HAL_OK);
    assert_int_equal(cdeg, 13000);
}

static void test_g0_channel_never_applied_times_out(void **state) {
    (void)state;
    g0_at(25.0, 3.3);
    int16_t cdeg = 4321;
    assert_int_equal(stm32_adc_g0_temp_read_cdeg(&adc, &cdeg), HAL_OK);
    /* From now on CCRDY never rises after a CHSELR write: no conversion may start. */
    fake_adc.ready_reads = UINT32_MAX;
    const uint32_t start = fake.time.now;
    cdeg = 4321;
    assert_int_equal(stm32_adc_g0_temp_read_cdeg(&adc, &cdeg), HAL_ERR_TIMEOUT);
    assert_int_equal(cdeg, 4321);
    assert_true(fake.time.now - start <= 2u * (cfg.poll_budget_us + 2u));
    assert_int_equal(fake_adc.violations, 0u);
    assert_int_equal(fake_adc.conversions, 2u);
}

static void test_g0_stuck_calibration_times_out(void **state) {
    (void)state;
    fake_adc.cal_reads = UINT32_MAX;
    int16_t cdeg = 77;
    assert_int_equal(stm32_adc_g0_temp_read_cdeg(&adc, &cdeg), HAL_ERR_TIMEOUT);
    assert_int_equal(cdeg, 77);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_reads_calibration_words_from_system_memory, setup),
        cmocka_unit_test_setup(test_sequence_is_the_documented_one, setup),
        cmocka_unit_test_setup(test_stuck_calibration_times_out, setup),
        cmocka_unit_test_setup(test_stuck_ready_times_out, setup),
        cmocka_unit_test_setup(test_stuck_conversion_times_out_then_recovers, setup),
        cmocka_unit_test_setup(test_short_sampling_time_gives_no_value, setup),
        cmocka_unit_test_setup(test_anchors_are_exact, setup),
        cmocka_unit_test_setup(test_conversion_within_quantisation, setup),
        cmocka_unit_test_setup(test_implausible_is_an_error_never_clamped, setup),
        cmocka_unit_test_setup(test_g0_sequence_and_value, setup_g0),
        cmocka_unit_test_setup(test_g0_channel_never_applied_times_out, setup_g0),
        cmocka_unit_test_setup(test_g0_stuck_calibration_times_out, setup_g0),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
