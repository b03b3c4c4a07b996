/* Named scenario generators (scenario.h; parameters in docs/reference/trace-format.md). */
#include "scene/scenario.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "scene/geometry.h"

const char *const scene_scenario_names[] = {
    "table1",  "table2",    "hetero",         "crossaxis",     "outliers", "flagged",
    "dropout", "realnoise", "realnoise-demo", "orbit-thermal", NULL,
};

/* The 11 nominal angles α_n of Table II of the first paper (Sec. V). */
static const double table2_alpha_deg[] = {-3.96, -2.88, -1.98, -1.26, -0.18, -0.09,
                                          0.0,   1.26,  1.98,  3.96,  4.68};

/* RNG streams of one seed: one per purpose so the draws of one do not shift
 * another's when a parameter changes. */
enum { STREAM_WINDOW = 0, STREAM_SENSOR0 = 1, STREAM_DITHER = 5, STREAM_OFFSET = 6 };

static void base_config(struct scene_config *cfg, const char *name) {
    memset(cfg, 0, sizeof *cfg);
    snprintf(cfg->name, sizeof cfg->name, "%s", name);
    cfg->arm_mm = SCENE_DEFAULT_ARM_MM;
    cfg->mean_mm = SCENE_DEFAULT_MEAN_MM;
    cfg->period_ms = SCENE_DEFAULT_PERIOD_MS;
    /* Paper Sec. IV: 100 positions from −5° to 5°, N = 100 samples, σ = 2 mm, β = 0. */
    cfg->schedule = SCENE_SCHEDULE_SWEEP;
    cfg->n_positions = 100u;
    cfg->samples_per_position = SCENE_DEFAULT_WINDOW;
    cfg->alpha_from_deg = -5.0;
    cfg->alpha_to_deg = 5.0;
    for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
        cfg->noise[k].sigma_mm = 2.0;
        cfg->noise[k].outlier_min_mm = 20.0;
        cfg->noise[k].outlier_max_mm = 80.0;
        cfg->noise[k].flag_error_mm = 60.0; /* keeps flagged readings above 0 mm */
    }
}

int scene_config_named(const char *name, struct scene_config *cfg) {
    if (name == NULL) {
        return -1;
    }
    base_config(cfg, name);
    if (strcmp(name, "table1") == 0) {
        return 0;
    }
    if (strcmp(name, "table2") == 0) {
        cfg->schedule = SCENE_SCHEDULE_LIST;
        cfg->n_positions = (uint32_t)(sizeof table2_alpha_deg / sizeof table2_alpha_deg[0]);
        memcpy(cfg->alpha_list_deg, table2_alpha_deg, sizeof table2_alpha_deg);
        return 0;
    }
    if (strcmp(name, "hetero") == 0) {
        cfg->noise[SCENE_A].sigma_mm = 6.0; /* A is one of the α pair (A, C) */
        return 0;
    }
    if (strcmp(name, "crossaxis") == 0) {
        cfg->beta_random_deg = 4.0;
        return 0;
    }
    if (strcmp(name, "outliers") == 0) {
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            cfg->noise[k].outlier_rate = 0.02;
        }
        return 0;
    }
    if (strcmp(name, "flagged") == 0) {
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            cfg->noise[k].flag_rate = 0.05;
        }
        return 0;
    }
    if (strcmp(name, "dropout") == 0) {
        cfg->window_dropout_prob = 0.2;
        return 0;
    }
    if (strcmp(name, "realnoise") == 0 || strcmp(name, "realnoise-demo") == 0) {
        cfg->real_noise = true;
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            cfg->noise[k].sigma_mm = 0.0; /* all jitter comes from the recording */
        }
        if (strcmp(name, "realnoise-demo") == 0) {
            cfg->schedule = SCENE_SCHEDULE_DEMO;
        }
        return 0;
    }
    if (strcmp(name, "orbit-thermal") == 0) {
        /* A calibrated head in orbit (scene/thermal.h): the plate sweeps α over ±5° once over
         * the run (0.0005° a 2 s window at 6 h, far within the unit's rate bound) at β = −2°,
         * while the head's temperature cycles and the offsets follow it. */
        scene_thermal_defaults(&cfg->thermal);
        cfg->beta_deg = -2.0;
        return scene_config_set_hours(cfg, SCENE_THERMAL_HOURS);
    }
    return -1;
}

int scene_config_set_hours(struct scene_config *cfg, double hours) {
    if (!(hours > 0.0 && hours <= 24.0) || cfg->schedule != SCENE_SCHEDULE_SWEEP ||
        cfg->period_ms == 0u || cfg->samples_per_position == 0u) {
        return -1;
    }
    const double window_ms = (double)cfg->period_ms * cfg->samples_per_position;
    cfg->n_positions = (uint32_t)ceil(hours * 3600e3 / window_ms);
    return 0;
}

uint64_t scene_config_rows(const struct scene_config *cfg) {
    if (cfg->schedule == SCENE_SCHEDULE_DEMO) {
        return SCENE_DEMO_ROWS;
    }
    return (uint64_t)cfg->n_positions * cfg->samples_per_position;
}

/* The demo schedule: holds, steps and ramps of α and β (docs/reference/trace-format.md). */
struct demo_segment {
    uint32_t rows;
    double alpha_end_deg, beta_end_deg;
    bool ramp; /* false: step to the end values and hold */
};
static const struct demo_segment demo_segments[] = {
    {600u, 0.0, 0.0, false},   /* level plate */
    {600u, 3.0, 0.0, false},   /* α step */
    {600u, 3.0, -2.0, false},  /* β step */
    {1000u, -4.0, -2.0, true}, /* α ramp 3° → −4° in 20 s */
    {800u, -4.0, 4.0, true},   /* β ramp −2° → 4° in 16 s */
    {700u, 1.5, 1.0, false},   /* both step */
    {700u, 0.0, 0.0, true},    /* both ramp back to level */
};

void scene_demo_attitude(uint64_t i, double *alpha_deg, double *beta_deg) {
    double a0 = 0.0;
    double b0 = 0.0;
    uint64_t start = 0;
    const size_t n = sizeof demo_segments / sizeof demo_segments[0];
    for (size_t s = 0; s < n; ++s) {
        const struct demo_segment *seg = &demo_segments[s];
        if (i < start + seg->rows || s + 1u == n) {
            if (!seg->ramp || i >= start + seg->rows) {
                *alpha_deg = seg->alpha_end_deg;
                *beta_deg = seg->beta_end_deg;
            } else {
                /* Linear in time, reaching the end values on the segment's last row. */
                const double f = (double)(i - start + 1u) / (double)seg->rows;
                *alpha_deg = a0 + (seg->alpha_end_deg - a0) * f;
                *beta_deg = b0 + (seg->beta_end_deg - b0) * f;
            }
            return;
        }
        a0 = seg->alpha_end_deg;
        b0 = seg->beta_end_deg;
        start += seg->rows;
    }
}

static int bad(char *err, size_t errlen, const char *name, const char *msg) {
    if (err != NULL && errlen > 0u) {
        snprintf(err, errlen, "scenario %s: %s", name, msg);
    }
    return -1;
}

static bool rate_ok(double p) {
    return p >= 0.0 && p <= 1.0;
}

static int check_config(const struct scene_config *c, char *err, size_t errlen) {
    if (!(c->arm_mm > 0.0) || !isfinite(c->arm_mm)) {
        return bad(err, errlen, c->name, "arm_mm must be positive");
    }
    if (!(c->mean_mm > 0.0) || !isfinite(c->mean_mm)) {
        return bad(err, errlen, c->name, "mean_mm must be positive");
    }
    if (c->samples_per_position == 0u) {
        return bad(err, errlen, c->name, "samples_per_position must be at least 1");
    }
    if (c->schedule != SCENE_SCHEDULE_DEMO && c->n_positions == 0u) {
        return bad(err, errlen, c->name, "n_positions must be at least 1");
    }
    if (c->schedule == SCENE_SCHEDULE_LIST && c->n_positions > SCENE_MAX_LIST) {
        return bad(err, errlen, c->name, "more list positions than SCENE_MAX_LIST");
    }
    if (c->schedule != SCENE_SCHEDULE_SWEEP && c->schedule != SCENE_SCHEDULE_LIST &&
        c->schedule != SCENE_SCHEDULE_DEMO) {
        return bad(err, errlen, c->name, "unknown schedule");
    }
    const uint64_t rows = scene_config_rows(c);
    if (rows > 0u && (rows - 1u) * (uint64_t)c->period_ms > UINT32_MAX) {
        return bad(err, errlen, c->name, "t_ms of the last row would overflow 32 bits");
    }
    if (!rate_ok(c->window_dropout_prob) || !(c->beta_random_deg >= 0.0) ||
        !(c->beta_random_deg < 45.0)) {
        return bad(err, errlen, c->name, "dropout probability or beta range out of bounds");
    }
    for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
        const struct scene_sensor_noise *n = &c->noise[k];
        if (!(n->sigma_mm >= 0.0) || !rate_ok(n->outlier_rate) || !rate_ok(n->flag_rate) ||
            !(n->outlier_min_mm <= n->outlier_max_mm) || !(n->outlier_min_mm >= 0.0) ||
            !(n->flag_error_mm >= 0.0)) {
            return bad(err, errlen, c->name, "noise parameter out of bounds");
        }
        if (c->real_noise ? false : !(n->sigma_mm > 0.0)) {
            return bad(err, errlen, c->name, "Gaussian sigma must be positive");
        }
    }
    if (c->thermal.on) {
        const char *why = scene_thermal_check(&c->thermal);
        if (why != NULL) {
            return bad(err, errlen, c->name, why);
        }
    }
    return 0;
}

static int start(struct scene_gen *gen, const struct scene_config *cfg, uint64_t seed, char *err,
                 size_t errlen) {
    gen->cfg = *cfg;
    gen->seed = seed;
    gen->total_rows = scene_config_rows(cfg);
    gen->row = 0;
    gen->missing_sensor = -1;
    gen->cur_beta_deg = cfg->beta_deg;
    scene_rng_seed(&gen->window_rng, seed, STREAM_WINDOW);
    for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
        scene_rng_seed(&gen->sensor_rng[k], seed, STREAM_SENSOR0 + k);
    }
    scene_rng_seed(&gen->dither_rng, seed, STREAM_DITHER);
    if (cfg->thermal.on) {
        scene_thermal_draw(&gen->thermal, &cfg->thermal, seed);
    }
    if (!cfg->real_noise) {
        return 0;
    }
    /* Each sensor takes a seeded contiguous stretch of its own quarter of the
     * recording; stretches of different sensors never overlap. */
    struct scene_rng offset_rng;
    scene_rng_seed(&offset_rng, seed, STREAM_OFFSET);
    const size_t q = gen->real->quarter_len;
    const size_t len = (size_t)gen->total_rows;
    for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
        size_t offset = 0;
        if (len < q) {
            offset = scene_rng_below(&offset_rng, (uint32_t)(q - len + 1u));
        }
        if (scene_real_stretch_init(gen->real, k, offset, len, &gen->stretch[k]) != 0) {
            return bad(err, errlen, cfg->name, "cannot take a stretch of the recording");
        }
        gen->offset_sd_mm[k] =
            scene_real_stretch_offset_sd(&gen->stretch[k], len, cfg->samples_per_position);
    }
    return 0;
}

int scene_gen_init_with(struct scene_gen *gen, const struct scene_config *cfg, uint64_t seed,
                        const struct scene_real_noise *real, char *err, size_t errlen) {
    memset(gen, 0, sizeof *gen);
    if (check_config(cfg, err, errlen) != 0) {
        return -1;
    }
    if (cfg->real_noise && (real == NULL || real->readings == NULL || real->quarter_len == 0u ||
                            real->quarter_len > UINT32_MAX)) {
        return bad(err, errlen, cfg->name, "real-noise scenario without a loaded recording");
    }
    gen->real = real;
    return start(gen, cfg, seed, err, errlen);
}

int scene_gen_init(struct scene_gen *gen, const struct scene_config *cfg, uint64_t seed, char *err,
                   size_t errlen) {
    memset(gen, 0, sizeof *gen);
    if (check_config(cfg, err, errlen) != 0) {
        return -1;
    }
    if (cfg->real_noise) {
        char path[1200];
        if (scene_real_noise_default_path(path, sizeof path) != 0) {
            return bad(err, errlen, cfg->name, "path of the shared recording too long");
        }
        if (scene_real_noise_load(path, &gen->real_owned, err, errlen) != 0) {
            return -1;
        }
        gen->real = &gen->real_owned;
    }
    const int rc = start(gen, cfg, seed, err, errlen);
    if (rc != 0) {
        scene_gen_free(gen);
    }
    return rc;
}

const char *scene_gen_error(const struct scene_gen *gen) {
    return gen->err;
}

void scene_gen_free(struct scene_gen *gen) {
    scene_real_noise_free(&gen->real_owned);
    gen->real = NULL;
}

static double position_alpha(const struct scene_config *c, uint32_t pos) {
    if (c->schedule == SCENE_SCHEDULE_LIST) {
        return c->alpha_list_deg[pos];
    }
    if (c->n_positions == 1u) {
        return c->alpha_from_deg;
    }
    return c->alpha_from_deg +
           (c->alpha_to_deg - c->alpha_from_deg) * (double)pos / (double)(c->n_positions - 1u);
}

int scene_gen_next(struct scene_gen *gen, struct scene_row *row, struct scene_row_info *info,
                   char *err, size_t errlen) {
    const struct scene_config *c = &gen->cfg;
    if (gen->row >= gen->total_rows) {
        return 1;
    }
    const uint64_t i = gen->row;
    const uint32_t pos = (uint32_t)(i / c->samples_per_position);
    if (i % c->samples_per_position == 0u) {
        /* New window: fixed draws (β, dropout decision, which sensor). */
        const double u_beta = scene_rng_uniform(&gen->window_rng);
        const double u_drop = scene_rng_uniform(&gen->window_rng);
        const uint32_t which = scene_rng_below(&gen->window_rng, SCENE_SENSORS);
        gen->cur_beta_deg =
            c->beta_random_deg > 0.0 ? c->beta_random_deg * (2.0 * u_beta - 1.0) : c->beta_deg;
        gen->missing_sensor = u_drop < c->window_dropout_prob ? (int)which : -1;
    }
    double alpha = 0.0;
    double beta = gen->cur_beta_deg;
    if (c->schedule == SCENE_SCHEDULE_DEMO) {
        scene_demo_attitude(i, &alpha, &beta);
    } else {
        alpha = position_alpha(c, pos);
    }
    double ideal[SCENE_SENSORS];
    scene_ideal_distances(c->arm_mm, c->mean_mm, alpha, beta, ideal);

    memset(row, 0, sizeof *row);
    row->t_ms = (uint32_t)(i * c->period_ms);
    row->has_alpha = true;
    row->has_beta = true;
    row->alpha_deg = alpha;
    row->beta_deg = beta;
    if (info != NULL) {
        memset(info, 0, sizeof *info);
        info->position = pos;
    }
    double thermal_offset[SCENE_SENSORS] = {0.0, 0.0, 0.0, 0.0};
    if (c->thermal.on) {
        const double t_s = (double)row->t_ms / 1000.0;
        const double dt_s = i == 0u ? 0.0 : (double)c->period_ms / 1000.0;
        double true_c = 0.0;
        scene_thermal_row(&gen->thermal, &c->thermal, t_s, dt_s, thermal_offset, &row->temp_c,
                          &true_c);
        row->has_temp = true;
        if (info != NULL) {
            memcpy(info->thermal_offset_mm, thermal_offset, sizeof thermal_offset);
            info->temp_true_c = true_c;
        }
    }
    for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
        double base = thermal_offset[k];
        double sigma = scene_quantised_sigma(c->noise[k].sigma_mm);
        if (c->real_noise) {
            /* Real readings are already whole millimetres; re-rounding ideal +
             * (reading − mean) would add a bias of up to ±0.5 mm that depends on
             * the ideal distance. A uniform dither u in [−½, ½) before rounding
             * makes the result unbiased (E round(x + u) = x) at the cost of
             * p(1 − p) mm² of variance, p = frac(ideal − mean). */
            const double u = scene_rng_uniform(&gen->dither_rng) - 0.5;
            base += scene_real_stretch_noise(&gen->stretch[k], (size_t)i) + u;
            const double cfrac = ideal[k] + thermal_offset[k] - gen->stretch[k].mean_mm;
            const double p = cfrac - floor(cfrac);
            sigma = sqrt(gen->stretch[k].sd_mm * gen->stretch[k].sd_mm +
                         c->noise[k].sigma_mm * c->noise[k].sigma_mm + p * (1.0 - p));
        }
        const struct scene_noise_draw d =
            scene_noise_sample(&c->noise[k], &gen->sensor_rng[k], ideal[k], base);
        if (info != NULL) {
            info->ideal_mm[k] = ideal[k];
            info->sigma_mm[k] = sigma;
            info->offset_sd_mm[k] = gen->offset_sd_mm[k];
        }
        if ((int)k == gen->missing_sensor) {
            row->present[k] = false;
            row->range_mm[k] = 0;
            row->status[k] = SCENE_STATUS_NO_READING;
            continue;
        }
        uint16_t mm = 0;
        if (scene_quantise_mm(d.value_mm, &mm) != 0) {
            snprintf(gen->err, sizeof gen->err,
                     "scenario %s: row %llu sensor %c: reading %.1f mm outside 0..65535", c->name,
                     (unsigned long long)i, (char)('A' + k), d.value_mm);
            if (err != NULL && errlen > 0u) {
                snprintf(err, errlen, "%s", gen->err);
            }
            return -1;
        }
        row->present[k] = true;
        row->range_mm[k] = mm;
        row->status[k] = d.status;
        if (info != NULL) {
            info->outlier[k] = d.outlier;
        }
    }
    gen->row++;
    return 0;
}
