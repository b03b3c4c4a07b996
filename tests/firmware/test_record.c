/*
 * The record store (firmware/record.h) and the settings section (firmware/settings.h) on
 * the simulated flash (sim/sim_flash.h): a power cut at every step of a save, clean or
 * torn, leaves the old record or the new one; damaged copies fall back and say why; the
 * sequence number wraps; the flash model refuses what the STM32L4 refuses.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "firmware/record.h"
#include "firmware/settings.h"
#include "hal/hal_err.h"
#include "sim/sim_flash.h"

static struct sim_flash flash;
static struct tof_record_store store;

static int setup(void **state) {
    (void)state;
    assert_int_equal(sim_flash_init(&flash, 2u, 2048u), HAL_OK);
    assert_int_equal(tof_record_init(&store, sim_flash_hal(&flash), 0u, 1u), HAL_OK);
    return 0;
}

/* A payload of `len` bytes that differs per `tag`. */
static void fill(uint8_t *p, uint16_t len, uint8_t tag) {
    for (uint16_t i = 0; i < len; ++i) {
        p[i] = (uint8_t)(tag * 31u + i * 7u);
    }
}

/* A fresh store over the same flash, as after a reboot: what it loads. */
static enum tof_record_state reboot(struct tof_record_store *s) {
    sim_flash_power_on(&flash);
    assert_int_equal(tof_record_init(s, sim_flash_hal(&flash), 0u, 1u), HAL_OK);
    return tof_record_load(s);
}

static void test_flash_model_refuses_what_the_part_refuses(void **state) {
    (void)state;
    const struct hal_records h = sim_flash_hal(&flash);
    const uint8_t dw[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    uint8_t back[8];
    assert_int_equal(h.ops->program(h.ctx, 0u, 4u, dw, 8u), HAL_ERR_INVALID); /* misaligned */
    assert_int_equal(h.ops->program(h.ctx, 0u, 0u, dw, 4u), HAL_ERR_INVALID); /* half */
    assert_int_equal(h.ops->program(h.ctx, 0u, 0u, dw, 8u), HAL_OK);
    assert_int_equal(h.ops->program(h.ctx, 0u, 0u, dw, 8u), HAL_ERR_DEVICE); /* not erased */
    assert_int_equal(h.ops->read(h.ctx, 0u, 0u, back, 8u), HAL_OK);
    assert_memory_equal(back, dw, 8u);
    assert_int_equal(h.ops->erase(h.ctx, 0u), HAL_OK);
    assert_int_equal(h.ops->read(h.ctx, 0u, 0u, back, 8u), HAL_OK);
    for (unsigned i = 0; i < 8u; ++i) {
        assert_int_equal(back[i], 0xFF);
    }
    assert_int_equal(h.ops->erase(h.ctx, 2u), HAL_ERR_INVALID);
    assert_int_equal(h.ops->read(h.ctx, 1u, 2044u, back, 8u), HAL_ERR_INVALID);
    /* a torn program leaves an unreadable double-word that cannot be programmed again */
    sim_flash_cut_after(&flash, 0u, true);
    assert_int_equal(h.ops->program(h.ctx, 0u, 8u, dw, 8u), HAL_OK);
    sim_flash_power_on(&flash);
    assert_int_equal(h.ops->read(h.ctx, 0u, 8u, back, 8u), HAL_ERR_CORRUPT);
    assert_int_equal(h.ops->program(h.ctx, 0u, 8u, dw, 8u), HAL_ERR_DEVICE);
}

static void test_nothing_stored_then_saved_then_loaded(void **state) {
    (void)state;
    assert_int_equal(tof_record_load(&store), TOF_RECORD_NONE);
    uint8_t p[40];
    fill(p, sizeof p, 1u);
    assert_int_equal(tof_record_save(&store, p, sizeof p), HAL_OK);
    struct tof_record_store s2;
    assert_int_equal(reboot(&s2), TOF_RECORD_LOADED);
    assert_int_equal(s2.length, sizeof p);
    assert_memory_equal(s2.payload, p, sizeof p);
    /* the old copy is erased once the new one is verified: one page holds a record */
    uint8_t q[40];
    fill(q, sizeof q, 2u);
    assert_int_equal(tof_record_save(&s2, q, sizeof q), HAL_OK);
    assert_int_equal(reboot(&store), TOF_RECORD_LOADED);
    assert_memory_equal(store.payload, q, sizeof q);
    assert_int_equal(flash.mem[0][0], 0xFF);
    assert_int_not_equal(flash.mem[1][0], 0xFF);
    assert_int_equal(tof_record_save(&store, p, TOF_RECORD_PAYLOAD_MAX + 1u), HAL_ERR_INVALID);
}

/* One sweep: the record `old_tag` in use, a save of `new_tag` cut after n operations. */
static void cut_sweep(bool torn, unsigned saves_before) {
    uint8_t old_p[TOF_RECORD_PAYLOAD_MAX], new_p[TOF_RECORD_PAYLOAD_MAX];
    const uint16_t len = 60u;
    unsigned saw_old = 0, saw_new = 0;
    for (uint32_t n = 0;; ++n) {
        setup(NULL);
        for (unsigned k = 0; k <= saves_before; ++k) {
            fill(old_p, len, (uint8_t)(10u + k));
            assert_int_equal(tof_record_save(&store, old_p, len), HAL_OK);
        }
        fill(new_p, len, 99u);
        const uint32_t ops_before = flash.ops;
        sim_flash_cut_after(&flash, n, torn);
        (void)tof_record_save(&store, new_p, len);
        const bool finished = flash.powered;
        struct tof_record_store s2;
        assert_int_equal(reboot(&s2), TOF_RECORD_LOADED); /* never lost */
        assert_int_equal(s2.length, len);
        const bool is_old = memcmp(s2.payload, old_p, len) == 0;
        const bool is_new = memcmp(s2.payload, new_p, len) == 0;
        assert_true(is_old || is_new); /* never mixed */
        saw_old += is_old;
        saw_new += is_new;
        /* and the store goes on: the next save is loaded */
        fill(new_p, len, 77u);
        assert_int_equal(tof_record_save(&s2, new_p, len), HAL_OK);
        struct tof_record_store s3;
        assert_int_equal(reboot(&s3), TOF_RECORD_LOADED);
        assert_memory_equal(s3.payload, new_p, len);
        if (finished) {
            /* a save: erase, 10 double-words (12 + 60 + 2 bytes -> 80), erase */
            assert_int_equal(flash.ops - ops_before > 0u, true);
            break;
        }
        assert_true(n < 100u);
    }
    assert_true(saw_old > 0u);
    assert_true(saw_new > 0u);
}

static void test_power_cut_at_every_step_keeps_old_or_new(void **state) {
    (void)state;
    cut_sweep(false, 0u); /* old copy on page 0 */
    cut_sweep(false, 1u); /* old copy on page 1 */
    cut_sweep(true, 0u);  /* the step the cut falls in half done */
    cut_sweep(true, 1u);
}

static void save_tag(uint8_t tag, uint16_t len) {
    uint8_t p[TOF_RECORD_PAYLOAD_MAX];
    fill(p, len, tag);
    assert_int_equal(tof_record_save(&store, p, len), HAL_OK);
}

static void test_a_damaged_record_falls_back_and_says_why(void **state) {
    (void)state;
    struct tof_record_store s2;
    save_tag(1u, 20u);
    sim_flash_poke(&flash, 0u, 12u + 5u, 0x10u); /* a payload bit: bad CRC */
    assert_int_equal(reboot(&s2), TOF_RECORD_CORRUPT);
    assert_int_equal(s2.current, -1);

    setup(NULL);
    save_tag(1u, 20u);
    sim_flash_poke(&flash, 0u, 6u, 0x01u); /* length 21: the CRC no longer matches */
    assert_int_equal(reboot(&s2), TOF_RECORD_CORRUPT);
    setup(NULL);
    save_tag(1u, 20u);
    sim_flash_poke(&flash, 0u, 7u, 0x80u); /* length beyond the maximum */
    assert_int_equal(reboot(&s2), TOF_RECORD_CORRUPT);
    setup(NULL);
    save_tag(1u, 20u);
    sim_flash_poke(&flash, 0u, 4u, 0x03u); /* format version 2 */
    assert_int_equal(reboot(&s2), TOF_RECORD_VERSION);
    setup(NULL);
    save_tag(1u, 20u);
    sim_flash_poke(&flash, 0u, 0u, 0x01u); /* magic */
    assert_int_equal(reboot(&s2), TOF_RECORD_CORRUPT);

    /* an older valid copy beside a damaged newer one: the older one is used */
    setup(NULL);
    save_tag(1u, 20u);
    const struct hal_records h = sim_flash_hal(&flash);
    uint8_t old_copy[40];
    assert_int_equal(h.ops->read(h.ctx, 0u, 0u, old_copy, sizeof old_copy), HAL_OK);
    save_tag(2u, 20u); /* on page 1, page 0 erased: put the old copy back */
    assert_int_equal(h.ops->program(h.ctx, 0u, 0u, old_copy, sizeof old_copy), HAL_OK);
    assert_int_equal(reboot(&s2), TOF_RECORD_LOADED);
    uint8_t p[20];
    fill(p, 20u, 2u);
    assert_memory_equal(s2.payload, p, 20u); /* the newer one */
    sim_flash_poke(&flash, 1u, 12u, 0x01u);
    assert_int_equal(reboot(&s2), TOF_RECORD_LOADED);
    fill(p, 20u, 1u);
    assert_memory_equal(s2.payload, p, 20u); /* the older one, the newer one damaged */
}

static void test_sequence_number_wraps(void **state) {
    (void)state;
    save_tag(1u, 8u);
    store.sequence = 0xFFFFFFFEu; /* as after 2^32 - 2 saves */
    save_tag(2u, 8u);             /* 0xFFFFFFFF */
    struct tof_record_store s2;
    assert_int_equal(reboot(&s2), TOF_RECORD_LOADED);
    assert_int_equal(s2.sequence, 0xFFFFFFFFu);
    /* cut before the old copy (0xFFFFFFFF) is erased: both valid, 0 is the newer */
    /* 3 double-words (12+8+2 -> 24): the other page is blank (the last save erased it), so
     * no erase comes first; the cut leaves out the old copy's erase */
    sim_flash_cut_after(&flash, 3u, false);
    uint8_t p[8];
    fill(p, 8u, 3u);
    assert_int_equal(tof_record_save(&s2, p, 8u), HAL_OK);
    assert_true(!flash.powered);
    assert_int_equal(reboot(&store), TOF_RECORD_LOADED);
    assert_int_equal(store.sequence, 0u);
    assert_memory_equal(store.payload, p, 8u);
}

/* A save skips the erase of a blank page (a page erase is ~22 ms on the part) and erases one
 * that is not; in steps, no step does more than one erase or one copy. */
static void test_save_erases_only_what_is_not_blank(void **state) {
    (void)state;
    save_tag(1u, 20u); /* page 0; page 1 erased after it */
    const uint32_t erases = flash.erases;
    save_tag(2u, 20u); /* page 1 blank: programmed at once, then page 0 erased */
    assert_int_equal(flash.erases - erases, 1u);
    sim_flash_poke(&flash, 0u, 1000u, 0x01u); /* a stray bit on the spare page */
    uint8_t p[20];
    fill(p, 20u, 3u);
    assert_int_equal(tof_record_save_begin(&store, p, 20u), HAL_OK);
    fill(p, 20u, 9u); /* the caller's buffer is free after begin */
    unsigned steps = 0;
    int rc = HAL_ERR_NOT_READY;
    for (; rc == HAL_ERR_NOT_READY && steps < 10u; ++steps) {
        rc = tof_record_step(&store);
    }
    assert_int_equal(rc, HAL_OK);
    /* look (not blank) and erase it (the sim has no background erase), then program */
    assert_int_equal(steps, 2u);
    assert_false(tof_record_busy(&store)); /* the sim erases at once: nothing left */
    assert_int_equal(flash.erases - erases, 3u);
    struct tof_record_store s2;
    assert_int_equal(reboot(&s2), TOF_RECORD_LOADED);
    fill(p, 20u, 3u);
    assert_memory_equal(s2.payload, p, 20u);
}

static void test_settings_section_round_trip_and_other_sections_kept(void **state) {
    (void)state;
    /* a calibration section already in the record */
    const uint8_t cal[] = {TOF_SECTION_CALIBRATION, 1u, 4u, 0u, 0xDE, 0xAD, 0xBE, 0xEF};
    assert_int_equal(tof_record_save(&store, cal, sizeof cal), HAL_OK);
    const struct tof_settings s = {.window = 50u,
                                   .sliding = true,
                                   .primary = 2u,
                                   .running = true,
                                   .raw_output = true,
                                   .process_noise_set = true,
                                   .process_noise_auto = false,
                                   .qd_um2_per_s = 500000u,
                                   .qt_um2_per_s = 50000u,
                                   .arm_um = 45250,
                                   .period_ms = 33u};
    assert_int_equal(tof_settings_save(&store, &s), HAL_OK);
    struct tof_record_store s2;
    assert_int_equal(reboot(&s2), TOF_RECORD_LOADED);
    struct tof_settings back;
    assert_int_equal(tof_settings_decode(s2.payload, s2.length, &back), TOF_RECORD_LOADED);
    /* field by field: the struct has padding */
    assert_int_equal(back.window, s.window);
    assert_int_equal(back.sliding, s.sliding);
    assert_int_equal(back.primary, s.primary);
    assert_int_equal(back.running, s.running);
    assert_int_equal(back.raw_output, s.raw_output);
    assert_int_equal(back.process_noise_set, s.process_noise_set);
    assert_int_equal(back.process_noise_auto, s.process_noise_auto);
    assert_int_equal(back.qd_um2_per_s, s.qd_um2_per_s);
    assert_int_equal(back.qt_um2_per_s, s.qt_um2_per_s);
    assert_int_equal(back.arm_um, s.arm_um);
    assert_int_equal(back.period_ms, s.period_ms);
    const unsigned settings_len = TOF_SECTION_HEADER + TOF_SETTINGS_LENGTH; /* 28 */
    assert_int_equal(s2.length, settings_len + sizeof cal);
    assert_memory_equal(&s2.payload[settings_len], cal, sizeof cal);
    /* a version this firmware does not read; a broken section list; none at all */
    uint8_t p[TOF_RECORD_PAYLOAD_MAX];
    memcpy(p, s2.payload, s2.length);
    p[1] = 3u;
    assert_int_equal(tof_settings_decode(p, s2.length, &back), TOF_RECORD_VERSION);
    p[1] = 2u;
    p[4 + 22] = 1u; /* the padding after the period */
    assert_int_equal(tof_settings_decode(p, s2.length, &back), TOF_RECORD_CORRUPT);
    p[4 + 22] = 0u;
    p[1] = 1u; /* a version-1 section is 16 bytes: this 24-byte one is not one */
    assert_int_equal(tof_settings_decode(p, s2.length, &back), TOF_RECORD_CORRUPT);
    /* version 1 (before arm and period were settings): read, arm and period the image's */
    uint8_t v1[TOF_SECTION_HEADER + TOF_SETTINGS_V1_LENGTH];
    memcpy(v1, p, sizeof v1);
    v1[2] = (uint8_t)TOF_SETTINGS_V1_LENGTH;
    assert_int_equal(tof_settings_decode(v1, sizeof v1, &back), TOF_RECORD_LOADED);
    assert_int_equal(back.window, 50u);
    assert_int_equal(back.qd_um2_per_s, 500000u);
    assert_int_equal(back.arm_um, 0);
    assert_int_equal(back.period_ms, 0u);
    p[1] = 2u;
    p[2] = 17u;
    assert_int_equal(tof_settings_decode(p, s2.length, &back), TOF_RECORD_CORRUPT);
    p[2] = (uint8_t)TOF_SETTINGS_LENGTH;
    p[4 + 2] = 2u; /* mode 2 */
    assert_int_equal(tof_settings_decode(p, s2.length, &back), TOF_RECORD_CORRUPT);
    assert_int_equal(tof_settings_decode(cal, sizeof cal, &back), TOF_RECORD_NONE);
    assert_int_equal(tof_settings_save(NULL, &s), HAL_ERR_STATE);
}

/* A storage that erases in the background as the STM32L4 does (hal_records erase_start and
 * erase_poll): the sim's blocking erase, carried out on the third poll after its start. */
static struct {
    struct hal_records inner;
    struct hal_records_ops ops;
    int erasing; /* the page being erased, or -1 */
    unsigned polls;
} bg;

static int bg_read(void *ctx, uint16_t page, uint32_t offset, uint8_t *out, size_t len) {
    (void)ctx;
    assert_int_equal(bg.erasing, -1); /* no other op while an erase runs */
    return bg.inner.ops->read(bg.inner.ctx, page, offset, out, len);
}

static int bg_program(void *ctx, uint16_t page, uint32_t offset, const uint8_t *data, size_t len) {
    (void)ctx;
    assert_int_equal(bg.erasing, -1);
    return bg.inner.ops->program(bg.inner.ctx, page, offset, data, len);
}

static int bg_erase_start(void *ctx, uint16_t page) {
    (void)ctx;
    assert_int_equal(bg.erasing, -1);
    bg.erasing = page;
    bg.polls = 0;
    return HAL_OK;
}

static int bg_erase_poll(void *ctx) {
    (void)ctx;
    if (bg.erasing < 0) {
        return HAL_OK;
    }
    if (++bg.polls < 3u) {
        return HAL_ERR_NOT_READY;
    }
    const int rc = bg.inner.ops->erase(bg.inner.ctx, (uint16_t)bg.erasing);
    bg.erasing = -1;
    return rc;
}

/* tof_record_save_in_use() (write-calibration, re-zero) returns with the new copy in
 * use and the old page's erase still running; steps end it; a save while it runs waits for
 * it and keeps the rules (the old copy goes only once the new one is verified). */
static void test_save_in_use_leaves_the_old_erase_running(void **state) {
    (void)state;
    bg.inner = sim_flash_hal(&flash);
    bg.ops = (struct hal_records_ops){.read = bg_read,
                                      .program = bg_program,
                                      .erase_start = bg_erase_start,
                                      .erase_poll = bg_erase_poll};
    bg.erasing = -1;
    struct hal_records h = bg.inner;
    h.ops = &bg.ops;
    assert_int_equal(tof_record_init(&store, h, 0u, 1u), HAL_OK);
    uint8_t p[40];
    fill(p, sizeof p, 1u);
    assert_int_equal(tof_record_save(&store, p, sizeof p), HAL_OK); /* the first: page 0 */
    assert_false(tof_record_busy(&store));
    fill(p, sizeof p, 2u);
    const uint32_t erases = flash.erases;
    assert_int_equal(tof_record_save_in_use(&store, p, sizeof p), HAL_OK);
    assert_true(tof_record_busy(&store)); /* the old page (0) is being erased */
    assert_int_equal(bg.erasing, 0);
    assert_int_equal(store.current, 1);
    assert_memory_equal(store.payload, p, sizeof p);
    assert_int_equal(flash.erases, erases);
    /* a save now waits for that erase, then writes page 0 */
    fill(p, sizeof p, 3u);
    assert_int_equal(tof_record_save_in_use(&store, p, sizeof p), HAL_OK);
    assert_int_equal(store.current, 0);
    assert_int_equal(bg.erasing, 1);
    unsigned steps = 0;
    while (tof_record_busy(&store) && steps < 10u) {
        assert_int_equal(tof_record_step(&store), HAL_OK); /* in use: done for the caller */
        ++steps;
    }
    assert_false(tof_record_busy(&store));
    assert_int_equal(bg.erasing, -1);
    assert_int_equal(flash.erases, erases + 2u);
    struct tof_record_store s2;
    assert_int_equal(reboot(&s2), TOF_RECORD_LOADED);
    assert_memory_equal(s2.payload, p, sizeof p);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_flash_model_refuses_what_the_part_refuses, setup),
        cmocka_unit_test_setup(test_nothing_stored_then_saved_then_loaded, setup),
        cmocka_unit_test_setup(test_power_cut_at_every_step_keeps_old_or_new, setup),
        cmocka_unit_test_setup(test_a_damaged_record_falls_back_and_says_why, setup),
        cmocka_unit_test_setup(test_sequence_number_wraps, setup),
        cmocka_unit_test_setup(test_save_erases_only_what_is_not_blank, setup),
        cmocka_unit_test_setup(test_settings_section_round_trip_and_other_sections_kept, setup),
        cmocka_unit_test_setup(test_save_in_use_leaves_the_old_erase_running, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
