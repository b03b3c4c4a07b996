/* A host's command text into a struct tlm_command (telemetry/tlm_command_text.h). */
#include "telemetry/tlm_command_text.h"

#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#define MAX_WORDS 4u
#define WORD_MAX  24u

struct words {
    char w[MAX_WORDS][WORD_MAX];
    unsigned n;
};

/* `c` in lower case (ASCII letters; anything else as it is), without char arithmetic. */
static char lower(char c) {
    static const char upper_set[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZ";
    static const char lower_set[] = "abcdefghijklmnopqrstuvwxyz";
    const char *at = c != '\0' ? strchr(upper_set, c) : NULL;
    if (at == NULL) {
        return c;
    }
    return lower_set[at - upper_set];
}

/* Split `text` at spaces into lower-case words; false if too many or one too long. */
static bool split(const char *text, struct words *out) {
    out->n = 0;
    size_t len = 0;
    for (const char *p = text;; ++p) {
        const char c = *p;
        if (c == ' ' || c == '\t' || c == '\0') {
            if (len > 0u) {
                out->w[out->n - 1u][len] = '\0';
                len = 0;
            }
            if (c == '\0') {
                return true;
            }
            continue;
        }
        if (len == 0u) {
            if (out->n == MAX_WORDS) {
                return false;
            }
            ++out->n;
        }
        if (len + 1u >= WORD_MAX) {
            return false;
        }
        out->w[out->n - 1u][len++] = lower(c);
    }
}

static bool is(const char *word, const char *a, const char *b) {
    return strcmp(word, a) == 0 || (b != NULL && strcmp(word, b) == 0);
}

/* A decimal with at most `decimals` places into an integer of 10^-decimals units (mm²/s with
 * 6 into um²/s, mm with 3 into um); false if malformed or > UINT32_MAX. */
static bool fixed_decimal(const char *s, size_t len, unsigned decimals, uint32_t *out) {
    uint64_t v = 0;
    unsigned places = 0;
    bool dot = false, digit = false;
    for (size_t i = 0; i < len; ++i) {
        if (s[i] == '.' && !dot) {
            dot = true;
            continue;
        }
        if (s[i] < '0' || s[i] > '9' || (dot && places == decimals) || v > UINT32_MAX) {
            return false;
        }
        v = v * 10u + (uint64_t)(s[i] - '0');
        places += dot ? 1u : 0u;
        digit = true;
    }
    for (; places < decimals; ++places) {
        v *= 10u;
    }
    *out = (uint32_t)v;
    return digit && v <= UINT32_MAX;
}

static const char *set_window(const struct words *w, struct tlm_command *out) {
    if (w->n < 2u || w->n > 3u) {
        return "usage: set-window N [tumbling|sliding]";
    }
    unsigned n = 0;
    for (const char *p = w->w[1]; *p != '\0'; ++p) {
        if (*p < '0' || *p > '9' || n > TLM_WINDOW_MAX) {
            return "set-window: N is not an integer 2..255";
        }
        n = n * 10u + (unsigned)(*p - '0');
    }
    if (n < TLM_WINDOW_MIN || n > TLM_WINDOW_MAX) {
        return "set-window: N is not an integer 2..255";
    }
    out->type = TLM_TYPE_SET_WINDOW;
    out->u.set_window.window_n = (uint16_t)n;
    out->u.set_window.mode = TLM_WINDOW_TUMBLING;
    if (w->n == 3u && strcmp(w->w[2], "sliding") == 0) {
        out->u.set_window.mode = TLM_WINDOW_SLIDING;
    } else if (w->n == 3u && strcmp(w->w[2], "tumbling") != 0) {
        return "set-window: the mode is tumbling or sliding";
    }
    return NULL;
}

static const char *estimator(const struct words *w, struct tlm_command *out) {
    static const char *const names[] = {"consensus", "consensus-paper", "kalman", "mean"};
    if (w->n != 2u) {
        return "usage: estimator consensus|consensus-paper|kalman|mean";
    }
    for (unsigned e = 0; e < sizeof names / sizeof names[0]; ++e) {
        if (strcmp(w->w[1], names[e]) == 0) {
            out->type = TLM_TYPE_SELECT_ESTIMATOR;
            out->u.estimator = (uint8_t)e; /* enum tlm_estimator, in this order */
            return NULL;
        }
    }
    return "estimator: one of consensus, consensus-paper, kalman, mean";
}

static const char *process_noise(const struct words *w, struct tlm_command *out) {
    if (w->n != 2u) {
        return "usage: process-noise QD,QT|auto";
    }
    out->type = TLM_TYPE_SET_PROCESS_NOISE;
    out->u.process_noise.qd_um2_per_s = 0u;
    out->u.process_noise.qt_um2_per_s = 0u;
    out->u.process_noise.flags = 0u;
    if (strcmp(w->w[1], "auto") == 0) {
        out->u.process_noise.flags = TLM_PROCESS_NOISE_AUTO;
        return NULL;
    }
    const char *comma = strchr(w->w[1], ',');
    if (comma == NULL ||
        !fixed_decimal(w->w[1], (size_t)(comma - w->w[1]), 6u,
                       &out->u.process_noise.qd_um2_per_s) ||
        !fixed_decimal(comma + 1, strlen(comma + 1), 6u, &out->u.process_noise.qt_um2_per_s)) {
        return "process-noise: QD,QT in mm^2/s (at most 6 decimals, <= 4294.967295) or auto";
    }
    return NULL;
}

/* set-arm MM (up to 3 decimals) and set-period MS (whole milliseconds). */
static const char *arm_or_period(const struct words *w, bool arm, struct tlm_command *out) {
    uint32_t v = 0;
    const bool ok = w->n == 2u && fixed_decimal(w->w[1], strlen(w->w[1]), arm ? 3u : 0u, &v);
    if (arm) {
        out->type = TLM_TYPE_SET_ARM;
        out->u.arm_um = v;
        return ok && v >= TLM_ARM_MIN_UM && v <= TLM_ARM_MAX_UM
                   ? NULL
                   : "usage: set-arm MM, the arm in mm (1..1000, at most 3 decimals)";
    }
    out->type = TLM_TYPE_SET_PERIOD;
    out->u.period_ms = (uint16_t)(v <= TLM_PERIOD_MAX_MS ? v : 0u);
    return ok && v >= TLM_PERIOD_MIN_MS && v <= TLM_PERIOD_MAX_MS
               ? NULL
               : "usage: set-period MS, the sample period in whole ms (1..10000)";
}

/* "write-calibration HEX": the record's section 2 as 236 hex digits (tools/tof_telemetry.py
 * --send-cal makes it from a HEAD.cal); the header checked as the protocol checks it. */
static const char *write_calibration(const char *hex, struct tlm_command *out) {
    static const char usage[] = "usage: write-calibration HEX (the 118 bytes of record section "
                                "2 in hex; tools/tof_telemetry.py --send-cal makes it)";
    while (*hex == ' ' || *hex == '\t') {
        ++hex;
    }
    out->type = TLM_TYPE_WRITE_CALIBRATION;
    for (size_t i = 0; i < (size_t)TLM_CAL_SECTION_LEN * 2u; ++i) {
        const char c = hex[i];
        const int v = c >= '0' && c <= '9'   ? c - '0'
                      : c >= 'a' && c <= 'f' ? c - 'a' + 10
                      : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                             : -1;
        if (v < 0) {
            return usage; /* also a string that ends early */
        }
        out->u.cal_section[i / 2u] =
            (uint8_t)((unsigned)out->u.cal_section[i / 2u] << 4 | (unsigned)v);
    }
    const char *rest = &hex[(size_t)TLM_CAL_SECTION_LEN * 2u];
    while (*rest == ' ' || *rest == '\t') {
        ++rest;
    }
    return *rest == '\0' && tlm_cal_section_is_valid(out->u.cal_section, false) ? NULL : usage;
}

/* "re-zero N": N samples at the latched position, TLM_REZERO_MIN..TLM_REZERO_MAX. */
static const char *rezero(const struct words *w, struct tlm_command *out) {
    uint32_t n = 0;
    out->type = TLM_TYPE_REZERO;
    if (w->n != 2u || !fixed_decimal(w->w[1], strlen(w->w[1]), 0u, &n) || n < TLM_REZERO_MIN ||
        n > TLM_REZERO_MAX) {
        return "usage: re-zero N, N samples 10..5000";
    }
    out->u.rezero_samples = (uint16_t)n;
    return NULL;
}

const char *tlm_command_from_text(const char *text, struct tlm_command *out) {
    struct words w;
    memset(out, 0, sizeof *out);
    static const char write_cal[] = "write-calibration";
    if (text != NULL && strncmp(text, write_cal, sizeof write_cal - 1u) == 0 &&
        (text[sizeof write_cal - 1u] == ' ' || text[sizeof write_cal - 1u] == '\0')) {
        return write_calibration(&text[sizeof write_cal - 1u], out);
    }
    if (text == NULL || !split(text, &w) || w.n == 0u) {
        return "empty or overlong command";
    }
    const char *verb = w.w[0];
    if (is(verb, "set-window", NULL)) {
        return set_window(&w, out);
    }
    if (is(verb, "estimator", "select-estimator")) {
        return estimator(&w, out);
    }
    if (is(verb, "process-noise", "set-process-noise")) {
        return process_noise(&w, out);
    }
    if (is(verb, "re-zero", NULL)) {
        return rezero(&w, out);
    }
    if (is(verb, "set-arm", NULL) || is(verb, "set-period", NULL)) {
        return arm_or_period(&w, strcmp(verb, "set-arm") == 0, out);
    }
    if (is(verb, "raw", "raw-stream")) {
        out->type = TLM_TYPE_RAW_STREAM;
        out->u.raw_enable = w.n == 2u && strcmp(w.w[1], "on") == 0;
        return w.n == 2u && (out->u.raw_enable || strcmp(w.w[1], "off") == 0) ? NULL
                                                                              : "usage: raw on|off";
    }
    static const struct {
        const char *a, *b;
        uint8_t type;
    } plain[] = {{"start", NULL, TLM_TYPE_START},
                 {"stop", NULL, TLM_TYPE_STOP},
                 {"status", "status-request", TLM_TYPE_STATUS_REQUEST},
                 {"save", NULL, TLM_TYPE_SAVE},
                 {"read-calibration", NULL, TLM_TYPE_READ_CALIBRATION}};
    for (unsigned k = 0; k < sizeof plain / sizeof plain[0]; ++k) {
        if (is(verb, plain[k].a, plain[k].b)) {
            out->type = plain[k].type;
            return w.n == 1u ? NULL : "this command takes no argument";
        }
    }
    return "unknown command (set-window, estimator, start, stop, status, raw, process-noise, "
           "set-arm, set-period, save, write-calibration, read-calibration, re-zero)";
}

const char *tlm_command_from_arg(const char *arg, uint32_t *row, struct tlm_command *out) {
    uint64_t v = 0;
    const char *p = arg;
    for (; p != NULL && *p >= '0' && *p <= '9' && v <= UINT32_MAX; ++p) {
        v = v * 10u + (uint64_t)(*p - '0');
    }
    if (p == NULL || p == arg || *p != ':' || v > UINT32_MAX) {
        return "expected ROW:TEXT, ROW a trace row number";
    }
    *row = (uint32_t)v;
    return tlm_command_from_text(p + 1, out);
}
