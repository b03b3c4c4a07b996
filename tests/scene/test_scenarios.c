/* Named scenarios: shape, parameters, determinism, real-noise loading. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "scene/crb.h"
#include "scene/geometry.h"
#include "scene/real_noise.h"
#include "scene/scenario.h"

static void assert_close(double got, double want, double tol) {
    if (!(fabs(got - want) <= tol)) {
        fail_msg("got %.17g, want %.17g (tolerance %.3g)", got, want, tol);
    }
}

struct run {
    struct scene_row *rows;
    struct scene_row_info *info;
    size_t n;
};

/* Generates a whole scenario into memory. */
static struct run generate(const struct scene_config *cfg, uint64_t seed) {
    struct scene_gen *gen = malloc(sizeof *gen);
    assert_non_null(gen);
    char err[512] = "";
    if (scene_gen_init(gen, cfg, seed, err, sizeof err) != 0) {
        fail_msg("%s", err);
    }
    const size_t total = (size_t)scene_config_rows(cfg);
    struct run r = {malloc(total * sizeof *r.rows), malloc(total * sizeof *r.info), 0};
    assert_non_null(r.rows);
    assert_non_null(r.info);
    for (;;) {
        struct scene_row row;
        struct scene_row_info info;
        const int got = scene_gen_next(gen, &row, &info, err, sizeof err);
        if (got == 1) {
            break;
        }
        if (got != 0) {
            fail_msg("%s", err);
        }
        assert_true(r.n < total);
        r.rows[r.n] = row;
        r.info[r.n] = info;
        r.n++;
    }
    assert_int_equal(r.n, total);
    scene_gen_free(gen);
    free(gen);
    return r;
}

static struct run generate_named(const char *name, uint64_t seed) {
    struct scene_config cfg;
    assert_int_equal(scene_config_named(name, &cfg), 0);
    return generate(&cfg, seed);
}

static void release(struct run *r) {
    free(r->rows);
    free(r->info);
}

/* Common checks: time base, truth present, readings consistent with the ideal. */
static void check_common(const struct run *r, const struct scene_config *cfg) {
    for (size_t i = 0; i < r->n; ++i) {
        const struct scene_row *row = &r->rows[i];
        assert_int_equal(row->t_ms, (uint32_t)(i * cfg->period_ms));
        assert_true(row->has_alpha && row->has_beta);
        double ideal[SCENE_SENSORS];
        scene_ideal_distances(cfg->arm_mm, cfg->mean_mm, row->alpha_deg, row->beta_deg, ideal);
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            assert_close(r->info[i].ideal_mm[k], ideal[k], 1e-12);
            if (!row->present[k]) {
                assert_int_equal(row->status[k], SCENE_STATUS_NO_READING);
                assert_int_equal(row->range_mm[k], 0);
            }
        }
    }
}

/* Sample σ of reading − ideal over valid, non-outlier readings of sensor k. */
static double sensor_sd(const struct run *r, unsigned k, double *mean_out) {
    double s = 0.0;
    double s2 = 0.0;
    size_t n = 0;
    for (size_t i = 0; i < r->n; ++i) {
        if (!scene_row_valid(&r->rows[i], k) || r->info[i].outlier[k]) {
            continue;
        }
        const double e = (double)r->rows[i].range_mm[k] - r->info[i].ideal_mm[k];
        s += e;
        s2 += e * e;
        ++n;
    }
    assert_true(n > 1000u);
    const double mean = s / (double)n;
    if (mean_out != NULL) {
        *mean_out = mean;
    }
    return sqrt(s2 / (double)n - mean * mean);
}

/* Paper Sec. IV: 100 positions evenly from −5° to 5°, N = 100 each, β = 0, σ = 2. */
static void test_table1(void **state) {
    (void)state;
    struct scene_config cfg;
    assert_int_equal(scene_config_named("table1", &cfg), 0);
    assert_close(cfg.arm_mm, 30.0, 0.0);
    struct run r = generate(&cfg, 1);
    assert_int_equal(r.n, 10000);
    check_common(&r, &cfg);
    for (size_t i = 0; i < r.n; ++i) {
        const uint32_t pos = (uint32_t)(i / 100u);
        assert_int_equal(r.info[i].position, pos);
        assert_close(r.rows[i].alpha_deg, -5.0 + 10.0 * pos / 99.0, 1e-12);
        assert_true(r.rows[i].beta_deg == 0.0);
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            assert_true(scene_row_valid(&r.rows[i], k));
            assert_close(r.info[i].sigma_mm[k], scene_quantised_sigma(2.0), 1e-12);
        }
    }
    assert_close(r.rows[0].alpha_deg, -5.0, 1e-12);
    assert_close(r.rows[r.n - 1u].alpha_deg, 5.0, 1e-12);
    for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
        double mean = 0.0;
        assert_close(sensor_sd(&r, k, &mean), 2.02, 0.06); /* 10000 samples: sd ±0.7 % */
        assert_close(mean, 0.0, 0.08);
    }
    release(&r);
}

/* The 11 nominal angles of Table II, 100 samples each. */
static void test_table2(void **state) {
    (void)state;
    static const double nominal[11] = {-3.96, -2.88, -1.98, -1.26, -0.18, -0.09,
                                       0.0,   1.26,  1.98,  3.96,  4.68};
    struct scene_config cfg;
    assert_int_equal(scene_config_named("table2", &cfg), 0);
    struct run r = generate(&cfg, 2);
    assert_int_equal(r.n, 1100);
    check_common(&r, &cfg);
    for (size_t i = 0; i < r.n; ++i) {
        assert_true(r.rows[i].alpha_deg == nominal[i / 100u]);
        assert_true(r.rows[i].beta_deg == 0.0);
    }
    release(&r);
}

static void test_hetero(void **state) {
    (void)state;
    struct scene_config cfg;
    assert_int_equal(scene_config_named("hetero", &cfg), 0);
    struct run r = generate(&cfg, 3);
    check_common(&r, &cfg);
    assert_close(sensor_sd(&r, SCENE_A, NULL), 6.0, 0.15);
    assert_close(r.info[0].sigma_mm[SCENE_A], scene_quantised_sigma(6.0), 1e-12);
    for (unsigned k = SCENE_B; k < SCENE_SENSORS; ++k) {
        assert_close(sensor_sd(&r, k, NULL), 2.02, 0.06);
    }
    release(&r);
}

/* β uniform in ±4°, constant within each 100-sample window. */
static void test_crossaxis(void **state) {
    (void)state;
    struct scene_config cfg;
    assert_int_equal(scene_config_named("crossaxis", &cfg), 0);
    struct run r = generate(&cfg, 4);
    check_common(&r, &cfg);
    double lo = 0.0;
    double hi = 0.0;
    double sum2 = 0.0;
    for (size_t w = 0; w < 100u; ++w) {
        const double b = r.rows[w * 100u].beta_deg;
        for (size_t i = 1; i < 100u; ++i) {
            assert_true(r.rows[w * 100u + i].beta_deg == b);
        }
        assert_true(fabs(b) < 4.0);
        lo = fmin(lo, b);
        hi = fmax(hi, b);
        sum2 += b * b;
    }
    assert_true(lo < -3.0 && hi > 3.0);
    /* variance of U(−4, 4) is 16/3; 100 windows: ±30 % is beyond 3 σ */
    assert_close(sum2 / 100.0, 16.0 / 3.0, 1.6);
    release(&r);
}

static void test_outliers(void **state) {
    (void)state;
    struct scene_config cfg;
    assert_int_equal(scene_config_named("outliers", &cfg), 0);
    struct run r = generate(&cfg, 5);
    check_common(&r, &cfg);
    size_t outliers = 0;
    for (size_t i = 0; i < r.n; ++i) {
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            assert_int_equal(r.rows[i].status[k], 0); /* outliers keep a valid status */
            if (r.info[i].outlier[k]) {
                ++outliers;
                const double off = fabs((double)r.rows[i].range_mm[k] - r.info[i].ideal_mm[k]);
                assert_true(off >= 20.0 - 13.0 && off <= 80.0 + 13.0);
            }
        }
    }
    assert_close((double)outliers / 40000.0, 0.02, 0.0035); /* 5 binomial σ */
    release(&r);
}

static void test_flagged(void **state) {
    (void)state;
    struct scene_config cfg;
    assert_int_equal(scene_config_named("flagged", &cfg), 0);
    struct run r = generate(&cfg, 6);
    check_common(&r, &cfg);
    size_t flagged = 0;
    for (size_t i = 0; i < r.n; ++i) {
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            assert_true(r.rows[i].present[k]);
            if (r.rows[i].status[k] != 0u) {
                assert_int_equal(r.rows[i].status[k], SCENE_STATUS_FLAGGED);
                ++flagged;
            }
        }
    }
    assert_close((double)flagged / 40000.0, 0.05, 0.0055);
    release(&r);
}

/* One random sensor missing for whole windows, in 20 % of them: checked over
 * 2000 windows of N = 10 so the rate is measured to ±0.045 (5 σ). */
static void test_dropout(void **state) {
    (void)state;
    struct scene_config cfg;
    assert_int_equal(scene_config_named("dropout", &cfg), 0);
    cfg.n_positions = 2000u;
    cfg.samples_per_position = 10u;
    struct run r = generate(&cfg, 7);
    check_common(&r, &cfg);
    unsigned dropped = 0;
    unsigned per_sensor[SCENE_SENSORS] = {0};
    for (size_t w = 0; w < 2000u; ++w) {
        int missing = -1;
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            if (!r.rows[w * 10u].present[k]) {
                assert_int_equal(missing, -1); /* at most one sensor */
                missing = (int)k;
            }
        }
        for (size_t i = 0; i < 10u; ++i) { /* the whole window, nothing else */
            for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
                assert_int_equal(r.rows[w * 10u + i].present[k], (int)k != missing);
            }
        }
        if (missing >= 0) {
            ++dropped;
            per_sensor[missing]++;
        }
    }
    assert_close(dropped / 2000.0, 0.2, 0.045);
    for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
        assert_true(per_sensor[k] > 50u); /* every sensor gets its turn (~100) */
    }
    release(&r);
}

/* Real noise: zero mean per sensor, σ of the recording (≈ 2.15 mm), sigma_mm in
 * the info equal to the stretch's own σ plus the dither term. */
static void test_realnoise(void **state) {
    (void)state;
    struct scene_config cfg;
    assert_int_equal(scene_config_named("realnoise", &cfg), 0);
    struct run r = generate(&cfg, 8);
    check_common(&r, &cfg);
    for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
        double mean = 0.0;
        const double sd = sensor_sd(&r, k, &mean);
        assert_close(mean, 0.0, 0.03); /* centred on its own mean, dither unbiased */
        assert_true(sd > 1.9 && sd < 2.5);
        assert_true(r.info[0].sigma_mm[k] > 1.9 && r.info[0].sigma_mm[k] < 2.5);
        /* The recording wanders slowly: a per-window offset of a few tenths of a mm. */
        assert_true(r.info[0].offset_sd_mm[k] > 0.05 && r.info[0].offset_sd_mm[k] < 1.0);
        /* The reported σ matches the measured one within 3 %. */
        double sig = 0.0;
        for (size_t i = 0; i < r.n; ++i) {
            sig += r.info[i].sigma_mm[k] * r.info[i].sigma_mm[k];
        }
        assert_close(sqrt(sig / (double)r.n), sd, 0.03 * sd);
    }
    /* Disjoint stretches: the sensors' noise sequences are not copies. */
    size_t equal = 0;
    for (size_t i = 0; i < r.n; ++i) {
        equal += (int)r.rows[i].range_mm[0] - (int)lround(r.info[i].ideal_mm[0]) ==
                 (int)r.rows[i].range_mm[2] - (int)lround(r.info[i].ideal_mm[2]);
    }
    assert_true(equal < r.n / 3u);
    release(&r);
}

/* Demo: 5000 rows on the steps-and-ramps schedule, α and β both move. */
static void test_realnoise_demo(void **state) {
    (void)state;
    struct scene_config cfg;
    assert_int_equal(scene_config_named("realnoise-demo", &cfg), 0);
    struct run r = generate(&cfg, 9);
    assert_int_equal(r.n, SCENE_DEMO_ROWS);
    check_common(&r, &cfg);
    double amin = 0.0;
    double amax = 0.0;
    double bmin = 0.0;
    double bmax = 0.0;
    for (size_t i = 0; i < r.n; ++i) {
        double a = 0.0;
        double b = 0.0;
        scene_demo_attitude(i, &a, &b);
        assert_true(r.rows[i].alpha_deg == a && r.rows[i].beta_deg == b);
        amin = fmin(amin, a);
        amax = fmax(amax, a);
        bmin = fmin(bmin, b);
        bmax = fmax(bmax, b);
    }
    assert_close(amin, -4.0, 1e-12);
    assert_close(amax, 3.0, 1e-12);
    assert_close(bmin, -2.0, 1e-12);
    assert_close(bmax, 4.0, 1e-12);
    /* Step at row 600: α 0 → 3; ramp 1800..2799 ends at −4 on its last row. */
    assert_true(r.rows[599].alpha_deg == 0.0 && r.rows[600].alpha_deg == 3.0);
    assert_close(r.rows[2799].alpha_deg, -4.0, 1e-12);
    assert_close(r.rows[2299].alpha_deg, 3.0 - 7.0 * 500.0 / 1000.0, 1e-12);
    assert_close(r.rows[4999].alpha_deg, 0.0, 1e-12);
    release(&r);
}

static void test_same_seed_same_rows(void **state) {
    (void)state;
    for (size_t s = 0; scene_scenario_names[s] != NULL; ++s) {
        struct run a = generate_named(scene_scenario_names[s], 77);
        struct run b = generate_named(scene_scenario_names[s], 77);
        struct run c = generate_named(scene_scenario_names[s], 78);
        assert_int_equal(a.n, b.n);
        size_t differ = 0;
        for (size_t i = 0; i < a.n; ++i) {
            assert_memory_equal(a.rows[i].range_mm, b.rows[i].range_mm, sizeof a.rows[i].range_mm);
            assert_memory_equal(a.rows[i].status, b.rows[i].status, sizeof a.rows[i].status);
            assert_true(a.rows[i].alpha_deg == b.rows[i].alpha_deg);
            assert_true(a.rows[i].beta_deg == b.rows[i].beta_deg);
            differ +=
                memcmp(a.rows[i].range_mm, c.rows[i].range_mm, sizeof a.rows[i].range_mm) != 0;
        }
        assert_true(differ > a.n / 2u);
        release(&a);
        release(&b);
        release(&c);
    }
}

static void test_unknown_and_bad_configs(void **state) {
    (void)state;
    struct scene_config cfg;
    assert_int_equal(scene_config_named("table3", &cfg), -1);
    assert_int_equal(scene_config_named(NULL, &cfg), -1);
    struct scene_gen gen;
    char err[256] = "";
    assert_int_equal(scene_config_named("table1", &cfg), 0);
    cfg.arm_mm = 0.0;
    assert_int_equal(scene_gen_init(&gen, &cfg, 1, err, sizeof err), -1);
    assert_non_null(strstr(err, "arm_mm"));
    assert_int_equal(scene_config_named("table1", &cfg), 0);
    cfg.noise[2].outlier_rate = 1.5;
    assert_int_equal(scene_gen_init(&gen, &cfg, 1, err, sizeof err), -1);
    assert_non_null(strstr(err, "noise parameter"));
    /* A reading that falls below 0 mm is an error naming row and sensor. */
    assert_int_equal(scene_config_named("table1", &cfg), 0);
    cfg.mean_mm = 1.0;
    assert_int_equal(scene_gen_init(&gen, &cfg, 1, err, sizeof err), 0);
    struct scene_row row;
    assert_int_equal(scene_gen_next(&gen, &row, NULL, err, sizeof err), -1);
    assert_non_null(strstr(err, "scenario table1: row 0 sensor "));
    assert_non_null(strstr(err, "outside 0..65535"));
    assert_string_equal(scene_gen_error(&gen), err);
    scene_gen_free(&gen);
}

/* Writes text to a temporary file and returns its path. */
static const char *temp_file(const char *name, const char *text) {
    static char path[256];
    snprintf(path, sizeof path, "%s_%s", "scene_test_tmp", name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fputs(text, f) >= 0, 1);
    assert_int_equal(fclose(f), 0);
    return path;
}

static void test_real_noise_loader_errors(void **state) {
    (void)state;
    struct scene_real_noise rn;
    char err[512];
    const char *p = temp_file("a.csv", "Fs,50.00\nLogging time,3600\nd\n79.0\n7x.0\n");
    assert_int_equal(scene_real_noise_load(p, &rn, err, sizeof err), -1);
    char want[300];
    snprintf(want, sizeof want, "%s:5: not a distance", p);
    assert_non_null(strstr(err, want));
    remove(p);
    p = temp_file("b.csv", "Fs,50.00\nLogging\nd\n");
    assert_int_equal(scene_real_noise_load(p, &rn, err, sizeof err), -1);
    snprintf(want, sizeof want, "%s:2: expected 'Logging time", p);
    assert_non_null(strstr(err, want));
    remove(p);
    p = temp_file("c.csv", "Fs,50.00\nLogging time,3600\nd\n79.0\n");
    assert_int_equal(scene_real_noise_load(p, &rn, err, sizeof err), -1);
    assert_non_null(strstr(err, "too few readings"));
    remove(p);
    assert_int_equal(scene_real_noise_load("no/such/file.csv", &rn, err, sizeof err), -1);
    assert_non_null(strstr(err, "no/such/file.csv: cannot open"));
}

/* The shared recording loads completely and matches SOURCE.md's statistics. */
static void test_real_noise_file(void **state) {
    (void)state;
    char path[1200];
    assert_int_equal(scene_real_noise_default_path(path, sizeof path), 0);
    struct scene_real_noise rn;
    char err[512] = "";
    if (scene_real_noise_load(path, &rn, err, sizeof err) != 0) {
        fail_msg("%s", err);
    }
    assert_int_equal(rn.count, 200244);
    assert_int_equal(rn.quarter_len, 50061);
    struct scene_real_stretch st;
    assert_int_equal(scene_real_stretch_init(&rn, 0, 0, rn.count, &st), 0);
    double s = 0.0;
    for (size_t i = 0; i < rn.count; ++i) {
        s += rn.readings[i];
    }
    assert_close(s / (double)rn.count, 75.54, 0.01); /* SOURCE.md: mean 75.54 */
    assert_true(st.sd_mm > 1.8 && st.sd_mm < 2.6);
    assert_close(scene_real_stretch_noise(&st, 0), rn.readings[0] - st.mean_mm, 1e-12);
    assert_int_equal(scene_real_stretch_init(&rn, 1, rn.quarter_len, 10, &st), -1);
    scene_real_noise_free(&rn);
}

/* Offset σ of a synthetic stretch: blocks of 100 readings alternately +1 and −1
 * mm have sd 1 and block means ±1, so the slow part is sqrt(1 − 1/100). A
 * constant-free alternating sequence (+1, −1, ...) has none. */
static void test_stretch_offset_sd(void **state) {
    (void)state;
    static double readings[4u * 2000u];
    for (size_t i = 0; i < 2000u; ++i) {
        readings[i] = 50.0 + (((i / 100u) % 2u) ? 1.0 : -1.0); /* sensor A */
        readings[2000u + i] = 50.0 + ((i % 2u) ? 1.0 : -1.0);  /* sensor B */
        readings[4000u + i] = readings[6000u + i] = 50.0;
    }
    struct scene_real_noise rn = {readings, 8000u, 2000u};
    struct scene_real_stretch st;
    assert_int_equal(scene_real_stretch_init(&rn, 0, 0, 2000u, &st), 0);
    assert_close(st.mean_mm, 50.0, 1e-12);
    assert_close(st.sd_mm, 1.0, 1e-12);
    assert_close(scene_real_stretch_offset_sd(&st, 2000u, 100u), sqrt(0.99), 1e-12);
    assert_int_equal(scene_real_stretch_init(&rn, 1, 0, 2000u, &st), 0);
    assert_close(scene_real_stretch_offset_sd(&st, 2000u, 100u), 0.0, 0.0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_table1),
        cmocka_unit_test(test_table2),
        cmocka_unit_test(test_hetero),
        cmocka_unit_test(test_crossaxis),
        cmocka_unit_test(test_outliers),
        cmocka_unit_test(test_flagged),
        cmocka_unit_test(test_dropout),
        cmocka_unit_test(test_realnoise),
        cmocka_unit_test(test_realnoise_demo),
        cmocka_unit_test(test_same_seed_same_rows),
        cmocka_unit_test(test_unknown_and_bad_configs),
        cmocka_unit_test(test_real_noise_loader_errors),
        cmocka_unit_test(test_real_noise_file),
        cmocka_unit_test(test_stretch_offset_sd),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
