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

/* The blocks a version may hold after bytes 0..79, and their sizes. */
enum { BLOCK_THERMAL, BLOCK_PARTS, BLOCK_ARM, BLOCKS };
static const uint8_t block_size[BLOCKS] = {TOF_CALIBRATION_V4_LENGTH - CAL_TEMP_AT,
                                           CALIBRATION_SENSORS *PART_ID_SIZE, 4u};

/* Where each version keeps them (0: not in it), and its body's length. */
struct cal_layout {
    uint8_t length;
    uint8_t at[BLOCKS];
};
static const struct cal_layout layouts[TOF_CALIBRATION_VERSION + 1u] = {
    [1] = {TOF_CALIBRATION_V1_LENGTH, {0u, 0u, 0u}},
    [2] = {TOF_CALIBRATION_V2_LENGTH, {0u, TOF_CALIBRATION_V1_LENGTH, 0u}},
    [3] = {TOF_CALIBRATION_V3_LENGTH, {0u, TOF_CALIBRATION_V1_LENGTH, TOF_CALIBRATION_V2_LENGTH}},
    [4] = {TOF_CALIBRATION_V4_LENGTH, {CAL_TEMP_AT, 0u, 0u}},
    [5] = {TOF_CALIBRATION_LENGTH, {CAL_TEMP_AT, PARTS_AT_V5, ARM_AT_V5}},
};

/* The layout of the section whose header is `section`, NULL for a version not read or a
 * length not its version's. */
static const struct cal_layout *layout_of(const uint8_t *section) {
    const uint8_t version = section[1];
    if (version < 1u || version > TOF_CALIBRATION_VERSION ||
        (uint16_t)(section[2] | section[3] << 8) != layouts[version].length) {
        return NULL;
    }
    return &layouts[version];
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

/* estimator/calibration.h's bounds, field by field (enum tof_cal_field order from
 * TOF_CAL_FIELD_OFFSET): where the four values sit, and the largest |value| (signed) or
 * value. A field of a flag (gains, thermal) that is clear must be 0. */
struct cal_bound {
    uint8_t at, stride;
    uint8_t flag;   /* the flag the field needs, 0: none */
    bool is_signed; /* i32, else u32 */
    int32_t max;
};
static const struct cal_bound bounds[] = {
    {SENSORS_AT, PER_SENSOR, 0u, true, CALIBRATION_OFFSET_MAX_UM},
    {SENSORS_AT + 4u, PER_SENSOR, TOF_CAL_FLAG_GAINS, true, CALIBRATION_GAIN_MAX_PPM},
    {SENSORS_AT + 8u, PER_SENSOR, 0u, false, CALIBRATION_OFFSET_MAX_UM},
    {SENSORS_AT + 12u, PER_SENSOR, TOF_CAL_FLAG_GAINS, false, CALIBRATION_GAIN_MAX_PPM},
    {COEFF_AT, PER_COEFF, TOF_CAL_FLAG_THERMAL, true, CALIBRATION_TEMP_COEFF_MAX_NM_PER_C},
    {COEFF_AT + 4u, PER_COEFF, TOF_CAL_FLAG_THERMAL, false, CALIBRATION_TEMP_COEFF_MAX_NM_PER_C},
};
_Static_assert(TOF_CAL_FIELD_GAIN == TOF_CAL_FIELD_OFFSET + 1 &&
                   TOF_CAL_FIELD_OFFSET_SD == TOF_CAL_FIELD_OFFSET + 2 &&
                   TOF_CAL_FIELD_GAIN_SD == TOF_CAL_FIELD_OFFSET + 3 &&
                   TOF_CAL_FIELD_TEMP_COEFF == TOF_CAL_FIELD_OFFSET + 4 &&
                   TOF_CAL_FIELD_TEMP_COEFF_SD == TOF_CAL_FIELD_OFFSET + 5,
               "bounds[] is in the fields' order");

/* The first field of body `v` (of version `version`'s layout `lay`) that is wrong, or NONE:
 * the one check both the encoder (of what it wrote) and the decoder run. */
static enum tof_cal_field body_bad(const uint8_t *v, const struct cal_layout *lay) {
    const bool thermal_block = lay->at[BLOCK_THERMAL] != 0u;
    const uint8_t flags = v[5];
    if ((flags & (uint8_t) ~(TOF_CAL_FLAG_GAINS | (thermal_block ? TOF_CAL_FLAG_THERMAL : 0u))) !=
        0u) {
        return TOF_CAL_FIELD_FLAGS;
    }
    if (v[4] != (uint8_t)VL53_DISTANCE_SHORT && v[4] != (uint8_t)VL53_DISTANCE_LONG) {
        return TOF_CAL_FIELD_MODE;
    }
    if ((v[6] | v[7]) == 0u) {
        return TOF_CAL_FIELD_BUDGET;
    }
    if (thermal_block) {
        const int16_t t = get_i16(&v[CAL_TEMP_AT]);
        const bool on = (flags & TOF_CAL_FLAG_THERMAL) != 0u;
        if (on ? t < CALIBRATION_TEMP_MIN_CDEG || t > CALIBRATION_TEMP_MAX_CDEG : t != 0) {
            return TOF_CAL_FIELD_CAL_TEMP;
        }
    }
    for (unsigned f = 0; f < sizeof bounds / sizeof bounds[0]; ++f) {
        const struct cal_bound *b = &bounds[f];
        if (b->flag == TOF_CAL_FLAG_THERMAL && !thermal_block) {
            break; /* the thermal fields come last */
        }
        const uint32_t max = (flags & b->flag) == b->flag ? (uint32_t)b->max : 0u;
        for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
            const uint32_t u = le_get_u32(&v[b->at + b->stride * i]);
            const int32_t s = as_i32(u);
            if (b->is_signed ? s < -(int32_t)max || s > (int32_t)max : u > max) {
                return (enum tof_cal_field)(TOF_CAL_FIELD_OFFSET + (int)f);
            }
        }
    }
    const uint8_t arm = lay->at[BLOCK_ARM];
    return arm != 0u && as_i32(le_get_u32(&v[arm])) < 0 ? TOF_CAL_FIELD_ARM : TOF_CAL_FIELD_NONE;
}

int tof_cal_encode(const struct calibration_head *cal, bool has_gain,
                   const struct tof_cal_binding *bind, uint8_t *out) {
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
        le_put_u32(&s[4], (uint32_t)cal->gain_ppm[i]); /* not fitted: must be 0 (checked) */
        le_put_u32(&s[8], cal->offset_sd_um[i]);
        le_put_u32(&s[12], has_gain ? cal->gain_sd_ppm[i] : 0u);
        put_i16(&s[16], cal->offset_gain_corr_q15[i]);
        if (cal->thermal) { /* else the thermal bytes stay 0: the coefficients are ignored */
            le_put_u32(&v[COEFF_AT + PER_COEFF * i], (uint32_t)cal->temp_coeff_nm_per_c[i]);
            le_put_u32(&v[COEFF_AT + PER_COEFF * i + 4u], cal->temp_coeff_sd_nm_per_c[i]);
        }
    }
    if (cal->thermal) {
        put_i16(&v[CAL_TEMP_AT], cal->cal_temp_cdeg);
    }
    if (!cal->calibrated ||
        body_bad(v, &layouts[TOF_CALIBRATION_WIRE_VERSION]) != TOF_CAL_FIELD_NONE) {
        memset(out, 0, TOF_CAL_WIRE_SIZE);
        return HAL_ERR_INVALID;
    }
    return HAL_OK;
}

static uint64_t get_part_id(const uint8_t *v, unsigned at, unsigned i) {
    const uint8_t *p = &v[at + PART_ID_SIZE * i];
    return (uint64_t)le_get_u32(&p[4]) << 32 | le_get_u32(p);
}

/* The fields of body `v` (checked by body_bad()) into *cal and *bind. */
static void decode_body(const uint8_t *v, const struct cal_layout *lay,
                        struct calibration_head *cal, struct tof_cal_binding *bind) {
    memset(cal, 0, sizeof *cal);
    memset(bind, 0, sizeof *bind);
    bind->head_id = le_get_u32(&v[0]);
    bind->mode = v[4];
    bind->budget_ms = (uint16_t)(v[6] | v[7] << 8);
    cal->calibrated = true;
    cal->thermal = (v[5] & TOF_CAL_FLAG_THERMAL) != 0u;
    const bool has_gain = (v[5] & TOF_CAL_FLAG_GAINS) != 0u;
    const uint8_t parts = lay->at[BLOCK_PARTS];
    const bool thermal = lay->at[BLOCK_THERMAL] != 0u;
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        const uint8_t *s = &v[SENSORS_AT + PER_SENSOR * i];
        cal->offset_um[i] = as_i32(le_get_u32(&s[0]));
        cal->gain_ppm[i] = as_i32(le_get_u32(&s[4]));
        cal->offset_sd_um[i] = le_get_u32(&s[8]);
        /* no gain stored: gain 1 with the parts' spread (docs/reference/calibration-file.md) */
        cal->gain_sd_ppm[i] = has_gain ? le_get_u32(&s[12]) : CALIBRATION_UNCAL_GAIN_SD_PPM;
        cal->offset_gain_corr_q15[i] = get_i16(&s[16]);
        if (thermal) { /* 0 unless the thermal flag is set (body_bad()) */
            cal->temp_coeff_nm_per_c[i] = as_i32(le_get_u32(&v[COEFF_AT + PER_COEFF * i]));
            cal->temp_coeff_sd_nm_per_c[i] = le_get_u32(&v[COEFF_AT + PER_COEFF * i + 4u]);
        }
        bind->part_id[i] = parts != 0u ? get_part_id(v, parts, i) : 0u;
    }
    cal->cal_temp_cdeg = (int16_t)(thermal ? get_i16(&v[CAL_TEMP_AT]) : 0);
    bind->arm_um = lay->at[BLOCK_ARM] != 0u ? as_i32(le_get_u32(&v[lay->at[BLOCK_ARM]])) : 0;
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
        const struct cal_layout *lay = layout_of(p);
        if (p[1] < 1u || p[1] > TOF_CALIBRATION_VERSION) {
            state = TOF_CAL_VERSION;
        } else if (lay != NULL) {
            bad = body_bad(&p[TOF_SECTION_HEADER], lay);
            if (bad == TOF_CAL_FIELD_NONE) {
                decode_body(&p[TOF_SECTION_HEADER], lay, cal, bind);
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
        [TOF_CAL_FIELD_TEMP_COEFF] = "temp_coeff_nm_per_c",
        [TOF_CAL_FIELD_TEMP_COEFF_SD] = "temp_coeff_sd_nm_per_c",
        [TOF_CAL_FIELD_CAL_TEMP] = "cal_temp_cdeg",
        [TOF_CAL_FIELD_ARM] = "arm_um",
    };
    return (unsigned)field < sizeof names / sizeof names[0] ? names[field] : "unknown field";
}

/* Section `section` (of layout `from`) as version `version` into `out`: bytes 0..79 and every
 * block both versions hold; the others 0. */
static void convert(const uint8_t *section, const struct cal_layout *from, uint8_t version,
                    uint8_t *out) {
    const struct cal_layout *to = &layouts[version];
    memset(out, 0, TOF_SECTION_HEADER + (size_t)to->length);
    memcpy(out, section, TOF_SECTION_HEADER + TOF_CALIBRATION_V1_LENGTH);
    out[1] = version;
    out[2] = to->length;
    for (unsigned k = 0; k < BLOCKS; ++k) {
        if (from->at[k] != 0u && to->at[k] != 0u) {
            memcpy(&out[TOF_SECTION_HEADER + to->at[k]], &section[TOF_SECTION_HEADER + from->at[k]],
                   block_size[k]);
        }
    }
}

int tof_cal_bind_parts(const uint8_t *section, const uint64_t part_id[CALIBRATION_SENSORS],
                       uint8_t *out) {
    const struct cal_layout *lay = layout_of(section);
    if (section[0] != TOF_SECTION_CALIBRATION || lay == NULL ||
        (lay->at[BLOCK_THERMAL] == 0u &&
         (section[TOF_SECTION_HEADER + 5u] & TOF_CAL_FLAG_THERMAL) != 0u)) {
        return HAL_ERR_INVALID; /* a reserved flag must not become version 5's thermal one */
    }
    convert(section, lay, TOF_CALIBRATION_VERSION, out);
    uint8_t *v = &out[TOF_SECTION_HEADER];
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
    } else if (section[0] != TOF_SECTION_CALIBRATION ||
               (section[1] >= 1u && section[1] <= TOF_CALIBRATION_VERSION)) {
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
    const struct cal_layout *lay = at >= 0 ? layout_of(&store->payload[at]) : NULL;
    if (lay != NULL) { /* versions 1 to 3: the thermal bytes 0 */
        convert(&store->payload[at], lay, TOF_CALIBRATION_WIRE_VERSION, section);
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
