/*
 * `host_sim camera` end to end: argument errors exit 2 with a message, a small
 * run writes the JSON report with the required keys and a valid PNG (checked
 * here chunk by chunk: CRCs, zlib stored blocks, Adler-32, row filters).
 */
#include <math.h>
#include <setjmp.h>
#include <stdbool.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "camera/camera_cmd.h"

#ifndef OUT_DIR
#error "OUT_DIR must name a writable directory"
#endif

static int run(int argc, const char *const *argv) {
    char *copy[32];
    assert_true(argc < 32);
    for (int i = 0; i < argc; ++i) {
        copy[i] = (char *)(uintptr_t)argv[i];
    }
    copy[argc] = NULL;
    return host_sim_camera_main(argc, copy);
}

#define RUN(...)                                                                                   \
    run((int)(sizeof((const char *const[]){__VA_ARGS__}) / sizeof(const char *)),                  \
        (const char *const[]){__VA_ARGS__})

#define BASE                                                                                       \
    "camera", "--frames", "2", "--range-mm", "700", "--spurious", "2", "--missing", "1",           \
        "--depth-noise", "0.01", "--gray-noise", "0.02", "--seed", "5"

static void test_bad_arguments_exit_2(void **state) {
    (void)state;
    const char *report = OUT_DIR "/bad.json";
    assert_int_equal(RUN(BASE, "--report", report, "--bogus", "1"), 2);
    assert_int_equal(RUN(BASE, "--report"), 2); /* missing value */
    assert_int_equal(RUN(BASE), 2);             /* --report missing */
    assert_int_equal(RUN("camera", "--frames", "x", "--report", report), 2);
    assert_int_equal(RUN("camera", "--frames", "0", "--report", report), 2);
    assert_int_equal(RUN("camera", "--frames", "2", "--range-mm", "700", "--spurious", "9",
                         "--missing", "1", "--depth-noise", "0", "--gray-noise", "0", "--seed", "1",
                         "--report", report),
                     2);
    assert_int_equal(RUN("camera", "--frames", "2", "--range-mm", "700", "--spurious", "0",
                         "--missing", "1", "--depth-noise", "-0.1", "--gray-noise", "0", "--seed",
                         "1", "--report", report),
                     2);
    assert_int_equal(RUN("camera", "--frames", "2", "--range-mm", "700", "--spurious", "0",
                         "--missing", "1", "--depth-noise", "0", "--gray-noise", "0", "--seed",
                         "-3", "--report", report),
                     2);
    assert_int_equal(RUN("camera", "stray", "--report", report), 2);
    /* every marker in view is impossible at 0.3 m for this target */
    assert_int_equal(RUN("camera", "--frames", "1", "--range-mm", "300", "--spurious", "0",
                         "--missing", "0", "--depth-noise", "0", "--gray-noise", "0", "--seed", "1",
                         "--report", report),
                     2);
    /* unwritable report path: I/O error */
    assert_int_equal(RUN(BASE, "--report", OUT_DIR "/no/such/dir/r.json"), 1);
}

static char *slurp(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *buf = malloc((size_t)n + 1u);
    assert_non_null(buf);
    assert_int_equal(fread(buf, 1, (size_t)n, f), (size_t)n);
    buf[n] = '\0';
    fclose(f);
    *len = (size_t)n;
    return buf;
}

static double json_number(const char *json, const char *key) {
    char pattern[64];
    snprintf(pattern, sizeof pattern, "\"%s\":", key);
    const char *p = strstr(json, pattern);
    assert_non_null(p);
    return strtod(p + strlen(pattern), NULL);
}

static uint32_t be32(const unsigned char *p) {
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

static uint32_t crc32_of(const unsigned char *p, size_t n) {
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; ++i) {
        c ^= p[i];
        for (int k = 0; k < 8; ++k) {
            c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
        }
    }
    return c ^ 0xFFFFFFFFu;
}

static void check_png(const char *path, uint32_t want_w, uint32_t want_h) {
    size_t len = 0;
    unsigned char *png = (unsigned char *)slurp(path, &len);
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    assert_memory_equal(png, sig, 8);
    size_t pos = 8;
    uint32_t w = 0, h = 0;
    unsigned char *idat = NULL;
    size_t idat_len = 0;
    bool iend = false;
    while (pos + 12 <= len && !iend) {
        uint32_t n = be32(png + pos);
        const unsigned char *type = png + pos + 4;
        assert_true(pos + 12 + n <= len);
        assert_int_equal(crc32_of(type, 4u + n), be32(png + pos + 8 + n));
        if (memcmp(type, "IHDR", 4) == 0) {
            w = be32(type + 4);
            h = be32(type + 8);
            assert_int_equal(type[12], 8); /* bit depth */
            assert_int_equal(type[13], 2); /* RGB */
        } else if (memcmp(type, "IDAT", 4) == 0) {
            idat = (unsigned char *)type + 4;
            idat_len = n;
        } else if (memcmp(type, "IEND", 4) == 0) {
            iend = true;
        }
        pos += 12u + n;
    }
    assert_true(iend);
    assert_int_equal(w, want_w);
    assert_int_equal(h, want_h);
    assert_non_null(idat);
    if (idat == NULL) {
        return; /* not reached: the assertion ended the test (keeps -O3 from warning) */
    }
    assert_int_equal((idat[0] * 256 + idat[1]) % 31, 0);
    size_t row = (size_t)w * 3u + 1u;
    size_t raw_len = row * h;
    unsigned char *raw = malloc(raw_len);
    assert_non_null(raw);
    size_t zp = 2, out = 0;
    bool final = false;
    while (!final) {
        assert_true(zp + 5 <= idat_len);
        final = idat[zp] & 1u;
        assert_int_equal(idat[zp] & 6u, 0); /* stored */
        unsigned n = idat[zp + 1] | (unsigned)idat[zp + 2] << 8;
        unsigned nn = idat[zp + 3] | (unsigned)idat[zp + 4] << 8;
        assert_int_equal(n ^ 0xFFFFu, nn);
        assert_true(out + n <= raw_len);
        memcpy(raw + out, idat + zp + 5, n);
        out += n;
        zp += 5u + n;
    }
    assert_int_equal(out, raw_len);
    uint32_t a = 1, b = 0;
    for (size_t i = 0; i < raw_len; ++i) {
        a = (a + raw[i]) % 65521u;
        b = (b + a) % 65521u;
    }
    assert_int_equal(be32(idat + zp), (b << 16) | a);
    for (uint32_t y = 0; y < h; ++y) {
        assert_int_equal(raw[(size_t)y * row], 0); /* filter type none */
    }
    free(raw);
    free(png);
}

static void test_run_writes_report_and_image(void **state) {
    (void)state;
    const char *report = OUT_DIR "/camera_report.json";
    const char *image = OUT_DIR "/camera_frame.png";
    remove(report);
    remove(image);
    assert_int_equal(RUN("camera", "--frames", "6", "--range-mm", "700", "--spurious", "2",
                         "--missing", "1", "--depth-noise", "0.01", "--gray-noise", "0.02",
                         "--seed", "42", "--report", report, "--image", image),
                     0);
    size_t len = 0;
    char *json = slurp(report, &len);
    assert_true(json_number(json, "frames") == 6.0);
    assert_true(json_number(json, "range_mm") == 700.0);
    double rot = json_number(json, "rot_err_deg_rms");
    double pos = json_number(json, "pos_err_mm_rms");
    double match = json_number(json, "match_rate");
    double cen = json_number(json, "centroid_err_px_rms");
    assert_true(rot >= 0.0 && rot < 0.2);
    assert_true(pos >= 0.0 && pos < 2.0);
    assert_true(match >= 0.0 && match <= 1.0);
    assert_true(cen > 0.0 && cen < 0.2);
    free(json);
    check_png(image, 960, 720);
    /* same seed, same report: the run is deterministic (the timing field aside) */
    const char *again = OUT_DIR "/camera_report2.json";
    assert_int_equal(RUN("camera", "--frames", "6", "--range-mm", "700", "--spurious", "2",
                         "--missing", "1", "--depth-noise", "0.01", "--gray-noise", "0.02",
                         "--seed", "42", "--report", again),
                     0);
    char *j1 = slurp(report, &len);
    char *j2 = slurp(again, &len);
    assert_true(json_number(j1, "rot_err_deg_rms") == json_number(j2, "rot_err_deg_rms"));
    assert_true(json_number(j1, "pos_err_mm_rms") == json_number(j2, "pos_err_mm_rms"));
    free(j1);
    free(j2);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_arguments_exit_2),
        cmocka_unit_test(test_run_writes_report_and_image),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
