/* The head-calibration file v1 (docs/reference/calibration-file.md): reader and writer
 * (head_cal.h). */
#include "calibrate/head_cal.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { K_OFFSET, K_OFFSET_SD, K_GAIN, K_GAIN_SD, K_CAL_TEMP, K_COEFF, K_COEFF_SD, K_KNOWN };
static const char *const known_keys[K_KNOWN] = {
    "offset_mm",           "offset_sd_mm",          "gain", "gain_sd", "cal_temp_c",
    "temp_coeff_mm_per_c", "temp_coeff_sd_mm_per_c"};

__attribute__((format(printf, 4, 5))) static int fail(struct head_cal_reader *r, unsigned line,
                                                      unsigned col, const char *fmt, ...) {
    char what[200]; /* with the name (HEAD_CAL_NAME_MAX) it fits HEAD_CAL_ERR_MAX */
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    if (line == 0u) {
        snprintf(r->err, sizeof r->err, "%s: %s", r->name, what);
    } else if (col == 0u) {
        snprintf(r->err, sizeof r->err, "%s:%u: %s", r->name, line, what);
    } else {
        snprintf(r->err, sizeof r->err, "%s:%u:%u: %s", r->name, line, col, what);
    }
    return -1;
}

void head_cal_begin(struct head_cal_reader *r, const char *name) {
    memset(r, 0, sizeof *r);
    const size_t n = strlen(name);
    if (n < sizeof r->name) {
        memcpy(r->name, name, n + 1u);
    } else {
        snprintf(r->name, sizeof r->name, "...%s", name + n - (sizeof r->name - 4u));
    }
}

/* CRC-32, IEEE 802.3 polynomial 0xEDB88320 reflected, init and final xor 0xFFFFFFFF (the
 * check value of "123456789" is 0xCBF43926). */
static uint32_t crc32_of(const char *data, size_t len) {
    uint32_t crc = 0xFFFFFFFFu;
    for (size_t i = 0; i < len; ++i) {
        crc ^= (uint8_t)data[i];
        for (unsigned b = 0; b < 8u; ++b) {
            crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
        }
    }
    return crc ^ 0xFFFFFFFFu;
}

#define CHECKSUM_PREFIX "# checksum=crc32:"

static bool is_blank(char c) {
    return c == ' ' || c == '\t';
}

/* A plain decimal number: sign, digits, point, exponent; no inf, nan or hex. */
static bool decimal_chars(const char *s, size_t len) {
    bool digit = false;
    for (size_t i = 0; i < len; ++i) {
        const char c = s[i];
        if (c >= '0' && c <= '9') {
            digit = true;
        } else if (c != '+' && c != '-' && c != '.' && c != 'e' && c != 'E') {
            return false;
        }
    }
    return digit;
}

/* The four values of known key k into out[] (cal_temp_c: its one value into out[0]); col is
 * the value's first column (0: unknown). */
static int read_four(struct head_cal_reader *r, unsigned k, const char *value, unsigned line,
                     unsigned col, double out[HEAD_CAL_SENSORS]) {
    const char *key = known_keys[k];
    const unsigned want = k == K_CAL_TEMP ? 1u : HEAD_CAL_SENSORS;
    unsigned n = 0;
    size_t at = 0;
    const size_t len = strlen(value);
    for (;;) {
        size_t end = at;
        while (end < len && value[end] != ',') {
            ++end;
        }
        size_t s = at;
        size_t e = end;
        while (s < e && is_blank(value[s])) {
            ++s;
        }
        while (e > s && is_blank(value[e - 1u])) {
            --e;
        }
        const unsigned c = col == 0u ? 0u : col + (unsigned)s;
        if (n == want) {
            return want == 1u
                       ? fail(r, line, c, "%s: one value (the head's), not a list", key)
                       : fail(r, line, c, "%s: more than 4 values (sensors A, B, C, D)", key);
        }
        char text[HEAD_CAL_VALUE_MAX];
        snprintf(text, sizeof text, "%.*s", (int)(e - s), value + s);
        char *stop = NULL;
        errno = 0;
        const double v = strtod(text, &stop);
        if (e == s || !decimal_chars(text, e - s) || *stop != '\0' || errno != 0 || !isfinite(v)) {
            return fail(r, line, c, "%s: value %u (sensor %c): expected a decimal number, got '%s'",
                        key, n + 1u, (char)('A' + n), text);
        }
        if ((k == K_OFFSET_SD || k == K_GAIN_SD || k == K_COEFF_SD) && v < 0.0) {
            return fail(r, line, c, "%s: sensor %c: an sd cannot be negative, got '%s'", key,
                        (char)('A' + n), text);
        }
        if (k == K_GAIN && !(v > 0.0)) {
            return fail(r, line, c, "gain: sensor %c: must be positive, got '%s'", (char)('A' + n),
                        text);
        }
        if (k == K_CAL_TEMP && !(v >= -100.0 && v <= 200.0)) {
            return fail(r, line, c, "cal_temp_c: within -100..200 C, got '%s'", text);
        }
        if ((k == K_COEFF || k == K_COEFF_SD) && !(fabs(v) <= 1.0)) {
            return fail(r, line, c,
                        "%s: sensor %c: within -1..1 mm/C (no VL53 part's beyond), got '%s'", key,
                        (char)('A' + n), text);
        }
        out[n++] = v;
        if (end >= len) {
            break;
        }
        at = end + 1u;
    }
    if (n != want) {
        return fail(r, line, col == 0u ? 0u : col + (unsigned)len,
                    "%s: %u value%s, expected 4 (A, B, C, D)", key, n, n == 1u ? "" : "s");
    }
    return 0;
}

int head_cal_key(struct head_cal_reader *r, const char *key, const char *value, unsigned line,
                 unsigned col) {
    struct head_cal *cal = &r->cal;
    for (unsigned i = 0; i < cal->count; ++i) {
        if (strcmp(cal->key[i], key) == 0) {
            return fail(r, line, 0u, "duplicate key '%s' (first on line %u)", key, cal->line[i]);
        }
    }
    if (strlen(key) >= HEAD_CAL_KEY_MAX || strlen(value) >= HEAD_CAL_VALUE_MAX) {
        return fail(r, line, col, "key '%.40s' or its value is too long (%u, %u bytes at most)",
                    key, HEAD_CAL_KEY_MAX - 1u, HEAD_CAL_VALUE_MAX - 1u);
    }
    if (cal->count >= HEAD_CAL_MAX_KEYS) {
        return fail(r, line, 0u, "more than %u keys", HEAD_CAL_MAX_KEYS);
    }
    double cal_temp[HEAD_CAL_SENSORS];
    double *const dest[K_KNOWN] = {
        cal->offset_mm,           cal->offset_sd_mm,          cal->gain, cal->gain_sd, cal_temp,
        cal->temp_coeff_mm_per_c, cal->temp_coeff_sd_mm_per_c};
    for (unsigned k = 0; k < K_KNOWN; ++k) {
        if (strcmp(key, known_keys[k]) == 0) {
            if (read_four(r, k, value, line, col, dest[k]) != 0) {
                return -1;
            }
            r->seen[k] = true;
            r->seen_line[k] = line;
            if (k == K_CAL_TEMP) {
                cal->cal_temp_c = cal_temp[0];
            }
        }
    }
    const unsigned i = cal->count++;
    snprintf(cal->key[i], sizeof cal->key[i], "%s", key);
    snprintf(cal->value[i], sizeof cal->value[i], "%s", value);
    cal->line[i] = line;
    return 0;
}

int head_cal_finish(struct head_cal_reader *r) {
    for (unsigned k = K_OFFSET; k <= K_OFFSET_SD; ++k) {
        if (!r->seen[k]) {
            return fail(r, 0u, 0u, "missing required key %s (a line '# %s=A,B,C,D')", known_keys[k],
                        known_keys[k]);
        }
    }
    if (r->seen[K_GAIN] != r->seen[K_GAIN_SD]) {
        const unsigned has = r->seen[K_GAIN] ? K_GAIN : K_GAIN_SD;
        const unsigned lacks = r->seen[K_GAIN] ? K_GAIN_SD : K_GAIN;
        return fail(r, r->seen_line[has], 0u, "%s without %s (they come together or not at all)",
                    known_keys[has], known_keys[lacks]);
    }
    const unsigned thermal =
        (unsigned)r->seen[K_CAL_TEMP] + (unsigned)r->seen[K_COEFF] + (unsigned)r->seen[K_COEFF_SD];
    if (thermal != 0u && thermal != 3u) {
        unsigned has = K_CAL_TEMP;
        while (!r->seen[has]) {
            ++has;
        }
        return fail(r, r->seen_line[has], 0u,
                    "%s without all of cal_temp_c, temp_coeff_mm_per_c, temp_coeff_sd_mm_per_c "
                    "(they come together or not at all)",
                    known_keys[has]);
    }
    r->cal.thermal = thermal == 3u;
    r->cal.has_gain = r->seen[K_GAIN];
    if (!r->cal.has_gain) {
        for (unsigned s = 0; s < HEAD_CAL_SENSORS; ++s) {
            r->cal.gain[s] = 1.0;
            r->cal.gain_sd[s] = 0.0;
        }
    }
    return 0;
}

/* One line of a HEAD.cal (without its end), number `line`. 0, or -1 with r->err. */
static int parse_line(struct head_cal_reader *r, const char *s, size_t len, unsigned line) {
    size_t i = 0;
    while (i < len && is_blank(s[i])) {
        ++i;
    }
    if (i == len) {
        return 0; /* blank line */
    }
    if (s[i] != '#') {
        return fail(r, line, (unsigned)i + 1u, "expected '# key=value' or a comment line");
    }
    ++i;
    while (i < len && is_blank(s[i])) {
        ++i;
    }
    const size_t key_at = i;
    while (i < len && ((s[i] >= 'a' && s[i] <= 'z') || (s[i] >= 'A' && s[i] <= 'Z') ||
                       (s[i] >= '0' && s[i] <= '9') || s[i] == '_' || s[i] == '-' || s[i] == '.')) {
        ++i;
    }
    const size_t key_len = i - key_at;
    while (i < len && is_blank(s[i])) {
        ++i;
    }
    if (key_len == 0u || i >= len || s[i] != '=') {
        return 0; /* a comment */
    }
    ++i;
    while (i < len && is_blank(s[i])) {
        ++i;
    }
    size_t end = len;
    while (end > i && is_blank(s[end - 1u])) {
        --end;
    }
    if (key_len >= HEAD_CAL_KEY_MAX || end - i >= HEAD_CAL_VALUE_MAX) {
        return fail(r, line, (unsigned)key_at + 1u, "key or value too long (%u, %u bytes at most)",
                    HEAD_CAL_KEY_MAX - 1u, HEAD_CAL_VALUE_MAX - 1u);
    }
    char key[HEAD_CAL_KEY_MAX];
    char value[HEAD_CAL_VALUE_MAX];
    snprintf(key, sizeof key, "%.*s", (int)key_len, s + key_at);
    snprintf(value, sizeof value, "%.*s", (int)(end - i), s + i);
    return head_cal_key(r, key, value, line, (unsigned)i + 1u);
}

int head_cal_parse(const char *text, size_t len, const char *name, struct head_cal *cal, char *err,
                   size_t errlen) {
    struct head_cal_reader *r = malloc(sizeof *r);
    if (r == NULL) {
        snprintf(err, errlen, "%s: out of memory", name);
        return -1;
    }
    head_cal_begin(r, name);
    size_t at = 0;
    if (len >= 3u && memcmp(text, "\xEF\xBB\xBF", 3u) == 0) {
        at = 3u; /* a UTF-8 byte-order mark, as some editors write */
    }
    unsigned line = 0, checksum_line = 0u, after_checksum = 0u;
    size_t checksum_at = 0u;
    int rc = 0;
    while (rc == 0 && at < len) {
        const char *nl = memchr(text + at, '\n', len - at);
        size_t end = nl != NULL ? (size_t)(nl - text) : len;
        const size_t next = nl != NULL ? end + 1u : len;
        if (end > at && text[end - 1u] == '\r') {
            --end;
        }
        ++line;
        const char *s = text + at;
        const size_t n = end - at;
        const char *bad = memchr(s, '\0', n);
        if (bad == NULL) {
            bad = memchr(s, '\r', n);
        }
        if (bad != NULL) {
            rc = fail(r, line, (unsigned)(bad - s) + 1u, "%s byte in the line",
                      *bad == '\0' ? "NUL" : "CR");
        } else if (line == 1u) {
            if (n != 17u || memcmp(s, "# tof-head-cal v1", 17u) != 0) {
                rc = fail(r, 1u, 1u, "expected '# tof-head-cal v1' as the first line");
            }
        } else if (n >= sizeof CHECKSUM_PREFIX - 1u &&
                   memcmp(s, CHECKSUM_PREFIX, sizeof CHECKSUM_PREFIX - 1u) == 0) {
            if (checksum_line != 0u) {
                rc = fail(r, line, 1u, "a second checksum line (the first on line %u)",
                          checksum_line);
            }
            checksum_line = line;
            checksum_at = at;
        } else {
            if (checksum_line != 0u && after_checksum == 0u) {
                size_t k = 0;
                while (k < n && is_blank(s[k])) {
                    ++k;
                }
                after_checksum = k < n ? line : 0u;
            }
            rc = parse_line(r, s, n, line);
        }
        at = next;
    }
    if (rc == 0 && line == 0u) {
        rc = fail(r, 1u, 1u, "empty file (expected '# tof-head-cal v1')");
    }
    if (rc == 0 && len > 0u && text[len - 1u] != '\n') {
        rc = fail(r, line, 0u, "the last line has no line end: the file was cut");
    }
    if (rc == 0 && after_checksum != 0u) {
        rc = fail(r, after_checksum, 1u,
                  "content after the checksum line (line %u): the file was edited or joined",
                  checksum_line);
    }
    if (rc == 0 && checksum_line != 0u) {
        const char *v = text + checksum_at + sizeof CHECKSUM_PREFIX - 1u;
        const char *nl = memchr(v, '\n', len - (size_t)(v - text));
        size_t vn = nl != NULL ? (size_t)(nl - v) : len - (size_t)(v - text);
        vn -= vn > 0u && v[vn - 1u] == '\r' ? 1u : 0u;
        char want[12];
        snprintf(want, sizeof want, "%08x", crc32_of(text, checksum_at));
        if (vn != 8u || memcmp(v, want, 8u) != 0) {
            rc = fail(r, checksum_line, (unsigned)sizeof CHECKSUM_PREFIX,
                      "checksum crc32:%.*s does not match the content before it (crc32:%s): "
                      "the file was cut or edited",
                      (int)(vn < 16u ? vn : 16u), v, want);
        }
        r->cal.checksummed = rc == 0;
    }
    if (rc == 0) {
        rc = head_cal_finish(r);
    }
    if (rc == 0) {
        *cal = r->cal;
    } else {
        snprintf(err, errlen, "%s", r->err);
    }
    free(r);
    return rc;
}

int head_cal_load(const char *path, struct head_cal *cal, char *err, size_t errlen) {
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        return -1;
    }
    /* A HEAD.cal is a few hundred bytes; 64 KiB is far beyond any real one. */
    enum { MAX_BYTES = 65536 };
    char *buf = malloc(MAX_BYTES + 1);
    if (buf == NULL) {
        fclose(f);
        snprintf(err, errlen, "%s: out of memory", path);
        return -1;
    }
    const size_t n = fread(buf, 1u, MAX_BYTES + 1, f);
    int rc = 0;
    if (ferror(f)) {
        snprintf(err, errlen, "%s: read error: %s", path, strerror(errno));
        rc = -1;
    } else if (n > MAX_BYTES) {
        snprintf(err, errlen, "%s: larger than %d bytes: not a head-calibration file", path,
                 MAX_BYTES);
        rc = -1;
    } else {
        rc = head_cal_parse(buf, n, path, cal, err, errlen);
        if (rc == 0 && !cal->checksummed) {
            fprintf(stderr,
                    "warning: %s: no checksum line (a file written before checksums): read as "
                    "it stands; a cut or edited file cannot be told from it. Write it again "
                    "(host_sim calibrate) to add one\n",
                    path);
        }
    }
    free(buf);
    fclose(f);
    return rc;
}

const char *head_cal_extra(const struct head_cal *cal, const char *key) {
    for (unsigned i = 0; i < cal->count; ++i) {
        if (strcmp(cal->key[i], key) == 0) {
            return cal->value[i];
        }
    }
    return NULL;
}

/* The file's text as it is written, before its checksum line. */
struct text_out {
    char buf[HEAD_CAL_MAX_KEYS * (HEAD_CAL_KEY_MAX + HEAD_CAL_VALUE_MAX + 4u) + 64u];
    size_t len;
    bool overflow;
};

__attribute__((format(printf, 2, 3))) static void put(struct text_out *o, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    const int n = vsnprintf(o->buf + o->len, sizeof o->buf - o->len, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= sizeof o->buf - o->len) {
        o->overflow = true;
        return;
    }
    o->len += (size_t)n;
}

static void write_four(struct text_out *o, const char *key, const double v[HEAD_CAL_SENSORS]) {
    /* %.10g: 1e-9 relative, well below any sd a fit states. */
    put(o, "# %s=%.10g,%.10g,%.10g,%.10g\n", key, v[0], v[1], v[2], v[3]);
}

static bool extra_ok(const char *kv) {
    const char *eq = strchr(kv, '=');
    if (eq == NULL || eq == kv || (size_t)(eq - kv) >= HEAD_CAL_KEY_MAX ||
        strlen(eq + 1) >= HEAD_CAL_VALUE_MAX || strpbrk(kv, "\r\n") != NULL) {
        return false;
    }
    for (const char *c = kv; c < eq; ++c) {
        if (!((*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9') ||
              *c == '_' || *c == '-' || *c == '.')) {
            return false;
        }
    }
    return true;
}

int head_cal_write(FILE *f, const struct head_cal *cal, const char *const *extra) {
    static struct text_out o; /* ~12 KB */
    o.len = 0u;
    o.overflow = false;
    put(&o, "# tof-head-cal v1\n");
    write_four(&o, "offset_mm", cal->offset_mm);
    write_four(&o, "offset_sd_mm", cal->offset_sd_mm);
    if (cal->has_gain) {
        write_four(&o, "gain", cal->gain);
        write_four(&o, "gain_sd", cal->gain_sd);
    }
    if (cal->thermal) {
        const double *k = cal->temp_coeff_mm_per_c;
        const double *sd = cal->temp_coeff_sd_mm_per_c;
        put(&o, "# cal_temp_c=%.2f\n", cal->cal_temp_c);
        put(&o, "# temp_coeff_mm_per_c=%.6f,%.6f,%.6f,%.6f\n", k[0], k[1], k[2], k[3]);
        put(&o, "# temp_coeff_sd_mm_per_c=%.6f,%.6f,%.6f,%.6f\n", sd[0], sd[1], sd[2], sd[3]);
    }
    for (size_t i = 0; extra != NULL && extra[i] != NULL; ++i) {
        if (!extra_ok(extra[i])) {
            return -1;
        }
        put(&o, "# %s\n", extra[i]);
    }
    if (o.overflow) {
        return -1;
    }
    /* the last line: the checksum of everything before it (head_cal.h) */
    return fwrite(o.buf, 1u, o.len, f) != o.len ||
                   fprintf(f, CHECKSUM_PREFIX "%08x\n", crc32_of(o.buf, o.len)) < 0
               ? -1
               : 0;
}
