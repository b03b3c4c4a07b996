/*
 * The STM32 I2Cv2 driver (boards/stm32/stm32_i2c.c, compiled unchanged with
 * STM32_REG_HOOKS) against the register-level fake of fake_stm32.c: transfer
 * sequences, error classification, time budgets (with a running and with a
 * stopped clock) and bus recovery on the open-drain line model.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "fake_stm32.h"
#include "hal/hal_err.h"
#include "stm32_gpio_regs.h"
#include "stm32_i2c.h"
#include "stm32_i2c_regs.h"

#define DEV       0x29        /* VL53L1X default address */
#define START_US  0xFFFFFF00u /* near the uint32 wrap: budgets must be wrap-safe */
#define BYTE_US   23u
#define CYCLES_US 16u
#define HALF_US   5u

static struct stm32_i2c_config cfg;
static struct stm32_i2c bus;

static int setup(void **state) {
    (void)state;
    fake_reset(DEV, START_US);
    cfg = (struct stm32_i2c_config){
        .base = fake_i2c_base(),
        .timingr = STM32_I2C_TIMINGR_400KHZ_AT_16MHZ,
        .byte_time_us = BYTE_US,
        .core_cycles_per_us = CYCLES_US,
        .recovery_half_period_us = HALF_US,
        .scl = {fake_port_base('B'), 8u, 4u},
        .sda = {fake_port_base('B'), 9u, 4u},
        .time = fake_time_hal(),
    };
    assert_int_equal(stm32_i2c_init(&bus, &cfg), HAL_OK);
    assert_int_equal(fake.i2c.protocol_errors, 0u);
    fake.i2c.log_len = 0u;
    fake.i2c.isr_reads = 0u;
    return 0;
}

/* Budget of a transfer as the driver promises it: timeout plus byte times. */
static uint32_t budget_us(uint32_t timeout_us, size_t tx_len, size_t rx_len) {
    return timeout_us + (uint32_t)(tx_len + rx_len + 2u) * BYTE_US;
}

static uint32_t pin_mode(uint32_t pin) {
    return (fake_port_reg('B', STM32_GPIO_MODER) >> (2u * pin)) & 3u;
}

static uint32_t pin_af(uint32_t pin) {
    return (fake_port_reg('B', STM32_GPIO_AFRH) >> (4u * (pin - 8u))) & 0xFu;
}

static void test_init_programs_timing_pins_and_enable(void **state) {
    (void)state;
    assert_int_equal(fake_i2c_reg(STM32_I2C_TIMINGR), 0x10320309u);
    assert_int_equal(fake_i2c_reg(STM32_I2C_CR1), STM32_I2C_CR1_PE);
    for (uint32_t pin = 8u; pin <= 9u; ++pin) {
        assert_int_equal(pin_mode(pin), STM32_GPIO_MODE_AF);
        assert_int_equal(pin_af(pin), 4u);
        assert_true((fake_port_reg('B', STM32_GPIO_OTYPER) & (1u << pin)) != 0u);
        assert_int_equal((fake_port_reg('B', STM32_GPIO_PUPDR) >> (2u * pin)) & 3u,
                         STM32_GPIO_PULL_UP);
    }
}

static void test_init_rejects_bad_config(void **state) {
    (void)state;
    struct stm32_i2c other;
    struct stm32_i2c_config bad = cfg;
    bad.time.ops = NULL;
    assert_int_equal(stm32_i2c_init(&other, &bad), HAL_ERR_INVALID);
    bad = cfg;
    bad.byte_time_us = 0u;
    assert_int_equal(stm32_i2c_init(&other, &bad), HAL_ERR_INVALID);
    bad = cfg;
    bad.sda.pin = 16u;
    assert_int_equal(stm32_i2c_init(&other, &bad), HAL_ERR_INVALID);
    assert_int_equal(stm32_i2c_init(NULL, &cfg), HAL_ERR_INVALID);
}

static void test_write_only_ends_with_stop(void **state) {
    (void)state;
    const uint8_t tx[3] = {0x01, 0x0F, 0x55};
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, 3u, NULL, 0u, 1000u), HAL_OK);
    assert_int_equal(fake.i2c.log_len, 5u);
    assert_int_equal(fake.i2c.log[0].kind, EV_START);
    const uint32_t cr2 = fake.i2c.log[0].value;
    assert_int_equal(cr2 & 0x3FFu, (uint32_t)DEV << 1);
    assert_int_equal((cr2 >> STM32_I2C_CR2_NBYTES_SHIFT) & 0xFFu, 3u);
    assert_true((cr2 & STM32_I2C_CR2_AUTOEND) != 0u);
    assert_true((cr2 & STM32_I2C_CR2_RD_WRN) == 0u);
    for (size_t i = 0; i < 3u; ++i) {
        assert_int_equal(fake.i2c.log[1 + i].kind, EV_BYTE_OUT);
        assert_int_equal(fake.i2c.log[1 + i].value, tx[i]);
    }
    assert_int_equal(fake.i2c.log[4].kind, EV_STOP);
    assert_int_equal(fake.i2c.protocol_errors, 0u);
    assert_int_equal(fake.i2c.software_resets, 0u);
    assert_int_equal(bus.stats.transfers, 1u);
    /* STOPF cleared for the next transfer. */
    assert_true((fake_i2c_reg(STM32_I2C_ISR) & STM32_I2C_ISR_STOPF) == 0u);
}

static void test_write_then_read_uses_repeated_start(void **state) {
    (void)state;
    const uint8_t index[2] = {0x01, 0x0F};
    uint8_t rx[4] = {0};
    fake.i2c.script.rx_data[0] = 0xEA;
    fake.i2c.script.rx_data[1] = 0xCC;
    fake.i2c.script.rx_data[2] = 0x10;
    fake.i2c.script.rx_data[3] = 0x02;
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, index, 2u, rx, 4u, 1000u), HAL_OK);
    const uint8_t expect[4] = {0xEA, 0xCC, 0x10, 0x02};
    assert_memory_equal(rx, expect, 4u);

    /* S addr+W b b Sr addr+R b b b b P: exactly one STOP, at the very end. */
    assert_int_equal(fake.i2c.log_len, 9u);
    assert_int_equal(fake.i2c.log[0].kind, EV_START);
    assert_true((fake.i2c.log[0].value & STM32_I2C_CR2_AUTOEND) == 0u);
    assert_int_equal(fake.i2c.log[3].kind, EV_RESTART);
    const uint32_t cr2 = fake.i2c.log[3].value;
    assert_true((cr2 & STM32_I2C_CR2_RD_WRN) != 0u);
    assert_true((cr2 & STM32_I2C_CR2_AUTOEND) != 0u);
    assert_int_equal((cr2 >> STM32_I2C_CR2_NBYTES_SHIFT) & 0xFFu, 4u);
    assert_int_equal(fake_i2c_count(EV_STOP), 1u);
    assert_int_equal(fake_i2c_find(EV_STOP, 0u), 8);
    assert_int_equal(fake.i2c.protocol_errors, 0u);
}

static void test_read_only(void **state) {
    (void)state;
    uint8_t rx[2] = {0};
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, NULL, 0u, rx, 2u, 1000u), HAL_OK);
    assert_int_equal(rx[0], 0xA0);
    assert_int_equal(rx[1], 0xA1);
    assert_int_equal(fake.i2c.log[0].kind, EV_START);
    assert_true((fake.i2c.log[0].value & STM32_I2C_CR2_RD_WRN) != 0u);
    assert_int_equal(fake_i2c_count(EV_STOP), 1u);
}

static void test_long_transfers_use_reload(void **state) {
    (void)state;
    static uint8_t tx[600];
    static uint8_t rx[300];
    for (size_t i = 0; i < sizeof tx; ++i) {
        tx[i] = (uint8_t)(i * 7u);
    }
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, sizeof tx, rx, sizeof rx, 1000u), HAL_OK);
    assert_int_equal(fake_i2c_count(EV_BYTE_OUT), 600u);
    assert_int_equal(fake_i2c_count(EV_BYTE_IN), 300u);
    assert_int_equal(fake_i2c_count(EV_START), 1u);
    assert_int_equal(fake_i2c_count(EV_RESTART), 1u);
    assert_int_equal(fake_i2c_count(EV_STOP), 1u);
    assert_true((fake.i2c.log[0].value & STM32_I2C_CR2_RELOAD) != 0u);
    assert_int_equal((fake.i2c.log[0].value >> STM32_I2C_CR2_NBYTES_SHIFT) & 0xFFu, 255u);
    size_t out = 0;
    for (size_t i = 0; i < fake.i2c.log_len; ++i) {
        if (fake.i2c.log[i].kind == EV_BYTE_OUT) {
            assert_int_equal(fake.i2c.log[i].value, tx[out]);
            ++out;
        }
    }
    for (size_t i = 0; i < sizeof rx; ++i) {
        assert_int_equal(rx[i], fake.i2c.script.rx_data[i]);
    }
    assert_int_equal(fake.i2c.protocol_errors, 0u);
}

static void test_reload_chunk_boundaries(void **state) {
    (void)state;
    static uint8_t tx[511];
    const size_t sizes[5] = {1u, 255u, 256u, 510u, 511u};
    for (size_t k = 0; k < 5u; ++k) {
        fake.i2c.log_len = 0u;
        assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, sizes[k], NULL, 0u, 100u), HAL_OK);
        assert_int_equal(fake_i2c_count(EV_BYTE_OUT), sizes[k]);
        assert_int_equal(fake_i2c_count(EV_STOP), 1u);
        const uint32_t cr2 = fake.i2c.log[0].value;
        assert_int_equal((cr2 & STM32_I2C_CR2_RELOAD) != 0u, sizes[k] > 255u);
        assert_int_equal((cr2 & STM32_I2C_CR2_AUTOEND) != 0u, sizes[k] <= 255u);
    }
    assert_int_equal(fake.i2c.protocol_errors, 0u);
}

static void test_flags_arriving_late_are_waited_for(void **state) {
    (void)state;
    fake.i2c.script.latency = 9u;
    const uint8_t tx[2] = {0x00, 0x8F};
    uint8_t rx[2] = {0};
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, 2u, rx, 2u, 1000u), HAL_OK);
    assert_int_equal(rx[1], 0xA1);
    assert_true(fake.i2c.isr_reads > 9u * 6u); /* really polled through each delay */
    assert_int_equal(fake.i2c.protocol_errors, 0u);
}

static void test_address_nack(void **state) {
    (void)state;
    fake.i2c.script.present_addr = 0x52; /* nobody at DEV */
    const uint8_t tx[2] = {0x01, 0x0F};
    uint8_t rx[1];
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, 2u, rx, 1u, 1000u), HAL_ERR_ADDR_NACK);
    assert_int_equal(fake_i2c_count(EV_BYTE_OUT), 0u);
    assert_int_equal(fake_i2c_count(EV_RESTART), 0u); /* no read phase after a failed write */
    assert_int_equal(bus.stats.addr_nacks, 1u);
    assert_int_equal(bus.stats.data_nacks, 0u);
    /* The automatic STOP was waited for; no reset needed; flags cleared. */
    assert_int_equal(fake.i2c.software_resets, 0u);
    assert_true((fake_i2c_reg(STM32_I2C_ISR) & (STM32_I2C_ISR_NACKF | STM32_I2C_ISR_STOPF)) == 0u);

    /* Read-only transfer to an absent device: address NACK too. */
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, NULL, 0u, rx, 1u, 1000u), HAL_ERR_ADDR_NACK);
    assert_int_equal(bus.stats.addr_nacks, 2u);
}

static void test_data_nack_first_and_later_bytes(void **state) {
    (void)state;
    const uint8_t tx[4] = {1, 2, 3, 4};
    /* The address was acknowledged (TXIS came), then the first byte was NACKed. */
    fake.i2c.script.nack_byte = 0;
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, 4u, NULL, 0u, 1000u), HAL_ERR_DATA_NACK);
    assert_int_equal(fake_i2c_count(EV_BYTE_OUT), 1u);

    fake.i2c.log_len = 0u;
    fake.i2c.script.nack_byte = 2;
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, 4u, NULL, 0u, 1000u), HAL_ERR_DATA_NACK);
    assert_int_equal(fake_i2c_count(EV_BYTE_OUT), 3u);
    assert_int_equal(bus.stats.data_nacks, 2u);
    assert_int_equal(bus.stats.addr_nacks, 0u);
    assert_int_equal(fake.i2c.protocol_errors, 0u);
    /* The automatic STOP after the NACK was waited for: no reset, TXDR
     * flushed, flags clear. */
    assert_int_equal(fake.i2c.software_resets, 0u);
    assert_int_equal(fake.i2c.txdr_flushes, 2u);
    assert_true((fake_i2c_reg(STM32_I2C_ISR) & (STM32_I2C_ISR_NACKF | STM32_I2C_ISR_STOPF)) == 0u);
}

static void test_data_nack_on_last_byte_skips_read(void **state) {
    (void)state;
    const uint8_t tx[2] = {0x01, 0x0F};
    uint8_t rx[2] = {0x11, 0x22};
    fake.i2c.script.nack_byte = 1;
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, 2u, rx, 2u, 1000u), HAL_ERR_DATA_NACK);
    assert_int_equal(fake_i2c_count(EV_RESTART), 0u);
    assert_int_equal(rx[0], 0x11); /* untouched */
    /* The bus is usable again straight away. */
    fake.i2c.script.nack_byte = FAKE_NONE;
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, 2u, rx, 2u, 1000u), HAL_OK);
    assert_int_equal(rx[0], 0xA0);
}

static void test_arbitration_lost_is_bus_busy(void **state) {
    (void)state;
    fake.i2c.script.arlo_at_address = true;
    const uint8_t tx[1] = {0};
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, 1u, NULL, 0u, 1000u), HAL_ERR_BUS_BUSY);
    assert_int_equal(bus.stats.arbitration_lost, 1u);
    assert_int_equal(fake.i2c.software_resets, 1u); /* TXDR flushed, state machine idle */
    assert_int_equal(fake_i2c_reg(STM32_I2C_CR1) & STM32_I2C_CR1_PE, STM32_I2C_CR1_PE);
}

/* Errata ES0250 "Spurious bus error detection in master mode": BERR is cleared and the
 * transfer completes; no abort, no software reset, no bus recovery. */
static void test_spurious_bus_error_is_cleared_and_ignored(void **state) {
    (void)state;
    fake.i2c.script.berr_at_address = true;
    uint8_t rx[1];
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, NULL, 0u, rx, 1u, 1000u), HAL_OK);
    assert_int_equal(bus.stats.bus_errors, 1u);
    assert_int_equal(fake.i2c.software_resets, 0u);
    assert_int_equal(fake_i2c_reg(STM32_I2C_ISR) & STM32_I2C_ISR_BERR, 0u);
}

static void test_busy_before_start_issues_no_start(void **state) {
    (void)state;
    fake.i2c.regs[6] |= STM32_I2C_ISR_BUSY;
    const uint8_t tx[1] = {0};
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, 1u, NULL, 0u, 1000u), HAL_ERR_BUS_BUSY);
    assert_int_equal(fake.i2c.log_len, 0u);
    assert_int_equal(bus.stats.busy, 1u);
    assert_int_equal(bus.stats.transfers, 0u);
}

static void test_sda_held_low_is_stuck_without_start(void **state) {
    (void)state;
    fake_set_sda_stuck(100u);
    const uint8_t tx[1] = {0};
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, 1u, NULL, 0u, 1000u), HAL_ERR_BUS_STUCK);
    assert_int_equal(fake.i2c.log_len, 0u);
    assert_int_equal(bus.stats.stuck, 1u);
}

static void test_never_txis_times_out_within_budget(void **state) {
    (void)state;
    fake.i2c.script.stall_after_bytes = 0; /* address ACKed, then the slave stretches for ever */
    const uint8_t tx[2] = {1, 2};
    const uint32_t t0 = fake.time.now;
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, 2u, NULL, 0u, 100u), HAL_ERR_TIMEOUT);
    const uint32_t elapsed = fake.time.now - t0; /* wraps: START_US is near 2^32 */
    assert_true(elapsed > budget_us(100u, 2u, 0u));
    assert_true(elapsed <= budget_us(100u, 2u, 0u) + 3u);
    assert_int_equal(bus.stats.timeouts, 1u);
    assert_int_equal(fake.i2c.software_resets, 1u);
    assert_int_equal(fake_i2c_count(EV_BYTE_OUT), 0u);
}

static void test_stall_mid_read_times_out(void **state) {
    (void)state;
    fake.i2c.script.stall_after_bytes = 3; /* 1 index byte written, 2 of 4 read */
    const uint8_t tx[1] = {0x31};
    uint8_t rx[4] = {0};
    const uint32_t t0 = fake.time.now;
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, 1u, rx, 4u, 500u), HAL_ERR_TIMEOUT);
    assert_true(fake.time.now - t0 <= budget_us(500u, 1u, 4u) + 3u);
    assert_int_equal(fake_i2c_count(EV_BYTE_IN), 2u);
    assert_int_equal(fake.i2c.software_resets, 1u);
}

static void test_stopped_clock_still_bounded(void **state) {
    (void)state;
    fake.time.step_us = 0u; /* the time source never advances */
    fake.i2c.script.stall_after_bytes = 0;
    const uint8_t tx[1] = {7};
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, 1u, NULL, 0u, 100u), HAL_ERR_TIMEOUT);
    /* At most budget x cycles-per-us polls (+ the pre-check read + the first poll). */
    const uint32_t max_polls = budget_us(100u, 1u, 0u) * CYCLES_US + 1u;
    assert_true(fake.i2c.isr_reads <= max_polls + 2u);
    assert_true(fake.i2c.isr_reads >= max_polls); /* and it did keep polling till then */
}

static void test_invalid_arguments_touch_nothing(void **state) {
    (void)state;
    uint8_t buf[2] = {0};
    assert_int_equal(stm32_i2c_write_read(&bus, 0x80, buf, 1u, NULL, 0u, 100u), HAL_ERR_INVALID);
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, NULL, 0u, NULL, 0u, 100u), HAL_ERR_INVALID);
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, NULL, 1u, NULL, 0u, 100u), HAL_ERR_INVALID);
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, buf, 1u, NULL, 1u, 100u), HAL_ERR_INVALID);
    assert_int_equal(stm32_i2c_write_read(NULL, DEV, buf, 1u, NULL, 0u, 100u), HAL_ERR_INVALID);
    assert_int_equal(fake.i2c.isr_reads, 0u);
    assert_int_equal(fake.i2c.log_len, 0u);
}

static void test_hal_handle_dispatches(void **state) {
    (void)state;
    const struct hal_i2c i2c = stm32_i2c_hal(&bus);
    const uint8_t tx[1] = {0x42};
    assert_int_equal(i2c.ops->write_read(i2c.ctx, DEV, tx, 1u, NULL, 0u, 100u), HAL_OK);
    assert_int_equal(i2c.ops->recover(i2c.ctx), HAL_OK);
}

/* ---------------------------------------------------------------- recovery */

static void assert_pins_back_to_i2c(void) {
    assert_int_equal(pin_mode(8u), STM32_GPIO_MODE_AF);
    assert_int_equal(pin_mode(9u), STM32_GPIO_MODE_AF);
    assert_int_equal(pin_af(8u), 4u);
    assert_int_equal(pin_af(9u), 4u);
    assert_int_equal(fake_i2c_reg(STM32_I2C_CR1) & STM32_I2C_CR1_PE, STM32_I2C_CR1_PE);
}

static void test_recover_clocks_until_sda_released(void **state) {
    (void)state;
    fake_set_sda_stuck(3u); /* the slave lets go after three more clocks */
    const uint32_t t0 = fake.time.now;
    assert_int_equal(stm32_i2c_recover(&bus), HAL_OK);
    /* SDA is released on the SCL fall after the third rise: four clocks,
     * then the STOP's own SCL rise. */
    assert_int_equal(fake.lines.scl_rises_before_stop, 5u);
    assert_int_equal(fake.lines.stops, 1u);
    assert_true(fake.lines.last_sda && fake.lines.last_scl);
    assert_true(fake.time.now - t0 >= 4u * 2u * HALF_US); /* ~100 kHz bit-banging */
    assert_pins_back_to_i2c();
    assert_int_equal(bus.stats.recoveries, 1u);
    assert_int_equal(bus.stats.recoveries_failed, 0u);

    /* And the bus works afterwards. */
    const uint8_t tx[1] = {1};
    assert_int_equal(stm32_i2c_write_read(&bus, DEV, tx, 1u, NULL, 0u, 100u), HAL_OK);
}

static void test_recover_free_bus_only_sends_stop(void **state) {
    (void)state;
    assert_int_equal(stm32_i2c_recover(&bus), HAL_OK);
    assert_int_equal(fake.lines.scl_rises_before_stop, 1u);
    assert_int_equal(fake.lines.stops, 1u);
    assert_int_equal(fake.lines.starts, 0u); /* SDA only moved while SCL was low */
    assert_pins_back_to_i2c();
}

static void test_recover_sda_stuck_for_good(void **state) {
    (void)state;
    fake_set_sda_stuck(1000u);
    assert_int_equal(stm32_i2c_recover(&bus), HAL_ERR_BUS_STUCK);
    assert_int_equal(fake.lines.scl_rises, 10u); /* nine clocks, then the STOP attempt */
    assert_int_equal(fake.lines.stops, 0u);
    assert_pins_back_to_i2c();
    assert_int_equal(bus.stats.recoveries_failed, 1u);
}

static void test_recover_scl_stuck_is_bounded(void **state) {
    (void)state;
    fake_set_scl_stuck();
    const uint32_t t0 = fake.time.now;
    assert_int_equal(stm32_i2c_recover(&bus), HAL_ERR_BUS_STUCK);
    /* One bounded wait for SCL (1 ms stretch limit) and no clocking after it. */
    assert_true(fake.time.now - t0 <= 1000u + 4u * HALF_US);
    assert_int_equal(fake.lines.scl_rises, 0u);
    assert_pins_back_to_i2c();
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_init_programs_timing_pins_and_enable, setup),
        cmocka_unit_test_setup(test_init_rejects_bad_config, setup),
        cmocka_unit_test_setup(test_write_only_ends_with_stop, setup),
        cmocka_unit_test_setup(test_write_then_read_uses_repeated_start, setup),
        cmocka_unit_test_setup(test_read_only, setup),
        cmocka_unit_test_setup(test_long_transfers_use_reload, setup),
        cmocka_unit_test_setup(test_reload_chunk_boundaries, setup),
        cmocka_unit_test_setup(test_flags_arriving_late_are_waited_for, setup),
        cmocka_unit_test_setup(test_address_nack, setup),
        cmocka_unit_test_setup(test_data_nack_first_and_later_bytes, setup),
        cmocka_unit_test_setup(test_data_nack_on_last_byte_skips_read, setup),
        cmocka_unit_test_setup(test_arbitration_lost_is_bus_busy, setup),
        cmocka_unit_test_setup(test_spurious_bus_error_is_cleared_and_ignored, setup),
        cmocka_unit_test_setup(test_busy_before_start_issues_no_start, setup),
        cmocka_unit_test_setup(test_sda_held_low_is_stuck_without_start, setup),
        cmocka_unit_test_setup(test_never_txis_times_out_within_budget, setup),
        cmocka_unit_test_setup(test_stall_mid_read_times_out, setup),
        cmocka_unit_test_setup(test_stopped_clock_still_bounded, setup),
        cmocka_unit_test_setup(test_invalid_arguments_touch_nothing, setup),
        cmocka_unit_test_setup(test_hal_handle_dispatches, setup),
        cmocka_unit_test_setup(test_recover_clocks_until_sda_released, setup),
        cmocka_unit_test_setup(test_recover_free_bus_only_sends_stop, setup),
        cmocka_unit_test_setup(test_recover_sda_stuck_for_good, setup),
        cmocka_unit_test_setup(test_recover_scl_stuck_is_bounded, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
