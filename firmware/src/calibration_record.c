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
#define PART_ID_SIZE 8u                        /* u64, two little-endian u32: low word first */
#define CAL_TEMP_AT  TOF_CALIBRATION_V1_LENGTH /* versions 4 and 5: i16 cal_temp_cdeg */
#define COEFF_AT     (CAL_TEMP_AT + 2u)        /* then per sensor i32 coeff, u32 its sd */
#define PER_COEFF    8u
#define THERMAL_SIZE (TOF_CALIBRATION_V4_LENGTH - TOF_CALIBRATION_V1_LENGTH)
#define PARTS_AT_V5  TOF_CALIBRATION_V4_LENGTH
#define ARM_AT_V5    (PARTS_AT_V5 + CALIBRATION_SENSORS * PART_ID_SIZE)
_Static_assert(SENSORS_AT + CALIBRATION_SENSORS * PER_SENSOR == TOF_CALIBRATION_V1_LENGTH,
               "section 2 version 1 is 80 bytes");
_Static_assert(TOF_CALIBRATION_V1_LENGTH + CALIBRATION_SENSORS * PART_ID_SIZE ==
                   TOF_CALIBRATION_V2_LENGTH,
               "version 2 is version 1 and the four parts' identities");
_Static_assert(TOF_CALIBRATION_V2_LENGTH + 4u == TOF_CALIBRATION_V3_LENGTH,
               "version 3 is version 2 and the arm");
_Static_assert(COEFF_AT + CALIBRATION_SENSORS * PER_COEFF == TOF_CALIBRATION_V4_LENGTH,
               "version 4 is version 1 and the thermal fields");
_Static_assert(ARM_AT_V5 + 4u == TOF_CALIBRATION_LENGTH,
               "version 5 is version 4, the parts' identities and the arm");
_Static_assert(TOF_CAL_WIRE_SIZE == TLM_CAL_SECTION_LEN, "the commands carry version 4");
_Static_assert(TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH + TOF_SECTION_HEADER +
                       TOF_SETTINGS_LENGTH <=
                   TOF_RECORD_PAYLOAD_MAX,
               "the settings and the calibration fit one record");

/* Where each version keeps what it has (0: not in it; the thermal fields: versions 4, 5). */
struct cal_layout {
    uint8_t length;   /* the body's bytes */
    uint8_t parts_at; /* the parts' identities */
    uint8_t arm_at;   /* the arm */
};
static const struct cal_layout layouts[TOF_CALIBRATION_VERSION + 1u] = {
    [1] = {TOF_CALIBRATION_V1_LENGTH, 0u, 0u},
    [2] = {TOF_CALIBRATION_V2_LENGTH, TOF_CALIBRATION_V1_LENGTH, 0u},
    [3] = {TOF_CALIBRATION_V3_LENGTH, TOF_CALIBRATION_V1_LENGTH, TOF_CALIBRATION_V2_LENGTH},
    [4] = {TOF_CALIBRATION_V4_LENGTH, 0u, 0u},
    [5] = {TOF_CALIBRATION_LENGTH, PARTS_AT_V5, ARM_AT_V5},
};

/* The layout of calibration section version `version`, NULL for one not read. */
static const struct cal_layout *layout_of(uint8_t version) {
    return version >= 1u && version <= TOF_CALIBRATION_VERSION ? &layouts[version] : NULL;
}

/* The flags a version may set (the others are reserved, 0). */
static uint8_t flags_allowed(uint8_t version) {
    return version >= TOF_CALIBRATION_WIRE_VERSION ? TOF_CAL_FLAG_GAINS | TOF_CAL_FLAG_THERMAL
                                                   : TOF_CAL_FLAG_GAINS;
}

/* Two's complement from the stored bits, without relying on the conversion's behaviour. */
static int32_t as_i32(uint32_t v) {
    return v <= 0x7FFFFFFFu ? (int32_t)v : -(int32_t)(~v) - 1;
}

static int16_t get_i16(const uint8_t *p) {
    const uint16_t v = (uint16_t)(p[0] | p[1] << 8);
    return (int16_t)(v <= 0x7FFFu ? (int32_t)v : (int32_t)v - 65536);
}

static void put_i16(uint8_t *p, int16_t v) {
    p[0] = (uint8_t)((uint16_t)v);
    p[1] = (uint8_t)((uint16_t)v >> 8);
}

static bool within(int32_t v, int32_t max) {
    return v >= -max && v <= max;
}

/* The first of sensor i's values outside estimator/calibration.h's bounds, or NONE (the
 * thermal ones only when `cal` is thermal). */
static enum tof_cal_field sensor_bad(const struct calibration_head *cal, unsigned i) {
    if (!within(cal->offset_um[i], CALIBRATION_OFFSET_MAX_UM)) {
        return TOF_CAL_FIELD_OFFSET;
    }
    if (!within(cal->gain_ppm[i], CALIBRATION_GAIN_MAX_PPM)) {
        return TOF_CAL_FIELD_GAIN;
    }
    if (cal->offset_sd_um[i] > (uint32_t)CALIBRATION_OFFSET_MAX_UM) {
        return TOF_CAL_FIELD_OFFSET_SD;
    }
    if (cal->gain_sd_ppm[i] > (uint32_t)CALIBRATION_GAIN_MAX_PPM) {
        return TOF_CAL_FIELD_GAIN_SD;
    }
    if (cal->thermal && !within(cal->temp_coeff_nm_per_c[i], CALIBRATION_TEMP_COEFF_MAX_NM_PER_C)) {
        return TOF_CAL_FIELD_TEMP_COEFF;
    }
    if (cal->thermal &&
        cal->temp_coeff_sd_nm_per_c[i] > (uint32_t)CALIBRATION_TEMP_COEFF_MAX_NM_PER_C) {
        return TOF_CAL_FIELD_TEMP_COEFF_SD;
    }
    return TOF_CAL_FIELD_NONE;
}

static bool cal_temp_ok(const struct calibration_head *cal) {
    return !cal->thermal || (cal->cal_temp_cdeg >= CALIBRATION_TEMP_MIN_CDEG &&
                             cal->cal_temp_cdeg <= CALIBRATION_TEMP_MAX_CDEG);
}

int tof_cal_encode(const struct calibration_head *cal, bool has_gain,
                   const struct tof_cal_binding *bind, uint8_t *out) {
    if (!cal->calibrated || bind->budget_ms == 0u || !cal_temp_ok(cal) ||
        (bind->mode != (uint8_t)VL53_DISTANCE_SHORT && bind->mode != (uint8_t)VL53_DISTANCE_LONG)) {
        return HAL_ERR_INVALID;
    }
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        if (sensor_bad(cal, i) != TOF_CAL_FIELD_NONE || (!has_gain && cal->gain_ppm[i] != 0)) {
            return HAL_ERR_INVALID;
        }
    }
    memset(out, 0, TOF_CAL_WIRE_SIZE);
    out[0] = TOF_SECTION_CALIBRATION;
    out[1] = TOF_CALIBRATION_WIRE_VERSION;
    out[2] = TOF_CALIBRATION_V4_LENGTH;
    uint8_t *v = &out[TOF_SECTION_HEADER];
    le_put_u32(&v[0], bind->head_id);
    v[4] = bind->mode;
    v[5] = (uint8_t)((has_gain ? TOF_CAL_FLAG_GAINS : 0u) |
                     (cal->thermal ? TOF_CAL_FLAG_THERMAL : 0u));
    v[6] = (uint8_t)bind->budget_ms;
    v[7] = (uint8_t)(bind->budget_ms >> 8);
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        uint8_t *s = &v[SENSORS_AT + PER_SENSOR * i];
        le_put_u32(&s[0], (uint32_t)cal->offset_um[i]);
        le_put_u32(&s[4], (uint32_t)cal->gain_ppm[i]);
        le_put_u32(&s[8], cal->offset_sd_um[i]);
        le_put_u32(&s[12], has_gain ? cal->gain_sd_ppm[i] : 0u);
        put_i16(&s[16], cal->offset_gain_corr_q15[i]);
    }
    if (cal->thermal) { /* else the thermal bytes stay 0: the coefficients are ignored */
        put_i16(&v[CAL_TEMP_AT], cal->cal_temp_cdeg);
        for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
            le_put_u32(&v[COEFF_AT + PER_COEFF * i], (uint32_t)cal->temp_coeff_nm_per_c[i]);
            le_put_u32(&v[COEFF_AT + PER_COEFF * i + 4u], cal->temp_coeff_sd_nm_per_c[i]);
        }
    }
    return HAL_OK;
}

/* Sensor i of section bytes `v` into `cal` (the thermal fields already there); the first
 * value out of bounds, or NONE. */
static enum tof_cal_field decode_sensor(const uint8_t *v, bool has_gain, unsigned i,
                                        struct calibration_head *cal) {
    const uint8_t *s = &v[SENSORS_AT + PER_SENSOR * i];
    cal->offset_um[i] = as_i32(le_get_u32(&s[0]));
    cal->gain_ppm[i] = as_i32(le_get_u32(&s[4]));
    cal->offset_sd_um[i] = le_get_u32(&s[8]);
    cal->gain_sd_ppm[i] = le_get_u32(&s[12]);
    cal->offset_gain_corr_q15[i] = get_i16(&s[16]);
    if (!has_gain) {
        /* no gain stored: gain 1 with the parts' spread (docs/reference/calibration-file.md) */
        if (cal->gain_ppm[i] != 0) {
            return TOF_CAL_FIELD_GAIN;
        }
        if (cal->gain_sd_ppm[i] != 0u) {
            return TOF_CAL_FIELD_GAIN_SD;
        }
        cal->gain_sd_ppm[i] = CALIBRATION_UNCAL_GAIN_SD_PPM;
    }
    return sensor_bad(cal, i);
}

/* The thermal fields of a version-4 or -5 body `v` into `cal`: NONE, or the field that is
 * out of bounds or set without the thermal flag (nothing is stored that is not read). */
static enum tof_cal_field decode_thermal(const uint8_t *v, struct calibration_head *cal) {
    cal->thermal = (v[5] & TOF_CAL_FLAG_THERMAL) != 0u;
    cal->cal_temp_cdeg = get_i16(&v[CAL_TEMP_AT]);
    if (!cal_temp_ok(cal) || (!cal->thermal && cal->cal_temp_cdeg != 0)) {
        return TOF_CAL_FIELD_CAL_TEMP;
    }
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        cal->temp_coeff_nm_per_c[i] = as_i32(le_get_u32(&v[COEFF_AT + PER_COEFF * i]));
        cal->temp_coeff_sd_nm_per_c[i] = le_get_u32(&v[COEFF_AT + PER_COEFF * i + 4u]);
        if (!cal->thermal && cal->temp_coeff_nm_per_c[i] != 0) {
            return TOF_CAL_FIELD_TEMP_COEFF;
        }
        if (!cal->thermal && cal->temp_coeff_sd_nm_per_c[i] != 0u) {
            return TOF_CAL_FIELD_TEMP_COEFF_SD;
        }
    }
    return TOF_CAL_FIELD_NONE;
}

static uint64_t get_part_id(const uint8_t *v, unsigned at, unsigned i) {
    const uint8_t *p = &v[at + PART_ID_SIZE * i];
    return (uint64_t)le_get_u32(&p[4]) << 32 | le_get_u32(p);
}

/* The body's fields into *cal and *bind: NONE, or the first field that is wrong. */
static enum tof_cal_field decode_body(const uint8_t *v, uint8_t version,
                                      const struct cal_layout *lay, struct calibration_head *cal,
                                      struct tof_cal_binding *bind) {
    if ((v[5] & (uint8_t)~flags_allowed(version)) != 0u) {
        return TOF_CAL_FIELD_FLAGS;
    }
    bind->head_id = le_get_u32(&v[0]);
    bind->mode = v[4];
    bind->budget_ms = (uint16_t)(v[6] | v[7] << 8);
    if (bind->mode != (uint8_t)VL53_DISTANCE_SHORT && bind->mode != (uint8_t)VL53_DISTANCE_LONG) {
        return TOF_CAL_FIELD_MODE;
    }
    if (bind->budget_ms == 0u) {
        return TOF_CAL_FIELD_BUDGET;
    }
    cal->calibrated = true;
    if (version >= TOF_CALIBRATION_WIRE_VERSION) {
        const enum tof_cal_field bad = decode_thermal(v, cal);
        if (bad != TOF_CAL_FIELD_NONE) {
            return bad;
        }
    }
    const bool has_gain = (v[5] & TOF_CAL_FLAG_GAINS) != 0u;
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        const enum tof_cal_field bad = decode_sensor(v, has_gain, i, cal);
        if (bad != TOF_CAL_FIELD_NONE) {
            return bad;
        }
        bind->part_id[i] = lay->parts_at != 0u ? get_part_id(v, lay->parts_at, i) : 0u;
    }
    bind->arm_um = lay->arm_at != 0u ? as_i32(le_get_u32(&v[lay->arm_at])) : 0;
    return bind->arm_um < 0 ? TOF_CAL_FIELD_ARM : TOF_CAL_FIELD_NONE;
}

enum tof_cal_state tof_cal_decode(const uint8_t *payload, uint16_t len,
                                  struct calibration_head *cal, struct tof_cal_binding *bind,
                                  enum tof_cal_field *field) {
    enum tof_cal_field bad = TOF_CAL_FIELD_HEADER;
    enum tof_cal_state state = TOF_CAL_CORRUPT;
    const int at = tof_section_find(payload, len, TOF_SECTION_CALIBRATION);
    if (at == -1) {
        state = TOF_CAL_NONE;
        bad = TOF_CAL_FIELD_NONE;
    } else if (at >= 0) {
        const uint8_t *p = &payload[at];
        const struct cal_layout *lay = layout_of(p[1]);
        if (lay == NULL) {
            state = TOF_CAL_VERSION;
        } else if ((uint16_t)(p[2] | p[3] << 8) == lay->length) {
            struct calibration_head c;
            struct tof_cal_binding b;
            memset(&c, 0, sizeof c);
            memset(&b, 0, sizeof b);
            bad = decode_body(&p[TOF_SECTION_HEADER], p[1], lay, &c, &b);
            if (bad == TOF_CAL_FIELD_NONE) {
                *cal = c;
                *bind = b;
                state = TOF_CAL_APPLIED;
            }
        }
    }
    if (field != NULL) {
        *field = bad;
    }
    return state;
}

const char *tof_cal_field_name(enum tof_cal_field field) {
    static const char *const names[] = {
        [TOF_CAL_FIELD_NONE] = "none",
        [TOF_CAL_FIELD_HEADER] = "section header (id, version, length)",
        [TOF_CAL_FIELD_FLAGS] = "flags (a reserved bit)",
        [TOF_CAL_FIELD_MODE] = "distance mode",
        [TOF_CAL_FIELD_BUDGET] = "timing budget",
        [TOF_CAL_FIELD_OFFSET] = "offset_um",
        [TOF_CAL_FIELD_GAIN] = "gain_ppm",
        [TOF_CAL_FIELD_OFFSET_SD] = "offset_sd_um",
        [TOF_CAL_FIELD_GAIN_SD] = "gain_sd_ppm",
        [TOF_CAL_FIELD_ARM] = "arm_um",
        [TOF_CAL_FIELD_CAL_TEMP] = "cal_temp_cdeg",
        [TOF_CAL_FIELD_TEMP_COEFF] = "temp_coeff_nm_per_c",
        [TOF_CAL_FIELD_TEMP_COEFF_SD] = "temp_coeff_sd_nm_per_c",
    };
    return (unsigned)field < sizeof names / sizeof names[0] ? names[field] : "unknown field";
}

int tof_cal_bind_parts(const uint8_t *section, const uint64_t part_id[CALIBRATION_SENSORS],
                       uint8_t *out) {
    const struct cal_layout *lay = layout_of(section[1]);
    if (section[0] != TOF_SECTION_CALIBRATION || lay == NULL ||
        (uint16_t)(section[2] | section[3] << 8) != lay->length ||
        (section[TOF_SECTION_HEADER + 5u] & (uint8_t)~flags_allowed(section[1])) != 0u) {
        return HAL_ERR_INVALID; /* a reserved flag must not become version 5's thermal one */
    }
    const uint8_t *from = &section[TOF_SECTION_HEADER];
    uint8_t *v = &out[TOF_SECTION_HEADER];
    memset(out, 0, TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH);
    memcpy(out, section, TOF_SECTION_HEADER + TOF_CALIBRATION_V1_LENGTH);
    out[1] = TOF_CALIBRATION_VERSION;
    out[2] = TOF_CALIBRATION_LENGTH;
    if (section[1] >= TOF_CALIBRATION_WIRE_VERSION) {
        memcpy(&v[CAL_TEMP_AT], &from[CAL_TEMP_AT], THERMAL_SIZE);
    }
    if (lay->parts_at != 0u) {
        memcpy(&v[PARTS_AT_V5], &from[lay->parts_at], CALIBRATION_SENSORS * PART_ID_SIZE);
    }
    if (lay->arm_at != 0u) {
        memcpy(&v[ARM_AT_V5], &from[lay->arm_at], 4u);
    }
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        uint8_t *id = &v[PARTS_AT_V5 + PART_ID_SIZE * i];
        if (get_part_id(v, PARTS_AT_V5, i) == 0u) {
            le_put_u32(id, (uint32_t)part_id[i]);
            le_put_u32(&id[4], (uint32_t)(part_id[i] >> 32));
        }
    }
    return HAL_OK;
}

void tof_cal_bind_arm(uint8_t *section, int32_t arm_um) {
    uint8_t *arm = &section[TOF_SECTION_HEADER + ARM_AT_V5];
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
        state = store->current < 0
                    ? TOF_CAL_NONE
                    : tof_cal_decode(store->payload, store->length, &cal, &bind, NULL);
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
    /* the section as stored on board: version 5, bound to the parts that run */
    static uint8_t stored[TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH];
    enum tof_cal_state state = TOF_CAL_VERSION;
    if (tof_cal_bind_parts(section, running, stored) == HAL_OK) {
        tof_cal_bind_arm(stored, app->estimator.cfg.arm_um); /* written at the arm in force */
        state = tof_cal_decode(stored, (uint16_t)sizeof stored, &cal, &bind, NULL);
    } else if (section[0] != TOF_SECTION_CALIBRATION || layout_of(section[1]) != NULL) {
        state = TOF_CAL_CORRUPT; /* not a calibration section, a wrong length, a reserved flag */
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
    if (at < 0) {
        return;
    }
    const uint8_t *p = &store->payload[at];
    const struct cal_layout *lay = layout_of(p[1]);
    if (lay != NULL && (uint16_t)(p[2] | p[3] << 8) == lay->length) {
        /* the fields versions 1 to 5 share, and the thermal ones where stored (else 0) */
        memcpy(section, p, TOF_SECTION_HEADER + TOF_CALIBRATION_V1_LENGTH);
        if (p[1] >= TOF_CALIBRATION_WIRE_VERSION) {
            memcpy(&section[TOF_SECTION_HEADER + CAL_TEMP_AT], &p[TOF_SECTION_HEADER + CAL_TEMP_AT],
                   THERMAL_SIZE);
        }
        section[1] = TOF_CALIBRATION_WIRE_VERSION;
        section[2] = TOF_CALIBRATION_V4_LENGTH;
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
