/* The head's calibration as record section 2, and applied at boot (firmware/calibration_record.h).
 */
#include "firmware/calibration_record.h"

#include <stddef.h>
#include <string.h>

#include "firmware/settings.h"
#include "hal/hal_err.h"
#include "telemetry/tlm_crc.h"
#include "telemetry/tlm_messages.h"
#include "le_bytes.h"

/* The status frame carries enum tof_cal_state as it is (link.c). */
_Static_assert(TOF_CAL_NONE == (int)TLM_CAL_NONE && TOF_CAL_APPLIED == (int)TLM_CAL_APPLIED &&
                   TOF_CAL_CORRUPT == (int)TLM_CAL_CORRUPT &&
                   TOF_CAL_VERSION == (int)TLM_CAL_VERSION &&
                   TOF_CAL_OTHER_HEAD == (int)TLM_CAL_OTHER_HEAD &&
                   TOF_CAL_OTHER_MODE == (int)TLM_CAL_OTHER_MODE &&
                   TOF_CAL_REJECTED == (int)TLM_CAL_REJECTED &&
                   TOF_CAL_NO_STORAGE == (int)TLM_CAL_NO_STORAGE &&
                   TOF_CAL_OTHER_PARTS == (int)TLM_CAL_OTHER_PARTS &&
                   TOF_CAL_OTHER_BUDGET == (int)TLM_CAL_OTHER_BUDGET &&
                   TOF_CAL_OTHER_ARM == (int)TLM_CAL_OTHER_ARM,
               "calibration states are the status frame's codes");

#define PER_SENSOR   18u /* i32 offset, i32 gain, u32 offset sd, u32 gain sd, i16 corr */
#define SENSORS_AT   8u
#define PART_ID_SIZE 8u /* u64, two little-endian u32: low word first */
_Static_assert(SENSORS_AT + CALIBRATION_SENSORS * PER_SENSOR == TOF_CALIBRATION_V1_LENGTH,
               "section 2 version 1 is 80 bytes");
_Static_assert(TOF_CALIBRATION_V1_LENGTH + CALIBRATION_SENSORS * PART_ID_SIZE ==
                   TOF_CALIBRATION_V2_LENGTH,
               "version 2 is version 1 and the four parts' identities");
_Static_assert(TOF_CALIBRATION_V2_LENGTH + 4u == TOF_CALIBRATION_LENGTH,
               "version 3 is version 2 and the arm");
_Static_assert(TOF_CAL_WIRE_SIZE == TLM_CAL_SECTION_LEN, "the commands carry version 1");
_Static_assert(TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH + TOF_SECTION_HEADER +
                       TOF_SETTINGS_LENGTH <=
                   TOF_RECORD_PAYLOAD_MAX,
               "the settings and the calibration fit one record");

/* Two's complement from the stored bits, without relying on the conversion's behaviour. */
static int32_t as_i32(uint32_t v) {
    return v <= 0x7FFFFFFFu ? (int32_t)v : -(int32_t)(~v) - 1;
}

static bool within(int32_t v, int32_t max) {
    return v >= -max && v <= max;
}

/* The bounds estimator/calibration.h states, for one sensor. */
static bool sensor_ok(const struct calibration_head *cal, unsigned i) {
    return within(cal->offset_um[i], CALIBRATION_OFFSET_MAX_UM) &&
           within(cal->gain_ppm[i], CALIBRATION_GAIN_MAX_PPM) &&
           cal->offset_sd_um[i] <= (uint32_t)CALIBRATION_OFFSET_MAX_UM &&
           cal->gain_sd_ppm[i] <= (uint32_t)CALIBRATION_GAIN_MAX_PPM;
}

int tof_cal_encode(const struct calibration_head *cal, bool has_gain,
                   const struct tof_cal_binding *bind, uint8_t *out) {
    if (!cal->calibrated || bind->budget_ms == 0u ||
        (bind->mode != (uint8_t)VL53_DISTANCE_SHORT && bind->mode != (uint8_t)VL53_DISTANCE_LONG)) {
        return HAL_ERR_INVALID;
    }
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        if (!sensor_ok(cal, i) || (!has_gain && cal->gain_ppm[i] != 0)) {
            return HAL_ERR_INVALID;
        }
    }
    memset(out, 0, TOF_CAL_WIRE_SIZE);
    out[0] = TOF_SECTION_CALIBRATION;
    out[1] = 1u;
    out[2] = TOF_CALIBRATION_V1_LENGTH;
    uint8_t *v = &out[TOF_SECTION_HEADER];
    le_put_u32(&v[0], bind->head_id);
    v[4] = bind->mode;
    v[5] = has_gain ? TOF_CAL_FLAG_GAINS : 0u;
    v[6] = (uint8_t)bind->budget_ms;
    v[7] = (uint8_t)(bind->budget_ms >> 8);
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        uint8_t *s = &v[SENSORS_AT + PER_SENSOR * i];
        le_put_u32(&s[0], (uint32_t)cal->offset_um[i]);
        le_put_u32(&s[4], (uint32_t)cal->gain_ppm[i]);
        le_put_u32(&s[8], cal->offset_sd_um[i]);
        le_put_u32(&s[12], has_gain ? cal->gain_sd_ppm[i] : 0u);
        s[16] = (uint8_t)((uint16_t)cal->offset_gain_corr_q15[i]);
        s[17] = (uint8_t)((uint16_t)cal->offset_gain_corr_q15[i] >> 8);
    }
    return HAL_OK;
}

/* Sensor i of section bytes `v` into `cal`; false for a value out of bounds. */
static bool decode_sensor(const uint8_t *v, bool has_gain, unsigned i,
                          struct calibration_head *cal) {
    const uint8_t *s = &v[SENSORS_AT + PER_SENSOR * i];
    cal->offset_um[i] = as_i32(le_get_u32(&s[0]));
    cal->gain_ppm[i] = as_i32(le_get_u32(&s[4]));
    cal->offset_sd_um[i] = le_get_u32(&s[8]);
    cal->gain_sd_ppm[i] = le_get_u32(&s[12]);
    const uint16_t corr = (uint16_t)(s[16] | s[17] << 8);
    cal->offset_gain_corr_q15[i] =
        (int16_t)(corr <= 0x7FFFu ? (int32_t)corr : (int32_t)corr - 65536);
    if (!has_gain) {
        /* no gain stored: gain 1 with the parts' spread (docs/reference/calibration-file.md) */
        if (cal->gain_ppm[i] != 0 || cal->gain_sd_ppm[i] != 0u) {
            return false;
        }
        cal->gain_sd_ppm[i] = CALIBRATION_UNCAL_GAIN_SD_PPM;
    }
    return sensor_ok(cal, i);
}

/* The body length of calibration section version `version`, or 0 for one not read. */
static uint16_t body_length(uint8_t version) {
    return version == 1u   ? (uint16_t)TOF_CALIBRATION_V1_LENGTH
           : version == 2u ? (uint16_t)TOF_CALIBRATION_V2_LENGTH
           : version == 3u ? (uint16_t)TOF_CALIBRATION_LENGTH
                           : 0u;
}

static uint64_t get_part_id(const uint8_t *v, unsigned i) {
    const uint8_t *p = &v[TOF_CALIBRATION_V1_LENGTH + PART_ID_SIZE * i];
    return (uint64_t)le_get_u32(&p[4]) << 32 | le_get_u32(p);
}

enum tof_cal_state tof_cal_decode(const uint8_t *payload, uint16_t len,
                                  struct calibration_head *cal, struct tof_cal_binding *bind) {
    const int at = tof_section_find(payload, len, TOF_SECTION_CALIBRATION);
    if (at < 0) {
        return at == -1 ? TOF_CAL_NONE : TOF_CAL_CORRUPT;
    }
    const uint8_t *p = &payload[at];
    const uint16_t body = body_length(p[1]);
    if (body == 0u) {
        return TOF_CAL_VERSION;
    }
    const uint8_t *v = &p[TOF_SECTION_HEADER];
    if ((uint16_t)(p[2] | p[3] << 8) != body || (v[5] & (uint8_t)~TOF_CAL_FLAG_GAINS) != 0u) {
        return TOF_CAL_CORRUPT;
    }
    struct calibration_head c;
    memset(&c, 0, sizeof c);
    c.calibrated = true;
    const bool has_gain = (v[5] & TOF_CAL_FLAG_GAINS) != 0u;
    struct tof_cal_binding b = {
        .head_id = le_get_u32(&v[0]), .mode = v[4], .budget_ms = (uint16_t)(v[6] | v[7] << 8)};
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        if (!decode_sensor(v, has_gain, i, &c)) {
            return TOF_CAL_CORRUPT;
        }
        b.part_id[i] = body >= TOF_CALIBRATION_V2_LENGTH ? get_part_id(v, i) : 0u;
    }
    b.arm_um =
        body == TOF_CALIBRATION_LENGTH ? as_i32(le_get_u32(&v[TOF_CALIBRATION_V2_LENGTH])) : 0;
    if (b.arm_um < 0) {
        return TOF_CAL_CORRUPT;
    }
    if ((b.mode != (uint8_t)VL53_DISTANCE_SHORT && b.mode != (uint8_t)VL53_DISTANCE_LONG) ||
        b.budget_ms == 0u) {
        return TOF_CAL_CORRUPT;
    }
    *cal = c;
    *bind = b;
    return TOF_CAL_APPLIED;
}

int tof_cal_bind_parts(const uint8_t *section, const uint64_t part_id[CALIBRATION_SENSORS],
                       uint8_t *out) {
    const uint16_t body = body_length(section[1]);
    if (section[0] != TOF_SECTION_CALIBRATION || body == 0u ||
        (uint16_t)(section[2] | section[3] << 8) != body) {
        return HAL_ERR_INVALID;
    }
    uint8_t *v = &out[TOF_SECTION_HEADER];
    memset(out, 0, TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH);
    memcpy(out, section, TOF_SECTION_HEADER + body);
    out[1] = TOF_CALIBRATION_VERSION;
    out[2] = TOF_CALIBRATION_LENGTH;
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        uint8_t *id = &v[TOF_CALIBRATION_V1_LENGTH + PART_ID_SIZE * i];
        if (get_part_id(v, i) == 0u) {
            le_put_u32(id, (uint32_t)part_id[i]);
            le_put_u32(&id[4], (uint32_t)(part_id[i] >> 32));
        }
    }
    return HAL_OK;
}

void tof_cal_bind_arm(uint8_t *section, int32_t arm_um) {
    uint8_t *arm = &section[TOF_SECTION_HEADER + TOF_CALIBRATION_V2_LENGTH];
    if (le_get_u32(arm) == 0u && arm_um > 0) {
        le_put_u32(arm, (uint32_t)arm_um);
    }
}

void tof_cal_running_parts(const struct tof_app *app, uint64_t running[CALIBRATION_SENSORS]) {
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        running[i] = vl53_part_id(&app->array.dev[i]);
    }
}

struct tof_cal_binding tof_cal_binding_of(const struct tof_app_config *cfg) {
    const struct tof_cal_binding b = {.head_id = cfg->head_id,
                                      .mode = (uint8_t)cfg->timing.mode,
                                      .budget_ms = cfg->timing.budget_ms};
    return b;
}

enum tof_cal_state tof_cal_check(const struct tof_cal_binding *bind,
                                 const struct tof_app_config *cfg,
                                 const uint64_t running[CALIBRATION_SENSORS]) {
    const struct tof_cal_binding mine = tof_cal_binding_of(cfg);
    if (bind->head_id != mine.head_id) {
        return TOF_CAL_OTHER_HEAD;
    }
    for (unsigned i = 0; i < CALIBRATION_SENSORS && running != NULL; ++i) {
        /* a part not bound, or not known running (it did not come up): nothing to compare */
        if (bind->part_id[i] != 0u && running[i] != 0u && bind->part_id[i] != running[i]) {
            return TOF_CAL_OTHER_PARTS;
        }
    }
    if (bind->mode != mine.mode) {
        return TOF_CAL_OTHER_MODE;
    }
    if (bind->budget_ms != mine.budget_ms) {
        return TOF_CAL_OTHER_BUDGET;
    }
    return bind->arm_um != 0 && bind->arm_um != cfg->estimator.arm_um ? TOF_CAL_OTHER_ARM
                                                                      : TOF_CAL_APPLIED;
}

/* tof_cal_check() against the application as it runs: the arm in force is the estimator's
 * (set-arm changes it, not the compiled configuration). */
static enum tof_cal_state check_in_force(const struct tof_cal_binding *bind,
                                         const struct tof_app *app,
                                         const uint64_t running[CALIBRATION_SENSORS]) {
    const enum tof_cal_state st = tof_cal_check(bind, &app->cfg, running);
    if (st != TOF_CAL_APPLIED && st != TOF_CAL_OTHER_ARM) {
        return st;
    }
    return bind->arm_um != 0 && bind->arm_um != app->estimator.cfg.arm_um ? TOF_CAL_OTHER_ARM
                                                                          : TOF_CAL_APPLIED;
}

enum tof_cal_state tof_cal_boot(struct tof_record_store *store, struct tof_app *app) {
    enum tof_cal_state state = TOF_CAL_NO_STORAGE;
    if (store != NULL && store->storage.ops != NULL) {
        switch (tof_record_load(store)) {
        case TOF_RECORD_LOADED:
            return tof_cal_recheck(store, app);
        case TOF_RECORD_NONE:
            state = TOF_CAL_NONE;
            break;
        case TOF_RECORD_VERSION:
            state = TOF_CAL_VERSION;
            break;
        default:
            state = TOF_CAL_CORRUPT;
            break;
        }
    }
    /* No record to apply: the configuration's own calibration, whatever was in force before
     * (a boot after a soft restart, or a test rig reusing the application, must not keep it). */
    (void)tof_app_set_calibration(app, &app->cfg.estimator.calibration);
    return state;
}

enum tof_cal_state tof_cal_recheck(const struct tof_record_store *store, struct tof_app *app) {
    struct calibration_head cal;
    struct tof_cal_binding bind;
    (void)memset(&cal, 0, sizeof cal); /* read only when decoded (cppcheck cannot tell) */
    (void)memset(&bind, 0, sizeof bind);
    enum tof_cal_state state = TOF_CAL_NO_STORAGE;
    if (store != NULL && store->storage.ops != NULL) {
        state = store->current < 0 ? TOF_CAL_NONE
                                   : tof_cal_decode(store->payload, store->length, &cal, &bind);
    }
    uint64_t running[CALIBRATION_SENSORS];
    tof_cal_running_parts(app, running);
    if (state == TOF_CAL_APPLIED) {
        state = check_in_force(&bind, app, running);
    }
    if (state == TOF_CAL_APPLIED && tof_app_set_calibration(app, &cal) != 0) {
        state = TOF_CAL_REJECTED;
    }
    if (state != TOF_CAL_APPLIED) { /* the configuration's own (uncalibrated unless it says) */
        (void)tof_app_set_calibration(app, &app->cfg.estimator.calibration);
    }
    return state;
}

enum tof_cal_state tof_cal_write(struct tof_record_store *store, struct tof_app *app,
                                 const uint8_t *section, int *error) {
    *error = 0;
    struct calibration_head cal;
    struct tof_cal_binding bind;
    /* Static, not on the stack: the re-zero reaches here at the deepest point of the
     * sample path (the m4 image's stack reserve). Never re-entered: main loop only. */
    static uint64_t running[CALIBRATION_SENSORS];
    tof_cal_running_parts(app, running);
    /* the section as stored on board: version 2, bound to the parts that run */
    static uint8_t stored[TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH];
    enum tof_cal_state state = TOF_CAL_VERSION;
    if (tof_cal_bind_parts(section, running, stored) == HAL_OK) {
        tof_cal_bind_arm(stored, app->estimator.cfg.arm_um); /* written at the arm in force */
        state = tof_cal_decode(stored, (uint16_t)sizeof stored, &cal, &bind);
    } else if (section[0] != TOF_SECTION_CALIBRATION || body_length(section[1]) != 0u) {
        state = TOF_CAL_CORRUPT; /* not a calibration section, or a wrong length */
    }
    if (state == TOF_CAL_APPLIED) {
        state = check_in_force(&bind, app, running);
    }
    if (state == TOF_CAL_NONE) {
        state = TOF_CAL_CORRUPT; /* not a calibration section at all */
    }
    if (state != TOF_CAL_APPLIED) {
        return state;
    }
    /* Saved first: a calibration in force that the next boot would not find is worse
     * than one refused now. */
    *error = tof_section_save(store, stored);
    if (*error != HAL_OK) {
        return TOF_CAL_NO_STORAGE;
    }
    *error = tof_app_set_calibration(app, &cal);
    return *error == 0 ? TOF_CAL_APPLIED : TOF_CAL_REJECTED;
}

void tof_cal_read(const struct tof_record_store *store, uint8_t *section) {
    memset(section, 0, TOF_CAL_WIRE_SIZE);
    if (store == NULL || store->current < 0) {
        return;
    }
    const int at = tof_section_find(store->payload, store->length, TOF_SECTION_CALIBRATION);
    if (at >= 0 && (uint16_t)(store->payload[at + 2] | store->payload[at + 3] << 8) ==
                       body_length(store->payload[at + 1])) {
        /* version 1 as stored, or version 2 without the parts' identities */
        memcpy(section, &store->payload[at], TOF_CAL_WIRE_SIZE);
        section[1] = 1u;
        section[2] = TOF_CALIBRATION_V1_LENGTH;
    }
}

enum tof_cal_state tof_cal_write_head(struct tof_record_store *store, struct tof_app *app,
                                      const struct calibration_head *cal, int *error) {
    bool has_gain = false;
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        has_gain = has_gain || cal->gain_ppm[i] != 0 ||
                   cal->gain_sd_ppm[i] != CALIBRATION_UNCAL_GAIN_SD_PPM;
    }
    const struct tof_cal_binding bind = tof_cal_binding_of(&app->cfg);
    static uint8_t section[TOF_CAL_WIRE_SIZE]; /* static: see tof_cal_write() */
    *error = 0;
    if (tof_cal_encode(cal, has_gain, &bind, section) != HAL_OK) {
        return TOF_CAL_CORRUPT;
    }
    return tof_cal_write(store, app, section, error);
}

uint16_t tof_cal_tag(const struct tof_record_store *store) {
    if (store == NULL || store->current < 0) {
        return 0u;
    }
    const int at = tof_section_find(store->payload, store->length, TOF_SECTION_CALIBRATION);
    if (at < 0) {
        return 0u;
    }
    const uint16_t body = (uint16_t)(store->payload[at + 2] | store->payload[at + 3] << 8);
    if ((uint32_t)at + TOF_SECTION_HEADER + body > store->length) {
        return 0u;
    }
    return tlm_crc16(TLM_CRC_INIT, &store->payload[at], (size_t)TOF_SECTION_HEADER + body);
}
