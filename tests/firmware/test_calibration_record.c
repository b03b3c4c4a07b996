/*
 * The head's calibration as record section 2 (firmware/calibration_record.h) on the
 * simulated flash: what boot puts in attitude_config.calibration for a matching section,
 * and that a missing, damaged, other-version, other-head, other-parts or other-mode one leaves
 * the head uncalibrated and says why; version 5 carries the thermal fields and binds the parts'
 * NVM identities, versions 1 to 3 (before the thermal fields) are still read as calibrations
 * without them, version 1 bound to the head only; a field out of bounds is refused by name; a
 * section written on board is bound to the parts that run; the settings and the calibration
 * keep each other's section.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "firmware/calibration_record.h"
#include "firmware/config.h"
#include "firmware/settings.h"
#include "hal/hal_err.h"
#include "sim/sim_flash.h"
#include "test_calibration.h"

static struct sim_flash flash;
static struct tof_record_store store;
static struct tof_app_config cfg;
static struct tof_app app;

/* A head as calibrate writes one: offsets, gains, their sd and correlation. */
static struct calibration_head a_head(void) {
    struct calibration_head cal;
    test_calibration_fitted(&cal);
    return cal;
}

static int setup(void **state) {
    (void)state;
    assert_int_equal(sim_flash_init(&flash, 2u, 2048u), HAL_OK);
    assert_int_equal(tof_record_init(&store, sim_flash_hal(&flash), 0u, 1u), HAL_OK);
    cfg = tof_app_default_config;
    memset(&app, 0, sizeof app);
    app.cfg = cfg; /* tof_cal_boot() needs the configuration and the estimator only */
    assert_int_equal(attitude_init(&app.estimator, &cfg.estimator), ATTITUDE_ERR_NONE);
    return 0;
}

static struct tof_cal_binding mine(void) {
    return tof_cal_binding_of(&cfg);
}

/* A head whose offsets' temperature coefficients were measured (cal_apply.c's mapping of
 * HEAD.cal's cal_temp_c, temp_coeff_mm_per_c, temp_coeff_sd_mm_per_c). */
static struct calibration_head a_thermal_head(void) {
    struct calibration_head cal = a_head();
    cal.thermal = true;
    cal.cal_temp_cdeg = -1250; /* -12.5 degC */
    const int32_t coeff[4] = {21000, -8000, 0, CALIBRATION_TEMP_COEFF_MAX_NM_PER_C};
    const uint32_t sd[4] = {1500, 900, 2000, (uint32_t)CALIBRATION_TEMP_COEFF_MAX_NM_PER_C};
    memcpy(cal.temp_coeff_nm_per_c, coeff, sizeof coeff);
    memcpy(cal.temp_coeff_sd_nm_per_c, sd, sizeof sd);
    return cal;
}

/* Version 5 as the firmware stores it, bound to bind->part_id. */
static void save_cal(const struct calibration_head *cal, bool has_gain,
                     const struct tof_cal_binding *bind) {
    uint8_t wire[TOF_CAL_WIRE_SIZE];
    uint8_t section[TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH];
    assert_int_equal(tof_cal_encode(cal, has_gain, bind, wire), HAL_OK);
    assert_int_equal(tof_cal_bind_parts(wire, bind->part_id, section), HAL_OK);
    assert_int_equal(section[1], TOF_CALIBRATION_VERSION);
    assert_int_equal(tof_section_save(&store, section), HAL_OK);
}

/* A section of the versions before the thermal fields, as an older firmware stored it (byte
 * layouts of calibration_record.h: version 1 is the first 80 bytes of the body, version 2
 * adds the parts at 80, version 3 the arm at 112), of a head without thermal fields. */
static void old_section(uint8_t version, const struct calibration_head *cal,
                        const struct tof_cal_binding *bind, uint8_t *out) {
    uint8_t wire[TOF_CAL_WIRE_SIZE];
    assert_false(cal->thermal);
    assert_int_equal(tof_cal_encode(cal, true, bind, wire), HAL_OK);
    const uint16_t length = version == 1u ? 80u : version == 2u ? 112u : 116u;
    memset(out, 0, TOF_SECTION_HEADER + length);
    memcpy(out, wire, TOF_SECTION_HEADER + 80u);
    out[1] = version;
    out[2] = (uint8_t)length;
    for (unsigned i = 0; i < 4u && version >= 2u; ++i) {
        for (unsigned b = 0; b < 8u; ++b) {
            out[TOF_SECTION_HEADER + 80u + 8u * i + b] = (uint8_t)(bind->part_id[i] >> (8u * b));
        }
    }
    for (unsigned b = 0; b < 4u && version == 3u; ++b) {
        out[TOF_SECTION_HEADER + 112u + b] = (uint8_t)((uint32_t)bind->arm_um >> (8u * b));
    }
}

/* Version 1, as an older firmware stored it. */
static void save_cal_v1(const struct calibration_head *cal, const struct tof_cal_binding *bind) {
    uint8_t section[TOF_SECTION_HEADER + 80u];
    old_section(1u, cal, bind, section);
    assert_int_equal(tof_section_save(&store, section), HAL_OK);
}

/* The parts the bring-up found: part i has identity ids[i] (0: none read). */
static void running_parts(const uint64_t ids[4]) {
    static struct vl53_config any;
    for (unsigned i = 0; i < 4u; ++i) {
        app.array.dev[i].cfg = &any;
        app.array.dev[i].part_id = ids[i];
    }
}

static const uint64_t parts[4] = {0x9A6B1C2D3E074021ull, 0x9A6B1C2D3E074322ull,
                                  0x9A6B1C2D3E074623ull, 0x9A6B1C2D3E074924ull};

/* Boot on a fresh store over the same flash, as after a reset. */
static enum tof_cal_state boot(void) {
    sim_flash_power_on(&flash);
    static struct tof_record_store s2;
    assert_int_equal(tof_record_init(&s2, sim_flash_hal(&flash), 0u, 1u), HAL_OK);
    return tof_cal_boot(&s2, &app);
}

/* Field by field: the struct has padding after `calibrated`. */
static void assert_same_cal(const struct calibration_head *a, const struct calibration_head *b) {
    assert_int_equal(a->calibrated, b->calibrated);
    assert_memory_equal(a->offset_um, b->offset_um, sizeof a->offset_um);
    assert_memory_equal(a->gain_ppm, b->gain_ppm, sizeof a->gain_ppm);
    assert_memory_equal(a->offset_sd_um, b->offset_sd_um, sizeof a->offset_sd_um);
    assert_memory_equal(a->gain_sd_ppm, b->gain_sd_ppm, sizeof a->gain_sd_ppm);
    assert_memory_equal(a->offset_gain_corr_q15, b->offset_gain_corr_q15,
                        sizeof a->offset_gain_corr_q15);
    assert_int_equal(a->thermal, b->thermal);
    assert_int_equal(a->cal_temp_cdeg, b->cal_temp_cdeg);
    assert_memory_equal(a->temp_coeff_nm_per_c, b->temp_coeff_nm_per_c,
                        sizeof a->temp_coeff_nm_per_c);
    assert_memory_equal(a->temp_coeff_sd_nm_per_c, b->temp_coeff_sd_nm_per_c,
                        sizeof a->temp_coeff_sd_nm_per_c);
}

static void assert_uncalibrated(void) {
    assert_false(app.estimator.cfg.calibration.calibrated);
}

static void test_a_matching_section_reaches_the_estimator(void **state) {
    (void)state;
    const struct calibration_head cal = a_head();
    const struct tof_cal_binding b = mine();
    save_cal(&cal, true, &b);
    assert_int_equal(boot(), TOF_CAL_APPLIED);
    assert_same_cal(&app.estimator.cfg.calibration, &cal);
}

static void test_without_gains_the_gain_sd_is_the_parts_spread(void **state) {
    (void)state;
    struct calibration_head cal = a_head();
    memset(cal.gain_ppm, 0, sizeof cal.gain_ppm);
    const struct tof_cal_binding b = mine();
    save_cal(&cal, false, &b);
    assert_int_equal(boot(), TOF_CAL_APPLIED);
    for (unsigned i = 0; i < 4u; ++i) {
        assert_int_equal(app.estimator.cfg.calibration.gain_ppm[i], 0);
        assert_int_equal(app.estimator.cfg.calibration.gain_sd_ppm[i],
                         CALIBRATION_UNCAL_GAIN_SD_PPM);
        assert_int_equal(app.estimator.cfg.calibration.offset_um[i], cal.offset_um[i]);
    }
    /* a gain where none was fitted is refused at encoding */
    cal.gain_ppm[2] = 1;
    uint8_t section[TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH];
    assert_int_equal(tof_cal_encode(&cal, false, &b, section), HAL_ERR_INVALID);
}

static void test_nothing_stored_is_uncalibrated(void **state) {
    (void)state;
    assert_int_equal(boot(), TOF_CAL_NONE);
    assert_uncalibrated();
    /* a record with the settings only: none either */
    const struct tof_settings s = {.window = 50, .running = true};
    assert_int_equal(tof_settings_save(&store, &s), HAL_OK);
    assert_int_equal(boot(), TOF_CAL_NONE);
    assert_uncalibrated();
    assert_int_equal(tof_cal_boot(NULL, &app), TOF_CAL_NO_STORAGE);
}

static void test_a_damaged_record_is_not_applied(void **state) {
    (void)state;
    const struct calibration_head cal = a_head();
    const struct tof_cal_binding b = mine();
    save_cal(&cal, true, &b);
    sim_flash_poke(&flash, 0u, 12u + 4u + 9u, 0x04u); /* an offset bit: the CRC fails */
    assert_int_equal(boot(), TOF_CAL_CORRUPT);
    assert_uncalibrated();
}

static void test_another_section_version_is_not_applied(void **state) {
    (void)state;
    const struct calibration_head cal = a_head();
    const struct tof_cal_binding b = mine();
    uint8_t section[TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH];
    assert_int_equal(tof_cal_encode(&cal, true, &b, section), HAL_OK);
    section[1] = 6u; /* a later firmware's layout */
    assert_int_equal(tof_section_save(&store, section), HAL_OK);
    assert_int_equal(boot(), TOF_CAL_VERSION);
    assert_uncalibrated();
}

static void test_another_head_is_not_applied(void **state) {
    (void)state;
    const struct calibration_head cal = a_head();
    struct tof_cal_binding b = mine();
    b.head_id = 17u;
    save_cal(&cal, true, &b);
    assert_int_equal(boot(), TOF_CAL_OTHER_HEAD);
    assert_uncalibrated();
    app.cfg.head_id = 17u; /* the image of that head */
    assert_int_equal(boot(), TOF_CAL_APPLIED);
    assert_true(app.estimator.cfg.calibration.calibrated);
}

static void test_another_mode_or_budget_is_not_applied(void **state) {
    (void)state;
    const struct calibration_head cal = a_head();
    struct tof_cal_binding b = mine();
    b.mode = cfg.timing.mode == VL53_DISTANCE_SHORT ? (uint8_t)VL53_DISTANCE_LONG
                                                    : (uint8_t)VL53_DISTANCE_SHORT;
    save_cal(&cal, true, &b);
    assert_int_equal(boot(), TOF_CAL_OTHER_MODE);
    assert_uncalibrated();
    b = mine();
    b.budget_ms = (uint16_t)(b.budget_ms + 1u);
    save_cal(&cal, true, &b);
    assert_int_equal(boot(), TOF_CAL_OTHER_BUDGET);
    assert_uncalibrated();
}

/* A section the CRC cannot catch (written so by a defect): decoded values are checked. */
static void test_values_out_of_bounds_are_corrupt(void **state) {
    (void)state;
    const struct calibration_head cal = a_head();
    const struct tof_cal_binding b = mine();
    struct calibration_head out;
    struct tof_cal_binding bo;
    uint8_t s[TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH];
    const struct {
        unsigned at;
        uint8_t value;
    } bad[] = {
        {4u + 5u, 0x04u},            /* a reserved flag */
        {4u + 4u, 0u},               /* distance mode 0 */
        {4u + 6u, 0u},               /* with the next byte: budget 0 */
        {4u + 8u + 3u, 0x7Fu},       /* offset A beyond ±100 mm */
        {4u + 8u + 18u + 7u, 0x80u}, /* gain B beyond ±10 % */
        {2u, 113u},                  /* a section length other than 114 */
        {1u, 2u},                    /* version 2 with version 4's length */
    };
    const enum tof_cal_field named[] = {
        TOF_CAL_FIELD_FLAGS, TOF_CAL_FIELD_MODE,   TOF_CAL_FIELD_BUDGET, TOF_CAL_FIELD_OFFSET,
        TOF_CAL_FIELD_GAIN,  TOF_CAL_FIELD_HEADER, TOF_CAL_FIELD_HEADER};
    enum tof_cal_field field = TOF_CAL_FIELD_HEADER;
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; ++k) {
        assert_int_equal(tof_cal_encode(&cal, true, &b, s), HAL_OK);
        assert_int_equal(tof_cal_decode(s, sizeof s, &out, &bo, &field), TOF_CAL_APPLIED);
        assert_int_equal(field, TOF_CAL_FIELD_NONE);
        s[bad[k].at] = bad[k].value;
        if (bad[k].at == 4u + 6u) {
            s[bad[k].at + 1u] = 0u;
        }
        const uint16_t len = bad[k].at == 2u ? (uint16_t)(sizeof s - 1u) : (uint16_t)sizeof s;
        assert_int_equal(tof_cal_decode(s, len, &out, &bo, &field), TOF_CAL_CORRUPT);
        assert_int_equal(field, named[k]);
    }
    /* an uncalibrated head or one out of bounds is never encoded */
    /* version 5 with a length other than 150 */
    uint8_t s2[TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH];
    assert_int_equal(tof_cal_encode(&cal, true, &b, s), HAL_OK);
    assert_int_equal(tof_cal_bind_parts(s, parts, s2), HAL_OK);
    assert_int_equal(tof_cal_decode(s2, sizeof s2, &out, &bo, NULL), TOF_CAL_APPLIED);
    s2[2] = 149u;
    assert_int_equal(tof_cal_decode(s2, sizeof s2, &out, &bo, &field), TOF_CAL_CORRUPT);
    assert_int_equal(field, TOF_CAL_FIELD_HEADER);
    struct calibration_head u = cal;
    u.calibrated = false;
    assert_int_equal(tof_cal_encode(&u, true, &b, s), HAL_ERR_INVALID);
    u = cal;
    u.offset_um[3] = CALIBRATION_OFFSET_MAX_UM + 1;
    assert_int_equal(tof_cal_encode(&u, true, &b, s), HAL_ERR_INVALID);
}

static void test_settings_and_calibration_keep_each_other(void **state) {
    (void)state;
    const struct calibration_head cal = a_head();
    const struct tof_cal_binding b = mine();
    save_cal(&cal, true, &b);
    const struct tof_settings s = {.window = 50, .sliding = true, .running = true};
    assert_int_equal(tof_settings_save(&store, &s), HAL_OK);
    assert_int_equal(boot(), TOF_CAL_APPLIED);
    assert_same_cal(&app.estimator.cfg.calibration, &cal);
    struct tof_settings back;
    assert_int_equal(tof_settings_decode(store.payload, store.length, &back), TOF_RECORD_LOADED);
    assert_int_equal(back.window, 50);
    save_cal(&cal, true, &b); /* again: the settings stay */
    assert_int_equal(tof_settings_decode(store.payload, store.length, &back), TOF_RECORD_LOADED);
    assert_true(back.sliding);
    assert_int_equal(store.length,
                     2u * TOF_SECTION_HEADER + TOF_SETTINGS_LENGTH + TOF_CALIBRATION_LENGTH);
}

/* Version 2 carries the four identities, each read back as written, under the record's CRC. */
static void test_version_2_keeps_the_parts_identities(void **state) {
    (void)state;
    const struct calibration_head cal = a_head();
    struct tof_cal_binding b = mine();
    memcpy(b.part_id, parts, sizeof parts);
    b.part_id[1] = 0u; /* one part bound to none */
    uint8_t wire[TOF_CAL_WIRE_SIZE];
    uint8_t s[TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH];
    assert_int_equal(tof_cal_encode(&cal, true, &b, wire), HAL_OK);
    assert_int_equal(tof_cal_bind_parts(wire, b.part_id, s), HAL_OK);
    assert_int_equal(s[0], TOF_SECTION_CALIBRATION);
    assert_int_equal(s[1], 5u);
    assert_int_equal(s[2] | s[3] << 8, TOF_CALIBRATION_LENGTH);
    assert_memory_equal(&s[TOF_SECTION_HEADER], &wire[TOF_SECTION_HEADER], 114u); /* v4's bytes */
    struct calibration_head out;
    struct tof_cal_binding bo;
    assert_int_equal(tof_cal_decode(s, sizeof s, &out, &bo, NULL), TOF_CAL_APPLIED);
    assert_same_cal(&out, &cal);
    for (unsigned i = 0; i < 4u; ++i) {
        assert_true(bo.part_id[i] == b.part_id[i]);
    }
    /* binding again keeps the parts already bound and fills only the unbound one */
    const uint64_t others[4] = {1u, 2u, 3u, 4u};
    uint8_t again[sizeof s];
    assert_int_equal(tof_cal_bind_parts(s, others, again), HAL_OK);
    assert_int_equal(tof_cal_decode(again, sizeof again, &out, &bo, NULL), TOF_CAL_APPLIED);
    assert_true(bo.part_id[0] == parts[0] && bo.part_id[1] == 2u && bo.part_id[3] == parts[3]);
    /* a damaged identity byte on flash: the record's CRC refuses it */
    b.part_id[1] = parts[1];
    save_cal(&cal, true, &b);
    assert_int_equal(boot(), TOF_CAL_APPLIED);
    sim_flash_poke(&flash, 0u, 12u + 4u + 114u + 8u + 2u, 0x10u);
    assert_int_equal(attitude_init(&app.estimator, &cfg.estimator), ATTITUDE_ERR_NONE); /* reset */
    assert_int_equal(boot(), TOF_CAL_CORRUPT);
    assert_uncalibrated();
}

/* A part whose NVM identity differs from the one bound: other parts, uncalibrated; a part not
 * read (it did not come up) or not bound is not compared. */
static void test_another_part_is_not_applied(void **state) {
    (void)state;
    const struct calibration_head cal = a_head();
    struct tof_cal_binding b = mine();
    memcpy(b.part_id, parts, sizeof parts);
    save_cal(&cal, true, &b);
    running_parts(parts);
    assert_int_equal(boot(), TOF_CAL_APPLIED);
    assert_same_cal(&app.estimator.cfg.calibration, &cal);
    for (unsigned k = 0; k < 4u; ++k) {
        uint64_t swapped[4];
        memcpy(swapped, parts, sizeof parts);
        swapped[k] ^= 0x0100u; /* another die X on one part */
        running_parts(swapped);
        assert_int_equal(boot(), TOF_CAL_OTHER_PARTS);
        assert_uncalibrated();
        swapped[k] = 0u; /* that part not read: not compared */
        running_parts(swapped);
        assert_int_equal(boot(), TOF_CAL_APPLIED);
    }
    /* head first: another head with other parts says other-head */
    b.head_id = 5u;
    save_cal(&cal, true, &b);
    const uint64_t none[4] = {7u, 7u, 7u, 7u};
    running_parts(none);
    assert_int_equal(boot(), TOF_CAL_OTHER_HEAD);
}

/* Version 1 (an older firmware's record) is read and bound to the head only: it holds for any
 * parts, and for no other head. */
static void test_version_1_binds_the_head_only(void **state) {
    (void)state;
    const struct calibration_head cal = a_head();
    struct tof_cal_binding b = mine();
    save_cal_v1(&cal, &b);
    running_parts(parts);
    assert_int_equal(boot(), TOF_CAL_APPLIED);
    assert_same_cal(&app.estimator.cfg.calibration, &cal);
    struct calibration_head out;
    struct tof_cal_binding bo;
    assert_int_equal(tof_cal_decode(store.payload, store.length, &out, &bo, NULL), TOF_CAL_APPLIED);
    for (unsigned i = 0; i < 4u; ++i) {
        assert_true(bo.part_id[i] == 0u);
    }
    b.head_id = 9u;
    save_cal_v1(&cal, &b);
    assert_int_equal(boot(), TOF_CAL_OTHER_HEAD);
    assert_uncalibrated();
}

/* A calibration received (the version-4 form the command carries) is stored as version 5 bound
 * to the parts that run and read back in its version-4 form; after a part is replaced the
 * next boot refuses it. One received as version 2 for other parts is refused, nothing stored. */
static void test_written_on_board_binds_the_running_parts(void **state) {
    (void)state;
    const struct calibration_head cal = a_head();
    const struct tof_cal_binding b = mine();
    uint8_t wire[TOF_CAL_WIRE_SIZE];
    assert_int_equal(tof_cal_encode(&cal, true, &b, wire), HAL_OK);
    running_parts(parts);
    int error = 1;
    assert_int_equal(tof_cal_write(&store, &app, wire, &error), TOF_CAL_APPLIED);
    assert_int_equal(error, 0);
    struct calibration_head out;
    struct tof_cal_binding bo;
    assert_int_equal(tof_cal_decode(store.payload, store.length, &out, &bo, NULL), TOF_CAL_APPLIED);
    for (unsigned i = 0; i < 4u; ++i) {
        assert_true(bo.part_id[i] == parts[i]);
    }
    uint8_t back[TOF_CAL_WIRE_SIZE];
    tof_cal_read(&store, back);
    assert_memory_equal(back, wire, sizeof wire);
    assert_int_equal(boot(), TOF_CAL_APPLIED);
    uint64_t replaced[4];
    memcpy(replaced, parts, sizeof parts);
    replaced[2] = 0x1122334455667788ull;
    running_parts(replaced);
    assert_int_equal(boot(), TOF_CAL_OTHER_PARTS);
    assert_uncalibrated();

    /* received as version 5, bound to parts other than these: refused, the record kept */
    const uint32_t seq = store.sequence;
    uint8_t v2[TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH];
    assert_int_equal(tof_cal_bind_parts(wire, parts, v2), HAL_OK);
    assert_int_equal(tof_cal_write(&store, &app, v2, &error), TOF_CAL_OTHER_PARTS);
    assert_int_equal(store.sequence, seq);
    /* and for these parts: stored as it is */
    assert_int_equal(tof_cal_bind_parts(wire, replaced, v2), HAL_OK);
    assert_int_equal(tof_cal_write(&store, &app, v2, &error), TOF_CAL_APPLIED);
    assert_int_equal(boot(), TOF_CAL_APPLIED);
}

static void put_le(uint8_t *p, uint32_t v, unsigned bytes) {
    for (unsigned b = 0; b < bytes; ++b) {
        p[b] = (uint8_t)(v >> (8u * b));
    }
}

/* The thermal fields at the documented bytes (flag bit 1, cal_temp_cdeg at 80, coefficient and
 * sd per sensor at 82 + 8·i), through the wire form, the stored version 5, a boot and
 * read-calibration, unchanged. */
static void test_the_thermal_fields_travel_and_reach_the_estimator(void **state) {
    (void)state;
    const struct calibration_head cal = a_thermal_head();
    struct tof_cal_binding b = mine();
    uint8_t wire[TOF_CAL_WIRE_SIZE];
    assert_int_equal(tof_cal_encode(&cal, true, &b, wire), HAL_OK);
    assert_int_equal(sizeof wire, 118u);
    const uint8_t header[4] = {2u, 4u, 114u, 0u};
    assert_memory_equal(wire, header, 4u);
    assert_int_equal(wire[4 + 5], 0x03u); /* gains and thermal */
    uint8_t want[34];
    put_le(&want[0], (uint32_t)(int32_t)-1250, 2u);
    for (unsigned i = 0; i < 4u; ++i) {
        put_le(&want[2u + 8u * i], (uint32_t)cal.temp_coeff_nm_per_c[i], 4u);
        put_le(&want[6u + 8u * i], cal.temp_coeff_sd_nm_per_c[i], 4u);
    }
    assert_memory_equal(&wire[4 + 80], want, sizeof want);
    struct calibration_head out;
    struct tof_cal_binding bo;
    enum tof_cal_field field = TOF_CAL_FIELD_HEADER;
    assert_int_equal(tof_cal_decode(wire, sizeof wire, &out, &bo, &field), TOF_CAL_APPLIED);
    assert_int_equal(field, TOF_CAL_FIELD_NONE);
    assert_same_cal(&out, &cal);
    /* stored as version 5 with the parts, booted, read back as sent */
    memcpy(b.part_id, parts, sizeof parts);
    save_cal(&cal, true, &b);
    running_parts(parts);
    assert_int_equal(boot(), TOF_CAL_APPLIED);
    assert_same_cal(&app.estimator.cfg.calibration, &cal);
    assert_int_equal(tof_cal_decode(store.payload, store.length, &out, &bo, NULL), TOF_CAL_APPLIED);
    assert_true(bo.part_id[2] == parts[2]);
    uint8_t back[TOF_CAL_WIRE_SIZE];
    tof_cal_read(&store, back);
    assert_memory_equal(back, wire, sizeof wire);
    /* written on board through the command's path: the same */
    int error = 1;
    assert_int_equal(tof_cal_write(&store, &app, wire, &error), TOF_CAL_APPLIED);
    assert_same_cal(&app.estimator.cfg.calibration, &cal);
    tof_cal_read(&store, back);
    assert_memory_equal(back, wire, sizeof wire);

    /* a head without thermal fields stores them as 0, whatever the struct holds there */
    struct calibration_head plain = cal;
    plain.thermal = false;
    plain.cal_temp_cdeg = 3000;
    assert_int_equal(tof_cal_encode(&plain, true, &b, wire), HAL_OK);
    assert_int_equal(wire[4 + 5], 0x01u);
    memset(want, 0, sizeof want);
    assert_memory_equal(&wire[4 + 80], want, sizeof want);
    assert_int_equal(tof_cal_decode(wire, sizeof wire, &out, &bo, NULL), TOF_CAL_APPLIED);
    assert_false(out.thermal);
    assert_int_equal(out.cal_temp_cdeg, 0);
    assert_int_equal(out.temp_coeff_nm_per_c[0], 0);
    assert_int_equal(out.temp_coeff_sd_nm_per_c[3], 0u);
}

/* Versions 1, 2 and 3 (before the thermal fields) read as calibrations without them, with the
 * binding each carries, and go out as the version-4 form with the thermal bytes 0; the
 * thermal flag bit is reserved in them. */
static void test_the_versions_before_the_thermal_fields_read_as_non_thermal(void **state) {
    (void)state;
    const struct calibration_head cal = a_head();
    struct tof_cal_binding b = mine();
    memcpy(b.part_id, parts, sizeof parts);
    b.arm_um = cfg.estimator.arm_um;
    uint8_t wire[TOF_CAL_WIRE_SIZE];
    assert_int_equal(tof_cal_encode(&cal, true, &b, wire), HAL_OK);
    running_parts(parts);
    for (uint8_t version = 1u; version <= 3u; ++version) {
        uint8_t old[TOF_SECTION_HEADER + 116u];
        old_section(version, &cal, &b, old);
        assert_int_equal(tof_section_save(&store, old), HAL_OK);
        assert_int_equal(attitude_init(&app.estimator, &cfg.estimator), ATTITUDE_ERR_NONE);
        assert_int_equal(boot(), TOF_CAL_APPLIED);
        assert_same_cal(&app.estimator.cfg.calibration, &cal); /* thermal false, fields 0 */
        struct calibration_head out;
        struct tof_cal_binding bo;
        assert_int_equal(tof_cal_decode(store.payload, store.length, &out, &bo, NULL),
                         TOF_CAL_APPLIED);
        assert_false(out.thermal);
        assert_true(bo.part_id[3] == (version >= 2u ? parts[3] : 0u));
        assert_int_equal(bo.arm_um, version == 3u ? cfg.estimator.arm_um : 0);
        uint8_t back[TOF_CAL_WIRE_SIZE];
        tof_cal_read(&store, back);
        assert_memory_equal(back, wire, sizeof wire);
        /* bound again as version 5: parts and arm kept, thermal fields 0 */
        uint8_t v5[TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH];
        assert_int_equal(tof_cal_bind_parts(old, parts, v5), HAL_OK);
        assert_int_equal(tof_cal_decode(v5, sizeof v5, &out, &bo, NULL), TOF_CAL_APPLIED);
        assert_same_cal(&out, &cal);
        assert_int_equal(bo.arm_um, version == 3u ? cfg.estimator.arm_um : 0);
        /* flag bit 1 is reserved before version 4: corrupt, never a thermal calibration */
        old[4 + 5] |= 0x02u;
        enum tof_cal_field field = TOF_CAL_FIELD_NONE;
        assert_int_equal(tof_cal_decode(old, (uint16_t)(old[2] + 4u), &out, &bo, &field),
                         TOF_CAL_CORRUPT);
        assert_int_equal(field, TOF_CAL_FIELD_FLAGS);
        assert_int_equal(tof_cal_bind_parts(old, parts, v5), HAL_ERR_INVALID);
        int error = 0;
        assert_int_equal(tof_cal_write(&store, &app, old, &error), TOF_CAL_CORRUPT);
    }
}

/* Thermal values out of estimator/calibration.h's bounds, or thermal bytes without the flag:
 * never encoded, and refused at decoding naming the field. */
static void test_thermal_values_out_of_bounds_are_refused_by_name(void **state) {
    (void)state;
    const struct calibration_head cal = a_thermal_head();
    const struct tof_cal_binding b = mine();
    uint8_t s[TOF_CAL_WIRE_SIZE];
    struct calibration_head u = cal;
    u.cal_temp_cdeg = CALIBRATION_TEMP_MAX_CDEG + 1;
    assert_int_equal(tof_cal_encode(&u, true, &b, s), HAL_ERR_INVALID);
    u = cal;
    u.temp_coeff_nm_per_c[1] = -CALIBRATION_TEMP_COEFF_MAX_NM_PER_C - 1;
    assert_int_equal(tof_cal_encode(&u, true, &b, s), HAL_ERR_INVALID);
    u = cal;
    u.temp_coeff_sd_nm_per_c[2] = (uint32_t)CALIBRATION_TEMP_COEFF_MAX_NM_PER_C + 1u;
    assert_int_equal(tof_cal_encode(&u, true, &b, s), HAL_ERR_INVALID);
    u = cal;
    u.cal_temp_cdeg = CALIBRATION_TEMP_MIN_CDEG; /* the bounds themselves are taken */
    assert_int_equal(tof_cal_encode(&u, true, &b, s), HAL_OK);

    const struct {
        unsigned at;    /* body byte */
        uint32_t value; /* little-endian */
        unsigned bytes; /* its width */
        bool thermal;   /* the flag left set */
        enum tof_cal_field field;
    } bad[] = {
        {80u, (uint32_t)(CALIBRATION_TEMP_MAX_CDEG + 1), 2u, true, TOF_CAL_FIELD_CAL_TEMP},
        {80u, (uint32_t)(int32_t)(CALIBRATION_TEMP_MIN_CDEG - 1), 2u, true, TOF_CAL_FIELD_CAL_TEMP},
        {82u + 8u, (uint32_t)(CALIBRATION_TEMP_COEFF_MAX_NM_PER_C + 1), 4u, true,
         TOF_CAL_FIELD_TEMP_COEFF},
        {82u + 24u, (uint32_t) - (CALIBRATION_TEMP_COEFF_MAX_NM_PER_C + 1), 4u, true,
         TOF_CAL_FIELD_TEMP_COEFF},
        {86u + 16u, (uint32_t)CALIBRATION_TEMP_COEFF_MAX_NM_PER_C + 1u, 4u, true,
         TOF_CAL_FIELD_TEMP_COEFF_SD},
        {80u, 1u, 2u, false, TOF_CAL_FIELD_CAL_TEMP},   /* a value without the flag */
        {82u, 1u, 4u, false, TOF_CAL_FIELD_TEMP_COEFF}, /* likewise */
        {86u + 8u, 1u, 4u, false, TOF_CAL_FIELD_TEMP_COEFF_SD},
    };
    struct calibration_head out;
    struct tof_cal_binding bo;
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; ++k) {
        struct calibration_head h = bad[k].thermal ? cal : a_head();
        assert_int_equal(tof_cal_encode(&h, true, &b, s), HAL_OK);
        put_le(&s[4u + bad[k].at], bad[k].value, bad[k].bytes);
        enum tof_cal_field field = TOF_CAL_FIELD_NONE;
        assert_int_equal(tof_cal_decode(s, sizeof s, &out, &bo, &field), TOF_CAL_CORRUPT);
        assert_int_equal(field, bad[k].field);
        int error = 0;
        assert_int_equal(tof_cal_write(&store, &app, s, &error), TOF_CAL_CORRUPT);
        assert_int_equal(store.current, -1); /* nothing stored */
    }
    assert_string_equal(tof_cal_field_name(TOF_CAL_FIELD_CAL_TEMP), "cal_temp_cdeg");
    assert_string_equal(tof_cal_field_name(TOF_CAL_FIELD_TEMP_COEFF), "temp_coeff_nm_per_c");
    assert_string_equal(tof_cal_field_name(TOF_CAL_FIELD_TEMP_COEFF_SD), "temp_coeff_sd_nm_per_c");
    assert_string_equal(tof_cal_field_name((enum tof_cal_field)99), "unknown field");
}

/* A unit running calibrated whose record is then found damaged, erased, of another version or
 * gone (no storage) at the next boot: the estimator's calibration goes back to the
 * configuration's own, never the one left in force. */
static void test_a_boot_without_a_valid_record_resets_the_calibration(void **state) {
    (void)state;
    const struct calibration_head cal = a_head();
    const struct tof_cal_binding b = mine();
    enum { DAMAGED, ERASED, OTHER_FORMAT, NO_STORAGE, CASES };
    for (int k = 0; k < CASES; ++k) {
        save_cal(&cal, true, &b);
        assert_int_equal(boot(), TOF_CAL_APPLIED);
        assert_true(app.estimator.cfg.calibration.calibrated);
        enum tof_cal_state want = TOF_CAL_CORRUPT;
        if (k == DAMAGED) {
            sim_flash_poke(&flash, (uint16_t)store.current, 12u + 4u + 9u, 0x04u);
        } else if (k == ERASED) {
            assert_int_equal(sim_flash_ops.erase(&flash, 0u), HAL_OK);
            assert_int_equal(sim_flash_ops.erase(&flash, 1u), HAL_OK);
            want = TOF_CAL_NONE;
        } else if (k == OTHER_FORMAT) {
            sim_flash_poke(&flash, (uint16_t)store.current, 4u, TOF_RECORD_FORMAT + 1u);
            want = TOF_CAL_VERSION;
        }
        if (k == NO_STORAGE) {
            assert_int_equal(tof_cal_boot(NULL, &app), TOF_CAL_NO_STORAGE);
        } else {
            assert_int_equal(boot(), want);
        }
        assert_uncalibrated();
        assert_int_equal(setup(NULL), 0); /* a blank flash and store for the next case */
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_a_matching_section_reaches_the_estimator, setup),
        cmocka_unit_test_setup(test_without_gains_the_gain_sd_is_the_parts_spread, setup),
        cmocka_unit_test_setup(test_nothing_stored_is_uncalibrated, setup),
        cmocka_unit_test_setup(test_a_damaged_record_is_not_applied, setup),
        cmocka_unit_test_setup(test_another_section_version_is_not_applied, setup),
        cmocka_unit_test_setup(test_another_head_is_not_applied, setup),
        cmocka_unit_test_setup(test_another_mode_or_budget_is_not_applied, setup),
        cmocka_unit_test_setup(test_values_out_of_bounds_are_corrupt, setup),
        cmocka_unit_test_setup(test_settings_and_calibration_keep_each_other, setup),
        cmocka_unit_test_setup(test_version_2_keeps_the_parts_identities, setup),
        cmocka_unit_test_setup(test_another_part_is_not_applied, setup),
        cmocka_unit_test_setup(test_version_1_binds_the_head_only, setup),
        cmocka_unit_test_setup(test_written_on_board_binds_the_running_parts, setup),
        cmocka_unit_test_setup(test_a_boot_without_a_valid_record_resets_the_calibration, setup),
        cmocka_unit_test_setup(test_the_thermal_fields_travel_and_reach_the_estimator, setup),
        cmocka_unit_test_setup(test_the_versions_before_the_thermal_fields_read_as_non_thermal,
                               setup),
        cmocka_unit_test_setup(test_thermal_values_out_of_bounds_are_refused_by_name, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
