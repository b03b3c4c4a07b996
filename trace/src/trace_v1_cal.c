/* The head's calibration keys of a trace or a HEAD.cal in integers (trace/trace_v1.h,
 * docs/reference/trace-format.md, §6a). */
#include <stdint.h>
#include <string.h>

#include "trace_v1_impl.h"

#define NANO 1000000000 /* gain and correlation are read in units of 1e-9 */

/* Half away from zero of num / den (den > 0). */
static int64_t div_round(int64_t num, int64_t den) {
    const int64_t q = num / den;
    const int64_t r = num % den;
    if (2 * (r < 0 ? -r : r) >= den) {
        return num < 0 ? q - 1 : q + 1;
    }
    return q;
}

/* The key's bit and how its values read: decimals of the unit, largest magnitude. */
struct cal_key {
    const char *name;
    uint8_t bit;
    unsigned decimals;
    int64_t max_units;
    bool non_negative;
    const char *range; /* for the message */
};

static const struct cal_key keys[] = {
    {"offset_mm", TRACE_CAL_KEY_OFFSET, 3u, TRACE_CAL_OFFSET_MAX_UM, false,
     "an offset within -100..100 mm"},
    {"offset_sd_mm", TRACE_CAL_KEY_OFFSET_SD, 3u, TRACE_CAL_OFFSET_MAX_UM, true,
     "an sd within 0..100 mm"},
    {"gain", TRACE_CAL_KEY_GAIN, 9u, 1100000000, true, "a gain within 0.9..1.1"},
    {"gain_sd", TRACE_CAL_KEY_GAIN_SD, 6u, TRACE_CAL_GAIN_MAX_PPM, true, "an sd within 0..0.1"},
    {"offset_gain_corr", TRACE_CAL_KEY_CORR, 9u, NANO, false, "a correlation within -1..1"},
};

/* Value i of key k (units as read) into cal. false: out of the key's range. */
static bool store(struct trace_v1_cal *cal, const struct cal_key *k, unsigned i, int64_t v) {
    if (k->non_negative && v < 0) {
        return false;
    }
    switch (k->bit) {
    case TRACE_CAL_KEY_OFFSET:
        cal->offset_um[i] = (int32_t)v;
        break;
    case TRACE_CAL_KEY_OFFSET_SD:
        cal->offset_sd_um[i] = (uint32_t)v;
        break;
    case TRACE_CAL_KEY_GAIN: {
        const int64_t ppm = div_round(v - NANO, 1000); /* (gain − 1) in ppm */
        if (ppm < -TRACE_CAL_GAIN_MAX_PPM || ppm > TRACE_CAL_GAIN_MAX_PPM) {
            return false;
        }
        cal->gain_ppm[i] = (int32_t)ppm;
        break;
    }
    case TRACE_CAL_KEY_GAIN_SD:
        cal->gain_sd_ppm[i] = (uint32_t)v;
        break;
    default: { /* the correlation, Q15 (1 saturates at 32767) */
        const int64_t q = div_round(v * 32768, NANO);
        cal->corr_q15[i] = (int16_t)(q > 32767 ? 32767 : q);
        break;
    }
    }
    return true;
}

/* Four comma-separated values of key k. 0, or -1 with *what, *col. */
static int read_list(struct trace_v1_cal *cal, const struct cal_key *k, const char *value,
                     uint32_t *col, const char **what) {
    const char *p = value;
    for (unsigned i = 0; i < TRACE_CAL_SENSORS; ++i) {
        const char *const start = p;
        int64_t v = 0;
        const bool read = trace_v1_list_decimal(&p, 0u, INT64_MAX, &v) == 0; /* a number? */
        p = start;
        if (!read || trace_v1_list_decimal(&p, k->decimals, k->max_units, &v) != 0 ||
            !store(cal, k, i, v)) {
            *col = (uint32_t)(start - value);
            *what = read ? k->range : "not a plain decimal";
            return -1;
        }
        const bool last = i + 1u == TRACE_CAL_SENSORS;
        if (last ? *p != '\0' : *p != ',') {
            *col = (uint32_t)(p - value);
            *what = last ? "more than four values (sensors A, B, C, D)"
                         : "fewer than four values (sensors A, B, C, D)";
            return -1;
        }
        p += last ? 0 : 1;
    }
    return 0;
}

int trace_v1_cal_value(struct trace_v1_cal *cal, const char *key, const char *value, uint32_t line,
                       uint32_t *col, const char **what) {
    *col = 0u;
    if (strcmp(key, "calibration") == 0) {
        if (value[0] == '\0') {
            *what = "calibration must be 'none' or a head-calibration file";
            return -1;
        }
        const uint8_t bit = strcmp(value, "none") == 0 ? TRACE_CAL_KEY_NONE : TRACE_CAL_KEY_FILE;
        cal->keys |= bit;
        cal->line[bit == TRACE_CAL_KEY_NONE ? 6u : 5u] = line;
        return 0;
    }
    for (unsigned k = 0; k < sizeof keys / sizeof keys[0]; ++k) {
        if (strcmp(key, keys[k].name) == 0) {
            if (read_list(cal, &keys[k], value, col, what) != 0) {
                return -1;
            }
            cal->keys |= keys[k].bit;
            cal->line[k] = line;
            return 0;
        }
    }
    return 1;
}

/* The line of the first key among `bits` (for messages). */
static uint32_t line_of(const struct trace_v1_cal *cal, uint8_t bits) {
    for (unsigned k = 0; k < 7u; ++k) {
        if ((bits & (1u << k)) != 0u && cal->line[k] != 0u) {
            return cal->line[k];
        }
    }
    return 0u;
}

int trace_v1_cal_check(struct trace_v1_cal *cal, const char **what, uint32_t *line) {
    const uint8_t inline_keys = TRACE_CAL_KEY_OFFSET | TRACE_CAL_KEY_OFFSET_SD |
                                TRACE_CAL_KEY_GAIN | TRACE_CAL_KEY_GAIN_SD | TRACE_CAL_KEY_CORR;
    const uint8_t k = cal->keys;
    const uint8_t gains = TRACE_CAL_KEY_GAIN | TRACE_CAL_KEY_GAIN_SD;
    const uint8_t offsets = TRACE_CAL_KEY_OFFSET | TRACE_CAL_KEY_OFFSET_SD;
    *what = NULL;
    if ((k & TRACE_CAL_KEY_FILE) != 0u && (k & TRACE_CAL_KEY_NONE) != 0u) {
        *what = "calibration given twice";
    } else if ((k & (TRACE_CAL_KEY_FILE | TRACE_CAL_KEY_NONE)) != 0u && (k & inline_keys) != 0u) {
        *what = "calibration keys inline and calibration= both: give one";
    } else if ((k & inline_keys) != 0u && (k & offsets) != offsets) {
        *what = "offset_mm and offset_sd_mm come together (docs/reference/calibration-file.md)";
    } else if ((k & gains) != 0u && (k & gains) != gains) {
        *what = "gain and gain_sd come together or not at all (docs/reference/calibration-file.md)";
    } else if ((k & TRACE_CAL_KEY_CORR) != 0u && (k & gains) == 0u) {
        *what = "offset_gain_corr without gain and gain_sd";
    }
    if (*what != NULL) {
        *line = line_of(cal, k);
        return -1;
    }
    cal->calibrated = (k & offsets) == offsets;
    cal->has_gain = (k & gains) == gains;
    for (unsigned i = 0; i < TRACE_CAL_SENSORS && cal->calibrated && !cal->has_gain; ++i) {
        cal->gain_ppm[i] = 0;
        cal->gain_sd_ppm[i] = TRACE_CAL_UNCAL_GAIN_SD_PPM;
    }
    return 0;
}

int trace_v1_cal_key(struct trace_v1_reader *r, const char *key, const struct trace_field *val) {
    char value[TRACE_VALUE_MAX];
    const size_t n = val->len < TRACE_VALUE_MAX ? val->len : TRACE_VALUE_MAX - 1u;
    memcpy(value, val->s, n);
    value[n] = '\0';
    uint32_t col = 0;
    const char *what = NULL;
    if (trace_v1_cal_value(&r->meta.cal, key, value, r->line_no, &col, &what) >= 0) {
        return 0;
    }
    struct trace_msg m = trace_msg_begin(r, r->line_no, (uint32_t)val->col + col);
    trace_msg_str(&m, key);
    trace_msg_str(&m, ": ");
    trace_msg_str(&m, what);
    trace_msg_str(&m, ", got '");
    trace_msg_quote(&m, value, n);
    trace_msg_str(&m, "'");
    return trace_msg_fail(r);
}

int trace_v1_cal_finish(struct trace_v1_reader *r) {
    const char *what = NULL;
    uint32_t line = 0;
    if (trace_v1_cal_check(&r->meta.cal, &what, &line) != 0) {
        return trace_v1_fail(r, line, 1u, what);
    }
    return 0;
}
