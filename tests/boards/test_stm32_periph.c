/*
 * The other STM32 board drivers against the register fakes: the numbered-pin
 * GPIO table, the SysTick microsecond time base (snapshot arithmetic, wrap,
 * bounded delay) and the independent watchdog start/kick sequence.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "cortex_m_regs.h"
#include "fake_stm32.h"
#include "hal/hal_err.h"
#include "stm32_gpio.h"
#include "stm32_gpio_regs.h"
#include "stm32_iwdg.h"
#include "stm32_iwdg_regs.h"
#include "stm32_systick_time.h"

static int setup(void **state) {
    (void)state;
    fake_reset(0x29, 0u);
    return 0;
}

/* ---------------------------------------------------------------- GPIO */

static struct stm32_pin pins[8];
static struct stm32_gpio gpio;

/* The NUCLEO-L476RG table shape: XSHUT on PA10 PB3 PB5 PB4, GPIO1 on PB10 PA8 PA9 PC7. */
static void make_table(void) {
    const uintptr_t a = fake_port_base('A'), b = fake_port_base('B'), c = fake_port_base('C');
    const struct stm32_pin table[8] = {
        {a, 10u, STM32_PIN_OUTPUT_OPEN_DRAIN}, {b, 3u, STM32_PIN_OUTPUT_OPEN_DRAIN},
        {b, 5u, STM32_PIN_OUTPUT_OPEN_DRAIN},  {b, 4u, STM32_PIN_OUTPUT_OPEN_DRAIN},
        {b, 10u, STM32_PIN_INPUT_PULL_UP},     {a, 8u, STM32_PIN_INPUT_PULL_UP},
        {a, 9u, STM32_PIN_INPUT_PULL_UP},      {c, 7u, STM32_PIN_INPUT_PULL_UP},
    };
    memcpy(pins, table, sizeof pins);
    gpio = (struct stm32_gpio){pins, 8u};
}

static uint32_t field(char port, uint32_t offset, uint32_t pin, uint32_t width) {
    return (fake_port_reg(port, offset) >> (width * pin)) & ((1u << width) - 1u);
}

static void test_gpio_configure_sets_roles(void **state) {
    (void)state;
    make_table();
    /* Reset state: analog mode everywhere, ODR high so "low first" is visible. */
    fake.port_a.regs[0] = 0xFFFFFFFFu;
    fake.port_b.regs[0] = 0xFFFFFFFFu;
    fake.port_c.regs[0] = 0xFFFFFFFFu;
    fake.port_a.regs[5] = 0xFFFFu;
    fake.port_b.regs[5] = 0xFFFFu;
    assert_int_equal(stm32_gpio_configure(&gpio), HAL_OK);

    assert_int_equal(field('A', STM32_GPIO_MODER, 10u, 2u), STM32_GPIO_MODE_OUTPUT);
    assert_int_equal(field('A', STM32_GPIO_OTYPER, 10u, 1u), 1u);
    assert_int_equal(field('A', STM32_GPIO_ODR, 10u, 1u), 0u); /* XSHUT low: sensor off */
    assert_int_equal(field('B', STM32_GPIO_MODER, 3u, 2u), STM32_GPIO_MODE_OUTPUT);
    assert_int_equal(field('B', STM32_GPIO_ODR, 4u, 1u), 0u);
    assert_int_equal(field('B', STM32_GPIO_MODER, 10u, 2u), STM32_GPIO_MODE_INPUT);
    assert_int_equal(field('B', STM32_GPIO_PUPDR, 10u, 2u), STM32_GPIO_PULL_UP);
    assert_int_equal(field('C', STM32_GPIO_MODER, 7u, 2u), STM32_GPIO_MODE_INPUT);
    /* Neighbours untouched. */
    assert_int_equal(field('A', STM32_GPIO_MODER, 11u, 2u), STM32_GPIO_MODE_ANALOG);
    assert_int_equal(field('C', STM32_GPIO_MODER, 6u, 2u), STM32_GPIO_MODE_ANALOG);
    assert_int_equal(field('A', STM32_GPIO_ODR, 9u, 1u), 1u);
}

static void test_gpio_configure_rejects_bad_table(void **state) {
    (void)state;
    make_table();
    pins[2].pin = 16u;
    assert_int_equal(stm32_gpio_configure(&gpio), HAL_ERR_INVALID);
    make_table();
    pins[5].role = 9u;
    assert_int_equal(stm32_gpio_configure(&gpio), HAL_ERR_INVALID);
}

static void test_gpio_numbered_write_and_read(void **state) {
    (void)state;
    make_table();
    assert_int_equal(stm32_gpio_configure(&gpio), HAL_OK);
    const struct hal_gpio hal = {&stm32_gpio_hal_ops, &gpio};

    assert_int_equal(hal.ops->write(hal.ctx, 3u, true), HAL_OK); /* XSHUT D = PB4 */
    assert_int_equal(field('B', STM32_GPIO_ODR, 4u, 1u), 1u);
    assert_int_equal(field('B', STM32_GPIO_ODR, 5u, 1u), 0u);
    assert_int_equal(hal.ops->write(hal.ctx, 3u, false), HAL_OK);
    assert_int_equal(field('B', STM32_GPIO_ODR, 4u, 1u), 0u);

    /* Inputs and unknown pins cannot be written. */
    assert_int_equal(hal.ops->write(hal.ctx, 4u, true), HAL_ERR_INVALID);
    assert_int_equal(hal.ops->write(hal.ctx, 8u, true), HAL_ERR_INVALID);

    /* GPIO1 B = PA8 pulled low by its sensor; the others read high. */
    fake.port_a.external_low = 1u << 8;
    bool level = true;
    assert_int_equal(hal.ops->read(hal.ctx, 5u, &level), HAL_OK);
    assert_false(level);
    assert_int_equal(hal.ops->read(hal.ctx, 6u, &level), HAL_OK);
    assert_true(level);
    /* An output reads back its line level. */
    assert_int_equal(hal.ops->read(hal.ctx, 0u, &level), HAL_OK);
    assert_false(level);
    assert_int_equal(hal.ops->read(hal.ctx, 8u, &level), HAL_ERR_INVALID);
    assert_int_equal(hal.ops->read(hal.ctx, 4u, NULL), HAL_ERR_INVALID);
}

/* ---------------------------------------------------------------- SysTick */

#define RELOAD_16MHZ 15999u

static void test_systick_init(void **state) {
    (void)state;
    struct stm32_systick_time t;
    assert_int_equal(stm32_systick_time_init(&t, 16000000u), HAL_OK);
    assert_int_equal(fake.systick.rvr, RELOAD_16MHZ);
    assert_int_equal(fake.systick.csr, CORTEX_M_SYST_CSR_CLKSOURCE | CORTEX_M_SYST_CSR_TICKINT |
                                           CORTEX_M_SYST_CSR_ENABLE);
    assert_int_equal(t.cycles_per_us, 16u);
    assert_int_equal(t.tick_base_us, 0u);
    assert_int_equal(stm32_systick_time_init(&t, 0u), HAL_ERR_INVALID);
    assert_int_equal(stm32_systick_time_init(&t, 16500000u), HAL_ERR_INVALID);
    assert_int_equal(stm32_systick_time_init(NULL, 16000000u), HAL_ERR_INVALID);
}

static void test_systick_now_reads_counter(void **state) {
    (void)state;
    struct stm32_systick_time t;
    assert_int_equal(stm32_systick_time_init(&t, 16000000u), HAL_OK);
    t.tick_base_us = 5000u;
    /* 300 us into the millisecond: 4800 cycles since the tick at VAL = 0. */
    fake.systick.cvr_queue[0] = RELOAD_16MHZ + 1u - 4800u;
    fake.systick.cvr_queue[1] = RELOAD_16MHZ + 1u - 4810u;
    fake.systick.cvr_len = 2u;
    assert_int_equal(stm32_systick_time_now_us(&t), 5300u);

    /* A tick the ISR has not counted yet: the second read is after it. */
    fake.systick.cvr_next = 0u;
    fake.systick.cvr_queue[0] = 3u;                 /* just before the tick */
    fake.systick.cvr_queue[1] = RELOAD_16MHZ - 31u; /* 32 cycles after it */
    fake.systick.pending = true;
    assert_int_equal(stm32_systick_time_now_us(&t), 6002u);

    /* The ISR then counts it: same time base, no jump back. */
    stm32_systick_time_tick(&t);
    fake.systick.pending = false;
    fake.systick.cvr_next = 0u;
    fake.systick.cvr_queue[0] = RELOAD_16MHZ - 40u;
    fake.systick.cvr_queue[1] = RELOAD_16MHZ - 41u;
    assert_int_equal(stm32_systick_time_now_us(&t), 6002u);
}

/* Sweep a simulated counter through several milliseconds with the ISR
 * running 700 cycles late: the composed time never goes back and
 * stays within one microsecond below the true time. */
static void test_systick_compose_is_monotonic(void **state) {
    (void)state;
    const uint32_t reload = RELOAD_16MHZ;
    const uint32_t period = reload + 1u;
    uint32_t base = 0xFFFFF000u; /* crosses the uint32 wrap during the sweep */
    const uint32_t base0 = base;
    uint32_t counted_ticks = 0u;
    uint32_t last = 0u;
    bool first = true;
    for (uint32_t cycle = 0; cycle < 6u * period; ++cycle) { /* every cycle, ticks included */
        /* The counter reached 0 at cycle k*period + reload (tick k+1). */
        const uint32_t ticks_happened = (cycle + 1u) / period;
        const uint32_t since_tick = (cycle + 1u) % period;
        const uint32_t val = since_tick == 0u ? 0u : period - since_tick;
        /* The ISR counts a tick 700 cycles late. */
        while (counted_ticks < ticks_happened &&
               cycle >= (counted_ticks + 1u) * period - 1u + 700u) {
            counted_ticks++;
            base += 1000u;
        }
        const bool pending = counted_ticks < ticks_happened;
        assert_true(ticks_happened - counted_ticks <= 1u);
        const uint32_t now = stm32_systick_compose_us(base, val, pending, val, reload, 16u);
        const uint32_t truth = (cycle + 1u) / 16u; /* us since base0 (tick 0 at cycle -1) */
        const uint32_t got = now - base0;
        assert_true(got <= truth);
        assert_true(truth - got <= 1u);
        if (!first) {
            assert_true((uint32_t)(now - last) < 0x80000000u); /* never backwards */
        }
        last = now;
        first = false;
    }
}

static void test_systick_elapsed_across_wrap(void **state) {
    (void)state;
    struct stm32_systick_time t;
    assert_int_equal(stm32_systick_time_init(&t, 16000000u), HAL_OK);
    t.tick_base_us = 0xFFFFFC18u; /* 2^32 - 1000 */
    fake.systick.cvr_default = RELOAD_16MHZ + 1u - 16u * 900u;
    const uint32_t before = stm32_systick_time_now_us(&t);
    stm32_systick_time_tick(&t); /* wraps to 0 */
    assert_int_equal(t.tick_base_us, 0u);
    fake.systick.cvr_default = RELOAD_16MHZ + 1u - 16u * 50u;
    const uint32_t after = stm32_systick_time_now_us(&t);
    assert_int_equal(hal_time_elapsed_us(after, before), 150u);
}

static void test_systick_delay_waits_and_is_bounded(void **state) {
    (void)state;
    struct stm32_systick_time t;
    assert_int_equal(stm32_systick_time_init(&t, 16000000u), HAL_OK);

    /* A stopped counter: the delay still returns, after at most us x 16 polls. */
    fake.systick.cvr_default = 8000u;
    stm32_systick_time_delay_us(&t, 50u);
    assert_true(fake.systick.cvr_reads <= 2u * (50u * 16u + 2u));
    assert_true(fake.systick.cvr_reads >= 2u * 50u * 16u);

    /* A running counter: each queued value is 128 cycles (8 us) after the
     * previous one; now_us() takes two of them and uses the first. */
    uint32_t val = RELOAD_16MHZ;
    for (size_t i = 0; i < FAKE_CVR_QUEUE; ++i) {
        fake.systick.cvr_queue[i] = val;
        val -= 8u * 16u;
    }
    fake.systick.cvr_len = FAKE_CVR_QUEUE;
    fake.systick.cvr_next = 0u;
    stm32_systick_time_delay_us(&t, 20u);
    /* The last now_us() used entry used-2, 8 us per entry after entry 0. */
    const size_t used = fake.systick.cvr_next;
    assert_true(used >= 4u && used % 2u == 0u);
    assert_true((used - 2u) * 8u > 20u);  /* waited at least 20 us */
    assert_true((used - 4u) * 8u <= 20u); /* and stopped at the first reading past it */
    stm32_systick_time_delay_us(&t, 0u);  /* returns at once */
}

/* ---------------------------------------------------------------- IWDG */

static const struct stm32_iwdg_config iwdg_cfg_template = {0u, 3u, 399u};

static void test_iwdg_start_sequence(void **state) {
    (void)state;
    struct stm32_iwdg_config cfg = iwdg_cfg_template;
    cfg.base = fake_iwdg_base();
    struct stm32_iwdg wdg;
    fake.iwdg.sr_busy_reads = 3u;
    const struct hal_time time = fake_time_hal();
    assert_int_equal(stm32_iwdg_start(&wdg, &cfg, &time, 10000u), HAL_OK);
    assert_int_equal(fake.iwdg.kr_len, 3u);
    assert_int_equal(fake.iwdg.kr_log[0], STM32_IWDG_KEY_START);
    assert_int_equal(fake.iwdg.kr_log[1], STM32_IWDG_KEY_UNLOCK);
    assert_int_equal(fake.iwdg.kr_log[2], STM32_IWDG_KEY_RELOAD);
    assert_int_equal(fake.iwdg.regs[1], 3u);   /* PR: /32 */
    assert_int_equal(fake.iwdg.regs[2], 399u); /* RLR: 400 ms at 32 kHz */
    assert_int_equal(fake.iwdg.sr_reads, 4u);  /* waited for the update */

    const struct hal_watchdog hal = {&stm32_iwdg_ops, &wdg};
    hal.ops->kick(hal.ctx);
    assert_int_equal(fake.iwdg.kr_len, 4u);
    assert_int_equal(fake.iwdg.kr_log[3], STM32_IWDG_KEY_RELOAD);
}

static void test_iwdg_update_that_never_lands_times_out(void **state) {
    (void)state;
    struct stm32_iwdg_config cfg = iwdg_cfg_template;
    cfg.base = fake_iwdg_base();
    struct stm32_iwdg wdg;
    fake.iwdg.sr_busy_reads = UINT32_MAX;
    const struct hal_time time = fake_time_hal();
    assert_int_equal(stm32_iwdg_start(&wdg, &cfg, &time, 1000u), HAL_ERR_TIMEOUT);
    assert_true(fake.iwdg.sr_reads <= 1001u);
    assert_int_equal(fake.iwdg.kr_log[fake.iwdg.kr_len - 1u], STM32_IWDG_KEY_RELOAD);

    /* With a stopped clock the read bound still ends it. */
    fake_reset(0x29, 0u);
    fake.time.step_us = 0u;
    fake.iwdg.sr_busy_reads = UINT32_MAX;
    assert_int_equal(stm32_iwdg_start(&wdg, &cfg, &time, 1000u), HAL_ERR_TIMEOUT);
    assert_int_equal(fake.iwdg.sr_reads, 1001u);
}

static void test_iwdg_rejects_bad_config(void **state) {
    (void)state;
    struct stm32_iwdg_config cfg = iwdg_cfg_template;
    cfg.base = fake_iwdg_base();
    struct stm32_iwdg wdg;
    const struct hal_time time = fake_time_hal();
    cfg.prescaler_code = 7u;
    assert_int_equal(stm32_iwdg_start(&wdg, &cfg, &time, 1000u), HAL_ERR_INVALID);
    cfg.prescaler_code = 3u;
    cfg.reload = 0x1000u;
    assert_int_equal(stm32_iwdg_start(&wdg, &cfg, &time, 1000u), HAL_ERR_INVALID);
    assert_int_equal(fake.iwdg.kr_len, 0u); /* never started */
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_gpio_configure_sets_roles, setup),
        cmocka_unit_test_setup(test_gpio_configure_rejects_bad_table, setup),
        cmocka_unit_test_setup(test_gpio_numbered_write_and_read, setup),
        cmocka_unit_test_setup(test_systick_init, setup),
        cmocka_unit_test_setup(test_systick_now_reads_counter, setup),
        cmocka_unit_test_setup(test_systick_compose_is_monotonic, setup),
        cmocka_unit_test_setup(test_systick_elapsed_across_wrap, setup),
        cmocka_unit_test_setup(test_systick_delay_waits_and_is_bounded, setup),
        cmocka_unit_test_setup(test_iwdg_start_sequence, setup),
        cmocka_unit_test_setup(test_iwdg_update_that_never_lands_times_out, setup),
        cmocka_unit_test_setup(test_iwdg_rejects_bad_config, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
