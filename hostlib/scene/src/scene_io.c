/* Scenarios written as trace v1 files (scene_io.h). */
#include "scene/scene_io.h"

#include <errno.h>
#include <string.h>

#include "scene/trace.h"

/* "key=v1,v2,v3,v4" with `decimals` decimals. */
static void four(char *buf, size_t len, const char *key, int decimals, const double v[4]) {
    snprintf(buf, len, "%s=%.*f,%.*f,%.*f,%.*f", key, decimals, v[0], decimals, v[1], decimals,
             v[2], decimals, v[3]);
}

/* The thermal head's keys (docs/reference/trace-format.md, "orbit-thermal"): its calibration as
 * the unit would hold it (offsets exact at cal_temp_c, the coefficients as stated with their sd)
 * and the truth the simulation used (sim_*), which a replay does not read. */
static void thermal_keys(const struct scene_config *cfg, const struct scene_thermal_head *h,
                         char kv[8][TRACE_VALUE_MAX + TRACE_KEY_MAX]) {
    const struct scene_thermal *t = &cfg->thermal;
    const size_t len = TRACE_VALUE_MAX + TRACE_KEY_MAX;
    const double sd[4] = {t->coeff_sd_mm_per_c, t->coeff_sd_mm_per_c, t->coeff_sd_mm_per_c,
                          t->coeff_sd_mm_per_c};
    four(kv[0], len, "offset_mm", 3, h->offset_mm);
    snprintf(kv[1], len, "cal_temp_c=%.2f", t->cal_temp_c);
    four(kv[2], len, "temp_coeff_mm_per_c", 6, h->stated_mm_per_c);
    four(kv[3], len, "temp_coeff_sd_mm_per_c", 6, sd);
    four(kv[4], len, "sim_temp_coeff_mm_per_c", 9, h->coeff_mm_per_c);
    snprintf(kv[5], len, "sim_thermal=period_s %g mean_c %g amplitude_c %g phase_deg %g",
             t->period_s, t->mean_c, t->amplitude_c, t->phase_deg);
    snprintf(kv[6], len, "sim_coeff_range_mm_per_c=%g", t->coeff_range_mm_per_c);
    snprintf(kv[7], len, "sim_walk_um2_h=%g temp_noise_c %g temp_quantum_c %g", t->walk_um2_h,
             t->temp_noise_c, t->temp_quantum_c);
}

int scene_write_config(const struct scene_config *cfg, uint64_t seed, FILE *f, const char *path,
                       char *err, size_t errlen) {
    struct scene_gen gen;
    if (scene_gen_init(&gen, cfg, seed, err, errlen) != 0) {
        return -1;
    }
    char scenario[64];
    char seed_kv[48];
    char mean_kv[48];
    char window_kv[48];
    char noise_kv[120];
    snprintf(scenario, sizeof scenario, "scenario=%s", cfg->name);
    snprintf(seed_kv, sizeof seed_kv, "seed=%llu", (unsigned long long)seed);
    snprintf(mean_kv, sizeof mean_kv, "mean_mm=%g", cfg->mean_mm);
    snprintf(window_kv, sizeof window_kv, "window=%lu", (unsigned long)cfg->samples_per_position);
    if (cfg->real_noise) {
        snprintf(noise_kv, sizeof noise_kv,
                 "noise=real VL53L0X recording, tomisuarez2/TimeOfFlightCalibration (MIT)");
    } else {
        snprintf(noise_kv, sizeof noise_kv, "noise=gaussian sigma_mm=%g,%g,%g,%g",
                 cfg->noise[0].sigma_mm, cfg->noise[1].sigma_mm, cfg->noise[2].sigma_mm,
                 cfg->noise[3].sigma_mm);
    }
    /* For real noise, where in the recording each sensor's stretch starts (reading
     * index inside that sensor's quarter), so the trace can be traced back. */
    char stretch_kv[120] = "";
    if (cfg->real_noise) {
        snprintf(stretch_kv, sizeof stretch_kv,
                 "noise_stretch=quarter %zu readings; offsets A=%zu B=%zu C=%zu D=%zu",
                 gen.stretch[0].quarter_len, gen.stretch[0].offset, gen.stretch[1].offset,
                 gen.stretch[2].offset, gen.stretch[3].offset);
    }
    /* The simulated sensors read true distance plus zero-mean noise: offsets and gains known
     * exactly, which the trace says (docs/reference/trace-format.md), so a replay takes the head as
     * calibrated. The gains too: without them a reader takes gain 1 with the parts' spread
     * (1.7 %), an sd these sensors do not have. */
    static const char offset_kv[] = "offset_mm=0,0,0,0";
    static const char offset_sd_kv[] = "offset_sd_mm=0,0,0,0";
    static const char gain_kv[] = "gain=1,1,1,1";
    static const char gain_sd_kv[] = "gain_sd=0,0,0,0";
    char thermal_kv[8][TRACE_VALUE_MAX + TRACE_KEY_MAX];
    const bool thermal = cfg->thermal.on;
    if (thermal) {
        thermal_keys(cfg, &gen.thermal, thermal_kv);
    }
    /* the order every scenario's header has; a thermal head's offsets in offset_mm's place */
    /* A thermal head whose calibration stands in a HEAD.cal: calibration=FILE instead of the
     * calibration keys, the simulation's truth (sim_*) kept. */
    char file_kv[TRACE_VALUE_MAX + TRACE_KEY_MAX];
    const bool file = thermal && cfg->thermal.calibration_file[0] != '\0';
    snprintf(file_kv, sizeof file_kv, "calibration=%s", cfg->thermal.calibration_file);
    const char *meta[24] = {scenario, seed_kv, mean_kv, window_kv};
    unsigned n = 4u;
    if (file) {
        meta[n++] = file_kv;
    } else {
        meta[n++] = thermal ? thermal_kv[0] : offset_kv;
        meta[n++] = offset_sd_kv;
        meta[n++] = gain_kv;
        meta[n++] = gain_sd_kv;
    }
    meta[n++] = noise_kv;
    if (cfg->real_noise) {
        meta[n++] = stretch_kv;
    }
    for (unsigned k = file ? 4u : 1u; thermal && k < 8u; ++k) {
        meta[n++] = thermal_kv[k];
    }
    meta[n] = NULL;
    int rc = 0;
    if (trace_write_header_temp(f, cfg->arm_mm, cfg->period_ms, meta, thermal) != 0) {
        snprintf(err, errlen, "%s: cannot write the header: %s", path, strerror(errno));
        rc = -1;
    }
    while (rc == 0) {
        struct scene_row row = {0};
        const int got = scene_gen_next(&gen, &row, NULL, err, errlen);
        if (got == 1) {
            break;
        }
        if (got < 0) {
            rc = -1;
            break;
        }
        if (trace_write_row_temp(f, &row, thermal) != 0) {
            snprintf(err, errlen, "%s: cannot write row %llu: %s", path,
                     (unsigned long long)(gen.row - 1u), strerror(errno));
            rc = -1;
        }
    }
    scene_gen_free(&gen);
    return rc;
}

int scene_write_scenario(const char *name, uint64_t seed, const char *path, char *err,
                         size_t errlen) {
    struct scene_config cfg;
    if (scene_config_named_listed(name, &cfg, err, errlen) != 0) {
        return -1;
    }
    return scene_write_scenario_config(&cfg, seed, path, err, errlen);
}

int scene_config_named_listed(const char *name, struct scene_config *cfg, char *err,
                              size_t errlen) {
    if (scene_config_named(name, cfg) != 0) {
        char names[256] = "";
        for (size_t i = 0; scene_scenario_names[i] != NULL; ++i) {
            const size_t used = strlen(names);
            snprintf(names + used, sizeof names - used, "%s%s", i ? ", " : "",
                     scene_scenario_names[i]);
        }
        snprintf(err, errlen, "unknown scenario '%s' (known: %s)", name, names);
        return -1;
    }
    return 0;
}

int scene_write_scenario_config(const struct scene_config *cfg, uint64_t seed, const char *path,
                                char *err, size_t errlen) {
    const bool to_stdout = strcmp(path, "-") == 0;
    FILE *f = to_stdout ? stdout : fopen(path, "wb");
    if (f == NULL) {
        snprintf(err, errlen, "%s: cannot open for writing: %s", path, strerror(errno));
        return -1;
    }
    int rc = scene_write_config(cfg, seed, f, path, err, errlen);
    if (to_stdout) {
        if (fflush(f) != 0 && rc == 0) {
            snprintf(err, errlen, "%s: write error: %s", path, strerror(errno));
            rc = -1;
        }
        return rc;
    }
    if (fclose(f) != 0 && rc == 0) {
        snprintf(err, errlen, "%s: write error: %s", path, strerror(errno));
        rc = -1;
    }
    if (rc != 0) {
        remove(path);
    }
    return rc;
}
