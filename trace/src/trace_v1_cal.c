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

/* The key's bit and how its values read: decimals of the unit, largest magnitude, how many. */
struct cal_key {
    const char *name;
    uint16_t bit;
    unsigned decimals;
    int64_t max_units;
    bool non_negative;
    const char *range; /* for the message */
    unsigned values;   /* 4 (sensors A..D) or 1 */
};

static const struct cal_key keys[] = {
    {"offset_mm", TRACE_CAL_KEY_OFFSET, 3u, TRACE_CAL_OFFSET_MAX_UM, false,
     "an offset within -100..100 mm", 4u},
    {"offset_sd_mm", TRACE_CAL_KEY_OFFSET_SD, 3u, TRACE_CAL_OFFSET_MAX_UM, true,
     "an sd within 0..100 mm", 4u},
    {"gain", TRACE_CAL_KEY_GAIN, 9u, 1100000000, true, "a gain within 0.9..1.1", 4u},
    {"gain_sd", TRACE_CAL_KEY_GAIN_SD, 6u, TRACE_CAL_GAIN_MAX_PPM, true, "an sd within 0..0.1", 4u},
    {"offset_gain_corr", TRACE_CAL_KEY_CORR, 9u, NANO, false, "a correlation within -1..1", 4u},
    /* the range's larger end; the lower (-100 °C) is checked in store() */
    {"cal_temp_c", TRACE_CAL_KEY_CAL_TEMP, 2u, TRACE_CAL_TEMP_MAX_CDEG, false,
     "a temperature within -100..200 C", 1u},
    {"temp_coeff_mm_per_c", TRACE_CAL_KEY_TEMP_COEFF, 6u, TRACE_CAL_TEMP_COEFF_MAX_NM_PER_C, false,
     "a coefficient within -1..1 mm/C", 4u},
    {"temp_coeff_sd_mm_per_c", TRACE_CAL_KEY_TEMP_COEFF_SD, 6u, TRACE_CAL_TEMP_COEFF_MAX_NM_PER_C,
     true, "an sd within 0..1 mm/C", 4u},
};

/* The index of a key's single bit (its slot in trace_v1_cal.line). */
static unsigned bit_index(uint16_t bit) {
    unsigned i = 0;
    while (i + 1u < TRACE_CAL_KEY_BITS && (bit >> i) != 1u) {
        ++i;
    }
    return i;
}

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
    case TRACE_CAL_KEY_CAL_TEMP:
        if (v < TRACE_CAL_TEMP_MIN_CDEG) {
            return false;
        }
        cal->cal_temp_cdeg = (int16_t)v;
        break;
    case TRACE_CAL_KEY_TEMP_COEFF:
        cal->temp_coeff_nm_per_c[i] = (int32_t)v;
        break;
    case TRACE_CAL_KEY_TEMP_COEFF_SD:
        cal->temp_coeff_sd_nm_per_c[i] = (uint32_t)v;
        break;
    default: { /* the correlation, Q15 (1 saturates at 32767) */
        const int64_t q = div_round(v * 32768, NANO);
        cal->corr_q15[i] = (int16_t)(q > 32767 ? 32767 : q);
        break;
    }
    }
    return true;
}

/* The comma-separated values of key k (four, or one). 0, or -1 with *what, *col. */
static int read_list(struct trace_v1_cal *cal, const struct cal_key *k, const char *value,
                     uint32_t *col, const char **what) {
    const char *p = value;
    for (unsigned i = 0; i < k->values; ++i) {
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
        const bool last = i + 1u == k->values;
        if (last ? *p != '\0' : *p != ',') {
            *col = (uint32_t)(p - value);
            *what = k->values == 1u ? "one value (the head's), not a list"
                    : last          ? "more than four values (sensors A, B, C, D)"
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
        cal->line[bit_index(bit)] = line;
        return 0;
    }
    for (unsigned k = 0; k < sizeof keys / sizeof keys[0]; ++k) {
        if (strcmp(key, keys[k].name) == 0) {
            if (read_list(cal, &keys[k], value, col, what) != 0) {
                return -1;
            }
            cal->keys |= keys[k].bit;
            cal->line[bit_index(keys[k].bit)] = line;
            return 0;
        }
    }
    return 1;
}

/* The line of the first key among `bits` (for messages). */
static uint32_t line_of(const struct trace_v1_cal *cal, uint16_t bits) {
    for (unsigned k = 0; k < TRACE_CAL_KEY_BITS; ++k) {
        if ((bits & (1u << k)) != 0u && cal->line[k] != 0u) {
            return cal->line[k];
        }
    }
    return 0u;
}

int trace_v1_cal_check(struct trace_v1_cal *cal, const char **what, uint32_t *line) {
    const uint16_t thermal =
        TRACE_CAL_KEY_CAL_TEMP | TRACE_CAL_KEY_TEMP_COEFF | TRACE_CAL_KEY_TEMP_COEFF_SD;
    const uint16_t inline_keys = TRACE_CAL_KEY_OFFSET | TRACE_CAL_KEY_OFFSET_SD |
                                 TRACE_CAL_KEY_GAIN | TRACE_CAL_KEY_GAIN_SD | TRACE_CAL_KEY_CORR |
                                 thermal;
    const uint16_t k = cal->keys;
    const uint16_t gains = TRACE_CAL_KEY_GAIN | TRACE_CAL_KEY_GAIN_SD;
    const uint16_t offsets = TRACE_CAL_KEY_OFFSET | TRACE_CAL_KEY_OFFSET_SD;
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
    } else if ((k & thermal) != 0u && (k & thermal) != thermal) {
        *what = "cal_temp_c, temp_coeff_mm_per_c and temp_coeff_sd_mm_per_c come together or not "
                "at all (docs/reference/calibration-file.md)";
        *line = line_of(cal, k & thermal);
        return -1;
    }
    if (*what != NULL) {
        *line = line_of(cal, k);
        return -1;
    }
    cal->thermal = (k & thermal) == thermal;
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
