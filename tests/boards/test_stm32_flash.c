/*
 * The STM32L4 flash record driver (boards/stm32/stm32_flash.c) against the flash fake
 * (fake_stm32_flash.c): the unlock sequence, page erase and double-word programming in
 * the reference manual's order with no forbidden access, error flags cleared before and
 * reported after, BSY bounded, ECC double errors reported, and the record store on top.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "fake_stm32.h"
#include "fake_stm32_flash.h"
#include "firmware/record.h"
#include "hal/hal_err.h"
#include "stm32_flash.h"
#include "stm32_flash_regs.h"

static struct stm32_flash_config cfg;
static struct stm32_flash flash;
static struct hal_records rec;

static int setup(void **state) {
    (void)state;
    fake_reset(0x29, 0u);
    fake_flash_reset(254u, true); /* the NUCLEO-L476RG's: bank 2, pages 254 and 255 */
    cfg = (struct stm32_flash_config){.regs = fake_flash_regs(),
                                      .memory = fake_flash_memory(),
                                      .first_page = 254u,
                                      .pages = 2u,
                                      .bank2 = true,
                                      .erase_budget_us = 40000u,
                                      .program_budget_us = 1000u,
                                      .time = fake_time_hal()};
    assert_int_equal(stm32_flash_init(&flash, &cfg), HAL_OK);
    rec = stm32_flash_hal(&flash);
    return 0;
}

static bool locked(void) {
    return (fake_flash.regs[STM32_FLASH_CR / 4u] & STM32_FLASH_CR_LOCK) != 0u;
}

/* A page erase as a user of the driver waits for one: started, then polled to its end (the
 * driver has no blocking erase: the firmware never waits ~22 ms for one). */
static int erase(uint16_t page) {
    int rc = rec.ops->erase_start(rec.ctx, page);
    for (unsigned n = 0; rc == HAL_OK && n < 1000000u; ++n) {
        const int p = rec.ops->erase_poll(rec.ctx);
        if (p != HAL_ERR_NOT_READY) {
            return p;
        }
    }
    return rc == HAL_OK ? HAL_ERR_TIMEOUT : rc;
}

static void test_erase_follows_the_sequence(void **state) {
    (void)state;
    memset(fake_flash.mem[1], 0x00, FAKE_FLASH_PAGE_SIZE);
    assert_int_equal(erase(1u), HAL_OK);
    assert_int_equal(fake_flash.erases, 1u);
    const uint32_t cr = fake_flash.last_erase_cr;
    assert_true((cr & STM32_FLASH_CR_PER) != 0u);
    assert_true((cr & STM32_FLASH_CR_BKER) != 0u);
    assert_int_equal((cr & STM32_FLASH_CR_PNB_MASK) >> STM32_FLASH_CR_PNB_SHIFT, 255u);
    for (unsigned i = 0; i < FAKE_FLASH_PAGE_SIZE; ++i) {
        assert_int_equal(fake_flash.mem[1][i], 0xFF);
    }
    assert_true(locked()); /* locked again after the operation */
    assert_int_equal(fake_flash.unlocks, 1u);
    assert_true(fake_flash.dcache_reset);
    assert_int_equal(fake_flash.regs[STM32_FLASH_SR / 4u], 0u); /* EOP cleared */
    assert_int_equal(fake_flash.violations, 0u);
    assert_int_equal(erase(2u), HAL_ERR_INVALID);
    /* started, the erase runs while the caller goes on: BSY polled, one erase at a time */
    assert_int_equal(rec.ops->erase_start(rec.ctx, 0u), HAL_OK);
    assert_int_equal(rec.ops->erase_poll(rec.ctx), HAL_ERR_NOT_READY);
    assert_int_equal(rec.ops->erase_start(rec.ctx, 1u), HAL_ERR_INVALID);
    int rc = HAL_ERR_NOT_READY;
    for (unsigned n = 0; rc == HAL_ERR_NOT_READY && n < 100u; ++n) {
        rc = rec.ops->erase_poll(rec.ctx);
    }
    assert_int_equal(rc, HAL_OK);
    assert_true(locked());
    assert_int_equal(rec.ops->erase_poll(rec.ctx), HAL_OK); /* nothing started */
    assert_int_equal(fake_flash.erases, 2u);
}

static void test_program_then_read_back(void **state) {
    (void)state;
    uint8_t data[24], back[24];
    for (unsigned i = 0; i < sizeof data; ++i) {
        data[i] = (uint8_t)(i * 13u + 1u);
    }
    assert_int_equal(rec.ops->program(rec.ctx, 1u, 16u, data, sizeof data), HAL_OK);
    assert_int_equal(fake_flash.programs, 3u);
    assert_memory_equal(&fake_flash.mem[1][16], data, sizeof data);
    assert_int_equal(rec.ops->read(rec.ctx, 1u, 16u, back, sizeof back), HAL_OK);
    assert_memory_equal(back, data, sizeof data);
    uint8_t odd[5];
    assert_int_equal(rec.ops->read(rec.ctx, 1u, 17u, odd, sizeof odd), HAL_OK); /* unaligned */
    assert_memory_equal(odd, &data[1], sizeof odd);
    assert_true(locked());
    assert_int_equal(fake_flash.violations, 0u);
    /* refused before any register access: misaligned, partial, out of the page */
    const uint32_t unlocks = fake_flash.unlocks;
    assert_int_equal(rec.ops->program(rec.ctx, 1u, 4u, data, 8u), HAL_ERR_INVALID);
    assert_int_equal(rec.ops->program(rec.ctx, 1u, 0u, data, 12u), HAL_ERR_INVALID);
    assert_int_equal(rec.ops->program(rec.ctx, 1u, 2044u, data, 8u), HAL_ERR_INVALID);
    assert_int_equal(rec.ops->read(rec.ctx, 0u, 2047u, back, 2u), HAL_ERR_INVALID);
    assert_int_equal(fake_flash.unlocks, unlocks);
}

static void test_programming_a_programmed_double_word_is_reported(void **state) {
    (void)state;
    const uint8_t data[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    assert_int_equal(rec.ops->program(rec.ctx, 0u, 0u, data, 8u), HAL_OK);
    const uint8_t other[16] = {0};
    assert_int_equal(rec.ops->program(rec.ctx, 0u, 0u, other, 16u), HAL_ERR_DEVICE);
    assert_true((flash.last_sr_errors & STM32_FLASH_SR_PROGERR) != 0u);
    assert_memory_equal(fake_flash.mem[0], data, 8u); /* unchanged */
    assert_int_equal(fake_flash.mem[0][8], 0xFF);     /* and nothing after it written */
    assert_int_equal(fake_flash.regs[STM32_FLASH_SR / 4u] & STM32_FLASH_SR_ERRORS, 0u);
    assert_true(locked());
}

static void test_stale_flags_are_cleared_and_new_ones_reported(void **state) {
    (void)state;
    /* an earlier operation's PGSERR would block the next one on the part: cleared first */
    fake_flash.regs[STM32_FLASH_SR / 4u] = STM32_FLASH_SR_PGSERR | STM32_FLASH_SR_EOP;
    assert_int_equal(erase(0u), HAL_OK);
    fake_flash.inject_sr = STM32_FLASH_SR_WRPERR; /* the page is write protected */
    assert_int_equal(erase(0u), HAL_ERR_DEVICE);
    assert_int_equal(flash.last_sr_errors, STM32_FLASH_SR_WRPERR);
    assert_int_equal(fake_flash.regs[STM32_FLASH_SR / 4u], 0u);
    const uint8_t data[8] = {0};
    fake_flash.inject_sr = STM32_FLASH_SR_PGAERR;
    assert_int_equal(rec.ops->program(rec.ctx, 0u, 0u, data, 8u), HAL_ERR_DEVICE);
    assert_int_equal(flash.last_sr_errors, STM32_FLASH_SR_PGAERR);
    assert_true(locked());
}

static void test_busy_for_ever_times_out(void **state) {
    (void)state;
    fake_flash.busy_reads = UINT32_MAX;
    const uint32_t t0 = fake.time.now;
    assert_int_equal(erase(0u), HAL_ERR_TIMEOUT);
    assert_true(fake.time.now - t0 <= 2u * 40000u + 10u); /* its budget, not for ever */
    assert_int_equal(fake_flash.violations, 0u);          /* CR left alone while busy */
}

static void test_wrong_key_leaves_it_locked(void **state) {
    (void)state;
    fake_flash.locked_until_reset = true; /* a stray KEYR write earlier */
    assert_int_equal(erase(0u), HAL_ERR_DEVICE);
    assert_int_equal(fake_flash.erases, 0u);
}

static void test_ecc_double_error_is_reported_on_read(void **state) {
    (void)state;
    fake_flash.ecc_bad[0][2] = true; /* bytes 16..23 of page 0 */
    uint8_t back[8];
    assert_int_equal(rec.ops->read(rec.ctx, 0u, 0u, back, 8u), HAL_OK);
    assert_int_equal(rec.ops->read(rec.ctx, 0u, 16u, back, 8u), HAL_ERR_CORRUPT);
    assert_int_equal(flash.ecc_errors, 1u);
    assert_int_equal(fake_flash.regs[STM32_FLASH_ECCR / 4u] & STM32_FLASH_ECCR_ECCD, 0u);
    assert_int_equal(rec.ops->read(rec.ctx, 0u, 0u, back, 8u), HAL_OK); /* cleared */
    /* the NMI a read of it raises on the part: the handler clears ECCD, the read reports */
    fake_flash.regs[STM32_FLASH_ECCR / 4u] |= STM32_FLASH_ECCR_ECCD;
    assert_true(stm32_flash_nmi(fake_flash_regs()));
    /* the read above found ECCD before its NMI ran: that NMI is taken as the flash's too */
    assert_true(stm32_flash_nmi(fake_flash_regs()));
    assert_false(stm32_flash_nmi(fake_flash_regs())); /* anything else is not */
}

static void test_record_store_on_the_driver(void **state) {
    (void)state;
    static struct tof_record_store store;
    assert_int_equal(tof_record_init(&store, rec, 0u, 1u), HAL_OK);
    assert_int_equal(tof_record_load(&store), TOF_RECORD_NONE);
    const uint8_t p[20] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20};
    assert_int_equal(tof_record_save(&store, p, sizeof p), HAL_OK);
    assert_int_equal(tof_record_save(&store, p, 10u), HAL_OK);
    assert_int_equal(tof_record_load(&store), TOF_RECORD_LOADED);
    assert_int_equal(store.length, 10u);
    assert_int_equal(store.sequence, 1u);
    assert_int_equal(fake_flash.violations, 0u);
    assert_true(locked());
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_erase_follows_the_sequence, setup),
        cmocka_unit_test_setup(test_program_then_read_back, setup),
        cmocka_unit_test_setup(test_programming_a_programmed_double_word_is_reported, setup),
        cmocka_unit_test_setup(test_stale_flags_are_cleared_and_new_ones_reported, setup),
        cmocka_unit_test_setup(test_busy_for_ever_times_out, setup),
        cmocka_unit_test_setup(test_wrong_key_leaves_it_locked, setup),
        cmocka_unit_test_setup(test_ecc_double_error_is_reported_on_read, setup),
        cmocka_unit_test_setup(test_record_store_on_the_driver, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
