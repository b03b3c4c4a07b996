/* Loading and slicing the shared real-noise recording (real_noise.h). */
#include "scene/real_noise.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef TOF_SOURCE_DIR
#error "TOF_SOURCE_DIR must name the repository (set by hostlib/scene/CMakeLists.txt)"
#endif

int scene_shared_dir(char *buf, size_t buflen) {
    const char *env = getenv("TOF_SHARED_DIR");
    int n;
    if (env != NULL && env[0] != '\0') {
        n = snprintf(buf, buflen, "%s", env);
    } else {
        n = snprintf(buf, buflen, "%s/../shared", TOF_SOURCE_DIR);
    }
    return (n < 0 || (size_t)n >= buflen) ? -1 : 0;
}

int scene_real_noise_default_path(char *buf, size_t buflen) {
    char dir[1024];
    if (scene_shared_dir(dir, sizeof dir) != 0) {
        return -1;
    }
    const int n = snprintf(buf, buflen, "%s/%s", dir, SCENE_REAL_NOISE_FILE);
    return (n < 0 || (size_t)n >= buflen) ? -1 : 0;
}

/* Reads one line into buf (without the newline). Returns 1 with a line, 0 at end
 * of file, -1 if the line does not fit or holds a NUL byte. */
static int read_line(FILE *f, char *buf, size_t buflen, size_t *len) {
    size_t n = 0;
    int c = 0;
    bool any = false;
    while ((c = fgetc(f)) != EOF) {
        any = true;
        if (c == '\n') {
            break;
        }
        if (c == '\0' || n + 1u >= buflen) {
            *len = n;
            return -1;
        }
        buf[n++] = (char)c;
    }
    if (n > 0u && buf[n - 1u] == '\r') {
        --n;
    }
    buf[n] = '\0';
    *len = n;
    return any ? 1 : 0;
}

static int fail(char *err, size_t errlen, const char *path, unsigned long line, const char *msg,
                const char *text) {
    if (err != NULL && errlen > 0u) {
        snprintf(err, errlen, "%s:%lu: %s%s%s%s", path, line, msg, text ? " '" : "",
                 text ? text : "", text ? "'" : "");
    }
    return -1;
}

/* Header line "<label>,<number>" (the number is not used, only checked). */
static bool header_ok(const char *line, const char *label) {
    const size_t n = strlen(label);
    if (strncmp(line, label, n) != 0 || line[n] != ',') {
        return false;
    }
    char *end = NULL;
    errno = 0;
    const double v = strtod(line + n + 1u, &end);
    return end != line + n + 1u && *end == '\0' && errno == 0 && isfinite(v) && v > 0.0;
}

int scene_real_noise_load(const char *path, struct scene_real_noise *rn, char *err, size_t errlen) {
    memset(rn, 0, sizeof *rn);
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        if (err != NULL && errlen > 0u) {
            snprintf(err, errlen, "%s: cannot open: %s (set TOF_SHARED_DIR to the shared folder)",
                     path, strerror(errno));
        }
        return -1;
    }
    size_t cap = 1u << 18;
    double *data = malloc(cap * sizeof *data);
    if (data == NULL) {
        fclose(f);
        return fail(err, errlen, path, 0, "out of memory", NULL);
    }
    char line[128];
    size_t len = 0;
    unsigned long lineno = 0;
    size_t count = 0;
    int rc = 0;
    for (;;) {
        const int got = read_line(f, line, sizeof line, &len);
        if (got == 0) {
            break;
        }
        ++lineno;
        if (got < 0) {
            rc = fail(err, errlen, path, lineno, "line too long or holds a NUL byte", NULL);
            break;
        }
        if (lineno == 1u && !header_ok(line, "Fs")) {
            rc = fail(err, errlen, path, lineno, "expected 'Fs,<rate>', got", line);
            break;
        }
        if (lineno == 2u && !header_ok(line, "Logging time")) {
            rc = fail(err, errlen, path, lineno, "expected 'Logging time,<seconds>', got", line);
            break;
        }
        if (lineno == 3u && strcmp(line, "d") != 0) {
            rc = fail(err, errlen, path, lineno, "expected column header 'd', got", line);
            break;
        }
        if (lineno <= 3u) {
            continue;
        }
        char *end = NULL;
        errno = 0;
        const double v = strtod(line, &end);
        if (end == line || *end != '\0' || errno != 0 || !isfinite(v) || v < 0.0 || v > 65535.0) {
            rc = fail(err, errlen, path, lineno, "not a distance in 0..65535 mm:", line);
            break;
        }
        if (count >= SCENE_REAL_NOISE_MAX) {
            rc = fail(err, errlen, path, lineno, "more readings than the limit", NULL);
            break;
        }
        if (count == cap) {
            cap *= 2u;
            double *grown = realloc(data, cap * sizeof *data);
            if (grown == NULL) {
                rc = fail(err, errlen, path, lineno, "out of memory", NULL);
                break;
            }
            data = grown;
        }
        data[count++] = v;
    }
    if (rc == 0 && ferror(f)) {
        rc = fail(err, errlen, path, lineno, "read error", NULL);
    }
    fclose(f);
    if (rc == 0 && count < 4u * 1000u) {
        rc = fail(err, errlen, path, lineno, "too few readings for four sensors (need 4000)", NULL);
    }
    if (rc != 0) {
        free(data);
        return rc;
    }
    rn->readings = data;
    rn->count = count;
    rn->quarter_len = count / 4u;
    return 0;
}

void scene_real_noise_free(struct scene_real_noise *rn) {
    free(rn->readings);
    memset(rn, 0, sizeof *rn);
}

int scene_real_stretch_init(const struct scene_real_noise *rn, unsigned sensor, size_t offset,
                            size_t len, struct scene_real_stretch *st) {
    if (rn->readings == NULL || rn->quarter_len == 0u || sensor >= SCENE_SENSORS ||
        offset >= rn->quarter_len || len == 0u) {
        return -1;
    }
    st->quarter = rn->readings + (size_t)sensor * rn->quarter_len;
    st->quarter_len = rn->quarter_len;
    st->offset = offset;
    /* A stretch longer than the quarter wraps: its mean is the quarter's. */
    const size_t used = len < rn->quarter_len ? len : rn->quarter_len;
    double sum = 0.0;
    for (size_t i = 0; i < used; ++i) {
        sum += st->quarter[(offset + i) % rn->quarter_len];
    }
    st->mean_mm = sum / (double)used;
    double ss = 0.0;
    for (size_t i = 0; i < used; ++i) {
        const double d = st->quarter[(offset + i) % rn->quarter_len] - st->mean_mm;
        ss += d * d;
    }
    st->sd_mm = sqrt(ss / (double)used);
    return 0;
}

double scene_real_stretch_noise(const struct scene_real_stretch *st, size_t i) {
    return st->quarter[(st->offset + i) % st->quarter_len] - st->mean_mm;
}

double scene_real_stretch_offset_sd(const struct scene_real_stretch *st, size_t len,
                                    size_t window) {
    if (window == 0u || len / window < 2u) {
        return 0.0;
    }
    const size_t blocks = len / window;
    double sum = 0.0;
    double sum2 = 0.0;
    for (size_t b = 0; b < blocks; ++b) {
        double m = 0.0;
        for (size_t i = 0; i < window; ++i) {
            m += scene_real_stretch_noise(st, b * window + i);
        }
        m /= (double)window;
        sum += m;
        sum2 += m * m;
    }
    const double mean = sum / (double)blocks;
    const double var_means = sum2 / (double)blocks - mean * mean;
    const double excess = var_means - st->sd_mm * st->sd_mm / (double)window;
    return excess > 0.0 ? sqrt(excess) : 0.0;
}
